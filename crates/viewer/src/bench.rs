//! `relight bench frames`: the viewer's frame path, timed headlessly.
//!
//! Every figure comes from the code a window runs: a [`Viewer`] per method
//! and image size, driven as a user drives it, and each frame turned into
//! display words ([`to_display`]) as the window does — only the window
//! system's blit is left out. Per method and size:
//!
//! | column | what is timed (median of several steps) |
//! |---|---|
//! | `prepare_ms` | first use: create, check, bake or cache load, first `set_lighting` (once, excluded from the rest) |
//! | `view_change_ms` | one camera-orbit step while dragging: [`Viewer::frame`] with `preview` |
//! | `light_change_ms` | one lighting-rotation step while right-dragging: `set_lighting` + a preview frame |
//! | `first_still_ms` | the first frame after the view stops: the first refinement pass |
//! | `refined_ms` | from the view stopping until [`Viewer::refining`] is false: every pass |
//!
//! The cases: every method of issue 11 on the default scene at 960×540
//! and 1280×720 with that target rows, then the later methods
//! ([`later_cases`]: ndf, triple, nearfield, shexp), each on its own
//! issue's bench scene at the size its frame-rate target is stated for.
//!
//! Rows with a target say `pass` when the columns it judges ([`Judged`]:
//! both interaction columns, or the view change alone where the rate
//! is for a shading or animated frame) are within `target` ms; `source`
//! names the issue and its wording. `work_fma` is the method's own count of fused multiply-adds
//! per view-change frame ([`relight_render::method::Relighter::frame_work`]),
//! and `machine_fraction` what share of the machine's f32 FMA rate
//! ([`MACHINE_GFMA`]) the view-change time reaches; `light_work_fma` and
//! `light_machine_fraction` are the same for a lighting-change frame.

use crate::state::{Viewer, ViewerError, ViewerOptions, to_display};
use relight_methods::{MethodKind, MethodOptions};
use relight_render::method::MethodError;
use relight_render::texture::NormalMap;
use relight_render::{Medium, NoProgress, Progress, Scene};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// The machine's peak f32 fused multiply-add rate the work is read against,
/// GFMA/s: 2 vCPUs × 2 FMA ports × 8 lanes (AVX2) × ≈ 0.9 GHz sustained
/// under the shared load, the figure issue 11 states ("about 28 GFMA/s").
pub const MACHINE_GFMA: f64 = 28.0;

/// Where the targets come from.
pub const TARGET_SOURCE: &str = "issue 11";

/// One scene variant of the bench.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BenchScene {
    /// `relight_scene::default_scene` as embedded.
    Default,
    /// Every object with a procedural bump normal map ([`NormalMap::bumps`]).
    NormalMap,
    /// A homogeneous medium and four point lights
    /// (`relight_fog::default_scene_lights`).
    Fog4Lights,
    /// Issue 14's horizon plane ([`relight_ndf::bench::frame_scene`]) with a
    /// procedural bump map of `map`² texels: `sky`, Lambert under a sky;
    /// otherwise Blinn 64 under one point light.
    NdfPlane { map: usize, sky: bool },
    /// Issue 12's Table 3 scene ([`relight_triple::bench::table3_scene`]): a
    /// UV sphere of about `vertices` vertices (the bench's stand-in for the
    /// bunny) on a floor, under the default scene's environment, shadows on.
    TripleSphere { vertices: usize },
    /// Issue 13's Fig. 4.11 scene
    /// ([`relight_nearfield::scenes::floor_and_sphere`]): a floor of
    /// `floor`² quads and a sphere of `segments` under a textured ceiling
    /// light, shadows on.
    NearfieldFloor { floor: usize, segments: usize },
    /// Issue 15's battle-like scene
    /// ([`relight_shexp::bench::battle_like_scene`]), each mesh's side
    /// divided by `shrink`.
    ShExpBattle { shrink: usize },
}

