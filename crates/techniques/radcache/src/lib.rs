//! Radiance caching with rotation-aligned SH interpolation (Křivánek et al.
//! 2005; the fast rotation of Křivánek et al. 2006, §4.2 and Appendix B):
//! `--method radiance-cache`.
//!
//! # Method
//! Indirect light on glossy surfaces varies slowly over space but not over
//! direction, so it is sampled sparsely as *records* of the incoming
//! radiance and interpolated:
//!
//! * **Record** at surface point `p_i` with normal `n_i`: the incoming
//!   *indirect* radiance (light reflected by other surfaces, from the GI
//!   reference's own path tracer, [`relight_render::reference::GiTracer`])
//!   over the hemisphere, projected onto real SH of order `n` (6 or 10 as in
//!   the paper's Table 1) in the frame `Frame::from_z(n_i)`, from
//!   `side × side` stratified uniform rays; and `R_i`, the harmonic mean of
//!   those rays' hit distances (clamped, [`RadianceCacheOptions::radius_clamp`]).
//! * **Weight** `w_i(p) = (‖p − p_i‖ / R_i + √(1 − n·n_i))⁻¹` and the set
//!   `S = {i : w_i(p) > 1/a}` for the allowed error `a`
//!   ([`RadianceCacheOptions::error`]): a record reaches at most `a·R_i`.
//! * **Index**: an octree ([`index`]) where each record sits in the deepest
//!   node at least twice its reach.
//! * **Lazy creation**: a shading point with an empty `S` gets a new record.
//!   To stay deterministic on any thread count, points are visited in rounds
//!   (every 16th pixel, 8th, …, then every camera sample); each round finds
//!   its uncovered points in parallel, computes their records in parallel,
//!   and keeps them in sample order, dropping a record that one kept earlier
//!   in the round already covers ([`CacheStats::wasted_records`]).
//! * **Interpolation**: `λ(p) = Σ_S w_i R_i λ_i / Σ_S w_i`, with `R_i` the
//!   aligning rotation from record frame to `Frame::from_z(n)` at `p`, by
//!   [`RotationMethod`] (ignore, Taylor 1/1.5/2 with the exact switch above
//!   `β_lim = 1.25 a`, exact ZYZ, Ivanic–Ruedenberg). The Y angle β of the
//!   ZYZ split of `R_i` is the angle between `n_i` and `n`; because `S`
//!   keeps `√(1 − n·n_i) < a`, it is small (`β < acos(1 − a²) ≈ √2·a`),
//!   which is where the Taylor rotation holds. It passes `β_lim` only where
//!   the position term leaves room: on a surface of curvature radius `r`,
//!   `1/w_i ≈ β (r/R_i + 1/√2)`, so only where `r < 0.093 R_i` (Appendix B
//!   chose `β_lim` for `r/R_i = 0.1`); there the share of exact rotations is
//!   `≈ 1 − (1.25 (r/R_i + 1/√2))²` whatever `a` is (checked by
//!   [`verify::exact_share_on_sphere`]). The verify scene's surfaces have
//!   `r ≥ 0.1 R_i` almost everywhere (`R_i` is at most half the scene's
//!   size), so its renders take the exact path a few times in 10⁴.
//! * **Rotation cost**: one `R_i` per record × point, applied to the three
//!   channels at once ([`relight_sh::taylor::TaylorRotation::apply_rgb`]:
//!   one ZYZ split and one set of multiple angles per rotation).
//! * **Shading**: one exact Z rotation by `−φ_o` puts the view in the `xz`
//!   plane, then `L_ind = Σ_k λ_k ρ_k(θ_o)` with the BRDF's SH coefficients
//!   tabulated over `θ_o` ([`brdf_sh`]; blends mix the two tables).
//!
//! The camera rays, the emission they see and the direct light are the GI
//! reference's own code and random numbers, so for the same seed and samples
//! the direct image equals the reference's and the indirect image carries
//! the cache's error alone.

pub mod align;
pub mod brdf_sh;
mod cache;
pub mod index;
mod method;
mod options;
pub mod verify;

pub use cache::{
    CacheImage, CacheStats, Record, brdf_tables, render_radiance_cache, render_radiance_cache_with,
};
pub use method::RadianceCacheRelighter;
pub use options::{RadianceCacheOptions, RotationMethod};

/// Why the radiance cache did not produce an image.
#[derive(Debug, thiserror::Error)]
pub enum RadCacheError {
    /// The user asked to stop.
    #[error("radiance cache cancelled")]
    Cancelled,
    /// An option out of range (named).
    #[error("--{option}: {message}")]
    InvalidOption {
        option: &'static str,
        message: String,
    },
    /// The GI reference refused the scene.
    #[error(transparent)]
    Reference(relight_render::ReferenceError),
    /// An SH plan failed.
    #[error(transparent)]
    Sh(relight_sh::ShError),
}

impl From<relight_render::Cancelled> for RadCacheError {
    fn from(_: relight_render::Cancelled) -> Self {
        Self::Cancelled
    }
}

/// Checks the options.
///
/// # Errors
/// [`RadCacheError::InvalidOption`] naming the flag.
pub fn validate(o: &RadianceCacheOptions) -> Result<(), RadCacheError> {
    let bad = |option, message: String| Err(RadCacheError::InvalidOption { option, message });
    if !(o.error > 0.0 && o.error <= 1.0) {
        return bad(
            "error",
            format!("allowed error must be in (0, 1] (got {})", o.error),
        );
    }
    if !(2..=16).contains(&o.order) {
        return bad(
            "order",
            format!("SH order must be 2…16 bands (got {})", o.order),
        );
    }
    if o.record_rays_side == 0 {
        return bad("record-rays", "must be at least 1".into());
    }
    if o.spp == 0 {
        return bad("spp", "must be at least 1".into());
    }
    if o.beta_lim_per_error.is_nan() || o.beta_lim_per_error < 0.0 {
        return bad(
            "beta-lim",
            format!("must be ≥ 0 (got {})", o.beta_lim_per_error),
        );
    }
    let [lo, hi] = o.radius_clamp;
    if !(lo > 0.0 && hi >= lo && hi.is_finite()) {
        return bad(
            "radius-clamp",
            format!("need 0 < min ≤ max (got {lo}, {hi})"),
        );
    }
    Ok(())
}
