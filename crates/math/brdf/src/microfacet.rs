//! Cook–Torrance microfacet reflection with the GGX (Trowbridge–Reitz)
//! distribution, height-correlated Smith masking-shadowing and Schlick's
//! Fresnel approximation; importance sampled through the distribution of
//! visible normals.
//!
//! f(wo, wi) = D(ĥ) · G₂(wo, wi) · F(wo·ĥ) / (4 cos θ_o cos θ_i)
//!
//! * D: anisotropic GGX, D(ĥ) = 1 / (π α_x α_y (h_x²/α_x² + h_y²/α_y² + h_z²)²)
//!   (Walter et al. 2007, *Microfacet Models for Refraction*, eq. 33;
//!   anisotropic form from Heitz 2014, *Understanding the Masking-Shadowing
//!   Function*, eq. 85). Normalized: ∫ D(ĥ) cos θ_h dω_h = 1.
//! * Λ(w) = (−1 + √(1 + (α_x² w_x² + α_y² w_y²)/w_z²)) / 2 (Heitz 2014 eq. 86),
//!   G₁ = 1/(1 + Λ), height-correlated G₂ = 1/(1 + Λ(wo) + Λ(wi)) (Heitz 2014 eq. 99).
//! * F = F₀ + (1 − F₀)(1 − wo·ĥ)⁵ (Schlick 1994), F₀ the RGB reflectance at
//!   normal incidence. F₀ = 1 is a perfect conductor (white furnace).
//! * Sampling: visible normals, Heitz 2018, *Sampling the GGX Distribution
//!   of Visible Normals* (JCGT 7(4)); D_wo(ĥ) = G₁(wo) max(0, wo·ĥ) D(ĥ) / cos θ_o,
//!   so p(wi) = G₁(wo) D(ĥ) / (4 cos θ_o) and the estimator weight
//!   f cos θ_i / p = F G₂ / G₁(wo) ≤ 1.

use crate::error::{check_colour, check_range};
use crate::sampling::{both_above, half_vector, reflect_about_half};
use crate::{Brdf, BrdfError, BrdfSample};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Smallest accepted GGX / Ward roughness α.
pub const MIN_ALPHA: f32 = 1.0e-4;

/// Anisotropic GGX normal distribution D(ĥ) (sr⁻¹ of microfacet normal,
/// projected-area normalized); zero for h_z ≤ 0. `h` unit.
#[inline]
#[must_use]
pub fn ggx_d(h: Vec3, alpha_x: f32, alpha_y: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let t = (h.x / alpha_x).powi(2) + (h.y / alpha_y).powi(2) + h.z * h.z;
    1.0 / (PI * alpha_x * alpha_y * t * t)
}

/// Smith Λ(w) for GGX (Heitz 2014 eq. 86); +∞ at the horizon.
#[inline]
#[must_use]
pub fn ggx_lambda(w: Vec3, alpha_x: f32, alpha_y: f32) -> f32 {
    let z2 = w.z * w.z;
    if z2 <= 0.0 {
        return f32::INFINITY;
    }
    let a2_tan2 = ((alpha_x * w.x).powi(2) + (alpha_y * w.y).powi(2)) / z2;
    0.5 * (-1.0 + (1.0 + a2_tan2).sqrt())
}

/// Smith masking G₁(w) = 1/(1 + Λ(w)).
#[inline]
#[must_use]
pub fn smith_g1(w: Vec3, alpha_x: f32, alpha_y: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(w, alpha_x, alpha_y))
}

/// Height-correlated Smith masking-shadowing G₂ = 1/(1 + Λ(wo) + Λ(wi)).
#[inline]
#[must_use]
pub fn smith_g2_height_correlated(wo: Vec3, wi: Vec3, alpha_x: f32, alpha_y: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(wo, alpha_x, alpha_y) + ggx_lambda(wi, alpha_x, alpha_y))
}

/// Isotropic Beckmann normal distribution D(ĥ) = exp(−tan²θ/α²) / (π α² cos⁴θ)
/// (sr⁻¹ of microfacet normal, projected-area normalized); zero for h_z ≤ 0.
/// `h` unit, α = RMS slope.
#[inline]
#[must_use]
pub fn beckmann_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let c2 = h.z * h.z;
    let tan2 = (1.0 - c2).max(0.0) / c2;
    let a2 = alpha * alpha;
    (-tan2 / a2).exp() / (PI * a2 * c2 * c2)
}

