//! The Ashikhmin–Shirley anisotropic Phong model (Ashikhmin & Shirley,
//! *An Anisotropic Phong BRDF Model*, JGT 5(2), 2000).
//!
//! Specular term (eq. 4), with ĥ the half vector, e(φ_h) = n_u cos²φ_h + n_v sin²φ_h:
//!
//! ρ_s = √((n_u+1)(n_v+1)) / (8π) · cos θ_h^{e(φ_h)} / ((wo·ĥ) max(cos θ_i, cos θ_o)) · F(wo·ĥ),
//! F = R_s + (1 − R_s)(1 − wo·ĥ)⁵.
//!
//! Diffuse term (eq. 5):
//! ρ_d = 28 R_d / (23π) · (1 − R_s) · (1 − (1 − cos θ_i/2)⁵) · (1 − (1 − cos θ_o/2)⁵).
//!
//! Sampling (eq. 9–10): the specular part draws ĥ with density
//! p_h = √((n_u+1)(n_v+1))/(2π) · cos θ_h^{e(φ_h)} (exact: its integral is 1) via
//! φ_h = atan2(√(n_u+1) sin 2πu, √(n_v+1) cos 2πu), cos θ_h = (1−u')^{1/(e+1)},
//! then wi = reflect(wo, ĥ) with density p_h / (4 wo·ĥ); the diffuse part draws
//! the cosine hemisphere. The two are mixed with probabilities from mean R_s
//! versus mean R_d (1 − R_s), clamped to [0.25, 0.75] when both lobes are present.

use crate::error::{check_colour, check_range};
use crate::sampling::{
    both_above, cosine_hemisphere_pdf, half_to_incident_pdf, half_vector, mean, reflect_about_half,
    sample_cosine_hemisphere,
};
use crate::{Brdf, BrdfError, BrdfSample};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Largest accepted Ashikhmin–Shirley exponent.
pub const MAX_AS_EXPONENT: f32 = 1.0e6;

/// Ashikhmin–Shirley anisotropic Phong with its diffuse term (module docs).
///
/// `nu`, `nv`: Phong exponents along tangent / bitangent, each in [0, 10⁶];
/// `rd`: diffuse reflectance R_d ∈ [0, 1]³; `rs`: specular reflectance at
/// normal incidence R_s ∈ [0, 1]³. Reciprocal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AshikhminShirley {
    nu: f32,
    nv: f32,
    rd: Vec3,
    rs: Vec3,
    /// Probability of sampling the specular lobe.
    spec_prob: f32,
}

impl AshikhminShirley {
    /// Default specular reflectance used by the spec syntax when omitted.
    pub const DEFAULT_RS: f32 = 0.04;

    /// Ashikhmin–Shirley with exponents `nu`, `nv` ∈ [0, 10⁶], diffuse `rd`
    /// and specular `rs` reflectances ∈ [0, 1]³.
    pub fn new(nu: f32, nv: f32, rd: Vec3, rs: Vec3) -> Result<Self, BrdfError> {
        const EXPECTED: &str = "[0, 1e6]";
        let nu = check_range("ashikhmin", "nu", nu, 0.0, MAX_AS_EXPONENT, EXPECTED)?;
        let nv = check_range("ashikhmin", "nv", nv, 0.0, MAX_AS_EXPONENT, EXPECTED)?;
        let rd = check_colour("ashikhmin", "rd", rd)?;
        let rs = check_colour("ashikhmin", "rs", rs)?;
        let ws = mean(rs);
        let wd = mean(rd * (Vec3::ONE - rs));
        let spec_prob = if wd <= 0.0 {
            1.0
        } else if ws <= 0.0 {
            0.0
        } else {
            (ws / (ws + wd)).clamp(0.25, 0.75)
        };
        Ok(Self {
            nu,
            nv,
            rd,
            rs,
            spec_prob,
        })
    }
    /// Exponents (n_u, n_v).
    #[must_use]
    pub fn exponents(&self) -> (f32, f32) {
        (self.nu, self.nv)
    }
    /// Diffuse reflectance R_d.
    #[must_use]
    pub fn rd(&self) -> Vec3 {
        self.rd
    }
    /// Specular reflectance R_s.
    #[must_use]
    pub fn rs(&self) -> Vec3 {
        self.rs
    }

    #[inline]
    fn norm(&self) -> f32 {
        ((self.nu + 1.0) * (self.nv + 1.0)).sqrt()
    }

    /// cos θ_h^{e(φ_h)} for unit ĥ.
    #[inline]
    fn lobe(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let s2 = 1.0 - h.z * h.z;
        if s2 <= 1e-12 {
            return 1.0;
        }
        let e = (self.nu * h.x * h.x + self.nv * h.y * h.y) / s2;
        h.z.powf(e)
    }

    /// Density of the half-vector warp: √((n_u+1)(n_v+1))/(2π) · cos θ_h^{e(φ_h)}.
    #[must_use]
    pub fn half_pdf(&self, h: Vec3) -> f32 {
        self.norm() / (2.0 * PI) * self.lobe(h)
    }

    /// Samples ĥ with density [`AshikhminShirley::half_pdf`].
    #[must_use]
    pub fn sample_half(&self, u: Vec2) -> Vec3 {
        let t = 2.0 * PI * u.x;
        let phi = ((self.nu + 1.0).sqrt() * t.sin()).atan2((self.nv + 1.0).sqrt() * t.cos());
        let (s, c) = phi.sin_cos();
        let e = self.nu * c * c + self.nv * s * s;
        let cos_theta = (1.0 - u.y).powf(1.0 / (e + 1.0));
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        Vec3::new(sin_theta * c, sin_theta * s, cos_theta)
    }
}

impl Brdf for AshikhminShirley {
    fn label(&self) -> String {
        crate::BrdfSpec::AshikhminShirley(*self).to_string()
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !both_above(wo, wi) {
            return Vec3::ZERO;
        }
        let p = |c: f32| 1.0 - (1.0 - 0.5 * c).powi(5);
        let diffuse = self.rd * (Vec3::ONE - self.rs) * (28.0 / (23.0 * PI) * p(wi.z) * p(wo.z));
        let Some(h) = half_vector(wo, wi) else {
            return diffuse;
        };
        let k_h = wo.dot(h);
        if k_h <= 0.0 {
            return diffuse;
        }
        let fresnel = self.rs + (Vec3::ONE - self.rs) * (1.0 - k_h).powi(5);
        let spec = self.norm() / (8.0 * PI) * self.lobe(h) / (k_h * wi.z.max(wo.z));
        diffuse + fresnel * spec
    }
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u.x < self.spec_prob {
            let u = Vec2::new(u.x / self.spec_prob, u.y);
            reflect_about_half(wo, self.sample_half(u))?
        } else {
            let u = Vec2::new((u.x - self.spec_prob) / (1.0 - self.spec_prob), u.y);
            let wi = sample_cosine_hemisphere(u.min(Vec2::splat(1.0 - f32::EPSILON)));
            if wi.z <= 0.0 {
                return None;
            }
            wi
        };
        BrdfSample::at(self, wo, wi)
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !both_above(wo, wi) {
            return 0.0;
        }
        let spec = match half_vector(wo, wi) {
            Some(h) => half_to_incident_pdf(self.half_pdf(h), wo.dot(h)),
            None => 0.0,
        };
        self.spec_prob * spec + (1.0 - self.spec_prob) * cosine_hemisphere_pdf(wi.z)
    }
}
