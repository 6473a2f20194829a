//! `relight verify importance`: [`LightSampling::Wavelet`] (sun-thesis-2008
//! §4.6.1) against the renderer's default MIS and against light-area
//! sampling, on a glossy sphere under a textured area light
//! ([`glossy_scene`]). Every row with a target says pass/fail and names its
//! source (issue 13's verify list: "unbiased (the high-spp mean within
//! 3σ); at 8 spp on a glossy object, variance ≥ 10× lower than light
//! sampling").

use super::wavelet_sampling::{FaceProduct, LightGrid, WaveletSamplingOptions};
use super::{LightSampling, ReferenceError, ReferenceOptions, render_reference_with};
use crate::sampling::luminance;
use crate::texture::Texture;
use crate::verify_row::{VerifyRow, row};
use crate::{AreaLight, Camera, EnvLight, NoProgress, Object, Scene, SceneBvh};
use glam::{Mat3, Vec2, Vec3};
use relight_brdf::{Brdf, Ggx};
use relight_sphere::{EnvMap, Frame};
use std::sync::Arc;
use std::time::Instant;

/// The light's texture at `size²` texels: warm and cool halves, a stripe
/// band and a bright spot.
#[must_use]
pub fn test_texture(size: usize) -> Texture {
    Texture::stripes_and_spot(size, 0.4, 4.0)
}

/// The glossy BRDF of [`glossy_scene`]: GGX, α = 0.1, gold-like F₀.
#[must_use]
pub fn glossy_brdf() -> Arc<dyn Brdf> {
    Arc::new(Ggx::isotropic(0.1, Vec3::new(0.95, 0.64, 0.54)).expect("valid GGX"))
}

/// A glossy sphere (radius 0.5 at `(0, 0.5, 0)`, [`glossy_brdf`]) under a
/// downward 1.6 × 1.0 ceiling light at height 1.6 with [`test_texture`],
/// shadows on, a black environment, seen from the front and above by a
/// `width × height` camera framing the sphere.
#[must_use]
pub fn glossy_scene(width: usize, height: usize) -> Scene {
    let objects = vec![Object::new(
        Arc::new(relight_geom::shapes::uv_sphere_at(
            Vec3::new(0.0, 0.5, 0.0),
            0.5,
            96,
            48,
        )),
        glossy_brdf(),
    )];
    let env = EnvMap::black();
    let camera = Camera {
        eye: Vec3::new(0.0, 1.3, 2.0),
        target: Vec3::new(0.0, 0.55, 0.0),
        up: Vec3::Y,
        vfov_deg: 30.0,
        width,
        height,
        image_offset: Vec2::ZERO,
    };
    let mut s = Scene::new(objects, env, camera);
    s.visibility = true;
    s.area_lights.push(AreaLight {
        center: Vec3::new(0.1, 1.6, -0.1),
        size: Vec2::new(1.6, 1.0),
        // x̂ = X, ŷ = Z, ẑ = −Y: emits downwards (right-handed).
        world_from_light: Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y),
        intensity: Vec3::splat(2.0),
        texture: Some(Arc::new(test_texture(64))),
        light_field: None,
    });
    s
}

/// Pixels whose centre and four corners all see object `object` (no
/// coverage noise from the pixel's jitter), row-major.
#[must_use]
pub fn covered_pixels(scene: &Scene, object: u32) -> Vec<bool> {
    let bvh = SceneBvh::from_scene(scene);
    let (w, h) = (scene.camera.width, scene.camera.height);
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            [(0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .iter()
                .all(|&(dx, dy)| {
                    let (o, d) = scene.camera.ray(x + dx, y + dy);
                    bvh.intersect(o, d, 0.0, f32::INFINITY)
                        .is_some_and(|hit| hit.object == object)
                })
        })
        .collect()
}

