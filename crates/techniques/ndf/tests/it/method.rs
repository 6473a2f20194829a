//! The method on the horizon plane: with a constant normal map every filter
//! must render what plain normal mapping renders.

use glam::Vec3;
use relight_ndf::verify::horizon_plane_scene;
use relight_ndf::{NdfBrdf, NdfFilter, NdfMethod, NdfOptions};
use relight_render::method::{FrameRequest, Relighter, Rendered, render_frame};
use relight_render::{NoProgress, NormalMap, Scene};

/// The ndf method's frame of `scene` with `brdf` under `filter`.
fn render_with(scene: &Scene, brdf: NdfBrdf, filter: NdfFilter) -> Rendered {
    let mut m = NdfMethod::new(NdfOptions {
        filter,
        brdf,
        ..NdfOptions::default()
    })
    .unwrap();
    m.prepare(scene, &NoProgress).unwrap();
    render_frame(&mut m, scene, &FrameRequest::new(scene.camera), &NoProgress).unwrap()
}

#[test]
fn constant_map_every_filter_matches_plain_normal_mapping() {
    let n0 = Vec3::new(0.3, 0.2, 0.93).normalize();
    let map = NormalMap::from_vectors(16, 16, &[n0; 256]).unwrap();
    for brdf in [NdfBrdf::Lambert, NdfBrdf::Blinn { s: 32.0 }] {
        let scene = horizon_plane_scene(&map, brdf, 48, 2.0);
        let render = |filter| render_with(&scene, brdf, filter);
        let truth = render(NdfFilter::None);
        let mask = truth.coverage.as_ref().unwrap().object_mask();
        assert!(truth.image.pixels.iter().any(|p| p.x > 0.0));
        for filter in NdfFilter::ALL {
            if filter == NdfFilter::Sh && brdf != NdfBrdf::Lambert {
                continue;
            }
            // LEAN shades a tilted normal's glossy lobe in tangent slope
            // space (narrower than about n0): checked at +Z below.
            if filter == NdfFilter::Lean && brdf != NdfBrdf::Lambert {
                continue;
            }
            let img = render(filter);
            let e = img.image.relative_rms_error(&truth.image, Some(&mask));
            let tol = 1e-3;
            assert!(e < tol, "{brdf:?} {filter:?}: {e}");
        }
    }
}

#[test]
fn lean_on_a_flat_map_renders_the_base_glossy_lobe() {
    let map = NormalMap::from_vectors(16, 16, &[Vec3::Z; 256]).unwrap();
    let brdf = NdfBrdf::Blinn { s: 32.0 };
    let scene = horizon_plane_scene(&map, brdf, 48, 2.0);
    let render = |filter| render_with(&scene, brdf, filter);
    let truth = render(NdfFilter::None);
    let mask = truth.coverage.as_ref().unwrap().object_mask();
    let e = render(NdfFilter::Lean)
        .image
        .relative_rms_error(&truth.image, Some(&mask));
    assert!(e < 1e-3, "LEAN on +Z: {e}");
}
