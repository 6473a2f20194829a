//! The embedded default scene (generated in code, no files), the built-in
//! procedural meshes scene files can name, and the camera that frames a set
//! of objects when a scene gives none.
//!
//! The default scene is what `relight demo` renders and what every
//! `relight verify` measures first: an all-frequency studio environment
//! ([`crate::studio`], with a sun) over three procedural objects — a glossy
//! sphere, a diffuse torus and a detailed knot — standing on a grey floor
//! that catches their shadows (where a method renders visibility), seen by a
//! fixed camera.

use crate::studio::studio_environment;
use glam::{Affine3A, Quat, Vec3};
use relight_brdf::{Brdf, BrdfSpec};
use relight_geom::Mesh;
use relight_render::{Camera, Object, Scene};
use std::sync::Arc;

/// Height of the embedded studio environment's lat-long map (width = 2×).
pub const STUDIO_HEIGHT: usize = 256;

/// Names accepted by [`builtin_mesh`].
pub const BUILTIN_MESHES: [&str; 5] = ["sphere", "torus", "knot", "ground", "ground-grid"];

/// A procedural mesh by name (`sphere`, `torus`, `knot`, `ground`,
/// `ground-grid`: the ground split into 128 × 128 quads for per-vertex
/// methods), unit-sized and centred at the origin, with normals, uvs and
/// tangents.
pub fn builtin_mesh(name: &str) -> Option<Mesh> {
    use relight_geom::shapes;
    let mut mesh = match name {
        "sphere" => shapes::uv_sphere(1.0, 192, 96),
        "torus" => shapes::torus(0.75, 0.28, 256, 96),
        "knot" => shapes::detailed_shape(),
        "ground" => shapes::quad(4.0),
        "ground-grid" => shapes::plane(4.0, 128),
        _ => return None,
    };
    mesh.validate_and_repair();
    Some(mesh)
}

fn brdf(spec: &str) -> Arc<dyn Brdf> {
    spec.parse::<BrdfSpec>()
        .expect("built-in BRDF spec is valid")
        .build()
}

fn placed(name: &str, translate: Vec3, scale: f32) -> Arc<Mesh> {
    let mesh = builtin_mesh(name).expect("built-in mesh name");
    Arc::new(mesh.transformed(Affine3A::from_scale_rotation_translation(
        Vec3::splat(scale),
        Quat::IDENTITY,
        translate,
    )))
}

/// The camera of the default scene at `width × height` pixels.
#[must_use]
pub fn default_camera(width: usize, height: usize) -> Camera {
    Camera {
        eye: Vec3::new(0.0, 1.4, 5.2),
        target: Vec3::new(0.0, 0.35, 0.0),
        up: Vec3::Y,
        vfov_deg: 38.0,
        width,
        height,
        image_offset: glam::Vec2::ZERO,
    }
}

/// Half side of the default scene's floor (scene units): far enough that its
/// edge lies within a degree of the horizon seen from the default camera.
pub const FLOOR_HALF_SIDE: f32 = 100.0;

/// Half side of the floor's uniform inner square, which holds every object
/// and shadow (scene units).
const FLOOR_INNER_HALF_SIDE: f32 = 3.0;

/// Grid spacing of the inner square (scene units).
const FLOOR_SPACING: f32 = 0.05;

/// Growth of each cell over the previous one outside the inner square.
const FLOOR_GROWTH: f32 = 1.2;

/// The grid coordinates of the floor along one axis, from −[`FLOOR_HALF_SIDE`]
/// to +: uniform at [`FLOOR_SPACING`] inside ±[`FLOOR_INNER_HALF_SIDE`], then
/// cells growing geometrically by [`FLOOR_GROWTH`], the last one stretched to
/// end at the edge.
fn floor_coordinates() -> Vec<f32> {
    let inner = (FLOOR_INNER_HALF_SIDE / FLOOR_SPACING).round() as usize;
    let mut half: Vec<f32> = (0..=inner).map(|i| i as f32 * FLOOR_SPACING).collect();
    let mut step = FLOOR_SPACING;
    loop {
        step *= FLOOR_GROWTH;
        let last = *half.last().expect("not empty");
        if last + step >= FLOOR_HALF_SIDE {
            // The remainder joins the last cell, so cells never shrink.
            half.pop();
            half.push(FLOOR_HALF_SIDE);
            break;
        }
        half.push(last + step);
    }
    let mut all: Vec<f32> = half.iter().rev().map(|x| -x).collect();
    all.extend(&half[1..]);
    all
}

/// The default scene's floor: a square in XZ at y = 0 facing +Y, half side
/// [`FLOOR_HALF_SIDE`], on a grid that is uniform (spacing 0.05) over the
/// 6 × 6 square holding the objects and their shadows and grows by 20 % a
/// cell beyond it: per-vertex methods (wavelet AO) resolve contact shadows
/// where they fall, with 33.5 K vertices instead of the 16 M a uniform grid of
/// that spacing would need, and the floor reaches within a degree of the
/// horizon. Normals +Y, uvs over [0, 1]² (not used by the default scene).
#[must_use]
pub fn floor_mesh() -> Mesh {
    let xs = floor_coordinates();
    let n = xs.len() - 1;
    let mut m = relight_geom::shapes::plane(1.0, n);
    // `plane` places vertex (i, j) at ((i/n − ½), 0, (j/n − ½)): move each
    // to its grid coordinate.
    for p in &mut m.positions {
        let i = ((p.x + 0.5) * n as f32).round() as usize;
        let j = ((p.z + 0.5) * n as f32).round() as usize;
        *p = Vec3::new(xs[i.min(n)], 0.0, xs[j.min(n)]);
    }
    m.validate_and_repair();
    m
}

