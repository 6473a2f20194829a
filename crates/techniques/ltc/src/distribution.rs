//! The linearly transformed cosine (Heitz et al. 2016, *Real-Time
//! Polygonal-Light Shading with Linearly Transformed Cosines*, §3).
//!
//! The original distribution is the clamped cosine `D_o(ω_o) = max(0, z)/π`
//! on the unit sphere. A 3×3 matrix `M` maps its directions,
//! `ω = M ω_o / |M ω_o|`, and the distribution of `ω` is (eq. 1–3)
//!
//! `D(ω) = D_o(M⁻¹ω / |M⁻¹ω|) · |det M⁻¹| / |M⁻¹ω|³`
//!
//! (sr⁻¹, integrates to 1 over the sphere for any invertible `M`). Its
//! integral over a polygon `P` is the clamped-cosine integral of the
//! polygon `M⁻¹P` (eq. 5): [`Ltc::polygon_integral`]. Frames: the local
//! shading frame, normal on +Z, the view in the xz-plane with `x ≥ 0`.

use crate::polygon::{MAX_VERTICES, clamped_cosine_integral, clip_to_horizon};
use glam::{DMat3, DVec2, DVec3};
use std::f64::consts::PI;

/// A linearly transformed cosine: the matrix `M` and its inverse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ltc {
    /// `M`: clamped-cosine directions → this distribution's directions.
    pub m: DMat3,
    /// `M⁻¹`.
    pub m_inv: DMat3,
    /// `|det M⁻¹|`.
    det_inv: f64,
}

impl Ltc {
    /// The distribution of `M` (invertible).
    #[must_use]
    pub fn from_m(m: DMat3) -> Self {
        let m_inv = m.inverse();
        Self {
            m,
            m_inv,
            det_inv: m_inv.determinant().abs(),
        }
    }

    /// The distribution whose inverse matrix is `m_inv` (any non-zero scale:
    /// `D` does not change when `M⁻¹` is scaled).
    #[must_use]
    pub fn from_inverse(m_inv: DMat3) -> Self {
        Self {
            m: m_inv.inverse(),
            m_inv,
            det_inv: m_inv.determinant().abs(),
        }
    }

    /// The clamped cosine itself (`M = I`).
    #[must_use]
    pub fn identity() -> Self {
        Self::from_m(DMat3::IDENTITY)
    }

    /// `D(ω)` for a unit `w` (sr⁻¹), module docs.
    #[inline]
    #[must_use]
    pub fn eval(&self, w: DVec3) -> f64 {
        let lo = self.m_inv * w;
        let l2 = lo.length_squared();
        if l2 <= 0.0 {
            return 0.0;
        }
        let l = l2.sqrt();
        let d_o = (lo.z / l).max(0.0) / PI;
        d_o * self.det_inv / (l2 * l)
    }

    /// A direction distributed as `D` from `u ∈ [0, 1)²`: a cosine sample
    /// (Malley: the unit disk lifted to the hemisphere) mapped by `M`.
    #[inline]
    #[must_use]
    pub fn sample(&self, u: DVec2) -> DVec3 {
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let wo = DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt());
        (self.m * wo).normalize()
    }

    /// `∫_P D(ω) dω` over the convex polygon `poly` (≤ 4 vertices, relative
    /// to the shading point, local frame): the polygon is clipped to the
    /// shading horizon `z ≥ 0` first (the BRDF·cos the LTC stands for is 0
    /// below it, while `D` need not be), then transformed by `M⁻¹` and
    /// integrated against the clamped cosine, which clips it again at the
    /// cosine's own horizon (eq. 5; [`clamped_cosine_integral`]). Signed by
    /// the winding.
    #[must_use]
    pub fn polygon_integral(&self, poly: &[DVec3]) -> f64 {
        let mut above = [DVec3::ZERO; MAX_VERTICES];
        let k = clip_to_horizon(&poly[..poly.len().min(4)], &mut above);
        if k < 3 {
            return 0.0;
        }
        for p in &mut above[..k] {
            *p = self.m_inv * *p;
        }
        clamped_cosine_integral(&above[..k])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    fn sheared() -> Ltc {
        Ltc::from_m(DMat3::from_cols(
            DVec3::new(0.4, 0.0, 0.1),
            DVec3::new(0.0, 0.6, 0.0),
            DVec3::new(0.3, 0.0, 1.0),
        ))
    }

    /// `D` integrates to 1 (midpoint quadrature over the sphere in
    /// (cos θ, φ), which is area-uniform).
    #[test]
    fn integrates_to_one() {
        for ltc in [Ltc::identity(), sheared()] {
            let n = 800;
            let mut sum = 0.0;
            for j in 0..n {
                let z = -1.0 + 2.0 * (j as f64 + 0.5) / n as f64;
                let s = (1.0 - z * z).sqrt();
                for i in 0..2 * n {
                    let phi = PI * (i as f64 + 0.5) / n as f64;
                    sum += ltc.eval(DVec3::new(s * phi.cos(), s * phi.sin(), z));
                }
            }
            let total = sum * (2.0 / n as f64) * (PI / n as f64);
            assert!((total - 1.0).abs() < 2e-3, "{total}");
        }
    }

    /// The polygon integral equals the fraction of `D`'s samples that fall
    /// in the polygon and above the shading horizon (seeded stratified
    /// Monte Carlo, 4σ): one polygon above the horizon, one crossing it (a
    /// wall at x = 0.6, where the sheared `D` has mass below z = 0).
    #[test]
    fn polygon_integral_matches_sampling() {
        let ltc = sheared();
        // (polygon, inside test for a unit direction).
        type Inside = fn(DVec3) -> bool;
        let cases: [([DVec3; 4], Inside); 2] = [
            (
                [
                    DVec3::new(-0.2, -0.5, 1.0),
                    DVec3::new(0.9, -0.5, 1.0),
                    DVec3::new(0.9, 0.4, 1.0),
                    DVec3::new(-0.2, 0.4, 1.0),
                ],
                |w| {
                    let p = w / w.z;
                    w.z > 0.0 && (-0.2..=0.9).contains(&p.x) && (-0.5..=0.4).contains(&p.y)
                },
            ),
            (
                [
                    DVec3::new(-0.6, -0.7, -0.5),
                    DVec3::new(-0.6, 0.7, -0.5),
                    DVec3::new(-0.6, 0.7, 0.8),
                    DVec3::new(-0.6, -0.7, 0.8),
                ],
                |w| {
                    let p = w * (-0.6 / w.x);
                    w.x < 0.0 && w.z > 0.0 && (-0.7..=0.7).contains(&p.y) && p.z <= 0.8
                },
            ),
        ];
        for (poly, inside) in cases {
            let exact = ltc.polygon_integral(&poly).abs();
            let n = 400;
            let mut hits = 0usize;
            for j in 0..n {
                for i in 0..n {
                    let u = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                    if inside(ltc.sample(u)) {
                        hits += 1;
                    }
                }
            }
            let f = hits as f64 / (n * n) as f64;
            let sigma = (f * (1.0 - f) / (n * n) as f64).sqrt();
            assert!(exact > 0.01, "{exact}");
            assert!((f - exact).abs() < 4.0 * sigma + 1e-4, "{f} vs {exact}");
        }
    }
}
