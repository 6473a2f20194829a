//! Ground truth: a volumetric Monte Carlo path tracer for isotropic point
//! lights in a homogeneous medium with surfaces — the oracle that judges
//! the analytic model's glows and surface shading (Sun 2008, §3.3.3,
//! Figure 3.7).
//!
//! # Estimator
//! Paths start at the eye. On every segment (from a vertex along a
//! direction to the next surface, or to infinity) the radiance of paths
//! whose *last* vertex is a medium scattering event on that segment is
//! estimated with **equiangular sampling** about each light (Kulla &
//! Fajardo, "Importance Sampling Techniques for Path Tracing in
//! Participating Media", EGSR 2012): with Δ the light's offset along the
//! ray and D its distance from the ray, t = Δ + D tan θ, θ uniform between
//! the angles of the segment ends, pdf = D / ((θ_b − θ_a)(D² + (t − Δ)²)),
//! which cancels the 1/d² of the light exactly. The contribution is
//! β k(α) I₀ e^{−β(t + d)} V / (d² pdf) with a **shadow ray through the
//! medium** (visibility V from the BVH, attenuation on every segment).
//! Surface vertices connect to each light (next-event estimation with
//! e^{−β d}·V). With albedo a the medium scatters σ_s = a β and
//! extinguishes σ_t = β: the in-scatter estimate carries σ_s, every
//! transmittance σ_t. Paths continue by analogue free-flight sampling
//! (t ~ β e^{−βt}; a scattering vertex multiplies the throughput by a),
//! new directions from the phase function (uniform sphere, weight 4π k) or
//! the BRDF (cosine / Phong-lobe sampling).
//!
//! # Path length: Russian roulette
//! No fixed cap on the number of medium vertices (a cap of 64 biased the
//! glow low at T ≥ 5, where deep orders carry much of the light). From the
//! [`ROULETTE_START`]-th vertex on, a path survives each vertex with
//! probability q = min(max throughput channel, [`ROULETTE_MAX_SURVIVAL`])
//! and its throughput is divided by q, which keeps the estimator unbiased;
//! q < 1 ends even a throughput-1 path (albedo 1, unbounded medium) with
//! probability 1, after 100 vertices on average.
//!
//! # Path classes
//! * [`Transport::Single`]: exactly the classes of the analytic model —
//!   eye→medium→light (airlight), eye→surface→light (direct), and
//!   eye→surface→medium→light (airlight on the surface, eq. 3.22); the view
//!   ray is otherwise only attenuated.
//! * [`Transport::Multiple`]: any number of medium vertices and up to
//!   `max_bounces` surface vertices.
//!
//! The direct (delta) image of the light itself is not included (the glow
//! images compare airlight). Units as in [`crate::model`].

use crate::FogError;
use crate::model::{FogMaterial, Phase, PointLight};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use relight_render::bvh::{SceneBvh, offset_ray_origin};
use relight_render::sampling::{Rng, sample_cosine_hemisphere, sample_uniform_sphere};
use relight_render::{Camera, Image, Progress};
use std::f32::consts::PI;

/// Which light paths the Monte Carlo estimates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transport {
    /// The analytic model's single-scattering classes (see the module docs).
    Single,
    /// Multiple scattering: any number of medium vertices (Russian
    /// roulette, no cap) and up to `max_bounces` surface vertices per path.
    Multiple { max_bounces: u32 },
}

/// The medium, lights and (optional) surfaces.
#[derive(Clone, Copy)]
pub struct VolumetricScene<'a> {
    /// Surfaces (object i has material `materials[i]`); `None` = medium only.
    pub bvh: Option<&'a SceneBvh<'a>>,
    pub materials: &'a [FogMaterial],
    pub lights: &'a [PointLight],
    /// Extinction coefficient σ_t = β, ≥ 0.
    pub beta: f32,
    /// Single-scattering albedo σ_s/σ_t in [0, 1] (σ_s = albedo · β).
    pub albedo: f32,
    pub phase: &'a Phase,
}

/// Monte Carlo settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct McOptions {
    pub samples_per_pixel: u32,
    pub seed: u64,
    pub transport: Transport,
}

/// Path vertices (medium scatters and surface bounces) before Russian
/// roulette starts.
pub const ROULETTE_START: u32 = 3;
/// Largest survival probability of Russian roulette: even a path whose
/// throughput stays 1 (albedo 1, isotropic phase) ends after on average
/// 1/(1 − 0.99) = 100 more vertices.
pub const ROULETTE_MAX_SURVIVAL: f32 = 0.99;

/// Russian roulette after the `depth`-th vertex: survive with probability
/// q = min(max channel of `thr`, [`ROULETTE_MAX_SURVIVAL`]) and divide the
/// throughput by q (unbiased: E[thr'] = q · thr/q = thr). False: the path ends.
#[inline]
fn roulette(thr: &mut Vec3, depth: u32, rng: &mut Rng) -> bool {
    if depth < ROULETTE_START {
        return thr.max_element() > 0.0;
    }
    let q = thr.max_element().min(ROULETTE_MAX_SURVIVAL);
    // NaN or 0 throughput ends the path.
    if q.is_nan() || q <= 0.0 || rng.next_f32() >= q {
        return false;
    }
    *thr /= q;
    true
}

