//! relight-geom: triangle meshes — the data every renderer and baker of
//! relight consumes — with their validation and repair, smooth normals,
//! tangents, affine edits, Loop subdivision and the procedural shapes of the
//! embedded default scene.
//!
//! | module | what |
//! |---|---|
//! | [`mesh`] | [`Mesh`], [`Mesh::validate_and_repair`] and its [`RepairReport`], normals, tangents, bounds, transforms, merge, topology counts |
//! | [`subdivide`] | Loop subdivision; [`Mesh::refine_to_vertices`] (Loop steps + longest-edge bisection) gives benchmark meshes exact vertex counts |
//! | [`shapes`] | uv sphere, icosphere, torus, detailed displaced sphere, plane, quad |
//!
//! **Architecture invariant:** no IO here; loaders live in `relight-assets`.
//! The pure core cannot fail: repair returns a report, not a `Result`.

pub mod mesh;
pub mod shapes;
pub mod subdivide;

pub use mesh::{Aabb, Mesh, MeshError, RepairReport};
