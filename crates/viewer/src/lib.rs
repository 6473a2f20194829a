//! `relight view`: an interactive window over the real-time methods.
//!
//! The viewer is where the papers' claims are felt rather than measured:
//! drag to orbit the camera (a *view change*: wavelet-rotation-2006 §3
//! step 2, per-vertex sparse dot products; the SH renderer's per-pixel
//! rotation; the fog model's per-pixel airlight), right-drag to turn the
//! lighting (a *lighting change*: the wavelet method's step 1, the SH
//! coefficients rotated, the fog lights moving), and switch methods on the
//! same scene with `1`, `2`, … — the reference among them, which refines
//! pass by pass while the view is still, to judge them against. Every
//! method is reached through the method interface
//! (`relight_render::method::Relighter`), as the CLI reaches it.
//!
//! Layout:
//! * [`orbit`]: the orbit camera (pure math, tested);
//! * [`state`]: [`Viewer`], which owns each method's precomputed data and
//!   draws a [`Frame`] for the current camera, lighting and method —
//!   headless, so tests and scripts can drive it;
//! * [`window`]: winit events → [`Viewer`], frames → a softbuffer surface.
//!   Only this module touches a display;
//! * [`hud`]: the heads-up display drawn into each frame (method, ms, fps,
//!   settings, error against the reference, refusals, progress, keys);
//! * [`light`]: the area-light edit (move in its plane, scale, texture) that
//!   every method is given through `set_lighting`;
//! * [`text`]: bitmap text and panels over display words — the one text
//!   path, shared by the HUD and the demo's labels;
//! * [`sheet`] and [`demo`]: `relight demo`, every method's tile of the
//!   embedded scene composed into one labelled image.
//!
//! While a mouse button is held frames are drawn without antialiasing
//! (preview); a still view is drawn with `aa × aa` samples per pixel.

pub mod bench;
pub mod demo;
pub mod hud;
pub mod light;
pub mod orbit;
pub mod sheet;
pub mod state;
pub mod text;
pub mod window;

pub use light::{LightEdit, LightTexture};
pub use orbit::Orbit;
pub use state::{Frame, Viewer, ViewerError, ViewerOptions, to_display};
pub use window::{check_display, run};

#[cfg(test)]
mod tests {
    use super::*;
    use relight_methods::{MethodKind, MethodOptions};
    use relight_render::NoProgress;

    /// Small, fast settings of every method (the wavelet bake at n = 16).
    fn small_options() -> ViewerOptions {
        // One cache for every run (its entries are versioned and written
        // atomically): a folder per process was left behind by each run.
        let cache = std::env::temp_dir().join("relight-viewer-test-cache");
        let methods = [
            MethodKind::Wavelet,
            MethodKind::Sh,
            MethodKind::Fog,
            MethodKind::Reference,
            MethodKind::Triple,
        ]
        .into_iter()
        .map(|k| match MethodOptions::default_for(k) {
            MethodOptions::Wavelet(mut w) => {
                w.n = 16;
                w.ntess = 4;
                w.terms = 64;
                w.cache_dir = cache.clone();
                MethodOptions::Wavelet(w)
            }
            MethodOptions::Sh(mut s) => {
                s.order = 3;
                MethodOptions::Sh(s)
            }
            MethodOptions::Reference(mut r) => {
                r.pass_spp = 4;
                MethodOptions::Reference(r)
            }
            MethodOptions::Triple(mut t) => {
                t.terms = 80;
                t.brdf_views = 8;
                t.twists = 4;
                t.cache_dir = cache.clone();
                MethodOptions::Triple(t)
            }
            other => other,
        })
        .collect();
        ViewerOptions {
            methods,
            aa: 2,
            approximate: false,
        }
    }

    /// A method's options from [`small_options`], else its defaults.
    fn small_method(k: MethodKind) -> MethodOptions {
        small_options()
            .methods
            .into_iter()
            .find(|m| m.kind() == k)
            .unwrap_or_else(|| MethodOptions::default_for(k))
    }

