//! [`Mesh`]: an indexed triangle mesh with per-vertex attributes.

use glam::{Vec2, Vec3, Vec4};

/// An indexed triangle mesh in object space (+Y up).
///
/// **Invariants** (established by [`Mesh::validate_and_repair`]): every index
/// is `< positions.len()`, no triangle is degenerate (zero area), `normals`
/// has one unit vector per vertex, `uvs`/`tangents` are empty or one per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Unit vertex normals; empty until computed or loaded.
    pub normals: Vec<Vec3>,
    /// Texture coordinates, empty when the mesh has none.
    pub uvs: Vec<Vec2>,
    /// Tangents (xyz unit, w = handedness ±1), empty unless computed from uvs.
    pub tangents: Vec<Vec4>,
    pub indices: Vec<[u32; 3]>,
}

/// What [`Mesh::validate_and_repair`] changed, for the caller to report.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RepairReport {
    pub out_of_range_triangles: usize,
    pub degenerate_triangles: usize,
    pub computed_normals: bool,
    pub repaired_normals: usize,
    pub computed_tangents: bool,
}

impl Mesh {
    /// Number of triangles.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }
}
