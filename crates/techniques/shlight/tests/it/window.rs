//! The default window keeps SH shading non-negative: deringed GGX transfer
//! lobes at order 6 are non-negative on a dense grid, and a small default-
//! scene frame through the method interface has no negative pixel (while the
//! unwindowed one has some).

use glam::Vec3;
use relight_brdf::Ggx;
use relight_render::method::{FrameRequest, Relighter, render_frame};
use relight_render::{NoProgress, Scene};
use relight_sh::quadrature::SphereQuadrature;
use relight_sh::window::LobeSet;
use relight_shlight::{BakeOptions, BrdfShTable, ShMethod, ShOptions, WindowChoice};

#[test]
fn deringed_ggx_transfer_is_non_negative_at_order_6() {
    let order = 6;
    let ggx = Ggx::isotropic(0.2, Vec3::new(1.0, 0.78, 0.34)).unwrap();
    let bake = BakeOptions {
        theta_samples: 16,
        ..BakeOptions::default()
    };
    let table = BrdfShTable::bake(&ggx, order, &bake, 0, &NoProgress).unwrap();
    let lobes = table.lobes(order);
    let refs: Vec<&[f32]> = lobes.iter().map(Vec::as_slice).collect();
    let set = LobeSet::new(order, &refs).unwrap();
    let chosen = set.choose(WindowChoice::Auto);
    assert!(
        chosen.raw_min_ratio < -0.05,
        "GGX 0.2 rings at order 6: {}",
        chosen.raw_min_ratio
    );
    assert_eq!(chosen.applied, "dering");
    let fine = LobeSet::with_grid(order, &refs, &SphereQuadrature::new(192, 384)).unwrap();
    let m = fine.min_ratio(&chosen.factors);
    assert!(
        m >= -1e-3,
        "windowed GGX minimum {m} of the peak on the fine grid"
    );
}

fn negatives(scene: &Scene, window: WindowChoice) -> usize {
    // A coarser bake than the default keeps the test fast; the window is
    // chosen for whatever table is shaded.
    let mut m = ShMethod::new(ShOptions {
        window,
        bake: BakeOptions {
            theta_samples: 24,
            mu_nodes: 64,
            phi_nodes: 64,
        },
        ..ShOptions::default()
    })
    .unwrap();
    m.prepare(scene, &NoProgress).unwrap();
    let out = render_frame(&mut m, scene, &FrameRequest::new(scene.camera), &NoProgress).unwrap();
    out.image
        .pixels
        .iter()
        .filter(|p| p.min_element() < 0.0)
        .count()
}

#[test]
fn default_scene_sh_frame_has_no_negative_pixels() {
    let scene = relight_scene::default_scene(96, 54);
    assert_eq!(negatives(&scene, WindowChoice::Auto), 0);
    // The test can fail: without the window the same frame rings below zero.
    assert!(negatives(&scene, WindowChoice::None) > 0);
}

/// "Black pixels on SH normal-mapped silhouettes" (issue 11): at grazing
/// view angles the glossy transfer is at its sharpest and rang far below
/// zero (black once tone-mapped); with the window no pixel is negative,
/// normal-mapped silhouettes included.
#[test]
fn normal_mapped_silhouettes_are_not_negative() {
    let mut scene = relight_scene::default_scene(96, 54);
    let bumps = std::sync::Arc::new(relight_shlight::NormalMap::bumps(64, 6, 0.6));
    for o in &mut scene.objects {
        o.normal_map = Some(bumps.clone());
    }
    assert!(negatives(&scene, WindowChoice::None) > 0);
    assert_eq!(negatives(&scene, WindowChoice::Auto), 0);
}
