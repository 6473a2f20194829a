//! Fitting the LTC table to the project's GGX (Heitz et al. 2016, §5 and
//! their published fitting procedure, re-implemented here).
//!
//! The fitted lobe is `ρ(ω_i) = f(ω_o, ω_i) cos θ_i` of
//! [`relight_brdf::Ggx`] (isotropic roughness `α`, height-correlated Smith
//! G₂) with Fresnel 1 (`F₀ = 1`), for the view `ω_o = (sin θ_o, 0, cos θ_o)`.
//! Per cell of a grid over `(r = √α, θ_o)`:
//!
//! * **magnitude** `n = ∫ ρ dω` and **Fresnel moment** `f = ∫ ρ (1 − ω_o·ĥ)⁵ dω`,
//!   so that with Schlick's `F = F₀ + (1 − F₀)(1 − ω_o·ĥ)⁵` the lobe's
//!   integral is `F₀ n + (1 − F₀) f` (the separate norm/Fresnel table);
//! * the **average direction** `ω̄ ∝ ∫ ρ ω dω` (its y-part is 0 by symmetry)
//!   and the frame `Z = ω̄, Y = ŷ, X = Y × Z`;
//! * the matrix `M = [X Y Z] · [[m₁₁, 0, m₁₃], [0, m₂₂, 0], [0, 0, 1]]`,
//!   minimising (Nelder–Mead, [`crate::nelder_mead`]) the error
//!   `Σ |ρ − n D|³ / (p_ρ + p_D)` over `s²` stratified samples drawn from each of
//!   `ρ` (visible normals) and `D` (both densities in the denominator, as in
//!   Heitz's fitting code), started from the previous `θ_o` cell's solution;
//!   at `θ_o = 0` the lobe is isotropic and only `m₁₁ = m₂₂` is fitted,
//!   from `m₁₁ = α`.
//!
//! The stored form is `M⁻¹` scaled so that its (1, 1) entry is 1 (D does not
//! change), with non-zero entries `a = M⁻¹₀₀, b = M⁻¹₀₂, d = M⁻¹₂₀,
//! e = M⁻¹₂₂` (rows, columns from 0); [`crate::table`] interpolates them
//! bilinearly. Everything in f64 except the BRDF, which is the project's f32
//! model.

use crate::distribution::Ltc;
use crate::nelder_mead::minimize;
use glam::{DMat3, DVec2, DVec3, Vec2, Vec3};
use relight_brdf::{Brdf, Ggx};
use std::f64::consts::FRAC_PI_2;

/// Smallest GGX roughness α the table is fitted at (the `r = 0` row); a
/// smoother surface is shaded with this lobe.
pub const ALPHA_MIN: f64 = 1e-3;

/// Largest view angle fitted (radians): the last column (`θ_o = π/2`, where
/// the lobe vanishes) is fitted here.
pub const THETA_MAX: f64 = 1.56;

/// Settings of the fit; `Default` holds the ones the committed table was
/// fitted with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// Cells per side of the `(√α, θ_o)` grid.
    pub size: usize,
    /// Stratified samples per side per distribution in the error.
    pub samples: usize,
    /// Stratified samples per side for the magnitude, Fresnel moment and
    /// average direction.
    pub moment_samples: usize,
    /// Nelder–Mead iterations per cell at most.
    pub iterations: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            size: 32,
            samples: 32,
            moment_samples: 128,
            iterations: 300,
        }
    }
}

/// The roughness α of row `i` of a `size`-row table: `r = i/(size−1)`,
/// `α = max(r², ALPHA_MIN)`.
#[must_use]
pub fn row_alpha(i: usize, size: usize) -> f64 {
    let r = i as f64 / (size - 1) as f64;
    (r * r).max(ALPHA_MIN)
}

/// The view angle θ_o of column `j`: `j/(size−1) · π/2`, at most [`THETA_MAX`].
#[must_use]
pub fn column_theta(j: usize, size: usize) -> f64 {
    (j as f64 / (size - 1) as f64 * FRAC_PI_2).min(THETA_MAX)
}

/// One fitted cell: `[a, b, d, e, n, f]` (module docs).
pub type Cell = [f32; 6];

/// The GGX·cos lobe of one cell (Fresnel 1).
#[derive(Clone, Copy, Debug)]
pub struct Lobe {
    ggx: Ggx,
    wo: Vec3,
}

impl Lobe {
    /// The lobe for roughness `alpha` (clamped to the BRDF's range) seen
    /// from `theta_o` radians.
    #[must_use]
    pub fn new(alpha: f64, theta_o: f64) -> Self {
        let a = (alpha as f32).clamp(relight_brdf::microfacet::MIN_ALPHA, 1.0);
        Self {
            ggx: Ggx::isotropic(a, Vec3::ONE).expect("α clamped to the valid range"),
            wo: Vec3::new(theta_o.sin() as f32, 0.0, theta_o.cos() as f32),
        }
    }

