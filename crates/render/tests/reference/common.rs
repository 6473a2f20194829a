//! Scenes and measures shared by the reference tests.

use glam::Vec3;
use relight_brdf::{Brdf, Lambert};
use relight_render::bvh::SceneBvh;
use relight_render::sampling::luminance;
use relight_render::{Camera, Image, Object, ReferenceImage, Scene};
use relight_sphere::{EnvMap, Param};
use std::sync::Arc;

pub fn constant_env(value: f32) -> EnvMap {
    let param = Param::LatLong {
        width: 32,
        height: 16,
    };
    EnvMap::try_new(param, vec![Vec3::splat(value); param.len()]).unwrap()
}

pub fn black_env() -> EnvMap {
    constant_env(0.0)
}

pub use relight_render::reference::sun_sky;

pub fn lambert(albedo: f32) -> Arc<dyn Brdf> {
    Arc::new(Lambert::new(Vec3::splat(albedo)).expect("albedo in [0, 1]"))
}

pub fn camera(eye: Vec3, target: Vec3, vfov_deg: f32, width: usize, height: usize) -> Camera {
    Camera {
        eye,
        target,
        up: if (target - eye).normalize().y.abs() > 0.99 {
            Vec3::Z
        } else {
            Vec3::Y
        },
        vfov_deg,
        width,
        height,
        image_offset: glam::Vec2::ZERO,
    }
}

/// A unit UV sphere (with tangents) at the origin seen from +Z.
pub fn sphere_scene(env: EnvMap, brdf: Arc<dyn Brdf>, size: usize) -> Scene {
    let mut mesh = relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 96, 48);
    if mesh.tangents.is_empty() {
        mesh.tangents = mesh.compute_tangents();
    }
    Scene::new(
        vec![Object::new(Arc::new(mesh), brdf)],
        env,
        camera(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, 40.0, size, size),
    )
}

/// Pixels whose four corner rays all hit object `object` first.
pub fn object_mask(scene: &Scene, object: u32) -> Vec<bool> {
    let bvh = SceneBvh::from_scene(scene);
    let (w, h) = (scene.camera.width, scene.camera.height);
    (0..w * h)
        .map(|i| {
            [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .iter()
                .all(|&(dx, dy)| {
                    let (o, d) = scene.camera.ray((i % w) as f32 + dx, (i / w) as f32 + dy);
                    bvh.intersect(o, d, 0.0, f32::INFINITY)
                        .is_some_and(|h| h.object == object)
                })
        })
        .collect()
}

/// Mean luminance over the masked pixels and the standard error of that
/// mean from the renderer's per-pixel standard errors: `(mean, σ_mean, n)`.
pub fn masked_mean(r: &ReferenceImage, mask: &[bool]) -> (f64, f64, usize) {
    let (mut sum, mut var, mut n) = (0.0f64, 0.0f64, 0usize);
    for ((p, se), &m) in r.image.pixels.iter().zip(&r.std_error).zip(mask) {
        if m {
            sum += f64::from(luminance(*p));
            var += f64::from(*se).powi(2);
            n += 1;
        }
    }
    let n_f = n.max(1) as f64;
    (sum / n_f, var.sqrt() / n_f, n)
}

/// Luminance image.
pub fn lum(img: &Image) -> Vec<f64> {
    img.pixels
        .iter()
        .map(|p| f64::from(luminance(*p)))
        .collect()
}
