//! Phong-family lobes: the energy-normalized [`Phong`] (about the mirror
//! direction) and the normalized [`BlinnPhong`] (about the normal, in the
//! half vector).

use crate::error::{check_colour, check_range};
use crate::sampling::{
    both_above, from_axis_frame, half_to_incident_pdf, half_vector, mirror, power_cosine_pdf,
    reflect_about_half, sample_power_cosine,
};
use crate::{Brdf, BrdfError, BrdfSample};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Largest accepted Phong / Blinn–Phong exponent.
pub const MAX_EXPONENT: f32 = 1.0e6;

/// Normalized (modified) Phong: f = ρ_s · (n+2)/(2π) · max(0, r·wi)ⁿ, with
/// r = mirror(wo) the reflection of `wo` about the normal
/// (Lafortune & Willems 1994, *Using the modified Phong reflectance model
/// for physically based rendering*). The (n+2)/(2π) factor makes the
/// directional albedo exactly ρ_s at normal incidence and less elsewhere.
///
/// `exponent` n ∈ [0, 10⁶]; `colour` ρ_s ∈ [0, 1]³. Reciprocal
/// (r·wi = mirror(wi)·wo). Sampling: the (n+1)/(2π) cosⁿ lobe about r;
/// lobe directions below the horizon are rejected (`None`), so the pdf
/// integrates to the acceptance rate, ≤ 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phong {
    exponent: f32,
    colour: Vec3,
}

impl Phong {
    /// Normalized Phong with `exponent` n ∈ [0, 10⁶] and specular `colour` ρ_s ∈ [0, 1]³.
    pub fn new(exponent: f32, colour: Vec3) -> Result<Self, BrdfError> {
        Ok(Self {
            exponent: check_range("phong", "exponent", exponent, 0.0, MAX_EXPONENT, "[0, 1e6]")?,
            colour: check_colour("phong", "colour", colour)?,
        })
    }
    /// The exponent n.
    #[must_use]
    pub fn exponent(&self) -> f32 {
        self.exponent
    }
    /// The specular reflectance ρ_s.
    #[must_use]
    pub fn colour(&self) -> Vec3 {
        self.colour
    }
}

impl Brdf for Phong {
    fn label(&self) -> String {
        crate::BrdfSpec::Phong(*self).to_string()
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !both_above(wo, wi) {
            return Vec3::ZERO;
        }
        let c = mirror(wo).dot(wi);
        if c <= 0.0 {
            return Vec3::ZERO;
        }
        self.colour * ((self.exponent + 2.0) / (2.0 * PI) * c.powf(self.exponent))
    }
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = from_axis_frame(mirror(wo), sample_power_cosine(u, self.exponent)).normalize();
        if wi.z <= 0.0 {
            return None;
        }
        Some(BrdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf: self.pdf(wo, wi),
        })
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !both_above(wo, wi) {
            return 0.0;
        }
        power_cosine_pdf(mirror(wo).dot(wi), self.exponent)
    }
}

/// Normalization of the Blinn–Phong lobe cosⁿ θ_h so that the directional
/// albedo at normal incidence is exactly 1:
/// c_n = (n+2)(n+4) / (8π (2^{−n/2} + n)).
///
/// Derivation: with wo = +Z, θ_h = θ_i/2 and
/// ∫ cosⁿ(θ_i/2) cos θ_i dω_i = 8π (n + 2^{−n/2}) / ((n+2)(n+4)).
#[must_use]
pub fn blinn_phong_normalization(exponent: f32) -> f32 {
    let n = exponent as f64;
    ((n + 2.0) * (n + 4.0) / (8.0 * std::f64::consts::PI * ((-n / 2.0).exp2() + n))) as f32
}

/// Normalized Blinn–Phong: f = ρ_s · c_n · cosⁿ θ_h, ĥ the half vector,
/// c_n = [`blinn_phong_normalization`] (exact, not the (n+8)/(8π)
/// approximation), so the directional albedo is ρ_s at normal incidence and
/// falls towards grazing.
///
/// `exponent` n ∈ [0, 10⁶]; `colour` ρ_s ∈ [0, 1]³. Reciprocal. Sampling:
/// ĥ from the (n+1)/(2π) cosⁿ θ_h lobe about +Z, wi = reflect(wo, ĥ), density
/// p_h / (4 wo·ĥ); reflections below the horizon are rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlinnPhong {
    exponent: f32,
    colour: Vec3,
    norm: f32,
}

impl BlinnPhong {
    /// Normalized Blinn–Phong with `exponent` n ∈ [0, 10⁶] and `colour` ρ_s ∈ [0, 1]³.
    pub fn new(exponent: f32, colour: Vec3) -> Result<Self, BrdfError> {
        let exponent = check_range("blinn", "exponent", exponent, 0.0, MAX_EXPONENT, "[0, 1e6]")?;
        Ok(Self {
            exponent,
            colour: check_colour("blinn", "colour", colour)?,
            norm: blinn_phong_normalization(exponent),
        })
    }
    /// The exponent n.
    #[must_use]
    pub fn exponent(&self) -> f32 {
        self.exponent
    }
    /// The specular reflectance ρ_s.
    #[must_use]
    pub fn colour(&self) -> Vec3 {
        self.colour
    }
}

impl Brdf for BlinnPhong {
    fn label(&self) -> String {
        crate::BrdfSpec::BlinnPhong(*self).to_string()
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !both_above(wo, wi) {
            return Vec3::ZERO;
        }
        match half_vector(wo, wi) {
            Some(h) => self.colour * (self.norm * h.z.max(0.0).powf(self.exponent)),
            None => Vec3::ZERO,
        }
    }
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = reflect_about_half(wo, sample_power_cosine(u, self.exponent))?;
        Some(BrdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf: self.pdf(wo, wi),
        })
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !both_above(wo, wi) {
            return 0.0;
        }
        match half_vector(wo, wi) {
            Some(h) => half_to_incident_pdf(power_cosine_pdf(h.z, self.exponent), wo.dot(h)),
            None => 0.0,
        }
    }
}
