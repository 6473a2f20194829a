//! The BRDF table of one material (spherical-wavelets-triple-product-2006
//! §3.2, §4.1): for a grid of view directions `ω_o` in the local frame, the
//! BRDF term `ρ̃(ω_i) = ρ(ω_o, ω_i) cos⁺θ_i` with the exact leaf solid angles
//! folded in ([`crate::quadrature`]), kept as the level-`m` cell integrals
//! `ρ̂_c = ∫_{cell c} ρ cos⁺ dω` (sr) so that the top-only product is the
//! plain sum `B = Σ_c L̄_c V̄_c ρ̂_c` (the cell area `A_m` is folded in too).
//!
//! # View grid
//! `θ_o` in `views` uniform rows over `[0, π/2]`, `φ_o` in `2·views` columns
//! over `[0, 2π)` (the paper's 64×128 is `views = 64`), cell-centred,
//! bilinear with `φ` wrapping and `θ` clamped ([`BrdfTable::lookup`]). An
//! isotropic BRDF still needs the azimuth: the cells are not symmetric about
//! the normal.

use crate::basis::{Basis, triangles};
use crate::lighting::{padded_cells, upper_cells};
use crate::quadrature::{LeafGrid, Weighting};
use crate::storage::Planes;
use glam::Vec3;
use rayon::prelude::*;
use relight_brdf::Brdf;
use relight_sphere::atan::atan2_f32;
use std::f32::consts::{FRAC_PI_2, TAU};

/// A baked BRDF table (module docs).
#[derive(Clone, Debug)]
pub struct BrdfTable {
    /// Top-only level.
    pub m: usize,
    /// θ rows (φ columns are `2·views`).
    pub views: usize,
    /// Padded cells per view.
    pub stride: usize,
    /// View `(row, col)` at `(row · 2·views + col) · 3 · stride`: R, G, B
    /// planes ([`crate::storage`]: f32, or 8-bit when compact).
    pub data: Planes,
}

/// A weighted view entry.
pub use crate::lighting::Tap;

impl BrdfTable {
    /// Bakes `brdf` for level `m`, `views` rows, on `grid` (leaf quadrature)
    /// with `weighting`.
    #[must_use]
    pub fn bake(
        brdf: &dyn Brdf,
        grid: &LeafGrid,
        m: usize,
        views: usize,
        weighting: Weighting,
    ) -> Self {
        let basis: Basis = grid.basis();
        let cols = 2 * views;
        let stride = padded_cells(m);
        let cells = triangles(m);
        let per = basis.len() / cells;
        let area_m = (20.0 / cells as f64) as f32;
        let mut data = vec![0.0f32; views * cols * 3 * stride];
        data.par_chunks_mut(3 * stride).enumerate().for_each_init(
            || vec![Vec3::ZERO; basis.len()],
            |leaf, (v, out)| {
                let wo = view_dir(views, v / cols, v % cols);
                grid.brdf_term(
                    |wi| {
                        if wi.z <= 0.0 {
                            Vec3::ZERO
                        } else {
                            brdf.eval(wo, wi) * wi.z
                        }
                    },
                    weighting,
                    leaf,
                );
                for (slot, &cell) in upper_cells(m).iter().enumerate() {
                    let cell = cell as usize;
                    let s: Vec3 = leaf[cell * per..(cell + 1) * per].iter().sum();
                    // Mean leaf term × A_m = cell integral (sr).
                    for c in 0..3 {
                        out[c * stride + slot] = s[c] / per as f32 * area_m;
                    }
                }
            },
        );
        Self {
            m,
            views,
            stride,
            data: Planes::F32(data),
        }
    }

    /// The baked values as f32 (what the cache stores).
    #[must_use]
    pub fn into_values(self) -> Vec<f32> {
        match self.data {
            Planes::F32(v) => v,
            other => (0..other.len())
                .map(|i| other.get(i, self.stride))
                .collect(),
        }
    }

    /// Bytes held.
    #[must_use]
    pub fn bytes(&self) -> u64 {
        self.data.bytes()
    }

    /// The four weighted views around local `wo` (normal +Z).
    #[must_use]
    pub fn lookup(&self, wo: Vec3) -> [Tap; 4] {
        let cols = 2 * self.views;
        let theta = wo.z.clamp(-1.0, 1.0).acos().min(FRAC_PI_2);
        // As `LightTable::lookup`'s twist: the polynomial atan2, then φ
        // into [0, 2π) and the columns wrapped without `fmodf` or integer
        // divisions (this lookup runs per pixel).
        let phi = atan2_f32(wo.y, wo.x);
        let phi = if phi < 0.0 { phi + TAU } else { phi };
        let r = (theta / FRAC_PI_2 * self.views as f32 - 0.5).clamp(0.0, self.views as f32 - 1.0);
        let c = phi / TAU * cols as f32 - 0.5;
        // Floors by truncation (no `floorf` call on the baseline target):
        // r ≥ 0; c ∈ [−½, cols − ½], so its floor is −1 below 0 and reaches
        // `cols` only by rounding.
        let r0 = r as usize;
        let fr = r - r0 as f32;
        let r1 = (r0 + 1).min(self.views - 1);
        let (c0, fc) = if c < 0.0 {
            (cols - 1, c + 1.0)
        } else {
            let c0 = c as usize;
            (if c0 >= cols { c0 - cols } else { c0 }, c - c0 as f32)
        };
        let c1 = if c0 + 1 == cols { 0 } else { c0 + 1 };
        let entry = 3 * self.stride;
        let off = |r: usize, c: usize| ((r * cols + c) * entry) as u32;
        [
            Tap {
                offset: off(r0, c0),
                weight: (1.0 - fr) * (1.0 - fc),
            },
            Tap {
                offset: off(r0, c1),
                weight: (1.0 - fr) * fc,
            },
            Tap {
                offset: off(r1, c0),
                weight: fr * (1.0 - fc),
            },
            Tap {
                offset: off(r1, c1),
                weight: fr * fc,
            },
        ]
    }
}

/// The local view direction of grid cell `(row, col)` (cell centres).
#[must_use]
pub fn view_dir(views: usize, row: usize, col: usize) -> Vec3 {
    let theta = (row as f32 + 0.5) / views as f32 * FRAC_PI_2;
    let phi = (col as f32 + 0.5) / (2 * views) as f32 * TAU;
    let (st, ct) = theta.sin_cos();
    Vec3::new(st * phi.cos(), st * phi.sin(), ct)
}
