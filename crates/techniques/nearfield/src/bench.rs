//! `relight bench nearfield`: Fig. 4.11's table — propagation and
//! full-frame rates per compression on three scenes — against the thesis'
//! 1-thread (must) and 8-thread (target) figures, the work per vertex
//! against the machine's FMA ceiling, the bake time, and what several
//! lights cost (not in the thesis: the method's module docs, "Several
//! lights").

use crate::method::{NearfieldMethod, NearfieldOptions};
use crate::scenes::{
    floor_and_sphere, floor_and_sphere_light_field, floor_and_sphere_three_lights,
};
use relight_render::method::{FrameRequest, MethodError, Relighter};
use relight_render::{NoProgress, Progress};
use serde::Serialize;
use std::time::Instant;

/// Fig. 4.11's compressions (source, target).
pub const COMPRESSIONS: [(f64, f64); 5] = [
    (0.01, 0.01),
    (0.01, 0.20),
    (0.05, 0.40),
    (0.20, 0.70),
    (1.0, 1.0),
];

/// Fig. 4.11: (scene, vertices, 8-thread fps, 1-thread fps) per compression.
pub const THESIS: [(&str, usize, [f64; 5], [f64; 5]); 3] = [
    (
        "diffuse fertility",
        39_391,
        [151.86, 38.71, 24.83, 13.78, 7.04],
        [32.79, 7.58, 4.17, 2.17, 1.08],
    ),
    (
        "specular chairs",
        56_995,
        [107.33, 25.87, 12.48, 7.87, 4.86],
        [20.43, 4.52, 2.03, 1.15, 0.75],
    ),
    (
        "specular couches",
        68_046,
        [101.64, 23.34, 11.98, 7.31, 4.80],
        [18.60, 3.91, 1.94, 1.10, 0.71],
    ),
];

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub scene: String,
    pub vertices: usize,
    pub compression: String,
    pub source_terms: usize,
    pub target_terms: usize,
    pub fma_per_vertex: f64,
    /// Per-frame relighting (a texture edit) on 1 thread, by that thread's
    /// CPU time (unaffected by other jobs on the machine).
    pub propagate_fps_1t: f64,
    /// The same on every thread of the machine, wall clock (shared machine:
    /// lower than the idle figure).
    pub propagate_fps: f64,
    /// Propagation + Gouraud rasterization at the frame size, every thread,
    /// wall clock.
    pub frame_fps: f64,
    /// A light move or scale (a new light frame and the propagation), ms,
    /// every thread, wall clock.
    pub move_ms: f64,
    /// Propagation + rasterization on 1 thread, CPU time.
    pub frame_fps_1t: f64,
    /// Propagation FMAs per second on 1 thread.
    pub gfma_per_s_1t: f64,
    /// `gfma_per_s_1t` ÷ the machine's ceiling for both cores
    /// ([`BenchOptions::ceiling_gfma`]).
    pub of_ceiling: f64,
    pub thesis_fps_1t: f64,
    pub thesis_fps_8t: f64,
    /// `frame_fps_1t` ≥ the thesis' 1-thread figure (must).
    pub must_pass: bool,
    /// `2 × frame_fps_1t` (both cores, ideal scaling) ≥ the thesis' 8-thread
    /// figure (target).
    pub target_pass: bool,
}

/// The bake of one scene.
#[derive(Clone, Debug, Serialize)]
pub struct BakeRow {
    pub scene: String,
    pub vertices: usize,
    pub shadows: bool,
    pub bake_s: f64,
    pub target_s: f64,
    pub pass: bool,
    pub data_mb: f64,
}

