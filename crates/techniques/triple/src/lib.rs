//! relight-triple: all-frequency relighting as a triple product of lighting,
//! visibility and BRDF in spherical triangular Haar wavelets, each point
//! shaded in its own local frame (Ma, Hsiao, Lee, Chuang, Chen, "Real-time
//! triple product relighting using spherical local-frame parameterization",
//! The Visual Computer 22(9–11), 2006 —
//! `spherical-wavelets-triple-product-2006`).
//!
//! # The math (no IO)
//! * [`basis`]: the basis on the icosahedral hierarchy (scaling functions and
//!   three wavelet types per triangle, `A_l = 4^{−l}`), the coarse-levels-first
//!   layout, the forward and inverse transform and the tripling coefficients.
//! * [`quadrature`]: leaf sampling and the exact solid-angle weighting folded
//!   into the BRDF term (and the paper's unweighted form).
//! * [`product`]: the fast tree triple-product integral (dense O(N), sparse
//!   O(n log n)) and the top-only kernel.
//! * [`select`]: top-only and adaptive coefficient selection.

pub mod basis;
pub mod product;
pub mod quadrature;
pub mod select;

pub use basis::{Basis, Function, level_area, tripling};
pub use quadrature::{LeafGrid, Weighting};
pub use select::{Selection, SparseVec, select};

// The method (bakes, runtime).
pub mod bench;
pub mod brdf_table;
pub mod cache;
pub mod lighting;
pub mod method;
pub mod shade;
pub mod verify;
pub mod visibility;

pub use method::{Shading, TRIPLE_METHOD_NAME, TripleMethod, TripleOptions};
