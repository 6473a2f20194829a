//! Settings of the radiance cache and the aligning-rotation methods.

use relight_sh::taylor::TaylorOrder;

/// How a record's coefficients are turned from its frame into the frame of
/// the point being shaded (Křivánek et al. 2006, §4.2, Table 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RotationMethod {
    /// No rotation: the record's coefficients are used as if its frame were
    /// the point's (the error the paper's Fig. 7 starts from).
    Ignore,
    /// Z–Y–Z with the Y step by its 1st-order Taylor expansion (exact ZYZ
    /// above β_lim).
    Taylor1,
    /// As [`RotationMethod::Taylor1`] plus the diagonal of the 2nd-order
    /// term (`shRotYdiff15`) — the paper's method.
    Taylor15,
    /// The full 2nd-order Taylor expansion.
    Taylor2,
    /// Exact Z–Y–Z ("ZXZXZ", two fixed X matrices).
    Zyz,
    /// Exact rotation matrix by the Ivanic–Ruedenberg recurrence (built per
    /// rotation, then applied).
    Ivanic,
}

impl RotationMethod {
    /// Every method, in the order of the verify table.
    pub const ALL: [RotationMethod; 6] = [
        Self::Ignore,
        Self::Taylor1,
        Self::Taylor15,
        Self::Taylor2,
        Self::Zyz,
        Self::Ivanic,
    ];

    /// The name on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Ignore => "ignore",
            Self::Taylor1 => "taylor1",
            Self::Taylor15 => "taylor15",
            Self::Taylor2 => "taylor2",
            Self::Zyz => "zyz",
            Self::Ivanic => "ivanic",
        }
    }

    /// The Taylor order, for the Taylor methods.
    #[must_use]
    pub fn taylor(self) -> Option<TaylorOrder> {
        match self {
            Self::Taylor1 => Some(TaylorOrder::First),
            Self::Taylor15 => Some(TaylorOrder::OneAndHalf),
            Self::Taylor2 => Some(TaylorOrder::Second),
            _ => None,
        }
    }
}

impl std::str::FromStr for RotationMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown rotation {s:?} (expected ignore, taylor1, taylor15, taylor2, zyz or ivanic)"
                )
            })
    }
}

/// Settings of [`crate::RadianceCacheRelighter`]; `Default` holds every default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadianceCacheOptions {
    /// Allowed error `a` of the interpolation criterion `w_i(p) > 1/a`
    /// (Ward 1988; Křivánek 2005 eq. 3), in (0, 1].
    pub error: f32,
    /// SH order `n` (bands; `n²` coefficients per channel): the paper's
    /// Table 1 uses 6 and 10.
    pub order: usize,
    /// The aligning rotation.
    pub rotation: RotationMethod,
    /// β_lim / a: above `β_lim` the Taylor methods rotate exactly (the
    /// paper's Appendix B: 1.25).
    pub beta_lim_per_error: f32,
    /// A record samples the hemisphere with `side × side` stratified rays.
    pub record_rays_side: u32,
    /// Camera samples per pixel (same jitter and direct light as the
    /// reference's samples `0..spp`).
    pub spp: u32,
    /// Seed (the reference's seed gives the reference's direct image).
    pub seed: u64,
    /// Clamp of a record's harmonic-mean distance `R_i`, as fractions of the
    /// diagonal of the shaded points' bounding box: `[min, max]`.
    pub radius_clamp: [f32; 2],
}

impl Default for RadianceCacheOptions {
    fn default() -> Self {
        Self {
            error: 0.2,
            order: 6,
            rotation: RotationMethod::Taylor15,
            beta_lim_per_error: 1.25,
            record_rays_side: 16,
            spp: 4,
            seed: 0,
            radius_clamp: [0.01, 0.5],
        }
    }
}
