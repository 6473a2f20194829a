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
//! * [`mod@select`]: top-only and adaptive coefficient selection.
//!
//! # The method
//! ```text
//!  bake (cached, crate::cache)         lighting change                view change
//!  ───────────────────────────         ───────────────                ───────────
//!  BRDF table per material over        new environment: prefilter,    raster; per pixel: frame of the
//!  views (brdf_table), exact areas     table over 642 icosahedral     interpolated normal → 6 lighting
//!  per-vertex visibility by rays       normals × twists (lighting)    taps, 4 BRDF taps, 3 vertices'
//!  (visibility)                        rotation: lookup change only   visibility → Σ_c L̄ V̄ ρ̂ (shade)
//! ```
//! [`TripleMethod`] (`triple`, defaults in [`TripleOptions`]) wires them behind
//! `relight_render::method::Relighter`; [`verify`] and [`mod@bench`] hold the rows
//! of `relight verify triple` and `relight bench triple`.
//!
//! # Choices where the paper is silent (each documented in its module)
//! * Wavelet sign patterns: a Hadamard assignment ([`basis`]).
//! * Exact solid angles folded into the BRDF term; the paper's equal areas
//!   kept as [`Weighting::Paper`] ([`quadrature`]).
//! * Table normals at icosahedral vertices with the shortest-arc frame from
//!   +Y, singular only at −Y, and twist bins measured per neighbour
//!   ([`lighting`]), instead of Euler angles with a pole on +Y.
//! * The renderer keeps complete levels per pixel (top-only, the paper's GPU
//!   form) or, per vertex, the `n` largest terms of each function
//!   ([`adaptive`], from the 5120-cell tables); Fig. 7 compares the two
//!   point by point in verify.
//! * Per pixel, the lighting is looked up from the pixel's own frame (the
//!   paper's second form); visibility is interpolated from the vertices.
//!
//! * Bump mapping: the lighting and the BRDF's view in the bumped frame,
//!   visibility unrotated (the paper's approximation; [`method`] docs).
//!
//! * Storage: every table f32, or compact (lighting f16, BRDF and visibility
//!   8-bit with a scale per function; [`storage`]).
//!
//! * Visibility textures over the uvs ([`vis_texture`]); meshes without uvs
//!   get one packed chart per triangle (a documented simple packer; no
//!   parameterisation crate builds here), with a warning.
//!
//! * Media (sun-thesis-2008 §3.6.5): the product fed with the environment
//!   convolved by the fog chapter's PSF, band-limited and windowed for the
//!   scattered part only, then the view segment per pixel ([`medium`]).
//!

pub mod adaptive;
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
pub mod interpolated;
pub mod lighting;
pub mod medium;
pub mod method;
pub mod shade;
pub mod storage;
pub mod verify;
pub mod vis_texture;
pub mod visibility;

pub use method::{Shading, TRIPLE_METHOD_NAME, TripleMethod, TripleOptions};
pub use storage::Storage;
