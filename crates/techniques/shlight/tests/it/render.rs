//! SH shading against the reference renderer on small images (64×48).

use glam::Vec3;
use relight_brdf::{Brdf, Ggx, Lambert};
use relight_geom::shapes;
use relight_render::bvh::SceneBvh;
use relight_render::reference::{
    EnvLight, ReferenceImage, ReferenceOptions, render_reference_with,
};
use relight_render::sampling::EnvFilter;
use relight_render::{Camera, Image, NoProgress, Object, Scene};
use relight_shlight::{
    NormalMap, ShLightError, ShRenderer, ShRotationMethod, VerifyOptions, VerifyScene,
    WindowChoice, verify_sh,
};
use relight_sphere::{EnvMap, Param};
use std::sync::Arc;

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

/// Smooth lighting with bands ≤ 2 only (so order-3 Lambert shading is exact).
fn smooth_env() -> EnvMap {
    EnvMap::from_fn(
        Param::LatLong {
            width: 64,
            height: 32,
        },
        |d| {
            let v = 1.0 + 0.6 * d.y + 0.3 * d.x + 0.4 * d.x * d.z;
            Vec3::new(v, 0.8 * v + 0.1 * d.z, 0.6 + 0.2 * d.y * d.y)
        },
    )
}

/// An all-frequency sky: a bright warm lobe and a cool gradient.
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

fn sphere_scene(brdf: Arc<dyn Brdf>, env: EnvMap) -> Scene {
    Scene::new(
        vec![Object::new(Arc::new(shapes::uv_sphere(1.0, 64, 32)), brdf)],
        env,
        camera(),
    )
}

fn reference(scene: &Scene, nm: Option<&NormalMap>, spp: u32) -> ReferenceImage {
    let bvh = SceneBvh::from_scene(scene);
    let light = EnvLight::new(&scene.env, EnvFilter::Nearest);
    let opts = ReferenceOptions {
        spp,
        pass_spp: 16,
        seed: 3,
        env_filter: EnvFilter::Nearest,
        ..ReferenceOptions::default()
    };
    let mut scene = scene.clone();
    scene.visibility = false;
    if let Some(m) = nm {
        let m = Arc::new(m.clone());
        for o in &mut scene.objects {
            o.normal_map = Some(m.clone());
        }
    }
    render_reference_with(&scene, &bvh, &light, &opts, &NoProgress).unwrap()
}

fn render(
    scene: &Scene,
    order: usize,
    m: ShRotationMethod,
    nm: Option<&NormalMap>,
) -> (Image, Vec<bool>) {
    // The unwindowed transfer: these tests compare the band-limited integral
    // itself with the reference (windows are tested on their own).
    let r = ShRenderer::new(order, m)
        .unwrap()
        .with_window(WindowChoice::None)
        .with_supersampling(2)
        .render(scene, nm, &NoProgress)
        .unwrap();
    (r.image, r.mask)
}

#[test]
fn lambert_sphere_matches_reference_at_order_3() {
    let scene = sphere_scene(
        Arc::new(Lambert::new(Vec3::new(0.8, 0.7, 0.6)).unwrap()),
        smooth_env(),
    );
    // 512 spp: at 64 spp the reference's own noise alone is ~4.5 % RMS.
    let r = reference(&scene, None, 512);
    for order in [3, 5] {
        let (img, mask) = render(&scene, order, ShRotationMethod::Exact, None);
        let covered = mask.iter().filter(|&&m| m).count();
        assert!(covered > 600, "sphere covers {covered} pixels");
        let e = img.relative_rms_error(&r.image, Some(&mask));
        eprintln!(
            "lambert order {order}: rel RMS {e:.4} (reference rel std error {:.4})",
            r.relative_std_error
        );
        assert!(
            e < 0.025,
            "order {order}: SH vs reference rel RMS {e} (want < 0.025)"
        );
    }
}

