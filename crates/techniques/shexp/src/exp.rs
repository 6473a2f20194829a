//! SH exponentials for log-space shadowing (thesis §5.2.2): PS*-p, HYB and OL
//! with per-magnitude fitted coefficients, and the squaring histogram.
//!
//! # PS*-p (eqs. 5.24–5.27)
//! 1. **DC isolation.** (5.24) as printed subtracts `(f·1)·1`, which is wrong
//!    for `1 = (√(4π), 0, …)`; the projection onto the constant is
//!    `f̂ = f − (f·1)/(4π)·1`, i.e. `f̂ = (0, f₁, f₂, …)`, and
//!    `exp_*(f) = exp(f₀/√(4π)) exp_*(f̂)` (5.25).
//! 2. **Scaling and squaring** (5.26): `exp_*(f̂) ≈ (exp_*(f̂/2^s))^{2^s *}` with
//!    the thesis' rule `s = max(0, ⌈log₂‖f̂‖ + 3⌉)`. The thesis says at most 3
//!    squarings occur for `n ≤ 6`, but ‖f̂‖ of one 60° cap is already ≈ 5.4
//!    (s = 6) and sums of many blockers grow further, so `s` is capped at
//!    [`MAX_SQUARINGS`] and [`SquaringHistogram`] reports what was used.
//! 3. **Factored series** (5.27): even and odd powers apart,
//!    `(h₀1 + h₂f̂² + h₄f̂⁴ + …) + f̂ ∗ (h₁1 + h₃f̂² + …)`, `(p+1)/2` products.
//!    The odd part of PS*-2 is `h₁1`, whose product with f̂ is f̂ itself, so
//!    PS*-2 costs one square plus the squarings.
//!
//! # OL and HYB
//! OL approximates `exp_*(f̂) ≈ a(‖f̂‖)·1 + b(‖f̂‖)·f̂` (then the DC factor). The
//! Gaussian-moment coefficients (`a = b = e^{σ²/2}`, `σ² = ‖f̂‖²/(4π)`, the
//! ones in `relight_sh`) err by 7 % / 28 % / 190 % for single caps of
//! 30° / 40° / 50°. Here `a` and `b` are fitted per magnitude: for single caps
//! of half-angle 0…90° the value `exp(log g)` should take — the cap's own
//! visibility `E = g(θ) e^{−f₀/√(4π)}` without the DC factor — is projected
//! onto `1` and `f̂`: `a = E₀/√(4π)`, `b = E·f̂/‖f̂‖²` (the least-squares fit,
//! since `1 ⊥ f̂`). (The quadrature exponential [`exp_zonal_exact`] is not the
//! target: the eigen-analysis log inverts the product series, 5.31–5.33, not
//! the pointwise exp.) They are tabulated by `‖f̂‖` and read by
//! linear interpolation (clamped past the largest cap's magnitude).
//! HYB applies OL to `f̂/2^s` and squares `s` times (same rule and cap).

use crate::ShExpError;
use crate::log_table::LogTable;
use relight_sh::Real;
use relight_sh::product::TripleProduct;
use relight_sh::quadrature::gauss_legendre;
use serde::Serialize;
use std::f64::consts::PI;

/// Most squarings any exponential applies (the cap on rule 5.26).
pub const MAX_SQUARINGS: u32 = 8;

/// Which exponential (or the product-space baseline) accumulates visibility.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ExpKind {
    /// PS*-p: DC isolation, scaling/squaring, factored series of degree p.
    PsStar(u32),
    /// HYB: fitted OL with scaling/squaring.
    Hyb,
    /// OL: fitted optimal linear, no squaring.
    Ol,
    /// No log space: the product of every blocker's visibility (eq. 5.11).
    Product,
}

impl ExpKind {
    /// The name on the command line: `ps*2`, `ps*4`, `hyb`, `ol`, `product`.
    #[must_use]
    pub fn name(self) -> String {
        match self {
            Self::PsStar(p) => format!("ps*{p}"),
            Self::Hyb => "hyb".into(),
            Self::Ol => "ol".into(),
            Self::Product => "product".into(),
        }
    }
}

impl std::str::FromStr for ExpKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let t = s.to_ascii_lowercase();
        match t.as_str() {
            "hyb" => Ok(Self::Hyb),
            "ol" => Ok(Self::Ol),
            "product" => Ok(Self::Product),
            _ => t
                .strip_prefix("ps*")
                .and_then(|p| p.parse::<u32>().ok())
                .filter(|p| (1..=16).contains(p))
                .map(Self::PsStar)
                .ok_or_else(|| {
                    format!("unknown exponential `{s}` (known: ps*1…ps*16, hyb, ol, product)")
                }),
        }
    }
}

/// How many exponentials used each number of squarings (index = squarings,
/// 0…[`MAX_SQUARINGS`]); `capped` counts those the rule wanted more for.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SquaringHistogram {
    pub counts: Vec<u64>,
    pub capped: u64,
}

impl SquaringHistogram {
    /// All zero.
    #[must_use]
    pub fn new() -> Self {
        Self {
            counts: vec![0; MAX_SQUARINGS as usize + 1],
            capped: 0,
        }
    }

