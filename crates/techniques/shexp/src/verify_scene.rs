//! `relight verify shexp`, the image rows: the method's receivers against
//! ray-traced visibility of the real meshes.
//!
//! * **Spheres on a floor** (n = 4): a floor under a smooth sky
//!   ([`crate::verify::test_lighting`]'s function as an environment map) with
//!   moving sphere blockers; per floor vertex the method's radiance against
//!   a stratified cosine-weighted Monte Carlo estimate of `ρ ∫ L V cos/π`
//!   with the visibility ray-traced against the sphere meshes
//!   ([`REFERENCE_STRATA`]² rays per vertex). Target: relative RMS ≤ 5 %.
//! * **Ambient occlusion**: the same scene under a constant white
//!   environment against the BVH's per-vertex ambient occlusion
//!   (`relight_render::SceneBvh::vertex_ambient_occlusion`). Target ≤ 3 %.
//! * **A mesh blocker with 32 / 64 / 128 spheres** (the bunny when given)
//!   against its own mesh shadow: reported as a curve, no target.

use crate::method::{ShExpMethod, ShExpOptions};
use crate::verify::VerifyRow;
use glam::{Quat, Vec3};
use relight_geom::Mesh;
use relight_render::method::Relighter;
use relight_render::{Animation, Camera, Keyframe, NoProgress, Object, Rng, Scene, SceneBvh};
use relight_sphere::{EnvMap, Param};
use std::sync::Arc;

/// Strata per side of the reference's rays per vertex.
pub const REFERENCE_STRATA: usize = 24;

/// A still animation (one key): marks an object as a dynamic blocker.
fn hold() -> Arc<Animation> {
    Arc::new(
        Animation::try_new(vec![Keyframe {
            time: 0.0,
            translate: Vec3::ZERO,
            rotation: Quat::IDENTITY,
            scale: 1.0,
        }])
        .expect("valid key"),
    )
}

/// The sky of the image rows: `0.5 + 3 max(0, s·sun)⁸` (smooth, so order 4
/// holds the lighting and the error measured is the shadow's).
#[must_use]
pub fn sky() -> EnvMap {
    let sun = Vec3::new(0.3, 0.85, 0.4).normalize();
    EnvMap::from_fn(
        Param::LatLong {
            width: 128,
            height: 64,
        },
        |d| Vec3::splat(0.5 + 3.0 * d.dot(sun).max(0.0).powi(8)),
    )
}

/// A floor (static, flat receiver) with `blockers` (dynamic) under `env`.
#[must_use]
pub fn floor_scene(blockers: Vec<Mesh>, env: EnvMap, floor_n: usize) -> Scene {
    let lambert = Arc::new(relight_brdf::Lambert::new(Vec3::splat(0.8)).expect("valid albedo"));
    let floor = relight_geom::shapes::plane(4.0, floor_n);
    let mut objects = vec![Object::new(Arc::new(floor), lambert.clone())];
    for m in blockers {
        let mut o = Object::new(Arc::new(m), lambert.clone());
        o.animation = Some(hold());
        objects.push(o);
    }
    let camera = Camera {
        eye: Vec3::new(0.0, 3.0, 4.5),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
        width: 96,
        height: 64,
        image_offset: glam::Vec2::ZERO,
    };
    let mut s = Scene::new(objects, env, camera);
    s.visibility = true;
    s
}

/// Ray-traced `ρ ∫ L V cos/π` at every vertex of object 0 of `scene`.
fn reference_floor(scene: &Scene, strata: usize) -> Vec<Vec3> {
    use rayon::prelude::*;
    let bvh = SceneBvh::from_scene(scene);
    let floor = &scene.objects[0].mesh;
    let albedo = 0.8;
    (0..floor.positions.len())
        .into_par_iter()
        .map(|v| {
            let n = floor
                .normals
                .get(v)
                .copied()
                .unwrap_or(Vec3::Y)
                .normalize_or(Vec3::Y);
            let frame = relight_sphere::Frame::from_z(n);
            let o = relight_render::bvh::offset_ray_origin(floor.positions[v], n);
            let mut rng = Rng::new(99, v as u64);
            let mut sum = Vec3::ZERO;
            for a in 0..strata {
                for b in 0..strata {
                    let u = (a as f32 + rng.next_f32()) / strata as f32;
                    let s = (b as f32 + rng.next_f32()) / strata as f32;
                    let r = u.sqrt();
                    let phi = 2.0 * std::f32::consts::PI * s;
                    let d = frame
                        .from_local(Vec3::new(
                            r * phi.cos(),
                            r * phi.sin(),
                            (1.0 - u).max(0.0).sqrt(),
                        ))
                        .normalize();
                    if !bvh.occluded(o, d, f32::INFINITY) {
                        sum += scene.env_radiance(d);
                    }
                }
            }
            sum * (albedo / (strata * strata) as f32)
        })
        .collect()
}

