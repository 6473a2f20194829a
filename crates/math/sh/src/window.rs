//! Ringing windows chosen for a set of lobes: Hann and Lanczos σ-factors, and
//! Sloan's deringing (the least change that keeps the lobes non-negative).
//!
//! # The problem
//! Truncating a function with a sharp feature (a glossy lobe cut by the
//! horizon) to `n` bands rings (Gibbs): the reconstruction
//! `f̃(ω) = Σ_{l<n} Σ_m f_lm y_lm(ω)` dips below zero beside the lobe. In SH
//! shading the pixel is `⟨L, B⟩ = ∫ L(ω) B̃(ω) dω` (the band-limited transfer
//! `B̃` against the true lighting `L ≥ 0`, by orthonormality), so a negative
//! lobe `B̃` under a bright light gives negative radiance.
//!
//! # Windows
//! A window scales band `l` by `h_l` (`h_0 = 1`): a zonal convolution
//! (Funk–Hecke), so it commutes with every rotation and can be applied to the
//! transfer, the lighting or the product alike. With `N` = the number of
//! bands (order):
//! * **Hann** (Hanning): `h_l = ½ (1 + cos(π l / N))` (Sloan, *Stupid
//!   spherical harmonics tricks*, GDC 2008, §"Windowing");
//! * **Lanczos σ-factors**: `h_l = sinc(l / N) = sin(π l/N) / (π l/N)`
//!   (Lanczos, *Applied Analysis*, 1956, ch. IV §6; the Fourier-series
//!   σ-factors carried over to Legendre series);
//! * **Sloan's deringing** (P.-P. Sloan, *Deringing spherical harmonics*,
//!   SIGGRAPH Asia 2017 Technical Briefs): among windows that leave the
//!   reconstruction non-negative, the one that changes the function least.
//!   Here the candidates are three one-parameter families, each ordered from
//!   "no change" to "only band 0" (which is non-negative for a non-negative
//!   function, since `f_00 = ∫ f y_00 ≥ 0`): Hann and Lanczos of width
//!   `w ∈ [1, ∞)` (`l/N → l/w` above) and Sloan's Gaussian-like
//!   `h_l = 1 / (1 + λ (l(l+1))²)`, `λ ≥ 0` (GDC 2008). Each family's least
//!   smoothing member that is non-negative on a dense direction grid is found
//!   by bisection ([`dering`]); the one with the smallest L2 change
//!   `‖f − Hf‖ / ‖f‖ = √(Σ_l (1−h_l)² E_l / Σ_l E_l)` (Parseval, `E_l` the
//!   energy of band `l`) wins. Sloan solves a small quadratic program over all
//!   `h_l` instead; the families cover the windows his paper compares, and
//!   every result is checked on the grid, so the guarantee is the same.
//!
//! # Grid
//! [`LobeSet`] evaluates each band's part `g_l(ω) = Σ_m f_lm y_lm(ω)` once on
//! a Gauss–Legendre × uniform-φ grid ([`crate::quadrature::SphereQuadrature`],
//! `max(48, 8N)` rows × twice as many azimuths), so every candidate window
//! costs one `Σ_l h_l g_l` per node. The grid resolves the reconstruction's
//! oscillations (wavelength ≈ 2π/N) with ≥ 8 nodes each; a test checks the
//! chosen windows on a 4× finer grid.

use crate::project::Window;
use crate::quadrature::SphereQuadrature;
use crate::{ShError, check_order};
use rayon::prelude::*;

/// The window a caller asks for (`--window`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WindowChoice {
    /// No window (`h_l = 1`): rings.
    None,
    /// Hann σ-factors of width N.
    Hann,
    /// Lanczos σ-factors of width N.
    Lanczos,
    /// Sloan's deringing: the least change that keeps the lobes non-negative.
    Dering,
    /// No window where the lobes are already non-negative, else [`WindowChoice::Dering`].
    #[default]
    Auto,
}

impl WindowChoice {
    /// Every choice, in `verify` order.
    pub const ALL: [WindowChoice; 5] = [
        Self::None,
        Self::Hann,
        Self::Lanczos,
        Self::Dering,
        Self::Auto,
    ];

