//! The scenes `verify` and `bench nearfield` use, built in code: a
//! Lambertian floor and sphere under one textured ceiling light (or three
//! lights in two planes), no environment (the method renders the area
//! lights alone).

use glam::{Mat3, Vec2, Vec3};
use relight_brdf::Lambert;
use relight_geom::shapes::{plane, uv_sphere_at};
use relight_render::texture::Texture;
use relight_render::{AreaLight, Camera, LightField, Object, Scene};
use relight_sphere::EnvMap;
use std::sync::Arc;

/// The verify light's texture at `size²` texels: warm and cool halves, a
/// stripe band and a bright spot (all frequencies the heuristic must track).
#[must_use]
pub fn test_texture(size: usize) -> Texture {
    Texture::stripes_and_spot(size, 0.55, 3.0)
}

/// A downward ceiling light at `center` of `size`, with the test texture.
#[must_use]
pub fn ceiling_light(center: Vec3, size: Vec2, intensity: f32) -> AreaLight {
    AreaLight {
        center,
        size,
        // x̂ = X, ŷ = Z, ẑ = −Y: emits downwards (right-handed).
        world_from_light: Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y),
        intensity: Vec3::splat(intensity),
        texture: Some(Arc::new(test_texture(64))),
        light_field: None,
    }
}

/// A floor of `(floor + 1)²` vertices (side 4) and a sphere of
/// `segments × segments/2` quads (radius 0.45) on it, under
/// [`ceiling_light`] at height 1.6, seen by a `width × height` camera.
#[must_use]
pub fn floor_and_sphere(
    floor: usize,
    segments: usize,
    width: usize,
    height: usize,
    visibility: bool,
) -> Scene {
    let lambert = |a: f32| -> Arc<dyn relight_brdf::Brdf> {
        Arc::new(Lambert::new(Vec3::splat(a)).expect("valid albedo"))
    };
    let objects = vec![
        Object::new(
            Arc::new(uv_sphere_at(
                Vec3::new(0.25, 0.45, 0.15),
                0.45,
                segments,
                (segments / 2).max(2),
            )),
            lambert(0.8),
        ),
        Object::new(Arc::new(plane(4.0, floor)), lambert(0.7)),
    ];
    let env = EnvMap::black();
    let camera = Camera {
        eye: Vec3::new(0.0, 2.0, 3.4),
        target: Vec3::new(0.0, 0.3, 0.0),
        up: Vec3::Y,
        vfov_deg: 45.0,
        width,
        height,
        image_offset: Vec2::ZERO,
    };
    let mut s = Scene::new(objects, env, camera);
    s.visibility = visibility;
    s.area_lights.push(ceiling_light(
        Vec3::new(0.0, 1.6, 0.0),
        Vec2::new(1.6, 1.0),
        3.0,
    ));
    s
}

/// The BRDFs of [`glossy_floor_and_sphere`]: the sphere a coloured diffuse
/// base under a white GGX lobe (α 0.25; its colour changes with
/// direction: an RGB fixed-view transport), the floor a grey normalised
/// Phong lobe (exponent 20; one channel).
#[must_use]
pub fn glossy_brdfs() -> [Arc<dyn relight_brdf::Brdf>; 2] {
    let base: Arc<dyn relight_brdf::Brdf> =
        Arc::new(Lambert::new(Vec3::new(0.8, 0.45, 0.25)).expect("valid albedo"));
    let lobe: Arc<dyn relight_brdf::Brdf> =
        Arc::new(relight_brdf::Ggx::isotropic(0.25, Vec3::splat(0.9)).expect("valid GGX"));
    let sphere: Arc<dyn relight_brdf::Brdf> =
        Arc::new(relight_brdf::Mix::new(vec![(0.5, base), (0.5, lobe)]).expect("valid mix"));
    let floor: Arc<dyn relight_brdf::Brdf> =
        Arc::new(relight_brdf::Phong::new(20.0, Vec3::splat(0.7)).expect("valid Phong"));
    [sphere, floor]
}

/// [`floor_and_sphere`] with the glossy BRDFs of [`glossy_brdfs`]: the
/// fixed-view specular rows of `verify nearfield`.
#[must_use]
pub fn glossy_floor_and_sphere(
    floor: usize,
    segments: usize,
    width: usize,
    height: usize,
    visibility: bool,
) -> Scene {
    let mut s = floor_and_sphere(floor, segments, width, height, visibility);
    for (o, b) in s.objects.iter_mut().zip(glossy_brdfs()) {
        o.brdf = b;
    }
    s
}

/// [`floor_and_sphere`] lit by three lights in two planes (the method's
/// module docs, "Several lights"): the textured ceiling light, a second,
/// plain ceiling panel in the same plane turned 90° (it shares the first
/// one's transport through its bounding rectangle), and a textured wall
/// light facing `+X` beyond the floor's edge (its own plane, its own
/// transport; no camera ray through it meets an object).
#[must_use]
pub fn floor_and_sphere_three_lights(
    floor: usize,
    segments: usize,
    width: usize,
    height: usize,
    visibility: bool,
) -> Scene {
    let mut s = floor_and_sphere(floor, segments, width, height, visibility);
    s.area_lights.push(AreaLight {
        center: Vec3::new(-1.0, 1.6, -0.8),
        size: Vec2::new(0.6, 0.4),
        // The first light's axes turned 90° about its normal −Y.
        world_from_light: Mat3::from_cols(Vec3::Z, -Vec3::X, -Vec3::Y),
        intensity: Vec3::new(2.0, 1.8, 1.5),
        texture: None,
        light_field: None,
    });
    s.area_lights.push(AreaLight {
        center: Vec3::new(-2.2, 0.8, 0.0),
        size: Vec2::new(0.8, 0.6),
        // x̂ = −Z, ŷ = Y, ẑ = X: emits towards +X (right-handed).
        world_from_light: Mat3::from_cols(-Vec3::Z, Vec3::Y, Vec3::X),
        intensity: Vec3::splat(2.5),
        texture: Some(Arc::new(test_texture(32))),
        light_field: None,
    });
    s
}

/// [`floor_and_sphere`] with its light's texture seen through the built-in
/// prism light field ([`LightField::prism`]) of `views²` views over slopes
/// `[−extent, extent]²`; extent 2 puts the views' edges on the face cells
/// of face 4 at the floor (depth 1.6) for every power-of-two order ≥ views.
#[must_use]
pub fn floor_and_sphere_light_field(
    floor: usize,
    segments: usize,
    [width, height]: [usize; 2],
    visibility: bool,
    views: usize,
    extent: f32,
) -> Scene {
    let mut s = floor_and_sphere(floor, segments, width, height, visibility);
    let light = &mut s.area_lights[0];
    let base = light.texture.take().expect("the ceiling light is textured");
    light.light_field = Some(Arc::new(LightField::prism(&base, views, extent)));
    s
}
