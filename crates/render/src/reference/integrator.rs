//! Paths from the eye: the radiance of one camera ray, in either medium mode.
//!
//! # Structure of a path
//! A path is a chain of segments. The camera segment runs from the eye to
//! the first object (objects always block camera rays) or to infinity; every
//! later segment starts at a scattering vertex and runs to the first
//! occluder (with visibility; without, to infinity). On each segment:
//!
//! 1. the light scattered into it once ([`inscatter`]) is the contribution of
//!    the paths whose last vertex is a medium vertex on this segment;
//! 2. the camera segment alone adds the emission it sees: the front sides of
//!    the area lights it crosses and, when it leaves the scene, the
//!    environment (bilinear, [`Scene::env_radiance`](crate::Scene::env_radiance)), each times the
//!    transmittance;
//! 3. at the surface the segment ends on, [`direct_light`] adds the paths
//!    ending eye→…→surface→light.
//!
//! **Single scattering** stops after the camera segment, the surface's
//! direct light (times `T(eye, surface)`) and one BRDF-sampled segment from
//! the surface whose in-scattered light gives eye→surface→medium→light.
//!
//! **Multiple scattering** continues: analogue free flight on the segment's
//! part inside the ball (scatter at `t ~ β e^{−β t}`; reaching the segment's
//! end has probability `T`, which stands for the transmittance) with
//! throughput × albedo and a new direction from the isotropic phase function;
//! or, at the path's first surface, a BRDF sample (throughput × `f cos / pdf`).
//! A later surface ends the path (one surface vertex). From the
//! [`ROULETTE_START`]-th vertex on, Russian roulette lets a path survive
//! each vertex with probability `q = min(max throughput, ROULETTE_MAX_SURVIVAL)`
//! and divides its throughput by `q` (unbiased); nothing caps the number of
//! scattering events. The survival cap below 1 ends even a throughput-1 path
//! (albedo 1) after about 100 vertices on average: without it the mean order
//! grows like `T²` at albedo 1, 2,500 vertices per path at `T = 50`.

use super::lights::Lights;
use super::medium::{ball_segment, inscatter, transmittance};
use super::surface::{direct_light, surface_vertex};
use super::{LightSampling, MediumMode, ReferenceOptions, WaveletLights};
use crate::bvh::{Hit, SceneBvh};
use crate::sampling::{Rng, sample_uniform_sphere};
use crate::{Medium, Object, Scene};
use glam::Vec3;

/// Everything a path needs, shared by every sample.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tracer<'a> {
    pub objects: &'a [Object],
    /// All objects (camera rays always see them).
    pub bvh: &'a SceneBvh<'a>,
    /// Objects block light and scattered rays ([`Scene::visibility`]).
    pub occlude: bool,
    pub lights: Lights<'a>,
    /// The medium, when it has any extinction.
    pub medium: Option<Medium>,
    pub mode: MediumMode,
    pub light_sampling: LightSampling,
    /// The area lights' grids for [`LightSampling::Wavelet`] (`None`: that
    /// strategy falls back to plain MIS).
    pub wavelet: Option<&'a WaveletLights>,
}

impl<'a> Tracer<'a> {
    pub fn new(
        scene: &'a Scene,
        bvh: &'a SceneBvh<'a>,
        lights: Lights<'a>,
        opts: &ReferenceOptions,
    ) -> Self {
        Self {
            objects: &scene.objects,
            bvh,
            occlude: scene.visibility,
            lights,
            medium: scene.medium.filter(|m| m.beta > 0.0),
            mode: opts.medium_mode,
            light_sampling: opts.light_sampling,
            wavelet: None,
        }
    }

    /// This tracer with the area lights' grids for [`LightSampling::Wavelet`].
    #[must_use]
    pub fn with_wavelet(self, wavelet: Option<&'a WaveletLights>) -> Self {
        Self { wavelet, ..self }
    }

    /// True when nothing blocks `o + t d`, `0 < t < len` (always without
    /// visibility). Counts the shadow ray.
    #[inline]
    pub fn unoccluded(&self, o: Vec3, d: Vec3, len: f32, rays: &mut u64) -> bool {
        if !self.occlude {
            return true;
        }
        *rays += 1;
        !self.bvh.occluded(o, d, len)
    }

    /// The first occluder along a scattered ray (`None` without visibility).
    #[inline]
    pub fn secondary_hit(&self, o: Vec3, d: Vec3, rays: &mut u64) -> Option<Hit> {
        if !self.occlude {
            return None;
        }
        *rays += 1;
        self.bvh.intersect(o, d, 0.0, f32::INFINITY)
    }

    /// Medium transmittance of `o + t d`, `0 ≤ t < len` (1 without medium).
    #[inline]
    pub fn transmittance(&self, o: Vec3, d: Vec3, len: f32) -> f32 {
        self.medium.map_or(1.0, |m| transmittance(&m, o, d, len))
    }

    /// Emission of every area light crossed by `o + t d`, `0 < t < t_end`,
    /// seen from its front side, times the transmittance.
    pub(crate) fn area_emission(&self, o: Vec3, d: Vec3, t_end: f32) -> Vec3 {
        let mut l = Vec3::ZERO;
        for a in self.lights.areas {
            if let Some((t, uv)) = a.intersect(o, d, 0.0)
                && t < t_end
                && d.dot(a.normal()) < 0.0
            {
                l += a.radiance(uv, d) * self.transmittance(o, d, t);
            }
        }
        l
    }

