//! `relight bench shexp`: the thesis' Fig. 5.5 table (log space + PS*-2
//! against product accumulation, 60 blockers, n = 3…6), two scenes shaped
//! like the thesis' battle and dino scenes (receivers, leaf spheres and
//! receiver clusters as in §5.2.4), and the time to fit spheres to a
//! 100 K-triangle mesh.

use crate::accumulate::{Scratch, mul_blocker_visibility, zonal_rotation_factors};
use crate::exp::{ExpKind, Exponentiator, OlFit, SquaringHistogram};
use crate::lanes::{Lane, LaneBlocker, LaneKernel, LaneReceivers, W};
use crate::log_table::LogTable;
use crate::method::{ShExpMethod, ShExpOptions};
use crate::spheres::{FitOptions, fit_spheres};
use crate::verify::XorShift;
use glam::{Affine3A, Quat, Vec3};
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_geom::shapes::{plane, torus};
use relight_render::method::Relighter;
use relight_render::{Animation, Camera, Keyframe, NoProgress, Object, Scene};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// The thesis' Fig. 5.5 speedups of log + PS*-2 over products, n = 3…6.
pub const THESIS_SPEEDUP: [(usize, f64); 4] = [(3, 1.9), (4, 3.4), (5, 6.5), (6, 11.0)];

/// One row of the Fig. 5.5 table.
#[derive(Clone, Debug, Serialize)]
pub struct AccumulationRow {
    pub order: usize,
    pub blockers: usize,
    pub receivers: usize,
    pub log_ps2_us: f64,
    pub product_us: f64,
    pub speedup: f64,
    pub thesis_speedup: f64,
    pub meets_thesis: bool,
    /// Squarings PS*-2 used, `s:count`.
    pub squarings: String,
}

/// One scene row.
#[derive(Clone, Debug, Serialize)]
pub struct SceneRow {
    pub scene: String,
    pub receivers: usize,
    pub leaf_spheres: usize,
    pub clusters: usize,
    pub order: usize,
    /// Blocker spheres per vertex the cluster culling kept (mean).
    pub blockers_per_vertex: f64,
    pub ms_per_frame: f64,
    pub hz: f64,
    pub target_hz: f64,
    pub thesis_hz: f64,
    pub meets_target: bool,
    pub squarings: String,
}

/// The sphere-fitting row.
#[derive(Clone, Debug, Serialize)]
pub struct FitRow {
    pub triangles: usize,
    pub spheres: usize,
    pub seconds: f64,
    pub target_seconds: f64,
    pub meets_target: bool,
}

/// Everything `relight bench shexp` prints.
#[derive(Clone, Debug, Serialize)]
pub struct BenchShExp {
    pub accumulation: Vec<AccumulationRow>,
    pub scenes: Vec<SceneRow>,
    pub fit: FitRow,
}

