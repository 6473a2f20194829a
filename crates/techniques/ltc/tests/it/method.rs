//! The `ltc` method behind the interface: what it refuses, and its image
//! against the reference on the case it renders exactly (untextured,
//! unshadowed).

use glam::Vec3;
use relight_ltc::{LtcMethod, LtcOptions};
use relight_nearfield::scenes::floor_and_sphere;
use relight_render::NoProgress;
use relight_render::method::{FrameRequest, MethodError, Relighter, SceneFeature, check_scene};
use relight_render::reference::{ReferenceOptions, render_reference};
use std::sync::Arc;

#[test]
fn refuses_what_it_cannot_render() {
    let mut scene = floor_and_sphere(8, 8, 16, 12, false);
    let mut m = LtcMethod::new(LtcOptions::default()).unwrap();
    // Shadows: approximate, so an error unless the caller accepts it.
    scene.visibility = true;
    let e = check_scene(&m, &scene, false).unwrap_err().to_string();
    assert!(
        e.starts_with("method ltc cannot render visibility (shadows) exactly"),
        "{e}"
    );
    assert_eq!(check_scene(&m, &scene, true).unwrap().len(), 1);
    scene.visibility = false;
    // A BRDF that is not Lambert + GGX names the object.
    let mut phong = scene.clone();
    phong.objects[0].brdf = "phong:30"
        .parse::<relight_brdf::BrdfSpec>()
        .unwrap()
        .build();
    let e = m.prepare(&phong, &NoProgress).unwrap_err().to_string();
    assert!(e.contains("object 1's BRDF cannot be shaded"), "{e}");
    // No area light.
    let mut dark = scene.clone();
    dark.area_lights.clear();
    assert!(matches!(
        m.prepare(&dark, &NoProgress),
        Err(MethodError::InvalidOption { method: "ltc", .. })
    ));
    // An environment.
    let mut lit = scene.clone();
    lit.env.texels.iter_mut().for_each(|t| *t = Vec3::ONE);
    assert!(matches!(
        m.prepare(&lit, &NoProgress),
        Err(MethodError::Unsupported {
            method: "ltc",
            feature: SceneFeature::Environment,
            ..
        })
    ));
    // A textured light renders by its mean, with a warning.
    m.prepare(&scene, &NoProgress).unwrap();
    assert!(
        m.warnings()
            .iter()
            .any(|w| w.contains("by its mean radiance"))
    );
}

#[test]
fn untextured_unshadowed_image_matches_the_reference() {
    let mut scene = floor_and_sphere(16, 16, 48, 32, false);
    scene.area_lights[0].texture = None;
    scene.objects[0].brdf =
        Arc::new(relight_brdf::Ggx::isotropic(0.3, Vec3::new(0.9, 0.7, 0.5)).unwrap());
    let reference = render_reference(
        &scene,
        &ReferenceOptions {
            spp: 512,
            pass_spp: 16,
            seed: 3,
            ..ReferenceOptions::default()
        },
        &NoProgress,
    )
    .unwrap();
    let mut m = LtcMethod::new(LtcOptions::default()).unwrap();
    m.prepare(&scene, &NoProgress).unwrap();
    assert!(m.warnings().is_empty(), "{:?}", m.warnings());
    let r = m
        .render(
            &scene,
            &FrameRequest::new(scene.camera).with_aa(4),
            &NoProgress,
        )
        .unwrap();
    let mask = r.coverage.as_deref().unwrap().object_mask();
    let e = r.image.relative_rms_error(&reference.image, Some(&mask));
    // The noise of the reference plus the LTC fit's error on the glossy
    // sphere (a few %, docs/ltc.md) and silhouette antialiasing.
    let sigma = reference.rms_relative_std_error;
    assert!(e <= 2.0 * sigma + 0.03, "relative RMS {e} (σ_MC {sigma})");
}