    /// Adds `other`.
    pub fn merge(&mut self, other: &Self) {
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        self.capped += other.capped;
    }

    /// One line: `s:count …`.
    #[must_use]
    pub fn describe(&self) -> String {
        let mut s: Vec<String> = self
            .counts
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0)
            .map(|(i, c)| format!("{i}:{c}"))
            .collect();
        if self.capped > 0 {
            s.push(format!("capped:{}", self.capped));
        }
        s.join(" ")
    }
}

/// The rule (5.26): `max(0, ⌈log₂‖f̂‖ + 3⌉)`, uncapped.
#[must_use]
pub fn squarings_rule(norm: f64) -> u32 {
    if norm > 0.0 {
        (norm.log2() + 3.0).ceil().max(0.0) as u32
    } else {
        0
    }
}

/// Fitted OL coefficients `a(m)`, `b(m)` by magnitude `m = ‖f̂‖` (module docs).
#[derive(Clone, Debug, Serialize)]
pub struct OlFit {
    /// Increasing magnitudes, from 0.
    pub norm: Vec<f64>,
    pub a: Vec<f64>,
    pub b: Vec<f64>,
}

/// Exact `∫ exp(f(s)) y_{l,0}(s) ds`, `l < order`, of a zonal `f` (coefficients
/// of `y_{l,0}`), by a 1-D Gauss–Legendre rule of `points` nodes.
#[must_use]
pub fn exp_zonal_exact(f: &[f64], points: usize) -> Vec<f64> {
    let n = f.len();
    let (x, w) = gauss_legendre(points);
    let mut out = vec![0.0; n];
    let mut p = vec![0.0; n.max(2)];
    for (&x, &w) in x.iter().zip(&w) {
        legendre_into(x, &mut p);
        let y = |l: usize| ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * p[l];
        let v: f64 = (0..n).map(|l| f[l] * y(l)).sum::<f64>().exp();
        for l in 0..n {
            out[l] += 2.0 * PI * w * v * y(l);
        }
    }
    out
}

/// `P_l(x)` for `l < out.len()`.
pub fn legendre_into(x: f64, out: &mut [f64]) {
    for l in 0..out.len() {
        out[l] = match l {
            0 => 1.0,
            1 => x,
            _ => {
                let lf = l as f64;
                ((2.0 * lf - 1.0) * x * out[l - 1] - (lf - 1.0) * out[l - 2]) / lf
            }
        };
    }
}

impl OlFit {
    /// Fits the coefficients on single caps of the log table (every entry):
    /// the target of `exp_*(f̂)` is the cap's own visibility `g(θ)` with the DC
    /// factor taken out, `g · e^{−f₀/√(4π)}`, so that `exp(log g) ≈ g`.
    #[must_use]
    pub fn fit(table: &LogTable) -> Self {
        let n = table.order();
        let sqrt4pi = (4.0 * PI).sqrt();
        let mut rows: Vec<(f64, f64, f64)> = vec![(0.0, 1.0, 1.0)];
        for e in 1..table.entries() {
            let f = table.entry(e);
            let mut fh = f.to_vec();
            fh[0] = 0.0;
            let m2: f64 = fh.iter().map(|v| v * v).sum();
            if m2 <= 1e-20 {
                continue;
            }
            let dc = (-f[0] / sqrt4pi).exp();
            let g: Vec<f64> = crate::cap::cap_visibility_zonal(n, table.theta_of(e))
                .iter()
                .map(|v| v * dc)
                .collect();
            let a = g[0] / sqrt4pi;
            let b = g.iter().zip(&fh).map(|(x, f)| x * f).sum::<f64>() / m2;
            rows.push((m2.sqrt(), a, b));
        }
        rows.sort_by(|x, y| x.0.total_cmp(&y.0));
        rows.dedup_by(|x, y| (x.0 - y.0).abs() < 1e-12);
        Self {
            norm: rows.iter().map(|r| r.0).collect(),
            a: rows.iter().map(|r| r.1).collect(),
            b: rows.iter().map(|r| r.2).collect(),
        }
    }

    /// `(a, b)` at magnitude `m` (linear interpolation, clamped at the ends).
    #[must_use]
    pub fn at(&self, m: f64) -> (f64, f64) {
        let k = self.norm.partition_point(|&x| x <= m);
        if k == 0 {
            return (self.a[0], self.b[0]);
        }
        if k == self.norm.len() {
            return (self.a[k - 1], self.b[k - 1]);
        }
        let t = (m - self.norm[k - 1]) / (self.norm[k] - self.norm[k - 1]);
        (
            self.a[k - 1] + (self.a[k] - self.a[k - 1]) * t,
            self.b[k - 1] + (self.b[k] - self.b[k - 1]) * t,
        )
    }
}

/// An SH exponential evaluator with its scratch (allocation-free per call).
#[derive(Clone, Debug)]
pub struct Exponentiator<T> {
    tp: TripleProduct<T>,
    ol: OlFit,
    bufs: [Vec<T>; 5],
    scratch: Vec<T>,
}

