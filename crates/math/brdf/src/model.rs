//! The [`Brdf`] trait.

use glam::{Vec2, Vec3};

/// One importance sample of a BRDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrdfSample {
    /// Sampled incident direction (local frame, unit).
    pub wi: Vec3,
    /// f(wo, wi), RGB, without cosine.
    pub f: Vec3,
    /// Solid-angle pdf of `wi`.
    pub pdf: f32,
}

impl BrdfSample {
    /// The sample of `brdf` at a direction `wi` already drawn by some
    /// strategy: f(wo, wi) and the model's full [`Brdf::pdf`] (so mixtures and
    /// one-sided strategies report the density of the whole sampler). `None`
    /// where that density is zero.
    #[inline]
    #[must_use]
    pub fn at<B: Brdf + ?Sized>(brdf: &B, wo: Vec3, wi: Vec3) -> Option<Self> {
        let pdf = brdf.pdf(wo, wi);
        (pdf > 0.0).then(|| Self {
            wi,
            f: brdf.eval(wo, wi),
            pdf,
        })
    }
}

/// A reflectance model in the local shading frame (see the crate docs).
pub trait Brdf: Send + Sync + std::fmt::Debug {
    /// f(wo, wi) in sr⁻¹, RGB, without cosine; zero when either is below the horizon.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;
    /// Draws wi with density roughly ∝ f · cos from the uniform `u` ∈ [0,1)².
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample>;
    /// Solid-angle density of [`Brdf::sample`] producing `wi`.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
    /// A short text naming the model and every parameter, in the spec syntax
    /// of [`crate::BrdfSpec`] where the model has one (`phong:40`,
    /// `lambert@0.25,0.2,0.3`, `0.5*lambert+0.5*ggx:0.2`). Two BRDFs with the
    /// same label evaluate the same, so baked tables are cached under it
    /// (`relight cache list` shows it). The default is the `Debug` text.
    fn label(&self) -> String {
        format!("{self:?}")
    }
}
