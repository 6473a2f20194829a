//! `WaveletMethod` through the method interface: the same image as the
//! direct `WaveletRenderer::render` (the CLI's path), lighting rotation via
//! `world_from_env`, feature checks, bake reuse. Small bakes (n = 16,
//! ntess = 8) in a private cache folder, 64×48 images.

use glam::{Mat3, Vec3};
use relight_brdf::{Brdf, Ggx, Lambert};
use relight_geom::shapes;
use relight_render::method::{
    FrameRequest, MethodError, Relighter, Rendered, SceneFeature, Support, background_pixel,
    check_scene, render_frame,
};
use relight_render::{
    Camera, Image, NoProgress, NormalMap, Object, PointLight, Progress, Scene, SceneBvh,
};
use relight_sphere::{EnvMap, Param};
use relight_wavelet::{
    AO_APPROXIMATION, BrdfBake, WaveletMethod, WaveletOptions, WaveletRenderer,
    bake_or_load_rotation, bake_or_load_scene_brdfs,
};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

const W: usize = 64;
const H: usize = 48;

fn cache(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "relight-wavelet-method-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn options(cache_dir: PathBuf, ao: u32) -> WaveletOptions {
    WaveletOptions {
        n: 16,
        ntess: 8,
        terms: 64,
        ao,
        brdf_views: 16,
        brdf_terms: 32,
        cache_dir,
        ..WaveletOptions::default()
    }
}

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

/// A smooth sky with a warm lobe.
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

/// A GGX sphere resting near a Lambert one (they occlude each other a
/// little, so AO is not 1 everywhere).
fn scene() -> Scene {
    let ggx: Arc<dyn Brdf> = Arc::new(Ggx::isotropic(0.3, Vec3::ONE).unwrap());
    let lambert: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::splat(0.8)).unwrap());
    Scene::new(
        vec![
            Object::new(
                Arc::new(shapes::uv_sphere_at(
                    Vec3::new(-0.62, 0.0, 0.0),
                    0.6,
                    48,
                    24,
                )),
                ggx,
            ),
            Object::new(
                Arc::new(shapes::uv_sphere_at(Vec3::new(0.62, 0.0, 0.0), 0.6, 48, 24)),
                lambert,
            ),
        ],
        sky_env(),
        camera(),
    )
}

fn frame(method: &mut WaveletMethod, scene: &Scene, aa: usize) -> Rendered {
    render_frame(
        method,
        scene,
        &FrameRequest::new(scene.camera).with_aa(aa),
        &NoProgress,
    )
    .unwrap()
}

fn max_rel_diff(a: &Image, b: &Image, keep: impl Fn(usize) -> bool) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .enumerate()
        .filter(|(i, _)| keep(*i))
        .map(|(_, (p, q))| (*p - *q).abs().max_element() / q.abs().max_element().max(1.0))
        .fold(0.0, f32::max)
}

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

/// The CLI's wavelet path: bake or load, step 1, per-vertex AO, step 2 on
/// the `aa`× supersampled camera, box filter.
fn direct(scene: &Scene, o: &WaveletOptions, aa: usize) -> Image {
    let params = o.rotation_params();
    let (rot, _) = bake_or_load_rotation(&params, &o.cache_dir, &NoProgress).unwrap();
    let bakes = bake_or_load_scene_brdfs(
        scene,
        params.m,
        o.brdf_views,
        o.brdf_terms,
        &o.cache_dir,
        &NoProgress,
    )
    .unwrap();
    let mut r = WaveletRenderer::new(rot, o.terms).unwrap();
    r.set_lighting(&scene.env, scene.world_from_env).unwrap();
    let refs: Vec<&BrdfBake> = bakes.iter().map(|b| b.as_ref()).collect();
    let ao = (o.ao > 0).then(|| {
        let meshes: Vec<&relight_geom::Mesh> = scene.objects.iter().map(|o| &*o.mesh).collect();
        let bvh = SceneBvh::build(&meshes);
        (0..meshes.len())
            .map(|i| {
                bvh.vertex_ambient_occlusion(i, o.ao, o.ao_seed, &NoProgress)
                    .unwrap()
            })
            .collect::<Vec<_>>()
    });
    let mut cam = scene.camera;
    cam.width *= aa;
    cam.height *= aa;
    r.render(scene, &refs, &cam, ao.as_deref())
        .unwrap()
        .box_downsample(aa)
}