/// Several lights on the first scene ([`floor_and_sphere_three_lights`]):
/// one bake per light plane, one propagation per light.
#[derive(Clone, Debug, Serialize)]
pub struct LightsRow {
    pub scene: String,
    pub vertices: usize,
    pub lights: usize,
    pub planes: usize,
    pub compression: String,
    /// The bake of every plane, with shadows (s).
    pub bake_s: f64,
    pub data_mb: f64,
    pub fma_per_vertex: f64,
    /// The propagation of every light, every thread, wall clock (ms).
    pub propagate_ms: f64,
    /// The same for the first light alone, on the same bake (ms).
    pub propagate_ms_first_light: f64,
    /// `propagate_ms / propagate_ms_first_light` (≈ the lights, when each
    /// costs what the first does).
    pub ratio: f64,
}

/// A light field on the first scene ([`floor_and_sphere_light_field`],
/// 4 × 4 prism views, shadows): one propagation against the plain light's
/// on the same bake ([`crate::light_field`]).
#[derive(Clone, Debug, Serialize)]
pub struct LightFieldRow {
    pub scene: String,
    pub vertices: usize,
    /// Slope extent and whether the views fall on face cells (block
    /// operators) or not (pixel domain).
    pub views: String,
    pub compression: String,
    /// Angular slices kept, of 16.
    pub slices: usize,
    pub fma_per_vertex: f64,
    /// The propagation, both threads, wall clock (ms).
    pub propagate_ms: f64,
    /// The plain textured light's, same bake and compression (ms).
    pub plain_ms: f64,
    /// `propagate_ms / plain_ms`.
    pub ratio: f64,
}

/// Everything `relight bench nearfield` prints.
#[derive(Clone, Debug)]
pub struct NearfieldBench {
    /// Fig. 4.11's table.
    pub rows: Vec<BenchRow>,
    pub bakes: Vec<BakeRow>,
    pub lights: Vec<LightsRow>,
    pub light_fields: Vec<LightFieldRow>,
}

/// Settings of [`bench_nearfield`].
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// (floor quads per side, sphere segments) per scene.
    pub scenes: Vec<(usize, usize)>,
    pub width: usize,
    pub height: usize,
    pub repeats: usize,
    /// The machine's f32 FMA rate the work is read against, GFMA/s (the
    /// caller passes the project's figure).
    pub ceiling_gfma: f64,
}

impl BenchOptions {
    /// Thesis-sized scenes (~39 K / 57 K / 68 K vertices at 1200×900) or a
    /// `quick` smoke size.
    #[must_use]
    pub fn new(quick: bool, ceiling_gfma: f64) -> Self {
        if quick {
            Self {
                scenes: vec![(30, 30)],
                width: 240,
                height: 180,
                repeats: 2,
                ceiling_gfma,
            }
        } else {
            Self {
                scenes: vec![(140, 196), (168, 238), (184, 260)],
                width: 1200,
                height: 900,
                repeats: 5,
                ceiling_gfma,
            }
        }
    }
}

fn min_ms(repeats: usize, mut f: impl FnMut() -> f64) -> f64 {
    (0..repeats.max(1))
        .map(|_| f())
        .fold(f64::INFINITY, f64::min)
}

/// Nanoseconds the calling thread has run on a CPU (Linux
/// `/proc/thread-self/schedstat`), `None` elsewhere. Timing by CPU time
/// rather than wall time keeps the 1-thread figures meaningful on a machine
/// shared with other jobs.
fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// The CPU milliseconds per call of `f` on the calling thread: calls are
/// batched until the thread has run ≥ 250 ms (the clock advances in
/// scheduler ticks), at least `repeats` calls; wall time when the CPU clock
/// is unavailable.
fn min_cpu_ms(repeats: usize, mut f: impl FnMut()) -> f64 {
    let (Some(c0), t0) = (thread_cpu_ns(), Instant::now()) else {
        return min_ms(repeats, || {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        });
    };
    let mut calls = 0u32;
    loop {
        f();
        calls += 1;
        let used = thread_cpu_ns().unwrap_or(c0) - c0;
        if (calls as usize >= repeats.max(1) && used >= 250_000_000)
            || t0.elapsed().as_secs_f64() > 20.0
        {
            return used as f64 * 1e-6 / f64::from(calls);
        }
    }
}