impl BenchScene {
    /// The bench's scene of `width × height`.
    #[must_use]
    pub fn build(self, width: usize, height: usize) -> Scene {
        let mut s = relight_scene::default_scene(width, height);
        match self {
            Self::Default => {}
            Self::NormalMap => {
                let nm = Arc::new(NormalMap::bumps(256, 8, 0.6));
                for o in &mut s.objects {
                    o.normal_map = Some(nm.clone());
                }
            }
            Self::Fog4Lights => {
                s.medium = Some(Medium {
                    beta: 0.1,
                    albedo: 1.0,
                    radius: 10.0,
                });
                s.point_lights = relight_fog::default_scene_lights(4);
            }
            Self::NdfPlane { map, sky } => {
                let brdf = if sky {
                    relight_ndf::NdfBrdf::Lambert
                } else {
                    relight_ndf::bench::FRAME_BLINN
                };
                let map = relight_ndf::bench::procedural_map(map);
                s = relight_ndf::bench::frame_scene(&map, brdf, sky, width);
            }
            Self::TripleSphere { vertices } => {
                let mesh = Arc::new(relight_triple::bench::sphere_mesh(vertices));
                s = relight_triple::bench::table3_scene(s.env, mesh, width, height);
            }
            Self::NearfieldFloor { floor, segments } => {
                s = relight_nearfield::scenes::floor_and_sphere(
                    floor, segments, width, height, true,
                );
            }
            Self::ShExpBattle { shrink } => {
                s = relight_shexp::bench::battle_like_scene(shrink);
            }
        }
        s.camera.width = width;
        s.camera.height = height;
        s
    }
}

/// One case: a method with its options on one scene at one size, with an
/// optional target (ms for both interaction columns).
#[derive(Clone, Debug)]
pub struct FrameCase {
    pub label: String,
    pub options: MethodOptions,
    pub scene: BenchScene,
    pub width: usize,
    pub height: usize,
    pub target_ms: Option<f64>,
    /// Where `target_ms` comes from (the issue and its wording).
    pub source: String,
    /// Which columns `target_ms` judges.
    pub judged: Judged,
}

/// Which interaction columns a case's target judges.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Judged {
    /// The view change and the lighting change (issue 11's targets; issue
    /// 12's "a light rotation: … same frame time"; issue 13's Fig. 4.11
    /// frame, which a light move's propagation and raster make).
    Both,
    /// The view change only: the issue sets its rate for a shading frame
    /// (issue 14) or for an animated frame, which shades every vertex as a
    /// view change does (issue 15). The lighting change is reported.
    ViewChange,
}

/// What `relight bench frames` runs.
#[derive(Clone, Debug)]
pub struct FrameBenchOptions {
    pub cases: Vec<FrameCase>,
    /// View-change and lighting-change steps timed per case (median).
    pub steps: usize,
    /// Still-view refinements timed per case (median).
    pub stills: usize,
    /// At most this many steps and stills for Monte Carlo methods (each
    /// step is a full pass).
    pub monte_carlo_steps: usize,
    /// Samples per pixel side of a still frame.
    pub aa: usize,
}

impl FrameBenchOptions {
    /// The cases: every method on the default scene at 960×540 and
    /// 1280×720, plus the target rows (SH with a normal map, SH with Taylor
    /// rotation at 1280×720, fog with four lights).
    #[must_use]
    pub fn full() -> Self {
        let mut o = Self::with_sizes(
            &[(960, 540), (1280, 720)],
            7,
            3,
            1,
            MethodOptions::default_for,
        );
        o.cases
            .extend(later_cases(false, MethodOptions::default_for));
        o
    }

    /// A smoke run: the same cases at 160×90 with few steps, and the later
    /// methods' cases on small scenes.
    #[must_use]
    pub fn quick() -> Self {
        let mut o = Self::with_sizes(&[(160, 90)], 3, 1, 1, MethodOptions::default_for);
        o.cases
            .extend(later_cases(true, MethodOptions::default_for));
        o
    }