    /// One radiance sample along the camera ray `o + t d` (unit `d`) of
    /// `scene`. Adds the rays traced to `rays`.
    pub fn camera_sample(
        &self,
        scene: &Scene,
        o: Vec3,
        d: Vec3,
        rng: &mut Rng,
        rays: &mut u64,
    ) -> Vec3 {
        *rays += 1;
        let hit = self.bvh.intersect(o, d, 0.0, f32::INFINITY);
        let t_end = hit.map_or(f32::INFINITY, |h| h.t);
        let mut l = self.area_emission(o, d, t_end);
        if hit.is_none() {
            l += scene.env_radiance(d) * self.transmittance(o, d, f32::INFINITY);
        }
        l += inscatter(self, o, d, t_end, rng, rays);
        let l = match self.mode {
            _ if self.medium.is_none() => {
                l + hit.map_or(Vec3::ZERO, |h| {
                    let (_, sc) = surface_vertex(self.objects, self.bvh, &h, d);
                    direct_light(self, &sc, true, rng, rays)
                })
            }
            MediumMode::SingleScattering => l + self.single_surface(o, d, hit, rng, rays),
            MediumMode::MultipleScattering => l + self.multiple(o, d, hit, rng, rays),
        };
        if l.is_finite() { l } else { Vec3::ZERO }
    }

    /// Single scattering at the camera ray's surface: direct light and the
    /// light scattered once into one BRDF-sampled segment, times `T(eye, p)`.
    fn single_surface(
        &self,
        o: Vec3,
        d: Vec3,
        hit: Option<Hit>,
        rng: &mut Rng,
        rays: &mut u64,
    ) -> Vec3 {
        let Some(h) = hit else {
            return Vec3::ZERO;
        };
        let (_, sc) = surface_vertex(self.objects, self.bvh, &h, d);
        let mut l = direct_light(self, &sc, true, rng, rays);
        if let Some((wi, rho, pdf)) = sc.sample(rng.next_2d()) {
            let o2 = sc.origin_towards(wi);
            let t2 = self
                .secondary_hit(o2, wi, rays)
                .map_or(f32::INFINITY, |h| h.t);
            l += inscatter(self, o2, wi, t2, rng, rays) * rho / pdf;
        }
        l * self.transmittance(o, d, h.t)
    }

    /// Multiple scattering from the camera segment on (module docs). The
    /// camera segment's emission and in-scattering are already counted.
    fn multiple(&self, o: Vec3, d: Vec3, hit: Option<Hit>, rng: &mut Rng, rays: &mut u64) -> Vec3 {
        let Some(m) = self.medium else {
            return Vec3::ZERO;
        };
        let (mut o, mut d, mut hit) = (o, d, hit);
        let mut thr = Vec3::ONE;
        let mut l = Vec3::ZERO;
        let mut surface_used = false;
        let mut vertices = 0u32;
        loop {
            vertices += 1;
            let t_end = hit.map_or(f32::INFINITY, |h| h.t);
            // Free flight through the part of the segment inside the ball.
            let scatter_at = ball_segment(&m, o, d, t_end).and_then(|(a, b)| {
                let s = -(1.0 - rng.next_f32()).ln() / m.beta;
                (a + s < b).then_some(a + s)
            });
            if let Some(t) = scatter_at {
                thr *= m.albedo;
                if !roulette(&mut thr, vertices, rng) {
                    break;
                }
                o += t * d;
                d = sample_uniform_sphere(rng.next_2d());
            } else {
                let Some(h) = hit else { break };
                if surface_used {
                    break;
                }
                surface_used = true;
                let (_, sc) = surface_vertex(self.objects, self.bvh, &h, d);
                l += thr * direct_light(self, &sc, true, rng, rays);
                let Some((wi, rho, pdf)) = sc.sample(rng.next_2d()) else {
                    break;
                };
                thr *= rho / pdf;
                if !roulette(&mut thr, vertices, rng) {
                    break;
                }
                o = sc.origin_towards(wi);
                d = wi;
            }
            hit = self.secondary_hit(o, d, rays);
            let t_next = hit.map_or(f32::INFINITY, |h| h.t);
            l += thr * inscatter(self, o, d, t_next, rng, rays);
        }
        l
    }
}

/// The path vertex from which Russian roulette runs (module docs).
pub const ROULETTE_START: u32 = 3;

/// The largest survival probability of Russian roulette (module docs).
pub const ROULETTE_MAX_SURVIVAL: f32 = 0.99;

/// Russian roulette at path vertex `vertex` (from 1): before
/// [`ROULETTE_START`] only a zero throughput ends the path; then survive
/// with probability `q = min(max thr, ROULETTE_MAX_SURVIVAL)` and divide the
/// throughput by it. False when the path ends.
#[inline]
fn roulette(thr: &mut Vec3, vertex: u32, rng: &mut Rng) -> bool {
    let cap = if vertex < ROULETTE_START {
        1.0
    } else {
        ROULETTE_MAX_SURVIVAL
    };
    let q = thr.max_element().min(cap);
    if q.is_nan() || q <= 0.0 {
        return false;
    }
    if q < 1.0 {
        if rng.next_f32() >= q {
            return false;
        }
        *thr /= q;
    }
    true
}
