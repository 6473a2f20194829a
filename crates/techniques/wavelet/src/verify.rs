//! `relight verify wavelet`: relative RMS image error of the wavelet renderer
//! against the Monte Carlo reference (wavelet-rotation-2006 Tables 1 and 3),
//! and the SH renderer beside it.
//!
//! * [`verify_wavelet`]: relative RMS image error of the wavelet renderer
//!   against the reference renderer (no visibility, AO off, same BRDF) over
//!   the object pixels, for the caller's scenes and a set of configurations
//!   varied one parameter at a time around the paper's default
//!   (N = 64², ntess = 32², ntrunc = 1, 256 terms). Four errors per row,
//!   each overall and per object, beside the reference's own noise:
//!   1. `rel_rms_error`: the image as `relight render --method wavelet
//!      --aa K` draws it (per-vertex shading, Gouraud, rasterized at K × K
//!      times the resolution and box-downsampled like the reference's
//!      pixels, K = [`VerifyOptions::aa`]) on the scene's own meshes — the
//!      measure of the paper's Tables 1 and 3 and of the 0.07 target;
//!   2. `point_sampled_rel_rms_error`: the same with one sample at each
//!      pixel centre. Point samples against pixel integrals add the aliasing
//!      of every sub-pixel highlight, and that grows as meshes resolve finer
//!      ones, so this is a measure of aliasing more than of shading;
//!   3. `dense_rel_rms_error`: 1. on meshes subdivided to at least
//!      [`VerifyOptions::dense_vertices`] vertices per object (midpoint
//!      split by default, which keeps the surface and the reference);
//!   4. `per_pixel_rel_rms_error`: the wavelet shading evaluated per pixel
//!      sample (interpolated normal), K × K samples box-filtered: the
//!      technique's error with no vertex under-sampling at all.
//!
//!   Measured on the default scene (320 × 180, N = 64², ntess = 32²,
//!   ntrunc = 1, 256 terms, K = 4, 4096-spp reference with noise 0.016;
//!   sphere / knot / torus at 18.7 K / 131.8 K / 24.9 K vertices): antialiased
//!   0.066 (0.047/0.078/0.028), point-sampled 0.239 (0.051/0.303/0.086),
//!   per pixel 0.043 (0.043/0.044/0.029). With the knot at 33 K vertices
//!   the antialiased error was 0.166 (knot 0.200) and the point-sampled one
//!   0.185: the denser knot resolves its Phong-40 highlights of the 1.5°
//!   sun, which lowers the antialiased error and raises the point-sampled one.
//! * [`verify_wavelet_with_sh`]: the above plus the SH renderer
//!   (`relight_shlight`) at several orders on the same reference, flagging
//!   the order whose frame time matches the wavelet's.
//!
//! # Verdict
//! Issue 4 sets one accuracy target: "At N = 64², ntess = 32², ntrunc = 1,
//! 256 terms the image error must be at most 0.07 (paper: 0.062 for its
//! scene) on the default scene" ([`TARGET`], [`TARGET_CONFIG`],
//! [`TARGET_SCENE`] with the scene's own materials). That row passes when
//! `rel_rms_error ≤ 0.07` ([`judge`]). It is judged only when the
//! reference's own noise is at most a third of the target
//! ([`NOISE_FRACTION`]): the measured error is ≈ √(e² + noise²), and at a
//! third the noise adds at most 5.4 % (√(1 + 1/9)) to an error at the target.
//! The quick run's 128-spp reference (noise ≈ 0.10) cannot judge it, so
//! there the row is a report that says so; the full run's 4096-spp
//! reference (noise ≈ 0.016) does. Every other row is a report: the paper's
//! Tables 1 and 3 give errors for its own scene only, which the row's
//! `source` quotes beside it. The SH comparison rows are reports (issue 4
//! asks to show where each method wins, with no bound).

