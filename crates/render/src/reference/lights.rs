//! The scene's lights as the estimators see them: the environment (rotated
//! into the world by `world_from_env`, importance-sampled by luminance), the
//! point lights (deltas) and the one-sided rectangular area lights (sampled
//! uniformly by area).
//!
//! # Densities
//! * Environment: [`EnvSampler`] draws a direction in the map's own frame
//!   with an exact solid-angle density; a rotation preserves solid angle, so
//!   the world direction `world_from_env · ω` has the same density.
//! * Area light of area `A`: a point `y` uniform on the rectangle (uv
//!   uniform in [0, 1]², [`AreaLight::point_at`]) seen from `x` at distance
//!   `r` along `ω` has the solid-angle density `r² / (A · cos θ_y)`, with
//!   `cos θ_y = −ω·ẑ > 0` on the emitting side (zero density behind it,
//!   where it emits nothing).

use crate::sampling::{EnvFilter, EnvSample, EnvSampler};
use crate::{AreaLight, PointLight, Scene};
use glam::{Mat3, Vec2, Vec3};
use relight_sphere::EnvMap;

/// The environment as a light: the map, its luminance sampler and the filter
/// used to read it, in the map's own frame. Build once per map; cheap to
/// share across threads.
#[derive(Clone, Debug)]
pub struct EnvLight<'a> {
    pub env: &'a EnvMap,
    pub sampler: EnvSampler,
    pub filter: EnvFilter,
}

impl<'a> EnvLight<'a> {
    /// Builds the luminance sampler of `env`.
    #[must_use]
    pub fn new(env: &'a EnvMap, filter: EnvFilter) -> Self {
        Self {
            env,
            sampler: EnvSampler::new(env),
            filter,
        }
    }

    /// Radiance arriving from direction `d` (unit, the map's frame).
    #[inline]
    #[must_use]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.sampler.radiance(self.env, d, self.filter)
    }
}

/// A light sample seen from a point: direction, distance, radiance (or, for a
/// point light, irradiance at normal incidence) and solid-angle density
/// (`f32::INFINITY` for a delta).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LightSample {
    /// World direction towards the light (unit).
    pub wi: Vec3,
    /// Distance to the light (`f32::INFINITY` for the environment).
    pub dist: f32,
    /// Radiance arriving (area, environment) or `I / r²` (point light).
    pub value: Vec3,
    /// Solid-angle density of `wi` (infinite for a point light).
    pub pdf: f32,
}

/// Every light of a scene, ready to sample from a world point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lights<'a> {
    pub env: &'a EnvLight<'a>,
    pub world_from_env: Mat3,
    pub env_from_world: Mat3,
    pub points: &'a [PointLight],
    pub areas: &'a [AreaLight],
}

impl<'a> Lights<'a> {
    pub fn new(scene: &'a Scene, env: &'a EnvLight<'a>) -> Self {
        Self {
            env,
            world_from_env: scene.world_from_env,
            env_from_world: scene.world_from_env.transpose(),
            points: &scene.point_lights,
            areas: &scene.area_lights,
        }
    }

    /// An environment sample from `(u_texel, u_pos)`; `None` for a black map.
    #[inline]
    pub fn sample_env(&self, u_texel: f64, u_pos: Vec2) -> Option<LightSample> {
        let s: EnvSample = self.env.sampler.sample(u_texel, u_pos)?;
        (s.pdf > 0.0).then(|| LightSample {
            wi: (self.world_from_env * s.wi).normalize(),
            dist: f32::INFINITY,
            value: self
                .env
                .sampler
                .sample_radiance(self.env.env, &s, self.env.filter),
            pdf: s.pdf,
        })
    }

    /// Shading radiance of the environment from world direction `d` and the
    /// density with which [`Lights::sample_env`] draws it.
    #[inline]
    pub fn env_radiance_and_pdf(&self, d: Vec3) -> (Vec3, f32) {
        self.env
            .sampler
            .radiance_and_pdf(self.env.env, self.env_from_world * d, self.env.filter)
    }

    /// True when the environment holds light to sample.
    #[inline]
    pub fn has_env(&self) -> bool {
        !self.env.sampler.is_black()
    }
}

/// The connection from `x` to point light `l`: `I / r²` along the unit
/// direction; `None` when `x` sits on the light.
#[inline]
pub(crate) fn point_light_sample(l: &PointLight, x: Vec3) -> Option<LightSample> {
    let v = l.position - x;
    let r2 = v.length_squared();
    if !(r2 > 0.0 && r2.is_finite()) {
        return None;
    }
    let r = r2.sqrt();
    Some(LightSample {
        wi: v / r,
        dist: r,
        value: l.intensity / r2,
        pdf: f32::INFINITY,
    })
}

/// A point uniform by area on `l` (from `u`), seen from `x`; `None` when `x`
/// is behind the emitting side or on the light.
#[inline]
pub(crate) fn area_light_sample(l: &AreaLight, x: Vec3, u: Vec2) -> Option<LightSample> {
    let y = l.point_at(u);
    let v = y - x;
    let r2 = v.length_squared();
    if !(r2 > 0.0 && r2.is_finite()) {
        return None;
    }
    let r = r2.sqrt();
    let wi = v / r;
    let cos_l = -wi.dot(l.normal());
    if cos_l <= 0.0 {
        return None;
    }
    Some(LightSample {
        wi,
        dist: r,
        value: l.radiance(u, wi),
        pdf: r2 / (l.area() * cos_l),
    })
}

/// Density of [`area_light_sample`] for the direction `wi` that reaches `l`
/// at distance `t` (its front side), per steradian; 0 from behind.
#[inline]
pub(crate) fn area_light_pdf(l: &AreaLight, wi: Vec3, t: f32) -> f32 {
    let cos_l = -wi.dot(l.normal());
    if cos_l <= 0.0 {
        0.0
    } else {
        t * t / (l.area() * cos_l)
    }
}
