//! The canonical coupling coefficient (CCC) `M(r, c)` (thesis eq. 4.22,
//! Fig. 4.4) and its generalisation to boxes.
//!
//! `M_ab(r, c) = ∫ a(u/(2r) − c/(2r) + ½) b(u) du`: the integral of the
//! mother function `b` (β, support \[0, 1\]) against the mother function `a`
//! stretched to radius `r > 0` and centred at `c` (α, support
//! `[c − r, c + r]`). The thesis gives only `a = b = ψ`; a complete basis
//! (the scaling function, and the boxes of the nonstandard 2D basis) also
//! needs φφ, ψφ and φψ.
//!
//! # Closed forms (derived here)
//! With `B` the primitive of `b` ([`Kind::primitive`]: `clamp(x, 0, 1)` for
//! φ, the tent `max(0, ½ − |x − ½|)` for ψ), integrating `b` over each
//! constant piece of α gives
//!
//! ```text
//!   M_φb(r, c) = B(c + r) − B(c − r)
//!   M_ψb(r, c) = 2 B(c) − B(c − r) − B(c + r)
//! ```
//!
//! Differentiating gives eqs. 4.25–4.26 (and their box analogues) at once:
//! `∂M_ψb/∂c = 2b(c) − b(c−r) − b(c+r)`, `∂M_ψb/∂r = b(c−r) − b(c+r)`,
//! `∂M_φb/∂c = b(c+r) − b(c−r)`, `∂M_φb/∂r = b(c+r) + b(c−r)`.
//!
//! # Exact zeros
//! Floating-point cancellation in the forms above leaves residues like
//! 1e-17 where the integral is exactly zero. [`canonical`] therefore first
//! applies the structural zero test [`is_structural_zero`] (disjoint
//! supports, eq. 4.24; a wavelet inside a constant piece of the other
//! function; the two centred cancellations), so that a zero coefficient is
//! exactly `0.0` and sparsity counts ([`crate::sparsity`]) count true
//! non-zeros.
//!
//! # OCR corrections to Fig. 4.4 (verified by `tests/it/canonical.rs`)
//! * `dr = |r − ½|`, not the signed `r − ½` (the signed form is wrong for
//!   every `r < ½` in branches 5–8).
//! * The last branch `else if d ≤ min(dr, minr)` is the plain `else`.
//! * Eq. 4.28 reads `M(r, c) = 2r M(1/(4r), ½ + 1/(4r) − c/(2r))` (the OCR'd
//!   derivation's last line has `1/(2r)` as first argument); for mixed kinds
//!   the roles swap: `M_ab(r, c) = 2r M_ba(1/(4r), …)`.

use crate::atom::Kind;

/// `M_ab(r, c)`, exact zeros exactly `0.0` (module docs). `r > 0`.
#[must_use]
pub fn canonical(a: Kind, b: Kind, r: f64, c: f64) -> f64 {
    if is_structural_zero(a, b, r, c) {
        return 0.0;
    }
    primitive_form(a, b, r, c)
}

/// The primitive form of the module docs, without the zero test.
#[must_use]
pub fn primitive_form(a: Kind, b: Kind, r: f64, c: f64) -> f64 {
    match a {
        Kind::Box => b.primitive(c + r) - b.primitive(c - r),
        Kind::Wave => 2.0 * b.primitive(c) - b.primitive(c - r) - b.primitive(c + r),
    }
}