use crate::brdf_bake::{BrdfBake, BrdfBakeParams, bake_brdf};
use crate::error::WaveletError;
use crate::render::WaveletRenderer;
use crate::rotation::{RotationMatrices, RotationParams, bake_rotation};
use crate::study::{bake_or_load_brdf, bake_or_load_rotation, default_cache_dir};
use glam::Vec3;
use relight_brdf::{Brdf, BrdfSpec};
use relight_render::raster::{Background, DrawCall, RasterOptions, Rasterizer};
use relight_render::reference::{ReferenceOptions, render_reference};
use relight_render::{Image, Progress, Scene};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// One accuracy row (`relight verify wavelet`).
#[derive(Clone, Debug, Serialize)]
pub struct VerifyRow {
    /// Scene name.
    pub scene: String,
    /// BRDF spec.
    pub brdf: String,
    /// Source side n (N = n²).
    pub n: usize,
    /// Normal tessellation side.
    pub ntess: usize,
    /// Truncation threshold.
    pub ntrunc: u16,
    /// Lighting terms.
    pub terms: usize,
    /// Relative RMS image error vs the reference over object pixels: the
    /// image as `relight render --method wavelet --aa K` draws it, K = `aa`
    /// (per-vertex shading, Gouraud, rasterized at K × K times the
    /// resolution and box-downsampled — the reference's own pixel filter)
    /// on the scene's own meshes. The measure of the paper's Tables 1 and 3.
    pub rel_rms_error: f64,
    /// The same error per object (`/`-separated, scene object order).
    pub per_object: String,
    /// The Gouraud image with one sample at each pixel centre: point
    /// samples against the reference's pixel integrals, so this adds the
    /// aliasing of sub-pixel detail (it grows as meshes get denser and
    /// resolve finer highlights).
    pub point_sampled_rel_rms_error: f64,
    /// [`VerifyRow::point_sampled_rel_rms_error`] per object.
    pub point_sampled_per_object: String,
    /// The wavelet shading evaluated per pixel sample (interpolated normal),
    /// `aa × aa` samples box-filtered: the technique's error with no vertex
    /// under-sampling at all.
    pub per_pixel_rel_rms_error: f64,
    /// [`VerifyRow::per_pixel_rel_rms_error`] per object.
    pub per_pixel_per_object: String,
    /// Vertices per object of the dense meshes (`/`-separated; empty when
    /// [`VerifyOptions::dense_vertices`] is 0).
    pub dense_vertices: String,
    /// The Gouraud image on the dense meshes ([`VerifyOptions::densify`]),
    /// rasterized at `aa × aa` times the resolution and box-downsampled,
    /// against the reference of the dense scene: the renderer as the paper
    /// runs it (per-vertex shading of ~100 K-vertex models) and antialiased
    /// like the reference. `null` when densifying is off.
    pub dense_rel_rms_error: Option<f64>,
    /// [`VerifyRow::dense_rel_rms_error`] per object.
    pub dense_per_object: String,
    /// The reference's own noise as a relative RMS over the same pixels,
    /// `√(3 Σ se²) / √(Σ |ref|²)` from its per-pixel standard errors (the
    /// floor under both errors: they are ≈ √(e² + noise²)).
    pub reference_noise: f64,
    /// The dense scene's reference noise (same measure; equal to
    /// `reference_noise` for [`Densify::Linear`], which shares the reference).
    pub dense_reference_noise: Option<f64>,
    /// Lighting change time, ms (one warm call; `relight bench wavelet`
    /// gives medians).
    pub light_change_ms: f64,
    /// View change (vertex shading + raster) time, ms (one warm call).
    pub view_change_ms: f64,
    /// View change on the dense meshes (vertex shading + raster at
    /// `aa × aa` times the resolution + downsampling), ms.
    pub dense_view_change_ms: Option<f64>,
    /// `rel_rms_error ≤ target` for the issue-4 row; `None` for reports
    /// (module docs, [`judge`]).
    pub pass: Option<bool>,
    /// [`TARGET`] on the judged row.
    pub target: Option<f64>,
    /// Where the target comes from, or why the row is a report.
    pub source: Option<String>,
}

/// Issue 4's bound on `rel_rms_error` (wavelet-rotation-2006 Table 3 gives
/// 0.062 for the paper's scene).
pub const TARGET: f64 = 0.07;
/// The configuration `(n, ntess, ntrunc, terms)` the target is stated for.
pub const TARGET_CONFIG: (usize, usize, u16, usize) = (64, 32, 1, 256);
/// The scene name the target is stated for: the CLI's name for
/// `relight_scene::default_scene`, judged with its own materials (`brdf =
/// "scene"`).
pub const TARGET_SCENE: &str = "default";
/// The largest reference noise, as a fraction of [`TARGET`], at which the
/// target row is judged (module docs).
pub const NOISE_FRACTION: f64 = 1.0 / 3.0;
/// The source of the judged row.
pub const SOURCE: &str = "issue 4: N=64², ntess=32², ntrunc=1, 256 terms, default scene: \
     error ≤ 0.07 (wavelet-rotation-2006 Table 3: 0.062 for its scene)";

