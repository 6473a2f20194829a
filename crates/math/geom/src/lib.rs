//! Triangle meshes: the data every renderer and baker of relight consumes,
//! their validation and repair, smooth normals, tangents, subdivision and the
//! procedural shapes of the embedded default scene.
//!
//! **Architecture invariant:** no IO here; loaders live in `relight-assets`.

pub mod mesh;
pub use mesh::{Mesh, RepairReport};