/// A right-handed orthonormal frame with +z = `n`.
#[inline]
fn basis(n: Vec3) -> (Vec3, Vec3) {
    let s = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        Vec3::new(b, s + n.y * n.y * a, -n.y),
    )
}

#[inline]
fn to_world(n: Vec3, v: Vec3) -> Vec3 {
    let (t, b) = basis(n);
    t * v.x + b * v.y + n * v.z
}

impl VolumetricScene<'_> {
    /// Validates β, intensities and material indices.
    pub fn validate(&self) -> Result<(), FogError> {
        if !(self.beta.is_finite() && self.beta >= 0.0) {
            return Err(FogError::Beta { beta: self.beta });
        }
        if !(0.0..=1.0).contains(&self.albedo) {
            return Err(FogError::Albedo {
                albedo: self.albedo,
            });
        }
        for (index, l) in self.lights.iter().enumerate() {
            if !(l.intensity.is_finite() && l.intensity.min_element() >= 0.0) {
                return Err(FogError::Intensity {
                    index,
                    intensity: l.intensity.to_array(),
                });
            }
            if !l.position.is_finite() {
                return Err(FogError::LightPosition {
                    index,
                    position: l.position.to_array(),
                });
            }
        }
        if let Some(b) = self.bvh
            && b.meshes().len() > self.materials.len()
        {
            return Err(FogError::Object {
                object: self.materials.len(),
            });
        }
        Ok(())
    }

    fn intersect(&self, o: Vec3, d: Vec3) -> Option<(f32, Vec3, usize)> {
        let bvh = self.bvh?;
        let hit = bvh.intersect(o, d, 0.0, f32::INFINITY)?;
        let sp = bvh.shading_point(&hit);
        Some((hit.t, sp.geometric_normal, hit.object as usize))
    }

    fn visible(&self, from: Vec3, to: Vec3) -> bool {
        match self.bvh {
            None => true,
            Some(b) => {
                let d = to - from;
                let len = d.length();
                len <= 0.0 || !b.occluded(from, d / len, len * (1.0 - 1e-4))
            }
        }
    }

    /// Equiangular single-scatter estimate on the segment o + t d, t ∈ [0, t_end).
    fn segment_inscatter(&self, o: Vec3, d: Vec3, t_end: f32, rng: &mut Rng) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for l in self.lights {
            let ol = l.position - o;
            let delta = ol.dot(d);
            let dist = (ol - delta * d).length().max(1e-6);
            let th_a = (-delta).atan2(dist);
            let th_b = if t_end.is_finite() {
                (t_end - delta).atan2(dist)
            } else {
                0.5 * PI
            };
            if th_b <= th_a {
                continue;
            }
            let th = th_a + rng.next_f32() * (th_b - th_a);
            let t = (delta + dist * th.tan())
                .clamp(0.0, if t_end.is_finite() { t_end } else { f32::MAX });
            let x = o + t * d;
            let xl = l.position - x;
            let dl = xl.length().max(1e-6);
            let wl = xl / dl;
            if !self.visible(x, l.position) {
                continue;
            }
            let k = self.phase.eval(wl.dot(d));
            // I e^{-β(t+dl)} σ_s k / (dl² pdf), 1/(dl² pdf) = (θ_b − θ_a)/D.
            sum += l.intensity
                * (self.albedo * self.beta * k * (-self.beta * (t + dl)).exp() * (th_b - th_a)
                    / dist);
        }
        sum
    }

    /// Next-event estimate at a surface point (BRDF × cos, attenuation, visibility).
    fn surface_direct(&self, p: Vec3, n: Vec3, wo: Vec3, m: &FogMaterial) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let origin = offset_ray_origin(p, n);
        for l in self.lights {
            let pl = l.position - p;
            let d = pl.length().max(1e-6);
            let wi = pl / d;
            let mu = n.dot(wi);
            if mu <= 0.0 || !self.visible(origin, l.position) {
                continue;
            }
            let r = 2.0 * wo.dot(n) * n - wo;
            let spec = if m.ks == Vec3::ZERO {
                Vec3::ZERO
            } else {
                m.ks * r.dot(wi).max(0.0).powi(m.n as i32)
            };
            sum += l.intensity * (-self.beta * d).exp() / (d * d) * (m.albedo / PI * mu + spec);
        }
        sum
    }

    /// One radiance sample along the ray `o + t d` (unit `d`).
    #[must_use]
    pub fn radiance_sample(&self, o: Vec3, d: Vec3, transport: Transport, rng: &mut Rng) -> Vec3 {
        let (max_bounces, single) = match transport {
            Transport::Single => (1, true),
            Transport::Multiple { max_bounces } => (max_bounces, false),
        };
        let (mut o, mut d) = (o, d);
        let mut thr = Vec3::ONE;
        let mut l_sum = Vec3::ZERO;
        let (mut depth, mut bounces) = (0u32, 0u32);
        let scatters = self.beta > 0.0 && self.albedo > 0.0;
        // No cap on the path length: Russian roulette ends every path with
        // probability 1 (see the module docs).
        loop {
            let hit = self.intersect(o, d);
            let t_end = hit.map_or(f32::INFINITY, |h| h.0);
            if scatters {
                l_sum += thr * self.segment_inscatter(o, d, t_end, rng);
            }
            // Continue: free flight (medium vertex) or the surface.
            let t_s = if self.beta > 0.0 {
                -(1.0 - rng.next_f32()).ln() / self.beta
            } else {
                f32::INFINITY
            };
            if t_s < t_end {
                if single {
                    // The model's view ray only attenuates.
                    break;
                }
                o += t_s * d;
                let nd = sample_uniform_sphere(rng.next_2d());
                // Survival σ_s/σ_t = albedo, phase over the uniform pdf.
                thr *= self.albedo * 4.0 * PI * self.phase.eval(nd.dot(d)).max(0.0);
                d = nd;
                depth += 1;
                if !roulette(&mut thr, depth, rng) {
                    break;
                }
                continue;
            }
            let Some((t, ng, obj)) = hit else { break };
            if bounces >= max_bounces {
                break;
            }
            bounces += 1;
            let p = o + t * d;
            let n = if ng.dot(d) > 0.0 { -ng } else { ng };
            let m = &self.materials[obj.min(self.materials.len() - 1)];
            let wo = -d;
            // The surface is reached with probability e^{-β t}, which cancels the transmittance.
            l_sum += thr * self.surface_direct(p, n, wo, m);
            if bounces >= max_bounces && !scatters {
                break;
            }
            // Sample the BRDF lobe: diffuse (weight albedo) or Phong (k_s 2π/(n+1)).
            let wd = m.albedo.max_element();
            let ws = if m.ks == Vec3::ZERO {
                0.0
            } else {
                m.ks.max_element() * 2.0 * PI / (m.n as f32 + 1.0)
            };
            if wd + ws <= 0.0 {
                break;
            }
            let pd = wd / (wd + ws);
            let r = 2.0 * wo.dot(n) * n - wo;
            let u: Vec2 = rng.next_2d();
            let choose_d = rng.next_f32() < pd;
            let wi = if choose_d {
                to_world(n, sample_cosine_hemisphere(u))
            } else {
                let ct = u.x.powf(1.0 / (m.n as f32 + 1.0));
                let st = (1.0 - ct * ct).max(0.0).sqrt();
                let (s, c) = (2.0 * PI * u.y).sin_cos();
                to_world(r, Vec3::new(st * c, st * s, ct))
            };
            let mu = n.dot(wi);
            if mu <= 0.0 {
                break;
            }
            // Mixture pdf and the BRDF·cos weight.
            let lobe = r.dot(wi).max(0.0);
            let pdf =
                pd * mu / PI + (1.0 - pd) * (m.n as f32 + 1.0) / (2.0 * PI) * lobe.powi(m.n as i32);
            let f_cos = m.albedo / PI * mu + m.ks * lobe.powi(m.n as i32);
            thr *= f_cos / pdf.max(1e-12);
            depth += 1;
            if !single && !roulette(&mut thr, depth, rng) {
                break;
            }
            o = offset_ray_origin(p, n);
            d = wi;
            if single {
                // Only the segment in-scatter of the next segment remains (eq. 3.22).
                let hit2 = self.intersect(o, d).map_or(f32::INFINITY, |h| h.0);
                l_sum += thr * self.segment_inscatter(o, d, hit2, rng);
                break;
            }
        }
        if l_sum.is_finite() { l_sum } else { Vec3::ZERO }
    }
}

