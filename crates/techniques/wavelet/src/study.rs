//! The bake cache (`bake_or_load_*`), the synthetic lightings used by the
//! tests, and the speed study (`relight bench wavelet`, wavelet-rotation-2006
//! Tables 1, 2 and 4). The accuracy studies live in [`crate::verify`] (image
//! error, Tables 1 and 3) and [`crate::figure7`] (rotated lighting, Figure 7).
//!
//! * [`bench_wavelet`]: bake time, size, sparsity, non-zeros per row and
//!   lighting-change time (Tables 1–2, both storage layouts), and view-change
//!   time for 30 K–120 K vertices (Table 4).

use crate::brdf_bake::{BrdfBake, BrdfBakeParams, bake_brdf};
use crate::error::{WaveletError, io};
use crate::octa::{hemi_density, hemi_dir_from_uv, shading_frame};
use crate::render::{NormalInterp, WaveletRenderer};
use crate::rotation::{RotationMatrices, RotationParams, bake_rotation};
use glam::{DVec3, Vec3, Vec3A};
use relight_brdf::{Brdf, BrdfSpec};
use relight_geom::Mesh;
use relight_render::{NoProgress, Object, Progress, Scene};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Default bake cache: `$RELIGHT_CACHE`, else `$XDG_CACHE_HOME/relight/wavelet`,
/// else `$HOME/.cache/relight/wavelet`, else `./relight-cache/wavelet`.
#[must_use]
pub fn default_cache_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("RELIGHT_CACHE") {
        return PathBuf::from(d).join("wavelet");
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(d).join("relight/wavelet");
    }
    if let Some(h) = std::env::var_os("HOME") {
        return PathBuf::from(h).join(".cache/relight/wavelet");
    }
    PathBuf::from("relight-cache/wavelet")
}

/// Where a bake came from in `bake_or_load_*` (and the triple method's
/// tables): so that a re-bake which replaced an unusable cache file is said
/// ([`CacheUse::warning`]) rather than silent.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheUse {
    /// Read from a valid cache file.
    Loaded,
    /// Baked: there was no cache file.
    Baked,
    /// Baked, and the cache file at `path`, unusable because of `why`
    /// (corrupted, truncated, another format version, …), replaced.
    Replaced {
        /// The cache file.
        path: PathBuf,
        /// What was wrong with it ([`WaveletError::problem`]).
        why: String,
    },
}

impl CacheUse {
    /// A file at `path` that exists but could not be used because of `e`.
    #[must_use]
    pub fn replaced(path: &Path, e: &WaveletError) -> Self {
        Self::Replaced {
            path: path.to_path_buf(),
            why: e.problem(),
        }
    }

    /// True when the bake was read from the cache.
    #[must_use]
    pub fn loaded(&self) -> bool {
        *self == Self::Loaded
    }

    /// The one-line warning of a replaced file, led by `owner` (`method
    /// wavelet`, `ndf bake`); `None` when the cache was read or there was
    /// no file.
    #[must_use]
    pub fn warning(&self, owner: &str) -> Option<String> {
        match self {
            Self::Replaced { path, why } => Some(format!(
                "{owner}: cached bake {} was unusable ({why}); re-baked and replaced",
                path.display()
            )),
            Self::Loaded | Self::Baked => None,
        }
    }
}

/// Loads the rotation matrices for `params` from `cache_dir` (file name keyed
/// by every parameter and the format version), or bakes and stores them.
/// A stale or corrupted cache file is re-baked and replaced, and the
/// [`CacheUse`] says so.
///
/// # Errors
/// Bad parameters, cancellation, or an unwritable cache directory.
pub fn bake_or_load_rotation(
    params: &RotationParams,
    cache_dir: &Path,
    progress: &dyn Progress,
) -> Result<(Arc<RotationMatrices>, CacheUse), WaveletError> {
    params.validate()?;
    let path = cache_dir.join(params.cache_file_name());
    let mut used = CacheUse::Baked;
    if path.exists() {
        match RotationMatrices::load_expect(&path, params) {
            Ok(m) => return Ok((Arc::new(m), CacheUse::Loaded)),
            Err(e) => used = CacheUse::replaced(&path, &e),
        }
    }
    let m = bake_rotation(params, progress)?;
    std::fs::create_dir_all(cache_dir).map_err(io(cache_dir))?;
    m.save(&path)?;
    Ok((Arc::new(m), used))
}

