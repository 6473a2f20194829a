//! `relight render` and `relight view`: a scene, a method and its options,
//! through the method interface — the same calls the viewer makes
//! (`relight_viewer::Viewer`), so both give the same image. `relight demo`
//! is in [`crate::demo`].

use crate::args::{MethodFlags, RenderArgs, ViewArgs};
use crate::method_args::{kind_of, options_for};
use crate::output::{output_paths, warn_all, write_outputs};
use crate::progress::Bar;
use crate::scene_args::build_scene;
use anyhow::{Result, anyhow, bail, ensure};
use relight_methods::{MethodKind, MethodOptions};
use relight_render::Scene;
use relight_render::method::{
    FrameRequest, MethodError, Rendered, SceneFeature, check_scene, posed_for, render_frame,
};
use std::time::Instant;

/// A refusal, with what the user may not know about the scene they built:
/// scene files and `--mesh` scenes are lit by the studio map unless told
/// otherwise, so a method without environment lighting (nearfield, ltc)
/// refuses them until it is turned off.
fn scene_hint(e: MethodError) -> anyhow::Error {
    match e {
        MethodError::Unsupported {
            feature: SceneFeature::Environment,
            ..
        } => anyhow!("{e} ({})", crate::scene_args::STUDIO_ENV_HINT),
        e => e.into(),
    }
}

/// Checks, prepares and renders `scene` at `time` seconds with the method of
/// `options` at `aa × aa` samples per pixel. A moving scene is prepared as
/// [`posed_for`] says: once on the animation for a method that follows it,
/// else on the pose at `time`.
///
/// # Errors
/// A feature the method cannot render (unless `approximate` and it renders
/// it approximately), bad options, the method's own failures, Ctrl-C.
pub fn render_with(
    options: &MethodOptions,
    scene: &Scene,
    time: f32,
    aa: usize,
    approximate: bool,
    bar: &Bar,
) -> Result<Rendered> {
    let mut method = relight_methods::create(options)?;
    let prepared = posed_for(method.as_ref(), scene, time);
    warn_all(&check_scene(method.as_ref(), &prepared, approximate).map_err(scene_hint)?);
    let t = Instant::now();
    method.prepare(&prepared, bar)?;
    let prepare_s = t.elapsed().as_secs_f64();
    warn_all(&method.warnings());
    let posed = if prepared.is_animated() {
        std::borrow::Cow::Owned(scene.at_time(time))
    } else {
        prepared
    };
    let request = FrameRequest::new(posed.camera).with_aa(aa);
    let out = render_frame(method.as_mut(), &posed, &request, bar)?;
    if out.image.pixels.iter().all(|p| *p == glam::Vec3::ZERO) {
        let in_view = out
            .coverage
            .as_ref()
            .is_none_or(|c| c.object_mask().contains(&true));
        warn_all(&[format!(
            "method {}: the image is black (every pixel 0){}",
            method.name(),
            if in_view {
                ""
            } else {
                ": no object is in the camera's view, and the environment behind is black"
            }
        )]);
    }
    let noise = out.noise.map_or(String::new(), |n| {
        if n.spp < 2 {
            // One sample per pixel has no spread to estimate an error from.
            format!(", {} spp (the standard error needs ≥ 2)", n.spp)
        } else {
            format!(
                ", {} spp, relative standard error {:.4} (RMS {:.4}), over object pixels RMS {:.4}",
                n.spp,
                n.relative_std_error,
                n.rms_relative_std_error,
                n.object_rms_relative_std_error
            )
        }
    });
    eprintln!(
        "relight: {}: prepared in {prepare_s:.2} s; frame: lighting {:.1} ms, view {:.1} ms{noise}",
        method.name(),
        out.timings.lighting_ms,
        out.timings.view_ms
    );
    Ok(out)
}

/// `--aa`, refused for the reference (it integrates each pixel itself).
/// `--aa K` within 1…`MAX_AA` (render, view and demo).
///
/// # Errors
/// K out of range, naming the flag.
pub fn checked_aa(aa: usize) -> Result<usize> {
    let max = relight_render::method::MAX_AA;
    ensure!(
        (1..=max).contains(&aa),
        "--aa {aa}: must be 1…{max} samples per pixel side"
    );
    Ok(aa)
}

