//! `ShMethod` through the method interface: the same image as the direct
//! `ShRenderer::render`, lighting rotation in the SH domain, feature checks,
//! bake reuse, errors. Small images (64×48).

use glam::{Mat3, Vec3};
use relight_brdf::{Brdf, Ggx, Lambert};
use relight_geom::shapes;
use relight_render::method::{
    FrameRequest, MethodError, Relighter, Rendered, SceneFeature, background_pixel, check_scene,
    render_frame,
};
use relight_render::{
    Camera, Image, Medium, NoProgress, NormalMap, Object, PointLight, Progress, Scene,
};
use relight_shlight::{ShMethod, ShOptions, ShRenderer, ShRotationMethod};
use relight_sphere::{EnvMap, Param};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

const W: usize = 64;
const H: usize = 48;

fn camera() -> Camera {
    Camera {
        eye: Vec3::new(0.0, 0.4, 3.2),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
        width: W,
        height: H,
        image_offset: glam::Vec2::ZERO,
    }
}

/// An all-frequency sky: a bright warm lobe and a cool gradient (as in
/// `tests/render.rs`).
fn sky_env() -> EnvMap {
    let sun = Vec3::new(0.5, 0.7, 0.4).normalize();
    EnvMap::from_fn(
        Param::LatLong {
            width: 128,
            height: 64,
        },
        move |d| {
            let lobe = d.dot(sun).max(0.0).powi(8) * 6.0;
            Vec3::new(0.3 + lobe, 0.35 + 0.8 * lobe, 0.5 + 0.3 * d.y.max(0.0))
                + Vec3::splat(0.2 * d.x.max(0.0))
        },
    )
}

fn ggx() -> Arc<dyn Brdf> {
    Arc::new(Ggx::isotropic(0.4, Vec3::ONE).unwrap())
}

fn sphere(center: Vec3, radius: f32) -> Arc<relight_geom::Mesh> {
    Arc::new(shapes::uv_sphere_at(center, radius, 48, 24))
}

/// Two spheres apart on screen: the left one normal-mapped (GGX), the right
/// one plain (Lambert).
fn two_sphere_scene(nm: &Arc<NormalMap>) -> Scene {
    let mut left = Object::new(sphere(Vec3::new(-0.75, 0.0, 0.0), 0.6), ggx());
    left.normal_map = Some(nm.clone());
    let right = Object::new(
        sphere(Vec3::new(0.75, 0.0, 0.0), 0.6),
        Arc::new(Lambert::new(Vec3::splat(0.8)).unwrap()),
    );
    Scene::new(vec![left, right], sky_env(), camera())
}

fn frame(method: &mut ShMethod, scene: &Scene, aa: usize) -> Rendered {
    render_frame(
        method,
        scene,
        &FrameRequest::new(scene.camera).with_aa(aa),
        &NoProgress,
    )
    .unwrap()
}

fn prepared(scene: &Scene) -> ShMethod {
    let mut m = ShMethod::new(ShOptions::default()).unwrap();
    m.prepare(scene, &NoProgress).unwrap();
    m
}

/// Largest |a − b| relative to max(1, |b|) over pixels where `keep`.
fn max_rel_diff(a: &Image, b: &Image, keep: impl Fn(usize) -> bool) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .enumerate()
        .filter(|(i, _)| keep(*i))
        .map(|(_, (p, q))| (*p - *q).abs().max_element() / q.abs().max_element().max(1.0))
        .fold(0.0, f32::max)
}

/// Relative RMS of `a` against `b` over pixels where `keep`.
fn rel_rms(a: &Image, b: &Image, keep: impl Fn(usize) -> bool) -> f64 {
    let (mut n, mut d) = (0.0f64, 0.0f64);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        if keep(i) {
            n += f64::from((*p - *q).length_squared());
            d += f64::from(q.length_squared());
        }
    }
    (n / d).sqrt()
}