#[test]
fn mesh_without_tangents_uses_corner_frames_and_refuses_normal_maps() {
    // The icosphere has no uvs/tangents: per-corner frames, same answer.
    let brdf: Arc<dyn Brdf> = Arc::new(Ggx::isotropic(0.4, Vec3::ONE).unwrap());
    let mut scene = sphere_scene(brdf, smooth_env());
    scene.objects[0].mesh = Arc::new(shapes::icosphere(1.0, 4));
    // The lighting has bands ≤ 2, so any order ≥ 3 is exact up to reference noise.
    let r = reference(&scene, None, 512);
    let (img, mask) = render(&scene, 6, ShRotationMethod::Exact, None);
    let e = img.relative_rms_error(&r.image, Some(&mask));
    eprintln!("icosphere GGX 0.4 order 6: rel RMS {e:.4}");
    assert!(e < 0.035, "rel RMS {e}");
    let nm = NormalMap::bumps(32, 4, 0.3);
    let err = ShRenderer::new(4, ShRotationMethod::Exact)
        .unwrap()
        .render(&scene, Some(&nm), &NoProgress)
        .unwrap_err();
    assert!(
        matches!(err, ShLightError::MissingUvs { object: 0, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("uvs"), "{err}");
}

#[test]
fn zero_perturbation_every_method_equals_none() {
    let scene = sphere_scene(
        Arc::new(Ggx::isotropic(0.3, Vec3::new(1.0, 0.8, 0.5)).unwrap()),
        sky_env(),
    );
    let flat = NormalMap::from_vectors(4, 4, &[Vec3::Z; 16]).unwrap();
    let (base, mask) = render(&scene, 6, ShRotationMethod::None, None);
    for m in ShRotationMethod::ALL {
        let (img, _) = render(&scene, 6, m, Some(&flat));
        let d = img.relative_rms_error(&base, Some(&mask));
        assert!(
            d < 2e-4,
            "{m}: flat normal map differs from no normal map by {d}"
        );
    }
}

#[test]
fn taylor_error_grows_with_perturbation_angle() {
    let scene = sphere_scene(Arc::new(Ggx::isotropic(0.3, Vec3::ONE).unwrap()), sky_env());
    for m in [
        ShRotationMethod::Taylor1,
        ShRotationMethod::Taylor15,
        ShRotationMethod::Taylor2,
    ] {
        let mut last = 0.0;
        for tilt in [0.15f32, 0.4, 0.8] {
            let nm = NormalMap::bumps(64, 4, tilt);
            let (exact, mask) = render(&scene, 6, ShRotationMethod::Exact, Some(&nm));
            let (approx, _) = render(&scene, 6, m, Some(&nm));
            let e = approx.relative_rms_error(&exact, Some(&mask));
            eprintln!("{m} tilt {tilt}: rel RMS vs exact {e:.5}");
            assert!(
                e > last,
                "{m}: error {e} at tilt {tilt} not above {last} at the smaller tilt"
            );
            last = e;
        }
        assert!(
            last > 1e-3,
            "{m}: large tilts should show an error, got {last}"
        );
    }
    // ZYZ is exact: it agrees with Ivanic–Ruedenberg at any tilt.
    let nm = NormalMap::bumps(64, 4, 0.8);
    let (exact, mask) = render(&scene, 6, ShRotationMethod::Exact, Some(&nm));
    let (zyz, _) = render(&scene, 6, ShRotationMethod::Zyz, Some(&nm));
    let d = zyz.relative_rms_error(&exact, Some(&mask));
    assert!(d < 1e-4, "zyz vs exact {d}");
}

#[test]
fn per_pixel_rotation_beats_simplified_normal_mapping() {
    let nm = NormalMap::bumps(64, 6, 0.6);
    for (name, brdf) in [
        (
            "ggx 0.3",
            Arc::new(Ggx::isotropic(0.3, Vec3::new(1.0, 0.8, 0.5)).unwrap()) as Arc<dyn Brdf>,
        ),
        ("lambert", Arc::new(Lambert::new(Vec3::splat(0.8)).unwrap())),
    ] {
        let scene = sphere_scene(brdf, sky_env());
        let r = reference(&scene, Some(&nm), 96);
        let err = |m| {
            let (img, mask) = render(&scene, 6, m, Some(&nm));
            img.relative_rms_error(&r.image, Some(&mask))
        };
        let (exact, taylor15, none) = (
            err(ShRotationMethod::Exact),
            err(ShRotationMethod::Taylor15),
            err(ShRotationMethod::None),
        );
        eprintln!(
            "{name}: exact {exact:.4}, taylor15 {taylor15:.4}, none {none:.4} (reference noise {:.4})",
            r.relative_std_error
        );
        assert!(
            exact < 0.6 * none,
            "{name}: exact per-pixel rotation {exact} not clearly below `none` {none}"
        );
        assert!(
            taylor15 < 0.8 * none,
            "{name}: taylor15 {taylor15} not below `none` {none}"
        );
    }
}

#[test]
fn verify_quick_smoke() {
    let scene = sphere_scene(Arc::new(Ggx::isotropic(0.3, Vec3::ONE).unwrap()), sky_env());
    let opts = VerifyOptions {
        width: 48,
        height: 36,
        orders: vec![3, 5],
        spp: 32,
        supersampling: 1,
        ..VerifyOptions::quick()
    };
    let rows = verify_sh(
        &[VerifyScene {
            name: "sphere",
            scene: &scene,
        }],
        None,
        &opts,
        &NoProgress,
    )
    .unwrap();
    // Two windows (none, auto) × two orders × (no normal map + 6 rotations).
    assert_eq!(rows.len(), 2 * 2 * (1 + 6));
    for w in ["none", "auto"] {
        assert_eq!(rows.iter().filter(|r| r.window == w).count(), 2 * (1 + 6));
    }
    // The window removes the ringing below zero (rows with a normal map
    // rotate exactly or approximately; the exact ones must be clean).
    for r in rows
        .iter()
        .filter(|r| r.window == "auto" && (r.rotation == "exact" || r.rotation == "any"))
    {
        assert_eq!(r.negative_pixels, 0, "{r:?}");
    }
    for r in &rows {
        assert!(
            r.rel_rms_error.is_finite() && r.rel_rms_error > 0.0 && r.pixels > 100,
            "{r:?}"
        );
        // Against the exact per-pixel rotation: zero for exact itself (and for
        // the rows without a normal map), and the `none` baseline is the worst.
        match r.rotation.as_str() {
            "exact" | "any" => assert!(r.rel_rms_vs_exact == 0.0, "{r:?}"),
            _ => assert!(r.rel_rms_vs_exact.is_finite(), "{r:?}"),
        }
    }
    for order in [3, 5] {
        let vs = |m: &str| {
            rows.iter()
                .find(|r| r.order == order && r.rotation == m && r.window == "none")
                .map(|r| r.rel_rms_vs_exact)
                .unwrap()
        };
        assert!(
            vs("zyz") < 1e-4,
            "zyz vs exact at order {order}: {}",
            vs("zyz")
        );
        for taylor in ["taylor1", "taylor15", "taylor2"] {
            assert!(
                vs(taylor) < vs("none"),
                "{taylor} ({}) not closer to exact than `none` ({}) at order {order}",
                vs(taylor),
                vs("none")
            );
        }
    }
    // Every per-pixel row with the normal map is judged against the `none`
    // row of its order; the rest are reports.
    for r in &rows {
        let judged = r.normal_map != "none" && r.rotation != "none";
        assert_eq!(r.pass.is_some(), judged, "{r:?}");
        assert_eq!(r.target.is_some(), judged, "{r:?}");
        assert!(r.source.is_some(), "{r:?}");
        if let (Some(p), Some(t)) = (r.pass, r.target) {
            assert_eq!(p, r.rel_rms_error < t, "{r:?}");
        }
    }
}

#[test]
fn rotation_method_parses() {
    for m in ShRotationMethod::ALL {
        assert_eq!(m.name().parse::<ShRotationMethod>().unwrap(), m);
    }
    let e = "taylor3"
        .parse::<ShRotationMethod>()
        .unwrap_err()
        .to_string();
    assert!(e.contains("taylor15"), "{e}");
    assert!(ShRenderer::new(0, ShRotationMethod::Exact).is_err());
    assert!(ShRenderer::new(17, ShRotationMethod::Exact).is_err());
}

#[test]
fn lighting_filter_scales_bands_and_background() {
    let lambert: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::splat(0.7)).unwrap());
    let scene = sphere_scene(lambert, sky_env());
    let render = |f: Option<relight_shlight::LightingFilter>| {
        let mut r = ShRenderer::new(4, ShRotationMethod::Exact).unwrap();
        if let Some(f) = f {
            r = r.with_lighting_filter(f).unwrap();
        }
        r.render(&scene, None, &NoProgress).unwrap()
    };
    let filter =
        |direct: f32, bands: Vec<f32>| Some(relight_shlight::LightingFilter { direct, bands });
    let plain = render(None);
    // The identity filter changes nothing; `direct` alone scales everything.
    let same = render(filter(1.0, vec![]));
    let half = render(filter(0.5, vec![0.0; 4]));
    for ((a, b), c) in plain
        .image
        .pixels
        .iter()
        .zip(&same.image.pixels)
        .zip(&half.image.pixels)
    {
        assert!((*a - *b).abs().max_element() <= 1e-6 * a.max_element().max(1.0));
        assert!((*a * 0.5 - *c).abs().max_element() <= 1e-5 * a.max_element().max(1.0));
    }
    // Band 0 only: uniform lighting of the environment's mean radiance, so
    // the Lambert sphere is uniform ρ·mean and the background is the mean.
    let dc = render(filter(0.0, vec![1.0]));
    let mean = scene.env.integral() / (4.0 * std::f32::consts::PI);
    for (p, &covered) in dc.image.pixels.iter().zip(&dc.mask) {
        let want = if covered { mean * 0.7 } else { mean };
        if covered || p.max_element() > 0.0 {
            assert!(
                (*p - want).abs().max_element() < 2e-3 * want.max_element(),
                "{p} vs {want}"
            );
        }
    }
    let bad = ShRenderer::new(4, ShRotationMethod::Exact)
        .unwrap()
        .with_lighting_filter(relight_shlight::LightingFilter {
            direct: -1.0,
            bands: vec![],
        });
    assert!(matches!(bad, Err(ShLightError::InvalidParameter { .. })));
}

