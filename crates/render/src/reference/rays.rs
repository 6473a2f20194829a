//! Radiance samples along caller-given rays ([`RaySampler`]): the estimator
//! behind every reference pixel, for judges that need one ray per sample
//! rather than jittered pixels (`relight verify fog` compares the analytic
//! airlight at pixel centres). There is one judge: these are the same
//! paths [`render_reference`](super::render_reference) traces.

use super::integrator::Tracer;
use super::lights::{EnvLight, Lights};
use super::render::validate;
use super::{ReferenceError, ReferenceOptions};
use crate::Scene;
use crate::bvh::SceneBvh;
use crate::sampling::Rng;
use glam::Vec3;

/// One radiance sample at a time along any ray of one scene (built by
/// [`with_ray_sampler`]).
#[derive(Clone, Copy)]
pub struct RaySampler<'a> {
    scene: &'a Scene,
    tracer: Tracer<'a>,
}

impl RaySampler<'_> {
    /// One sample of the radiance arriving at `o` from direction `−d` (`d`
    /// unit: the ray `o + t d`), as a reference camera ray estimates it:
    /// emission seen, the medium's in-scattering, the first surface's light.
    #[must_use]
    pub fn sample(&self, o: Vec3, d: Vec3, rng: &mut Rng) -> Vec3 {
        let mut rays = 0;
        self.tracer.camera_sample(self.scene, o, d, rng, &mut rays)
    }
}

/// Builds the reference's BVH and lights for `scene` (checked as
/// [`render_reference`](super::render_reference) checks it, with `opts`'
/// medium mode, light sampling and environment filter) and hands `f` a
/// sampler of it.
///
/// # Errors
/// As [`render_reference`](super::render_reference) for a bad scene or
/// options.
pub fn with_ray_sampler<R>(
    scene: &Scene,
    opts: &ReferenceOptions,
    f: impl FnOnce(&RaySampler) -> R,
) -> Result<R, ReferenceError> {
    validate(scene, &scene.camera, opts)?;
    let bvh = SceneBvh::from_scene(scene);
    let light = EnvLight::new(&scene.env, opts.env_filter);
    let tracer = Tracer::new(scene, &bvh, Lights::new(scene, &light), opts);
    Ok(f(&RaySampler { scene, tracer }))
}
