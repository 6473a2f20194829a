//! [`Scene`]: what the renderers draw — meshes with materials under a distant
//! environment, seen by a camera.

use crate::Camera;
use relight_brdf::Brdf;
use relight_geom::Mesh;
use relight_sphere::EnvMap;
use std::sync::Arc;

/// A mesh (already in world space) and its material.
#[derive(Clone, Debug)]
pub struct Object {
    pub mesh: Arc<Mesh>,
    pub brdf: Arc<dyn Brdf>,
}

/// Objects under a distant environment map, seen by `camera`.
#[derive(Clone, Debug)]
pub struct Scene {
    pub objects: Vec<Object>,
    /// Distant lighting (radiance arriving from each direction, world frame).
    pub env: EnvMap,
    pub camera: Camera,
}