/// Mean over `mask` of each pixel's variance of the luminance across
/// independent renders of `scene` at `spp` (seeds `1..=seeds`, ≥ 2), and
/// the seconds per render.
///
/// # Errors
/// As [`render_reference_with`].
pub fn pixel_variance(
    scene: &Scene,
    opts: &ReferenceOptions,
    seeds: u64,
    mask: &[bool],
) -> Result<(f64, f64), ReferenceError> {
    let bvh = SceneBvh::from_scene(scene);
    let light = EnvLight::new(&scene.env, opts.env_filter);
    let n = mask.len();
    let (mut sum, mut sq) = (vec![0.0f64; n], vec![0.0f64; n]);
    let t = Instant::now();
    let seeds = seeds.max(2);
    for seed in 1..=seeds {
        let o = ReferenceOptions {
            seed: 1000 + seed,
            pass_spp: opts.spp,
            ..*opts
        };
        let r = render_reference_with(scene, &bvh, &light, &o, &NoProgress)?;
        for (i, p) in r.image.pixels.iter().enumerate() {
            let l = f64::from(luminance(*p));
            sum[i] += l;
            sq[i] += l * l;
        }
    }
    let k = seeds as f64;
    let (mut total, mut count) = (0.0, 0usize);
    for i in (0..n).filter(|&i| mask[i]) {
        let mean = sum[i] / k;
        total += ((sq[i] - k * mean * mean) / (k - 1.0)).max(0.0);
        count += 1;
    }
    Ok((total / count.max(1) as f64, t.elapsed().as_secs_f64() / k))
}

/// The image mean over `mask` of two renders and its difference in
/// standard errors: `(mean a, mean b, |a − b| / σ)` with σ from the
/// renders' own per-pixel standard errors (independent seeds).
///
/// # Errors
/// As [`render_reference_with`].
pub fn mean_agreement(
    scene: &Scene,
    a: &ReferenceOptions,
    b: &ReferenceOptions,
    mask: &[bool],
) -> Result<(f64, f64, f64), ReferenceError> {
    let bvh = SceneBvh::from_scene(scene);
    let light = EnvLight::new(&scene.env, a.env_filter);
    let ra = render_reference_with(scene, &bvh, &light, a, &NoProgress)?;
    let rb = render_reference_with(scene, &bvh, &light, b, &NoProgress)?;
    let (mut ma, mut mb, mut var, mut n) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for i in (0..mask.len()).filter(|&i| mask[i]) {
        ma += f64::from(luminance(ra.image.pixels[i]));
        mb += f64::from(luminance(rb.image.pixels[i]));
        var += f64::from(ra.std_error[i]).powi(2) + f64::from(rb.std_error[i]).powi(2);
        n += 1;
    }
    let nf = n.max(1) as f64;
    let sigma = var.sqrt() / nf;
    let (ma, mb) = (ma / nf, mb / nf);
    Ok((ma, mb, (ma - mb).abs() / sigma.max(f64::MIN_POSITIVE)))
}

/// `∫ p(ω) dω` of a face product over the whole sphere by the midpoint
/// rule on an `res × 2res` (θ, φ) grid, with `sin θ dθ dφ`.
#[must_use]
pub fn pdf_sphere_integral(face: &FaceProduct, res: usize) -> f64 {
    let (dt, dp) = (
        std::f64::consts::PI / res as f64,
        std::f64::consts::PI / res as f64,
    );
    let mut sum = 0.0f64;
    for j in 0..res {
        let theta = (j as f64 + 0.5) * dt;
        let (st, ct) = theta.sin_cos();
        let mut row = 0.0f64;
        for i in 0..2 * res {
            let phi = (i as f64 + 0.5) * dp;
            let d = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
            row += f64::from(face.pdf(d));
        }
        sum += row * st;
    }
    sum * dt * dp
}

/// The face product of [`glossy_scene`]'s light and BRDF at point `p` with
/// shading normal `n`, viewed from `eye` (for the sampler checks).
#[must_use]
pub fn glossy_face_product(
    scene: &Scene,
    options: &WaveletSamplingOptions,
    p: Vec3,
    n: Vec3,
    eye: Vec3,
) -> FaceProduct {
    let light = &scene.area_lights[0];
    let grid = LightGrid::of(light, options.light_order);
    let frame = Frame::from_z(n);
    let wo = frame.to_local((eye - p).normalize());
    let brdf = glossy_brdf();
    let mut f = FaceProduct::new(options);
    f.build(&grid, light, p, |d| {
        let l = frame.to_local(d);
        if l.z <= 0.0 {
            Vec3::ZERO
        } else {
            brdf.eval(wo, l) * l.z
        }
    });
    f
}

/// Sizes of the `verify importance` runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveletVerifyOptions {
    /// Image side (square) of the renders.
    pub size: usize,
    /// Samples per pixel of the unbiasedness renders.
    pub high_spp: u32,
    /// Samples per pixel of the variance renders (issue 13: 8).
    pub low_spp: u32,
    /// Independent seeds per variance estimate.
    pub seeds: u64,
    /// The wavelet strategy's settings.
    pub wavelet: WaveletSamplingOptions,
}