/// [`bake_or_load_rotation`] for BRDF slices (`params.key` names the BRDF).
///
/// # Errors
/// Bad parameters, cancellation, or an unwritable cache directory.
pub fn bake_or_load_brdf(
    params: &BrdfBakeParams,
    brdf: &dyn Brdf,
    cache_dir: &Path,
    progress: &dyn Progress,
) -> Result<(Arc<BrdfBake>, CacheUse), WaveletError> {
    params.validate()?;
    let path = cache_dir.join(params.cache_file_name());
    let mut used = CacheUse::Baked;
    if path.exists() {
        match BrdfBake::load_expect(&path, params) {
            Ok(b) => return Ok((Arc::new(b), CacheUse::Loaded)),
            Err(e) => used = CacheUse::replaced(&path, &e),
        }
    }
    let b = bake_brdf(params, brdf, progress)?;
    std::fs::create_dir_all(cache_dir).map_err(io(cache_dir))?;
    b.save(&path)?;
    Ok((Arc::new(b), used))
}

/// [`bake_or_load_brdf`] for every object of `scene`, each keyed by its
/// model's `Debug` description: slices on the `m × m` target grid for
/// `views × views` view directions, `terms` kept (capped at m²). For tests
/// and studies: where each came from is not reported (the method reports it,
/// [`crate::WaveletMethod`]).
///
/// # Errors
/// As [`bake_or_load_brdf`].
pub fn bake_or_load_scene_brdfs(
    scene: &Scene,
    m: usize,
    views: usize,
    terms: usize,
    cache_dir: &Path,
    progress: &dyn Progress,
) -> Result<Vec<Arc<BrdfBake>>, WaveletError> {
    scene
        .objects
        .iter()
        .map(|o| {
            let key = o.brdf.label();
            let p = BrdfBakeParams::new(&key, m, views, terms.min(m * m));
            bake_or_load_brdf(&p, o.brdf.as_ref(), cache_dir, progress).map(|(b, _)| b)
        })
        .collect()
}

/// A smooth sky (blue gradient, bright warm lobe, dark ground) as a function
/// of the world direction (+Y up); used by tests.
pub fn smooth_sky() -> impl Fn(Vec3) -> Vec3 + Sync + Copy {
    |d: Vec3| {
        let sun = Vec3::new(0.4, 0.8, 0.3).normalize();
        let lobe = (d.dot(sun).max(0.0)).powi(8) * 3.0;
        let sky = if d.y > 0.0 {
            Vec3::new(0.3, 0.5, 0.9) * (0.5 + 0.5 * d.y)
        } else {
            Vec3::splat(0.15) * (1.0 + d.y)
        };
        sky + Vec3::new(1.0, 0.9, 0.7) * lobe
    }
}

/// A sky with a small sun (angular radius 3°, radiance 500) — all-frequency lighting.
pub fn sun_sky() -> impl Fn(Vec3) -> Vec3 + Sync + Copy {
    |d: Vec3| {
        let sun = Vec3::new(0.5, 0.7, 0.4).normalize();
        let disk = if d.dot(sun) > 3.0f32.to_radians().cos() {
            500.0
        } else {
            0.0
        };
        let sky = if d.y > 0.0 {
            Vec3::new(0.3, 0.5, 0.9) * (0.5 + 0.5 * d.y)
        } else {
            Vec3::splat(0.2)
        };
        sky + Vec3::new(1.0, 0.95, 0.85) * disk
    }
}