    /// The CLI name (`none`, `hann`, `lanczos`, `dering`, `auto`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Hann => "hann",
            Self::Lanczos => "lanczos",
            Self::Dering => "dering",
            Self::Auto => "auto",
        }
    }
}

impl std::fmt::Display for WindowChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for WindowChoice {
    type Err = ShError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|w| w.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| ShError::InvalidParameter {
                what: "--window",
                why: format!("unknown window `{s}`; use one of none, hann, lanczos, dering, auto"),
            })
    }
}

/// Hann σ-factors for `order` bands: [`Window::Hanning`] of width `order`.
#[must_use]
pub fn hann(order: usize) -> Window {
    Window::Hanning {
        width: order as f64,
    }
}

/// Lanczos σ-factors for `order` bands: [`Window::Lanczos`] of width `order`.
#[must_use]
pub fn lanczos(order: usize) -> Window {
    Window::Lanczos {
        width: order as f64,
    }
}

/// The factors `h_0 … h_{order−1}` of `w`.
#[must_use]
pub fn factors(w: &Window, order: usize) -> Vec<f64> {
    (0..order).map(|l| w.factor(l)).collect()
}

/// Band parts of a set of functions (coefficient vectors of `order²`) on a
/// dense direction grid (module docs).
#[derive(Clone, Debug)]
pub struct LobeSet {
    order: usize,
    /// `g[(lobe · dirs + d) · order + l]`.
    g: Vec<f32>,
    dirs: usize,
    lobes: usize,
    /// Energy of each band summed over the lobes, `Σ_m f_lm²`.
    energy: Vec<f64>,
    /// Largest |value| of each lobe's unwindowed reconstruction on the grid.
    peak: Vec<f64>,
}

/// What [`LobeSet::choose`] picked.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChosenWindow {
    /// What was asked for.
    pub choice: WindowChoice,
    /// What was applied: `none`, `hanning(width=N)`, `lanczos(width=N)` or `dering`.
    pub applied: String,
    /// `h_0 … h_{order−1}`.
    pub factors: Vec<f64>,
    /// Relative L2 change of the lobes, `‖f − Hf‖ / ‖f‖` (0 = untouched).
    pub change: f64,
    /// Most negative windowed value on the grid relative to the lobe's peak
    /// (≥ 0: non-negative everywhere on the grid).
    pub min_ratio: f64,
    /// The unwindowed lobes' most negative value relative to their peak.
    pub raw_min_ratio: f64,
}

impl LobeSet {
    /// Evaluates the band parts of `lobes` (each `order²` coefficients) on the
    /// default grid for `order`.
    ///
    /// # Errors
    /// Order out of range, a lobe of another length, or non-finite coefficients.
    pub fn new(order: usize, lobes: &[&[f32]]) -> Result<Self, ShError> {
        let rows = (8 * order).max(48);
        Self::with_grid(order, lobes, &SphereQuadrature::new(rows, 2 * rows))
    }

    /// As [`LobeSet::new`] on the nodes of `q`.
    ///
    /// # Errors
    /// As [`LobeSet::new`].
    pub fn with_grid(
        order: usize,
        lobes: &[&[f32]],
        q: &SphereQuadrature,
    ) -> Result<Self, ShError> {
        check_order("order", order, crate::MAX_ORDER)?;
        for l in lobes {
            crate::check_coeffs("lobe", order, l)?;
        }
        let nn = order * order;
        let dirs = q.len();
        let mut g = vec![0.0f32; lobes.len() * dirs * order];
        let mut y = vec![0.0f64; nn];
        let mut energy = vec![0.0f64; order];
        for lobe in lobes {
            for l in 0..order {
                energy[l] += lobe[l * l..(l + 1) * (l + 1)]
                    .iter()
                    .map(|&c| f64::from(c).powi(2))
                    .sum::<f64>();
            }
        }
        for (d, dir) in q.dirs.iter().enumerate() {
            crate::eval_sh_into(order, dir.to_array(), &mut y);
            for (k, lobe) in lobes.iter().enumerate() {
                let out = &mut g[(k * dirs + d) * order..(k * dirs + d + 1) * order];
                for (l, o) in out.iter_mut().enumerate() {
                    let s: f64 = (l * l..(l + 1) * (l + 1))
                        .map(|i| f64::from(lobe[i]) * y[i])
                        .sum();
                    *o = s as f32;
                }
            }
        }
        let mut set = Self {
            order,
            g,
            dirs,
            lobes: lobes.len(),
            energy,
            peak: vec![0.0; lobes.len()],
        };
        let ones = vec![1.0; order];
        for k in 0..set.lobes {
            set.peak[k] = (0..dirs)
                .map(|d| set.value(k, d, &ones).abs())
                .fold(0.0, f64::max);
        }
        Ok(set)
    }

