//! `relight bench ndf`: bake and shading times, memory per representation.
//!
//! Bakes are what the method bakes per filter ([`Baked::bake`]), timed on
//! the map given (512² for the shared maps); frames on
//! the horizon plane ([`crate::verify::horizon_plane_scene`]) at the given
//! size, best of `repeats` after one warm-up frame.
//!
//! Rows with a target (issue 14's, stated at 512²) carry it in ms and say
//! `pass` when the time is within it; at another size (`--quick`) the row
//! is a report (`pass` null) and the source says why.

use crate::effective::NdfBrdf;
use crate::method::{Baked, NdfFilter, NdfMethod, NdfOptions, VmfTaps};
use crate::{ShNdfPyramid, VmfPyramid};
use relight_render::method::{FrameRequest, MethodError, Relighter, render_frame};
use relight_render::{NoProgress, NormalMap, Scene};
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
    /// Whether `ms` is within `target` (null: no target, or not at the
    /// target's size).
    pub pass: Option<bool>,
    /// The limit for `ms`, ms.
    pub target: Option<f64>,
    /// Where the target comes from, with its wording.
    pub source: Option<String>,
}

/// Where the targets come from.
pub const TARGET_SOURCE: &str = "issue 14";

/// The side (map for bakes, image for frames) issue 14's targets are set at.
pub const TARGET_SIZE: usize = 512;

/// Issue 14's frame-rate floor for SH Lambert under the environment, fps.
pub const SH_LAMBERT_FPS: f64 = 60.0;

/// Issue 14's frame-rate floor for vMF J = 6 with one light, fps.
pub const VMF_ONE_LIGHT_FPS: f64 = 25.0;

/// The glossy BRDF the vMF frame rows shade with (Blinn–Phong, s = 64).
pub const FRAME_BLINN: NdfBrdf = NdfBrdf::Blinn { s: 64.0 };

/// The procedural normal map the bench uses where no real map is given:
/// `side`² texels of bumps ([`NormalMap::bumps`], 8 per side, slope 0.8).
#[must_use]
pub fn procedural_map(side: usize) -> NormalMap {
    NormalMap::bumps(side, 8, 0.8)
}

/// The frames' scene: the horizon plane ([`crate::verify::horizon_plane_scene`],
/// `map` tiled 16 times) at `image × image`, shaded with `brdf`; `sky`
/// replaces its point light by a sky (`0.5 + 0.5·max(0, y)`, the
/// environment-lit case), otherwise the point light alone lights it.
#[must_use]
pub fn frame_scene(map: &NormalMap, brdf: NdfBrdf, sky: bool, image: usize) -> Scene {
    let mut scene = crate::verify::horizon_plane_scene(map, brdf, image, 16.0);
    if sky {
        scene.point_lights.clear();
        scene.env = relight_sphere::EnvMap::from_fn(
            relight_sphere::Param::LatLong {
                width: 64,
                height: 32,
            },
            |d| glam::Vec3::splat(0.5 + 0.5 * d.y.max(0.0)),
        );
    }
    scene
}