#[test]
fn render_frame_matches_the_direct_renderer_with_per_object_normal_maps() {
    let nm = Arc::new(NormalMap::bumps(256, 8, 0.6));
    let scene = two_sphere_scene(&nm);
    let aa = 2;
    let mut method = prepared(&scene);
    let got = frame(&mut method, &scene, aa);
    let cov = got.coverage.as_deref().unwrap();
    // The direct call applies one normal map to every object: with the map
    // it is right for object 1, without it for object 2.
    let direct = |map: Option<&NormalMap>| {
        ShRenderer::new(6, ShRotationMethod::Exact)
            .unwrap()
            .with_supersampling(aa)
            .render(&scene, map, &NoProgress)
            .unwrap()
    };
    let with_nm = direct(Some(&nm));
    let without = direct(None);
    let on = |id: u32| move |i: usize| cov.coverage[i] > 0.0 && cov.object_id[i] == id;
    let (n1, n2) = (
        (0..W * H).filter(|&i| on(1)(i)).count(),
        (0..W * H).filter(|&i| on(2)(i)).count(),
    );
    assert!(n1 > 300 && n2 > 300, "both spheres seen: {n1}, {n2} pixels");
    let d1 = max_rel_diff(&got.image, &with_nm.image, on(1));
    let d2 = max_rel_diff(&got.image, &without.image, on(2));
    assert!(d1 <= 1e-5, "normal-mapped object vs direct: {d1}");
    assert!(d2 <= 1e-5, "plain object vs direct: {d2}");
    // The map matters on object 1 and would on object 2.
    assert!(max_rel_diff(&got.image, &without.image, on(1)) > 1e-2);
    assert!(max_rel_diff(&got.image, &with_nm.image, on(2)) > 1e-2);
    // Coverage: fully covered pixels are the direct mask.
    for (i, &m) in with_nm.mask.iter().enumerate() {
        assert_eq!(m, cov.coverage[i] >= 1.0, "pixel {i}");
    }
    // Background pixels are the one shared background.
    let rays = scene.camera.ray_frame();
    for y in 0..H {
        for x in 0..W {
            let i = y * W + x;
            if cov.coverage[i] <= 0.0 {
                let want = background_pixel(&scene, &rays, x, y);
                assert!((got.image.pixels[i] - want).abs().max_element() <= 1e-6);
            }
        }
    }
    assert_eq!(method.tables().len(), 2);
    let bytes: usize = method.tables().iter().map(|t| t.coeffs().len() * 4).sum();
    assert_eq!(method.data_bytes(), bytes as u64);
}

