//! The ground-truth renderer (`--method reference`): Monte Carlo integration
//! of the reflection equation for meshes under a distant environment map.
//!
//! # What is computed
//! For the first surface seen through each pixel,
//!
//! L_o(x, ω_o) = ∫_{H²(n)} f(ω_o, ω_i) · L_env(ω_i) · V(x, ω_i) · (n·ω_i) dω_i
//!
//! (Kajiya 1986, restricted to one bounce): distant lighting `L_env` (the
//! [`EnvMap`], read with an [`EnvFilter`]), any [`Brdf`] in the local frame of the
//! shading normal `n` (interpolated vertex normals, or an override — the
//! normal-mapped reference of `relight verify sh`), and an optional binary
//! self-visibility `V` (shadow rays through the [`SceneBvh`]). With visibility
//! off, `V ≡ 1`: the *unshadowed* integral over the hemisphere of the shading
//! normal, which is exactly what the SH and wavelet techniques compute and what
//! their `verify` compares against. There are **no interreflections**: light
//! reflected between surfaces is not followed (the techniques this renderer
//! judges model direct environment lighting only). Pixels whose ray misses
//! every object show the environment, `L_env(ω)`.
//!
//! # How
//! Per pixel sample: a camera ray through a uniformly jittered point of the
//! pixel (box filter); at the hit, one environment sample (luminance
//! importance sampling, [`EnvSampler`]) and one BRDF sample ([`Brdf::sample`]),
//! combined by multiple importance sampling with the power heuristic
//! (Veach & Guibas 1995, "Optimally Combining Sampling Techniques for Monte
//! Carlo Rendering", §4). Both densities are exact solid-angle densities, so the
//! estimator is unbiased for either filter. Surfaces are two-sided: seen from
//! the back, both normals are flipped towards the viewer.
//!
//! # Determinism, progress, error estimate
//! Sample `s` of pixel `p` draws all its random numbers from
//! [`Rng::for_sample`]`(seed, p, s)`, and per-pixel sums are accumulated in
//! sample order, so an image depends only on the seed and sample count —
//! never on the thread count or tile schedule. Rendering is progressive:
//! passes of [`ReferenceOptions::pass_spp`] samples, each parallel over
//! 16 × 16 tiles with rayon; [`Progress::inc`] per tile,
//! [`Progress::check`] before each tile (Ctrl-C returns [`ReferenceError::Cancelled`]
//! and no image).
//! The renderer reports its own accuracy: per pixel the standard error of the
//! mean luminance, s/√N from the sample variance, and over the image
//! [`ReferenceImage::relative_std_error`] = mean standard error / mean luminance.

use crate::bvh::{Hit, SceneBvh, ShadingPoint, offset_ray_origin};
use crate::sampling::{EnvFilter, EnvSampler, Rng, luminance, power_heuristic};
use crate::{Camera, Cancelled, Image, NoProgress, Object, Progress, Scene};
use glam::Vec3;
use rayon::prelude::*;
use relight_brdf::{Brdf, BrdfSample, Lambert};
use relight_geom::Mesh;
use relight_sphere::{EnvMap, Frame, Param};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// Why a reference render did not produce an image.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
pub enum ReferenceError {
    /// The user asked to stop (Ctrl-C); nothing was produced.
    #[error("reference render cancelled")]
    Cancelled,
    /// `spp` must be at least 1.
    #[error("--spp must be at least 1 (got {0})")]
    ZeroSamples(u32),
    /// The camera has a zero width or height.
    #[error("image size must be at least 1×1 (got {width}×{height})")]
    EmptyImage { width: usize, height: usize },
}

impl From<Cancelled> for ReferenceError {
    fn from(_: Cancelled) -> Self {
        Self::Cancelled
    }
}

/// Settings of [`render_reference`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceOptions {
    /// Total samples per pixel (≥ 1); each sample is one camera ray plus one
    /// environment and one BRDF sample at the hit.
    pub spp: u32,
    /// Samples per pixel per progressive pass (≥ 1; clamped to `spp`).
    pub pass_spp: u32,
    /// Global seed: same seed and `spp` → bit-identical image.
    pub seed: u64,
    /// Trace shadow rays (self-visibility); off = unshadowed lighting.
    pub visibility: bool,
    /// How environment radiance is read (see [`EnvFilter`]).
    pub env_filter: EnvFilter,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self {
            spp: 64,
            pass_spp: 8,
            seed: 0,
            visibility: true,
            env_filter: EnvFilter::Nearest,
        }
    }
}

/// A finished reference render with its own error estimate.
#[derive(Clone, Debug)]
pub struct ReferenceImage {
    /// Mean radiance per pixel (linear RGB).
    pub image: Image,
    /// Standard error of each pixel's mean luminance (row-major).
    pub std_error: Vec<f32>,
    /// Samples per pixel taken.
    pub spp: u32,
    /// Mean over pixels of `std_error` divided by the mean pixel luminance.
    pub relative_std_error: f64,
    /// Rays traced (camera + shadow).
    pub rays: u64,
    /// Wall-clock time of the sampling (excluding BVH build), seconds.
    pub seconds: f64,
}