    /// The cases at `sizes` (the first size carries the 960×540
    /// targets, the second the 1280×720 one) with each method's options
    /// from `options_of`.
    #[must_use]
    pub fn with_sizes(
        sizes: &[(usize, usize)],
        steps: usize,
        stills: usize,
        monte_carlo_steps: usize,
        options_of: impl Fn(MethodKind) -> MethodOptions,
    ) -> Self {
        let full_size = sizes.first() == Some(&(960, 540));
        let t = |ms: f64| full_size.then_some(ms);
        let mut cases = Vec::new();
        for (i, &(width, height)) in sizes.iter().enumerate() {
            let first = i == 0;
            for kind in [
                MethodKind::Wavelet,
                MethodKind::Sh,
                MethodKind::Fog,
                MethodKind::Reference,
            ] {
                cases.push(FrameCase {
                    label: "default scene".into(),
                    options: options_of(kind),
                    scene: BenchScene::Default,
                    width,
                    height,
                    target_ms: if first && kind == MethodKind::Wavelet {
                        t(33.0)
                    } else {
                        None
                    },
                    source: TARGET_SOURCE.into(),
                    judged: Judged::Both,
                });
            }
            if first {
                cases.push(FrameCase {
                    label: "order 6, per pixel, normal map".into(),
                    // The exact rotation `bench sh` times for this target
                    // (the method's default, ZYZ: no per-pixel matrix build).
                    options: sh_options(&options_of, relight_shlight::ShOptions::DEFAULT_ROTATION),
                    scene: BenchScene::NormalMap,
                    width,
                    height,
                    target_ms: t(33.0),
                    source: TARGET_SOURCE.into(),
                    judged: Judged::Both,
                });
                cases.push(FrameCase {
                    label: "medium + 4 point lights".into(),
                    options: options_of(MethodKind::Fog),
                    scene: BenchScene::Fog4Lights,
                    width,
                    height,
                    target_ms: t(16.0),
                    source: TARGET_SOURCE.into(),
                    judged: Judged::Both,
                });
            }
            if i == 1 || sizes.len() == 1 {
                cases.push(FrameCase {
                    label: "order 6, per-pixel Taylor, normal map".into(),
                    options: sh_options(&options_of, relight_shlight::ShRotationMethod::Taylor1),
                    scene: BenchScene::NormalMap,
                    width,
                    height,
                    target_ms: (full_size && i == 1).then_some(40.0),
                    source: TARGET_SOURCE.into(),
                    judged: Judged::Both,
                });
            }
        }
        Self {
            cases,
            steps,
            stills,
            monte_carlo_steps,
            aa: crate::state::DEFAULT_STILL_AA,
        }
    }
}