fn aa_for(kind: MethodKind, aa: Option<usize>, default: usize) -> Result<usize> {
    match (kind, aa) {
        (MethodKind::Reference, Some(_)) => bail!(
            "--aa does not apply to method reference (it integrates each pixel itself; use --spp)"
        ),
        (MethodKind::Reference, None) => Ok(1),
        (_, Some(k)) => checked_aa(k),
        (_, None) => Ok(default),
    }
}

/// Applies the scene file's `[render] spp` to the methods `--spp` is an
/// option of (reference, radiance-cache) when `--spp` is unset; the others
/// ignore it (a scene file is shared between methods).
fn with_file_spp(kind: MethodKind, mut flags: MethodFlags, spp: Option<u32>) -> MethodFlags {
    if crate::method_args::flag_applies("--spp", kind) && flags.spp.is_none() {
        flags.spp = spp;
    }
    flags
}

pub fn render(a: RenderArgs, bar: &Bar) -> Result<()> {
    let start = Instant::now();
    output_paths(&a.out)?;
    let built = build_scene(&a.scene, None)?;
    let file_method = built.render.as_ref().and_then(|r| r.method.clone());
    let kind = match (a.method, file_method) {
        (Some(m), _) => kind_of(m),
        (None, Some(m)) => m.parse::<MethodKind>().map_err(|e| {
            anyhow!(
                "{}: [render] method: {e}",
                a.scene
                    .scene
                    .as_deref()
                    .map_or("scene".into(), |p| p.display().to_string())
            )
        })?,
        (None, None) => MethodKind::Reference,
    };
    let flags = with_file_spp(
        kind,
        a.options.clone(),
        built.render.as_ref().and_then(|r| r.spp),
    );
    let options = options_for(kind, &flags)?;
    let aa = aa_for(kind, a.aa, 1)?;
    let out = render_with(&options, &built.scene, built.time, aa, a.approximate, bar)?;
    let (png, exr) = write_outputs(&out.image, out.coverage.as_deref(), &a.out)?;
    println!(
        "relight render: {}×{}, method {kind}, wrote {} and {} in {:.2} s",
        out.image.width,
        out.image.height,
        png.display(),
        exr.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The viewer's methods ([`relight_viewer::ViewerOptions`]'s), each with the
/// flags that belong to it.
fn view_methods(flags: &MethodFlags) -> Result<Vec<MethodOptions>> {
    relight_viewer::ViewerOptions::default()
        .methods
        .iter()
        .map(|m| {
            let k = m.kind();
            let mut f = flags.clone();
            crate::method_args::clear_foreign(k, &mut f);
            options_for(k, &f)
        })
        .collect()
}

pub fn view(a: ViewArgs, bar: &Bar) -> Result<()> {
    let built = build_scene(&a.scene, Some(&relight_scene::default_scene))?;
    let (w, h) = (built.scene.camera.width, built.scene.camera.height);
    let aa = checked_aa(a.aa.unwrap_or(relight_viewer::state::DEFAULT_STILL_AA))?;
    let opts = relight_viewer::ViewerOptions {
        methods: view_methods(&a.options)?,
        aa,
        approximate: a.approximate,
    };
    let mut viewer = relight_viewer::Viewer::new(built.scene, kind_of(a.method), opts)?;
    viewer.set_time(built.time);
    relight_viewer::check_display()?;
    // The window opens at once; the method prepares behind it, with its
    // progress in the window and on stderr.
    relight_viewer::run(viewer, w as u32, h as u32, bar)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene file's `[render] spp` goes to the methods `--spp` is an option
    /// of, unless the flag is given; the others ignore it.
    #[test]
    fn file_spp_follows_the_spp_flag() {
        let none = MethodFlags::default();
        for kind in [MethodKind::Reference, MethodKind::RadianceCache] {
            assert_eq!(with_file_spp(kind, none.clone(), Some(7)).spp, Some(7));
        }
        assert_eq!(with_file_spp(MethodKind::Sh, none, Some(7)).spp, None);
        let flag = MethodFlags {
            spp: Some(3),
            ..MethodFlags::default()
        };
        assert_eq!(
            with_file_spp(MethodKind::Reference, flag, Some(7)).spp,
            Some(3)
        );
    }
}
