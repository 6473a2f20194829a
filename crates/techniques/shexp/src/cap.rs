//! Analytic visibility of a spherical cap as zonal harmonics (thesis eq. 5.36).
//!
//! A sphere of radius `r` whose centre lies at distance `d > r` from a
//! receiver subtends a cap of half-angle `θ = asin(r/d)`. Its visibility
//! `g(s) = 0` inside the cap, 1 outside, is zonal about the cap axis, so it is
//! `Σ_l g_l y_{l,0}` with (about +Z)
//!
//! `g_l = √(4π) δ_{l0} − 2π √((2l+1)/(4π)) ∫_{cos θ}^{1} P_l(x) dx`,
//!
//! and `∫_{x₀}^{1} P_l = (P_{l−1}(x₀) − P_{l+1}(x₀))/(2l+1)` for `l ≥ 1`,
//! `1 − x₀` for `l = 0` — exact, with no quadrature of the step (which rings
//! visibly at low order).

use std::f64::consts::PI;

/// Zonal coefficients `g_l`, `l < order`, of the visibility of a cap of
/// half-angle `theta` (radians, clamped to [0, π]) about +Z: 0 inside, 1 outside.
#[must_use]
pub fn cap_visibility_zonal(order: usize, theta: f64) -> Vec<f64> {
    let mut out = vec![0.0; order];
    cap_visibility_zonal_into(theta, &mut out);
    out
}

/// [`cap_visibility_zonal`] into `out` (its length is the order); allocation-free.
pub fn cap_visibility_zonal_into(theta: f64, out: &mut [f64]) {
    let x = theta.clamp(0.0, PI).cos();
    // Legendre recurrence P_{l−1}, P_l, P_{l+1}.
    let (mut pm, mut p) = (1.0f64, x); // P_0, P_1
    let mut prev = 1.0; // P_{l-1} for l = 1 (P_0)
    for (l, o) in out.iter_mut().enumerate() {
        let int_cap = if l == 0 {
            1.0 - x
        } else {
            // Now pm = P_{l-1}... advance so that (prev, next) are P_{l−1}, P_{l+1}.
            let lf = l as f64;
            let next = ((2.0 * lf + 1.0) * x * p - lf * pm) / (lf + 1.0);
            let v = (prev - next) / (2.0 * lf + 1.0);
            prev = p;
            pm = p;
            p = next;
            v
        };
        let c = 2.0 * PI * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * int_cap;
        *o = if l == 0 { (4.0 * PI).sqrt() - c } else { -c };
    }
}

/// Half-angle (radians) of the cap a sphere of radius `r` at distance `d`
/// subtends: `asin(r/d)`, or π/2 when the receiver is inside or on it.
#[inline]
#[must_use]
pub fn cap_half_angle(r: f64, d: f64) -> f64 {
    if d <= r { PI / 2.0 } else { (r / d).asin() }
}