#[test]
fn lighting_rotation_in_sh_matches_a_rotated_map() {
    let ggx: Arc<dyn Brdf> = Arc::new(Ggx::isotropic(0.4, Vec3::ONE).unwrap());
    let scene = sphere_scene(ggx, sky_env());
    let r = glam::Mat3::from_euler(glam::EulerRot::YXZ, 1.1, 0.4, -0.3);
    let mut resampled = scene.clone();
    resampled.env = scene.env.rotated(r, 4);
    let renderer = ShRenderer::new(6, ShRotationMethod::Exact).unwrap();
    let want = renderer
        .render(&resampled, None, &NoProgress)
        .unwrap()
        .image;
    let got = ShRenderer::new(6, ShRotationMethod::Exact)
        .unwrap()
        .with_lighting_rotation(r)
        .unwrap()
        .render(&scene, None, &NoProgress)
        .unwrap()
        .image;
    let unrotated = renderer.render(&scene, None, &NoProgress).unwrap().image;
    let rel = |a: &Image, b: &Image| {
        let (mut n, mut d) = (0.0f64, 0.0f64);
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            n += f64::from((*p - *q).length_squared());
            d += f64::from(q.length_squared());
        }
        (n / d).sqrt()
    };
    let e = rel(&got, &want);
    assert!(e < 0.02, "SH-domain rotation vs resampled map: {e}");
    assert!(
        rel(&unrotated, &want) > 10.0 * e,
        "the rotation must matter"
    );
    let bad = ShRenderer::new(6, ShRotationMethod::Exact)
        .unwrap()
        .with_lighting_rotation(glam::Mat3::from_diagonal(Vec3::new(1.0, 1.0, -1.0)));
    assert!(bad.is_err());
}
