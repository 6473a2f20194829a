//! Affine coupling and tripling coefficients of 1D Haar atoms (thesis
//! §4.3.2, eqs. 4.7–4.10, 4.20–4.23, Property 2 = eq. 4.29) and the
//! standard ones as their `s = 1, o = 0` case (eq. 4.12).
//!
//! `D_ij(s, o) = ∫ Φ_i(s v + o) Φ_j(v) dv` for a scale `s > 0` and offset
//! `o` (units of the unit interval). Substituting `u = 2^{l_j} v − t_j`
//! (eq. 4.21) gives `D_ij = 2^{(l_i − l_j)/2} M(r, c)` with (eq. 4.23)
//!
//! ```text
//!   r = 2^{l_j − l_i − 1} / s
//!   c = (2^{l_j − l_i} t_i − 2^{l_j} o + 2^{l_j − l_i − 1}) / s − t_j
//! ```
//!
//! **OCR correction:** the thesis prints `2^{l_i} o` in `c`; the
//! substitution gives `2^{l_j} o` (checked against direct overlap in v and
//! quadrature in `tests/it/coupling.rs`). The same holds for every pair of
//! kinds (φ/ψ), with [`canonical`] of those kinds.
//!
//! The tripling coefficient `D_ijk(s, o) = ∫ Φ_i(s v + o) Φ_j(v) Φ_k(v) dv`
//! reduces by the product rule ([`Atom::product`]) to one coupling:
//! `Φ_j Φ_k = κ Φ_m`, so `D_ijk = κ D_im`. For two wavelets `j ≠ k` this is
//! eq. 4.29, `D_ijk = σ 2^{(l_i − l_m + l_n)/2} M(r, c)` with `n` the coarser,
//! `m` the finer and `(r, c)` of the pair `(i, m)`. **Correction:** the
//! thesis omits the sign σ (+1 when the finer wavelet lies in the first,
//! positive half of the coarser, −1 otherwise) and the case `j = k`, where
//! `ψ_j² = 2^{l_j/2} φ_{l_j, t_j}` and `D_ijj = 2^{l_i/2} M_ψφ(r, c)`.

use crate::atom::{Atom, Kind};
use crate::canonical::{canonical, canonical_gradient};

/// The canonical variables `(r, c)` of eq. 4.23 (corrected) for the pair
/// (`i` transformed, `j` fixed).
#[must_use]
pub fn canonical_args(i: Atom, j: Atom, s: f64, o: f64) -> (f64, f64) {
    let dl = (f64::from(j.level) - f64::from(i.level)).exp2();
    let lj = j.scale();
    let r = 0.5 * dl / s;
    let c = (dl * f64::from(i.offset) - lj * o + 0.5 * dl) / s - f64::from(j.offset);
    (r, c)
}

/// The affine coupling coefficient `D_ij(s, o)` (ACC, eq. 4.8) by eq. 4.21.
#[must_use]
pub fn affine_coupling(i: Atom, j: Atom, s: f64, o: f64) -> f64 {
    let (r, c) = canonical_args(i, j, s, o);
    let m = canonical(i.kind, j.kind, r, c);
    if m == 0.0 {
        return 0.0;
    }
    level_factor(i, j) * m
}

/// `2^{(l_i − l_j)/2}`.
fn level_factor(i: Atom, j: Atom) -> f64 {
    (0.5 * (f64::from(i.level) - f64::from(j.level))).exp2()
}

/// `(∂D_ij/∂s, ∂D_ij/∂o)` by the chain rule through eq. 4.23:
/// `∂r/∂s = −r/s`, `∂c/∂s = −(c + t_j)/s`, `∂c/∂o = −2^{l_j}/s`.
#[must_use]
pub fn affine_coupling_gradient(i: Atom, j: Atom, s: f64, o: f64) -> (f64, f64) {
    let (r, c) = canonical_args(i, j, s, o);
    let (dr, dc) = canonical_gradient(i.kind, j.kind, r, c);
    let k = level_factor(i, j);
    let ds = dr * (-r / s) + dc * (-(c + f64::from(j.offset)) / s);
    let d_o = dc * (-j.scale() / s);
    (k * ds, k * d_o)
}

