//! The `shexp` method against ray-traced visibility, and its interface.

use relight_render::method::{FrameRequest, MethodError, Relighter, SceneFeature, render_frame};
use relight_render::{NoProgress, PointLight};
use relight_shexp::verify_scene::{floor_scene, floor_spheres, sky, verify_scene};
use relight_shexp::{ExpKind, ShExpMethod, ShExpOptions};

#[test]
fn spheres_on_a_floor_and_ao_meet_their_targets() {
    let rows = verify_scene(24, None).unwrap();
    let mut gated = 0;
    for r in &rows {
        eprintln!("{} | {} | {} | {:?}", r.check, r.measured, r.target, r.pass);
        // Report rows (curves) carry no target.
        if r.pass.is_some() {
            assert_eq!(r.pass, Some(true), "{r:?}");
            gated += 1;
        }
    }
    // Floor, AO, self-shadowing, visibility texture, three area-light rows,
    // the small sun.
    assert_eq!(gated, 8, "{rows:?}");
}

#[test]
fn renders_through_the_interface_and_refuses_what_it_cannot() {
    let mut scene = floor_scene(floor_spheres(), sky(), 8);
    // The 8 × 8 floor is refined to a denser receiver for drawing.
    let opts = ShExpOptions {
        bake_strata: 4,
        flat_receiver_vertices: 2000,
        ..ShExpOptions::default()
    };
    let mut m = ShExpMethod::new(opts).unwrap();
    m.prepare(&scene, &NoProgress).unwrap();
    let out = render_frame(
        &mut m,
        &scene,
        &FrameRequest::new(scene.camera),
        &NoProgress,
    )
    .unwrap();
    assert_eq!(out.image.width, 96);
    let mean: f32 =
        out.image.pixels.iter().map(|p| p.x).sum::<f32>() / out.image.pixels.len() as f32;
    assert!(mean.is_finite() && mean > 0.0);
    assert!(
        m.vertex_colors()[0].len() >= 2000,
        "floor refined: {}",
        m.vertex_colors()[0].len()
    );
    let h = m.take_histogram();
    assert!(h.counts.iter().sum::<u64>() > 0, "{h:?}");
    scene
        .point_lights
        .push(PointLight::new(glam::Vec3::Y, glam::Vec3::ONE));
    let e = m.prepare(&scene, &NoProgress).unwrap_err();
    assert!(
        matches!(
            e,
            MethodError::Unsupported {
                method: "shexp",
                feature: SceneFeature::PointLights,
                ..
            }
        ),
        "{e}"
    );
    assert!(
        ShExpMethod::new(ShExpOptions {
            order: 1,
            ..ShExpOptions::default()
        })
        .is_err()
    );
}

#[test]
fn blockers_follow_the_animation_and_product_space_agrees() {
    let mut scene = floor_scene(floor_spheres(), sky(), 16);
    // Slide sphere 1 by +1 in x over a second.
    let keys = vec![
        relight_render::Keyframe {
            time: 0.0,
            translate: glam::Vec3::ZERO,
            rotation: glam::Quat::IDENTITY,
            scale: 1.0,
        },
        relight_render::Keyframe {
            time: 1.0,
            translate: glam::Vec3::new(1.0, 0.0, 0.0),
            rotation: glam::Quat::IDENTITY,
            scale: 1.0,
        },
    ];
    scene.objects[1].animation = Some(std::sync::Arc::new(
        relight_render::Animation::try_new(keys).unwrap(),
    ));
    let dense = ShExpOptions {
        flat_receiver_vertices: 0,
        ..ShExpOptions::default()
    };
    let mut m = ShExpMethod::new(dense).unwrap();
    m.prepare(&scene, &NoProgress).unwrap();
    m.shade_vertices(&scene.at_time(0.0)).unwrap();
    let a = m.vertex_colors()[0].clone();
    m.shade_vertices(&scene.at_time(1.0)).unwrap();
    let b = m.vertex_colors()[0].clone();
    // Moving the blocker moved its shadow: the frames differ, and the floor
    // under the sphere's new place is darker than before.
    let floor = &scene.objects[0].mesh;
    let near = |x: f32, z: f32| {
        floor
            .positions
            .iter()
            .enumerate()
            .min_by(|(_, p), (_, q)| {
                ((p.x - x).powi(2) + (p.z - z).powi(2))
                    .total_cmp(&((q.x - x).powi(2) + (q.z - z).powi(2)))
            })
            .unwrap()
            .0
    };
    let v = near(-0.9 + 1.0, 0.0);
    assert!(
        b[v].x < a[v].x,
        "shadow moved under the sphere: {} → {}",
        a[v].x,
        b[v].x
    );
    // Product accumulation gives nearly the same floor.
    let mut p = ShExpMethod::new(ShExpOptions {
        exp: ExpKind::Product,
        ..ShExpOptions::default()
    })
    .unwrap();
    p.prepare(&scene, &NoProgress).unwrap();
    p.shade_vertices(&scene.at_time(1.0)).unwrap();
    let c = &p.vertex_colors()[0];
    let num: f32 = b
        .iter()
        .zip(c)
        .map(|(x, y)| (*x - *y).length_squared())
        .sum();
    let den: f32 = c.iter().map(|y| y.length_squared()).sum();
    assert!(
        (num / den).sqrt() < 0.05,
        "log vs product floor {}",
        (num / den).sqrt()
    );
}

/// §5.2.4's cluster culling and LOD change the bench scenes' shading by at
/// most `CULLING_RMS_TARGET` against every leaf sphere (and do drop pairs).
#[test]
fn culling_and_lod_stay_close_to_every_leaf_sphere() {
    let checks = relight_shexp::bench::culling_checks().expect("culling checks");
    assert_eq!(checks.len(), 2);
    for c in checks {
        assert!(
            c.rms <= relight_shexp::bench::CULLING_RMS_TARGET,
            "{}: relative RMS {}",
            c.scene,
            c.rms
        );
        assert!(
            c.kept < 0.9,
            "{}: culling kept {} of the pairs",
            c.scene,
            c.kept
        );
        assert_eq!(c.row().pass, Some(true));
    }
}