/// Whether `M_ab(r, c)` is zero for a structural reason: the supports
/// overlap in at most a point (eq. 4.24, `|c − ½| ≥ r + ½`), a wavelet lies
/// inside one constant piece of the other function, or a box and a wavelet
/// are centred on each other (`c = ½`). These are all the zeros on open
/// regions of (r, c); the only other zeros are isolated crossings of a
/// linear piece, which [`canonical`] returns as computed.
#[must_use]
pub fn is_structural_zero(a: Kind, b: Kind, r: f64, c: f64) -> bool {
    let (lo, hi) = (c - r, c + r);
    if (c - 0.5).abs() >= r + 0.5 {
        return true;
    }
    let inside = |x0: f64, x1: f64, y0: f64, y1: f64| x0 >= y0 && x1 <= y1;
    match (a, b) {
        (Kind::Wave, Kind::Box) => inside(lo, hi, 0.0, 1.0) || c == 0.5,
        (Kind::Box, Kind::Wave) => inside(0.0, 1.0, lo, hi) || c == 0.5,
        (Kind::Wave, Kind::Wave) => {
            inside(lo, hi, 0.0, 0.5)
                || inside(lo, hi, 0.5, 1.0)
                || inside(0.0, 1.0, lo, c)
                || inside(0.0, 1.0, c, hi)
        }
        (Kind::Box, Kind::Box) => false,
    }
}

/// Fig. 4.4's nine-line branch form of `M_ψψ(r, c)`, corrected
/// (`dr = |r − ½|`, last branch `else`). Kept as written to verify it.
#[must_use]
pub fn canonical_fig44(r: f64, c: f64) -> f64 {
    let d = (c - 0.5).abs();
    let sr = r + 0.5;
    let dr = (r - 0.5).abs(); // OCR: `dr = r − 0.5` (signed) is wrong for r < ½.
    let maxr = r.max(0.5);
    let minr = r.min(0.5);
    if d >= sr {
        0.0 // Fig. 4.3B
    } else if d >= maxr {
        d - sr // Fig. 4.3C
    } else if d >= dr.max(minr) {
        dr - d // Fig. 4.3D
    } else if d >= dr.min(minr) {
        if dr >= minr {
            0.0 // Fig. 4.3E
        } else {
            sr - 3.0 * d // Fig. 4.3F
        }
    } else {
        2.0 * (minr - d) // Fig. 4.3G
    }
}

/// `M_ab(r, c)` by exact overlap of the constant pieces of α and β (a
/// signed sum of interval intersections; an independent check of
/// [`canonical`]).
#[must_use]
pub fn canonical_overlap(a: Kind, b: Kind, r: f64, c: f64) -> f64 {
    let mut sum = 0.0;
    for &(x0, x1, sa) in a.pieces() {
        // α's piece in u: u = 2r (x − ½) + c.
        let (u0, u1) = (2.0 * r * (x0 - 0.5) + c, 2.0 * r * (x1 - 0.5) + c);
        for &(y0, y1, sb) in b.pieces() {
            sum += sa * sb * (u1.min(y1) - u0.max(y0)).max(0.0);
        }
    }
    sum
}

/// `M_ab(r, c)` by the midpoint rule with `samples` points over the union
/// of both supports (the second, quadrature check of eq. 4.22).
#[must_use]
pub fn canonical_quadrature(a: Kind, b: Kind, r: f64, c: f64, samples: usize) -> f64 {
    let (lo, hi) = ((c - r).min(0.0), (c + r).max(1.0));
    let h = (hi - lo) / samples as f64;
    let mut sum = 0.0;
    for k in 0..samples {
        let u = lo + (k as f64 + 0.5) * h;
        sum += a.mother(u / (2.0 * r) - c / (2.0 * r) + 0.5) * b.mother(u);
    }
    sum * h
}

/// The partial derivatives `(∂M/∂r, ∂M/∂c)` (eqs. 4.25–4.26 for ψψ; the box
/// forms of the module docs). β is evaluated as the mean of its one-sided
/// limits at its jumps, which makes the result exact wherever M is
/// differentiable, including where a break point of α meets one of β.
#[must_use]
pub fn canonical_gradient(a: Kind, b: Kind, r: f64, c: f64) -> (f64, f64) {
    let (bl, bc, bh) = (b.mother_mean(c - r), b.mother_mean(c), b.mother_mean(c + r));
    match a {
        Kind::Box => (bh + bl, bh - bl),
        Kind::Wave => (bl - bh, 2.0 * bc - bl - bh),
    }
}