    /// Whether every windowed lobe is ≥ 0 at every grid node (stops at the
    /// first negative one).
    #[must_use]
    pub fn nonneg(&self, h: &[f64]) -> bool {
        (0..self.lobes)
            .into_par_iter()
            .all(|k| self.peak[k] == 0.0 || (0..self.dirs).all(|d| self.value(k, d, h) >= 0.0))
    }

    #[inline]
    fn value(&self, lobe: usize, d: usize, h: &[f64]) -> f64 {
        let o = (lobe * self.dirs + d) * self.order;
        self.g[o..o + self.order]
            .iter()
            .zip(h)
            .map(|(&g, &h)| f64::from(g) * h)
            .sum()
    }

    /// Most negative windowed value relative to each lobe's peak (min over
    /// lobes and grid nodes; ≥ 0 when every windowed lobe is non-negative on
    /// the grid, 0 for an empty set or all-zero lobes).
    #[must_use]
    pub fn min_ratio(&self, h: &[f64]) -> f64 {
        let mut worst = 0.0f64;
        for k in 0..self.lobes {
            if self.peak[k] == 0.0 {
                continue;
            }
            let mut m = f64::INFINITY;
            for d in 0..self.dirs {
                m = m.min(self.value(k, d, h));
            }
            worst = worst.min(m / self.peak[k]);
        }
        worst
    }

    /// Relative L2 change `√(Σ_l (1−h_l)² E_l / Σ_l E_l)` (Parseval).
    #[must_use]
    pub fn change(&self, h: &[f64]) -> f64 {
        let total: f64 = self.energy.iter().sum();
        if total == 0.0 {
            return 0.0;
        }
        let d: f64 = self
            .energy
            .iter()
            .zip(h)
            .map(|(e, h)| (1.0 - h).powi(2) * e)
            .sum();
        (d / total).sqrt()
    }

    /// Energy of band `l` over all lobes divided by the total (the lobes'
    /// bandwidth: a slowly decaying tail means `order` bands cannot hold them).
    #[must_use]
    pub fn band_fraction(&self, l: usize) -> f64 {
        let total: f64 = self.energy.iter().sum();
        if total == 0.0 {
            0.0
        } else {
            self.energy.get(l).copied().unwrap_or(0.0) / total
        }
    }

    fn chosen(&self, choice: WindowChoice, applied: String, h: Vec<f64>) -> ChosenWindow {
        ChosenWindow {
            choice,
            applied,
            change: self.change(&h),
            min_ratio: self.min_ratio(&h),
            raw_min_ratio: self.min_ratio(&vec![1.0; self.order]),
            factors: h,
        }
    }

    /// The window for `choice` (module docs): `Auto` keeps the lobes
    /// untouched where they are already non-negative on the grid.
    #[must_use]
    pub fn choose(&self, choice: WindowChoice) -> ChosenWindow {
        let n = self.order;
        let formula = |w: Window| self.chosen(choice, w.describe(), factors(&w, n));
        match choice {
            WindowChoice::None => formula(Window::None),
            WindowChoice::Hann => formula(hann(n)),
            WindowChoice::Lanczos => formula(lanczos(n)),
            WindowChoice::Dering | WindowChoice::Auto => {
                if self.nonneg(&vec![1.0; n]) {
                    formula(Window::None)
                } else {
                    self.chosen(choice, "dering".to_string(), dering(self))
                }
            }
        }
    }
}

/// Dual coordinate-ascent sweeps per cutting-plane round, and rounds.
const SWEEPS: usize = 60;
const ROUNDS: usize = 16;
/// Constraints added per round (the most violated nodes).
const CUTS: usize = 64;