fn rel_rms(a: &[Vec3], b: &[Vec3]) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (x, y) in a.iter().zip(b) {
        num += f64::from((*x - *y).length_squared());
        den += f64::from(y.length_squared());
    }
    (num / den.max(1e-30)).sqrt()
}

/// The method's floor radiance for `scene` with `options`.
///
/// # Errors
/// As the method.
pub fn method_floor(
    scene: &Scene,
    options: ShExpOptions,
) -> Result<Vec<Vec3>, relight_render::method::MethodError> {
    // The floor is dense already: shade its own vertices.
    let mut m = ShExpMethod::new(ShExpOptions {
        flat_receiver_vertices: 0,
        ..options
    })?;
    m.prepare(scene, &NoProgress)?;
    m.shade_vertices(scene)?;
    Ok(m.vertex_colors()[0].clone())
}

/// Three spheres of radius 0.35–0.6 at heights 0.45–0.9 over the floor.
#[must_use]
pub fn floor_spheres() -> Vec<Mesh> {
    vec![
        relight_geom::shapes::uv_sphere_at(Vec3::new(-0.9, 0.6, 0.0), 0.45, 32, 16),
        relight_geom::shapes::uv_sphere_at(Vec3::new(0.8, 0.9, 0.5), 0.6, 32, 16),
        relight_geom::shapes::uv_sphere_at(Vec3::new(0.2, 0.45, -0.9), 0.35, 32, 16),
    ]
}

/// The image rows (`floor_n`: floor grid cells per side; `mesh`: the bunny
/// or another blocker mesh for the sphere-count curve, `None` to skip it).
///
/// # Errors
/// As the method.
pub fn verify_scene(
    floor_n: usize,
    mesh: Option<&Mesh>,
) -> Result<Vec<VerifyRow>, relight_render::method::MethodError> {
    let mut rows = Vec::new();
    let opts = ShExpOptions::default();
    // Spheres on a floor, n = 4.
    let scene = floor_scene(floor_spheres(), sky(), floor_n);
    let got = method_floor(&scene, opts)?;
    let want = reference_floor(&scene, REFERENCE_STRATA);
    let e = rel_rms(&got, &want);
    rows.push(VerifyRow {
        check: format!(
            "spheres on a floor, n = {}, {} receivers",
            opts.order,
            got.len()
        ),
        measured: format!("relative RMS {:.2} %", 100.0 * e),
        target: "≤ 5 %".into(),
        source: "issue 15 (reference: ray-traced visibility of the sphere meshes)".into(),
        pass: Some(e <= 0.05),
    });
    // Ambient occlusion under a constant environment.
    let white = EnvMap::from_fn(
        Param::LatLong {
            width: 8,
            height: 4,
        },
        |_| Vec3::ONE,
    );
    let scene = floor_scene(floor_spheres(), white, floor_n);
    let got = method_floor(&scene, opts)?;
    let ao = SceneBvh::from_scene(&scene)
        .vertex_ambient_occlusion(
            0,
            (REFERENCE_STRATA * REFERENCE_STRATA) as u32,
            5,
            &NoProgress,
        )
        .map_err(relight_render::method::MethodError::from)?;
    let want: Vec<Vec3> = ao.iter().map(|a| Vec3::splat(0.8 * a)).collect();
    let e = rel_rms(&got, &want);
    rows.push(VerifyRow {
        check: "constant environment vs per-vertex ambient occlusion".into(),
        measured: format!("relative RMS {:.2} %", 100.0 * e),
        target: "≤ 3 %".into(),
        source: "issue 15 (reference: BVH vertex ambient occlusion)".into(),
        pass: Some(e <= 0.03),
    });
    // A mesh blocker by 32 / 64 / 128 spheres against its own mesh shadow.
    if let Some(mesh) = mesh {
        let mut m = mesh.clone();
        // Unit size, resting 0.3 above the floor's centre.
        m.normalize_to_unit_box();
        let b = m.bounds().expect("non-empty mesh");
        let lift = glam::Affine3A::from_translation(Vec3::new(0.0, 0.3 - 1.5 * b.min.y, 0.0))
            * glam::Affine3A::from_scale(Vec3::splat(1.5));
        let m = m.transformed(lift);
        let scene = floor_scene(vec![m], sky(), floor_n);
        let want = reference_floor(&scene, REFERENCE_STRATA);
        let mut curve = Vec::new();
        for k in [32, 64, 128] {
            let got = method_floor(&scene, ShExpOptions { spheres: k, ..opts })?;
            curve.push(format!("{k}: {:.2} %", 100.0 * rel_rms(&got, &want)));
        }
        rows.push(VerifyRow {
            check: "mesh blocker by 32 / 64 / 128 spheres vs its own mesh shadow".into(),
            measured: format!("relative RMS {}", curve.join(", ")),
            target: "reported (a curve)".into(),
            source: "issue 15".into(),
            pass: None,
        });
    }
    Ok(rows)
}
