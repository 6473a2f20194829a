//! Shading with a total visibility vector (thesis eq. 5.14): `L_H(N) · g`,
//! `L_H(N) = L ∗ H(N)`, with `H(N) = (1/π) ∫ max(s·N, 0) y(s) ds` the
//! irradiance weighting (so an unshadowed white environment of radiance 1
//! gives 1), tabulated over normals on an octahedral grid.

use relight_sh::quadrature::gauss_legendre;
use std::f64::consts::PI;

/// Zonal coefficients (about +Z) of `H = (1/π) max(cos θ, 0)`, `l < order`:
/// `h_l = 2 √((2l+1)/(4π)) ∫₀¹ x P_l(x) dx` (exact: a polynomial rule).
#[must_use]
pub fn irradiance_zonal(order: usize) -> Vec<f64> {
    let (x, w) = gauss_legendre(order + 2);
    let mut p = vec![0.0; order.max(2)];
    let mut h = vec![0.0; order];
    for (&x, &w) in x.iter().zip(&w) {
        // Map [−1, 1] → [0, 1].
        let t = 0.5 * (x + 1.0);
        crate::exp::legendre_into(t, &mut p);
        for l in 0..order {
            h[l] += 0.5 * w * t * p[l];
        }
    }
    for (l, v) in h.iter_mut().enumerate() {
        *v *= 2.0 * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt();
    }
    h
}

/// Octahedral map of a unit direction to [0, 1]².
#[inline]
#[must_use]
pub fn oct_encode(d: glam::Vec3) -> glam::Vec2 {
    let s = d.x.abs() + d.y.abs() + d.z.abs();
    let (mut x, mut y) = (d.x / s, d.y / s);
    if d.z < 0.0 {
        let (ox, oy) = (x, y);
        x = (1.0 - oy.abs()) * ox.signum();
        y = (1.0 - ox.abs()) * oy.signum();
    }
    glam::Vec2::new(0.5 * (x + 1.0), 0.5 * (y + 1.0))
}

/// Inverse of [`oct_encode`].
#[inline]
#[must_use]
pub fn oct_decode(uv: glam::Vec2) -> glam::Vec3 {
    let (x, y) = (2.0 * uv.x - 1.0, 2.0 * uv.y - 1.0);
    let z = 1.0 - x.abs() - y.abs();
    let (mut px, mut py) = (x, y);
    if z < 0.0 {
        px = (1.0 - y.abs()) * x.signum();
        py = (1.0 - x.abs()) * y.signum();
    }
    glam::Vec3::new(px, py, z).normalize()
}

/// The cosine-weighted direction (local frame, +Z the normal) in stratum
/// `(a, b)` of `k × k`, jittered by `rng`: the rays of the `T_p` bakes and
/// of verify's reference (`u` then `s` drawn in that order).
#[inline]
#[must_use]
pub fn cosine_stratum(a: usize, b: usize, k: usize, rng: &mut relight_render::Rng) -> glam::Vec3 {
    let u = (a as f32 + rng.next_f32()) / k as f32;
    let s = (b as f32 + rng.next_f32()) / k as f32;
    let r = u.sqrt();
    let phi = 2.0 * std::f32::consts::PI * s;
    glam::Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u).max(0.0).sqrt())
}
