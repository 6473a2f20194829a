//! The SH log of a cap's visibility, tabulated over the cap's half-angle
//! (thesis §5.2.3–5.2.4).
//!
//! Each entry is `log g(θ)` by the eigen-analysis log (eqs. 5.29–5.35, via
//! [`relight_sh::product::log_sh`]): with `M_g = Rᵀ D R` the product matrix of
//! the cap visibility `g(θ)` ([`crate::cap`]), `log g = Rᵀ q′(D̃) R (g − 1)`,
//! `q′(x) = ln x/(x − 1)`, and the eigenvalues clipped from below at
//! `ε · max D` (5.35; the thesis' ε = 0.02, [`DEFAULT_EIGEN_CLIP`]). The log of a
//! zonal function is zonal, so each entry keeps only its `order` coefficients
//! of `y_{l,0}`; a blocker's log is the entry rotated to the blocker's
//! direction ([`crate::accumulate`], eqs. 5.13, 5.36).
//!
//! The entries are equally spaced in `t = tan(θ/2)` over [0, 1] (θ from 0 to
//! π/2), and lookups interpolate linearly in `t`. From a receiver at distance
//! `d` of a sphere of radius `r`, `sin θ = r/d` and
//! `t = sin θ / (1 + √(1 − sin²θ))` ([`tan_half_of_sin`]): a square root and a
//! division, where an equal-θ grid needs an `asin` per blocker and receiver
//! (the lane kernel's hot loop). `dθ/dt = 2/(1 + t²)` stays within [1, 2], so
//! the grid is nearly uniform in θ with no end singular (a grid in `sin θ`
//! would crowd neither end and blur θ near π/2).

use crate::ShExpError;
use crate::cap::cap_visibility_zonal;
use relight_sh::product::{TripleProduct, log_sh};
use std::f64::consts::FRAC_PI_2;

/// Eigenvalue clipping threshold relative to the largest eigenvalue (thesis
/// §5.2.3: "0.02 times the largest eigenvalue").
pub const DEFAULT_EIGEN_CLIP: f64 = 0.02;

/// Entries of the log table over `tan(θ/2)` ∈ [0, 1] (θ at most 0.5° apart,
/// at θ = 0; 0.25° near π/2).
pub const DEFAULT_LOG_ENTRIES: usize = 231;

/// `tan(θ/2)` from `sin θ` for θ ∈ [0, π/2]: `s / (1 + √(1 − s²))`, `s`
/// clamped to [0, 1] (the table's coordinate; module docs).
#[inline]
#[must_use]
pub fn tan_half_of_sin(s: f32) -> f32 {
    let s = s.clamp(0.0, 1.0);
    // (1 − s)(1 + s), not 1 − s²: no cancellation as s → 1.
    s / (1.0 + ((1.0 - s) * (1.0 + s)).sqrt())
}

/// The half-angle of entry `e` of `entries`: `2 atan(e/(entries − 1))`.
fn theta_of_entry(e: usize, entries: usize) -> f64 {
    2.0 * (e as f64 / (entries - 1) as f64).atan()
}

/// `log g(θ)` for caps of half-angle θ ∈ [0, π/2], zonal, per order.
#[derive(Clone, Debug)]
pub struct LogTable {
    order: usize,
    /// θ of entry `e` is `2 atan(e/(entries − 1))`: 0 to π/2.
    entries: usize,
    /// `entries × order` zonal coefficients, f64.
    zonal: Vec<f64>,
    /// The same in f32, for the runtime.
    zonal32: Vec<f32>,
}

