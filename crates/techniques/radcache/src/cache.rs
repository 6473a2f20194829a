//! The radiance-cache renderer: lazy record creation in deterministic
//! rounds, interpolation with the aligning rotation, shading by the BRDF's
//! SH coefficients (module docs of the crate).

use crate::align::Aligner;
use crate::brdf_sh::BrdfSh;
use crate::index::Octree;
use crate::{RadCacheError, RadianceCacheOptions};
use glam::Vec3;
use rayon::prelude::*;
use relight_brdf::Brdf;
use relight_render::reference::{GiOptions, GiTracer, GiVertex};
use relight_render::sampling::sample_uniform_hemisphere;
use relight_render::{Camera, EnvLight, Image, Progress, Rng, Scene, SceneBvh};
use relight_sh::rotation::{Rot3, rotate_z};
use relight_sphere::Frame;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

/// Seed offset of the records' rays (apart from the camera samples' streams).
const RECORD_STREAM: u64 = 0x7ad1_a7ce_cac4_e000;

/// One radiance record: incoming indirect radiance at `p` in SH, in the
/// frame `Frame::from_z(n)`.
#[derive(Clone, Debug)]
pub struct Record {
    /// World position.
    pub p: Vec3,
    /// Frame (`z` = the shading normal at `p`).
    pub frame: Frame,
    /// Harmonic-mean distance of the record's rays to the surfaces they hit
    /// (clamped, scene units).
    pub r: f32,
    /// RGB coefficients, channel-major (`3·order²`).
    pub coeffs: Vec<f32>,
}

/// What a cache render did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CacheStats {
    /// Records created.
    pub records: usize,
    /// Records computed and dropped because another record of the same
    /// round already covered them.
    pub wasted_records: usize,
    /// Shaded camera samples.
    pub lookups: u64,
    /// Aligning rotations applied (one per record used per sample).
    pub rotations: u64,
    /// Of those, rotations a Taylor method took exactly (β > β_lim).
    pub exact_rotations: u64,
    /// Octree nodes.
    pub nodes: usize,
    /// Seconds creating records (ray tracing).
    pub record_seconds: f64,
    /// Seconds interpolating (lookups, rotations, shading).
    pub interpolation_seconds: f64,
}

/// Direct and cached indirect images.
#[derive(Clone, Debug)]
pub struct CacheImage {
    /// Emission seen plus direct light (the GI reference's direct image for
    /// the same seed and samples).
    pub direct: Image,
    /// Indirect light interpolated from the cache.
    pub indirect: Image,
    pub stats: CacheStats,
    /// Up to the requested number of the frame's aligning rotations (for the
    /// rotation bench): the record used and the rotation.
    pub rotations: Vec<(u32, Rot3<f32>)>,
    /// The records.
    pub records: Arc<Vec<Record>>,
}

/// A shaded sample: indirect radiance, rotations, exact ones, captured.
type Shaded = (Vec3, u64, u64, Vec<(u32, Rot3<f32>)>);

/// One camera sample's first surface.
struct Query<'a> {
    pixel: usize,
    v: GiVertex<'a>,
}

fn table_key(b: &dyn Brdf) -> usize {
    std::ptr::from_ref(b).cast::<()>() as usize
}

/// The BRDF tables of every material of `scene` at `order`.
#[must_use]
pub fn brdf_tables(scene: &Scene, order: usize) -> HashMap<usize, Arc<BrdfSh>> {
    let mut out = HashMap::new();
    for o in &scene.objects {
        let mut lobes: Vec<&dyn Brdf> = vec![o.brdf.as_ref()];
        if let Some(b) = &o.blend {
            lobes.push(b.second.as_ref());
        }
        for b in lobes {
            out.entry(table_key(b))
                .or_insert_with(|| Arc::new(BrdfSh::new(b, order)));
        }
    }
    out
}