    /// The default scene with a point light and a thin medium, so that every
    /// method has something to draw (fog renders point lights and the
    /// foggy environment; sh and wavelet refuse the medium).
    fn small_viewer(method: MethodKind, scene: relight_render::Scene) -> Viewer {
        Viewer::new(scene, method, small_options()).unwrap()
    }

    fn mean(f: &Frame) -> f32 {
        f.image.pixels.iter().map(|p| p.element_sum()).sum::<f32>() / f.image.pixels.len() as f32
    }

    /// Summed absolute difference of two frames (also the light tests').
    pub(crate) fn diff(a: &Frame, b: &Frame) -> f32 {
        a.image
            .pixels
            .iter()
            .zip(&b.image.pixels)
            .map(|(p, q)| (*p - *q).abs().element_sum())
            .sum::<f32>()
    }

    #[test]
    fn every_method_draws_and_responds_to_camera_and_lighting() {
        let mut foggy = relight_scene::default_scene(64, 36);
        foggy.medium = Some(relight_render::Medium {
            beta: 0.04,
            albedo: 1.0,
            radius: 10.0,
        });
        foggy.point_lights.push(relight_render::PointLight::new(
            glam::Vec3::new(0.0, 2.5, 1.5),
            glam::Vec3::splat(8.0),
        ));
        for (method, scene) in [
            (MethodKind::Wavelet, relight_scene::default_scene(64, 36)),
            (MethodKind::Sh, relight_scene::default_scene(64, 36)),
            (MethodKind::Fog, foggy),
            (MethodKind::Triple, relight_scene::default_scene(64, 36)),
        ] {
            let mut v = small_viewer(method, scene);
            // A still view after dragging: its first antialiasing pass.
            v.frame(48, 27, true, &NoProgress).unwrap();
            let still = v.frame(48, 27, false, &NoProgress).unwrap();
            // No refusal; SH may warn that order 3 cannot hold a lobe.
            assert!(
                still
                    .message
                    .as_deref()
                    .is_none_or(|m| method == MethodKind::Sh && m.contains("cannot represent")),
                "{method}: {:?}",
                still.message
            );
            assert_eq!(
                (still.image.width, still.image.height, still.aa),
                (48, 27, 2)
            );
            let m0 = mean(&still);
            assert!(m0.is_finite() && m0 > 0.01, "{method}: mean {m0}");
            let preview = v.frame(48, 27, true, &NoProgress).unwrap();
            assert_eq!(preview.aa, 1);
            // Turning the lighting or the camera changes the picture; the
            // lighting turn re-bakes nothing (triple: a table lookup).
            let prepared = v.prepares();
            v.light_yaw_deg = 120.0;
            let lit = v.frame(48, 27, false, &NoProgress).unwrap();
            assert_eq!(v.prepares(), prepared, "{method}: a light turn prepared");
            v.orbit.rotate(90.0, 20.0);
            let turned = v.frame(48, 27, false, &NoProgress).unwrap();
            assert!(diff(&still, &lit) > 0.0, "{method}: lighting had no effect");
            assert!(diff(&lit, &turned) > 0.0, "{method}: camera had no effect");
            v.reset();
            let back = v.frame(48, 27, false, &NoProgress).unwrap();
            assert!(
                diff(&still, &back) < 1e-3 * diff(&still, &lit).max(1e-6),
                "{method}: reset"
            );
        }
    }

