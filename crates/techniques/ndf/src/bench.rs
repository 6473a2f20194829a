//! `relight bench ndf`: bake and shading times, memory per representation.
//!
//! Bakes are timed on the map given (512² for the shared maps); frames on
//! the horizon plane ([`crate::verify::horizon_plane_scene`]) at the given
//! size, best of `repeats` after one warm-up frame.

use crate::effective::NdfBrdf;
use crate::method::{NdfFilter, NdfMethod, NdfOptions};
use crate::pyramid::{VmfBakeOptions, VmfPyramid};
use crate::{MeanPyramid, ShNdfPyramid};
use relight_render::method::{FrameRequest, MethodError, Relighter, render_frame};
use relight_render::{NoProgress, NormalMap};
use serde::Serialize;
use std::time::Instant;

/// One row of `relight bench ndf`.
#[derive(Clone, Debug, Serialize)]
pub struct NdfBenchRow {
    /// `bake` or `frame`.
    pub what: String,
    pub representation: String,
    /// Map side (bake) or image side (frame).
    pub size: usize,
    pub ms: f64,
    /// Frames per second (frame rows).
    pub fps: Option<f64>,
    /// Bytes of the representation with its full MIP chain (bake rows).
    pub bytes: Option<u64>,
    /// The target for this row.
    pub target: String,
}

fn best(repeats: usize, mut f: impl FnMut()) -> f64 {
    (0..repeats.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

/// Runs the benchmark on `map`, frames at `image × image`.
///
/// # Errors
/// A method failure.
pub fn bench_ndf(
    map: &NormalMap,
    image: usize,
    repeats: usize,
) -> Result<Vec<NdfBenchRow>, MethodError> {
    let (w, h) = (map.width, map.height);
    let mut rows = Vec::new();
    let mut sh = None;
    let ms = best(repeats, || {
        sh = Some(ShNdfPyramid::build(w, h, &map.texels, 3))
    });
    rows.push(NdfBenchRow {
        what: "bake".into(),
        representation: "sh order 3".into(),
        size: w,
        ms,
        fps: None,
        bytes: sh.map(|s| s.bytes()),
        target: "≤ 100 ms at 512²".into(),
    });
    let mut vmf = None;
    let ms = best(1, || {
        vmf = Some(VmfPyramid::build(
            w,
            h,
            &map.texels,
            &VmfBakeOptions::default(),
        ))
    });
    rows.push(NdfBenchRow {
        what: "bake".into(),
        representation: "vmf J=6".into(),
        size: w,
        ms,
        fps: None,
        bytes: vmf.map(|v| v.bytes()),
        target: "≤ 5 s at 512²".into(),
    });
    let mut mean = None;
    let ms = best(repeats, || {
        mean = Some(MeanPyramid::build(w, h, &map.texels))
    });
    rows.push(NdfBenchRow {
        what: "bake".into(),
        representation: "mean normal (baselines)".into(),
        size: w,
        ms,
        fps: None,
        bytes: mean.map(|m| m.levels.iter().map(|l| l.2.len() as u64 * 12).sum()),
        target: "-".into(),
    });
    let mut lean = None;
    let ms = best(repeats, || {
        lean = Some(crate::LeanPyramid::build(w, h, &map.texels))
    });
    rows.push(NdfBenchRow {
        what: "bake".into(),
        representation: "lean (5 moments)".into(),
        size: w,
        ms,
        fps: None,
        bytes: lean.map(|l| l.bytes()),
        target: "-".into(),
    });
    for (filter, brdf, env, target) in [
        (
            NdfFilter::Sh,
            NdfBrdf::Lambert,
            true,
            "SH Lambert ≥ 60 fps at 512²",
        ),
        (
            NdfFilter::Vmf,
            NdfBrdf::Blinn { s: 64.0 },
            false,
            "vMF J=6, one light ≥ 25 fps at 512²",
        ),
        (NdfFilter::Toksvig, NdfBrdf::Blinn { s: 64.0 }, false, "-"),
        (NdfFilter::Lean, NdfBrdf::Blinn { s: 64.0 }, false, "-"),
    ] {
        let mut scene = crate::verify::horizon_plane_scene(map, brdf, image, 16.0);
        if env {
            scene.point_lights.clear();
            scene.env = relight_sphere::EnvMap::from_fn(
                relight_sphere::Param::LatLong {
                    width: 64,
                    height: 32,
                },
                |d| glam::Vec3::splat(0.5 + 0.5 * d.y.max(0.0)),
            );
        }
        let mut m = NdfMethod::new(NdfOptions {
            filter,
            brdf,
            ..NdfOptions::default()
        })?;
        m.prepare(&scene, &NoProgress)?;
        let req = FrameRequest::new(scene.camera);
        render_frame(&mut m, &scene, &req, &NoProgress)?;
        let mut fail = None;
        let ms = best(repeats, || {
            if let Err(e) = m.render(&scene, &req, &NoProgress) {
                fail = Some(e);
            }
        });
        if let Some(e) = fail {
            return Err(e);
        }
        rows.push(NdfBenchRow {
            what: "frame".into(),
            representation: format!("{} ({})", filter.name(), brdf.label()),
            size: image,
            ms,
            fps: Some(1e3 / ms),
            bytes: None,
            target: target.into(),
        });
    }
    Ok(rows)
}