/// Fig. 5.5: per receiver, 60 blockers accumulated in log space and
/// exponentiated by PS*-2, against product accumulation, single thread.
///
/// The log side accumulates (eq. 5.13) with the method's own lane kernel
/// ([`LaneKernel::accumulate`], `W` receivers per pass: one basis evaluation
/// and `n²` multiply-adds per blocker and receiver, vectorised across
/// receivers), then exponentiates each receiver by PS*-2 (5.24–5.27) with
/// [`Exponentiator::exp`], whose squarings run the same generated SH product
/// kernel as the baseline's eq. 5.11 products. So both sides use the same
/// product code; only the accumulation differs, which is what Fig. 5.5
/// compares.
///
/// # Errors
/// A bad order.
pub fn bench_accumulation(
    orders: &[usize],
    receivers: usize,
    blockers: usize,
) -> Result<Vec<AccumulationRow>, crate::ShExpError> {
    let mut rows = Vec::new();
    for &n in orders {
        let table = LogTable::with_defaults(n)?;
        let mut e = Exponentiator::<f32>::new(n, OlFit::fit(&table))?;
        let factors = zonal_rotation_factors(n);
        let mut rng = XorShift::new(n as u64);
        // Blockers above the receivers' patch; receivers on a 2 × 2 patch.
        let spheres: Vec<(Vec3, f32)> = (0..blockers)
            .map(|_| {
                let c = Vec3::new(
                    (rng.next() as f32 - 0.5) * 8.0,
                    0.8 + 3.0 * rng.next() as f32,
                    (rng.next() as f32 - 0.5) * 8.0,
                );
                (c, 0.15 + 0.35 * rng.next() as f32)
            })
            .collect();
        let pts: Vec<Vec3> = (0..receivers)
            .map(|_| {
                Vec3::new(
                    rng.next() as f32 * 2.0 - 1.0,
                    0.0,
                    rng.next() as f32 * 2.0 - 1.0,
                )
            })
            .collect();
        let nn = n * n;
        let kernel = LaneKernel::new(&table, OlFit::fit(&table))?;
        let lane_blockers: Vec<LaneBlocker> = spheres
            .iter()
            .map(|&(c, r)| LaneBlocker { c: c.to_array(), r })
            .collect();
        let mut rec = LaneReceivers::default();
        let mut fl: Vec<Lane> = vec![[0.0; W]; nn];
        let mut s = Scratch::new(n);
        let (mut f, mut g) = (vec![0.0f32; nn], vec![0.0f32; nn]);
        let mut hist = SquaringHistogram::new();
        let lh: Vec<f32> = (0..nn).map(|i| 1.0 / (1 + i) as f32).collect();
        let mut sink = 0.0f32;
        let geom = |p: Vec3, c: Vec3, r: f32| {
            let d = c - p;
            let dist = d.length();
            ((r / dist).min(1.0).asin(), (d / dist).to_array())
        };
        let reps = 3;
        let mut best_log = f64::MAX;
        let mut best_prod = f64::MAX;
        for _ in 0..reps {
            let t = Instant::now();
            for chunk in pts.chunks(W) {
                for (j, p) in chunk.iter().enumerate() {
                    rec.set(j, *p, Vec3::Y);
                }
                fl.fill([0.0; W]);
                kernel.accumulate(&rec, &lane_blockers, &mut fl);
                for j in 0..chunk.len() {
                    for (d, v) in f.iter_mut().zip(&fl) {
                        *d = v[j];
                    }
                    let (sq, capped) = e.exp(ExpKind::PsStar(2), &f, &mut g);
                    hist.counts[sq as usize] += 1;
                    hist.capped += u64::from(capped);
                    sink += g.iter().zip(&lh).map(|(a, b)| a * b).sum::<f32>();
                }
            }
            best_log = best_log.min(t.elapsed().as_secs_f64());
            let t = Instant::now();
            for p in &pts {
                g.fill(0.0);
                g[0] = (4.0 * std::f32::consts::PI).sqrt();
                for &(c, r) in &spheres {
                    let (th, dir) = geom(*p, c, r);
                    mul_blocker_visibility(e.tensor(), &factors, th, dir, &mut s, &mut g);
                }
                sink += g.iter().zip(&lh).map(|(a, b)| a * b).sum::<f32>();
            }
            best_prod = best_prod.min(t.elapsed().as_secs_f64());
        }
        std::hint::black_box(sink);
        let thesis = THESIS_SPEEDUP
            .iter()
            .find(|t| t.0 == n)
            .map_or(f64::NAN, |t| t.1);
        let speedup = best_prod / best_log;
        hist.counts.iter_mut().for_each(|c| *c /= reps as u64);
        rows.push(AccumulationRow {
            order: n,
            blockers,
            receivers,
            log_ps2_us: best_log * 1e6 / receivers as f64,
            product_us: best_prod * 1e6 / receivers as f64,
            speedup,
            thesis_speedup: thesis,
            meets_thesis: speedup >= thesis,
            squarings: hist.describe(),
        });
    }
    Ok(rows)
}

fn spin(period: f32, offset: Vec3) -> Arc<Animation> {
    let keys = (0..=4)
        .map(|k| {
            let t = k as f32 * period / 4.0;
            let a = t / period * std::f32::consts::TAU;
            Keyframe {
                time: t,
                translate: offset + Vec3::new(0.8 * a.cos(), 0.0, 0.8 * a.sin()),
                rotation: Quat::from_rotation_y(a),
                scale: 1.0,
            }
        })
        .collect();
    Arc::new(Animation::try_new(keys).expect("valid keys"))
}