impl WaveletVerifyOptions {
    /// The full run, or a quick smoke run (smaller image, fewer samples).
    #[must_use]
    pub fn new(quick: bool) -> Self {
        Self {
            size: if quick { 24 } else { 48 },
            high_spp: if quick { 128 } else { 512 },
            low_spp: 8,
            seeds: if quick { 6 } else { 12 },
            wavelet: WaveletSamplingOptions::default(),
        }
    }
}

/// The `verify importance` rows (module docs).
///
/// # Errors
/// A render that fails (bad options).
pub fn verify_wavelet_sampling(o: &WaveletVerifyOptions) -> Result<Vec<VerifyRow>, ReferenceError> {
    const ISSUE: &str = "issue 13 (verify: importance sampling)";
    let scene = glossy_scene(o.size, o.size);
    let mask = covered_pixels(&scene, 0);
    let pixels = mask.iter().filter(|&&m| m).count();
    let mut rows = Vec::new();
    // The density integrates to one (points on the sphere facing the light
    // at several angles).
    let mut worst = 0.0f64;
    for (p, n) in [
        (Vec3::new(0.0, 1.0, 0.0), Vec3::Y),
        (Vec3::new(0.0, 0.5 + 0.35, 0.35), Vec3::new(0.0, 0.7, 0.7)),
        (Vec3::new(-0.35, 0.5 + 0.35, 0.0), Vec3::new(-0.7, 0.7, 0.0)),
    ] {
        let f = glossy_face_product(&scene, &o.wavelet, p, n.normalize(), scene.camera.eye);
        worst = worst.max((pdf_sphere_integral(&f, 1024) - 1.0).abs());
    }
    rows.push(row(
        "pdf: |∫ p dω − 1| over the sphere (3 points, 1024 × 2048 midpoints)",
        worst,
        "absolute",
        Some((5e-3, true)),
        "quadrature bound of this check (jumps at cell edges)",
    ));
    let base = ReferenceOptions {
        wavelet: o.wavelet,
        ..ReferenceOptions::default()
    };
    let high = |strategy, seed| ReferenceOptions {
        spp: o.high_spp,
        pass_spp: o.high_spp,
        seed,
        light_sampling: strategy,
        ..base
    };
    let (mw, mm, z) = mean_agreement(
        &scene,
        &high(LightSampling::Wavelet, 7),
        &high(LightSampling::Mis, 8),
        &mask,
    )?;
    rows.push(row(
        format!(
            "unbiased: wavelet vs MIS mean over {pixels} sphere px at {} spp ({mw:.5} vs {mm:.5})",
            o.high_spp
        ),
        z,
        "|difference| / σ",
        Some((3.0, true)),
        ISSUE,
    ));
    let low = |strategy| ReferenceOptions {
        spp: o.low_spp,
        light_sampling: strategy,
        ..base
    };
    let (vw, tw) = pixel_variance(&scene, &low(LightSampling::Wavelet), o.seeds, &mask)?;
    let (vl, tl) = pixel_variance(&scene, &low(LightSampling::LightOnly), o.seeds, &mask)?;
    let (vm, tm) = pixel_variance(&scene, &low(LightSampling::Mis), o.seeds, &mask)?;
    rows.push(row(
        format!(
            "variance at {} spp: light sampling / wavelet ({} seeds, {pixels} sphere px)",
            o.low_spp, o.seeds
        ),
        vl / vw,
        "ratio of mean pixel variances",
        Some((10.0, false)),
        ISSUE,
    ));
    rows.push(row(
        format!(
            "variance at {} spp: default MIS (light + BSDF) / wavelet",
            o.low_spp
        ),
        vm / vw,
        "ratio of mean pixel variances",
        None,
        "informative",
    ));
    rows.push(row(
        format!(
            "time per {}-spp render, wavelet / light sampling ({:.3} s / {:.3} s; MIS {:.3} s)",
            o.low_spp, tw, tl, tm
        ),
        tw / tl,
        "ratio (noisy on a shared machine)",
        None,
        "informative",
    ));
    rows.push(row(
        format!(
            "efficiency (1 / variance × time): wavelet / light sampling, order {}, face {}",
            o.wavelet.order, o.wavelet.face
        ),
        (vl * tl) / (vw * tw),
        "ratio",
        None,
        "informative",
    ));
    Ok(rows)
}