/// `pass`, `target` and `source` of a [`VerifyRow`] (module docs): the
/// issue-4 row (scene [`TARGET_SCENE`], `brdf = "scene"`, [`TARGET_CONFIG`])
/// is judged, `error ≤` [`TARGET`] (NaN fails), when `noise ≤`
/// [`NOISE_FRACTION`] × [`TARGET`]; every other row is a report whose source
/// quotes the paper's figure for that configuration where it has one.
#[must_use]
pub fn judge(
    scene: &str,
    brdf: &str,
    config: (usize, usize, u16, usize),
    error: f64,
    noise: f64,
) -> (Option<bool>, Option<f64>, Option<String>) {
    let report = |why: String| (None, None, Some(why));
    if config == TARGET_CONFIG && scene == TARGET_SCENE && brdf == "scene" {
        if noise <= NOISE_FRACTION * TARGET {
            (
                Some(error <= TARGET),
                Some(TARGET),
                Some(SOURCE.to_string()),
            )
        } else {
            report(format!(
                "report: reference noise above {TARGET}/3, too high to judge issue 4's ≤ {TARGET} \
                 (the full run judges it)"
            ))
        }
    } else {
        report(paper_figure(config).map_or_else(
            || "report: no target stated for this case".to_string(),
            |(table, value)| format!("report: {table} gives {value} for the paper's own scene"),
        ))
    }
}

/// The paper's image error for `(n, ntess, ntrunc, terms)`, where Table 1
/// (ntrunc at N = 64², ntess = 32²) or Table 3 (ntess at N = 64², ntrunc = 1)
/// lists one; 256 terms ("we typically use 128–256 terms").
fn paper_figure(config: (usize, usize, u16, usize)) -> Option<(&'static str, f64)> {
    match config {
        (64, 32, 1, 256) => Some(("Table 3", 0.062)),
        (64, 32, 8, 256) => Some(("Table 1", 0.067)),
        (64, 32, 16, 256) => Some(("Table 1", 0.068)),
        (64, 32, 32, 256) => Some(("Table 1", 0.077)),
        (64, 32, 128, 256) => Some(("Table 1", 0.102)),
        (64, 8, 1, 256) => Some(("Table 3", 0.225)),
        (64, 16, 1, 256) => Some(("Table 3", 0.087)),
        (64, 64, 1, 256) => Some(("Table 3", 0.051)),
        _ => None,
    }
}

/// Why the SH comparison rows are reports.
pub const REPORT_COMPARE: &str =
    "report: issue 4 asks where wavelets win and where SH does, with no bound";

/// How [`verify_wavelet`] densifies each object's mesh for the dense-mesh
/// Gouraud error ([`VerifyRow::dense_rel_rms_error`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum Densify {
    /// Loop subdivision ([`Mesh::subdivide_to_vertices`]): the smooth
    /// subdivision surface with its smooth normals, like a dense scanned
    /// model. The surface moves slightly (Loop smooths the knot's finest
    /// bumps), so the reference is rendered again on the dense scene.
    ///
    /// [`Mesh::subdivide_to_vertices`]: relight_geom::Mesh::subdivide_to_vertices
    Loop,
    /// Midpoint split with interpolated (renormalized) normals
    /// ([`Mesh::subdivide_midpoint`]): the same surface and, up to renormalizing the
    /// new vertex normals, the same shading-normal field as the original
    /// mesh, so the original reference applies (the default: it isolates
    /// vertex density from any change of the surface).
    ///
    /// [`Mesh::subdivide_midpoint`]: relight_geom::Mesh::subdivide_midpoint
    #[default]
    Linear,
}

/// The SH renderer beside the wavelet one (`relight verify wavelet`):
/// same scene, BRDF and reference, both antialiased with `aa × aa` samples.
#[derive(Clone, Debug, Serialize)]
pub struct CompareRow {
    /// Scene name.
    pub scene: String,
    /// BRDF spec.
    pub brdf: String,
    /// `wavelet n=… ntess=… terms=…` or `sh order L`.
    pub method: String,
    /// Relative RMS error vs the reference over the pixels the method covers.
    pub rel_rms_error: f64,
    /// Per object (`/`-separated).
    pub per_object: String,
    /// Frame time for a lighting change (wavelet: lighting + shading; SH:
    /// projection + per-vertex rotation + shading), ms, on this machine.
    pub frame_ms: f64,
    /// True for the SH order whose frame time is closest to the wavelet's.
    pub same_cost: bool,
    /// Always `None`: a report ([`REPORT_COMPARE`]).
    pub pass: Option<bool>,
    /// Always `None`.
    pub target: Option<f64>,
    /// [`REPORT_COMPARE`].
    pub source: Option<String>,
}

