//! The render loop: passes of samples over 16 × 16 tiles in parallel, a
//! running per-pixel sum (the progressive estimate), and the image with its
//! own error estimate.
//!
//! Each tile copies in its pixels' running sums, adds its samples in sample
//! order and copies them back, so the sums — and the image — do not depend
//! on the thread count, the schedule or the split into passes.

use super::integrator::Tracer;
use super::lights::{EnvLight, Lights};
use super::{LightSampling, ReferenceError, ReferenceOptions, WaveletLights, validate_scene};
use crate::bvh::SceneBvh;
use crate::sampling::{Rng, luminance};
use crate::{Camera, Image, Progress, Scene};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

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
    /// √(Σ std_error²) / √(Σ luminance²) over every pixel: the relative
    /// RMS error the image's own noise gives against the truth. An error
    /// measured over part of the image (object pixels) must be read against
    /// [`ReferenceImage::rms_relative_std_error_over`] the same part: the
    /// environment's background pixels are nearly noise-free but add to the
    /// denominator, so this figure understates the objects' noise.
    pub rms_relative_std_error: f64,
    /// Rays traced (camera, shadow and scattered).
    pub rays: u64,
    /// Wall-clock time of the sampling (excluding BVH build), seconds.
    pub seconds: f64,
}

impl ReferenceImage {
    /// σ_MC over the pixels where `mask` is true: √(Σ σ_i²) / √(Σ Y_i²),
    /// σ_i the standard error of pixel i's mean luminance `Y_i` — the noise
    /// floor of a relative RMS error [`Image::relative_rms_error`] measured
    /// over the same `mask` (checked against the difference of two
    /// references of different seeds, `tests/reference/basic.rs`). 0 when
    /// the masked pixels are black. `mask` shorter than the image counts
    /// only the pixels it covers.
    #[must_use]
    pub fn rms_relative_std_error_over(&self, mask: &[bool]) -> f64 {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for ((s, p), &m) in self.std_error.iter().zip(&self.image.pixels).zip(mask) {
            if m {
                let y = f64::from(luminance(*p));
                num += f64::from(*s) * f64::from(*s);
                den += y * y;
            }
        }
        if den > 0.0 { (num / den).sqrt() } else { 0.0 }
    }
}

/// Per-pixel running sums: RGB and luminance moments.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PixelAcc {
    rgb: [f64; 3],
    lum: f64,
    lum_sq: f64,
}

/// The running estimate of an image: per-pixel sums over samples `0..spp`.
#[derive(Clone, Debug)]
pub(crate) struct Accumulator {
    width: usize,
    height: usize,
    pixels: Vec<PixelAcc>,
    /// Samples per pixel summed so far.
    pub spp: u32,
    pub rays: u64,
    pub seconds: f64,
}

const TILE: usize = 16;

