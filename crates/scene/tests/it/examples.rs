//! Every file in `examples/` loads, and loads into what it says.

use crate::common;

use common::{examples_dir, shared_data_present};
use glam::Vec3;
use relight_scene::{LoadedScene, load_scene_file, rotation_from_yaw_pitch_roll};

/// Loads an example at a small size; `None` when it needs the shared data
/// and that is absent (outside CI).
fn load(name: &str) -> Option<LoadedScene> {
    let path = examples_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    if text.contains("../../shared/data") && !shared_data_present(name) {
        return None;
    }
    Some(load_scene_file(&path, Some((32, 18))).unwrap_or_else(|e| panic!("{e}")))
}

#[test]
fn every_example_loads() {
    let mut names: Vec<String> = std::fs::read_dir(examples_dir())
        .unwrap()
        .filter_map(|e| {
            let n = e.unwrap().file_name().into_string().unwrap();
            n.ends_with(".toml").then_some(n)
        })
        .collect();
    names.sort();
    for expected in [
        "animated.toml",
        "area-light.toml",
        "foggy-lights.toml",
        "normal-map.toml",
        "park-bunny.toml",
        "studio-spheres.toml",
        "svbrdf.toml",
    ] {
        assert!(names.iter().any(|n| n == expected), "{expected} missing");
    }
    for n in &names {
        if let Some(l) = load(n) {
            assert!(!l.scene.objects.is_empty(), "{n}");
            assert_eq!((l.scene.camera.width, l.scene.camera.height), (32, 18));
        }
    }
}

#[test]
fn foggy_lights_has_a_medium_and_two_point_lights() {
    let s = load("foggy-lights.toml").unwrap().scene;
    let m = s.medium.expect("medium");
    assert_eq!((m.beta, m.albedo, m.radius), (0.08, 1.0, 10.0));
    assert_eq!(s.point_lights.len(), 2);
    assert_eq!(s.point_lights[0].intensity, Vec3::splat(10.0));
    // intensity 6 × colour [1, 0.75, 0.5].
    assert_eq!(s.point_lights[1].intensity, Vec3::new(6.0, 4.5, 3.0));
    assert!(!s.has_environment(), "black environment");
}

#[test]
fn area_light_example_orients_both_lights() {
    let s = load("area-light.toml").unwrap().scene;
    assert!(s.visibility);
    assert_eq!(s.area_lights.len(), 2);
    let (a, b) = (&s.area_lights[0], &s.area_lights[1]);
    assert!((a.normal() - Vec3::NEG_Y).length() < 1e-6, "{}", a.normal());
    assert!((b.normal() - Vec3::X).length() < 1e-6, "{}", b.normal());
    assert!((a.area() - 1.5).abs() < 1e-6);
    // The floor point under the ceiling panel sees its emitting side.
    let (t, _) = a.intersect(Vec3::ZERO, Vec3::Y, 0.0).unwrap();
    assert!((t - 2.5).abs() < 1e-5);
}

#[test]
fn animated_example_moves_the_sphere_through_the_origin() {
    let s = load("animated.toml").unwrap().scene;
    assert!(s.is_animated());
    let centre = |s: &relight_render::Scene, i: usize| {
        let b = s.objects[i].mesh.bounds().unwrap();
        b.center()
    };
    // Keys: x = −1.5 at t = 0, +1.5 at t = 2, on top of the placement (0, 0.4, 0).
    for (t, x) in [(0.0, -1.5), (1.0, 0.0), (2.0, 1.5), (3.0, 0.0), (9.0, -1.5)] {
        let c = centre(&s.at_time(t), 1);
        assert!((c - Vec3::new(x, 0.4, 0.0)).length() < 1e-3, "t = {t}: {c}");
    }
    // The knot spins about its own centre, positioned by the keys.
    let c0 = centre(&s.at_time(0.0), 2);
    let c4 = centre(&s.at_time(4.0), 2);
    assert!((c0 - c4).length() < 0.1, "{c0} vs {c4}");
}

#[test]
fn park_bunny_rotates_the_environment_without_resampling() {
    let Some(l) = load("park-bunny.toml") else {
        return;
    };
    let s = l.scene;
    let r = rotation_from_yaw_pitch_roll([90.0, 0.0, 0.0]);
    assert!(s.world_from_env.abs_diff_eq(r, 1e-6));
    let (raw, _) =
        relight_assets::load_env_map(&examples_dir().join("../../shared/data/hdri/park.exr"))
            .unwrap();
    assert_eq!(s.env.texels, raw.texels, "the map is stored as read");
    assert!(s.visibility);
}

#[test]
fn normal_map_and_svbrdf_examples_carry_their_textures() {
    if let Some(l) = load("normal-map.toml") {
        for o in &l.scene.objects {
            let m = o.normal_map.as_ref().expect("normal map");
            assert_eq!((m.width, m.height), (512, 512));
            assert_eq!(o.mesh.tangents.len(), o.mesh.positions.len());
        }
    }
    if let Some(l) = load("svbrdf.toml") {
        let b = l.scene.objects[0].blend.as_ref().expect("blend");
        let (lo, hi) = b
            .weight
            .texels
            .iter()
            .fold((1.0f32, 0.0f32), |(lo, hi), t| (lo.min(t.x), hi.max(t.x)));
        assert!(hi - lo > 0.3, "the weight varies over uv: [{lo}, {hi}]");
    }
}

#[test]
fn studio_spheres_matches_its_file() {
    let s = load("studio-spheres.toml").unwrap().scene;
    assert_eq!(s.objects.len(), 3);
    assert_eq!(s.camera.vfov_deg, 38.0);
    assert_eq!(s.world_from_env, glam::Mat3::IDENTITY);
    assert!(!s.visibility && s.medium.is_none() && s.point_lights.is_empty());
}

/// The complete example in docs/scene-format.md loads, as if it sat in
/// `examples/`.
#[test]
fn the_documented_complete_example_loads() {
    let doc = std::fs::read_to_string(examples_dir().join("../docs/scene-format.md")).unwrap();
    let start = doc.rfind("```toml\n").expect("a toml block") + "```toml\n".len();
    let text = &doc[start..start + doc[start..].find("```").unwrap()];
    if !shared_data_present("the documented example") {
        return;
    }
    let l = relight_scene::load_scene_text(text, &examples_dir().join("doc.toml"), None)
        .unwrap_or_else(|e| panic!("{e}"));
    let s = l.scene;
    assert_eq!(s.objects.len(), 2);
    assert!(s.objects[1].normal_map.is_some() && s.objects[1].blend.is_some());
    assert!(s.objects[1].animation.is_some());
    assert_eq!(s.point_lights.len(), 1);
    assert_eq!(s.area_lights.len(), 1);
    assert!(s.area_lights[0].texture.is_some());
    assert_eq!(s.medium.unwrap().albedo, 0.9);
    assert!(s.visibility);
}