/// Configurations and settings of [`verify_wavelet`].
#[derive(Clone, Debug)]
pub struct VerifyOptions {
    /// `(n, ntess, ntrunc, terms)` to evaluate.
    pub configs: Vec<(usize, usize, u16, usize)>,
    /// BRDF specs applied to every object; `scene` keeps each object's own material.
    pub brdfs: Vec<String>,
    /// Reference samples per pixel.
    pub spp: u32,
    /// BRDF view grid side and terms per slice.
    pub views: usize,
    /// Terms per BRDF slice.
    pub brdf_terms: usize,
    /// Samples per pixel side of the antialiased errors (`rel_rms_error`,
    /// `per_pixel_rel_rms_error`, `dense_rel_rms_error`), ≥ 1.
    pub aa: usize,
    /// SH orders compared with the first configuration (empty: no comparison).
    pub sh_orders: Vec<usize>,
    /// Subdivide every object until it has at least this many vertices
    /// (at most [`VerifyOptions::dense_max_levels`] steps) for the dense-mesh
    /// Gouraud error; 0: off.
    pub dense_vertices: usize,
    /// Most subdivision steps per object.
    pub dense_max_levels: u32,
    /// Subdivision rule of the dense meshes.
    pub densify: Densify,
    /// Bake cache (None: bake in memory, no files).
    pub cache_dir: Option<PathBuf>,
}

impl VerifyOptions {
    /// The paper's studies, one parameter varied at a time around
    /// N = 64², ntess = 32², ntrunc = 1, 256 terms (Tables 1, 3; Figure 7
    /// terms). The reference takes 4096 samples per pixel: at 1024 its own
    /// noise is ≈ 0.03 relative RMS on the default scene, half the 0.07 budget.
    #[must_use]
    pub fn full() -> Self {
        let mut configs = vec![(64, 32, 1, 256)];
        for t in [16, 128] {
            configs.push((64, 32, t, 256));
        }
        for s in [8, 16] {
            configs.push((64, s, 1, 256));
        }
        configs.push((32, 32, 1, 256));
        for k in [128, 2048] {
            configs.push((64, 32, 1, k));
        }
        Self {
            configs,
            brdfs: vec!["scene".into(), "ggx:0.1".into(), "lambert".into()],
            spp: 4096,
            views: 64,
            brdf_terms: 128,
            aa: 4,
            sh_orders: vec![3, 5, 8, 12],
            dense_vertices: 60_000,
            dense_max_levels: 3,
            densify: Densify::Linear,
            cache_dir: Some(default_cache_dir()),
        }
    }
    /// A smoke run: N = 32², ntess = 16², one BRDF, few samples.
    #[must_use]
    pub fn quick() -> Self {
        Self {
            configs: vec![(32, 16, 1, 256), (64, 32, 1, 256)],
            brdfs: vec!["scene".into()],
            spp: 128,
            views: 32,
            brdf_terms: 128,
            aa: 2,
            sh_orders: vec![3, 6],
            dense_vertices: 15_000,
            dense_max_levels: 1,
            densify: Densify::Linear,
            cache_dir: Some(default_cache_dir()),
        }
    }
}

fn rot_for(
    p: &RotationParams,
    cache: Option<&Path>,
    progress: &dyn Progress,
) -> Result<Arc<RotationMatrices>, WaveletError> {
    match cache {
        Some(d) => bake_or_load_rotation(p, d, progress).map(|(r, _)| r),
        None => Ok(Arc::new(bake_rotation(p, progress)?)),
    }
}

fn brdf_for(
    p: &BrdfBakeParams,
    brdf: &dyn Brdf,
    cache: Option<&Path>,
    progress: &dyn Progress,
) -> Result<Arc<BrdfBake>, WaveletError> {
    match cache {
        Some(d) => bake_or_load_brdf(p, brdf, d, progress).map(|(b, _)| b),
        None => Ok(Arc::new(bake_brdf(p, brdf, progress)?)),
    }
}

