//! `relight bench reference`: throughput of the reference renderer on a
//! built-in scene (a 65 K-triangle sphere on a floor under a sky with a sun),
//! with and without shadows, with a point and an area light, and in a fog
//! ball in both medium modes.

use super::lights::EnvLight;
use super::render::render_reference_with;
use super::{MediumMode, ReferenceOptions};
use crate::bvh::SceneBvh;
use crate::sampling::EnvFilter;
use crate::{AreaLight, Camera, Medium, NoProgress, Object, PointLight, Scene};
use glam::{Mat3, Vec2, Vec3};
use relight_brdf::{Brdf, Lambert};
use relight_geom::Mesh;
use relight_sphere::{EnvMap, Param};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// One throughput measurement of the reference renderer (`relight bench`).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ReferenceBenchRow {
    /// Scene description (what the row adds to the base scene).
    pub scene: String,
    /// Shadow rays traced (visibility on).
    pub visibility: bool,
    pub width: usize,
    pub height: usize,
    pub spp: u32,
    pub triangles: usize,
    /// Rayon threads used.
    pub threads: usize,
    /// Camera, shadow and scattered rays traced.
    pub rays: u64,
    /// Sampling time, seconds (BVH build excluded).
    pub seconds: f64,
    /// Rays per second (every ray).
    pub rays_per_s: f64,
    /// Camera samples (pixel samples) per second.
    pub samples_per_s: f64,
    /// Self-reported relative standard error of the image.
    pub relative_std_error: f64,
    /// BVH build time, milliseconds.
    pub bvh_build_ms: f64,
}

/// A square floor at height `y`, facing +Y.
pub(crate) fn floor_quad(y: f32, half: f32) -> Mesh {
    Mesh {
        positions: vec![
            Vec3::new(-half, y, -half),
            Vec3::new(half, y, -half),
            Vec3::new(half, y, half),
            Vec3::new(-half, y, half),
        ],
        normals: vec![Vec3::Y; 4],
        indices: vec![[0, 2, 1], [0, 3, 2]],
        ..Default::default()
    }
}

/// A lat-long sky of `width × width/2` texels: blue gradient above, grey
/// ground below, and a small sun of radiance `sun` within `sun_radius_deg` of
/// `sun_dir` (high dynamic range). The bench's sky, and the tests'.
#[must_use]
pub fn sun_sky(width: usize, sun_dir: Vec3, sun_radius_deg: f32, sun: f32) -> EnvMap {
    let sun_dir = sun_dir.normalize();
    let cos_r = sun_radius_deg.to_radians().cos();
    EnvMap::from_fn(
        Param::LatLong {
            width,
            height: width / 2,
        },
        |d| {
            let base = if d.y >= 0.0 {
                Vec3::new(0.3, 0.5, 0.9).lerp(Vec3::new(0.8, 0.9, 1.0), 1.0 - d.y)
            } else {
                Vec3::splat(0.25)
            };
            if d.dot(sun_dir) >= cos_r {
                base + Vec3::splat(sun)
            } else {
                base
            }
        },
    )
}

/// The built-in benchmark scene: a 128 × 256 UV sphere (65 K triangles) on a
/// floor under a sky with a sun, seen at `width × height`.
fn bench_scene(width: usize, height: usize) -> Scene {
    let brdf: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::splat(0.8)).expect("albedo in [0, 1]"));
    Scene::new(
        vec![
            Object::new(
                Arc::new(relight_geom::shapes::uv_sphere_at(
                    Vec3::new(0.0, 1.0, 0.0),
                    1.0,
                    256,
                    128,
                )),
                brdf.clone(),
            ),
            Object::new(Arc::new(floor_quad(0.0, 20.0)), brdf),
        ],
        sun_sky(512, Vec3::new(0.5, 1.0, 0.3), 1.5, 2000.0),
        Camera {
            eye: Vec3::new(0.0, 1.6, 4.0),
            target: Vec3::new(0.0, 0.9, 0.0),
            up: Vec3::Y,
            vfov_deg: 45.0,
            width,
            height,
            image_offset: glam::Vec2::ZERO,
        },
    )
}

/// Throughput of the reference renderer on the built-in scene at
/// `width × height` and `spp`, on the current rayon pool: environment only
/// without and with shadows; plus a point and an area light; in a fog ball
/// (single, then multiple scattering).
#[must_use]
pub fn bench_reference(width: usize, height: usize, spp: u32) -> Vec<ReferenceBenchRow> {
    let base = bench_scene(width.max(1), height.max(1));
    let t0 = Instant::now();
    let bvh = SceneBvh::from_scene(&base);
    let bvh_build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let light = EnvLight::new(&base.env, EnvFilter::Nearest);
    let mut lit = base.clone();
    lit.visibility = true;
    lit.point_lights.push(PointLight::new(
        Vec3::new(-1.5, 2.5, 1.0),
        Vec3::splat(20.0),
    ));
    lit.area_lights.push(AreaLight {
        center: Vec3::new(1.5, 3.0, 0.5),
        size: Vec2::new(1.0, 0.5),
        world_from_light: Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y),
        intensity: Vec3::splat(10.0),
        texture: None,
        light_field: None,
    });
    let mut fog = lit.clone();
    fog.medium = Some(Medium {
        beta: 0.15,
        albedo: 0.9,
        radius: 8.0,
    });
    let mut plain = base.clone();
    plain.visibility = false;
    let mut shadowed = base.clone();
    shadowed.visibility = true;
    let cases = [
        ("environment", &plain, MediumMode::default()),
        ("environment", &shadowed, MediumMode::default()),
        ("+ point and area light", &lit, MediumMode::default()),
        (
            "+ fog ball β 0.15 albedo 0.9, single scattering",
            &fog,
            MediumMode::SingleScattering,
        ),
        (
            "+ fog ball β 0.15 albedo 0.9, multiple scattering",
            &fog,
            MediumMode::MultipleScattering,
        ),
    ];
    cases
        .into_iter()
        .filter_map(|(what, scene, medium_mode)| {
            let opts = ReferenceOptions {
                spp: spp.max(1),
                pass_spp: spp.max(1),
                seed: 1,
                medium_mode,
                ..ReferenceOptions::default()
            };
            let r = render_reference_with(scene, &bvh, &light, &opts, &NoProgress).ok()?;
            Some(ReferenceBenchRow {
                scene: format!("uv-sphere 65K tris + floor, sun sky 512x256, {what}"),
                visibility: scene.visibility,
                width: scene.camera.width,
                height: scene.camera.height,
                spp: opts.spp,
                triangles: bvh.triangle_count(),
                threads: rayon::current_num_threads(),
                rays: r.rays,
                seconds: r.seconds,
                rays_per_s: r.rays as f64 / r.seconds.max(1e-9),
                samples_per_s: (scene.camera.width * scene.camera.height) as f64
                    * f64::from(opts.spp)
                    / r.seconds.max(1e-9),
                relative_std_error: r.relative_std_error,
                bvh_build_ms,
            })
        })
        .collect()
}
