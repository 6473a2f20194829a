//! relight-shexp: soft shadows of dynamic blockers by SH exponentiation
//! (Ren et al. 2006; sun-thesis-2008 §5.2), with sphere-set fitting of meshes.
//!
//! Blockers are sets of spheres. From a receiver a sphere is a cap of
//! half-angle `asin(r/d)` whose visibility is zonal and analytic
//! ([`cap`]); its SH log is tabulated over the half-angle by the eigen-analysis
//! log with eigenvalue clipping ([`log_table`], eqs. 5.28–5.35). At a receiver
//! the logs of every blocker, turned to their directions, add up
//! ([`accumulate`], eq. 5.13), and one SH exponential ([`exp`]: PS*-p, HYB, OL,
//! eqs. 5.24–5.27) gives the total visibility `g`, dotted with the lighting
//! times the clamped cosine `L_H(N) = L ∗ H(N)` (eq. 5.14). The baseline
//! multiplies every blocker's visibility instead (eq. 5.11).
//!
//! * [`spheres`]: bounding sphere sets of meshes (clustering, own code), the
//!   sphere hierarchy, JSON export;
//! * [`method`]: the `shexp` method behind `relight_render::method::Relighter`;
//! * [`verify`], [`mod@bench`]: `relight verify shexp`, `relight bench shexp`.

#![allow(clippy::needless_range_loop)] // index-heavy numerical kernels read better with explicit indices

pub mod accumulate;
pub mod area;
pub mod bench;
pub mod cap;
pub mod exp;
pub mod lanes;
pub mod log_table;
pub mod method;
pub mod shade;
pub mod spheres;
pub mod texels;
pub mod union;
pub mod verify;
pub mod verify_scene;

pub use exp::{ExpKind, Exponentiator, MAX_SQUARINGS, OlFit, SquaringHistogram};
pub use log_table::{DEFAULT_EIGEN_CLIP, DEFAULT_LOG_ENTRIES, LogTable};
pub use method::{Kernel, SHEXP_METHOD_NAME, ShExpMethod, ShExpOptions};
pub use spheres::{FitOptions, Sphere, SphereSet, fit_spheres};

/// Errors of this crate.
#[derive(Debug, thiserror::Error)]
pub enum ShExpError {
    #[error(transparent)]
    Sh(#[from] relight_sh::ShError),
    #[error("{what}: {why}")]
    InvalidParameter { what: &'static str, why: String },
    #[error("shexp cancelled")]
    Cancelled,
}

impl From<relight_render::Cancelled> for ShExpError {
    fn from(_: relight_render::Cancelled) -> Self {
        Self::Cancelled
    }
}