/// Object index seen at the centre of every pixel (`-1`: background).
#[must_use]
pub fn object_ids(scene: &Scene) -> Vec<i32> {
    let draws: Vec<DrawCall> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| DrawCall::new(&o.mesh.positions, &o.mesh.indices).with_object_id(i as u32))
        .collect();
    let mut img = Image::new(scene.camera.width, scene.camera.height);
    let opts = RasterOptions::default().fit_depth(&scene.camera, &draws);
    let mut r = Rasterizer::new();
    let ok = r
        .render(
            &scene.camera,
            &draws,
            |f| Vec3::splat(f.object as f32 + 1.0),
            Background::Color(Vec3::ZERO),
            &opts,
            &mut img,
        )
        .is_ok();
    img.pixels
        .iter()
        .map(|p| if ok { p.x.round() as i32 - 1 } else { -1 })
        .collect()
}

/// Relative RMS error of `img` against `reference` over `mask`, for the
/// whole mask and per object (`ids` from [`object_ids`]) as `a/b/c`.
fn errors(
    img: &Image,
    reference: &Image,
    mask: &[bool],
    ids: &[i32],
    objects: usize,
) -> (f64, String) {
    let all = img.relative_rms_error(reference, Some(mask));
    let per: Vec<String> = (0..objects)
        .map(|k| {
            let m: Vec<bool> = mask
                .iter()
                .zip(ids)
                .map(|(&a, &i)| a && i == k as i32)
                .collect();
            format!("{:.3}", img.relative_rms_error(reference, Some(&m)))
        })
        .collect();
    (all, per.join("/"))
}

/// `scene` with every object's mesh subdivided by `rule` until it has at
/// least `target` vertices (at most `max_levels` steps); same materials,
/// lighting and camera.
#[must_use]
pub fn densified_scene(scene: &Scene, rule: Densify, target: usize, max_levels: u32) -> Scene {
    let mut s = scene.clone();
    for o in &mut s.objects {
        let mesh = match rule {
            Densify::Loop => o.mesh.subdivide_to_vertices(target, max_levels).0,
            Densify::Linear => {
                let mut m = (*o.mesh).clone();
                let mut levels = 0;
                while m.positions.len() < target && levels < max_levels && !m.indices.is_empty() {
                    m = m.subdivide_midpoint();
                    levels += 1;
                }
                m
            }
        };
        o.mesh = Arc::new(mesh);
    }
    s
}

/// The reference's own noise over `mask` as a relative RMS:
/// `√(3 Σ se²) / √(Σ |ref|²)` from its per-pixel standard errors.
fn reference_noise(reference: &relight_render::reference::ReferenceImage, mask: &[bool]) -> f64 {
    let (mut se, mut den) = (0.0f64, 0.0f64);
    for (i, &m) in mask.iter().enumerate() {
        if m {
            se += 3.0 * f64::from(reference.std_error[i]).powi(2);
            den += f64::from(reference.image.pixels[i].length_squared());
        }
    }
    if den > 0.0 { (se / den).sqrt() } else { 0.0 }
}