/// A scene shaped like the thesis' battle / dino scenes: a floor of
/// `floor_side²` static vertices, `dynamic` moving tori of `dyn_side`
/// segments and `statics` static tori, every torus a blocker.
fn thesis_like_scene(floor_side: usize, dynamic: usize, dyn_side: usize, statics: usize) -> Scene {
    let lambert = Arc::new(relight_brdf::Lambert::new(Vec3::splat(0.7)).expect("valid albedo"));
    let mut objects = vec![Object::new(
        Arc::new(plane(16.0, floor_side - 1)),
        lambert.clone(),
    )];
    let ring = |i: usize, k: usize, r: f32| {
        let a = i as f32 / k.max(1) as f32 * std::f32::consts::TAU;
        Vec3::new(r * a.cos(), 0.0, r * a.sin())
    };
    for i in 0..dynamic {
        let m: Mesh = torus(0.6, 0.25, dyn_side, dyn_side / 2)
            .transformed(Affine3A::from_rotation_x(1.2) * Affine3A::from_scale(Vec3::splat(1.0)));
        let mut o = Object::new(Arc::new(m), lambert.clone());
        o.animation = Some(spin(4.0 + i as f32, ring(i, dynamic, 3.0) + Vec3::Y * 1.0));
        objects.push(o);
    }
    for i in 0..statics {
        let m = torus(0.5, 0.3, 48, 24).transformed(
            Affine3A::from_translation(ring(i, statics, 6.0) + Vec3::Y * 0.6)
                * Affine3A::from_rotation_z(1.5),
        );
        objects.push(Object::new(Arc::new(m), lambert.clone()));
    }
    let env = crate::verify_scene::sky();
    let camera = Camera {
        eye: Vec3::new(0.0, 6.0, 12.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
        width: 64,
        height: 36,
        image_offset: glam::Vec2::ZERO,
    };
    let mut s = Scene::new(objects, env, camera);
    s.visibility = true;
    s
}

/// Issue 15's rate for the battle-like scene, Hz (thesis: 22.4 Hz).
pub const BATTLE_HZ: f64 = 30.0;

/// Leaf spheres per blocker of the battle-like scene (8 blockers: 240).
pub const BATTLE_SPHERES: usize = 30;

/// Receiver vertices per cluster of the battle-like scene (≈ 120 clusters).
pub const BATTLE_CLUSTER_VERTICES: usize = 410;

/// The battle-like scene: a 41 K-vertex static floor and 24 K dynamic
/// vertices in four moving tori, four static tori, every torus a blocker
/// (§5.2.4's battle: ~65 K receivers). `shrink` divides each mesh's side
/// (1 for the size).
#[must_use]
pub fn battle_like_scene(shrink: usize) -> Scene {
    let s = shrink.max(1);
    thesis_like_scene(203 / s, 4, 110 / s, 4)
}

/// The method's options for the battle-like scene: [`BATTLE_SPHERES`],
/// [`BATTLE_CLUSTER_VERTICES`] and a 3 × 3-ray static bake.
#[must_use]
pub fn battle_like_options() -> ShExpOptions {
    ShExpOptions {
        spheres: BATTLE_SPHERES,
        cluster_vertices: BATTLE_CLUSTER_VERTICES,
        bake_strata: 3,
        ..ShExpOptions::default()
    }
}

/// Frames per second of the per-vertex shadow work on a thesis-like scene.
///
/// # Errors
/// As the method.
#[allow(clippy::too_many_arguments)]
fn bench_scene(
    name: &str,
    scene: &Scene,
    spheres: usize,
    cluster_vertices: usize,
    frames: usize,
    target_hz: f64,
    thesis_hz: f64,
) -> Result<SceneRow, relight_render::method::MethodError> {
    let opts = ShExpOptions {
        spheres,
        cluster_vertices,
        bake_strata: 3,
        ..ShExpOptions::default()
    };
    let mut m = ShExpMethod::new(opts)?;
    m.prepare(scene, &NoProgress)?;
    let leaf: usize = m.sphere_sets().iter().map(|(_, s)| s.spheres.len()).sum();
    let frames_at: Vec<Scene> = (0..frames)
        .map(|f| scene.at_time(0.37 * f as f32))
        .collect();
    m.shade_vertices(&frames_at[0])?;
    m.take_histogram();
    let t = Instant::now();
    for s in &frames_at {
        m.shade_vertices(s)?;
    }
    let ms = t.elapsed().as_secs_f64() * 1e3 / frames as f64;
    let (pairs, verts) = m.last_frame_pairs();
    let receivers = scene.objects.iter().map(|o| o.mesh.positions.len()).sum();
    Ok(SceneRow {
        scene: name.into(),
        receivers,
        leaf_spheres: leaf,
        clusters: m.cluster_count(),
        order: opts.order,
        blockers_per_vertex: pairs as f64 / verts.max(1) as f64,
        ms_per_frame: ms,
        hz: 1e3 / ms,
        target_hz,
        thesis_hz,
        meets_target: 1e3 / ms >= target_hz,
        squarings: m.take_histogram().describe(),
    })
}

/// `relight verify shexp`'s culling rows: the battle-like and dino-like
/// scenes (at a quarter of the bench's resolution per side, clusters of a
/// sixteenth of the vertices, the same leaf spheres and layout: ~4.4 K and
/// ~7.6 K receivers) shaded with §5.2.4's culling and level of detail at the
/// defaults ([`ShExpOptions::min_angle_deg`], [`ShExpOptions::lod_angle_deg`])
/// against the same method with neither (every leaf sphere of every other
/// object, angles 0), over several animation times. The error is the relative
/// RMS of the vertex radiance over all receivers and frames; target ≤
/// [`CULLING_RMS_TARGET`].
///
/// # Errors
/// As the method.
pub fn verify_culling() -> Result<Vec<crate::verify::VerifyRow>, relight_render::method::MethodError>
{
    Ok(culling_checks()?.iter().map(CullingCheck::row).collect())
}

/// What [`verify_culling`] measured on one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct CullingCheck {
    pub scene: String,
    /// The culled run's thresholds (degrees).
    pub min_angle_deg: f32,
    pub lod_angle_deg: f32,
    /// Relative RMS of the vertex radiance against the unculled run.
    pub rms: f64,
    /// Largest difference of one vertex, relative to the RMS radiance (a
    /// vertex's own radiance is no scale: deep in shadow it is near 0).
    pub worst: f64,
    /// Blocker–vertex pairs kept, as a fraction of the unculled run's.
    pub kept: f64,
}