/// Smith Λ(w) for Beckmann, Walter et al. 2007's rational fit of
/// `(erf-based) Λ(a)`, `a = 1/(α tan θ)` (relative error < 0.35 %); 0 for
/// `a ≥ 1.6`, +∞ at the horizon.
#[inline]
#[must_use]
pub fn beckmann_lambda(w: Vec3, alpha: f32) -> f32 {
    let z2 = w.z * w.z;
    if z2 <= 0.0 {
        return f32::INFINITY;
    }
    let tan = ((1.0 - z2).max(0.0) / z2).sqrt();
    if tan == 0.0 {
        return 0.0;
    }
    let a = 1.0 / (alpha * tan);
    if a >= 1.6 {
        return 0.0;
    }
    (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
}

/// Schlick's Fresnel approximation F₀ + (1 − F₀)(1 − cos)⁵.
#[inline]
#[must_use]
pub fn fresnel_schlick(f0: Vec3, cos_theta: f32) -> Vec3 {
    let m = (1.0 - cos_theta.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * m
}

/// Samples a visible GGX normal for `wo` (z > 0) from `u` ∈ [0,1)²
/// (Heitz 2018, listing 1). Density: [`ggx_vndf_pdf`].
#[must_use]
pub fn sample_ggx_vndf(wo: Vec3, alpha_x: f32, alpha_y: f32, u: Vec2) -> Vec3 {
    // Section 3.2: transform the view direction to the hemisphere configuration.
    let vh = Vec3::new(alpha_x * wo.x, alpha_y * wo.y, wo.z).normalize();
    // Section 4.1: orthonormal basis (with special case if cross product is zero).
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    // Section 4.2: parameterization of the projected area.
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * phi.sin());
    // Section 4.3: reprojection onto the hemisphere.
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    // Section 3.4: transform the normal back to the ellipsoid configuration.
    Vec3::new(alpha_x * nh.x, alpha_y * nh.y, nh.z.max(0.0)).normalize()
}

/// Density of [`sample_ggx_vndf`] over microfacet normals:
/// D_wo(ĥ) = G₁(wo) max(0, wo·ĥ) D(ĥ) / cos θ_o.
#[inline]
#[must_use]
pub fn ggx_vndf_pdf(wo: Vec3, h: Vec3, alpha_x: f32, alpha_y: f32) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    smith_g1(wo, alpha_x, alpha_y) * wo.dot(h).max(0.0) * ggx_d(h, alpha_x, alpha_y) / wo.z
}

/// Cook–Torrance with anisotropic GGX, height-correlated Smith G₂ and
/// Schlick Fresnel (see the module docs).
///
/// `alpha_x`, `alpha_y`: GGX roughness α (= perceptual roughness²) along the
/// tangent and bitangent, each in [10⁻⁴, 1]; `f0`: RGB reflectance at normal
/// incidence in [0, 1]³. Reciprocal. Not energy-preserving at high α
/// (single scattering only), so the white-furnace albedo is < 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    alpha_x: f32,
    alpha_y: f32,
    f0: Vec3,
}

impl Ggx {
    /// Anisotropic GGX; α ∈ [10⁻⁴, 1] each, `f0` ∈ [0, 1]³.
    pub fn new(alpha_x: f32, alpha_y: f32, f0: Vec3) -> Result<Self, BrdfError> {
        const EXPECTED: &str = "roughness α in [1e-4, 1]";
        Ok(Self {
            alpha_x: check_range("ggx", "alpha_x", alpha_x, MIN_ALPHA, 1.0, EXPECTED)?,
            alpha_y: check_range("ggx", "alpha_y", alpha_y, MIN_ALPHA, 1.0, EXPECTED)?,
            f0: check_colour("ggx", "f0", f0)?,
        })
    }
    /// Isotropic GGX with roughness `alpha` ∈ [10⁻⁴, 1].
    pub fn isotropic(alpha: f32, f0: Vec3) -> Result<Self, BrdfError> {
        Self::new(alpha, alpha, f0)
    }
    /// Roughness (α_x, α_y).
    #[must_use]
    pub fn alpha(&self) -> (f32, f32) {
        (self.alpha_x, self.alpha_y)
    }
    /// Reflectance at normal incidence F₀.
    #[must_use]
    pub fn f0(&self) -> Vec3 {
        self.f0
    }
    /// The distribution D(ĥ) of this model.
    #[must_use]
    pub fn d(&self, h: Vec3) -> f32 {
        ggx_d(h, self.alpha_x, self.alpha_y)
    }
}

impl Brdf for Ggx {
    fn label(&self) -> String {
        crate::BrdfSpec::Ggx(*self).to_string()
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !both_above(wo, wi) {
            return Vec3::ZERO;
        }
        let Some(h) = half_vector(wo, wi) else {
            return Vec3::ZERO;
        };
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let d = ggx_d(h, ax, ay);
        let g = smith_g2_height_correlated(wo, wi, ax, ay);
        fresnel_schlick(self.f0, wo.dot(h)) * (d * g / (4.0 * wo.z * wi.z))
    }
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let h = sample_ggx_vndf(wo, self.alpha_x, self.alpha_y, u);
        let wi = reflect_about_half(wo, h)?;
        BrdfSample::at(self, wo, wi)
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !both_above(wo, wi) {
            return 0.0;
        }
        let Some(h) = half_vector(wo, wi) else {
            return 0.0;
        };
        // D_wo(h) / (4 wo·h) = G1(wo) D(h) / (4 cos θ_o).
        smith_g1(wo, self.alpha_x, self.alpha_y) * ggx_d(h, self.alpha_x, self.alpha_y)
            / (4.0 * wo.z)
    }
}