/// Reflected radiance `∫ f(ω_o, ω) L(ω) cos θ dω` at a surface with normal
/// `n` seen from `wo` (world, unit), by `q × q` midpoint quadrature of the
/// hemi-octahedral map with the exact area element (second way to compute
/// what the wavelet pipeline computes).
#[must_use]
pub fn direct_radiance(
    l: &dyn Fn(Vec3) -> Vec3,
    brdf: &dyn Brdf,
    n: Vec3,
    wo: Vec3,
    q: usize,
) -> Vec3 {
    let fr = shading_frame(n);
    let wl = fr.to_local(wo);
    let mut acc = DVec3::ZERO;
    for i in 0..q * q {
        let (c, r) = (i % q, i / q);
        let (u, v) = ((c as f64 + 0.5) / q as f64, (r as f64 + 0.5) / q as f64);
        let wi = hemi_dir_from_uv(u, v).as_vec3();
        let dw = hemi_density(u, v) / (q * q) as f64;
        let li = l(fr.from_local(wi));
        acc += (brdf.eval(wl, wi) * li * wi.z).as_dvec3() * dw;
    }
    acc.as_vec3()
}

/// One benchmark row (`relight bench wavelet`); fields that do not apply are `null`.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    /// `bake` (Tables 1–2) or `view` (Table 4).
    pub kind: String,
    /// Source side n.
    pub n: usize,
    /// Normal tessellation side.
    pub ntess: usize,
    /// Truncation threshold.
    pub ntrunc: u16,
    /// Matrix storage layout of `light_change_ms`: `csc` (ours) or `csr` (paper).
    pub layout: String,
    /// Bake time, s (wall clock).
    pub bake_s: Option<f64>,
    /// Bake CPU time summed over threads, s (robust to a busy machine).
    pub bake_cpu_s: Option<f64>,
    /// Stored matrix size, MB (10⁶ bytes).
    pub size_mb: Option<f64>,
    /// Fraction of non-zero matrix entries.
    pub sparsity: Option<f64>,
    /// Mean non-zeros per matrix row.
    pub nnz_per_row: Option<f64>,
    /// Lighting terms of `light_change_ms`.
    pub terms: Option<usize>,
    /// Lighting change (project + rotate), ms, median of repetitions (wall clock).
    pub light_change_ms: Option<f64>,
    /// Lighting change CPU time summed over threads, ms per change (mean).
    pub light_change_cpu_ms: Option<f64>,
    /// Vertices shaded.
    pub vertices: Option<usize>,
    /// View change (per-vertex shading), ms, median (wall clock).
    pub view_change_ms: Option<f64>,
    /// View change CPU time summed over threads, ms per change (mean).
    pub view_change_cpu_ms: Option<f64>,
    /// Normal blend rule of the view-change row (`MirrorAligned`, `Paper`).
    pub normal_interp: Option<NormalInterp>,
}

/// What [`bench_wavelet`] measures.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// `(n, ntess, ntrunc)` bakes.
    pub bakes: Vec<(usize, usize, u16)>,
    /// Lighting terms for the lighting-change timing.
    pub terms: usize,
    /// Vertex counts for the view-change timing (meshes from `meshes` or UV spheres).
    pub vertices: Vec<usize>,
    /// Repetitions (median reported).
    pub reps: usize,
    /// Measure the paper's CSR layout too.
    pub csr: bool,
}

impl BenchOptions {
    /// Tables 1, 2 and 4: N ∈ {32², 64², 128²} at ntess = 32², ntrunc = 1;
    /// ntrunc ∈ {16, 128} at N = 64²; 30 K–120 K vertices.
    #[must_use]
    pub fn full() -> Self {
        Self {
            bakes: vec![
                (32, 32, 1),
                (64, 32, 1),
                (64, 32, 16),
                (64, 32, 128),
                (128, 32, 1),
            ],
            terms: 256,
            vertices: vec![30_000, 50_000, 100_000, 120_000],
            reps: 20,
            csr: true,
        }
    }
    /// A smoke run.
    #[must_use]
    pub fn quick() -> Self {
        Self {
            bakes: vec![(32, 16, 1)],
            terms: 256,
            vertices: vec![30_000],
            reps: 10,
            csr: true,
        }
    }
}