impl CullingCheck {
    /// The verify row.
    #[must_use]
    pub fn row(&self) -> crate::verify::VerifyRow {
        crate::verify::VerifyRow {
            check: format!(
                "{} scene: cluster culling + LOD ({}°/{}°, proxy spheres) vs every leaf sphere",
                self.scene, self.min_angle_deg, self.lod_angle_deg
            ),
            measured: format!(
                "relative RMS {:.3} %, worst vertex {:.2} % of the RMS radiance, blocker pairs {:.0} % of all",
                100.0 * self.rms,
                100.0 * self.worst,
                100.0 * self.kept
            ),
            target: format!("relative RMS ≤ {:.1} %", 100.0 * CULLING_RMS_TARGET),
            source: "issue 15 §5.2.4 culling (tolerance ours: below the 5 % image target's tenth)"
                .into(),
            pass: Some(self.rms <= CULLING_RMS_TARGET),
        }
    }
}

/// [`verify_culling`]'s measurements.
///
/// # Errors
/// As the method.
pub fn culling_checks() -> Result<Vec<CullingCheck>, relight_render::method::MethodError> {
    let battle = battle_like_scene(4);
    let dino = thesis_like_scene(274 / 4, 8, 106 / 4, 0);
    Ok(vec![
        culling_check(
            "battle-like",
            &battle,
            BATTLE_SPHERES,
            BATTLE_CLUSTER_VERTICES / 16,
        )?,
        culling_check("dino-like", &dino, 62, 390 / 16)?,
    ])
}