/// A shading-normal override: given the hit (with its interpolated normal,
/// uv and tangent), the world-space unit normal to shade with — e.g. a normal
/// map sampled at `uv` and rotated into the tangent frame.
pub type NormalOverride<'a> = &'a (dyn Fn(&ShadingPoint) -> Vec3 + Sync);

/// The environment as a light: the map, its luminance sampler and the filter
/// used to read it. Build once per map; cheap to share across threads.
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

    /// Radiance arriving from world direction `d` (unit).
    #[inline]
    #[must_use]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.sampler.radiance(self.env, d, self.filter)
    }
}

/// Mean and standard error of a Monte Carlo radiance estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadianceEstimate {
    /// Estimated outgoing radiance, linear RGB.
    pub radiance: Vec3,
    /// Standard error of `radiance` per channel.
    pub std_error: Vec3,
}

/// Direct lighting at one surface point: one environment sample and one BRDF
/// sample combined with the power heuristic. `p` and `ng` (unit geometric
/// normal, facing the viewer) place shadow rays; `frame.z` is the shading
/// normal; `wo` is the local view direction. Increments `rays` per shadow ray.
#[allow(clippy::too_many_arguments)]
fn estimate_direct(
    p: Vec3,
    ng: Vec3,
    frame: &Frame,
    wo: Vec3,
    brdf: &dyn Brdf,
    light: &EnvLight,
    bvh: Option<&SceneBvh>,
    rng: &mut Rng,
    rays: &mut u64,
) -> Vec3 {
    let visible = |wi_world: Vec3, rays: &mut u64| -> bool {
        match bvh {
            None => true,
            Some(b) => {
                *rays += 1;
                let side = if wi_world.dot(ng) >= 0.0 { ng } else { -ng };
                !b.occluded(offset_ray_origin(p, side), wi_world, f32::INFINITY)
            }
        }
    };
    let mut l = Vec3::ZERO;
    // Environment sample.
    let u_texel = rng.next_f64();
    let u_pos = rng.next_2d();
    if let Some(s) = light.sampler.sample(u_texel, u_pos) {
        let wi = frame.to_local(s.wi);
        if wi.z > 0.0 && s.pdf > 0.0 {
            let f = brdf.eval(wo, wi);
            if f != Vec3::ZERO {
                let le = light.sampler.sample_radiance(light.env, &s, light.filter);
                if le != Vec3::ZERO && visible(s.wi, rays) {
                    let w = power_heuristic(s.pdf, brdf.pdf(wo, wi));
                    l += f * le * (wi.z * w / s.pdf);
                }
            }
        }
    }
    // BRDF sample.
    let u = rng.next_2d();
    if let Some(BrdfSample { wi, f, pdf }) = brdf.sample(wo, u)
        && pdf > 0.0
        && wi.z > 0.0
        && f != Vec3::ZERO
    {
        let wi_world = frame.from_local(wi);
        let (le, env_pdf) = light
            .sampler
            .radiance_and_pdf(light.env, wi_world, light.filter);
        if le != Vec3::ZERO && visible(wi_world, rays) {
            let w = power_heuristic(pdf, env_pdf);
            l += f * le * (wi.z * w / pdf);
        }
    }
    if l.is_finite() { l } else { Vec3::ZERO }
}

/// Reference outgoing radiance at one surface point (for per-vertex
/// verification): `spp` MIS samples of the reflection equation at `p` with
/// unit shading normal `n` (also used as the geometric normal for shadow
/// rays), world view direction `wo` (unit, pointing away from the surface),
/// `brdf`, environment `light`, and shadow rays through `visibility` when
/// given. Deterministic in `seed`. The shading frame is [`Frame::from_z`]`(n)`;
/// use [`reference_radiance_in_frame`] for anisotropic BRDFs.
#[allow(clippy::too_many_arguments)]
#[must_use]
pub fn reference_radiance_at(
    p: Vec3,
    n: Vec3,
    wo: Vec3,
    brdf: &dyn Brdf,
    light: &EnvLight,
    visibility: Option<&SceneBvh>,
    spp: u32,
    seed: u64,
) -> RadianceEstimate {
    reference_radiance_in_frame(p, &Frame::from_z(n), wo, brdf, light, visibility, spp, seed)
}

