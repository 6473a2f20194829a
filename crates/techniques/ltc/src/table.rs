//! The committed LTC table (`crate::table_data`, fitted by [`crate::fit`])
//! and its bilinear lookup over `(√α, θ_o)`, as Heitz et al. 2016 (§5)
//! interpolate theirs.

use crate::distribution::Ltc;
use crate::fit::unpack;
use crate::table_data::{CELLS, SIZE};

/// What the table gives for one `(α, θ_o)`.
#[derive(Clone, Copy, Debug)]
pub struct Lookup {
    /// The distribution fitted to the GGX·cos lobe (normalised).
    pub ltc: Ltc,
    /// `n = ∫ f cos θ_i dω` with Fresnel 1: the lobe's magnitude.
    pub norm: f32,
    /// `∫ f cos θ_i (1 − ω_o·ĥ)⁵ dω` with Fresnel 1: the Schlick moment.
    pub fresnel: f32,
}

impl Lookup {
    /// The lobe's integral with Schlick Fresnel `F = a + b (1 − ω_o·ĥ)⁵`
    /// (`a = F₀`, `b = 1 − F₀` for a plain GGX; a mixture weight scales
    /// both).
    #[must_use]
    pub fn scale(&self, a: f32, b: f32) -> f32 {
        a * self.norm + b * self.fresnel
    }
}

/// Cells per side of the committed table.
#[must_use]
pub fn size() -> usize {
    SIZE
}

/// The raw cell `(i, j)` (row = roughness index, column = view-angle index).
#[must_use]
pub fn cell(i: usize, j: usize) -> [f32; 6] {
    CELLS[i * SIZE + j]
}

/// The table's LTC for GGX roughness `alpha` (clamped to [`crate::fit::ALPHA_MIN`]…1)
/// and `cos θ_o` (clamped to 0…1), bilinear in `(√α, θ_o)` over the cells.
#[must_use]
pub fn lookup(alpha: f32, cos_theta_o: f32) -> Lookup {
    let last = (SIZE - 1) as f32;
    let x = alpha.clamp(0.0, 1.0).sqrt() * last;
    let theta = cos_theta_o.clamp(0.0, 1.0).acos();
    let y = theta / std::f32::consts::FRAC_PI_2 * last;
    let (i0, j0) = ((x as usize).min(SIZE - 2), (y as usize).min(SIZE - 2));
    let (fx, fy) = (
        (x - i0 as f32).clamp(0.0, 1.0),
        (y - j0 as f32).clamp(0.0, 1.0),
    );
    let mut v = [0.0f32; 6];
    for (di, wx) in [(0, 1.0 - fx), (1, fx)] {
        for (dj, wy) in [(0, 1.0 - fy), (1, fy)] {
            let c = cell(i0 + di, j0 + dj);
            for k in 0..6 {
                v[k] += wx * wy * c[k];
            }
        }
    }
    Lookup {
        ltc: unpack(&[v[0], v[1], v[2], v[3]]),
        norm: v[4],
        fresnel: v[5],
    }
}
