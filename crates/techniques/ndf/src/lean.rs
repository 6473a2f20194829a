//! LEAN mapping (Olano & Baker 2010, "LEAN Mapping", I3D), the fourth
//! baseline of issue 14: 5 floats per texel that MIP-filter linearly and
//! give each texel an anisotropic lobe. (The paper is not in
//! `../shared/papers`; section numbers are not cited. Every form below is
//! checked a second way in `verify ndf` and `tests/math.rs`: a constant map,
//! a V-groove's analytic moments, and the base lobe at `B = 0`.)
//!
//! # Moments
//! A unit tangent-space normal `n` is the slope `b = (n_x/n_z, n_y/n_z)` of
//! its facet (the facet's normal is ∝ `(b, 1)`; `n_z` is clamped at
//! [`MIN_NZ`] so the slope stays finite). A texel stores
//! `B = E[b]` (2 floats) and `M = (E[b_x²], E[b_y²], E[b_x b_y])`
//! (3 floats) over its footprint; both are plain averages, so the box
//! pyramid and trilinear filtering are exact ([`crate::box_pyramid`]). The
//! slope covariance of the footprint is `Σ = M − B Bᵀ`,
//! clamped to positive semi-definite against rounding.
//!
//! # Shading (tangent slope space)
//! The texel's normal is `n̄ ∝ (B, 1)` (its cosines, Lambert and the
//! microfacet denominators). The half vector's slope `h̃ = h_xy/h_z` is
//! compared with `B`, `e = h̃ − B`, under the slope distribution of the
//! BRDF's own lobe widened by the footprint's spread. With `S` the lobe's
//! slope matrix (`S = 2 × covariance`):
//! * Beckmann α: `S = α² I + 2Σ`, `D = exp(−eᵀS⁻¹e) / (π √det S h_z⁴)` —
//!   the paper's Gaussian, with the base roughness on the diagonal;
//! * GGX α: `S = α² I + 2Σ`, `D = 1 / (π √det S (1 + eᵀS⁻¹e)² h_z⁴)`
//!   (GGX is this Student form in slope space; LEAN's Gaussian does not
//!   exist for it, the same covariance sum is used);
//! * Blinn–Phong s: `cosˢθ_h = (1 + |h̃|²)^{−s/2}`; widened,
//!   `c(s) (2/s)/√det S (1 + 2 eᵀS⁻¹e / s)^{−s/2} cos θ_i` with
//!   `S = (2/s) I + 2Σ` (the paper adds `1/s` to Σ's diagonal and uses a
//!   Gaussian; the Student form keeps the base lobe *exact* for `B = 0`,
//!   and `√det` keeps the lobe's integral, as the Gaussian's would).
//!
//! The spread adds to the lobe as the vMF forms of [`crate::effective`] do
//! (`α′² = α² + 2/κ`, `1/s′ = 1/s + 1/κ`: a vMF has slope variance `1/κ` per
//! axis). GGX and Beckmann masking use the isotropic `α = (det S)^{1/4}` in
//! the frame of `n̄`.
//!
//! # What LEAN does not do
//! It works in the slope space of the *geometric* normal: a tilted normal
//! (`B ≠ 0`) at level 0 gets its base lobe in tangent slope space, which is
//! narrower in angle than the lobe about `n` by about `n_z²` radially and
//! `n_z` tangentially. So level 0
//! equals plain normal mapping only for `n = +Z` and for Lambert (`verify
//! ndf` shows the level-0 error).

use crate::effective::{NdfBrdf, microfacet};
use crate::{Linear, box_pyramid, sample_pyramid};
use glam::{Vec2, Vec3};
use relight_brdf::microfacet::{beckmann_lambda, smith_g2_height_correlated};
use relight_brdf::phong::blinn_phong_normalization;
use std::f32::consts::PI;

/// Smallest `n_z` a normal's slope is taken at (slopes ≤ ~20).
pub const MIN_NZ: f32 = 0.05;

/// One texel's LEAN moments: 5 floats.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LeanTexel {
    /// `B = E[b]`, the mean slope.
    pub b: Vec2,
    /// `M = (E[b_x²], E[b_y²], E[b_x b_y])`.
    pub m: Vec3,
}

impl Linear for LeanTexel {
    const ZERO: Self = Self {
        b: Vec2::ZERO,
        m: Vec3::ZERO,
    };
    #[inline]
    fn add_scaled(self, w: f32, x: Self) -> Self {
        Self {
            b: self.b + x.b * w,
            m: self.m + x.m * w,
        }
    }
}

impl LeanTexel {
    /// The moments of one unit normal (module docs).
    #[inline]
    #[must_use]
    pub fn of_normal(n: Vec3) -> Self {
        let b = Vec2::new(n.x, n.y) / n.z.max(MIN_NZ);
        Self {
            b,
            m: Vec3::new(b.x * b.x, b.y * b.y, b.x * b.y),
        }
    }

