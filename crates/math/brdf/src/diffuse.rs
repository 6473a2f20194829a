//! Diffuse models: [`Lambert`] and [`OrenNayar`]. Both are sampled with the
//! cosine-weighted hemisphere, density cos θ_i / π, which never fails while
//! `wo` is above the horizon.

use crate::error::{check_colour, check_range};
use crate::sampling::{both_above, cosine_hemisphere_pdf, sample_cosine_hemisphere};
use crate::{Brdf, BrdfError, BrdfSample};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2};

/// Cosine-sampling shared by the diffuse models (and MERL).
#[inline]
pub(crate) fn sample_cosine(brdf: &dyn Brdf, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let wi = sample_cosine_hemisphere(u);
    if wi.z <= 0.0 {
        return None;
    }
    Some(BrdfSample {
        wi,
        f: brdf.eval(wo, wi),
        pdf: cosine_hemisphere_pdf(wi.z),
    })
}

/// Density of [`sample_cosine`].
#[inline]
pub(crate) fn cosine_pdf(wo: Vec3, wi: Vec3) -> f32 {
    if both_above(wo, wi) {
        cosine_hemisphere_pdf(wi.z)
    } else {
        0.0
    }
}

/// Lambertian reflection: f = ρ / π.
///
/// `albedo` ρ is the RGB directional-hemispherical reflectance, each channel
/// in [0, 1]; the directional albedo is exactly ρ for every `wo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    albedo: Vec3,
}

impl Lambert {
    /// A Lambertian BRDF with RGB `albedo` ∈ [0, 1]³.
    pub fn new(albedo: Vec3) -> Result<Self, BrdfError> {
        Ok(Self {
            albedo: check_colour("lambert", "albedo", albedo)?,
        })
    }
    /// The RGB albedo ρ.
    #[must_use]
    pub fn albedo(&self) -> Vec3 {
        self.albedo
    }
}

impl Brdf for Lambert {
    fn label(&self) -> String {
        crate::BrdfSpec::Lambert(*self).to_string()
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if both_above(wo, wi) {
            self.albedo * FRAC_1_PI
        } else {
            Vec3::ZERO
        }
    }
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        sample_cosine(self, wo, u)
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        cosine_pdf(wo, wi)
    }
}

/// Oren–Nayar rough diffuse reflection, the "qualitative" model of
/// Oren & Nayar, *Generalization of Lambert's Reflectance Model*
/// (SIGGRAPH 1994, eq. 30):
///
/// f = ρ/π · (A + B · max(0, cos(φ_i − φ_o)) · sin α · tan β),
/// A = 1 − σ²/(2(σ² + 0.33)), B = 0.45 σ²/(σ² + 0.09),
/// α = max(θ_i, θ_o), β = min(θ_i, θ_o).
///
/// `sigma` σ is the standard deviation of the microfacet slope angle in
/// **radians**, [0, π/2] (σ = 0 is Lambert). `albedo` ρ ∈ [0, 1]³.
/// Reciprocal. Sampled with the cosine-weighted hemisphere.
///
/// **Energy:** the qualitative model drops a term of the full model and is
/// not exactly energy-conserving: with white ρ its directional albedo
/// reaches ≈ 1.016 near grazing incidence for σ ≈ 0.2 (quadrature, in the
/// tests); for σ ≥ 0.5 it stays below 0.96.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrenNayar {
    sigma: f32,
    albedo: Vec3,
    a: f32,
    b: f32,
}

impl OrenNayar {
    /// Oren–Nayar with slope deviation `sigma` (radians, [0, π/2]) and RGB `albedo` ∈ [0, 1]³.
    pub fn new(sigma: f32, albedo: Vec3) -> Result<Self, BrdfError> {
        let sigma = check_range(
            "oren-nayar",
            "sigma",
            sigma,
            0.0,
            FRAC_PI_2,
            "radians in [0, π/2] (20° = 0.349 rad)",
        )?;
        let albedo = check_colour("oren-nayar", "albedo", albedo)?;
        let s2 = sigma * sigma;
        Ok(Self {
            sigma,
            albedo,
            a: 1.0 - s2 / (2.0 * (s2 + 0.33)),
            b: 0.45 * s2 / (s2 + 0.09),
        })
    }
    /// Slope-angle deviation σ in radians.
    #[must_use]
    pub fn sigma(&self) -> f32 {
        self.sigma
    }
    /// The RGB albedo ρ.
    #[must_use]
    pub fn albedo(&self) -> Vec3 {
        self.albedo
    }
}

impl Brdf for OrenNayar {
    fn label(&self) -> String {
        crate::BrdfSpec::OrenNayar(*self).to_string()
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !both_above(wo, wi) {
            return Vec3::ZERO;
        }
        let sin_i = (1.0 - wi.z * wi.z).max(0.0).sqrt();
        let sin_o = (1.0 - wo.z * wo.z).max(0.0).sqrt();
        // cos(φ_i − φ_o) · sin θ_i sin θ_o = projected dot product.
        let max_cos = if sin_i > 1e-4 && sin_o > 1e-4 {
            ((wi.x * wo.x + wi.y * wo.y) / (sin_i * sin_o)).max(0.0)
        } else {
            0.0
        };
        let (sin_alpha, tan_beta) = if wi.z > wo.z {
            (sin_o, sin_i / wi.z)
        } else {
            (sin_i, sin_o / wo.z)
        };
        self.albedo * (FRAC_1_PI * (self.a + self.b * max_cos * sin_alpha * tan_beta))
    }
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        sample_cosine(self, wo, u)
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        cosine_pdf(wo, wi)
    }
}