/// The default scene's floor material: a grey Lambertian of albedo 0.25
/// (under the sun's 4.2 of irradiance it shows mid-grey, and its shadows
/// clearly).
pub const FLOOR_BRDF: &str = "lambert:0.25";

/// The embedded default scene at `width × height` pixels: the studio
/// environment, a glossy gold sphere (GGX α = 0.2), a red Phong knot
/// (exponent 40) and a white diffuse torus on a grey floor ([`floor_mesh`],
/// the last object). Generated in code; needs no files. Visibility is off
/// (the unshadowed integral SH and wavelet shading compute); set
/// `scene.visibility` for the floor to show the objects' shadows.
///
/// The meshes are as dense as the paper's models (wavelet-rotation-2006 §3
/// shades 30–120 K-vertex models per vertex): 18.7 K / 131.8 K / 24.9 K
/// vertices (and 33.5 K for the floor), so per-vertex (Gouraud) methods
/// sample the glossy highlights of the 1.5° sun instead of skipping between
/// vertices.
#[must_use]
pub fn default_scene(width: usize, height: usize) -> Scene {
    let objects = vec![
        Object::new(
            placed("sphere", Vec3::new(-1.55, 0.55, 0.0), 0.55),
            brdf("ggx:0.2@1,0.78,0.34"),
        ),
        Object::new(
            placed("knot", Vec3::new(0.0, 0.6, -0.2), 0.6),
            brdf("phong:40@0.9,0.25,0.2"),
        ),
        Object::new(
            placed("torus", Vec3::new(1.55, 0.55, 0.0), 0.6),
            brdf("lambert:0.8"),
        ),
        Object::new(Arc::new(floor_mesh()), brdf(FLOOR_BRDF)),
    ];
    Scene::new(
        objects,
        studio_environment(STUDIO_HEIGHT),
        default_camera(width, height),
    )
}

/// The same scene with every object's material replaced by `brdf`
/// (what `relight verify` uses to compare methods material by material).
#[must_use]
pub fn with_brdf(scene: &Scene, brdf: &Arc<dyn Brdf>) -> Scene {
    let mut s = scene.clone();
    for o in &mut s.objects {
        o.brdf = brdf.clone();
    }
    s
}

/// A camera that frames all `objects` from the front (+Z), slightly above.
#[must_use]
pub fn framing_camera(objects: &[Object], width: usize, height: usize, vfov_deg: f32) -> Camera {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for o in objects {
        for p in &o.mesh.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    if lo.x > hi.x {
        (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
    }
    let center = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-3);
    let aspect = width as f32 / height.max(1) as f32;
    let half = 0.5 * vfov_deg.to_radians();
    let half_h = (half.tan() * aspect).atan();
    let dist = radius / half.min(half_h).sin() * 1.05;
    let dir = Vec3::new(0.0, 0.3, 1.0).normalize();
    Camera {
        eye: center + dir * dist,
        target: center,
        up: Vec3::Y,
        vfov_deg,
        width,
        height,
        image_offset: glam::Vec2::ZERO,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_scene_meshes_are_dense_and_valid() {
        let s = default_scene(64, 36);
        let counts: Vec<usize> = s.objects.iter().map(|o| o.mesh.vertex_count()).collect();
        assert_eq!(
            counts,
            [193 * 97, 513 * 257, 257 * 97, 183 * 183],
            "{counts:?}"
        );
        for o in &s.objects {
            assert!(o.mesh.try_validate().is_ok());
        }
    }

    #[test]
    fn the_floor_is_under_the_objects_graded_and_facing_up() {
        let s = default_scene(64, 36);
        let (floor, objects) = s.objects.split_last().unwrap();
        let f = &floor.mesh;
        let lo = f.positions.iter().fold(Vec3::MAX, |a, p| a.min(*p));
        let hi = f.positions.iter().fold(Vec3::MIN, |a, p| a.max(*p));
        assert!((lo.x + FLOOR_HALF_SIDE).abs() < 1e-4 && (hi.z - FLOOR_HALF_SIDE).abs() < 1e-4);
        assert!(lo.y == 0.0 && hi.y == 0.0);
        assert!(f.normals.iter().all(|n| (*n - Vec3::Y).length() < 1e-6));
        // Every object stands on (or just above) the floor, inside it.
        for o in objects {
            let min_y = o
                .mesh
                .positions
                .iter()
                .map(|p| p.y)
                .fold(f32::MAX, f32::min);
            assert!((-0.05..0.45).contains(&min_y), "object bottom at {min_y}");
        }
        // Graded: fine under the objects, coarse at the edge.
        let mut xs: Vec<f32> = f.positions.iter().map(|p| p.x).collect();
        xs.sort_by(f32::total_cmp);
        xs.dedup();
        let centre = xs.iter().position(|x| *x >= 0.0).unwrap();
        let fine = xs[centre + 1] - xs[centre];
        let coarse = xs[xs.len() - 1] - xs[xs.len() - 2];
        assert!((fine - 0.05).abs() < 1e-4, "inner spacing {fine}");
        assert!(coarse > 5.0, "edge spacing {coarse}");
        let inner = xs.iter().filter(|x| x.abs() <= 3.0 + 1e-4).count();
        assert_eq!(inner, 121);
        // Grows, never shrinks, from the centre out.
        for w in xs[centre..].windows(3) {
            assert!(w[2] - w[1] >= w[1] - w[0] - 1e-4, "{w:?}");
        }
        // Faces wind counter-clockwise seen from above.
        let t = f.indices[0].map(|i| f.positions[i as usize]);
        assert!((t[1] - t[0]).cross(t[2] - t[0]).y > 0.0);
    }
}
