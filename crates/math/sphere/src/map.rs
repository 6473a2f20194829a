//! [`EnvMap`]: RGB radiance (or any spherical RGB function) stored on a [`Param`].

use crate::param::Param;
use glam::Vec3;

/// An RGB function on the sphere, one linear `Vec3` per texel of `param`.
///
/// Radiance units are whatever the source file used (relight treats them as
/// W·sr⁻¹·m⁻² up to a constant).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    pub param: Param,
    /// `param.len()` texels in texel order.
    pub texels: Vec<Vec3>,
}

impl EnvMap {
    /// A map from texels; `None` when the count does not match `param`.
    #[must_use]
    pub fn try_new(param: Param, texels: Vec<Vec3>) -> Option<Self> {
        (texels.len() == param.len()).then_some(Self { param, texels })
    }

    /// The map with every texel `f(direction)`.
    #[must_use]
    pub fn from_fn(param: Param, f: impl Fn(Vec3) -> Vec3 + Sync) -> Self {
        let texels = (0..param.len()).map(|i| f(param.dir_from_texel(i))).collect();
        Self { param, texels }
    }

    /// Bilinearly interpolated value in direction `d`.
    #[must_use]
    pub fn eval(&self, d: Vec3) -> Vec3 {
        let b = self.param.bilinear(d);
        (0..4).map(|k| self.texels[b.texels[k] as usize] * b.weights[k]).sum()
    }

    /// Area-correct resampling onto another parameterization: each target
    /// texel is the solid-angle-weighted mean of `supersample²` bilinear
    /// lookups spread over the target texel.
    #[must_use]
    pub fn resample(&self, target: Param, supersample: usize) -> EnvMap {
        let _ = (target, supersample);
        todo!()
    }

    /// ∫ L dω per channel (sum of texel × exact solid angle).
    #[must_use]
    pub fn integral(&self) -> Vec3 {
        todo!()
    }

    /// The map rotated: `out(d) = self(rot⁻¹ d)` (a rotation `world_from_old` of the lighting).
    #[must_use]
    pub fn rotated(&self, world_from_old: glam::Mat3, supersample: usize) -> EnvMap {
        let _ = (world_from_old, supersample);
        todo!()
    }
}