/// The later methods' cases (issue 11: "Later methods (triple product,
/// near-field, NDF, SH-exp) add their rows under their own issues'
/// targets"), each on its own issue's bench scene, at the size and with the
/// settings that issue states its frame-rate target for; `quick`: small
/// scenes and images, no targets.
#[must_use]
pub fn later_cases(
    quick: bool,
    options_of: impl Fn(MethodKind) -> MethodOptions,
) -> Vec<FrameCase> {
    let target = |fps: f64, source: String| {
        if quick {
            (None, String::new())
        } else {
            (Some(1e3 / fps), source)
        }
    };
    let mut cases = Vec::new();
    // Issue 14: SH Lambert under the sky, vMF J = 6 Blinn 64 under one light.
    let side = if quick {
        64
    } else {
        relight_ndf::bench::TARGET_SIZE
    };
    for (filter, sky, fps, what) in [
        (
            relight_ndf::NdfFilter::Sh,
            true,
            relight_ndf::bench::SH_LAMBERT_FPS,
            "SH Lambert",
        ),
        (
            relight_ndf::NdfFilter::Vmf,
            false,
            relight_ndf::bench::VMF_ONE_LIGHT_FPS,
            "vMF J=6, one light",
        ),
    ] {
        let options = match options_of(MethodKind::Ndf) {
            MethodOptions::Ndf(mut o) => {
                o.filter = filter;
                o.brdf = if sky {
                    relight_ndf::NdfBrdf::Lambert
                } else {
                    relight_ndf::bench::FRAME_BLINN
                };
                MethodOptions::Ndf(o)
            }
            other => other,
        };
        let (target_ms, source) = target(
            fps,
            format!(
                "{}: {what} ≥ {fps} fps at {side}² (a shading frame: the view change)",
                relight_ndf::bench::TARGET_SOURCE
            ),
        );
        cases.push(FrameCase {
            label: if sky {
                "horizon plane, sh, Lambert, sky".into()
            } else {
                "horizon plane, vmf J=6, Blinn 64, 1 light".into()
            },
            options,
            scene: BenchScene::NdfPlane { map: side, sky },
            width: side,
            height: side,
            target_ms,
            source,
            judged: Judged::ViewChange,
        });
    }
    // Issue 12, Table 3: n = 80, per-vertex visibility, at both sizes, in
    // both per-pixel forms (the default lookup from each pixel's frame, and
    // the interpolated functions the bench's targets are met with).
    let terms = 80;
    let (vertices, sizes): (usize, &[(usize, usize)]) = if quick {
        (2_000, &[(128, 96)])
    } else {
        (25_000, &[(1024, 768), (512, 384)])
    };
    for shading in [
        relight_triple::Shading::Pixel,
        relight_triple::Shading::Interpolated,
    ] {
        let triple = match options_of(MethodKind::Triple) {
            MethodOptions::Triple(mut o) => {
                o.terms = terms;
                o.shading = shading;
                o.vis_level = if quick {
                    relight_triple::method::level_of(terms)
                } else {
                    o.vis_level.max(relight_triple::method::level_of(terms))
                };
                MethodOptions::Triple(o)
            }
            other => other,
        };
        for &(width, height) in sizes {
            let (target_ms, source) = relight_triple::bench::target_fps(width, terms).map_or(
                (None, String::new()),
                |fps| {
                    target(
                        fps,
                        format!("issue 12: n = {terms} at {width}×{height} ≥ {fps} fps"),
                    )
                },
            );
            cases.push(FrameCase {
                // The distinguishing words first: plot legends cut long labels.
                label: format!(
                    "Table 3, {}: {:.1} K-vertex sphere + floor, n = {terms}, per-vertex visibility",
                    shading.name(),
                    vertices as f64 * 1e-3
                ),
                options: triple.clone(),
                scene: BenchScene::TripleSphere { vertices },
                width,
                height,
                target_ms,
                source,
                judged: Judged::Both,
            });
        }
    }
    // Issue 13, Fig. 4.11: the fertility-sized scene at the default 1 %/20 %.
    let nf = relight_nearfield::bench::BenchOptions::new(quick, MACHINE_GFMA);
    let (floor, segments) = nf.scenes[0];
    let (name, _, t8, _) = relight_nearfield::bench::THESIS[0];
    let (target_ms, source) = target(
        t8[1],
        format!(
            "issue 13: Fig. 4.11 {name} at 1 %/20 %, the thesis' 8-thread {} fps",
            t8[1]
        ),
    );
    cases.push(FrameCase {
        label: format!(
            "Fig. 4.11, 1 %/20 %: floor {floor}² + sphere {segments}{}, shadows",
            if quick {
                String::new()
            } else {
                format!(" ({name}-sized)")
            }
        ),
        options: options_of(MethodKind::Nearfield),
        scene: BenchScene::NearfieldFloor { floor, segments },
        width: nf.width,
        height: nf.height,
        target_ms,
        source,
        judged: Judged::Both,
    });
    // Issue 15: the battle-like scene's per-vertex shadows and its raster.
    let shexp = match options_of(MethodKind::ShExp) {
        MethodOptions::ShExp(_) => {
            MethodOptions::ShExp(relight_shexp::bench::battle_like_options())
        }
        other => other,
    };
    let (target_ms, source) = target(
        relight_shexp::bench::BATTLE_HZ,
        format!(
            "issue 15: battle-like ≥ {} Hz (an animated frame: the view change)",
            relight_shexp::bench::BATTLE_HZ
        ),
    );
    let ((width, height), shrink) = if quick {
        ((160, 90), 4)
    } else {
        ((960, 540), 1)
    };
    cases.push(FrameCase {
        label: if quick {
            "battle-like, meshes 1/4 per side".into()
        } else {
            "battle-like: 65 K receivers, 8 blockers".into()
        },
        options: shexp,
        scene: BenchScene::ShExpBattle { shrink },
        width,
        height,
        target_ms,
        source,
        judged: Judged::ViewChange,
    });
    cases
}