#[test]
fn set_lighting_rotates_the_lighting_exactly_in_the_sh_domain() {
    let scene = Scene::new(
        vec![Object::new(sphere(Vec3::ZERO, 1.0), ggx())],
        sky_env(),
        camera(),
    );
    let r = Mat3::from_euler(glam::EulerRot::YXZ, 1.1, 0.4, -0.3);
    let mut rotated = scene.clone();
    rotated.world_from_env = r;
    let mut resampled = scene.clone();
    resampled.env = scene.env.rotated(r, 4);

    // A lighting change on a prepared method: set_lighting only.
    let mut method = prepared(&scene);
    let unrotated = frame(&mut method, &scene, 1);
    let ms = method.set_lighting(&rotated, &NoProgress).unwrap();
    assert!(ms > 0.0);
    let got = frame(&mut method, &rotated, 1);
    assert!(
        (got.timings.lighting_ms - ms).abs() < 1e-9,
        "the frame reports the lighting change"
    );
    assert_eq!(frame(&mut method, &rotated, 1).timings.lighting_ms, 0.0);
    // Same as preparing with the rotation, and as the direct renderer's
    // SH-domain rotation.
    let fresh = frame(&mut prepared(&rotated), &rotated, 1);
    let direct = ShRenderer::new(6, ShRotationMethod::Exact)
        .unwrap()
        .with_lighting_rotation(r)
        .unwrap()
        .render(&scene, None, &NoProgress)
        .unwrap();
    let cov = got.coverage.as_deref().unwrap();
    let obj = |i: usize| cov.coverage[i] > 0.0;
    assert!(max_rel_diff(&got.image, &fresh.image, obj) <= 1e-5);
    assert!(max_rel_diff(&got.image, &direct.image, obj) <= 1e-5);
    // Against rendering the resampled map (tolerance of
    // `lighting_rotation_in_sh_matches_a_rotated_map`).
    let want = frame(&mut prepared(&resampled), &resampled, 1);
    let full = |i: usize| cov.coverage[i] >= 1.0;
    let e = rel_rms(&got.image, &want.image, full);
    assert!(e < 0.02, "SH-domain rotation vs resampled map: {e}");
    assert!(
        rel_rms(&unrotated.image, &want.image, full) > 10.0 * e,
        "the rotation must matter"
    );
    // Not a rotation: a typed error naming the option.
    let mut bad = rotated.clone();
    bad.world_from_env = Mat3::from_diagonal(Vec3::new(1.0, 1.0, -1.0));
    match method.set_lighting(&bad, &NoProgress) {
        Err(MethodError::InvalidOption { method, option, .. }) => {
            assert_eq!((method, option), ("sh", "world_from_env"));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn check_scene_refuses_what_sh_does_not_render() {
    let nm = Arc::new(NormalMap::bumps(64, 4, 0.5));
    let scene = two_sphere_scene(&nm);
    let method = ShMethod::new(ShOptions::default()).unwrap();
    assert!(check_scene(&method, &scene, false).unwrap().is_empty());
    let mut lit = scene.clone();
    lit.point_lights
        .push(PointLight::new(Vec3::new(0.0, 2.0, 0.0), Vec3::ONE));
    let mut foggy = scene.clone();
    foggy.medium = Some(Medium {
        beta: 0.1,
        albedo: 1.0,
        radius: 10.0,
    });
    let mut shadowed = scene.clone();
    shadowed.visibility = true;
    for (s, want) in [
        (&lit, SceneFeature::PointLights),
        (&foggy, SceneFeature::Medium),
        (&shadowed, SceneFeature::Visibility),
    ] {
        let err = check_scene(&method, s, true).unwrap_err();
        match &err {
            MethodError::Unsupported {
                method,
                feature,
                approximate,
            } => {
                assert_eq!((*method, *feature, *approximate), ("sh", want, None));
            }
            other => panic!("{other:?}"),
        }
        let text = err.to_string();
        assert!(
            text.contains("sh") && text.contains(want.describe()),
            "{text}"
        );
        // prepare refuses it too rather than dropping it.
        let mut m = ShMethod::new(ShOptions::default()).unwrap();
        assert!(matches!(
            m.prepare(s, &NoProgress),
            Err(MethodError::Unsupported { .. })
        ));
    }
}

/// Records the phases started.
#[derive(Default)]
struct Phases {
    started: Mutex<Vec<String>>,
    cancel: AtomicBool,
}

impl Progress for Phases {
    fn start(&self, what: &str, _: u64) {
        self.started.lock().unwrap().push(what.to_string());
    }
    fn inc(&self, _: u64) {}
    fn finish(&self) {}
    fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

#[test]
fn prepare_twice_does_not_rebake_and_cancellation_is_reported() {
    let nm = Arc::new(NormalMap::bumps(64, 4, 0.5));
    let scene = two_sphere_scene(&nm);
    let mut method = ShMethod::new(ShOptions::default()).unwrap();
    let p = Phases::default();
    method.prepare(&scene, &p).unwrap();
    let first = p.started.lock().unwrap().clone();
    assert_eq!(
        first.iter().filter(|s| *s == "sh bake").count(),
        2,
        "{first:?}"
    );
    let tables: Vec<_> = method.tables().to_vec();
    let p2 = Phases::default();
    method.prepare(&scene, &p2).unwrap();
    let second = p2.started.lock().unwrap().clone();
    assert!(!second.iter().any(|s| s == "sh bake"), "{second:?}");
    for (a, b) in tables.iter().zip(method.tables()) {
        assert!(Arc::ptr_eq(a, b));
    }
    // A moved object needs a new prepare (not a new bake).
    let mut moved = scene.clone();
    moved.objects[1].mesh = sphere(Vec3::new(0.8, 0.1, 0.0), 0.6);
    let err = render_frame(
        &mut method,
        &moved,
        &FrameRequest::new(moved.camera),
        &NoProgress,
    )
    .unwrap_err();
    assert!(err.to_string().contains("prepare"), "{err}");
    method.prepare(&moved, &p2).unwrap();
    assert!(!p2.started.lock().unwrap().iter().any(|s| s == "sh bake"));
    // Cancellation.
    let stop = Phases::default();
    stop.cancel.store(true, Ordering::Relaxed);
    let mut fresh = ShMethod::new(ShOptions::default()).unwrap();
    assert!(matches!(
        fresh.prepare(&scene, &stop),
        Err(MethodError::Cancelled)
    ));
}

#[test]
fn bad_options_and_requests_are_typed_errors() {
    for (opts, name) in [
        (
            ShOptions {
                order: 0,
                ..ShOptions::default()
            },
            "order",
        ),
        (
            ShOptions {
                order: 17,
                ..ShOptions::default()
            },
            "order",
        ),
        (
            ShOptions {
                beta_lim: -1.0,
                ..ShOptions::default()
            },
            "beta_lim",
        ),
    ] {
        match ShMethod::new(opts) {
            Err(MethodError::InvalidOption { method, option, .. }) => {
                assert_eq!((method, option), ("sh", name));
            }
            other => panic!("{other:?}"),
        }
    }
    let nm = Arc::new(NormalMap::bumps(64, 4, 0.5));
    let scene = two_sphere_scene(&nm);
    let mut unprepared = ShMethod::new(ShOptions::default()).unwrap();
    let err = render_frame(
        &mut unprepared,
        &scene,
        &FrameRequest::new(scene.camera),
        &NoProgress,
    )
    .unwrap_err();
    assert!(err.to_string().contains("prepare"), "{err}");
    let mut method = prepared(&scene);
    for aa in [0, 9] {
        assert!(matches!(
            render_frame(
                &mut method,
                &scene,
                &FrameRequest::new(scene.camera).with_aa(aa),
                &NoProgress
            ),
            Err(MethodError::InvalidOption { option: "aa", .. })
        ));
    }
    // A normal map on a mesh without uvs: the object is named.
    let mut no_uvs = scene.clone();
    no_uvs.objects[1].mesh = Arc::new(shapes::icosphere(0.5, 2));
    no_uvs.objects[1].normal_map = Some(nm);
    let err = ShMethod::new(ShOptions::default())
        .unwrap()
        .prepare(&no_uvs, &NoProgress)
        .unwrap_err();
    assert!(err.to_string().contains("object 2:"), "{err}");
}

/// The work count (`Relighter::frame_work`) follows what the frames do: a
/// lighting change lights only the vertices the next frame shows (step 2
/// is lazy), so a sphere behind the camera adds nothing to it, and a still
/// frame after it lights none; `set_lighting` counts nothing of its own.
#[test]
fn frame_work_counts_the_vertices_a_lighting_change_lights() {
    let lighting_change_work = |scene: &Scene| {
        let mut rotated = scene.clone();
        rotated.world_from_env = Mat3::from_rotation_y(0.7);
        let mut method = prepared(scene);
        let request = FrameRequest::new(scene.camera);
        // The first frame lights what it shows; the second nothing.
        frame(&mut method, scene, 1);
        frame(&mut method, scene, 1);
        let still = method.frame_work(scene, &request).expect("counted");
        method.set_lighting(&rotated, &NoProgress).unwrap();
        frame(&mut method, &rotated, 1);
        let changed = method.frame_work(&rotated, &request).expect("counted");
        frame(&mut method, &rotated, 1);
        let again = method.frame_work(&rotated, &request).expect("counted");
        assert_eq!(still.lighting_fma, 0.0);
        assert_eq!(changed.lighting_fma, 0.0);
        assert_eq!(
            again.view_fma, still.view_fma,
            "a still frame lights no vertex"
        );
        assert_eq!(changed.lighting_change_fma(), changed.view_fma);
        changed.view_fma - still.view_fma
    };
    let nm = Arc::new(NormalMap::bumps(64, 4, 0.5));
    let scene = two_sphere_scene(&nm);
    let seen = lighting_change_work(&scene);
    assert!(seen > 0.0, "the lit vertices are counted: {seen}");
    let mut behind = scene.clone();
    behind.objects.push(Object::new(
        sphere(Vec3::new(0.0, 0.4, 6.0), 0.6),
        Arc::new(Lambert::new(Vec3::splat(0.5)).unwrap()),
    ));
    assert_eq!(
        lighting_change_work(&behind),
        seen,
        "vertices no frame shows are not lit"
    );
}