impl<T: Real> Exponentiator<T> {
    /// For `order` bands, the OL fit taken from `table`.
    ///
    /// # Errors
    /// An order the product tensor does not support, or one unlike the table's.
    pub fn new(order: usize, ol: OlFit) -> Result<Self, ShExpError> {
        let tp = TripleProduct::<T>::new(order)?;
        let z = vec![T::ZERO; order * order];
        let scratch = vec![T::ZERO; tp.scratch_len()];
        Ok(Self {
            tp,
            ol,
            bufs: [z.clone(), z.clone(), z.clone(), z.clone(), z],
            scratch,
        })
    }

    /// The product tensor.
    #[must_use]
    pub fn tensor(&self) -> &TripleProduct<T> {
        &self.tp
    }

    /// The fitted OL coefficients (HYB, OL).
    #[must_use]
    pub fn ol(&self) -> &OlFit {
        &self.ol
    }

    /// `out = exp_*(f)` by `kind` (not [`ExpKind::Product`], which has no log:
    /// it copies `f`). Returns the squarings used and whether the rule was capped.
    ///
    /// # Panics
    /// If `f` or `out` is shorter than `order²`.
    pub fn exp(&mut self, kind: ExpKind, f: &[T], out: &mut [T]) -> (u32, bool) {
        let n = self.tp.order();
        let nn = n * n;
        let sqrt4pi = (4.0 * PI).sqrt();
        if kind == ExpKind::Product {
            out[..nn].copy_from_slice(&f[..nn]);
            return (0, false);
        }
        let dc = T::from_f64((f[0].to_f64() / sqrt4pi).exp());
        let norm = f[1..nn]
            .iter()
            .map(|v| v.to_f64() * v.to_f64())
            .sum::<f64>()
            .sqrt();
        let (s, capped) = match kind {
            ExpKind::Ol => (0, false),
            _ => {
                let s = squarings_rule(norm);
                (s.min(MAX_SQUARINGS), s > MAX_SQUARINGS)
            }
        };
        let scale = 0.5f64.powi(s as i32);
        {
            let fh = &mut self.bufs[0];
            fh[0] = T::ZERO;
            let sc = T::from_f64(scale);
            for (d, v) in fh[1..nn].iter_mut().zip(&f[1..nn]) {
                *d = *v * sc;
            }
        }
        match kind {
            ExpKind::PsStar(p) => self.factored_series(p, out),
            _ => {
                let (a, b) = self.ol.at(norm * scale);
                let (a, b) = (T::from_f64(a), T::from_f64(b));
                let fh = &self.bufs[0];
                for i in 0..nn {
                    out[i] = b * fh[i];
                }
                out[0] = a * T::from_f64(sqrt4pi);
            }
        }
        for _ in 0..s {
            let tmp = &mut self.bufs[1];
            // `product_with` runs the generated straight-line kernel (f32,
            // orders it covers); `square_with` always takes the n⁴-scratch
            // portable path. Same product, up to rounding.
            self.tp.product_with(out, out, tmp, &mut self.scratch);
            out[..nn].copy_from_slice(&tmp[..nn]);
        }
        for v in &mut out[..nn] {
            *v *= dc;
        }
        (s, capped)
    }

    /// Degree-`p` factored series (5.27) of `bufs[0]` into `out`.
    fn factored_series(&mut self, p: u32, out: &mut [T]) {
        let nn = self.tp.order() * self.tp.order();
        let sqrt4pi = T::from_f64((4.0 * PI).sqrt());
        let [fh, f2, pw, odd, tmp] = &mut self.bufs;
        let scratch = &mut self.scratch;
        let h = |k: u32| T::from_f64(1.0 / (1..=k).map(f64::from).product::<f64>());
        // even part: h0 1 + h2 f² + h4 f⁴ …; odd part: h1 1 + h3 f² + …
        out[..nn].fill(T::ZERO);
        out[0] = sqrt4pi;
        odd[..nn].fill(T::ZERO);
        odd[0] = sqrt4pi;
        let mut odd_is_one = true;
        if p >= 2 {
            self.tp.product_with(fh, fh, f2, scratch);
            pw[..nn].copy_from_slice(&f2[..nn]);
            let mut k = 2;
            loop {
                let he = h(k);
                for i in 0..nn {
                    out[i] += he * pw[i];
                }
                if k < p {
                    let ho = h(k + 1);
                    for i in 0..nn {
                        odd[i] += ho * pw[i];
                    }
                    odd_is_one = false;
                }
                k += 2;
                if k > p {
                    break;
                }
                // pw = f^k
                self.tp.product_with(pw, f2, tmp, scratch);
                std::mem::swap(pw, tmp);
            }
        }
        if p >= 1 {
            if odd_is_one {
                // f̂ ∗ (h₁ 1) = f̂.
                for i in 0..nn {
                    out[i] += fh[i];
                }
            } else {
                self.tp.product_with(fh, odd, f2, scratch);
                for i in 0..nn {
                    out[i] += f2[i];
                }
            }
        }
    }
}