/// CPU time of this process (all threads, user + system) in seconds, from
/// `/proc/self/stat` (Linux; 10 ms ticks). `None` elsewhere. Benchmarks report
/// it beside wall time because the build machine is shared: CPU time does not
/// grow when other processes take the cores.
#[must_use]
pub fn process_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ut: f64 = f.get(11)?.parse().ok()?;
    let st: f64 = f.get(12)?.parse().ok()?;
    Some((ut + st) / 100.0)
}

fn cpu_ms_per(reps: usize, start: Option<f64>) -> Option<f64> {
    Some((process_cpu_seconds()? - start?) * 1e3 / reps.max(1) as f64)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Runs the benchmark. `meshes` supplies `(vertices, mesh)` for the view-change
/// rows (e.g. the bunny subdivided to 30 K–120 K vertices); missing counts use
/// a UV sphere with about that many vertices. Bakes are not cached (timed).
///
/// # Errors
/// Bad parameters or cancellation.
pub fn bench_wavelet(
    opts: &BenchOptions,
    meshes: &[(usize, Arc<Mesh>)],
    progress: &dyn Progress,
) -> Result<Vec<BenchRow>, WaveletError> {
    let mut rows = Vec::new();
    let light = sun_sky();
    let mut view_rot: Option<Arc<RotationMatrices>> = None;
    for &(n, ntess, ntrunc) in &opts.bakes {
        let p = RotationParams::new(n, ntess, ntrunc);
        let c0 = process_cpu_seconds();
        let t0 = Instant::now();
        let rot = Arc::new(bake_rotation(&p, progress)?);
        let bake_s = t0.elapsed().as_secs_f64();
        let bake_cpu_s = cpu_ms_per(1, c0).map(|ms| ms / 1e3);
        let mut r = WaveletRenderer::new(rot.clone(), opts.terms.min(p.source_len()))?;
        let mut times = Vec::new();
        let c1 = process_cpu_seconds();
        for i in 0..opts.reps.max(1) {
            let rotm = relight_sphere::rotation_from_yaw_pitch_roll([10.0 * i as f32, 0.0, 0.0]);
            let t = Instant::now();
            r.set_lighting_fn(|d| light(rotm.transpose() * d))?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let light_cpu = cpu_ms_per(opts.reps.max(1), c1);
        let base = BenchRow {
            kind: "bake".into(),
            n,
            ntess,
            ntrunc,
            layout: "csc".into(),
            bake_s: Some(bake_s),
            bake_cpu_s,
            size_mb: Some(rot.size_bytes() as f64 / 1e6),
            sparsity: Some(rot.sparsity()),
            nnz_per_row: Some(rot.nnz_per_row()),
            terms: Some(opts.terms),
            light_change_ms: Some(median(times)),
            light_change_cpu_ms: light_cpu,
            vertices: None,
            view_change_ms: None,
            view_change_cpu_ms: None,
            normal_interp: None,
        };
        if opts.csr {
            let csr = rot.to_csr();
            let l = r.lighting().clone();
            let mut out = vec![Vec3A::ZERO; p.normals() * p.target_len()];
            let reps = opts.reps.max(1);
            let mut t = Vec::new();
            let c2 = process_cpu_seconds();
            for _ in 0..reps {
                let t0 = Instant::now();
                csr.local_lighting(&l, &mut out);
                t.push(t0.elapsed().as_secs_f64() * 1e3);
            }
            let csr_cpu = cpu_ms_per(reps, c2);
            let c3 = process_cpu_seconds();
            let csc_rot: Vec<f64> = (0..reps)
                .map(|_| {
                    let t0 = Instant::now();
                    let _ = rot.local_lighting(&l, &mut out);
                    t0.elapsed().as_secs_f64() * 1e3
                })
                .collect();
            let csc_cpu = cpu_ms_per(reps, c3);
            rows.push(BenchRow {
                layout: "csc (rotate only)".into(),
                light_change_ms: Some(median(csc_rot)),
                light_change_cpu_ms: csc_cpu,
                ..base.clone()
            });
            rows.push(BenchRow {
                layout: "csr (rotate only)".into(),
                light_change_ms: Some(median(t)),
                light_change_cpu_ms: csr_cpu,
                ..base.clone()
            });
        }
        rows.push(base);
        if n == 64 && ntess == 32 && ntrunc == 1 {
            view_rot = Some(rot);
        }
    }
    let rot = match view_rot {
        Some(r) => r,
        None => Arc::new(bake_rotation(&RotationParams::new(64, 32, 1), progress)?),
    };
    let p = *rot.params();
    let brdf = "ggx:0.1"
        .parse::<BrdfSpec>()
        .map_err(|e| crate::error::bad("brdf", "ggx:0.1", e.to_string()))?
        .build();
    let bb = bake_brdf(
        &BrdfBakeParams::new("ggx:0.1", p.m, 64, 128),
        brdf.as_ref(),
        progress,
    )?;
    let mut r = WaveletRenderer::new(rot, opts.terms.min(p.source_len()))?;
    r.set_lighting_fn(light)?;
    for &nv in &opts.vertices {
        let mesh = meshes
            .iter()
            .find(|m| m.0 == nv)
            .map(|m| m.1.clone())
            .unwrap_or_else(|| {
                let s = ((nv as f64 / 2.0).sqrt()).round() as u32;
                Arc::new(relight_geom::shapes::uv_sphere_at(
                    Vec3::ZERO,
                    1.0,
                    ((2 * s).max(3)) as usize,
                    (s.max(2)) as usize,
                ))
            });
        let mut out = vec![Vec3::ZERO; mesh.positions.len()];
        for rule in [NormalInterp::MirrorAligned, NormalInterp::Paper] {
            r.normal_interp = rule;
            let mut times = Vec::new();
            let c0 = process_cpu_seconds();
            for i in 0..opts.reps.max(1) {
                let eye = Vec3::new(3.0 * (i as f32).cos(), 1.0, 3.0 * (i as f32).sin());
                let t0 = Instant::now();
                r.shade_vertices(&mesh.positions, &mesh.normals, &bb, eye, None, &mut out)?;
                times.push(t0.elapsed().as_secs_f64() * 1e3);
            }
            rows.push(BenchRow {
                kind: "view".into(),
                n: p.n,
                ntess: p.ntess,
                ntrunc: p.ntrunc,
                layout: "csc".into(),
                bake_s: None,
                bake_cpu_s: None,
                size_mb: None,
                sparsity: None,
                nnz_per_row: None,
                terms: Some(bb.params.terms),
                light_change_ms: None,
                light_change_cpu_ms: None,
                vertices: Some(mesh.positions.len()),
                view_change_cpu_ms: cpu_ms_per(opts.reps.max(1), c0),
                view_change_ms: Some(median(times)),
                normal_interp: Some(rule),
            });
        }
    }
    let _ = NoProgress;
    Ok(rows)
}

/// A small default test scene: a unit sphere seen from the front under
/// `sun_sky()` sampled on a lat-long map, for `verify` when the caller has
/// none (the CLI passes relight-scene's default scene instead).
#[must_use]
pub fn sphere_scene(brdf: Arc<dyn Brdf>, width: usize, height: usize) -> Scene {
    let sky = sun_sky();
    let env = relight_sphere::EnvMap::from_fn(
        relight_sphere::Param::LatLong {
            width: 512,
            height: 256,
        },
        sky,
    );
    Scene::new(
        vec![Object::new(
            Arc::new(relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 128, 64)),
            brdf,
        )],
        env,
        relight_render::Camera {
            eye: Vec3::new(0.0, 0.6, 3.2),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 45.0,
            width,
            height,
            image_offset: glam::Vec2::ZERO,
        },
    )
}
