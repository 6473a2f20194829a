//! Affine double and triple product integrals in Haar wavelets (Sun,
//! *Frequency-based and analytic approaches to real-time rendering*, PhD
//! thesis, Columbia 2008, ch. 4 §4.3–4.4; Sun & Ramamoorthi, SIGGRAPH 2009).
//!
//! # What
//! A function `F(v)` on \[0, 1\] that is scaled and translated, `F(s v + o)`
//! — the light of a planar area source seen from a point at depth `s` and
//! lateral position `o` (eq. 4.34) — couples every basis function with many
//! others. The affine coupling coefficient (ACC) `D_ij(s, o) =
//! ∫ Φ_i(s v + o) Φ_j(v) dv` (eq. 4.8) and the affine tripling coefficient
//! (ATC) `D_ijk(s, o)` (eq. 4.10) generalise the standard coefficients
//! `C_ij = D_ij(1, 0)`, `C_ijk = D_ijk(1, 0)` (eq. 4.12). They obey
//! `D_ij(s, o) = s⁻¹ D_ji(1/s, −o/s)` (eq. 4.13) and Lemma 1,
//! `D_ijk = Σ_l D_il C_ljk` (eq. 4.14).
//!
//! In Haar wavelets every ACC is a level factor times the canonical coupling
//! coefficient `M(r, c)` of two mother functions (eq. 4.21), a sparse,
//! piecewise-linear, bounded 2D function ([`mod@canonical`]); every ATC is one
//! ACC by the Haar product rule (Property 2, [`coupling`]). The non-zeros
//! number `O(N log N)` per (s, o) ([`sparsity`]), so rows are computed
//! exactly from `M` ([`rows`], the computational approach of §4.5.5) or
//! looked up in a sparse 4D table ([`table`], the memory-based approach).
//! [`separable`] extends all of it to the nonstandard 2D basis of
//! `relight-haar` (§4.4.4); [`other_bases`] gives the pixel and Fourier
//! forms (eqs. 4.18–4.19) for the complexity table of §4.4.3; [`standard`]
//! is the tensor-product 2D basis and the two-step separable propagation of
//! §4.5.5 that near-field relighting (`relight-nearfield`) runs per vertex;
//! [`zoom`] is the sparse 2D propagation of image zoom (§4.6.2).
//!
//! # Corrections to the OCR'd thesis
//! Each is checked by a test against exact overlap and quadrature:
//! 1. eq. 4.23: the offset term of `c` is `2^{l_j} o`, not `2^{l_i} o`
//!    ([`coupling`]);
//! 2. Fig. 4.4: `dr = |r − ½|`, not signed; its last branch is `else`
//!    ([`mod@canonical`]);
//! 3. eq. 4.28's derivation: the last line's first argument is `1/(4r)`;
//! 4. Property 2 (eq. 4.29) lacks the sign σ (which half of the coarser
//!    wavelet holds the finer one) and the case `j = k`, where
//!    `ψ_j² = 2^{l_j/2} φ_{l_j,t_j}` makes `D_ijj = 2^{l_i/2} M_ψφ`;
//! 5. the thesis gives `M` for wavelet × wavelet only; the φφ, ψφ, φψ forms
//!    are derived in [`mod@canonical`] (one primitive-based formula for all).
//!
//! # Units and frames
//! `v`, `o` in units of the unit interval (one light-texture side in 2D);
//! `s > 0` dimensionless. No IO.

#![deny(missing_docs)]

pub mod atom;
pub mod bench;
pub mod canonical;
pub mod coupling;
pub mod other_bases;
pub mod rows;
pub mod separable;
pub mod sparsity;
pub mod standard;
pub mod table;
pub mod verify;
pub mod zoom;

pub use atom::{Atom, Kind};
pub use canonical::canonical;
pub use coupling::{affine_coupling, affine_tripling, canonical_args};