/// Sloan's deringing of `set` (module docs): the window `h` (with `h_0 = 1`,
/// so the lobe's integral — the albedo — is kept) minimising the change
/// `Σ_l E_l (1 − h_l)²` subject to a non-negative reconstruction at every
/// grid node and `0 ≤ h_l ≤ 1`. A convex quadratic program in `order`
/// unknowns: cutting planes (the most negative nodes join the active
/// constraints each round) solved by Hildreth's dual coordinate ascent
/// (Hildreth 1957; Censor & Zenios, *Parallel Optimization*, 1997, §8.2),
/// which is exact for a diagonal objective. The result is then scaled
/// towards band 0 (`h_l ← t h_l`, `l ≥ 1`, largest `t ≤ 1` by bisection) until
/// it is non-negative on the whole grid, so the guarantee does not rest on
/// the iteration's convergence. All ones when the lobes are already
/// non-negative.
#[must_use]
pub fn dering(set: &LobeSet) -> Vec<f64> {
    let n = set.order;
    let ones = vec![1.0; n];
    if set.nonneg(&ones) {
        return ones;
    }
    let total: f64 = set.energy.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    // Objective weights (band 0 pinned by a huge weight); a floor keeps
    // bands without energy from moving freely.
    let w: Vec<f64> = (0..n)
        .map(|l| {
            if l == 0 {
                1e12 * total
            } else {
                set.energy[l] + 1e-6 * total
            }
        })
        .collect();
    // Constraints a·h ≥ b: grid nodes (b = 0) and the bounds h_l ≤ 1, h_l ≥ 0.
    let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
    for l in 1..n {
        let mut up = vec![0.0; n];
        up[l] = -1.0;
        rows.push((up, -1.0));
        let mut lo = vec![0.0; n];
        lo[l] = 1.0;
        rows.push((lo, 0.0));
    }
    let mut lambda = vec![0.0f64; rows.len()];
    let mut h = ones.clone();
    for _ in 0..ROUNDS {
        // The most negative node of each lobe (in parallel), then the CUTS worst lobes.
        let mut worst: Vec<(f64, usize, usize)> = (0..set.lobes)
            .into_par_iter()
            .filter(|&k| set.peak[k] > 0.0)
            .filter_map(|k| {
                let (v, d) = (0..set.dirs)
                    .map(|d| (set.value(k, d, &h) / set.peak[k], d))
                    .min_by(|a, b| a.0.total_cmp(&b.0))?;
                (v < -1e-9).then_some((v, k, d))
            })
            .collect();
        if worst.is_empty() {
            break;
        }
        worst.sort_by(|a, b| a.0.total_cmp(&b.0));
        for &(_, k, d) in worst.iter().take(CUTS) {
            let o = (k * set.dirs + d) * n;
            let a: Vec<f64> = set.g[o..o + n]
                .iter()
                .map(|&g| f64::from(g) / set.peak[k])
                .collect();
            rows.push((a, 0.0));
            lambda.push(0.0);
        }
        // Hildreth: h = 1 + W⁻¹ Σ λ_i a_i, λ_i ← max(0, λ_i + (b_i − a_i·h)/(a_iᵀW⁻¹a_i)).
        for _ in 0..SWEEPS {
            for (i, (a, b)) in rows.iter().enumerate() {
                let ah: f64 = a.iter().zip(&h).map(|(x, y)| x * y).sum();
                let q: f64 = a.iter().zip(&w).map(|(x, w)| x * x / w).sum();
                if q == 0.0 {
                    continue;
                }
                let new = (lambda[i] + (b - ah) / q).max(0.0);
                let step = new - lambda[i];
                if step != 0.0 {
                    lambda[i] = new;
                    for ((hl, x), wl) in h.iter_mut().zip(a).zip(&w) {
                        *hl += step * x / wl;
                    }
                }
            }
        }
    }
    h[0] = 1.0;
    for v in &mut h[1..] {
        *v = v.clamp(0.0, 1.0);
    }
    // Make it exactly feasible on the grid: shrink towards band 0.
    let scaled = |t: f64| -> Vec<f64> {
        h.iter()
            .enumerate()
            .map(|(l, &v)| if l == 0 { 1.0 } else { t * v })
            .collect()
    };
    let t = if set.nonneg(&scaled(1.0)) {
        1.0
    } else {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if set.nonneg(&scaled(mid)) {
                lo = mid
            } else {
                hi = mid
            }
        }
        lo
    };
    scaled(t)
}
