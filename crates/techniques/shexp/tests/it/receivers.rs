//! The SH area light ([`relight_shexp::area`]) and the visibility texture of
//! flat receivers ([`relight_shexp::texels`]) through the method.

use glam::Vec3;
use relight_render::method::{FrameRequest, Relighter};
use relight_render::{Animation, Image, Keyframe, NoProgress, Scene};
use relight_shexp::verify_scene::{ceiling_light, floor_scene, floor_spheres, sky};
use relight_shexp::{ShExpMethod, ShExpOptions};
use relight_sphere::EnvMap;
use std::sync::Arc;

fn colors(scene: &Scene, opts: ShExpOptions) -> Vec<Vec<Vec3>> {
    let mut m = ShExpMethod::new(opts).unwrap();
    m.prepare(scene, &NoProgress).unwrap();
    m.shade_vertices(scene).unwrap();
    m.vertex_colors().to_vec()
}

fn rel_rms(a: &[Vec3], b: &[Vec3]) -> f32 {
    let num: f32 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).length_squared())
        .sum();
    let den: f32 = b.iter().map(|y| y.length_squared()).sum();
    (num / den.max(1e-30)).sqrt()
}

const FAST: ShExpOptions = ShExpOptions {
    order: 4,
    exp: relight_shexp::ExpKind::PsStar(2),
    spheres: 32,
    cluster_vertices: 512,
    min_angle_deg: 1.0,
    lod_angle_deg: 7.0,
    bake_strata: 4,
    flat_receiver_vertices: 0,
    self_shadow: true,
    visibility_texture: 0,
};

/// A floor lit by the area light alone is shaded alike as a static receiver
/// (its `F` baked at the lighting change) and as a dynamic one (projected
/// per frame): both compute `F · g` by the same quadrature.
#[test]
fn static_and_dynamic_receivers_see_the_same_area_light() {
    let mut scene = floor_scene(floor_spheres(), EnvMap::black(), 12);
    scene.area_lights.push(ceiling_light());
    let fixed = colors(&scene, FAST);
    let still = Animation::try_new(vec![Keyframe {
        time: 0.0,
        translate: Vec3::ZERO,
        rotation: glam::Quat::IDENTITY,
        scale: 1.0,
    }])
    .unwrap();
    scene.objects[0].animation = Some(Arc::new(still));
    let moving = colors(&scene, FAST);
    let e = rel_rms(&moving[0], &fixed[0]);
    assert!(e < 1e-3, "floor static vs dynamic: {e}");
    assert!(fixed[0].iter().any(|c| c.max_element() > 0.05));
}

/// Moving the light re-projects the static receivers; moving it back gives
/// the first colours again; a light below the floor leaves it black.
#[test]
fn moving_the_area_light_relights_static_receivers() {
    let mut scene = floor_scene(floor_spheres(), EnvMap::black(), 10);
    scene.area_lights.push(ceiling_light());
    let mut m = ShExpMethod::new(FAST).unwrap();
    m.prepare(&scene, &NoProgress).unwrap();
    m.shade_vertices(&scene).unwrap();
    let first = m.vertex_colors()[0].clone();
    scene.area_lights[0].center.x += 1.5;
    m.set_lighting(&scene, &NoProgress).unwrap();
    m.shade_vertices(&scene).unwrap();
    let moved = m.vertex_colors()[0].clone();
    assert!(rel_rms(&moved, &first) > 0.05);
    scene.area_lights[0].center.x -= 1.5;
    m.set_lighting(&scene, &NoProgress).unwrap();
    m.shade_vertices(&scene).unwrap();
    assert!(rel_rms(&m.vertex_colors()[0], &first) < 1e-6);
    scene.area_lights[0].center.y = -1.0;
    m.set_lighting(&scene, &NoProgress).unwrap();
    m.shade_vertices(&scene).unwrap();
    assert!(m.vertex_colors()[0].iter().all(|c| *c == Vec3::ZERO));
    // A bad light is an error naming it, not a panic.
    scene.area_lights[0].size.x = f32::NAN;
    let e = m.set_lighting(&scene, &NoProgress).unwrap_err().to_string();
    assert!(e.contains("area_lights[0].size"), "{e}");
}

fn frame(scene: &Scene, opts: ShExpOptions) -> Image {
    let mut m = ShExpMethod::new(opts).unwrap();
    m.prepare(scene, &NoProgress).unwrap();
    m.render(scene, &FrameRequest::new(scene.camera), &NoProgress)
        .unwrap()
        .image
}

/// A two-triangle floor through a 96² visibility texture draws the image
/// the same floor refined to ≥ 9 K vertices draws, and its texels are the
/// receivers the method reports.
#[test]
fn visibility_texture_draws_what_refined_vertices_draw() {
    let scene = floor_scene(floor_spheres(), sky(), 1);
    // The default bake (12² rays per receiver): the static transfer's noise
    // differs between texels and vertices.
    let baked = ShExpOptions {
        bake_strata: ShExpOptions::default().bake_strata,
        ..FAST
    };
    let refined = frame(
        &scene,
        ShExpOptions {
            flat_receiver_vertices: 9000,
            ..baked
        },
    );
    let opts = ShExpOptions {
        visibility_texture: 96,
        ..baked
    };
    let texture = frame(&scene, opts);
    let e = rel_rms(&texture.pixels, &refined.pixels);
    assert!(e < 0.03, "texture vs refined floor: {e}");
    let mut m = ShExpMethod::new(opts).unwrap();
    m.prepare(&scene, &NoProgress).unwrap();
    m.shade_vertices(&scene).unwrap();
    assert_eq!(m.vertex_colors()[0].len(), 96 * 96);
    assert_eq!(m.receiver_points(0).unwrap().positions.len(), 96 * 96);
    assert!(
        ShExpMethod::new(ShExpOptions {
            visibility_texture: relight_shexp::method::MAX_VISIBILITY_TEXTURE + 1,
            ..FAST
        })
        .is_err()
    );
}

