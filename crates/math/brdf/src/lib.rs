//! The BRDF library: analytic reflectance models and measured (MERL) data,
//! each with evaluation, importance sampling and its pdf.
//!
//! # Frame and conventions
//! Every function works in the **local shading frame**: the normal is +Z,
//! `wo` (towards the viewer) and `wi` (towards the light) are unit vectors
//! pointing away from the surface. [`Brdf::eval`] returns f(wo, wi) in sr⁻¹
//! **without** the cosine factor; the reflection integral is
//! L_o = ∫ f(wo, wi) L_i(wi) cos θ_i dω_i, with cos θ_i = wi.z supplied by
//! the caller. Directions below the horizon (z ≤ 0) evaluate to zero.
//!
//! **Architecture invariant:** no IO; [`merl::Merl::from_bytes`] parses a
//! buffer that `relight-assets` reads.

pub mod model;
pub use model::{Brdf, BrdfSample};