impl Accumulator {
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![PixelAcc::default(); width * height],
            spp: 0,
            rays: 0,
            seconds: 0.0,
        }
    }

    /// Adds samples `self.spp..until` of every pixel of `camera`'s image, in
    /// passes of `opts.pass_spp`, one progress unit per tile and pass.
    ///
    /// # Errors
    /// [`ReferenceError::Cancelled`]; the sums are then unchanged.
    pub fn add_samples(
        &mut self,
        tracer: &Tracer,
        scene: &Scene,
        camera: &Camera,
        opts: &ReferenceOptions,
        until: u32,
        progress: &dyn Progress,
    ) -> Result<(), ReferenceError> {
        let (width, height) = (self.width, self.height);
        if until <= self.spp {
            return Ok(());
        }
        let tiles: Vec<(usize, usize)> = (0..height.div_ceil(TILE))
            .flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
            .collect();
        let pass_spp = opts.pass_spp.clamp(1, until - self.spp);
        let passes = (until - self.spp).div_ceil(pass_spp);
        let rays_frame = camera.ray_frame();
        let start = Instant::now();
        let mut pixels = self.pixels.clone();
        let mut rays = 0u64;
        progress.start("reference", u64::from(passes) * tiles.len() as u64);
        for pass in 0..passes {
            let s0 = self.spp + pass * pass_spp;
            let s1 = (s0 + pass_spp).min(until);
            let results: Result<Vec<(Vec<PixelAcc>, u64)>, crate::Cancelled> = tiles
                .par_iter()
                .map(|&(x0, y0)| {
                    progress.check()?;
                    let (x1, y1) = ((x0 + TILE).min(width), (y0 + TILE).min(height));
                    let mut out = Vec::with_capacity((x1 - x0) * (y1 - y0));
                    let mut tile_rays = 0u64;
                    for y in y0..y1 {
                        for x in x0..x1 {
                            let pixel = y * width + x;
                            let mut a = pixels[pixel];
                            for s in s0..s1 {
                                let mut rng =
                                    Rng::for_sample(opts.seed, pixel as u64, u64::from(s));
                                let j = rng.next_2d();
                                let d = rays_frame.dir(x as f32 + j.x, y as f32 + j.y);
                                let l = tracer.camera_sample(
                                    scene,
                                    camera.eye,
                                    d,
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
                Err(_) => {
                    progress.finish();
                    return Err(ReferenceError::Cancelled);
                }
            };
            for (&(x0, y0), (tile_acc, tile_rays)) in tiles.iter().zip(results) {
                rays += tile_rays;
                let tw = (x0 + TILE).min(width) - x0;
                for (k, a) in tile_acc.into_iter().enumerate() {
                    pixels[(y0 + k / tw) * width + x0 + k % tw] = a;
                }
            }
        }
        progress.finish();
        self.pixels = pixels;
        self.spp = until;
        self.rays += rays;
        self.seconds += start.elapsed().as_secs_f64();
        Ok(())
    }

    /// The mean image and its error estimate.
    pub fn image(&self) -> ReferenceImage {
        let n = f64::from(self.spp.max(1));
        let mut image = Image::new(self.width, self.height);
        let mut std_error = vec![0.0f32; self.width * self.height];
        let (mut se_sum, mut lum_sum) = (0.0f64, 0.0f64);
        let (mut se_sq, mut lum_sq) = (0.0f64, 0.0f64);
        for (i, a) in self.pixels.iter().enumerate() {
            image.pixels[i] = Vec3::new(
                (a.rgb[0] / n) as f32,
                (a.rgb[1] / n) as f32,
                (a.rgb[2] / n) as f32,
            );
            let mean = a.lum / n;
            let var = if self.spp > 1 {
                ((a.lum_sq / n - mean * mean).max(0.0)) * n / (n - 1.0)
            } else {
                0.0
            };
            let se = (var / n).sqrt();
            std_error[i] = se as f32;
            se_sum += se;
            lum_sum += mean;
            se_sq += se * se;
            lum_sq += mean * mean;
        }
        ReferenceImage {
            image,
            std_error,
            spp: self.spp,
            relative_std_error: if lum_sum > 0.0 { se_sum / lum_sum } else { 0.0 },
            rms_relative_std_error: if lum_sq > 0.0 {
                (se_sq / lum_sq).sqrt()
            } else {
                0.0
            },
            rays: self.rays,
            seconds: self.seconds,
        }
    }
}

/// Checks the options, image size and scene.
pub(crate) fn validate(
    scene: &Scene,
    camera: &Camera,
    opts: &ReferenceOptions,
) -> Result<(), ReferenceError> {
    if opts.spp == 0 {
        return Err(ReferenceError::ZeroSamples(opts.spp));
    }
    if camera.width == 0 || camera.height == 0 {
        return Err(ReferenceError::EmptyImage {
            width: camera.width,
            height: camera.height,
        });
    }
    if opts.light_sampling == LightSampling::Wavelet
        && let Err((parameter, problem)) = opts.wavelet.check()
    {
        return Err(ReferenceError::InvalidOption { parameter, problem });
    }
    validate_scene(scene)
}

/// The area lights' grids when `opts` asks for [`LightSampling::Wavelet`]
/// and the scene has area lights.
pub(crate) fn wavelet_lights(scene: &Scene, opts: &ReferenceOptions) -> Option<WaveletLights> {
    (opts.light_sampling == LightSampling::Wavelet && !scene.area_lights.is_empty())
        .then(|| WaveletLights::new(&scene.area_lights, opts.wavelet))
}

/// Renders `scene` with the reference renderer (builds the BVH and the
/// environment sampler, then [`render_reference_with`]).
///
/// # Errors
/// [`ReferenceError`] for zero samples, an empty image, a bad scene value,
/// or cancellation.
pub fn render_reference(
    scene: &Scene,
    opts: &ReferenceOptions,
    progress: &dyn Progress,
) -> Result<ReferenceImage, ReferenceError> {
    validate(scene, &scene.camera, opts)?;
    let bvh = SceneBvh::from_scene(scene);
    let light = EnvLight::new(&scene.env, opts.env_filter);
    render_reference_with(scene, &bvh, &light, opts, progress)
}

/// Renders `scene` with a prebuilt BVH (over the meshes of `scene.objects`,
/// same order) and environment light (of `scene.env`; its filter is the one
/// used, not `opts.env_filter`).
///
/// # Errors
/// As [`render_reference`].
pub fn render_reference_with(
    scene: &Scene,
    bvh: &SceneBvh,
    light: &EnvLight,
    opts: &ReferenceOptions,
    progress: &dyn Progress,
) -> Result<ReferenceImage, ReferenceError> {
    validate(scene, &scene.camera, opts)?;
    let wavelet = wavelet_lights(scene, opts);
    let tracer =
        Tracer::new(scene, bvh, Lights::new(scene, light), opts).with_wavelet(wavelet.as_ref());
    let mut acc = Accumulator::new(scene.camera.width, scene.camera.height);
    acc.add_samples(&tracer, scene, &scene.camera, opts, opts.spp, progress)?;
    Ok(acc.image())
}