/// The tables.
///
/// # Errors
/// A method failure.
pub fn bench_nearfield(
    opts: &BenchOptions,
    progress: &dyn Progress,
) -> Result<NearfieldBench, MethodError> {
    let mut rows = Vec::new();
    let mut bakes = Vec::new();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| MethodError::failed("nearfield", e))?;
    for (si, &(floor, seg)) in opts.scenes.iter().enumerate() {
        let scene = floor_and_sphere(floor, seg, opts.width, opts.height, true);
        let verts: usize = scene.objects.iter().map(|o| o.mesh.positions.len()).sum();
        let (name, _, t8, t1) = THESIS[si.min(THESIS.len() - 1)];
        let label = format!("floor+sphere ({name}-sized)");
        let mut m = NearfieldMethod::new(NearfieldOptions::default())?;
        let t = Instant::now();
        m.prepare(&scene, progress)?;
        let bake_s = t.elapsed().as_secs_f64() - m.last_times.iter().sum::<f64>() * 1e-3;
        bakes.push(BakeRow {
            scene: label.clone(),
            vertices: verts,
            shadows: true,
            bake_s,
            target_s: 120.0,
            pass: bake_s <= 120.0,
            data_mb: m.data_bytes() as f64 / 1e6,
        });
        let light = scene.area_lights[0].clone();
        let request = FrameRequest::new(scene.camera);
        for (ci, &(s, tt)) in COMPRESSIONS.iter().enumerate() {
            m.set_compression(s, tt);
            m.set_lighting(&scene, &NoProgress)?;
            // A light move: a new frame, then the propagation (the kernel
            // builds the ACC rows and masks of the new position).
            let mut moved = light.clone();
            let move_ms = min_ms(opts.repeats.min(3), || {
                moved.center.x += 1e-3;
                let t = Instant::now();
                m.set_light_frame(&crate::face::LightFrame::of(&moved));
                m.propagate();
                t.elapsed().as_secs_f64() * 1e3
            });
            m.set_light_frame(&crate::face::LightFrame::of(&light));
            m.update_source(&light)?;
            let (prop_1t, raster_1t) = one.install(|| {
                (
                    min_cpu_ms(opts.repeats, || {
                        m.propagate();
                    }),
                    min_cpu_ms(opts.repeats, || {
                        let _ = m.render(&scene, &request, &NoProgress);
                    }),
                )
            });
            let prop = min_ms(opts.repeats, || m.propagate());
            let raster = min_ms(opts.repeats, || {
                let t = Instant::now();
                let _ = m.render(&scene, &request, &NoProgress);
                t.elapsed().as_secs_f64() * 1e3
            });
            let fma = m.propagate_fma();
            let frame_fps = 1e3 / (prop + raster);
            let frame_fps_1t = 1e3 / (prop_1t + raster_1t);
            rows.push(BenchRow {
                scene: label.clone(),
                vertices: verts,
                compression: format!("{:.0} %/{:.0} %", s * 100.0, tt * 100.0),
                source_terms: m.source().len(),
                target_terms: m.target_count(),
                fma_per_vertex: fma / verts as f64,
                propagate_fps_1t: 1e3 / prop_1t,
                propagate_fps: 1e3 / prop,
                frame_fps,
                move_ms,
                frame_fps_1t,
                gfma_per_s_1t: fma / (prop_1t * 1e-3) / 1e9,
                of_ceiling: fma / (prop_1t * 1e-3) / 1e9 / opts.ceiling_gfma,
                thesis_fps_1t: t1[ci],
                thesis_fps_8t: t8[ci],
                must_pass: frame_fps_1t >= t1[ci],
                target_pass: 2.0 * frame_fps_1t >= t8[ci],
            });
        }
    }
    let lights = bench_lights(opts, progress)?;
    let light_fields = bench_light_fields(opts, progress)?;
    Ok(NearfieldBench {
        rows,
        bakes,
        lights,
        light_fields,
    })
}

