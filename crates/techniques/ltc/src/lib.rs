//! Linearly transformed cosines (Heitz, Dupuy, Hill & Neubelt 2016,
//! *Real-Time Polygonal-Light Shading with Linearly Transformed Cosines*,
//! SIGGRAPH): the modern analytic baseline for the near-field area light
//! (issue 13). Untextured, unshadowed rectangles, diffuse + GGX, exactly
//! integrated per pixel; the table is this crate's own fit to the project's
//! GGX ([`relight_brdf::Ggx`]).
//!
//! | module | what |
//! |---|---|
//! | [`polygon`] | the exact clamped-cosine integral of a polygon (edge form), horizon clipping |
//! | [`distribution`] | the LTC `D(ω) = D_o(M⁻¹ω/‖M⁻¹ω‖) ‖M⁻¹‖/‖M⁻¹ω‖³`, sampling, polygon integral |
//! | [`nelder_mead`] | the simplex minimiser of the fit |
//! | [`fit`] | the fit of `M`, the magnitude and the Fresnel moment per `(√α, θ_o)` cell; the table's source |
//! | [`table`] | the committed table (`table_data.rs`, generated) and its bilinear lookup |
//! | [`lobes`] | an object's BRDF read as Lambert + isotropic GGX (probed), or refused |
//! | [`method`] | the `ltc` [`relight_render::method::Relighter`] |
//! | [`verify`] | `relight verify ltc`: fit accuracy and LTC vs nearfield vs the reference |
//!
//! The math modules (`polygon`, `distribution`, `nelder_mead`, `fit`,
//! `table`, `lobes`) do no IO. Measured figures: `docs/ltc.md`.

pub mod distribution;
pub mod fit;
pub mod lobes;
pub mod method;
pub mod nelder_mead;
pub mod polygon;
pub mod table;
#[rustfmt::skip]
mod table_data;
pub mod verify;

pub use method::{LTC_METHOD_NAME, LtcMethod, LtcOptions};

pub use distribution::Ltc;
