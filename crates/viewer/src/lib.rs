//! `relight view`: an interactive window over the real-time methods.
//!
//! The viewer is where the papers' claims are felt rather than measured:
//! drag to orbit the camera (a *view change*: wavelet-rotation-2006 §3
//! step 2, per-vertex sparse dot products; the SH renderer's per-pixel
//! rotation; the fog model's per-pixel airlight), right-drag to turn the
//! lighting (a *lighting change*: the wavelet method's step 1, the SH
//! coefficients rotated, the fog lights moving), and switch methods on the
//! same scene with `1`–`3` — or `4` for the Monte Carlo reference, which
//! refines pass by pass while the view is still, to judge them against.
//!
//! Layout:
//! * [`orbit`]: the orbit camera (pure math, tested);
//! * [`state`]: [`Viewer`], which owns each method's precomputed data and
//!   draws a [`Frame`] for the current camera, lighting and method —
//!   headless, so tests and scripts can drive it;
//! * [`window`]: winit events → [`Viewer`], frames → a softbuffer surface.
//!   Only this module touches a display.
//!
//! While a mouse button is held frames are drawn without antialiasing
//! (preview); a still view is drawn with `aa × aa` samples per pixel.

pub mod orbit;
pub mod state;
pub mod window;

pub use orbit::Orbit;
pub use state::{Frame, ViewMethod, Viewer, ViewerError, ViewerOptions, to_display};
pub use window::run;

#[cfg(test)]
mod tests {
    use super::*;
    use relight_render::NoProgress;

    fn small_viewer(method: ViewMethod) -> Viewer {
        let cache =
            std::env::temp_dir().join(format!("relight-viewer-test-{}", std::process::id()));
        let opts = ViewerOptions {
            n: 16,
            ntess: 4,
            terms: 64,
            sh_order: 3,
            aa: 2,
            cache,
            ..ViewerOptions::default()
        };
        Viewer::new(relight_scene::default_scene(64, 36), method, opts).unwrap()
    }

    fn mean(f: &Frame) -> f32 {
        f.image.pixels.iter().map(|p| p.element_sum()).sum::<f32>() / f.image.pixels.len() as f32
    }

    #[test]
    fn every_method_draws_and_responds_to_camera_and_lighting() {
        for method in [ViewMethod::Wavelet, ViewMethod::Sh, ViewMethod::Fog] {
            let mut v = small_viewer(method);
            let still = v.frame(48, 27, false, &NoProgress).unwrap();
            assert_eq!(
                (still.image.width, still.image.height, still.aa),
                (48, 27, 2)
            );
            let m0 = mean(&still);
            assert!(m0.is_finite() && m0 > 0.01, "{method:?}: mean {m0}");
            let preview = v.frame(48, 27, true, &NoProgress).unwrap();
            assert_eq!(preview.aa, 1);
            // Turning the lighting or the camera changes the picture.
            v.light_yaw_deg = 120.0;
            let lit = v.frame(48, 27, false, &NoProgress).unwrap();
            v.orbit.rotate(90.0, 20.0);
            let turned = v.frame(48, 27, false, &NoProgress).unwrap();
            let diff = |a: &Frame, b: &Frame| {
                a.image
                    .pixels
                    .iter()
                    .zip(&b.image.pixels)
                    .map(|(p, q)| (*p - *q).abs().element_sum())
                    .sum::<f32>()
            };
            assert!(
                diff(&still, &lit) > 0.0,
                "{method:?}: lighting had no effect"
            );
            assert!(
                diff(&lit, &turned) > 0.0,
                "{method:?}: camera had no effect"
            );
            v.reset();
            let back = v.frame(48, 27, false, &NoProgress).unwrap();
            assert!(
                diff(&still, &back) < 1e-3 * diff(&still, &lit).max(1e-6),
                "{method:?}: reset"
            );
        }
    }

    #[test]
    fn the_reference_refines_while_still_and_restarts_on_change() {
        let mut v = small_viewer(ViewMethod::Reference);
        let a = v.frame(32, 18, false, &NoProgress).unwrap();
        let b = v.frame(32, 18, false, &NoProgress).unwrap();
        assert_eq!((a.spp, b.spp), (4, 8));
        assert!(v.refining());
        assert!(mean(&b) > 0.01);
        v.orbit.rotate(10.0, 0.0);
        assert_eq!(v.frame(32, 18, false, &NoProgress).unwrap().spp, 4);
        assert_eq!(v.frame(32, 18, true, &NoProgress).unwrap().spp, 1);
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

    #[test]
    fn bad_options_are_errors() {
        let scene = relight_scene::default_scene(8, 8);
        let bad = |o: ViewerOptions| Viewer::new(scene.clone(), ViewMethod::Sh, o).is_err();
        assert!(bad(ViewerOptions {
            aa: 0,
            ..ViewerOptions::default()
        }));
        assert!(bad(ViewerOptions {
            beta: -1.0,
            ..ViewerOptions::default()
        }));
        assert!(bad(ViewerOptions {
            n: 48,
            ..ViewerOptions::default()
        }));
        assert!(bad(ViewerOptions {
            sh_order: 0,
            ..ViewerOptions::default()
        }));
    }
}