/// The zonal coefficients (`l < order`) of `log g(θ)` for one cap, by the
/// eigen-analysis log with clipping `eps_rel`.
///
/// # Errors
/// An order the product tensor does not support, or a bad `eps_rel`.
pub fn cap_log_zonal(
    tp: &TripleProduct<f64>,
    theta: f64,
    eps_rel: f64,
) -> Result<Vec<f64>, ShExpError> {
    let n = tp.order();
    let zonal = cap_visibility_zonal(n, theta);
    let mut g = vec![0.0; n * n];
    for (l, z) in zonal.iter().enumerate() {
        g[l * (l + 1)] = *z;
    }
    let f = log_sh(tp, &g, eps_rel)?;
    Ok((0..n).map(|l| f[l * (l + 1)]).collect())
}

impl LogTable {
    /// Builds the table for `order` bands with `entries ≥ 2` entries and
    /// clipping `eps_rel` (a preprocess: one `order² × order²` eigen-analysis
    /// per entry).
    ///
    /// # Errors
    /// A bad order, entry count or clipping threshold.
    pub fn new(order: usize, entries: usize, eps_rel: f64) -> Result<Self, ShExpError> {
        if entries < 2 {
            return Err(ShExpError::InvalidParameter {
                what: "log table entries",
                why: format!("need at least 2 (got {entries})"),
            });
        }
        let tp = TripleProduct::<f64>::new(order)?;
        let mut zonal = Vec::with_capacity(entries * order);
        for e in 0..entries {
            let theta = theta_of_entry(e, entries);
            zonal.extend(cap_log_zonal(&tp, theta, eps_rel)?);
        }
        let zonal32 = zonal.iter().map(|&v| v as f32).collect();
        Ok(Self {
            order,
            entries,
            zonal,
            zonal32,
        })
    }

    /// With the defaults ([`DEFAULT_LOG_ENTRIES`], [`DEFAULT_EIGEN_CLIP`]).
    ///
    /// # Errors
    /// As [`LogTable::new`].
    pub fn with_defaults(order: usize) -> Result<Self, ShExpError> {
        Self::new(order, DEFAULT_LOG_ENTRIES, DEFAULT_EIGEN_CLIP)
    }

    /// SH order n.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Number of entries.
    #[must_use]
    pub fn entries(&self) -> usize {
        self.entries
    }

    /// The half-angle of entry `e`, radians.
    #[must_use]
    pub fn theta_of(&self, e: usize) -> f64 {
        theta_of_entry(e, self.entries)
    }

    /// Entry `e`'s zonal coefficients (f64).
    #[must_use]
    pub fn entry(&self, e: usize) -> &[f64] {
        &self.zonal[e * self.order..(e + 1) * self.order]
    }

    #[inline]
    fn locate(&self, theta: f32) -> (usize, f32) {
        let x =
            (0.5 * theta.clamp(0.0, std::f32::consts::FRAC_PI_2)).tan() * (self.entries - 1) as f32;
        let i = (x as usize).min(self.entries - 2);
        (i, x - i as f32)
    }

    /// The entries at half-angle θ (radians, clamped to [0, π/2]), linearly
    /// interpolated in `tan(θ/2)`, into `out[..order]`.
    #[inline]
    pub fn lookup(&self, theta: f32, out: &mut [f32]) {
        let n = self.order;
        let (i, t) = self.locate(theta);
        let a = &self.zonal32[i * n..(i + 1) * n];
        let b = &self.zonal32[(i + 1) * n..(i + 2) * n];
        for ((o, a), b) in out[..n].iter_mut().zip(a).zip(b) {
            *o = a + (b - a) * t;
        }
    }

    /// f64 lookup (verification).
    pub fn lookup_f64(&self, theta: f64, out: &mut [f64]) {
        let n = self.order;
        let x = (0.5 * theta.clamp(0.0, FRAC_PI_2)).tan() * (self.entries - 1) as f64;
        let i = (x as usize).min(self.entries - 2);
        let t = x - i as f64;
        for l in 0..n {
            let (a, b) = (self.zonal[i * n + l], self.zonal[(i + 1) * n + l]);
            out[l] = a + (b - a) * t;
        }
    }

    /// Bytes held.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.zonal.len() * 12
    }
}
