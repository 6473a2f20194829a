//! Spherical parameterizations: how relight stores a function on the sphere
//! (an environment map, a local lighting vector, a visibility map) as texels.
//!
//! Every parameterization here provides the same family of maps
//! (`dir_from_texel`, `texel_from_dir`, `texel_solid_angle`, `bilinear`) and
//! the exact (analytic) solid angle of every texel, so that sums over texels
//! are quadratures of the sphere with no small-texel error.
//!
//! **Architecture invariant:** this crate does no IO and knows no renderer.
//!
//! # Frames and conventions
//! World space is right-handed with **+Y up** (the convention of glTF and of
//! the OBJ/PLY meshes relight loads). Directions are unit `Vec3`s pointing
//! *away* from the origin (towards the light for an environment map).
//! Local shading frames ([`Frame`]) put the surface normal on local **+Z**.
//!
//! See the module docs of [`param`] for the texel layout of each map.

pub mod frame;
pub mod icosahedral;
pub mod map;
pub mod param;

pub use frame::Frame;
pub use map::EnvMap;
pub use param::Param;