    /// The mean of the aa² offset passes is the aa × aa box-filtered frame
    /// the method renders in one go (wavelet: deterministic), up to the
    /// background's quadrature and float rounding.
    #[test]
    fn progressive_antialiasing_equals_the_direct_aa_frame() {
        let mut scene = relight_scene::default_scene(40, 24);
        // Without the floor (the last object): its far edge lies on the
        // environment's horizon, in half-covered pixels whose empty samples
        // take the environment per sample in one aa × aa frame but the
        // shared background's 4-corner quadrature in a pass — a difference
        // of background quadrature, not of the passes.
        scene.objects.pop();
        let mut v = small_viewer(MethodKind::Wavelet, scene.clone());
        v.frame(40, 24, true, &NoProgress).unwrap();
        let mut passes = 0;
        let mut last = v.frame(40, 24, false, &NoProgress).unwrap();
        while v.refining() {
            last = v.frame(40, 24, false, &NoProgress).unwrap();
            passes += 1;
            assert!(passes <= 4, "refines past aa² passes");
        }
        assert_eq!((last.aa, last.passes), (2, 4));
        // Refined: another still frame is the same image, without a pass.
        let again = v.frame(40, 24, false, &NoProgress).unwrap();
        assert_eq!(again.image.pixels, last.image.pixels);
        let opts = small_options().methods[0].clone();
        let mut m = relight_methods::create(&opts).unwrap();
        m.prepare(&scene, &NoProgress).unwrap();
        let request = relight_render::method::FrameRequest::new(v.camera(40, 24)).with_aa(2);
        let direct =
            relight_render::method::render_frame(m.as_mut(), &scene, &request, &NoProgress)
                .unwrap();
        let plain = relight_render::method::render_frame(
            m.as_mut(),
            &scene,
            &relight_render::method::FrameRequest::new(v.camera(40, 24)),
            &NoProgress,
        )
        .unwrap();
        let cov = direct.coverage.unwrap();
        // Relative RMS difference to the direct frame over fully covered
        // pixels (the same sample points either way; at this size triangles
        // are smaller than a pixel, so the rasterizer's 8 sub-pixel bits,
        // snapped at 1× instead of 2×, move barycentrics visibly), and over
        // edges and background (the background's quadrature differs).
        let rel = |img: &relight_render::Image, full: bool| {
            let (mut num, mut den) = (0.0f64, 0.0f64);
            for (i, (a, b)) in img.pixels.iter().zip(&direct.image.pixels).enumerate() {
                if (cov.coverage[i] >= 1.0) == full {
                    num += f64::from((*a - *b).length_squared());
                    den += f64::from(b.length_squared());
                }
            }
            assert!(den > 0.0);
            (num / den).sqrt()
        };
        let (obj, bg) = (rel(&last.image, true), rel(&last.image, false));
        assert!(obj < 1e-2, "objects: relative RMS {obj}");
        assert!(bg < 0.02, "edges and background: relative RMS {bg}");
        // … and much closer than one sample per pixel is.
        let (obj1, bg1) = (rel(&plain.image, true), rel(&plain.image, false));
        assert!(
            obj < 0.5 * obj1 && bg < 0.5 * bg1,
            "{obj} vs {obj1}, {bg} vs {bg1}"
        );
        // Moving the camera starts again.
        v.orbit.rotate(5.0, 0.0);
        assert!(v.refining());
        assert_eq!(v.frame(40, 24, false, &NoProgress).unwrap().passes, 1);
    }

    /// Issue 11: fog on a scene without lights or medium (the default
    /// scene) was a black frame. It draws the environment lighting (its
    /// environment part with no medium is plain SH shading).
    #[test]
    fn fog_without_lights_draws_the_environment_lighting() {
        let scene = relight_scene::default_scene(48, 27);
        assert!(scene.point_lights.is_empty() && scene.medium.is_none());
        let mut v = small_viewer(MethodKind::Fog, scene);
        v.frame(48, 27, true, &NoProgress).unwrap();
        let f = v.frame(48, 27, false, &NoProgress).unwrap();
        assert!(f.message.is_none(), "{:?}", f.message);
        // The knot fills the centre of the default view: lit, not black.
        let centre: f32 = (12..15)
            .flat_map(|y| (22..27).map(move |x| (x, y)))
            .map(|(x, y)| f.image.get(x, y).element_sum())
            .sum::<f32>()
            / 15.0;
        assert!(centre > 0.03, "knot radiance {centre}");
        assert!(mean(&f) > 0.01);
    }