    /// The view direction.
    #[must_use]
    pub fn wo(&self) -> DVec3 {
        self.wo.as_dvec3()
    }

    /// `(ρ(ω_i), p(ω_i))`: `f cos θ_i` and the visible-normal sampling density.
    #[inline]
    #[must_use]
    pub fn eval(&self, wi: DVec3) -> (f64, f64) {
        let w = wi.as_vec3();
        if w.z <= 0.0 {
            return (0.0, 0.0);
        }
        let f = f64::from(self.ggx.eval(self.wo, w).x) * wi.z;
        (f, f64::from(self.ggx.pdf(self.wo, w)))
    }

    /// A direction from the visible-normal sampler, if above the horizon.
    #[inline]
    #[must_use]
    pub fn sample(&self, u: DVec2) -> Option<DVec3> {
        self.ggx
            .sample(self.wo, Vec2::new(u.x as f32, u.y as f32))
            .map(|s| s.wi.as_dvec3().normalize())
    }
}

/// The lobe's moments: `(n, f, ω̄)` (module docs) by `s²` stratified
/// visible-normal samples.
#[must_use]
pub fn moments(lobe: &Lobe, s: usize) -> (f64, f64, DVec3) {
    let (mut n, mut f, mut avg) = (0.0, 0.0, DVec3::ZERO);
    let wo = lobe.wo();
    for j in 0..s {
        for i in 0..s {
            let u = DVec2::new((i as f64 + 0.5) / s as f64, (j as f64 + 0.5) / s as f64);
            let Some(wi) = lobe.sample(u) else { continue };
            let (rho, p) = lobe.eval(wi);
            if p <= 0.0 {
                continue;
            }
            let w = rho / p;
            let h = (wo + wi).normalize();
            n += w;
            f += w * (1.0 - wo.dot(h)).clamp(0.0, 1.0).powi(5);
            avg += w * wi;
        }
    }
    let k = (s * s) as f64;
    avg.y = 0.0;
    let avg = if avg.length_squared() > 0.0 {
        avg.normalize()
    } else {
        DVec3::Z
    };
    (n / k, f / k, avg)
}

/// `M` for parameters `p = (m₁₁, m₂₂, m₁₃)` about the average direction
/// `avg` (module docs); `isotropic`: `m₂₂ = m₁₁`, `m₁₃ = 0`.
#[must_use]
pub fn matrix(p: &[f64; 3], avg: DVec3, isotropic: bool) -> DMat3 {
    let m11 = p[0].abs().max(1e-7);
    let (m22, m13) = if isotropic {
        (m11, 0.0)
    } else {
        (p[1].abs().max(1e-7), p[2])
    };
    let z = avg;
    let y = DVec3::Y;
    let x = y.cross(z);
    let frame = DMat3::from_cols(x, y, z);
    let s = DMat3::from_cols(
        DVec3::new(m11, 0.0, 0.0),
        DVec3::new(0.0, m22, 0.0),
        DVec3::new(m13, 0.0, 1.0),
    );
    frame * s
}

/// The fitting error of `ltc` scaled by `n` against `lobe` (module docs),
/// `s²` samples from each.
#[must_use]
pub fn fit_error(ltc: &Ltc, n: f64, lobe: &Lobe, s: usize) -> f64 {
    let mut sum = 0.0;
    let term = |wi: DVec3| -> f64 {
        let (rho, p_rho) = lobe.eval(wi);
        let d = ltc.eval(wi);
        let den = p_rho + d;
        if den <= 0.0 {
            return 0.0;
        }
        (rho - n * d).abs().powi(3) / den
    };
    for j in 0..s {
        for i in 0..s {
            let u = DVec2::new((i as f64 + 0.5) / s as f64, (j as f64 + 0.5) / s as f64);
            sum += term(ltc.sample(u));
            if let Some(wi) = lobe.sample(u) {
                sum += term(wi);
            }
        }
    }
    sum / (s * s) as f64
}

