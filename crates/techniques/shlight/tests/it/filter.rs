//! The SH method's normal-map filtering mode (`ShOptions::normal_filter`,
//! issue 14): `none` is plain normal mapping bit for bit; another filter
//! shades the normal-mapped Lambertian objects as the `ndf` method does,
//! pixel for pixel, leaves every other pixel alone, and names the
//! normal-mapped objects it does not apply to.

use glam::Vec3;
use relight_brdf::{Ggx, Lambert};
use relight_geom::shapes;
use relight_ndf::{NdfBrdf, NdfFilter, NdfMethod, NdfOptions};
use relight_render::method::{FrameRequest, Relighter, Rendered, render_frame};
use relight_render::{Camera, NoProgress, NormalMap, Object, Scene};
use relight_shlight::{ShMethod, ShOptions};
use std::sync::Arc;

/// A small, dense-bumped Lambertian sphere (many texels per pixel: the
/// case filtering is for), a normal-mapped GGX sphere and a plain one.
fn scene() -> Scene {
    let nm = Arc::new(NormalMap::bumps(256, 32, 0.6));
    let lambert = Arc::new(Lambert::new(Vec3::splat(0.8)).unwrap());
    let mut bumpy = Object::new(
        Arc::new(shapes::uv_sphere_at(Vec3::new(-0.8, 0.0, 0.0), 0.5, 48, 24)),
        lambert.clone(),
    );
    bumpy.normal_map = Some(nm.clone());
    let mut glossy = Object::new(
        Arc::new(shapes::uv_sphere_at(Vec3::new(0.4, 0.0, 0.0), 0.4, 48, 24)),
        Arc::new(Ggx::isotropic(0.4, Vec3::ONE).unwrap()),
    );
    glossy.normal_map = Some(nm);
    let plain = Object::new(
        Arc::new(shapes::uv_sphere_at(Vec3::new(1.2, 0.0, 0.0), 0.3, 48, 24)),
        lambert,
    );
    let (env, _) = relight_scene::load_environment("studio").unwrap();
    let camera = Camera {
        eye: Vec3::new(0.0, 0.3, 4.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 40.0,
        width: 96,
        height: 48,
        image_offset: glam::Vec2::ZERO,
    };
    Scene::new(vec![bumpy, glossy, plain], env, camera)
}

fn sh_frame(scene: &Scene, filter: NdfFilter) -> (ShMethod, Rendered) {
    let mut m = ShMethod::new(ShOptions {
        normal_filter: filter,
        ..ShOptions::default()
    })
    .unwrap();
    m.prepare(scene, &NoProgress).unwrap();
    let f = render_frame(&mut m, scene, &FrameRequest::new(scene.camera), &NoProgress).unwrap();
    (m, f)
}

#[test]
fn none_is_plain_normal_mapping() {
    let s = scene();
    let (_, plain) = sh_frame(&s, NdfFilter::None);
    let mut m = ShMethod::new(ShOptions::default()).unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    let want = render_frame(&mut m, &s, &FrameRequest::new(s.camera), &NoProgress).unwrap();
    assert_eq!(plain.image.pixels, want.image.pixels);
}

/// For each filter, the Lambertian bumpy sphere's whole pixels are the
/// `ndf` method's (that object alone, same filter), the other objects'
/// pixels are plain SH, and the GGX sphere is named in a warning.
#[test]
fn filters_shade_lambertian_normal_maps_as_the_ndf_method() {
    let s = scene();
    let (_, plain) = sh_frame(&s, NdfFilter::None);
    for filter in [NdfFilter::Sh, NdfFilter::Vmf, NdfFilter::Normalized] {
        let (m, f) = sh_frame(&s, filter);
        let w = m.warnings().join("\n");
        assert!(
            w.contains("object 2 keeps plain normal mapping") && !w.contains("object 1 keeps"),
            "{w}"
        );
        let mut alone = s.clone();
        alone.objects.truncate(1);
        let mut ndf = NdfMethod::new(NdfOptions {
            filter,
            brdf: NdfBrdf::Lambert,
            ..NdfOptions::default()
        })
        .unwrap();
        ndf.prepare(&alone, &NoProgress).unwrap();
        let want = ndf
            .render(&alone, &FrameRequest::new(s.camera), &NoProgress)
            .unwrap();
        let cov = f.coverage.as_deref().unwrap();
        let (mut filtered, mut changed) = (0, 0);
        for p in 0..f.image.pixels.len() {
            if cov.coverage[p] < 1.0 {
                continue;
            }
            if cov.object_id[p] == 1 {
                assert_eq!(
                    f.image.pixels[p], want.image.pixels[p],
                    "{filter:?}, pixel {p}"
                );
                filtered += 1;
                changed += usize::from(f.image.pixels[p] != plain.image.pixels[p]);
            } else {
                assert_eq!(
                    f.image.pixels[p], plain.image.pixels[p],
                    "{filter:?}, pixel {p}"
                );
            }
        }
        assert!(filtered > 100, "{filtered} pixels of the bumpy sphere");
        assert!(
            changed * 2 > filtered,
            "{filter:?}: {changed} of {filtered} changed"
        );
    }
}