/// [`reference_radiance_at`] in an explicit shading frame (`frame.z` = normal).
#[allow(clippy::too_many_arguments)]
#[must_use]
pub fn reference_radiance_in_frame(
    p: Vec3,
    frame: &Frame,
    wo: Vec3,
    brdf: &dyn Brdf,
    light: &EnvLight,
    visibility: Option<&SceneBvh>,
    spp: u32,
    seed: u64,
) -> RadianceEstimate {
    let wo_local = frame.to_local(wo);
    let mut acc = Welford::default();
    let mut rays = 0;
    for s in 0..spp.max(1) {
        let mut rng = Rng::for_sample(seed, 0, u64::from(s));
        acc.push(estimate_direct(
            p, frame.z, frame, wo_local, brdf, light, visibility, &mut rng, &mut rays,
        ));
    }
    acc.estimate()
}

/// Running mean and variance per channel (f64).
#[derive(Clone, Copy, Debug, Default)]
struct Welford {
    n: u64,
    sum: [f64; 3],
    sum_sq: [f64; 3],
}

impl Welford {
    fn push(&mut self, v: Vec3) {
        self.n += 1;
        for (k, x) in v.to_array().into_iter().enumerate() {
            let x = f64::from(x);
            self.sum[k] += x;
            self.sum_sq[k] += x * x;
        }
    }
    fn estimate(&self) -> RadianceEstimate {
        let n = self.n.max(1) as f64;
        let mean = self.sum.map(|s| s / n);
        let se = std::array::from_fn::<f64, 3, _>(|k| {
            if self.n < 2 {
                0.0
            } else {
                ((self.sum_sq[k] / n - mean[k] * mean[k]).max(0.0) * n / (n - 1.0) / n).sqrt()
            }
        });
        RadianceEstimate {
            radiance: Vec3::new(mean[0] as f32, mean[1] as f32, mean[2] as f32),
            std_error: Vec3::new(se[0] as f32, se[1] as f32, se[2] as f32),
        }
    }
}

/// Per-pixel accumulator: RGB sums and luminance moments.
#[derive(Clone, Copy, Debug, Default)]
struct PixelAcc {
    rgb: [f64; 3],
    lum: f64,
    lum_sq: f64,
}

/// One camera sample: the radiance arriving through (`px`, `py`).
#[allow(clippy::too_many_arguments)]
fn trace_camera_sample(
    scene: &Scene,
    bvh: &SceneBvh,
    light: &EnvLight,
    normal_override: Option<NormalOverride>,
    visibility: bool,
    px: f32,
    py: f32,
    rng: &mut Rng,
    rays: &mut u64,
) -> Vec3 {
    let (o, d) = scene.camera.ray(px, py);
    *rays += 1;
    let Some(hit): Option<Hit> = bvh.intersect(o, d, 0.0, f32::INFINITY) else {
        return light.radiance(d);
    };
    let sp = bvh.shading_point(&hit);
    let mut ng = sp.geometric_normal;
    let mut ns = match normal_override {
        Some(f) => f(&sp).normalize_or(sp.shading_normal),
        None => sp.shading_normal,
    };
    let wo_world = -d;
    if wo_world.dot(ng) < 0.0 {
        ng = -ng;
        ns = -ns;
    }
    let frame = sp.frame(ns);
    let wo = frame.to_local(wo_world);
    let brdf = scene.objects[hit.object as usize].brdf.as_ref();
    estimate_direct(
        sp.position,
        ng,
        &frame,
        wo,
        brdf,
        light,
        visibility.then_some(bvh),
        rng,
        rays,
    )
}

/// Renders `scene` with the reference renderer (builds the BVH and the
/// environment sampler, then [`render_reference_with`]).
///
/// # Errors
/// [`ReferenceError`] for zero samples, an empty image, or cancellation.
pub fn render_reference(
    scene: &Scene,
    opts: &ReferenceOptions,
    progress: &dyn Progress,
) -> Result<ReferenceImage, ReferenceError> {
    let bvh = SceneBvh::from_scene(scene);
    let light = EnvLight::new(&scene.env, opts.env_filter);
    render_reference_with(scene, &bvh, &light, opts, None, progress)
}