/// A moving flat receiver with a visibility texture carries its texture
/// along: the frame of a floor and its blocker moved by +1 in x equals the
/// first frame seen from a camera moved by +1 too (the shadow moves with
/// the floor).
#[test]
fn a_moving_textured_floor_carries_its_texture() {
    let mut scene = floor_scene(vec![floor_spheres().remove(1)], sky(), 1);
    let key = |x: f32, time: f32| Keyframe {
        time,
        translate: Vec3::new(x, 0.0, 0.0),
        rotation: glam::Quat::IDENTITY,
        scale: 1.0,
    };
    let slide = Arc::new(Animation::try_new(vec![key(0.0, 0.0), key(1.0, 1.0)]).unwrap());
    scene.objects[0].animation = Some(slide.clone());
    scene.objects[1].animation = Some(slide);
    let opts = ShExpOptions {
        visibility_texture: 32,
        ..FAST
    };
    let mut m = ShExpMethod::new(opts).unwrap();
    m.prepare(&scene, &NoProgress).unwrap();
    let at0 = m
        .render(&scene, &FrameRequest::new(scene.camera), &NoProgress)
        .unwrap()
        .image;
    let later = scene.at_time(1.0);
    let mut cam = scene.camera;
    cam.eye.x += 1.0;
    cam.target.x += 1.0;
    let at1 = m
        .render(&later, &FrameRequest::new(cam), &NoProgress)
        .unwrap()
        .image;
    let e = rel_rms(&at1.pixels, &at0.pixels);
    assert!(e < 0.02, "moved textured floor: {e}");
}

/// A dynamic torus turns its own shadow with it: shaded at a turned pose
/// after `prepare` at rest, it matches the same torus prepared at that pose
/// (both bakes see the same occluders; only their ray noise differs), and
/// both differ clearly from the unshadowed torus.
#[test]
fn self_shadow_turns_with_the_object() {
    let torus = relight_geom::shapes::torus(0.8, 0.3, 48, 24)
        .transformed(glam::Affine3A::from_translation(Vec3::new(0.0, 1.5, 0.0)));
    let turn = glam::Quat::from_rotation_x(1.1) * glam::Quat::from_rotation_z(0.4);
    let key = |time: f32, rotation: glam::Quat| Keyframe {
        time,
        translate: Vec3::ZERO,
        rotation,
        scale: 1.0,
    };
    let lambert = Arc::new(relight_brdf::Lambert::new(Vec3::splat(0.8)).unwrap());
    let mut o = relight_render::Object::new(Arc::new(torus), lambert);
    o.animation = Some(Arc::new(
        Animation::try_new(vec![key(0.0, glam::Quat::IDENTITY), key(1.0, turn)]).unwrap(),
    ));
    let mut scene = Scene::new(vec![o], sky(), floor_scene(Vec::new(), sky(), 1).camera);
    scene.visibility = true;
    let opts = ShExpOptions {
        bake_strata: 12,
        ..FAST
    };
    let mut m = ShExpMethod::new(opts).unwrap();
    m.prepare(&scene, &NoProgress).unwrap();
    let later = scene.at_time(1.0);
    m.shade_vertices(&later).unwrap();
    let moved = m.vertex_colors()[0].clone();
    // The same pose prepared directly (held still there).
    let mut posed = later.clone();
    posed.objects[0].animation = Some(Arc::new(
        Animation::try_new(vec![key(0.0, glam::Quat::IDENTITY)]).unwrap(),
    ));
    let direct = colors(&posed, opts);
    let unshadowed = colors(
        &posed,
        ShExpOptions {
            self_shadow: false,
            ..opts
        },
    );
    let e = rel_rms(&moved, &direct[0]);
    let gap = rel_rms(&unshadowed[0], &direct[0]);
    assert!(
        e < 0.02 && gap > 4.0 * e,
        "turned vs posed {e}, unshadowed vs posed {gap}"
    );
}

/// An environment change gives the colours of a method prepared for it,
/// whether it turns the map (the kept projection, turned in the SH domain)
/// or changes its texels (projected again).
#[test]
fn environment_changes_shade_as_a_fresh_prepare() {
    let scene = floor_scene(floor_spheres(), sky(), 10);
    let mut turned = scene.clone();
    turned.world_from_env = glam::Mat3::from_rotation_y(0.9);
    let mut other = turned.clone();
    for (i, t) in other.env.texels.iter_mut().enumerate() {
        *t *= Vec3::new(1.4, 1.0, 0.6 + (i % 5) as f32 * 0.1);
    }
    let mut m = ShExpMethod::new(FAST).unwrap();
    m.prepare(&scene, &NoProgress).unwrap();
    m.shade_vertices(&scene).unwrap();
    let first = m.vertex_colors()[0].clone();
    for (name, s) in [
        ("turned", &turned),
        ("other texels", &other),
        ("first", &scene),
    ] {
        m.set_lighting(s, &NoProgress).unwrap();
        m.shade_vertices(s).unwrap();
        let got = m.vertex_colors().to_vec();
        let want = colors(s, FAST);
        let differ: usize = (got.iter().zip(&want))
            .map(|(a, b)| a.iter().zip(b).filter(|(x, y)| x != y).count())
            .sum();
        assert_eq!(differ, 0, "{name}: vertex colours differ");
        if name != "first" {
            assert!(
                rel_rms(&got[0], &first) > 1e-3,
                "{name}: the lighting must matter"
            );
        }
    }
}