/// Renders `camera`'s image with `opts.samples_per_pixel` jittered samples
/// per pixel (parallel over rows, deterministic for a seed). Cancels with
/// [`FogError::Cancelled`] between rows.
pub fn render_volumetric(
    scene: &VolumetricScene,
    camera: &Camera,
    opts: &McOptions,
    progress: &dyn Progress,
) -> Result<Image, FogError> {
    scene.validate()?;
    let (w, h) = (camera.width, camera.height);
    progress.start("volumetric Monte Carlo", h as u64);
    let rows: Result<Vec<Vec<Vec3>>, FogError> = (0..h)
        .into_par_iter()
        .map(|y| {
            progress.check()?;
            let row = (0..w)
                .map(|x| {
                    let mut rng = Rng::for_sample(opts.seed, (y * w + x) as u64, 0);
                    let mut s = Vec3::ZERO;
                    for _ in 0..opts.samples_per_pixel {
                        let j = rng.next_2d();
                        let (o, d) = camera.ray(x as f32 + j.x, y as f32 + j.y);
                        s += scene.radiance_sample(o, d, opts.transport, &mut rng);
                    }
                    s / opts.samples_per_pixel.max(1) as f32
                })
                .collect();
            progress.inc(1);
            Ok(row)
        })
        .collect();
    progress.finish();
    let pixels = rows?.into_iter().flatten().collect();
    Ok(Image {
        width: w,
        height: h,
        pixels,
    })
}