/// Renders `scene` with a prebuilt BVH (over `scene.objects`, same order) and
/// environment light, optionally overriding the shading normal per hit.
///
/// # Errors
/// [`ReferenceError`] for zero samples, an empty image, or cancellation.
pub fn render_reference_with(
    scene: &Scene,
    bvh: &SceneBvh,
    light: &EnvLight,
    opts: &ReferenceOptions,
    normal_override: Option<NormalOverride>,
    progress: &dyn Progress,
) -> Result<ReferenceImage, ReferenceError> {
    let Camera { width, height, .. } = scene.camera;
    if opts.spp == 0 {
        return Err(ReferenceError::ZeroSamples(opts.spp));
    }
    if width == 0 || height == 0 {
        return Err(ReferenceError::EmptyImage { width, height });
    }
    const TILE: usize = 16;
    let tiles: Vec<(usize, usize)> = (0..height.div_ceil(TILE))
        .flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let pass_spp = opts.pass_spp.clamp(1, opts.spp);
    let passes = opts.spp.div_ceil(pass_spp);
    let mut acc = vec![PixelAcc::default(); width * height];
    let mut rays = 0u64;
    let start = Instant::now();
    progress.start("reference", u64::from(passes) * tiles.len() as u64);
    for pass in 0..passes {
        let s0 = pass * pass_spp;
        let s1 = (s0 + pass_spp).min(opts.spp);
        let results: Result<Vec<(Vec<PixelAcc>, u64)>, Cancelled> = tiles
            .par_iter()
            .map(|&(x0, y0)| {
                progress.check()?;
                let (x1, y1) = ((x0 + TILE).min(width), (y0 + TILE).min(height));
                let mut out = Vec::with_capacity((x1 - x0) * (y1 - y0));
                let mut tile_rays = 0u64;
                for y in y0..y1 {
                    for x in x0..x1 {
                        let pixel = (y * width + x) as u64;
                        let mut a = PixelAcc::default();
                        for s in s0..s1 {
                            let mut rng = Rng::for_sample(opts.seed, pixel, u64::from(s));
                            let j = rng.next_2d();
                            let l = trace_camera_sample(
                                scene,
                                bvh,
                                light,
                                normal_override,
                                opts.visibility,
                                x as f32 + j.x,
                                y as f32 + j.y,
                                &mut rng,
                                &mut tile_rays,
                            );
                            let y_l = f64::from(luminance(l));
                            a.rgb[0] += f64::from(l.x);
                            a.rgb[1] += f64::from(l.y);
                            a.rgb[2] += f64::from(l.z);
                            a.lum += y_l;
                            a.lum_sq += y_l * y_l;
                        }
                        out.push(a);
                    }
                }
                progress.inc(1);
                Ok((out, tile_rays))
            })
            .collect();
        let results = match results {
            Ok(r) => r,
            Err(c) => {
                progress.finish();
                return Err(c.into());
            }
        };
        for (&(x0, y0), (tile_acc, tile_rays)) in tiles.iter().zip(results) {
            rays += tile_rays;
            let x1 = (x0 + TILE).min(width);
            let tw = x1 - x0;
            for (k, a) in tile_acc.into_iter().enumerate() {
                let p = &mut acc[(y0 + k / tw) * width + x0 + k % tw];
                for c in 0..3 {
                    p.rgb[c] += a.rgb[c];
                }
                p.lum += a.lum;
                p.lum_sq += a.lum_sq;
            }
        }
    }
    progress.finish();
    let seconds = start.elapsed().as_secs_f64();
    let n = f64::from(opts.spp);
    let mut image = Image::new(width, height);
    let mut std_error = vec![0.0f32; width * height];
    let (mut se_sum, mut lum_sum) = (0.0f64, 0.0f64);
    for (i, a) in acc.iter().enumerate() {
        image.pixels[i] = Vec3::new(
            (a.rgb[0] / n) as f32,
            (a.rgb[1] / n) as f32,
            (a.rgb[2] / n) as f32,
        );
        let mean = a.lum / n;
        let var = if opts.spp > 1 {
            ((a.lum_sq / n - mean * mean).max(0.0)) * n / (n - 1.0)
        } else {
            0.0
        };
        let se = (var / n).sqrt();
        std_error[i] = se as f32;
        se_sum += se;
        lum_sum += mean;
    }
    let relative_std_error = if lum_sum > 0.0 { se_sum / lum_sum } else { 0.0 };
    Ok(ReferenceImage {
        image,
        std_error,
        spp: opts.spp,
        relative_std_error,
        rays,
        seconds,
    })
}

// ---------------------------------------------------------------------------
// Built-in benchmark scene
// ---------------------------------------------------------------------------

/// One throughput measurement of the reference renderer (`relight bench`).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ReferenceBenchRow {
    /// Scene description.
    pub scene: String,
    /// Shadow rays traced (self-visibility on).
    pub visibility: bool,
    pub width: usize,
    pub height: usize,
    pub spp: u32,
    pub triangles: usize,
    /// Rayon threads used.
    pub threads: usize,
    /// Camera + shadow rays traced.
    pub rays: u64,
    /// Sampling time, seconds (BVH build excluded).
    pub seconds: f64,
    /// Rays per second (both the camera and shadow rays).
    pub rays_per_s: f64,
    /// Camera samples (pixel samples) per second.
    pub samples_per_s: f64,
    /// BVH build time, milliseconds.
    pub bvh_build_ms: f64,
}

/// A square floor at height `y`, facing +Y.
pub(crate) fn floor_quad(y: f32, half: f32) -> Mesh {
    Mesh {
        positions: vec![
            Vec3::new(-half, y, -half),
            Vec3::new(half, y, -half),
            Vec3::new(half, y, half),
            Vec3::new(-half, y, half),
        ],
        normals: vec![Vec3::Y; 4],
        indices: vec![[0, 2, 1], [0, 3, 2]],
        ..Default::default()
    }
}

