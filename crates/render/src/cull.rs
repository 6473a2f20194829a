//! Back-face culling that cannot change what a rasterizing method shows.
//!
//! Seen from outside, a closed mesh whose faces all point outwards hides
//! each of its back faces behind one of its own front faces: every ray from
//! the eye that reaches the solid enters it through a front face first. The
//! rasterizer may then skip the back faces (about half the triangles) and
//! still write the same visibility buffer. From inside the solid the back
//! faces are what shows, so the rule culls only while the eye is outside
//! the mesh's bounding box (outside the box is outside the solid).
//!
//! Whether a mesh is closed and outward ([`Mesh::is_closed_outward`]) costs a
//! sort of its edges, so [`ClosedMeshes`] works it out once per mesh.

use crate::Scene;
use crate::raster::CullMode;
use glam::Vec3;
use rayon::prelude::*;
use relight_geom::{Aabb, Mesh};
use std::sync::Arc;

/// The culling for a mesh with `closed` = its bounds where it is closed and
/// outward-oriented ([`ClosedMeshes`]), seen from `eye`: [`CullMode::Back`]
/// from outside those bounds, else [`CullMode::None`] (an open mesh, or an
/// eye inside the bounds and perhaps inside the solid).
#[must_use]
pub fn cull_for_closed(closed: Option<&Aabb>, eye: Vec3) -> CullMode {
    match closed {
        Some(b) if !b.contains(eye) => CullMode::Back,
        _ => CullMode::None,
    }
}

/// Per object of a scene, its mesh's bounds where the mesh is closed and
/// outward-oriented, else `None`: what [`cull_for_closed`] takes. Each mesh
/// is examined once and kept while an object holds the same mesh (the same
/// `Arc`; the cache holds it, so its address is never another mesh's).
#[derive(Clone, Debug, Default)]
pub struct ClosedMeshes {
    meshes: Vec<(Arc<Mesh>, Option<Aabb>)>,
    disabled: bool,
}

impl ClosedMeshes {
    /// A cache that reports every mesh open, so that nothing is culled (for
    /// comparing against drawing both sides).
    #[must_use]
    pub fn disabled() -> Self {
        Self {
            meshes: Vec::new(),
            disabled: true,
        }
    }

    /// The bounds of `scene`'s closed meshes, object by object (examining
    /// the meshes not seen before, in parallel).
    pub fn of(&mut self, scene: &Scene) -> Vec<Option<Aabb>> {
        let meshes: Vec<&Arc<Mesh>> = scene.objects.iter().map(|o| &o.mesh).collect();
        self.of_meshes(&meshes)
    }

    /// [`Self::of`] for meshes a method draws in place of the scene's (a
    /// coarse object's refined copy).
    pub fn of_meshes(&mut self, meshes: &[&Arc<Mesh>]) -> Vec<Option<Aabb>> {
        if self.disabled {
            return vec![None; meshes.len()];
        }
        let same = crate::method::same_mesh_list(
            self.meshes.iter().map(|(m, _)| m),
            meshes.iter().copied(),
        );
        if !same {
            let old = std::mem::take(&mut self.meshes);
            self.meshes = meshes
                .par_iter()
                .map(|&o| match old.iter().find(|(m, _)| Arc::ptr_eq(m, o)) {
                    Some(&(_, closed)) => (o.clone(), closed),
                    None => (o.clone(), closed_bounds(o)),
                })
                .collect();
        }
        self.meshes.iter().map(|&(_, c)| c).collect()
    }
}

/// `mesh`'s bounds if it is closed and outward-oriented.
#[must_use]
pub fn closed_bounds(mesh: &Mesh) -> Option<Aabb> {
    if mesh.is_closed_outward() {
        mesh.bounds()
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed meshes cull their back faces only from outside their bounds.
    #[test]
    fn closed_meshes_cull_only_from_outside_their_bounds() {
        let b = relight_geom::Aabb {
            min: Vec3::splat(-1.0),
            max: Vec3::new(1.0, 2.0, 1.0),
        };
        assert_eq!(
            cull_for_closed(Some(&b), Vec3::new(0.0, 0.0, 3.0)),
            CullMode::Back
        );
        assert_eq!(
            cull_for_closed(Some(&b), Vec3::new(0.5, 1.5, 0.0)),
            CullMode::None
        );
        assert_eq!(
            cull_for_closed(Some(&b), Vec3::new(1.0, 2.0, 1.0)),
            CullMode::None
        );
        assert_eq!(
            cull_for_closed(None, Vec3::new(0.0, 0.0, 3.0)),
            CullMode::None
        );
    }

    /// The cache examines a mesh once and follows the objects' meshes.
    #[test]
    fn closed_meshes_follow_the_objects() {
        use crate::{Camera, Object};
        let sphere = Arc::new(relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 16, 8));
        let plane = Arc::new(relight_geom::shapes::plane(2.0, 2));
        let brdf: Arc<dyn relight_brdf::Brdf> =
            Arc::new(relight_brdf::Lambert::new(Vec3::splat(0.5)).unwrap());
        let env = relight_sphere::EnvMap {
            param: relight_sphere::Param::LatLong {
                width: 4,
                height: 2,
            },
            texels: vec![Vec3::ONE; 8],
        };
        let camera = Camera {
            eye: Vec3::new(0.0, 0.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 45.0,
            width: 8,
            height: 8,
            image_offset: glam::Vec2::ZERO,
        };
        let mut scene = Scene::new(
            vec![
                Object::new(sphere.clone(), brdf.clone()),
                Object::new(plane.clone(), brdf.clone()),
            ],
            env,
            camera,
        );
        let mut cache = ClosedMeshes::default();
        let first = cache.of(&scene);
        assert_eq!(first[0], sphere.bounds());
        assert_eq!(first[1], None);
        scene.objects.swap(0, 1);
        assert_eq!(cache.of(&scene), vec![None, sphere.bounds()]);
        scene.objects[0] = Object::new(sphere, brdf);
        assert_eq!(cache.of(&scene), vec![first[0], first[0]]);
        assert_eq!(ClosedMeshes::disabled().of(&scene), vec![None, None]);
    }
}
