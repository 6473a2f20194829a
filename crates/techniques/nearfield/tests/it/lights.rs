//! Several area lights (topic `lights`): lights in one plane share one
//! transport, each plane gets its own, the result is the sum of the
//! lights' (exactly: each light is propagated on its own), edits keep the
//! bakes unless a light leaves its plane, and each plane's bake is cached.

use glam::Vec3;
use relight_nearfield::scenes::floor_and_sphere_three_lights;
use relight_nearfield::{NearfieldMethod, NearfieldOptions};
use relight_render::method::Relighter;
use relight_render::{NoProgress, Scene};

fn scene() -> Scene {
    floor_and_sphere_three_lights(8, 8, 32, 24, true)
}

fn method() -> NearfieldMethod {
    NearfieldMethod::new(NearfieldOptions {
        order: 16,
        ..NearfieldOptions::default()
    })
    .unwrap()
}

/// `scene` with only light `keep` on (the others at intensity 0).
fn only(scene: &Scene, keep: usize) -> Scene {
    let mut s = scene.clone();
    for (i, l) in s.area_lights.iter_mut().enumerate() {
        if i != keep {
            l.intensity = Vec3::ZERO;
        }
    }
    s
}

fn largest(colors: &[Vec<Vec3>]) -> f32 {
    colors
        .iter()
        .flatten()
        .map(|c| c.max_element())
        .fold(0.0, f32::max)
}

#[test]
fn lights_group_by_plane_and_add_up() {
    let s = scene();
    let mut m = method();
    m.prepare(&s, &NoProgress).unwrap();
    assert_eq!(
        m.planes(),
        2,
        "the ceiling pair shares a plane, the wall light has its own"
    );
    assert_eq!(m.bakes(), 1);
    let all = m.vertex_colors().to_vec();
    let top = largest(&all);
    assert!(top > 0.0);
    let mut sum: Vec<Vec<Vec3>> = all.iter().map(|o| vec![Vec3::ZERO; o.len()]).collect();
    for i in 0..s.area_lights.len() {
        m.set_lighting(&only(&s, i), &NoProgress).unwrap();
        let alone = m.vertex_colors();
        assert!(
            largest(alone) > 0.01 * top,
            "light {i} lights the scene on its own"
        );
        for (acc, c) in sum.iter_mut().zip(alone) {
            for (a, c) in acc.iter_mut().zip(c) {
                *a += *c;
            }
        }
    }
    assert_eq!(m.bakes(), 1, "an intensity edit keeps the bakes");
    let worst = all
        .iter()
        .flatten()
        .zip(sum.iter().flatten())
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0, f32::max);
    assert!(
        worst <= 1e-5 * top,
        "the sum of the lights: off by {worst} of {top}"
    );
}

#[test]
fn a_light_that_leaves_its_plane_rebakes() {
    let mut s = scene();
    let mut m = method();
    m.prepare(&s, &NoProgress).unwrap();
    // Moved in its plane and along its normal, and turned in it: kept.
    s.area_lights[2].center += Vec3::new(0.1, 0.2, -0.3);
    s.area_lights[1].world_from_light *= glam::Mat3::from_rotation_z(0.4);
    assert!(!m.lighting_rebakes(&s));
    m.set_lighting(&s, &NoProgress).unwrap();
    assert_eq!(m.bakes(), 1);
    // The wall light tilted: a new bake (it is still alone in its plane).
    s.area_lights[2].world_from_light *= glam::Mat3::from_rotation_x(0.3);
    assert!(m.lighting_rebakes(&s));
    m.set_lighting(&s, &NoProgress).unwrap();
    assert_eq!((m.bakes(), m.planes()), (2, 2));
    // One light fewer re-bakes; the second ceiling panel, lowered, is
    // then a plane of its own.
    s.area_lights[1].center.y -= 0.5;
    s.area_lights.remove(2);
    assert!(m.lighting_rebakes(&s));
    m.set_lighting(&s, &NoProgress).unwrap();
    assert_eq!((m.bakes(), m.planes()), (3, 2));
    // No light at all is an error naming the scene.
    s.area_lights.clear();
    let e = m.set_lighting(&s, &NoProgress).unwrap_err().to_string();
    assert!(e.contains("area_light"), "{e}");
}