/// A lat-long sky: blue gradient above, grey ground below, and a small sun of
/// radiance `sun` within `sun_radius_deg` of `sun_dir` (high dynamic range).
pub(crate) fn sun_sky(width: usize, sun_dir: Vec3, sun_radius_deg: f32, sun: f32) -> EnvMap {
    let sun_dir = sun_dir.normalize();
    let cos_r = sun_radius_deg.to_radians().cos();
    EnvMap::from_fn(
        Param::LatLong {
            width,
            height: width / 2,
        },
        |d| {
            let base = if d.y >= 0.0 {
                Vec3::new(0.3, 0.5, 0.9).lerp(Vec3::new(0.8, 0.9, 1.0), 1.0 - d.y)
            } else {
                Vec3::splat(0.25)
            };
            if d.dot(sun_dir) >= cos_r {
                base + Vec3::splat(sun)
            } else {
                base
            }
        },
    )
}

/// The built-in benchmark scene: a 128 × 256 UV sphere (65 K triangles) on a
/// floor under a sky with a sun, seen at `width × height`.
#[must_use]
fn bench_scene(width: usize, height: usize) -> Scene {
    let brdf: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::splat(0.8)).expect("albedo in [0, 1]"));
    Scene::new(
        vec![
            Object::new(
                Arc::new(relight_geom::shapes::uv_sphere_at(
                    Vec3::new(0.0, 1.0, 0.0),
                    1.0,
                    256,
                    128,
                )),
                brdf.clone(),
            ),
            Object::new(Arc::new(floor_quad(0.0, 20.0)), brdf),
        ],
        sun_sky(512, Vec3::new(0.5, 1.0, 0.3), 1.5, 2000.0),
        Camera {
            eye: Vec3::new(0.0, 1.6, 4.0),
            target: Vec3::new(0.0, 0.9, 0.0),
            up: Vec3::Y,
            vfov_deg: 45.0,
            width,
            height,
        },
    )
}