/// One scene of [`culling_checks`].
fn culling_check(
    name: &str,
    scene: &Scene,
    spheres: usize,
    cluster_vertices: usize,
) -> Result<CullingCheck, relight_render::method::MethodError> {
    let base = ShExpOptions {
        spheres,
        cluster_vertices,
        bake_strata: 3,
        ..ShExpOptions::default()
    };
    let none = ShExpOptions {
        min_angle_deg: 0.0,
        lod_angle_deg: 0.0,
        ..base
    };
    let mut culled = ShExpMethod::new(base)?;
    let mut all = ShExpMethod::new(none)?;
    culled.prepare(scene, &NoProgress)?;
    all.prepare(scene, &NoProgress)?;
    let (mut num, mut den, mut worst) = (0.0f64, 0.0f64, 0.0f64);
    let (mut kept, mut every, mut count) = (0u64, 0u64, 0u64);
    for f in 0..4 {
        let s = scene.at_time(0.9 * f as f32);
        culled.shade_vertices(&s)?;
        all.shade_vertices(&s)?;
        kept += culled.last_frame_pairs().0;
        every += all.last_frame_pairs().0;
        for (a, b) in culled.vertex_colors().iter().zip(all.vertex_colors()) {
            for (x, y) in a.iter().zip(b) {
                let d = f64::from((*x - *y).length());
                num += d * d;
                den += f64::from(y.length_squared());
                worst = worst.max(d);
                count += 1;
            }
        }
    }
    Ok(CullingCheck {
        scene: name.into(),
        min_angle_deg: base.min_angle_deg,
        lod_angle_deg: base.lod_angle_deg,
        rms: (num / den.max(1e-30)).sqrt(),
        worst: worst / (den / count.max(1) as f64).sqrt().max(1e-30),
        kept: kept as f64 / every.max(1) as f64,
    })
}

/// Relative RMS the culled shading may differ from the unculled one by.
pub const CULLING_RMS_TARGET: f64 = 0.005;

/// The whole bench (`quick`: fewer receivers and frames, smaller scenes).
///
/// # Errors
/// As the parts.
pub fn bench_shexp(quick: bool) -> Result<BenchShExp, relight_render::method::MethodError> {
    let fail = |e| relight_render::method::MethodError::failed(crate::SHEXP_METHOD_NAME, e);
    let accumulation =
        bench_accumulation(&[3, 4, 5, 6], if quick { 200 } else { 4000 }, 60).map_err(fail)?;
    let mut scenes = Vec::new();
    // Frames 0.37 s apart, averaged (the thesis averages over its clips).
    let (frames, s) = if quick { (2, 4) } else { (8, 1) };
    let battle = battle_like_scene(s);
    scenes.push(bench_scene(
        "battle-like",
        &battle,
        BATTLE_SPHERES,
        BATTLE_CLUSTER_VERTICES,
        frames,
        BATTLE_HZ,
        22.4,
    )?);
    // Dino-like: 75 K floor + 45 K dynamic in 8 movers, 8 × 62 ≈ 500 spheres.
    let dino = thesis_like_scene(274 / s, 8, 106 / s, 0);
    scenes.push(bench_scene(
        "dino-like",
        &dino,
        62,
        390,
        frames,
        15.0,
        12.6,
    )?);
    let (seg, sides) = if quick { (80, 40) } else { (320, 160) };
    let m = torus(1.0, 0.3, seg, sides);
    let t = Instant::now();
    let set = fit_spheres(
        &m,
        &FitOptions {
            spheres: 128,
            ..FitOptions::default()
        },
    )
    .map_err(fail)?;
    let secs = t.elapsed().as_secs_f64();
    let _ = set.spheres.par_iter().count();
    Ok(BenchShExp {
        accumulation,
        scenes,
        fit: FitRow {
            triangles: m.indices.len(),
            spheres: set.spheres.len(),
            seconds: secs,
            target_seconds: 10.0,
            meets_target: secs <= 10.0,
        },
    })
}