fn sh_options(
    options_of: &impl Fn(MethodKind) -> MethodOptions,
    rotation: relight_shlight::ShRotationMethod,
) -> MethodOptions {
    match options_of(MethodKind::Sh) {
        MethodOptions::Sh(mut o) => {
            o.order = 6;
            o.rotation = rotation;
            MethodOptions::Sh(o)
        }
        other => other,
    }
}

/// One row of `relight bench frames`.
#[derive(Clone, Debug, Serialize)]
pub struct FrameBenchRow {
    pub method: String,
    pub case: String,
    pub width: usize,
    pub height: usize,
    /// First use (create, check, bake or load, first lighting), ms; not in
    /// the other columns.
    pub prepare_ms: f64,
    pub view_change_ms: Option<f64>,
    pub light_change_ms: Option<f64>,
    pub first_still_ms: Option<f64>,
    pub refined_ms: Option<f64>,
    /// Passes until refined (AA passes, or Monte Carlo passes).
    pub passes: usize,
    /// Fused multiply-adds of one view-change frame, the method's own count
    /// (`None` when the method does not count its work).
    pub work_fma: Option<f64>,
    /// `work_fma` ÷ (view_change_ms × [`MACHINE_GFMA`]).
    pub machine_fraction: Option<f64>,
    /// The same count for a lighting-change frame
    /// ([`relight_render::method::FrameWork::lighting_change_fma`]).
    pub light_work_fma: Option<f64>,
    /// `light_work_fma` ÷ (light_change_ms × [`MACHINE_GFMA`]).
    pub light_machine_fraction: Option<f64>,
    /// Why the method drew nothing, when it refused the scene.
    pub note: Option<String>,
    /// Target of `view_change_ms` and `light_change_ms`, ms.
    pub target: Option<f64>,
    pub pass: Option<bool>,
    pub source: Option<String>,
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// One frame as the window draws it: [`Viewer::frame`], then the display words.
fn timed_frame(
    v: &mut Viewer,
    w: usize,
    h: usize,
    preview: bool,
    words: &mut Vec<u32>,
) -> Result<f64, ViewerError> {
    let t = Instant::now();
    let f = v.frame(w, h, preview, &NoProgress)?;
    words.resize(f.image.width * f.image.height, 0);
    to_display(&f.image, words);
    Ok(t.elapsed().as_secs_f64() * 1e3)
}

/// Runs one case.
///
/// # Errors
/// The method's errors (a refusal of the scene is a row with a note).
pub fn bench_case(
    case: &FrameCase,
    opts: &FrameBenchOptions,
    progress: &dyn Progress,
) -> Result<FrameBenchRow, ViewerError> {
    let (w, h) = (case.width, case.height);
    let kind = case.options.kind();
    let scene = case.scene.build(w, h);
    let mut v = Viewer::new(
        scene,
        kind,
        ViewerOptions {
            methods: vec![case.options.clone()],
            aa: opts.aa,
            approximate: false,
        },
    )?;
    let t = Instant::now();
    v.prepare(progress)?;
    let prepare_ms = t.elapsed().as_secs_f64() * 1e3;
    let mut words = Vec::new();
    let mut row = FrameBenchRow {
        method: kind.name().to_string(),
        case: case.label.clone(),
        width: w,
        height: h,
        prepare_ms,
        view_change_ms: None,
        light_change_ms: None,
        first_still_ms: None,
        refined_ms: None,
        passes: 0,
        work_fma: None,
        machine_fraction: None,
        light_work_fma: None,
        light_machine_fraction: None,
        note: None,
        target: case.target_ms,
        pass: None,
        source: case.target_ms.map(|_| case.source.clone()),
    };
    // One untimed frame: buffers sized, first raster done.
    let first = v.frame(w, h, true, progress)?;
    if let Some(msg) = v.refusal() {
        row.note = Some(msg.to_string());
        row.pass = case.target_ms.map(|_| false);
        return Ok(row);
    }
    row.note = first.message;
    let monte_carlo = first.spp > 0;
    let steps = if monte_carlo {
        opts.steps.min(opts.monte_carlo_steps)
    } else {
        opts.steps
    }
    .max(1);
    let mut view = Vec::new();
    for _ in 0..steps {
        progress.check().map_err(MethodError::from)?;
        v.orbit.rotate(4.0, 1.0);
        view.push(timed_frame(&mut v, w, h, true, &mut words)?);
    }
    // The method's count of the view change just drawn.
    row.work_fma = v.frame_work(w, h).map(|f| f.view_fma);
    let mut light = Vec::new();
    for _ in 0..steps {
        progress.check().map_err(MethodError::from)?;
        v.light_yaw_deg += 5.0;
        light.push(timed_frame(&mut v, w, h, true, &mut words)?);
    }
    row.light_work_fma = v.frame_work(w, h).map(|f| f.lighting_change_fma());
    let stills = if monte_carlo {
        opts.stills.min(opts.monte_carlo_steps)
    } else {
        opts.stills
    };
    let (mut first_still, mut refined, mut passes) = (Vec::new(), Vec::new(), 0);
    for _ in 0..stills.max(1) {
        progress.check().map_err(MethodError::from)?;
        v.orbit.rotate(-3.0, 0.0);
        timed_frame(&mut v, w, h, true, &mut words)?;
        let t0 = timed_frame(&mut v, w, h, false, &mut words)?;
        let mut total = t0;
        passes = 1;
        while v.refining() {
            progress.check().map_err(MethodError::from)?;
            total += timed_frame(&mut v, w, h, false, &mut words)?;
            passes += 1;
        }
        first_still.push(t0);
        refined.push(total);
    }
    row.view_change_ms = median(view);
    row.light_change_ms = median(light);
    row.first_still_ms = median(first_still);
    row.refined_ms = median(refined);
    row.passes = passes;
    let fraction = |fma: Option<f64>, ms: Option<f64>| {
        fma.zip(ms).map(|(fma, ms)| fma / (ms * MACHINE_GFMA * 1e6))
    };
    row.machine_fraction = fraction(row.work_fma, row.view_change_ms);
    row.light_machine_fraction = fraction(row.light_work_fma, row.light_change_ms);
    if let Some(target) = case.target_ms {
        let view = row.view_change_ms.unwrap_or(f64::INFINITY);
        let worst = match case.judged {
            Judged::Both => view.max(row.light_change_ms.unwrap_or(f64::INFINITY)),
            Judged::ViewChange => view,
        };
        row.pass = Some(worst <= target);
    }
    Ok(row)
}

/// Runs every case of `opts` (see the module docs).
///
/// # Errors
/// As [`bench_case`].
pub fn bench_frames(
    opts: &FrameBenchOptions,
    progress: &dyn Progress,
) -> Result<Vec<FrameBenchRow>, ViewerError> {
    opts.cases
        .iter()
        .map(|c| bench_case(c, opts, progress))
        .collect()
}