impl NdfBenchRow {
    /// Sets `target` (ms, `None` for a report row), `pass` and `source`
    /// (`what` the wording).
    fn judged(mut self, target: Option<(f64, &str)>) -> Self {
        if let Some((limit, what)) = target {
            self.target = Some(limit);
            if self.size == TARGET_SIZE {
                self.pass = Some(self.ms <= limit);
                self.source = Some(format!("{TARGET_SOURCE}: {what}"));
            } else {
                self.source = Some(format!(
                    "{TARGET_SOURCE}: {what} (report: measured at {}²)",
                    self.size
                ));
            }
        }
        self
    }
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
    let mut rows = Vec::new();
    // What the method bakes for each filter (`Baked::bake`: SH and vMF from
    // the interpolated field at the default supersampling, and vMF at 4 × 4
    // per texel), the
    // representation's bytes with its full MIP chain.
    let supersample = NdfOptions::default().supersample;
    for (filter, name, ss, reps, target) in [
        (
            NdfFilter::Sh,
            "sh order 3",
            supersample,
            repeats,
            Some((100.0, "SH bake ≤ 100 ms at 512²")),
        ),
        (
            NdfFilter::Vmf,
            "vmf J=6",
            supersample,
            1,
            Some((5000.0, "vMF bake ≤ 5 s at 512²")),
        ),
        // The glossy quality mode's field, 4 × 4 samples per texel.
        (NdfFilter::Vmf, "vmf J=6, field 4×4 per texel", 4, 1, None),
        (
            NdfFilter::Toksvig,
            "mean normal (baselines)",
            supersample,
            repeats,
            None,
        ),
        (
            NdfFilter::Lean,
            "lean (5 moments)",
            supersample,
            repeats,
            None,
        ),
    ] {
        let options = NdfOptions {
            filter,
            supersample: ss,
            ..NdfOptions::default()
        };
        let mut baked = None;
        let ms = best(reps, || baked = Some(Baked::bake(map, &options)));
        let bytes = baked.map(|b| match filter {
            NdfFilter::Sh => b.sh.as_ref().map_or(0, ShNdfPyramid::bytes),
            NdfFilter::Vmf => b.vmf.as_ref().map_or(0, VmfPyramid::bytes),
            NdfFilter::Lean => b.lean.as_ref().map_or(0, crate::LeanPyramid::bytes),
            _ => b.mean.levels.iter().map(|l| l.2.len() as u64 * 12).sum(),
        });
        rows.push(
            NdfBenchRow {
                what: "bake".into(),
                representation: name.into(),
                size: map.width,
                ms,
                fps: None,
                bytes,
                pass: None,
                target: None,
                source: None,
            }
            .judged(target),
        );
    }
    let blinn = FRAME_BLINN;
    for (filter, vmf_taps, probe_masks, brdf, env, target) in [
        (
            NdfFilter::Sh,
            VmfTaps::Merge,
            false,
            NdfBrdf::Lambert,
            true,
            Some((1e3 / SH_LAMBERT_FPS, "SH Lambert ≥ 60 fps at 512²")),
        ),
        // The sh filter's quality mode: the view mask per footprint probe.
        (
            NdfFilter::Sh,
            VmfTaps::Merge,
            true,
            NdfBrdf::Lambert,
            true,
            None,
        ),
        (
            NdfFilter::Vmf,
            VmfTaps::Merge,
            false,
            blinn,
            false,
            Some((
                1e3 / VMF_ONE_LIGHT_FPS,
                "vMF J=6, one light ≥ 25 fps at 512²",
            )),
        ),
        // The quality mode: what keeping every tap's lobes costs.
        (NdfFilter::Vmf, VmfTaps::Mixture, false, blinn, false, None),
        (
            NdfFilter::Toksvig,
            VmfTaps::Merge,
            false,
            blinn,
            false,
            None,
        ),
        (NdfFilter::Lean, VmfTaps::Merge, false, blinn, false, None),
    ] {
        let scene = frame_scene(map, brdf, env, image);
        let mut m = NdfMethod::new(NdfOptions {
            filter,
            brdf,
            vmf_taps,
            probe_masks,
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
        rows.push(
            NdfBenchRow {
                what: "frame".into(),
                representation: match (vmf_taps, probe_masks) {
                    (VmfTaps::Mixture, _) => {
                        format!("{}, taps as a mixture ({})", filter.name(), brdf.label())
                    }
                    (VmfTaps::Merge, true) => {
                        format!("{}, mask per probe ({})", filter.name(), brdf.label())
                    }
                    (VmfTaps::Merge, false) => format!("{} ({})", filter.name(), brdf.label()),
                },
                size: image,
                ms,
                fps: Some(1e3 / ms),
                bytes: None,
                pass: None,
                target: None,
                source: None,
            }
            .judged(target),
        );
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(size: usize, ms: f64) -> NdfBenchRow {
        NdfBenchRow {
            what: "frame".into(),
            representation: "sh (lambert)".into(),
            size,
            ms,
            fps: Some(1e3 / ms),
            bytes: None,
            pass: None,
            target: None,
            source: None,
        }
    }

    #[test]
    fn rows_are_judged_at_the_targets_size_only() {
        let t = Some((1e3 / 60.0, "SH Lambert ≥ 60 fps at 512²"));
        let ok = row(512, 16.0).judged(t);
        assert_eq!(ok.pass, Some(true));
        assert_eq!(ok.target, Some(1e3 / 60.0));
        assert_eq!(
            ok.source.as_deref(),
            Some("issue 14: SH Lambert ≥ 60 fps at 512²")
        );
        assert_eq!(row(512, 16.8).judged(t).pass, Some(false));
        let small = row(128, 1.0).judged(t);
        assert_eq!(small.pass, None);
        assert!(small.source.expect("source").contains("report"));
        let none = row(512, 1.0).judged(None);
        assert_eq!((none.pass, none.target, none.source), (None, None, None));
    }
}