    /// A right-drag that carries a point light into an object (the bench's
    /// fog scene turned 85°–90°: its fourth light is inside the third
    /// object) is a lighting the fog method refuses. The viewer said so by
    /// closing the window; it shows why on screen instead, and draws again
    /// once the light is out.
    #[test]
    fn a_lighting_the_method_refuses_is_shown_not_fatal() {
        let scene = bench::BenchScene::Fog4Lights.build(48, 27);
        let mut v = small_viewer(MethodKind::Fog, scene);
        let f = v.frame(48, 27, true, &NoProgress).unwrap();
        assert!(f.message.is_none(), "{:?}", f.message);
        let lit = mean(&f);
        // The frame at the home lighting: drawn, and the same as before.
        let draws_as_before = |v: &mut Viewer| {
            let back = v.frame(48, 27, true, &NoProgress).unwrap();
            assert!(back.message.is_none(), "{:?}", back.message);
            let m = mean(&back);
            assert!((m - lit).abs() <= 1e-6 * lit, "{m} vs {lit}");
        };
        let mut refused = 0;
        for step in 1..=24 {
            v.light_yaw_deg = 5.0 * step as f32;
            let f = v.frame(48, 27, true, &NoProgress).unwrap();
            if let Some(msg) = &f.message {
                assert!(f.refused && mean(&f) == 0.0);
                assert!(
                    msg.contains("fog") && msg.contains("point light 4") && msg.contains("inside"),
                    "{msg}"
                );
                assert!(msg.contains("turn the lighting"), "{msg}");
                refused += 1;
            }
        }
        assert!(refused > 0, "no pose put a light inside an object");
        v.light_yaw_deg = 0.0;
        draws_as_before(&mut v);

        // Prepared at a refused lighting (the method first shown there): the
        // same message, no bake retried while it stays, and a frame once
        // the light is out.
        let mut v = small_viewer(MethodKind::Fog, bench::BenchScene::Fog4Lights.build(48, 27));
        v.light_yaw_deg = 90.0;
        let f = v.frame(48, 27, true, &NoProgress).unwrap();
        let msg = f.message.expect("refused");
        assert!(
            msg.contains("point light 4") && msg.contains("turn the lighting"),
            "{msg}"
        );
        assert!(v.is_prepared(), "a refused lighting would prepare again");
        assert!(!v.refining());
        let prepares = v.prepares();
        v.frame(48, 27, true, &NoProgress).unwrap();
        assert_eq!(v.prepares(), prepares);
        v.light_yaw_deg = 0.0;
        assert!(!v.is_prepared());
        draws_as_before(&mut v);
    }

    /// A view the method refuses (fog: the eye zoomed out to more than 40
    /// mean free paths from the fog ball) is shown with its reason, not a
    /// closed window; zooming back in draws. Just outside the ball it draws.
    #[test]
    fn a_view_the_method_refuses_is_shown_not_fatal() {
        let mut v = small_viewer(MethodKind::Fog, bench::BenchScene::Fog4Lights.build(48, 27));
        let home = v.frame(48, 27, true, &NoProgress).unwrap();
        assert!(home.message.is_none(), "{:?}", home.message);
        v.orbit.zoom(-30.0, 0.0);
        assert!(v.orbit.eye().length() > 10.0, "outside the ball");
        let outside = v.frame(48, 27, true, &NoProgress).unwrap();
        assert!(
            outside.message.is_none() && !outside.refused && mean(&outside) > 0.0,
            "{:?}",
            outside.message
        );
        v.orbit.zoom(-60.0, 0.0);
        let out = v.frame(48, 27, true, &NoProgress).unwrap();
        let msg = out.message.clone().expect("refused");
        assert!(
            msg.contains("fog") && msg.contains("mean free paths"),
            "{msg}"
        );
        assert!(msg.contains("nothing is drawn at this view"), "{msg}");
        assert!(out.refused && mean(&out) == 0.0);
        // The window redraws while refining: an empty frame does not.
        assert!(!v.refining());
        v.orbit.zoom(90.0, 0.0);
        let back = v.frame(48, 27, true, &NoProgress).unwrap();
        assert!(
            back.message.is_none() && !back.refused,
            "{:?}",
            back.message
        );
        assert!(diff(&home, &back) <= 1e-3 * mean(&home) * 48.0 * 27.0);
    }