    /// The slope covariance `Σ = M − B Bᵀ` as `(σ_xx, σ_yy, σ_xy)`, clamped
    /// to positive semi-definite.
    #[inline]
    #[must_use]
    pub fn covariance(&self) -> Vec3 {
        let sxx = (self.m.x - self.b.x * self.b.x).max(0.0);
        let syy = (self.m.y - self.b.y * self.b.y).max(0.0);
        let lim = (sxx * syy).sqrt();
        let sxy = (self.m.z - self.b.x * self.b.y).clamp(-lim, lim);
        Vec3::new(sxx, syy, sxy)
    }

    /// The texel's normal `n̄ ∝ (B, 1)`.
    #[inline]
    #[must_use]
    pub fn normal(&self) -> Vec3 {
        Vec3::new(self.b.x, self.b.y, 1.0).normalize()
    }
}

/// The LEAN MIP chain (level 0 first, down to 1 × 1).
#[derive(Clone, Debug, PartialEq)]
pub struct LeanPyramid {
    pub levels: Vec<(usize, usize, Vec<LeanTexel>)>,
}

impl LeanPyramid {
    /// Builds it from `width × height` unit normals.
    #[must_use]
    pub fn build(width: usize, height: usize, normals: &[Vec3]) -> Self {
        let texels = normals.iter().map(|n| LeanTexel::of_normal(*n)).collect();
        Self {
            levels: box_pyramid(width, height, texels),
        }
    }

    /// Trilinear lookup (exact: the moments are linear).
    #[inline]
    #[must_use]
    pub fn sample(&self, uv: Vec2, lod: f32) -> LeanTexel {
        sample_pyramid(&self.levels, uv, lod)
    }

    /// The mean over an anisotropic footprint's probes.
    #[must_use]
    pub fn sample_footprint(&self, fp: &crate::Footprint) -> LeanTexel {
        crate::sample_footprint(&self.levels, fp)
    }

    /// Texel `(x, y)` of level `k`.
    #[must_use]
    pub fn texel(&self, k: usize, x: usize, y: usize) -> LeanTexel {
        let (w, _, t) = &self.levels[k];
        t[y * w + x]
    }

    /// Bytes over the whole chain (5 × f32 per texel).
    #[must_use]
    pub fn bytes(&self) -> u64 {
        self.levels.iter().map(|l| l.2.len() as u64 * 20).sum()
    }
}

/// `f·cos θ_i` of `brdf` for a LEAN texel (module docs; `wo`, `wi` unit,
/// tangent frame; no colour), as [`crate::effective::shade_lobe`].
#[inline]
#[must_use]
pub fn shade_lean(brdf: NdfBrdf, t: &LeanTexel, wo: Vec3, wi: Vec3) -> f32 {
    let n = t.normal();
    let (co, ci) = (n.dot(wo), n.dot(wi));
    if co <= 0.0 {
        return 0.0;
    }
    let base = match brdf {
        NdfBrdf::Lambert => return ci.max(0.0) / PI,
        _ if ci <= 0.0 => return 0.0,
        NdfBrdf::Blinn { s } => 2.0 / s,
        NdfBrdf::Ggx { alpha } | NdfBrdf::Beckmann { alpha } => alpha * alpha,
    };
    let Some(h) = (wo + wi).try_normalize() else {
        return 0.0;
    };
    if h.z <= 1e-4 {
        return 0.0;
    }
    let e = Vec2::new(h.x, h.y) / h.z - t.b;
    let c = t.covariance();
    // S = base I + 2Σ.
    let (sa, sc, sb) = (base + 2.0 * c.x, base + 2.0 * c.y, 2.0 * c.z);
    let det = sa * sc - sb * sb;
    if det <= 0.0 {
        return 0.0;
    }
    // eᵀ S⁻¹ e.
    let q = (sc * e.x * e.x - 2.0 * sb * e.x * e.y + sa * e.y * e.y) / det;
    let root = det.sqrt();
    let h4 = (h.z * h.z) * (h.z * h.z);
    match brdf {
        NdfBrdf::Blinn { s } => {
            blinn_phong_normalization(s) * (base / root) * (1.0 + 2.0 * q / s).powf(-0.5 * s) * ci
        }
        NdfBrdf::Beckmann { .. } => {
            let d = (-q).exp() / (PI * root * h4);
            let a = root.sqrt();
            microfacet(
                n,
                wo,
                wi,
                |_| d,
                |o, i| 1.0 / (1.0 + beckmann_lambda(o, a) + beckmann_lambda(i, a)),
            )
        }
        _ => {
            // GGX (Lambert returned above).
            let d = 1.0 / (PI * root * (1.0 + q) * (1.0 + q) * h4);
            let a = root.sqrt();
            microfacet(
                n,
                wo,
                wi,
                |_| d,
                |o, i| smith_g2_height_correlated(o, i, a, a),
            )
        }
    }
}