/// `D_ij(s, o)` by exact overlap of the constant pieces in v (no
/// canonical reduction): an independent check of eqs. 4.21–4.23.
#[must_use]
pub fn affine_coupling_overlap(i: Atom, j: Atom, s: f64, o: f64) -> f64 {
    let amp = (i.scale() * j.scale()).sqrt();
    let mut sum = 0.0;
    for &(x0, x1, sa) in i.kind.pieces() {
        // x = s v + o ∈ [(t_i + x0) 2^{−l_i}, (t_i + x1) 2^{−l_i}).
        let xa = (f64::from(i.offset) + x0) / i.scale();
        let xb = (f64::from(i.offset) + x1) / i.scale();
        let (v0, v1) = ((xa - o) / s, (xb - o) / s);
        for &(y0, y1, sb) in j.kind.pieces() {
            let w0 = (f64::from(j.offset) + y0) / j.scale();
            let w1 = (f64::from(j.offset) + y1) / j.scale();
            sum += sa * sb * (v1.min(w1) - v0.max(w0)).max(0.0);
        }
    }
    amp * sum
}

/// Midpoint quadrature of `∫ f(v) dv` over `[lo, hi]` with `samples` points.
#[must_use]
pub fn midpoint(lo: f64, hi: f64, samples: usize, f: impl Fn(f64) -> f64) -> f64 {
    let h = (hi - lo) / samples as f64;
    (0..samples)
        .map(|k| f(lo + (k as f64 + 0.5) * h))
        .sum::<f64>()
        * h
}

/// `D_ij(s, o)` by the midpoint rule over the support of `j`.
#[must_use]
pub fn affine_coupling_quadrature(i: Atom, j: Atom, s: f64, o: f64, samples: usize) -> f64 {
    let (lo, hi) = j.support();
    midpoint(lo, hi, samples, |v| i.eval(s * v + o) * j.eval(v))
}

/// The affine tripling coefficient `D_ijk(s, o)` (ATC, eq. 4.10) by the
/// product rule and one coupling (Property 2, corrected; module docs).
#[must_use]
pub fn affine_tripling(i: Atom, j: Atom, k: Atom, s: f64, o: f64) -> f64 {
    match j.product(k) {
        None => 0.0,
        Some((kappa, m)) => {
            let d = affine_coupling(i, m, s, o);
            if d == 0.0 { 0.0 } else { kappa * d }
        }
    }
}

/// Eq. 4.29 as printed plus the sign σ, for two wavelets `j ≠ k` (kept to
/// show the correction): `σ 2^{(l_i − l_m + l_n)/2} M(r, c)`.
#[must_use]
pub fn property2(i: Atom, j: Atom, k: Atom, s: f64, o: f64) -> Option<f64> {
    if j.kind != Kind::Wave || k.kind != Kind::Wave || j == k {
        return None;
    }
    let (n, m) = if j.level <= k.level { (j, k) } else { (k, j) };
    let (sigma_amp, _) = n.product(m)?;
    let sigma = sigma_amp.signum();
    let (r, c) = canonical_args(i, m, s, o);
    let e = 0.5 * (f64::from(i.level) - f64::from(m.level) + f64::from(n.level));
    Some(sigma * e.exp2() * canonical(i.kind, m.kind, r, c))
}

/// `D_ijk(s, o)` by the midpoint rule over the support of the finer of `j`, `k`.
#[must_use]
pub fn affine_tripling_quadrature(
    i: Atom,
    j: Atom,
    k: Atom,
    s: f64,
    o: f64,
    samples: usize,
) -> f64 {
    let fine = if j.level >= k.level { j } else { k };
    let (lo, hi) = fine.support();
    midpoint(lo, hi, samples, |v| {
        i.eval(s * v + o) * j.eval(v) * k.eval(v)
    })
}

/// The standard coupling coefficient `C_ij = D_ij(1, 0)` (eq. 4.12).
#[must_use]
pub fn standard_coupling(i: Atom, j: Atom) -> f64 {
    affine_coupling(i, j, 1.0, 0.0)
}

/// The standard tripling coefficient `C_ijk = D_ijk(1, 0)` (eqs. 4.6, 4.12).
#[must_use]
pub fn standard_tripling(i: Atom, j: Atom, k: Atom) -> f64 {
    affine_tripling(i, j, k, 1.0, 0.0)
}

/// Lemma 1 (eq. 4.14): `D_ijk(s, o) = Σ_l D_il(s, o) C_ljk` over the 1D
/// basis of order `n` (exact for any `n` whose finest level holds `j` and
/// `k`, since `Φ_j Φ_k` then lies in the span of that basis).
#[must_use]
pub fn tripling_by_lemma1(i: Atom, j: Atom, k: Atom, s: f64, o: f64, n: usize) -> f64 {
    (0..n)
        .map(Atom::from_index)
        .map(|l| {
            let c = standard_tripling(l, j, k);
            if c == 0.0 {
                0.0
            } else {
                affine_coupling(i, l, s, o) * c
            }
        })
        .sum()
}
