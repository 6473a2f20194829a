//! Near-field area-light relighting by affine wavelet products (Sun,
//! *Frequency-based and analytic approaches to real-time rendering*, PhD
//! thesis, Columbia 2008, §4.5; Sun & Ramamoorthi, SIGGRAPH 2009).
//!
//! # The method
//! A textured planar light `F` seen from a vertex at depth `z` and lateral
//! offset `x` is `F(z v + x)` on a plane at unit distance (eq. 4.34): an
//! affine transform, so its Haar coefficients are `L_k = Σ_i F_i D_ik(z, x)`
//! with the affine coupling coefficients of `relight-affine` (eq. 4.35), and
//! the exitant radiance is the double product `B = Σ_k L_k T_k` with a baked
//! transport `T` (eq. 4.36). Directions are parameterised by one expanded
//! top face aligned with the light's plane ([`face`], §4.5.4; size 3–4 keeps
//! most of a Lambertian lobe). Per frame the light's coefficients
//! ([`light`]) are compressed at the source, propagated to each vertex by
//! the two-step separable algorithm and dotted with the transport at the
//! target terms the constant-light heuristic keeps ([`propagate`]).
//!
//! | module | what |
//! |---|---|
//! | [`face`] | the face parameterisation and the vertex → texture affine map |
//! | [`light`] | the light's standard-basis coefficients, source compression |
//! | [`light_field`] | a light whose radiance varies with direction (eq. 4.37): 4D coefficients, per-slice propagation |
//! | [`transport`] | per-vertex Lambert × visibility transport bake |
//! | [`specular`] | per-vertex fixed-view specular (BRDF × cosine × visibility) transport bake, BRDF classification |
//! | [`cache`] | the transport bake on disk: versioned, checksummed, keyed |
//! | [`propagate`] | the fused per-vertex kernel: ACC rows from shared primitives, target mask (eq. 4.38), propagation and dot product |
//! | [`rotate`] | a light turned in its plane, re-rasterised into its bounding rectangle |
//! | [`method`] | the `nearfield` [`relight_render::method::Relighter`] |
//! | [`verify`], [`verify_specular`], [`verify_light_field`], [`mod@bench`] | `relight verify/bench nearfield` rows (the glossy scene's in `verify_specular`) |
//!
//! Figures measured by `relight verify nearfield` and `relight bench
//! nearfield` are in `docs/nearfield.md`.

pub mod bench;
pub mod cache;
pub mod face;
pub mod light;
pub mod light_field;
pub mod method;
pub mod propagate;
pub mod rotate;
pub mod scenes;
pub mod specular;
pub mod transport;
pub mod verify;
mod verify_judge;
pub mod verify_light_field;
pub mod verify_specular;

pub use light::Ranking;
pub use method::{NEARFIELD_METHOD_NAME, NearfieldMethod, NearfieldOptions};