#[test]
fn each_plane_is_cached_and_exported_to_its_own_file() {
    let d = std::env::temp_dir().join(format!("relight-nearfield-lights-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    let opts = NearfieldOptions {
        order: 16,
        cache_dir: Some(d.clone()),
        ..NearfieldOptions::default()
    };
    let s = scene();
    let mut a = NearfieldMethod::new(opts.clone()).unwrap();
    a.prepare(&s, &NoProgress).unwrap();
    let paths = a.cache_paths();
    assert_eq!(paths.len(), 2);
    assert!(paths.iter().all(|p| p.exists()), "{paths:?}");
    assert_ne!(paths[0], paths[1]);
    let mut b = NearfieldMethod::new(opts).unwrap();
    b.prepare(&s, &NoProgress).unwrap();
    assert_eq!((b.bakes(), b.loads()), (0, 1), "both planes load");
    assert_eq!(a.vertex_colors(), b.vertex_colors(), "bit for bit");
    // Exported one file per plane, each byte for byte its cache file.
    let written = a.save_bakes(&d.join("out.bin")).unwrap();
    assert_eq!(
        written,
        [d.join("out.plane1.bin"), d.join("out.plane2.bin")]
    );
    assert_eq!(
        relight_nearfield::method::plane_bake_path(std::path::Path::new("dir/out"), 2),
        std::path::Path::new("dir/out.plane3")
    );
    for (w, c) in written.iter().zip(&paths) {
        assert_eq!(
            std::fs::read(w).unwrap(),
            std::fs::read(c).unwrap(),
            "{w:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A glossy object under several lights: each plane gets its fixed-view
/// transport, and when the scene's camera moves every plane's is baked
/// again (the Lambertian floor's kept) — the same colours as a fresh
/// prepare from the new eye, bit for bit.
#[test]
fn a_camera_move_rebakes_every_planes_fixed_view() {
    let mut s = scene();
    s.objects[0].brdf = relight_nearfield::scenes::glossy_brdfs()[0].clone();
    let mut m = method();
    m.prepare(&s, &NoProgress).unwrap();
    assert_eq!((m.bakes(), m.planes()), (1, 2));
    s.camera.eye = Vec3::new(-2.0, 1.5, 2.5);
    assert!(m.lighting_rebakes(&s));
    m.set_lighting(&s, &NoProgress).unwrap();
    assert_eq!((m.bakes(), m.planes()), (2, 2));
    assert_eq!(m.baked_eye(), Some(s.camera.eye));
    let mut fresh = method();
    fresh.prepare(&s, &NoProgress).unwrap();
    assert_eq!(fresh.vertex_colors(), m.vertex_colors());
}

/// The parallel-rectangle integral behind the face-clipping warning
/// against midpoint quadrature, and the clipped share of a light that
/// fills the plane against the face's own Lambertian share
/// ([`relight_nearfield::face::lobe_fraction`]).
#[test]
fn the_clipped_share_matches_quadrature() {
    use relight_nearfield::face::{face_clipping, parallel_rect_integral};
    let quad = |x: [f64; 2], y: [f64; 2]| {
        let n = 600;
        let (hx, hy) = ((x[1] - x[0]) / n as f64, (y[1] - y[0]) / n as f64);
        let mut sum = 0.0;
        for j in 0..n {
            let v = y[0] + (j as f64 + 0.5) * hy;
            for i in 0..n {
                let u = x[0] + (i as f64 + 0.5) * hx;
                sum += (1.0 + u * u + v * v).powi(-2);
            }
        }
        sum * hx * hy
    };
    for (x, y) in [
        ([0.0, 1.0], [0.0, 2.0]),
        ([-0.7, 1.3], [-2.0, -0.4]),
        ([2.5, 5.5], [-0.3, 0.3]),
    ] {
        let (got, want) = (parallel_rect_integral(x, y), quad(x, y));
        assert!(
            (got / want - 1.0).abs() < 1e-5,
            "{x:?} × {y:?}: {got} vs {want}"
        );
    }
    // A light filling the plane (tiny s) centred on the vertex (o = ½ − s/2):
    // π in all, the face's Lambertian share of it kept.
    let s = 1e-4;
    let (all, kept) = face_clipping([s, s], [0.5 - 0.5 * s, 0.5 - 0.5 * s], 4.0);
    let want = relight_nearfield::face::lobe_fraction(4.0, 2000);
    assert!((all / std::f64::consts::PI - 1.0).abs() < 1e-3, "{all}");
    assert!((kept / all - want).abs() < 1e-3, "{} vs {want}", kept / all);
    // A light inside the face loses nothing.
    let (all, kept) = face_clipping([4.0, 4.0], [-1.5, -1.5], 4.0);
    assert!(all > 0.0 && kept == all, "{all} {kept}");
}

/// The wall light of the three-light scene falls past the face of the floor
/// vertices just in front of it, and the method says so (the ceiling light
/// does not; the small panel does, for a sphere vertex); the one-light
/// scene does not warn.
#[test]
fn light_past_the_face_is_a_warning() {
    let mut m = method();
    let three = scene();
    m.prepare(&three, &NoProgress).unwrap();
    let w = m.warnings().join("\n");
    assert!(w.contains("area light 3 falls past the face"), "{w}");
    assert!(!w.contains("area light 1 falls"), "{w}");
    // Moved back along its normal, away from the floor, the wall light
    // fits the faces: the warnings follow the lighting (no new bake).
    let mut moved = three.clone();
    let wall = &mut moved.area_lights[2];
    wall.center -= 2.0 * wall.normal();
    let bakes = m.bakes();
    m.set_lighting(&moved, &NoProgress).unwrap();
    assert_eq!(m.bakes(), bakes);
    let w = m.warnings().join("\n");
    assert!(!w.contains("area light 3 falls"), "{w}");
    let mut one = method();
    one.prepare(
        &relight_nearfield::scenes::floor_and_sphere(8, 8, 32, 24, true),
        &NoProgress,
    )
    .unwrap();
    let w = one.warnings().join("\n");
    assert!(!w.contains("falls past"), "{w}");
}

/// A light move draws the next frame over the kept visibility buffer (the
/// camera did not move): the same image, bit for bit, as a method whose
/// first frame rasterizes it afresh.
#[test]
fn a_light_move_shades_the_kept_visibility_buffer() {
    use relight_render::method::FrameRequest;
    let s = scene();
    let mut moved = s.clone();
    moved.area_lights[0].center.x += 0.2;
    let request = FrameRequest::new(s.camera);
    let mut kept = method();
    kept.prepare(&s, &NoProgress).unwrap();
    let before = kept.render(&s, &request, &NoProgress).unwrap();
    kept.set_lighting(&moved, &NoProgress).unwrap();
    let after = kept.render(&moved, &request, &NoProgress).unwrap();
    let mut fresh = method();
    fresh.prepare(&s, &NoProgress).unwrap();
    fresh.set_lighting(&moved, &NoProgress).unwrap();
    let want = fresh.render(&moved, &request, &NoProgress).unwrap();
    assert_ne!(
        before.image.pixels, after.image.pixels,
        "the move changed nothing"
    );
    assert_eq!(after.image.pixels, want.image.pixels);
    assert_eq!(after.coverage, want.coverage);
}