#[test]
fn render_frame_matches_the_direct_renderer_with_and_without_ao() {
    let dir = cache("direct");
    let mut s = scene();
    s.world_from_env = Mat3::from_euler(glam::EulerRot::YXZ, 0.7, 0.2, 0.1);
    for ao in [0, 16] {
        let o = options(dir.clone(), ao);
        let mut method = WaveletMethod::new(o.clone()).unwrap();
        method.prepare(&s, &NoProgress).unwrap();
        let aa = 2;
        let got = frame(&mut method, &s, aa);
        let want = direct(&s, &o, aa);
        let cov = got.coverage.as_deref().unwrap();
        let seen = |i: usize| cov.coverage[i] > 0.0;
        let n = (0..W * H).filter(|&i| seen(i)).count();
        assert!(n > 800, "objects seen: {n} pixels");
        let d = max_rel_diff(&got.image, &want, seen);
        assert!(d <= 1e-5, "ao {ao}: method vs direct {d}");
        for id in [1, 2] {
            assert!(cov.object_id.contains(&id), "object {id} in the id channel");
        }
        let rays = s.camera.ray_frame();
        for y in 0..H {
            for x in 0..W {
                let i = y * W + x;
                if cov.coverage[i] <= 0.0 {
                    let b = background_pixel(&s, &rays, x, y);
                    assert!((got.image.pixels[i] - b).abs().max_element() <= 1e-6);
                }
            }
        }
        let p = o.rotation_params();
        assert!(method.data_bytes() > 0);
        assert!(
            method.data_bytes()
                > bake_or_load_rotation(&p, &dir, &NoProgress)
                    .unwrap()
                    .0
                    .size_bytes()
        );
    }
    // AO darkens where the spheres meet.
    let mut plain = WaveletMethod::new(options(dir.clone(), 0)).unwrap();
    let mut occluded = WaveletMethod::new(options(dir.clone(), 16)).unwrap();
    plain.prepare(&s, &NoProgress).unwrap();
    occluded.prepare(&s, &NoProgress).unwrap();
    let (a, b) = (frame(&mut plain, &s, 1), frame(&mut occluded, &s, 1));
    let sum = |im: &Image| im.pixels.iter().map(|p| f64::from(p.x)).sum::<f64>();
    assert!(sum(&b.image) < 0.99 * sum(&a.image));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn set_lighting_with_world_from_env_matches_a_rotated_map() {
    let dir = cache("rotate");
    let s = scene();
    let r = Mat3::from_euler(glam::EulerRot::YXZ, 1.1, 0.4, -0.3);
    let mut rotated = s.clone();
    rotated.world_from_env = r;
    let mut resampled = s.clone();
    resampled.env = s.env.rotated(r, 4);
    let o = options(dir.clone(), 0);
    let mut method = WaveletMethod::new(o.clone()).unwrap();
    method.prepare(&s, &NoProgress).unwrap();
    let unrotated = frame(&mut method, &s, 1);
    let ms = method.set_lighting(&rotated, &NoProgress).unwrap();
    assert!(ms > 0.0);
    let got = frame(&mut method, &rotated, 1);
    assert!((got.timings.lighting_ms - ms).abs() < 1e-9);
    assert_eq!(frame(&mut method, &rotated, 1).timings.lighting_ms, 0.0);
    let cov = got.coverage.as_deref().unwrap();
    let full = |i: usize| cov.coverage[i] >= 1.0;
    // Exactly what preparing with the rotation gives.
    let mut fresh = WaveletMethod::new(o.clone()).unwrap();
    fresh.prepare(&rotated, &NoProgress).unwrap();
    let f = frame(&mut fresh, &rotated, 1);
    assert!(max_rel_diff(&got.image, &f.image, |i| cov.coverage[i] > 0.0) <= 1e-5);
    // Against the resampled map, unrotated: the two differ only by where
    // the octahedral samples read the map (bilinear lookups of a rotated
    // resampling vs of the original).
    let mut other = WaveletMethod::new(o).unwrap();
    other.prepare(&resampled, &NoProgress).unwrap();
    let want = frame(&mut other, &resampled, 1);
    let e = rel_rms(&got.image, &want.image, full);
    let moved = rel_rms(&unrotated.image, &want.image, full);
    eprintln!("world_from_env vs rotated map: rel RMS {e:.5}; unrotated {moved:.4}");
    // Measured 7e-4 (n = 16, 64 terms).
    assert!(e < 0.005, "rotation via world_from_env vs rotated map: {e}");
    assert!(moved > 10.0 * e, "the rotation must matter ({moved})");
    let mut bad = rotated.clone();
    bad.world_from_env = Mat3::from_diagonal(Vec3::new(1.0, 1.0, -1.0));
    assert!(matches!(
        method.set_lighting(&bad, &NoProgress),
        Err(MethodError::InvalidOption {
            method: "wavelet",
            option: "world_from_env",
            ..
        })
    ));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn check_scene_refuses_point_lights_and_normal_maps() {
    let dir = cache("check");
    let s = scene();
    let plain = WaveletMethod::new(options(dir.clone(), 0)).unwrap();
    assert!(check_scene(&plain, &s, false).unwrap().is_empty());
    let mut lit = s.clone();
    lit.point_lights
        .push(PointLight::new(Vec3::new(0.0, 2.0, 1.0), Vec3::ONE));
    let mut bumpy = s.clone();
    bumpy.objects[0].normal_map = Some(Arc::new(NormalMap::bumps(64, 4, 0.5)));
    for (sc, want) in [
        (&lit, SceneFeature::PointLights),
        (&bumpy, SceneFeature::NormalMaps),
    ] {
        let err = check_scene(&plain, sc, true).unwrap_err();
        assert!(
            matches!(err, MethodError::Unsupported { method: "wavelet", feature, approximate: None } if feature == want),
            "{err:?}"
        );
        let text = err.to_string();
        assert!(
            text.contains("wavelet") && text.contains(want.describe()),
            "{text}"
        );
        let mut m = WaveletMethod::new(options(dir.clone(), 0)).unwrap();
        assert!(matches!(
            m.prepare(sc, &NoProgress),
            Err(MethodError::Unsupported { .. })
        ));
    }
    // Visibility: no without AO; approximate (a warning, only when allowed) with it.
    let mut shadowed = s.clone();
    shadowed.visibility = true;
    assert!(matches!(
        check_scene(&plain, &shadowed, true),
        Err(MethodError::Unsupported {
            approximate: None,
            ..
        })
    ));
    let with_ao = WaveletMethod::new(options(dir.clone(), 8)).unwrap();
    assert_eq!(
        with_ao.supports(SceneFeature::Visibility),
        Support::Approximate(AO_APPROXIMATION)
    );
    assert!(matches!(
        check_scene(&with_ao, &shadowed, false),
        Err(MethodError::Unsupported {
            approximate: Some(AO_APPROXIMATION),
            ..
        })
    ));
    let warnings = check_scene(&with_ao, &shadowed, true).unwrap();
    assert_eq!(warnings.len(), 1);
    assert!(warnings[0].contains("ambient occlusion"), "{warnings:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Records the phases started.
#[derive(Default)]
struct Phases(Mutex<Vec<String>>);

impl Progress for Phases {
    fn start(&self, what: &str, _: u64) {
        self.0.lock().unwrap().push(what.to_string());
    }
    fn inc(&self, _: u64) {}
    fn finish(&self) {}
    fn is_cancelled(&self) -> bool {
        false
    }
}

#[test]
fn prepare_twice_does_not_rebake_or_reload() {
    let dir = cache("twice");
    let s = scene();
    let mut method = WaveletMethod::new(options(dir.clone(), 0)).unwrap();
    let p = Phases::default();
    method.prepare(&s, &p).unwrap();
    let first = p.0.lock().unwrap().clone();
    assert!(
        first.iter().any(|x| x.contains("rotation matrices")),
        "{first:?}"
    );
    assert_eq!(
        first.iter().filter(|x| x.contains("BRDF")).count(),
        2,
        "{first:?}"
    );
    assert_eq!(method.loads(), 3);
    let p2 = Phases::default();
    method.prepare(&s, &p2).unwrap();
    let second = p2.0.lock().unwrap().clone();
    assert!(!second.iter().any(|x| x.contains("bake")), "{second:?}");
    assert_eq!(method.loads(), 3, "nothing loaded again");
    // A new method over the same cache loads from disk without baking.
    let p3 = Phases::default();
    let mut again = WaveletMethod::new(options(dir.clone(), 0)).unwrap();
    again.prepare(&s, &p3).unwrap();
    assert!(!p3.0.lock().unwrap().iter().any(|x| x.contains("bake")));
    assert_eq!(again.loads(), 3);
    let p4 = Phases::default();
    again.prepare(&s, &p4).unwrap();
    assert_eq!(again.loads(), 3, "a loaded BRDF bake is matched in memory");
    // Moved objects: render asks for a new prepare.
    let mut moved = s.clone();
    moved.objects[1].mesh = Arc::new(shapes::uv_sphere_at(Vec3::new(0.7, 0.1, 0.0), 0.5, 32, 16));
    let err = render_frame(
        &mut method,
        &moved,
        &FrameRequest::new(moved.camera),
        &NoProgress,
    )
    .unwrap_err();
    assert!(err.to_string().contains("prepare"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_options_are_typed_errors() {
    let dir = cache("bad");
    for (o, name) in [
        (
            WaveletOptions {
                n: 12,
                ..options(dir.clone(), 0)
            },
            "n/ntess/ntrunc",
        ),
        (
            WaveletOptions {
                terms: 0,
                ..options(dir.clone(), 0)
            },
            "terms",
        ),
        (
            WaveletOptions {
                terms: 16 * 16 + 1,
                ..options(dir.clone(), 0)
            },
            "terms",
        ),
        (
            WaveletOptions {
                brdf_views: 0,
                ..options(dir.clone(), 0)
            },
            "brdf_views/brdf_terms",
        ),
    ] {
        match WaveletMethod::new(o) {
            Err(MethodError::InvalidOption { method, option, .. }) => {
                assert_eq!((method, option), ("wavelet", name));
            }
            other => panic!("{name}: {other:?}"),
        }
    }
    let d = WaveletOptions::default();
    assert_eq!(
        (d.n, d.ntess, d.terms, d.ao, d.brdf_views, d.brdf_terms),
        (64, 32, 256, 0, 64, 128)
    );
}

/// With ambient occlusion, a floor of one quad under the spheres is shaded
/// on a refined copy (its four vertices would hold no occlusion), said in a
/// warning: the image is the one of the same floor built as the grid the
/// copy is (the same vertices; their AO rays differ, numbered otherwise:
/// 256 rays, so within their noise), and the floor darkens under the
/// spheres. Without AO nothing is refined.
#[test]
fn ao_on_a_one_quad_floor_is_shaded_refined() {
    let dir = cache("refine");
    let lambert: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::splat(0.8)).unwrap());
    let with_floor = |cells: usize| {
        let mut s = scene();
        let floor = shapes::plane(4.0, cells)
            .transformed(glam::Affine3A::from_translation(Vec3::new(0.0, -0.6, 0.0)));
        s.objects
            .push(Object::new(Arc::new(floor), lambert.clone()));
        s.visibility = true;
        s
    };
    let quad = with_floor(1);
    let mut m = WaveletMethod::new(options(dir.clone(), 256)).unwrap();
    m.prepare(&quad, &NoProgress).unwrap();
    let w = m.warnings().join("\n");
    let at = w.find("refined to ").expect(&w) + "refined to ".len();
    let vertices: usize = w[at..].split(' ').next().unwrap().parse().unwrap();
    let side = (vertices as f64).sqrt() as usize;
    assert_eq!(side * side, vertices, "{w}");
    assert!(w.contains("object 3's 4 vertices are about"), "{w}");
    let a = frame(&mut m, &quad, 1);
    // Prepared again on the same scene: the same image.
    m.prepare(&quad, &NoProgress).unwrap();
    let again = frame(&mut m, &quad, 1);
    assert_eq!(a.image.pixels, again.image.pixels);
    let grid = with_floor(side - 1);
    let mut g = WaveletMethod::new(options(dir.clone(), 256)).unwrap();
    g.prepare(&grid, &NoProgress).unwrap();
    assert!(g.warnings().is_empty(), "{:?}", g.warnings());
    let b = frame(&mut g, &grid, 1);
    let floor = |r: &Rendered, i: usize| r.coverage.as_deref().unwrap().object_id[i] == 2;
    assert!((0..W * H).filter(|&i| floor(&b, i)).count() > 200);
    let rel_rms = |x: &Image, y: &Image| {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (p, q) in x.pixels.iter().zip(&y.pixels) {
            num += f64::from((*p - *q).length_squared());
            den += f64::from(q.length_squared());
        }
        (num / den).sqrt()
    };
    let e = rel_rms(&a.image, &b.image);
    // The quad as given, its AO at four corners.
    let mut as_given = WaveletMethod::new(WaveletOptions {
        refine_coarse: false,
        ..options(dir.clone(), 256)
    })
    .unwrap();
    as_given.prepare(&quad, &NoProgress).unwrap();
    assert!(
        as_given
            .warnings()
            .join("\n")
            .contains("the shadows between them are lost")
    );
    let coarse = rel_rms(&frame(&mut as_given, &quad, 1).image, &b.image);
    eprintln!("vs the grid floor: refined quad {e}, quad as given {coarse}");
    assert!(
        e < 0.03 && e < coarse / 3.0,
        "refined {e}, as given {coarse}"
    );
    // Occluded: the floor's darkest pixel well below its brightest.
    let lum: Vec<f32> = (0..W * H)
        .filter(|&i| floor(&a, i))
        .map(|i| a.image.pixels[i].element_sum())
        .collect();
    let (lo, hi) = lum
        .iter()
        .fold((f32::MAX, 0.0f32), |(l, h), &x| (l.min(x), h.max(x)));
    assert!(lo < 0.6 * hi, "floor from {lo} to {hi}");
    // Without AO (and shadows) the quad is drawn as it is.
    let mut unshadowed = quad.clone();
    unshadowed.visibility = false;
    let mut plain = WaveletMethod::new(options(dir.clone(), 0)).unwrap();
    plain.prepare(&unshadowed, &NoProgress).unwrap();
    assert!(plain.warnings().is_empty(), "{:?}", plain.warnings());
    let _ = std::fs::remove_dir_all(&dir);
}