/// The relative L1 distance `∫_{z>0} |ρ − n D| dω / n` over the upper
/// hemisphere (the part a horizon-clipped polygon sees) by the same
/// two-sided sampling (`s²` from each, balance-heuristic weights): how well
/// a cell fits, for `verify ltc`. It bounds the error of any polygon's
/// integral: `|∫_P (ρ − n D)| ≤ n · L1`.
#[must_use]
pub fn l1_error(ltc: &Ltc, n: f64, lobe: &Lobe, s: usize) -> f64 {
    let mut sum = 0.0;
    let term = |wi: DVec3| -> f64 {
        let (rho, p_rho) = lobe.eval(wi);
        let d = ltc.eval(wi);
        let den = p_rho + d;
        if den <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (rho - n * d).abs() / den
    };
    for j in 0..s {
        for i in 0..s {
            let u = DVec2::new((i as f64 + 0.5) / s as f64, (j as f64 + 0.5) / s as f64);
            sum += term(ltc.sample(u));
            if let Some(wi) = lobe.sample(u) {
                sum += term(wi);
            }
        }
    }
    sum / (s * s) as f64 / n.max(1e-30)
}

/// Packs `M` and the moments into a stored [`Cell`].
#[must_use]
pub fn pack(m: DMat3, n: f64, f: f64) -> Cell {
    let inv = m.inverse();
    // glam is column-major: row r, column c is `inv.col(c)[r]`.
    let at = |r: usize, c: usize| inv.col(c)[r];
    let k = 1.0 / at(1, 1);
    [
        (at(0, 0) * k) as f32,
        (at(0, 2) * k) as f32,
        (at(2, 0) * k) as f32,
        (at(2, 2) * k) as f32,
        n as f32,
        f as f32,
    ]
}

/// The distribution of a stored cell's `[a, b, d, e]`.
#[must_use]
pub fn unpack(c: &[f32; 4]) -> Ltc {
    let (a, b, d, e) = (
        f64::from(c[0]),
        f64::from(c[1]),
        f64::from(c[2]),
        f64::from(c[3]),
    );
    Ltc::from_inverse(DMat3::from_cols(
        DVec3::new(a, 0.0, d),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(b, 0.0, e),
    ))
}

/// Fits row `i` (one roughness) of the table: every `θ_o` column in order,
/// each started from the previous one's solution. Returns the cells.
#[must_use]
pub fn fit_row(i: usize, opts: &FitOptions) -> Vec<Cell> {
    let size = opts.size;
    let alpha = row_alpha(i, size);
    let mut p = [alpha, alpha, 0.0];
    let mut out = Vec::with_capacity(size);
    for j in 0..size {
        let theta = column_theta(j, size);
        let lobe = Lobe::new(alpha, theta);
        let (n, f, avg) = moments(&lobe, opts.moment_samples);
        let isotropic = j == 0;
        let err = |q: &[f64; 3]| {
            let ltc = Ltc::from_m(matrix(q, avg, isotropic));
            fit_error(&ltc, n, &lobe, opts.samples)
        };
        let (best, _) = minimize(err, p, 0.05, 1e-6, opts.iterations);
        p = best;
        if isotropic {
            p[1] = p[0].abs();
            p[2] = 0.0;
        }
        out.push(pack(matrix(&p, avg, isotropic), n, f));
    }
    out
}

/// Fits the whole table (rows in parallel), row-major: cell `(i, j)` at
/// `i·size + j`.
#[must_use]
pub fn fit_table(opts: &FitOptions) -> Vec<Cell> {
    use rayon::prelude::*;
    (0..opts.size)
        .into_par_iter()
        .map(|i| fit_row(i, opts))
        .collect::<Vec<_>>()
        .concat()
}

/// The Rust source of `crate::table_data` for `cells` fitted with `opts`.
#[must_use]
pub fn table_source(cells: &[Cell], opts: &FitOptions) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    s.push_str("// @generated by relight_ltc::fit::table_source — do not edit by hand.\n");
    s.push_str(
        "// Regenerate: RELIGHT_LTC_REGENERATE=1 cargo test --release -p relight-ltc --test it table::\n",
    );
    let _ = writeln!(
        s,
        "//! The fitted LTC table ({0}×{0} cells over (√α, θ_o), {1}² samples per distribution, {2}² for the moments, ≤ {3} Nelder–Mead iterations per cell): `[a, b, d, e, n, f]` per cell (`crate::fit`).\n",
        opts.size, opts.samples, opts.moment_samples, opts.iterations
    );
    let _ = writeln!(
        s,
        "/// Cells per side.\npub const SIZE: usize = {};\n",
        opts.size
    );
    let _ = writeln!(
        s,
        "/// Row-major cells (row = roughness, column = view angle).\n#[rustfmt::skip]\npub static CELLS: [[f32; 6]; {}] = [",
        cells.len()
    );
    for c in cells {
        let _ = writeln!(
            s,
            "    [{:e}, {:e}, {:e}, {:e}, {:e}, {:e}],",
            c[0], c[1], c[2], c[3], c[4], c[5]
        );
    }
    s.push_str("];\n");
    s
}