    /// The `s` key's screenshots skip the numbers an earlier session wrote.
    #[test]
    fn screenshots_do_not_overwrite_earlier_ones() {
        let dir = std::env::temp_dir().join(format!("relight-shots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("relight-view-1.png"), b"x").unwrap();
        std::fs::write(dir.join("relight-view-2.exr"), b"x").unwrap();
        let (n, stem) = state::free_shot_stem(&dir, 0);
        assert_eq!((n, stem), (3, dir.join("relight-view-3")));
        let f = Frame {
            image: relight_render::Image::new(4, 2),
            ms: 0.0,
            aa: 1,
            passes: 1,
            spp: 0,
            message: None,
            refused: false,
        };
        Viewer::save(&f, &dir.join("relight-view-3")).unwrap();
        assert_eq!(state::free_shot_stem(&dir, 3).0, 4);
        // An unwritable folder is an error (the window prints it and goes on).
        assert!(Viewer::save(&f, &dir.join("missing/relight-view-1")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_method_that_cannot_render_the_scene_says_why() {
        let mut scene = relight_scene::default_scene(32, 18);
        scene.point_lights.push(relight_render::PointLight::new(
            glam::Vec3::Y * 3.0,
            glam::Vec3::ONE,
        ));
        let mut v = small_viewer(MethodKind::Sh, scene);
        let f = v.frame(32, 18, false, &NoProgress).unwrap();
        let msg = f.message.expect("a refusal");
        assert!(msg.contains("sh") && msg.contains("point lights"), "{msg}");
    }

    #[test]
    fn the_reference_refines_while_still_and_restarts_on_change() {
        let mut v = small_viewer(MethodKind::Reference, relight_scene::default_scene(32, 18));
        let a = v.frame(32, 18, false, &NoProgress).unwrap();
        let b = v.frame(32, 18, false, &NoProgress).unwrap();
        assert_eq!((a.spp, b.spp), (4, 8));
        assert!(v.refining());
        assert!(mean(&b) > 0.01);
        v.orbit.rotate(10.0, 0.0);
        assert_eq!(v.frame(32, 18, false, &NoProgress).unwrap().spp, 4);
        // While dragging every frame is a new view: one pass each.
        v.orbit.rotate(10.0, 0.0);
        assert_eq!(v.frame(32, 18, true, &NoProgress).unwrap().spp, 4);
        // Refinement stops at the method's own spp.
        for _ in 0..20 {
            v.frame(32, 18, false, &NoProgress).unwrap();
        }
        assert!(!v.refining());
        assert_eq!(v.frame(32, 18, false, &NoProgress).unwrap().spp, 64);
    }

    /// The bench's rows at a tiny size with small settings: one per case,
    /// every timing present and finite, targets only where the issue sets
    /// them (not at this size), refinement of aa² passes.
    #[test]
    fn bench_frames_rows_have_the_issue_columns() {
        let mut opts = bench::FrameBenchOptions::with_sizes(&[(24, 14)], 1, 1, 1, small_method);
        // One case per method and scene (the SH variants differ by options only).
        opts.cases.retain(|c| {
            c.options.kind() != MethodKind::Sh || c.scene == bench::BenchScene::Default
        });
        for c in &mut opts.cases {
            if let MethodOptions::Sh(o) = &mut c.options {
                o.order = 3;
            }
            if let MethodOptions::Reference(r) = &mut c.options {
                r.spp = 8;
            }
        }
        let rows = bench::bench_frames(&opts, &NoProgress).unwrap();
        assert_eq!(rows.len(), opts.cases.len());
        let names: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
        for m in ["wavelet", "sh", "fog", "reference"] {
            assert!(names.contains(&m), "{names:?}");
        }
        for r in &rows {
            assert_eq!((r.width, r.height), (24, 14));
            // No refusal; SH may warn that order 3 cannot hold a lobe.
            assert!(
                r.note
                    .as_deref()
                    .is_none_or(|m| r.method == "sh" && m.contains("cannot represent")),
                "{}: {:?}",
                r.method,
                r.note
            );
            for (what, v) in [
                ("view", r.view_change_ms),
                ("light", r.light_change_ms),
                ("first still", r.first_still_ms),
                ("refined", r.refined_ms),
            ] {
                let v = v.unwrap_or(f64::NAN);
                assert!(v.is_finite() && v >= 0.0, "{} {what}: {v}", r.method);
            }
            assert!(r.refined_ms >= r.first_still_ms);
            assert_eq!((r.target, r.pass, r.source.as_deref()), (None, None, None));
            // The reference's preview frame before the still view is its
            // first pass already.
            let want = if r.method == "reference" { 1 } else { 4 };
            assert_eq!(r.passes, want, "{}", r.method);
        }
        let json = serde_json::to_value(&rows[0]).unwrap();
        for k in [
            "method",
            "width",
            "height",
            "view_change_ms",
            "light_change_ms",
            "first_still_ms",
            "refined_ms",
            "target",
            "pass",
            "source",
        ] {
            assert!(json.get(k).is_some(), "no {k} in {json}");
        }
    }

    /// The later methods' cases (issue 11: "Later methods … add their rows
    /// under their own issues' targets") on their quick scenes: a row each,
    /// drawn (no refusal), every timing finite, no target at these sizes;
    /// the full cases carry their own issue's target at its size.
    #[test]
    fn later_methods_have_rows_under_their_own_targets() {
        let opts = bench::FrameBenchOptions {
            cases: bench::later_cases(true, small_method),
            steps: 1,
            stills: 1,
            monte_carlo_steps: 1,
            aa: 2,
        };
        let rows = bench::bench_frames(&opts, &NoProgress).unwrap();
        let names: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
        assert_eq!(
            names,
            ["ndf", "ndf", "triple", "triple", "nearfield", "shexp"]
        );
        for r in &rows {
            assert!(r.note.is_none(), "{} {}: {:?}", r.method, r.case, r.note);
            for v in [
                r.view_change_ms,
                r.light_change_ms,
                r.first_still_ms,
                r.refined_ms,
            ] {
                let v = v.unwrap_or(f64::NAN);
                assert!(v.is_finite() && v >= 0.0, "{} {}: {v}", r.method, r.case);
            }
            assert_eq!((r.target, r.pass), (None, None), "{}", r.method);
        }
        // The methods that count their work do so for both columns; a
        // near-field light change propagates, on top of the view's resolve.
        for r in rows
            .iter()
            .filter(|r| matches!(r.method.as_str(), "triple" | "nearfield"))
        {
            let (v, l) = (r.work_fma.unwrap_or(0.0), r.light_work_fma.unwrap_or(0.0));
            assert!(v > 0.0 && l > 0.0, "{} {}: {v} / {l}", r.method, r.case);
            let f = r.light_machine_fraction.unwrap_or(f64::NAN);
            assert!(f.is_finite() && f > 0.0, "{}: {f}", r.method);
        }
        let near = rows.iter().find(|r| r.method == "nearfield").unwrap();
        assert!(near.light_work_fma > near.work_fma, "{near:?}");
        let full = bench::later_cases(false, MethodOptions::default_for);
        let want = [
            ("ndf", 512, 512, 1e3 / 60.0, "issue 14"),
            ("ndf", 512, 512, 1e3 / 25.0, "issue 14"),
            ("triple", 1024, 768, 1e3 / 12.0, "issue 12"),
            ("triple", 512, 384, 1e3 / 40.0, "issue 12"),
            ("triple", 1024, 768, 1e3 / 12.0, "issue 12"),
            ("triple", 512, 384, 1e3 / 40.0, "issue 12"),
            ("nearfield", 1200, 900, 1e3 / 38.71, "issue 13"),
            ("shexp", 960, 540, 1e3 / 30.0, "issue 15"),
        ];
        assert_eq!(full.len(), want.len());
        for (c, (name, w, h, ms, source)) in full.iter().zip(want) {
            assert_eq!(c.options.kind().name(), name);
            assert_eq!((c.width, c.height), (w, h), "{name}");
            let t = c.target_ms.unwrap_or(f64::NAN);
            assert!((t - ms).abs() < 1e-9, "{name}: target {t} ms, want {ms}");
            assert!(c.source.starts_with(source), "{name}: {}", c.source);
        }
    }

    #[test]
    fn display_words_are_tone_mapped_srgb() {
        let mut img = relight_render::Image::new(3, 1);
        img.pixels = vec![
            glam::Vec3::ZERO,
            glam::Vec3::new(100.0, 0.0, 0.0),
            glam::Vec3::splat(f32::NAN),
        ];
        let mut out = vec![0u32; 3];
        to_display(&img, &mut out);
        assert_eq!(out[0], 0);
        assert_eq!(out[1] >> 16, 255);
        assert_eq!(out[1] & 0xffff, 0);
    }

    /// The blocked, vectorised `to_display` gives every pixel of rows longer
    /// than a block (and a partial last block) the word of the per-channel
    /// formula: ACES, then sRGB to 8 bits, NaN and ±∞ included.
    #[test]
    fn display_words_match_the_per_channel_formula() {
        let (w, h) = (150, 3);
        let mut img = relight_render::Image::new(w, h);
        let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0, 0.0, 1e30];
        for (i, p) in img.pixels.iter_mut().enumerate() {
            let x = (i as f32 * 0.37).sin().abs() * 4.0;
            *p = glam::Vec3::new(x, specials[i % specials.len()], 0.01 * i as f32);
        }
        let mut out = vec![0u32; w * h];
        to_display(&img, &mut out);
        // The portable copy gives the same words as the AVX2 one (where the
        // CPU has it, `to_display` took that).
        let mut portable = vec![0u32; w * h];
        state::to_display_on(&img, &mut portable, false);
        assert_eq!(portable, out);
        if relight_isa::avx2() {
            let mut vector = vec![0u32; w * h];
            state::to_display_on(&img, &mut vector, true);
            assert_eq!(vector, out);
        } else if std::env::var_os("CI").is_some() {
            panic!("CI: this CPU lacks AVX2, so the AVX2 copy went untested");
        }
        let tone = relight_assets::ToneMap::default();
        let byte = |x: f32| {
            let y = tone.apply(x);
            let s = relight_assets::linear_to_srgb((y * 4095.0 + 0.5).floor() / 4095.0);
            (s * 255.0 + 0.5).clamp(0.0, 255.0) as u32
        };
        for (i, (p, &o)) in img.pixels.iter().zip(&out).enumerate() {
            let want = (byte(p.x) << 16) | (byte(p.y) << 8) | byte(p.z);
            assert_eq!(o, want, "pixel {i}: {p:?}");
        }
    }

    /// A floor under a sphere that slides 1 unit in x over 1 s, unshadowed.
    fn sliding_sphere() -> relight_render::Scene {
        let sphere =
            relight_geom::shapes::uv_sphere_at(glam::Vec3::new(-0.5, 0.6, 0.0), 0.4, 12, 8);
        let mut s = relight_shexp::verify_scene::floor_scene(
            vec![sphere],
            relight_shexp::verify_scene::sky(),
            12,
        );
        let key = |time: f32, x: f32| relight_render::Keyframe {
            time,
            translate: glam::Vec3::new(x, 0.0, 0.0),
            rotation: glam::Quat::IDENTITY,
            scale: 1.0,
        };
        s.objects[1].animation = Some(std::sync::Arc::new(
            relight_render::Animation::try_new(vec![key(0.0, 0.0), key(1.0, 1.0)]).unwrap(),
        ));
        s.camera.width = 48;
        s.camera.height = 32;
        // Unshadowed, so that sh (which cannot shadow) draws it too.
        s.visibility = false;
        s
    }

    #[test]
    fn the_clock_plays_for_a_method_that_follows_the_motion_and_waits_for_others() {
        let scene = sliding_sphere();
        let methods = vec![
            MethodOptions::ShExp(relight_shexp::ShExpOptions {
                spheres: 8,
                ..relight_shexp::ShExpOptions::default()
            }),
            MethodOptions::Sh(relight_shlight::ShOptions {
                order: 3,
                ..relight_shlight::ShOptions::default()
            }),
        ];
        let opts = || ViewerOptions {
            methods: methods.clone(),
            aa: 1,
            approximate: false,
        };
        // A static scene has no clock.
        let mut still =
            Viewer::new(relight_scene::default_scene(8, 8), MethodKind::Sh, opts()).unwrap();
        still.toggle_play();
        assert!(!still.playing());

        let mut v = Viewer::new(scene.clone(), MethodKind::ShExp, opts()).unwrap();
        let f0 = v.frame(48, 32, false, &NoProgress).unwrap();
        v.toggle_play();
        assert!(v.clock_runs());
        assert!(v.advance(0.6));
        assert!((v.time() - 0.6).abs() < 1e-6);
        assert!(
            v.is_prepared(),
            "shexp follows the motion without preparing again"
        );
        let f1 = v.frame(48, 32, false, &NoProgress).unwrap();
        assert!(diff(&f0, &f1) > 0.0, "the shadow moved");
        // The same frame as a viewer started at that time.
        let mut fresh = Viewer::new(scene.clone(), MethodKind::ShExp, opts()).unwrap();
        fresh.set_time(0.6);
        let g = fresh.frame(48, 32, false, &NoProgress).unwrap();
        assert!(
            diff(&f1, &g) <= 1e-3 * mean(&g) * 48.0 * 32.0,
            "{}",
            diff(&f1, &g)
        );
        // The clock loops over the keys.
        assert!(v.advance(0.6));
        assert!((v.time() - 0.2).abs() < 1e-5, "{}", v.time());

        // sh does not follow motion: it is prepared on the pose of the moment,
        // the clock waits, and the frame says why.
        v.select(1);
        let s1 = v.frame(48, 32, false, &NoProgress).unwrap();
        assert!(!v.clock_runs());
        assert!(!v.advance(0.5));
        assert!((v.time() - 0.2).abs() < 1e-5);
        let note = s1.message.clone().unwrap_or_default();
        assert!(note.contains("method sh cannot render animation"), "{note}");
        // After the clock moved elsewhere, sh prepares again at the new pose.
        v.toggle_play();
        v.set_time(0.9);
        assert!(!v.is_prepared());
        let s2 = v.frame(48, 32, false, &NoProgress).unwrap();
        assert!(v.is_prepared());
        assert!(s2.message.is_none(), "{:?}", s2.message);
        assert!(diff(&s1, &s2) > 0.0, "sh shows the sphere where it is now");
        // A lighting change keeps the pose (and sh's preparation).
        v.light_yaw_deg = 40.0;
        let s3 = v.frame(48, 32, false, &NoProgress).unwrap();
        assert!(diff(&s2, &s3) > 0.0, "the lighting turned");
    }

    #[test]
    fn bad_options_are_errors() {
        let scene = relight_scene::default_scene(8, 8);
        assert!(
            Viewer::new(
                scene.clone(),
                MethodKind::Sh,
                ViewerOptions {
                    aa: 0,
                    ..ViewerOptions::default()
                }
            )
            .is_err()
        );
        assert!(
            Viewer::new(
                scene.clone(),
                MethodKind::Sh,
                ViewerOptions {
                    methods: vec![MethodOptions::default_for(MethodKind::Fog)],
                    ..ViewerOptions::default()
                }
            )
            .is_err()
        );
        // A method the viewer does not show names the ones it does, and the
        // command that renders it.
        let e = Viewer::new(scene, MethodKind::RadianceCache, ViewerOptions::default())
            .err()
            .expect("not a viewer method")
            .to_string();
        assert!(
            e.contains("radiance-cache is not among the viewer's methods (wavelet, sh, fog")
                && e.contains("`relight render --method radiance-cache` renders it"),
            "{e}"
        );
    }
}