/// Throughput of the reference renderer on the built-in scene (sphere on a
/// floor, sun and sky) at `width × height` and `spp`, with and without
/// shadow rays, on the current rayon pool.
#[must_use]
pub fn bench_reference(width: usize, height: usize, spp: u32) -> Vec<ReferenceBenchRow> {
    let scene = bench_scene(width.max(1), height.max(1));
    let t0 = Instant::now();
    let bvh = SceneBvh::from_scene(&scene);
    let bvh_build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let light = EnvLight::new(&scene.env, EnvFilter::Nearest);
    [false, true]
        .into_iter()
        .filter_map(|visibility| {
            let opts = ReferenceOptions {
                spp: spp.max(1),
                pass_spp: spp.max(1),
                seed: 1,
                visibility,
                env_filter: EnvFilter::Nearest,
            };
            let r = render_reference_with(&scene, &bvh, &light, &opts, None, &NoProgress).ok()?;
            Some(ReferenceBenchRow {
                scene: "uv-sphere 65K tris + floor, sun sky 512x256".into(),
                visibility,
                width: scene.camera.width,
                height: scene.camera.height,
                spp: opts.spp,
                triangles: bvh.triangle_count(),
                threads: rayon::current_num_threads(),
                rays: r.rays,
                seconds: r.seconds,
                rays_per_s: r.rays as f64 / r.seconds.max(1e-9),
                samples_per_s: (scene.camera.width * scene.camera.height) as f64
                    * f64::from(opts.spp)
                    / r.seconds.max(1e-9),
                bvh_build_ms,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant_env(value: f32) -> EnvMap {
        let param = Param::LatLong {
            width: 32,
            height: 16,
        };
        EnvMap::try_new(param, vec![Vec3::splat(value); param.len()]).unwrap()
    }

    fn sphere_scene(env: EnvMap, albedo: f32, size: usize) -> Scene {
        Scene::new(
            vec![Object::new(
                Arc::new(relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 96, 48)),
                Arc::new(Lambert::new(Vec3::splat(albedo)).expect("albedo in [0, 1]")),
            )],
            env,
            Camera {
                eye: Vec3::new(0.0, 0.0, 3.5),
                target: Vec3::ZERO,
                up: Vec3::Y,
                vfov_deg: 40.0,
                width: size,
                height: size,
            },
        )
    }

    /// Mask of pixels whose centre ray hits geometry.
    fn hit_mask(scene: &Scene, bvh: &SceneBvh) -> Vec<bool> {
        let (w, h) = (scene.camera.width, scene.camera.height);
        (0..w * h)
            .map(|i| {
                // Only pixels fully inside the object: all four corners hit.
                [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                    .iter()
                    .all(|&(dx, dy)| {
                        let (o, d) = scene.camera.ray((i % w) as f32 + dx, (i / w) as f32 + dy);
                        bvh.intersect(o, d, 0.0, f32::INFINITY).is_some()
                    })
            })
            .collect()
    }

    #[test]
    fn white_furnace() {
        for visibility in [false, true] {
            let scene = sphere_scene(constant_env(1.0), 1.0, 24);
            let opts = ReferenceOptions {
                spp: 64,
                pass_spp: 16,
                seed: 3,
                visibility,
                env_filter: EnvFilter::Nearest,
            };
            let r = render_reference(&scene, &opts, &NoProgress).unwrap();
            let bvh = SceneBvh::from_scene(&scene);
            let mask = hit_mask(&scene, &bvh);
            let (mut sum, mut n) = (0.0f64, 0usize);
            for (p, &m) in r.image.pixels.iter().zip(&mask) {
                if m {
                    sum += f64::from(p.x + p.y + p.z) / 3.0;
                    n += 1;
                }
            }
            let mean = sum / n as f64;
            eprintln!(
                "white furnace (visibility {visibility}): mean {mean:.5} over {n} pixels, rel. std error {:.2e}",
                r.relative_std_error
            );
            assert!(n > 100);
            assert!(
                (mean - 1.0).abs() < 0.005,
                "white furnace mean {mean} vs 1 ± 0.5 %"
            );
            // Background shows the environment exactly.
            assert_eq!(r.image.pixels[0], Vec3::ONE);
        }
    }

    #[test]
    fn deterministic_across_thread_counts() {
        let scene = sphere_scene(sun_sky(64, Vec3::new(1.0, 1.0, 0.5), 5.0, 200.0), 0.7, 20);
        let opts = ReferenceOptions {
            spp: 8,
            pass_spp: 3,
            seed: 11,
            visibility: true,
            env_filter: EnvFilter::Bilinear,
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let a = one.install(|| render_reference(&scene, &opts, &NoProgress).unwrap());
        let b = three.install(|| render_reference(&scene, &opts, &NoProgress).unwrap());
        assert_eq!(a.image, b.image, "1 vs 3 threads");
        assert_eq!(a.std_error, b.std_error);
        let c =
            render_reference(&scene, &ReferenceOptions { seed: 12, ..opts }, &NoProgress).unwrap();
        assert_ne!(a.image, c.image, "another seed gives another image");
    }

    /// Error of an spp-N render against a high-spp render falls as 1/√N.
    #[test]
    fn error_falls_as_inverse_sqrt_spp() {
        let scene = sphere_scene(sun_sky(64, Vec3::new(1.0, 1.0, 0.5), 6.0, 50.0), 0.8, 16);
        let bvh = SceneBvh::from_scene(&scene);
        let light = EnvLight::new(&scene.env, EnvFilter::Nearest);
        let render = |spp: u32, seed: u64| {
            let opts = ReferenceOptions {
                spp,
                pass_spp: spp,
                seed,
                visibility: false,
                env_filter: EnvFilter::Nearest,
            };
            render_reference_with(&scene, &bvh, &light, &opts, None, &NoProgress).unwrap()
        };
        let truth = render(2048, 1000);
        let mask = hit_mask(&scene, &bvh);
        let mut errs = Vec::new();
        for spp in [4u32, 16, 64] {
            // Average the squared error over a few seeds to steady the ratio.
            let mut e2 = 0.0;
            let seeds = 4;
            let mut est = 0.0;
            for k in 0..seeds {
                let r = render(spp, 7 + 31 * k);
                e2 += r
                    .image
                    .relative_rms_error(&truth.image, Some(&mask))
                    .powi(2);
                est += r.relative_std_error;
            }
            let e = (e2 / seeds as f64).sqrt();
            eprintln!(
                "spp {spp}: relative RMS error {e:.4e}, self-reported relative std error {:.4e}",
                est / seeds as f64
            );
            errs.push(e);
        }
        for w in errs.windows(2) {
            let ratio = w[0] / w[1];
            eprintln!("error ratio per ×4 spp: {ratio:.3} (ideal 2)");
            assert!(
                (1.6..2.5).contains(&ratio),
                "error ratio {ratio} per ×4 spp, expected ≈ 2"
            );
        }
    }

    #[test]
    fn bad_options_and_cancellation() {
        let scene = sphere_scene(constant_env(1.0), 1.0, 8);
        let zero = ReferenceOptions {
            spp: 0,
            ..Default::default()
        };
        assert_eq!(
            render_reference(&scene, &zero, &NoProgress).unwrap_err(),
            ReferenceError::ZeroSamples(0)
        );
        struct Stop;
        impl Progress for Stop {
            fn start(&self, _: &str, _: u64) {}
            fn inc(&self, _: u64) {}
            fn finish(&self) {}
            fn is_cancelled(&self) -> bool {
                true
            }
        }
        assert_eq!(
            render_reference(&scene, &ReferenceOptions::default(), &Stop).unwrap_err(),
            ReferenceError::Cancelled
        );
        let mut empty = scene.clone();
        empty.camera.width = 0;
        assert!(matches!(
            render_reference(&empty, &ReferenceOptions::default(), &NoProgress),
            Err(ReferenceError::EmptyImage { .. })
        ));
    }

    /// The normal override replaces the interpolated normal: shading a sphere
    /// with a constant normal +Z (towards the camera) under an environment
    /// that is 1 for z > 0 and 0 below gives radiance 1 at every hit pixel
    /// (albedo 1), whatever the interpolated normal.
    #[test]
    fn normal_override_is_used() {
        // Column boundaries at u = ¼, ¾ are exactly the great circle z = 0.
        let env = EnvMap::from_fn(
            Param::LatLong {
                width: 32,
                height: 16,
            },
            |d| if d.z > 0.0 { Vec3::ONE } else { Vec3::ZERO },
        );
        let scene = sphere_scene(env, 1.0, 12);
        let bvh = SceneBvh::from_scene(&scene);
        let light = EnvLight::new(&scene.env, EnvFilter::Nearest);
        let towards_camera = |_: &ShadingPoint| Vec3::Z;
        let opts = ReferenceOptions {
            spp: 256,
            pass_spp: 64,
            seed: 1,
            visibility: false,
            env_filter: EnvFilter::Nearest,
        };
        let r = render_reference_with(
            &scene,
            &bvh,
            &light,
            &opts,
            Some(&towards_camera),
            &NoProgress,
        )
        .unwrap();
        let plain = render_reference_with(&scene, &bvh, &light, &opts, None, &NoProgress).unwrap();
        let mask = hit_mask(&scene, &bvh);
        let (mut sum, mut n, mut spread) = (0.0, 0, 0.0f32);
        for ((p, q), &m) in r.image.pixels.iter().zip(&plain.image.pixels).zip(&mask) {
            if m {
                assert!(
                    (p.x - 1.0).abs() < 0.1,
                    "pixel {p:?} vs 1 with the overridden normal"
                );
                sum += p.x;
                n += 1;
                spread = spread.max((q.x - 1.0).abs());
            }
        }
        let mean = sum / n as f32;
        eprintln!(
            "normal override: mean {mean} over {n} pixels (without override, max |L − 1| = {spread})"
        );
        assert!((mean - 1.0).abs() < 0.01, "mean {mean} vs 1");
        assert!(
            spread > 0.1,
            "the interpolated normals shade differently ({spread})"
        );
    }

    /// A flat-RGBE Radiance .hdr reader for the test (the render crate does no IO).
    fn read_flat_hdr(bytes: &[u8]) -> Option<EnvMap> {
        let text_end = bytes.windows(2).position(|w| w == b"\n\n")? + 2;
        let line_end = text_end + bytes[text_end..].iter().position(|&b| b == b'\n')?;
        let res = std::str::from_utf8(&bytes[text_end..line_end]).ok()?;
        let f: Vec<&str> = res.split_whitespace().collect();
        let (h, w): (usize, usize) = (f.get(1)?.parse().ok()?, f.get(3)?.parse().ok()?);
        let data = &bytes[line_end + 1..];
        if data.len() < w * h * 4 || (data[0] == 2 && data[1] == 2) {
            return None; // run-length encoded: not needed for the shared probes
        }
        let texels = data
            .chunks_exact(4)
            .take(w * h)
            .map(|p| {
                if p[3] == 0 {
                    Vec3::ZERO
                } else {
                    let s = 2f32.powi(i32::from(p[3]) - 136);
                    Vec3::new(f32::from(p[0]), f32::from(p[1]), f32::from(p[2])) * s
                }
            })
            .collect();
        EnvMap::try_new(
            Param::LatLong {
                width: w,
                height: h,
            },
            texels,
        )
    }

    fn park_probe() -> Option<EnvMap> {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/data/hdri/park.hdr"
        );
        match std::fs::read(path) {
            Ok(b) => Some(read_flat_hdr(&b).expect("park.hdr parses as flat RGBE")),
            Err(e) => {
                assert!(
                    std::env::var_os("CI").is_none(),
                    "CI is set and the shared data is missing: {path}: {e}"
                );
                eprintln!(
                    "skipping: {path} not found ({e}); set up ../shared/data to run this test"
                );
                None
            }
        }
    }

    /// Irradiance-based radiance of a Lambert surface by quadrature over every
    /// texel: albedo/π · Σ L_i max(0, n·ω_i) Ω_i.
    fn lambert_quadrature(env: &EnvMap, n: Vec3, albedo: f32) -> Vec3 {
        let mut e = [0.0f64; 3];
        for i in 0..env.param.len() {
            let c = f64::from(env.param.dir_from_texel(i).dot(n).max(0.0))
                * env.param.texel_solid_angle(i);
            if c > 0.0 {
                let l = env.texels[i];
                e[0] += f64::from(l.x) * c;
                e[1] += f64::from(l.y) * c;
                e[2] += f64::from(l.z) * c;
            }
        }
        let k = f64::from(albedo) / std::f64::consts::PI;
        Vec3::new((e[0] * k) as f32, (e[1] * k) as f32, (e[2] * k) as f32)
    }

    /// A Lambert sphere under the real `park` probe (sun ~3e4 against a mean
    /// near 1) matches numerically integrated irradiance to 1 %.
    #[test]
    fn lambert_sphere_under_real_probe_matches_quadrature() {
        let Some(env) = park_probe() else { return };
        let albedo = 0.8;
        let scene = sphere_scene(env, albedo, 12);
        let bvh = SceneBvh::from_scene(&scene);
        let light = EnvLight::new(&scene.env, EnvFilter::Nearest);
        // Per-point estimates on a set of normals, including ones facing the sun.
        let sun_texel = (0..scene.env.texels.len())
            .max_by(|&a, &b| {
                luminance(scene.env.texels[a]).total_cmp(&luminance(scene.env.texels[b]))
            })
            .unwrap();
        let sun = scene.env.param.dir_from_texel(sun_texel);
        let mut normals = vec![
            sun,
            Vec3::Y,
            -Vec3::Y,
            Vec3::X,
            -Vec3::Z,
            (sun + Vec3::X).normalize(),
            (-sun + 0.3 * Vec3::Y).normalize(),
        ];
        normals.push(Vec3::new(0.3, -0.2, 0.9).normalize());
        let brdf = Lambert::new(Vec3::splat(albedo)).expect("albedo in [0, 1]");
        for (k, n) in normals.into_iter().enumerate() {
            let q = lambert_quadrature(&scene.env, n, albedo);
            let est = reference_radiance_at(n, n, n, &brdf, &light, None, 65536, 100 + k as u64);
            let rel = (luminance(est.radiance) - luminance(q)).abs() / luminance(q);
            eprintln!(
                "n {n:?}: reference {:?} ± {:?}, quadrature {q:?}, rel. error {rel:.2e}",
                est.radiance, est.std_error
            );
            assert!(
                rel < 0.01,
                "normal {n:?}: reference {:?} vs quadrature {q:?} ({rel})",
                est.radiance
            );
        }
        // And the rendered image: every fully covered pixel against quadrature at its normal.
        let opts = ReferenceOptions {
            spp: 256,
            pass_spp: 64,
            seed: 5,
            visibility: false,
            env_filter: EnvFilter::Nearest,
        };
        let r = render_reference_with(&scene, &bvh, &light, &opts, None, &NoProgress).unwrap();
        let mask = hit_mask(&scene, &bvh);
        let (w, _) = (scene.camera.width, scene.camera.height);
        let mut quad = Image::new(scene.camera.width, scene.camera.height);
        for (i, &covered) in mask.iter().enumerate() {
            if covered {
                // Same jitter-free normal: the pixel-centre hit (pixel footprint is small).
                let (o, d) = scene.camera.ray((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                let hit = bvh.intersect(o, d, 0.0, f32::INFINITY).unwrap();
                quad.pixels[i] =
                    lambert_quadrature(&scene.env, bvh.shading_point(&hit).shading_normal, albedo);
            }
        }
        // Per pixel the error is sampling noise (printed); over the covered
        // pixels it averages out, and the mean must match to 1 %.
        let err = r.image.relative_rms_error(&quad, Some(&mask));
        let (mut sum_r, mut sum_q) = (0.0f64, 0.0f64);
        for ((p, q), _) in r
            .image
            .pixels
            .iter()
            .zip(&quad.pixels)
            .zip(&mask)
            .filter(|(_, m)| **m)
        {
            sum_r += f64::from(luminance(*p));
            sum_q += f64::from(luminance(*q));
        }
        let rel = (sum_r - sum_q).abs() / sum_q;
        eprintln!(
            "Lambert sphere under park: mean over covered pixels {sum_r:.4} vs quadrature {sum_q:.4} (rel. {rel:.2e}); per-pixel relative RMS {err:.3e}, self-reported relative std error {:.3e}",
            r.relative_std_error
        );
        assert!(
            rel < 0.01,
            "image mean {sum_r} vs quadrature {sum_q}: {rel}"
        );
        assert!(
            err < 4.0 * r.relative_std_error,
            "per-pixel error {err} is more than sampling noise ({})",
            r.relative_std_error
        );
    }

    #[test]
    fn bench_reports_positive_throughput() {
        let rows = bench_reference(16, 12, 1);
        assert_eq!(rows.len(), 2);
        for r in &rows {
            assert!(r.rays >= (16 * 12) as u64 && r.rays_per_s > 0.0, "{r:?}");
        }
        assert!(rows[1].rays > rows[0].rays, "shadow rays counted");
    }
}
