//! `relight bench` rows for the SH renderer: per-frame time at a given size.

use crate::relight::ShRotationMethod;
use crate::{NormalMap, ShLightError, ShRenderer};
use relight_render::{NoProgress, Scene};
use serde::Serialize;
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