/// [`LightFieldRow`]s: views on and off face cells, at 1 %/20 % and with
/// 4× the source terms.
fn bench_light_fields(
    opts: &BenchOptions,
    progress: &dyn Progress,
) -> Result<Vec<LightFieldRow>, MethodError> {
    let Some(&(floor, seg)) = opts.scenes.first() else {
        return Ok(Vec::new());
    };
    let size = [opts.width, opts.height];
    let plain = floor_and_sphere(floor, seg, opts.width, opts.height, true);
    let verts: usize = plain.objects.iter().map(|o| o.mesh.positions.len()).sum();
    let mut p = NearfieldMethod::new(NearfieldOptions::default())?;
    p.prepare(&plain, progress)?;
    let mut rows = Vec::new();
    for (extent, on_cells) in [
        (2.0f32, "views on face cells"),
        (1.7, "views off face cells"),
    ] {
        let scene = floor_and_sphere_light_field(floor, seg, size, true, 4, extent);
        let mut m = NearfieldMethod::new(NearfieldOptions::default())?;
        m.prepare(&scene, progress)?;
        for s in [0.01, 0.04] {
            m.set_compression(s, 0.20);
            m.set_lighting(&scene, &NoProgress)?;
            p.set_compression(s, 0.20);
            p.set_lighting(&plain, &NoProgress)?;
            let field_ms = min_ms(opts.repeats, || m.propagate());
            let plain_ms = min_ms(opts.repeats, || p.propagate());
            rows.push(LightFieldRow {
                scene: "floor+sphere, prism light field 4 × 4".into(),
                vertices: verts,
                views: format!("extent {extent}: {on_cells}"),
                compression: format!("{:.0} %/20 %", s * 100.0),
                slices: m.field_slices(0),
                fma_per_vertex: m.propagate_fma() / verts as f64,
                propagate_ms: field_ms,
                plain_ms,
                ratio: field_ms / plain_ms,
            });
        }
    }
    Ok(rows)
}

/// [`LightsRow`]s at 1 %/20 % and 5 %/40 %.
fn bench_lights(
    opts: &BenchOptions,
    progress: &dyn Progress,
) -> Result<Vec<LightsRow>, MethodError> {
    let Some(&(floor, seg)) = opts.scenes.first() else {
        return Ok(Vec::new());
    };
    let scene = floor_and_sphere_three_lights(floor, seg, opts.width, opts.height, true);
    let verts: usize = scene.objects.iter().map(|o| o.mesh.positions.len()).sum();
    let mut m = NearfieldMethod::new(NearfieldOptions::default())?;
    let t = Instant::now();
    m.prepare(&scene, progress)?;
    let bake_s = t.elapsed().as_secs_f64() - m.last_times.iter().sum::<f64>() * 1e-3;
    // The first light alone, as a scene of its own: its bake is the same
    // transport as the three-light scene's first plane.
    let mut first = scene.clone();
    first.area_lights.truncate(1);
    let mut one = NearfieldMethod::new(NearfieldOptions::default())?;
    one.prepare(&first, progress)?;
    let mut rows = Vec::new();
    for (s, tt) in [(0.01, 0.20), (0.05, 0.40)] {
        m.set_compression(s, tt);
        m.set_lighting(&scene, &NoProgress)?;
        one.set_compression(s, tt);
        one.set_lighting(&first, &NoProgress)?;
        let all = min_ms(opts.repeats, || m.propagate());
        let alone = min_ms(opts.repeats, || one.propagate());
        rows.push(LightsRow {
            scene: "floor+sphere, three lights".into(),
            vertices: verts,
            lights: scene.area_lights.len(),
            planes: m.planes(),
            compression: format!("{:.0} %/{:.0} %", s * 100.0, tt * 100.0),
            bake_s,
            data_mb: m.data_bytes() as f64 / 1e6,
            fma_per_vertex: m.propagate_fma() / verts as f64,
            propagate_ms: all,
            propagate_ms_first_light: alone,
            ratio: all / alone,
        });
    }
    Ok(rows)
}
