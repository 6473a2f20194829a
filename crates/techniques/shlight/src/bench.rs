//! `relight bench` rows for the SH renderer: per-frame time at a given size,
//! and the method's frame through the interface against issue 11's targets.

use crate::method::{ShMethod, ShOptions};
use crate::relight::ShRotationMethod;
use crate::{NormalMap, ShLightError, ShRenderer};
use glam::Quat;
use relight_render::method::{FrameRequest, MethodError, Relighter, render_frame};
use relight_render::{NoProgress, Scene};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// One timing of the SH renderer.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ShRenderBenchRow {
    /// Bands.
    pub order: usize,
    pub rotation: String,
    pub normal_map: bool,
    pub width: usize,
    pub height: usize,
    /// Per frame, bake cached: lighting projection + per-vertex rotation + raster + shading (ms, median).
    pub ms_frame: f64,
    /// The first frame, including the BRDF bakes (ms).
    pub ms_first_frame: f64,
}

/// Times [`ShRenderer::render`] on `scene` at `width × height` (e.g. 1280×720)
/// for each order and method, with and without `normal_map`: the first frame
/// (bake included) and the median of `frames` more. Background pixels are
/// black: the time is the technique's (lighting projection, per-vertex
/// rotation, raster, per-pixel shading), not `EnvMap::eval` of the sky.
///
/// # Errors
/// As [`ShRenderer::render`].
pub fn bench_sh_render(
    scene: &Scene,
    normal_map: Option<&NormalMap>,
    width: usize,
    height: usize,
    orders: &[usize],
    methods: &[ShRotationMethod],
    frames: usize,
) -> Result<Vec<ShRenderBenchRow>, ShLightError> {
    let mut scene = scene.clone();
    scene.camera.width = width;
    scene.camera.height = height;
    let mut rows = Vec::new();
    for &order in orders {
        for &m in methods {
            for nm in std::iter::once(None).chain(normal_map.map(Some)) {
                if nm.is_none() && m != methods[0] {
                    continue; // without a normal map every method is the same image
                }
                let r = ShRenderer::new(order, m)?.with_env_background(false);
                let t0 = Instant::now();
                r.render(&scene, nm, &NoProgress)?;
                let first = t0.elapsed().as_secs_f64() * 1e3;
                let mut times: Vec<f64> = (0..frames.max(1))
                    .map(|_| {
                        let t = Instant::now();
                        r.render(&scene, nm, &NoProgress)
                            .map(|_| t.elapsed().as_secs_f64() * 1e3)
                    })
                    .collect::<Result<_, _>>()?;
                times.sort_by(f64::total_cmp);
                rows.push(ShRenderBenchRow {
                    order,
                    rotation: if nm.is_some() {
                        m.name().to_string()
                    } else {
                        "any".to_string()
                    },
                    normal_map: nm.is_some(),
                    width,
                    height,
                    ms_frame: times[times.len() / 2],
                    ms_first_frame: first,
                });
            }
        }
    }
    Ok(rows)
}

/// One configuration of [`bench_sh_frames`]: the `sh` method's frame through
/// the interface (`render_frame`: raster, per-pixel shading, coverage and the
/// shared background), with a target.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ShFrameBenchRow {
    pub method: &'static str,
    pub width: usize,
    pub height: usize,
    pub order: usize,
    pub rotation: String,
    pub window: String,
    pub normal_map: bool,
    pub aa: usize,
    /// `render_frame` after a camera-orbit step, median (ms): the method's
    /// `render` plus the shared coverage and background of `render_frame`.
    pub view_change_ms: f64,
    /// The method's own `render` of the same step, median (ms): raster and
    /// per-pixel shading, without `render_frame`'s shared background.
    pub method_render_ms: f64,
    /// `set_lighting` after a lighting rotation step, median (ms).
    pub light_change_ms: f64,
    /// The view change's target (ms).
    pub target_ms: f64,
    pub pass: bool,
    /// Where the target comes from.
    pub source: &'static str,
}

/// The configurations of issue 11 item 2: (width, height, rotation, target ms).
pub const FRAME_TARGETS: [(usize, usize, ShRotationMethod, f64); 2] = [
    (960, 540, ShOptions::DEFAULT_ROTATION, 33.0),
    (1280, 720, ShRotationMethod::Taylor1, 40.0),
];

/// Times the `sh` method (order 6, every object normal-mapped with
/// [`NormalMap::bumps`], `aa = 1`, the viewer while interacting) on `scene`
/// for each of [`FRAME_TARGETS`] (at `scale` × their size: 1 for the real
/// rows, smaller for a quick run): `frames` camera-orbit steps of 2° and as
/// many lighting steps, medians.
///
/// # Errors
/// As the method's `prepare` / `render`.
pub fn bench_sh_frames(
    scene: &Scene,
    frames: usize,
    scale: f64,
) -> Result<Vec<ShFrameBenchRow>, MethodError> {
    let bumps = Arc::new(NormalMap::bumps(256, 8, 0.6));
    let mut scene = scene.clone();
    for o in &mut scene.objects {
        o.normal_map = Some(bumps.clone());
    }
    let mut rows = Vec::new();
    for (w, h, rotation, target) in FRAME_TARGETS {
        let (w, h) = (
            ((w as f64 * scale) as usize).max(16),
            ((h as f64 * scale) as usize).max(9),
        );
        scene.camera.width = w;
        scene.camera.height = h;
        let options = ShOptions {
            order: 6,
            rotation,
            ..ShOptions::default()
        };
        let mut m = ShMethod::new(options)?;
        m.prepare(&scene, &NoProgress)?;
        let base = scene.camera;
        let mut view = Vec::new();
        let mut light = Vec::new();
        let mut own = Vec::new();
        let world_from_env = scene.world_from_env;
        for i in 0..=frames.max(1) {
            let q = Quat::from_rotation_y((2.0 * i as f32).to_radians());
            let mut cam = base;
            cam.eye = base.target + q * (base.eye - base.target);
            let req = FrameRequest::new(cam);
            let t = Instant::now();
            render_frame(&mut m, &scene, &req, &NoProgress)?;
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let t = Instant::now();
            m.render(&scene, &req, &NoProgress)?;
            let rms = t.elapsed().as_secs_f64() * 1e3;
            scene.world_from_env = glam::Mat3::from_quat(q) * world_from_env;
            let t = Instant::now();
            m.set_lighting(&scene, &NoProgress)?;
            let lms = t.elapsed().as_secs_f64() * 1e3;
            if i > 0 {
                // The first frame warms caches and thread pools.
                view.push(ms);
                own.push(rms);
                light.push(lms);
            }
        }
        scene.world_from_env = world_from_env;
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let view_ms = median(&mut view);
        rows.push(ShFrameBenchRow {
            method: crate::SH_METHOD_NAME,
            width: w,
            height: h,
            order: options.order,
            rotation: rotation.name().to_string(),
            window: options.window.name().to_string(),
            normal_map: true,
            aa: 1,
            view_change_ms: view_ms,
            method_render_ms: median(&mut own),
            light_change_ms: median(&mut light),
            target_ms: target,
            pass: view_ms <= target,
            source: "issue 11",
        });
    }
    Ok(rows)
}