/// Relative RMS image error of the wavelet renderer against the reference
/// renderer (visibility off, same BRDF, AO off) over object pixels, for every
/// `(name, scene)` × BRDF × configuration.
///
/// # Errors
/// Bad BRDF specs or parameters, cancellation, cache IO.
pub fn verify_wavelet(
    scenes: &[(String, Scene)],
    opts: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, WaveletError> {
    let o = VerifyOptions {
        sh_orders: Vec::new(),
        ..opts.clone()
    };
    Ok(verify_wavelet_with_sh(scenes, &o, progress)?.0)
}

/// [`verify_wavelet`] plus, for the first configuration of every scene and
/// BRDF, the SH renderer (`relight_shlight::ShRenderer`, exact per-pixel
/// rotation) at `opts.sh_orders` against the same reference, both
/// antialiased with `aa × aa` samples per pixel; the SH order whose frame
/// time is closest to the wavelet's is flagged `same_cost`.
///
/// # Errors
/// As [`verify_wavelet`], plus SH renderer errors.
pub fn verify_wavelet_with_sh(
    scenes: &[(String, Scene)],
    opts: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<(Vec<VerifyRow>, Vec<CompareRow>), WaveletError> {
    let mut rows = Vec::new();
    let mut compare = Vec::new();
    let cache = opts.cache_dir.as_deref();
    let aa = opts.aa.max(1);
    for (name, scene) in scenes {
        // The dense meshes do not depend on the BRDF: subdivide once per scene.
        let dense = (opts.dense_vertices > 0).then(|| {
            densified_scene(
                scene,
                opts.densify,
                opts.dense_vertices,
                opts.dense_max_levels,
            )
        });
        let dense_counts = dense.as_ref().map_or_else(String::new, |d| {
            d.objects
                .iter()
                .map(|o| o.mesh.positions.len().to_string())
                .collect::<Vec<_>>()
                .join("/")
        });
        for spec in &opts.brdfs {
            // `scene`: every object keeps its own material (baked per object,
            // keyed by the model's Debug description); else one spec for all.
            // The unshadowed integral the technique computes (module docs).
            let mut sc = scene.clone();
            sc.visibility = false;
            if spec != "scene" {
                let parsed: BrdfSpec = spec
                    .parse()
                    .map_err(|e| crate::error::bad("brdf", spec, format!("{e}")))?;
                let brdf = parsed.build();
                for o in &mut sc.objects {
                    o.brdf = brdf.clone();
                }
            }
            let ropts = ReferenceOptions {
                spp: opts.spp,
                ..ReferenceOptions::default()
            };
            let reference =
                render_reference(&sc, &ropts, progress).map_err(|_| WaveletError::Cancelled)?;
            let ids = object_ids(&sc);
            let nobj = sc.objects.len();
            let mut big = sc.clone();
            big.camera.width *= aa;
            big.camera.height *= aa;
            // Dense scene with this BRDF; its reference (Loop moves the
            // surface) or the original one (Linear keeps it), ids and mask.
            let dense_sc = dense.as_ref().map(|d| {
                let mut d = d.clone();
                for (o, s) in d.objects.iter_mut().zip(&sc.objects) {
                    o.brdf = s.brdf.clone();
                }
                d
            });
            let dense_ref = match (&dense_sc, opts.densify) {
                (Some(d), Densify::Loop) => {
                    let rd = render_reference(d, &ropts, progress)
                        .map_err(|_| WaveletError::Cancelled)?;
                    let ids_d = object_ids(d);
                    let mask_d: Vec<bool> = ids_d.iter().map(|&i| i >= 0).collect();
                    Some((Some(rd), ids_d, mask_d))
                }
                (Some(_), Densify::Linear) => None,
                (None, _) => None,
            };
            let big_dense = dense_sc.as_ref().map(|d| {
                let mut b = d.clone();
                b.camera.width *= aa;
                b.camera.height *= aa;
                b
            });
            for (ci, &(n, ntess, ntrunc, terms)) in opts.configs.iter().enumerate() {
                progress.check()?;
                let rp = RotationParams::new(n, ntess, ntrunc);
                let rot = rot_for(&rp, cache, progress)?;
                let mut bakes = Vec::with_capacity(sc.objects.len());
                for o in &sc.objects {
                    let key = if spec == "scene" {
                        o.brdf.label()
                    } else {
                        spec.clone()
                    };
                    let bp = BrdfBakeParams::new(
                        &key,
                        rp.m,
                        opts.views,
                        opts.brdf_terms.min(rp.target_len()),
                    );
                    bakes.push(brdf_for(&bp, o.brdf.as_ref(), cache, progress)?);
                }
                let mut r = WaveletRenderer::new(rot, terms.min(rp.source_len()))?;
                // Each timing is of a second call: the first one pages in the
                // memory-mapped bake files (hundreds of MB at N = 64²).
                r.set_lighting(&sc.env, glam::Mat3::IDENTITY)?;
                let t0 = Instant::now();
                r.set_lighting(&sc.env, glam::Mat3::IDENTITY)?;
                let light_ms = t0.elapsed().as_secs_f64() * 1e3;
                let refs: Vec<&BrdfBake> = bakes.iter().map(AsRef::as_ref).collect();
                let _ = r.render_with_mask(&sc, &refs, &sc.camera, None)?;
                let t1 = Instant::now();
                let (img, mask) = r.render_with_mask(&sc, &refs, &sc.camera, None)?;
                let view_ms = t1.elapsed().as_secs_f64() * 1e3;
                let t2 = Instant::now();
                let (pimg, _) = r.render_per_pixel(&big, &refs, &big.camera)?;
                let pimg = pimg.box_downsample(aa);
                let aa_ms = t2.elapsed().as_secs_f64() * 1e3;
                let (e, per) = errors(&img, &reference.image, &mask, &ids, nobj);
                let (ea, per_a) = errors(&pimg, &reference.image, &mask, &ids, nobj);
                let noise = reference_noise(&reference, &mask);
                // Gouraud at aa × aa the resolution, box-downsampled.
                let (gimg, _) = r.render_with_mask(&big, &refs, &big.camera, None)?;
                let gimg = gimg.box_downsample(aa);
                let (eg, per_g) = errors(&gimg, &reference.image, &mask, &ids, nobj);
                // The same on the dense meshes, against the dense scene's reference.
                let mut dense_out = None;
                if let Some(bd) = &big_dense {
                    let t3 = Instant::now();
                    let (dimg, _) = r.render_with_mask(bd, &refs, &bd.camera, None)?;
                    let dimg = dimg.box_downsample(aa);
                    let dense_ms = t3.elapsed().as_secs_f64() * 1e3;
                    let (rd, ids_d, mask_d) = match &dense_ref {
                        Some((Some(rd), i, m)) => (rd, &i[..], &m[..]),
                        _ => (&reference, &ids[..], &mask[..]),
                    };
                    let (ed, per_d) = errors(&dimg, &rd.image, mask_d, ids_d, nobj);
                    dense_out = Some((ed, per_d, reference_noise(rd, mask_d), dense_ms));
                }
                let (pass, target, source) =
                    judge(name, spec, (n, ntess, ntrunc, terms), eg, noise);
                rows.push(VerifyRow {
                    scene: name.clone(),
                    brdf: spec.clone(),
                    n,
                    ntess,
                    ntrunc,
                    terms,
                    rel_rms_error: eg,
                    per_object: per_g,
                    point_sampled_rel_rms_error: e,
                    point_sampled_per_object: per,
                    per_pixel_rel_rms_error: ea,
                    per_pixel_per_object: per_a.clone(),
                    dense_vertices: dense_counts.clone(),
                    dense_rel_rms_error: dense_out.as_ref().map(|d| d.0),
                    dense_per_object: dense_out.as_ref().map_or_else(String::new, |d| d.1.clone()),
                    reference_noise: noise,
                    dense_reference_noise: dense_out.as_ref().map(|d| d.2),
                    light_change_ms: light_ms,
                    view_change_ms: view_ms,
                    dense_view_change_ms: dense_out.as_ref().map(|d| d.3),
                    pass,
                    target,
                    source,
                });
                if ci == 0 && !opts.sh_orders.is_empty() {
                    let wave_ms = light_ms + aa_ms;
                    let first = compare.len();
                    compare.push(CompareRow {
                        scene: name.clone(),
                        brdf: spec.clone(),
                        method: format!("wavelet n={n} ntess={ntess} terms={terms}"),
                        rel_rms_error: ea,
                        per_object: per_a,
                        frame_ms: wave_ms,
                        same_cost: false,
                        pass: None,
                        target: None,
                        source: Some(REPORT_COMPARE.into()),
                    });
                    for &order in &opts.sh_orders {
                        progress.check()?;
                        let sh = relight_shlight::ShRenderer::new(
                            order,
                            relight_shlight::ShRotationMethod::Exact,
                        )
                        .map_err(|e| crate::error::bad("sh order", order, e.to_string()))?
                        .with_supersampling(aa);
                        // First call bakes the SH BRDF tables (cached in the
                        // renderer); the second is timed.
                        sh.render(&sc, None, progress)
                            .map_err(|e| crate::error::bad("sh render", order, e.to_string()))?;
                        let t = Instant::now();
                        let out = sh
                            .render(&sc, None, progress)
                            .map_err(|e| crate::error::bad("sh render", order, e.to_string()))?;
                        let ms = t.elapsed().as_secs_f64() * 1e3;
                        let m: Vec<bool> =
                            out.mask.iter().zip(&mask).map(|(a, b)| *a && *b).collect();
                        let (es, per_s) = errors(&out.image, &reference.image, &m, &ids, nobj);
                        compare.push(CompareRow {
                            scene: name.clone(),
                            brdf: spec.clone(),
                            method: format!("sh order {order}"),
                            rel_rms_error: es,
                            per_object: per_s,
                            frame_ms: ms,
                            same_cost: false,
                            pass: None,
                            target: None,
                            source: Some(REPORT_COMPARE.into()),
                        });
                    }
                    if let Some(best) = (first + 1..compare.len()).min_by(|&a, &b| {
                        (compare[a].frame_ms - wave_ms)
                            .abs()
                            .total_cmp(&(compare[b].frame_ms - wave_ms).abs())
                    }) {
                        compare[best].same_cost = true;
                    }
                }
            }
        }
    }
    Ok((rows, compare))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::sphere_scene;

    /// The issue-4 row passes at the target and fails just over it (or at
    /// NaN); too noisy a reference, another scene, material or configuration
    /// makes a report.
    #[test]
    fn the_issue_4_row_is_judged_and_the_rest_are_reports() {
        let quiet = 0.016;
        let j = |scene, brdf, cfg, e, noise| judge(scene, brdf, cfg, e, noise);
        let (p, t, s) = j("default", "scene", TARGET_CONFIG, TARGET, quiet);
        assert_eq!((p, t), (Some(true), Some(TARGET)));
        assert_eq!(s.as_deref(), Some(SOURCE));
        let over = TARGET * (1.0 + 1e-9);
        assert_eq!(
            j("default", "scene", TARGET_CONFIG, over, quiet).0,
            Some(false)
        );
        assert_eq!(
            j("default", "scene", TARGET_CONFIG, f64::NAN, quiet).0,
            Some(false)
        );
        // Noise at a third of the target is judged; above it is a report.
        let edge = NOISE_FRACTION * TARGET;
        assert_eq!(
            j("default", "scene", TARGET_CONFIG, 0.05, edge).0,
            Some(true)
        );
        let (p, t, s) = j("default", "scene", TARGET_CONFIG, 0.05, edge * 1.01);
        assert_eq!((p, t), (None, None));
        assert!(s.unwrap().starts_with("report: reference noise"));
        for (scene, brdf, cfg) in [
            ("park", "scene", TARGET_CONFIG),
            ("default", "ggx:0.1", TARGET_CONFIG),
            ("default", "scene", (64, 32, 16, 256)),
            ("default", "scene", (32, 32, 1, 256)),
        ] {
            let (p, t, s) = j(scene, brdf, cfg, 0.01, quiet);
            assert_eq!((p, t), (None, None), "{scene} {brdf} {cfg:?}");
            assert!(s.unwrap().starts_with("report:"));
        }
        let s = j("default", "scene", (64, 32, 16, 256), 0.01, quiet)
            .2
            .unwrap();
        assert!(s.contains("Table 1 gives 0.068"), "{s}");
    }

    /// Midpoint subdivision keeps the surface and the reference's shading
    /// normals: every new vertex is the midpoint of a parent edge with the
    /// normal the reference interpolates there; counts are V + E and 4 F.
    #[test]
    fn linear_subdivision_keeps_surface_and_normal_field() {
        let m = relight_geom::shapes::uv_sphere_at(Vec3::new(0.2, -0.1, 0.3), 0.7, 7, 5);
        let edges: std::collections::HashSet<(u32, u32)> = m
            .indices
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
            .collect();
        let s = m.subdivide_midpoint();
        assert_eq!(s.positions.len(), m.positions.len() + edges.len());
        assert_eq!(s.normals.len(), s.positions.len());
        assert_eq!(s.indices.len(), 4 * m.indices.len());
        assert_eq!(&s.positions[..m.positions.len()], &m.positions[..]);
        for (t, &[a, b, c]) in m.indices.iter().enumerate() {
            // The child triangles of (a, b, c) are consecutive: the middle
            // one holds the three edge points (ab, bc, ca).
            let [ab, bc, ca] = s.indices[4 * t + 3];
            for (e, (p, q)) in [(ab, (a, b)), (bc, (b, c)), (ca, (c, a))] {
                let (e, p, q) = (e as usize, p as usize, q as usize);
                let mid = 0.5 * (m.positions[p] + m.positions[q]);
                assert!((s.positions[e] - mid).length() < 1e-6);
                let want = (0.5 * m.normals[p] + 0.5 * m.normals[q]).normalize();
                assert!(s.normals[e].dot(want) > 1.0 - 1e-6);
            }
        }
        let sc = sphere_scene("lambert".parse::<BrdfSpec>().unwrap().build(), 8, 8);
        let d = densified_scene(&sc, Densify::Linear, 40_000, 1);
        assert_eq!(
            d.objects[0].mesh.indices.len(),
            4 * sc.objects[0].mesh.indices.len(),
            "max_levels bounds the steps"
        );
    }
}