/// Renders the direct image with the reference's code and the indirect
/// image from the radiance cache; keeps up to `capture_rotations` rotations.
///
/// # Errors
/// A bad option, a scene the GI reference refuses, cancellation.
pub fn render_radiance_cache(
    scene: &Scene,
    camera: &Camera,
    opts: &RadianceCacheOptions,
    tables: &HashMap<usize, Arc<BrdfSh>>,
    capture_rotations: usize,
    progress: &dyn Progress,
) -> Result<CacheImage, RadCacheError> {
    render_radiance_cache_with(
        scene,
        camera,
        opts,
        tables,
        capture_rotations,
        None,
        progress,
    )
}

/// [`render_radiance_cache`], optionally with the records of an earlier
/// render of the same scene, camera and options but for the rotation
/// (`reuse`): record creation is then skipped, so interpolation alone differs
/// — how the verify and bench compare rotation methods on one record set
/// (the paper's Table 1 times the interpolation only).
///
/// # Errors
/// A bad option, a scene the GI reference refuses, cancellation.
pub fn render_radiance_cache_with(
    scene: &Scene,
    camera: &Camera,
    opts: &RadianceCacheOptions,
    tables: &HashMap<usize, Arc<BrdfSh>>,
    capture_rotations: usize,
    reuse: Option<&Arc<Vec<Record>>>,
    progress: &dyn Progress,
) -> Result<CacheImage, RadCacheError> {
    crate::validate(opts)?;
    let n = opts.order;
    let nn = n * n;
    let bvh = SceneBvh::from_scene(scene);
    let light = EnvLight::new(&scene.env, relight_render::EnvFilter::Nearest);
    let gi = GiOptions::default();
    let tracer = GiTracer::new(scene, &bvh, &light, &gi).map_err(RadCacheError::Reference)?;
    let (w, h) = (camera.width, camera.height);
    let frame = camera.ray_frame();
    let mut direct = Image::new(w, h);
    let spp = opts.spp;
    progress.start("radiance cache", 3);
    // 1. Camera samples: emission and direct light exactly as the reference.
    let per_pixel: Vec<(Vec3, Vec<GiVertex>)> = (0..w * h)
        .into_par_iter()
        .map(|pixel| {
            let (x, y) = (pixel % w, pixel / w);
            let mut rays = 0;
            let mut l = Vec3::ZERO;
            let mut vs = vec![];
            for s in 0..spp {
                let mut rng = Rng::for_sample(opts.seed, pixel as u64, u64::from(s));
                let j = rng.next_2d();
                let d = frame.dir(x as f32 + j.x, y as f32 + j.y);
                let hit = tracer.camera_hit(camera.eye, d, &mut rays);
                let mut ld = hit.emission;
                if let Some(v) = hit.vertex {
                    ld += tracer.direct(&v, &mut rng, &mut rays);
                    vs.push(v);
                }
                l += if ld.is_finite() { ld } else { Vec3::ZERO };
            }
            (l / spp as f32, vs)
        })
        .collect();
    progress.check()?;
    progress.inc(1);
    let mut queries = vec![];
    for (pixel, (l, vs)) in per_pixel.into_iter().enumerate() {
        direct.pixels[pixel] = l;
        queries.extend(vs.into_iter().map(|v| Query { pixel, v }));
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for q in &queries {
        lo = lo.min(q.v.position());
        hi = hi.max(q.v.position());
    }
    let diag = if queries.is_empty() {
        1.0
    } else {
        (hi - lo).length().max(1e-3)
    };
    let (r_min, r_max) = (opts.radius_clamp[0] * diag, opts.radius_clamp[1] * diag);
    let mut tree = Octree::new(
        (lo + hi) * 0.5,
        (hi - lo).max_element().max(1e-3) * 0.5 + 1e-3,
    );
    let mut records: Vec<Record> = vec![];
    let a = opts.error;
    let covered = |records: &[Record], tree: &Octree, v: &GiVertex| -> bool {
        let (p, nrm) = (v.position(), v.frame().z);
        let mut hit = false;
        tree.for_each_near(p, |i| {
            let r = &records[i as usize];
            if !hit && error_of(r, p, nrm) < a {
                hit = true;
            }
        });
        hit
    };
    // 2. Lazy records, in rounds from coarse to fine over the samples.
    let t_rec = Instant::now();
    let mut stats = CacheStats::default();
    let side = opts.record_rays_side as usize;
    if let Some(prev) = reuse {
        records = prev.as_ref().clone();
        for (i, rec) in records.iter().enumerate() {
            tree.insert(i as u32, rec.p, a * rec.r);
        }
    }
    let strides: &[usize] = if reuse.is_some() {
        &[]
    } else {
        &[16, 8, 4, 2, 1, 0]
    };
    for &stride in strides {
        loop {
            progress.check()?;
            let misses: Vec<usize> = (0..queries.len())
                .into_par_iter()
                .filter(|&k| {
                    let q = &queries[k];
                    let (x, y) = (q.pixel % w, q.pixel / w);
                    let in_round = if stride == 0 {
                        true
                    } else {
                        x % stride == 0
                            && y % stride == 0
                            && (k == 0 || queries[k - 1].pixel != q.pixel)
                    };
                    in_round && !covered(&records, &tree, &q.v)
                })
                .collect();
            if misses.is_empty() {
                break;
            }
            let made: Vec<Record> = misses
                .par_iter()
                .map(|&k| make_record(&tracer, &queries[k].v, k as u64, opts, side, [r_min, r_max]))
                .collect();
            for rec in made {
                // Records of this round computed side by side: keep the first
                // of those that cover one another (sample order).
                let (p, nz) = (rec.p, rec.frame.z);
                let mut dup = false;
                tree.for_each_near(p, |i| {
                    dup = dup || error_of(&records[i as usize], p, nz) < a;
                });
                if dup {
                    stats.wasted_records += 1;
                    continue;
                }
                tree.insert(records.len() as u32, rec.p, a * rec.r);
                records.push(rec);
            }
        }
    }
    stats.record_seconds = t_rec.elapsed().as_secs_f64();
    progress.inc(1);
    // 3. Interpolation.
    let t_int = Instant::now();
    let beta_lim = opts.beta_lim_per_error * a;
    let aligner = Aligner::new(opts.rotation, n, beta_lim).map_err(RadCacheError::Sh)?;
    let shaded: Vec<Shaded> = queries
        .par_iter()
        .enumerate()
        .map_init(
            || {
                (
                    aligner.clone(),
                    vec![0.0f32; 3 * nn],
                    vec![0.0f32; 3 * nn],
                    vec![0.0f32; 3 * nn],
                )
            },
            |(al, acc, rot_buf, view), (k, q)| {
                let v = &q.v;
                let (p, nrm) = (v.position(), v.frame().z);
                let g = Frame::from_z(nrm);
                acc.fill(0.0);
                let (mut wsum, mut rots, mut exact) = (0.0f32, 0u64, 0u64);
                let mut captured = vec![];
                tree.for_each_near(p, |i| {
                    let r = &records[i as usize];
                    let e = error_of(r, p, nrm);
                    if e >= a {
                        return;
                    }
                    let wi = 1.0 / e.max(1e-6);
                    let rot = frame_rotation(&g, &r.frame);
                    exact += u64::from(al.apply(&rot, &r.coeffs, rot_buf));
                    rots += 1;
                    if k < capture_rotations {
                        captured.push((i, rot));
                    }
                    for (s, &c) in acc.iter_mut().zip(rot_buf.iter()) {
                        *s += wi * c;
                    }
                    wsum += wi;
                });
                if wsum <= 0.0 {
                    return (Vec3::ZERO, rots, exact, captured);
                }
                for s in acc.iter_mut() {
                    *s /= wsum;
                }
                // Into the view-aligned frame: x along the view's azimuth.
                let wo = g.to_local(v.frame().from_local(v.wo_local()));
                let phi = wo.y.atan2(wo.x);
                let (sn, cs) = phi.sin_cos();
                for c in 0..3 {
                    rotate_z(
                        n,
                        cs,
                        -sn,
                        &acc[c * nn..(c + 1) * nn],
                        &mut view[c * nn..(c + 1) * nn],
                    );
                }
                let (b1, second) = v.lobes();
                let shade = |b: &dyn Brdf| {
                    tables
                        .get(&table_key(b))
                        .map_or(Vec3::ZERO, |t| t.shade(wo.z, view))
                };
                let l = match second {
                    None => shade(b1),
                    Some((b2, wb)) => shade(b1) * (1.0 - wb) + shade(b2) * wb,
                };
                (
                    if l.is_finite() { l } else { Vec3::ZERO },
                    rots,
                    exact,
                    captured,
                )
            },
        )
        .collect();
    let mut indirect = Image::new(w, h);
    let mut rotations = vec![];
    for (q, (l, r, e, cap)) in queries.iter().zip(shaded) {
        indirect.pixels[q.pixel] += l / spp as f32;
        stats.rotations += r;
        stats.exact_rotations += e;
        if rotations.len() < capture_rotations {
            rotations.extend(cap);
        }
    }
    rotations.truncate(capture_rotations);
    stats.interpolation_seconds = t_int.elapsed().as_secs_f64();
    stats.lookups = queries.len() as u64;
    stats.records = records.len();
    stats.nodes = tree.node_count();
    progress.inc(1);
    progress.finish();
    Ok(CacheImage {
        direct,
        indirect,
        stats,
        rotations,
        records: Arc::new(records),
    })
}

/// `1 / w_i(p) = ‖p − p_i‖ / R_i + √(1 − n·n_i)` (Křivánek 2005 eq. 3).
#[inline]
pub(crate) fn error_of(r: &Record, p: Vec3, n: Vec3) -> f32 {
    (p - r.p).length() / r.r + (1.0 - n.dot(r.frame.z)).max(0.0).sqrt()
}

/// The rotation taking record-frame directions to point-frame directions:
/// `R_jk = g_j · f_k`.
#[inline]
pub(crate) fn frame_rotation(g: &Frame, f: &Frame) -> Rot3<f32> {
    let (ga, fa) = ([g.x, g.y, g.z], [f.x, f.y, f.z]);
    Rot3 {
        m: std::array::from_fn(|j| std::array::from_fn(|k| ga[j].dot(fa[k]))),
    }
}

/// A record at `v`: `side²` stratified uniform hemisphere rays, each the
/// GI reference's incoming indirect radiance, projected onto SH
/// (`λ_k = (2π/N) Σ L(ω) y_k(ω)`), and the harmonic-mean hit distance.
fn make_record(
    tracer: &GiTracer,
    v: &GiVertex,
    key: u64,
    opts: &RadianceCacheOptions,
    side: usize,
    clamp: [f32; 2],
) -> Record {
    let n = opts.order;
    let nn = n * n;
    let frame = Frame::from_z(v.frame().z);
    let mut coeffs = vec![0.0f32; 3 * nn];
    let mut y = vec![0.0f32; nn];
    let mut inv = 0.0f64;
    let mut rays = 0u64;
    let count = side * side;
    let scale = std::f32::consts::TAU / count as f32;
    for k in 0..count {
        let mut rng = Rng::for_sample(opts.seed ^ RECORD_STREAM, key, k as u64);
        let j = rng.next_2d();
        let u = glam::Vec2::new(
            ((k % side) as f32 + j.x) / side as f32,
            ((k / side) as f32 + j.y) / side as f32,
        );
        let local = sample_uniform_hemisphere(u);
        let (l, t) = tracer.incoming_indirect(v, frame.from_local(local), &mut rng, &mut rays);
        if t.is_finite() && t > 0.0 {
            inv += 1.0 / f64::from(t);
        }
        if l == Vec3::ZERO {
            continue;
        }
        relight_sh::basis::eval_sh_into(n, local.to_array(), &mut y);
        let l = l * scale;
        for (i, &yk) in y.iter().enumerate() {
            coeffs[i] += l.x * yk;
            coeffs[nn + i] += l.y * yk;
            coeffs[2 * nn + i] += l.z * yk;
        }
    }
    let r = if inv > 0.0 {
        (count as f64 / inv) as f32
    } else {
        f32::INFINITY
    };
    Record {
        p: v.position(),
        frame,
        r: r.clamp(clamp[0], clamp[1]),
        coeffs,
    }
}
