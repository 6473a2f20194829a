//! Spherical parameterizations: how relight stores a function on the sphere
//! (an environment map, a local lighting vector, a visibility map, a BRDF
//! slice) as texels or triangles.
//!
//! | module | what | used by |
//! |---|---|---|
//! | [`param`] | [`Param`]: lat-long, cube map, octahedral, hemi-octahedral grids | everything |
//! | [`map`] | [`EnvMap`]: RGB texels on a `Param`; lookup, integral, resampling, rotation | assets, renderer, SH, wavelets |
//! | [`icosahedral`] | [`Icosahedral`]: geodesic triangle hierarchy, levels 0–7 | spherical Haar wavelets |
//! | [`ico_weights`] | [`ico_weights::IcoWeights`]: a direction's triangle and barycentric weights at one level, last triangle first | per-pixel lookups (triple product) |
//! | [`frame`] | [`Frame`]: local shading frames | BRDFs, renderer |
//! | [`verify`] | accuracy / timing rows for `relight verify` and `relight bench` | CLI |
//!
//! Every grid parameterization provides the same family of maps
//! (`dir_from_uv` / `uv_from_dir`, `dir_from_texel` / `texel_from_dir`,
//! `texel_solid_angle`, `bilinear`) and the exact (analytic) solid angle of
//! every texel, so that sums over texels are quadratures of the sphere with no
//! small-texel error: `Σ Ω_i = 4π` (2π for the hemisphere) to rounding. The
//! icosahedral hierarchy likewise carries exact spherical-triangle areas.
//! Geometry is computed in f64 (`*_f64` variants, `DVec3`); the f32 `Vec3`
//! entry points are thin conversions for renderers.
//!
//! **Architecture invariant:** this crate does no IO and knows no renderer;
//! it depends only on glam, rayon (bulk operations) and serde (report rows).
//!
//! # Frames and conventions
//! World space is right-handed with **+Y up** (the convention of glTF and of
//! the OBJ/PLY meshes relight loads). Directions are unit `Vec3`s pointing
//! *away* from the origin (towards the light for an environment map).
//! Local shading frames ([`Frame`]) put the surface normal on local **+Z**;
//! the octahedral maps put their +Z pole at the centre of the square, so a
//! hemi-octahedral map in a shading frame covers the hemisphere around the
//! normal.
//!
//! # Example
//!
//! ```
//! use relight_sphere::{EnvMap, Param};
//! use glam::Vec3;
//!
//! // A sky that is bright towards +Y, stored on a 64² octahedral map.
//! let sky = EnvMap::from_fn(Param::Octahedral { n: 64 }, |d| Vec3::splat(1.0 + d.y));
//! // ∫ (1 + y) dω = 4π, exactly up to the texel quadrature of y.
//! assert!((sky.integral().x - 4.0 * std::f32::consts::PI).abs() < 1e-3);
//! // Area-correct conversion to a cube map keeps the integral.
//! let cube = sky.resample(Param::Cube { n: 32 }, 4);
//! assert!((cube.integral().x - sky.integral().x).abs() < 1e-3);
//! ```
//!
//! See the module docs of [`param`] for the exact texel layout of each map and
//! of [`icosahedral`] for the triangle numbering.

#![warn(missing_docs)]

pub mod atan;
pub mod frame;
pub mod ico_weights;
pub mod icosahedral;
pub mod latlong_batch;
pub mod map;
pub mod param;
pub mod verify;

pub use frame::{Frame, rotation_from_yaw_pitch_roll};
pub use icosahedral::{Icosahedral, IcosahedralError};
pub use map::{EnvMap, MAX_RADIANCE};
pub use param::{Bilinear, BilinearF64, Param, ParamError};
