//! 2D lookup tables of the special functions ([`FogTables`]) and their
//! bilinear / nearest lookup (the CPU analogue of the paper's 64×64 float
//! textures, Sun 2008 §3.5).
//!
//! # Tables, axes and out-of-range behaviour
//! | table | x axis | y axis | value | outside the axes |
//! |---|---|---|---|---|
//! | `tail[k]` (k = 0..=K) | w = u/(1+u) ∈ \[0, 1\] (u = T sin γ ∈ \[0, ∞\]) | v ∈ \[0, π/2\] | Rᵏ = H̃ᵏ(u, v)/(N(u, v) q(u tan v)) | none: the axes cover the whole domain; w = 1 holds the analytic limit cosᵏ 2v |
//! | `g[n]` | w = T/(1+T), T ∈ \[0, [`G_T_MAX`]\] | μ = cos θ ∈ \[−1, 1\] | e^{T} G_n(T, θ) | T > T_max is clamped to T_max (the surface term then carries e^{−T} < 1e−27) |
//! | `f` (paper's F, export only) | u ∈ \[0, [`F_U_MAX`]\] | v ∈ \[0, π/2\] | F(u, v) | u clamped |
//!
//! H̃, N and R are defined in [`crate::special`]. Values are f32, row-major
//! (`values[y * size + x]`), grid points at both ends of each axis, so any
//! size ≥ 2 works. Lookups clamp the coordinate to the axis (never NaN for
//! finite input; NaN coordinates read the first texel).

// `.max(0.0).min(n)` instead of `clamp` on purpose: it maps NaN to 0.
#![allow(clippy::manual_clamp)]

use crate::FogError;
use crate::special::{fk_special, lobe_azimuthal, tail_ratio, tail_scaled_tol};
use glam::Vec3;
use rayon::prelude::*;
use std::f64::consts::FRAC_PI_2;

/// Largest optical thickness on the axis of the G tables.
pub const G_T_MAX: f64 = 64.0;
/// Largest u on the axis of the exported paper-style F table (paper: 10).
pub const F_U_MAX: f64 = 10.0;
/// Default table resolution (the paper's 64×64).
pub const DEFAULT_TABLE_SIZE: usize = 64;

/// How a table is read between grid points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Interp {
    /// Bilinear interpolation of the four surrounding texels.
    Bilinear,
    /// The nearest texel.
    Nearest,
}

/// A square table of f32 samples on a uniform grid over [x0, x1] × [y0, y1].
///
/// Invariant (kept private so lookups can skip bounds checks):
/// `size ≥ 2` and `values.len() == size²`.
#[derive(Clone, Debug, PartialEq)]
pub struct Table2 {
    size: usize,
    pub x0: f32,
    pub x1: f32,
    pub y0: f32,
    pub y1: f32,
    /// Row-major, `values[y * size + x]`.
    values: Vec<f32>,
    /// Each cell's four corners, `quads[4 (y · size + x) ..][..4]` =
    /// (x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1), for x, y ≤ size − 2
    /// (the last row and column are zero): one 16-byte load per bilinear
    /// lookup for the AVX2 kernels instead of four gathered values.
    quads: Vec<f32>,
    /// Texel coordinate = x · sx + ox (and y · sy + oy).
    sx: f32,
    ox: f32,
    sy: f32,
    oy: f32,
    /// size − 1 as f32.
    last: f32,
}

impl Table2 {
    /// Tabulates `f(x, y)` (in f64) on a `size`² grid, in parallel.
    pub fn tabulate(
        size: usize,
        x: (f64, f64),
        y: (f64, f64),
        f: impl Fn(f64, f64) -> f64 + Sync,
    ) -> Result<Self, FogError> {
        if !(2..=MAX_TABLE_SIZE).contains(&size) {
            return Err(FogError::TableSize { size });
        }
        let n = size as f64 - 1.0;
        let values: Vec<f32> = (0..size * size)
            .into_par_iter()
            .map(|i| {
                let (ix, iy) = (i % size, i / size);
                let xv = x.0 + (x.1 - x.0) * ix as f64 / n;
                let yv = y.0 + (y.1 - y.0) * iy as f64 / n;
                f(xv, yv) as f32
            })
            .collect();
        Ok(Self::from_values(size, x, y, values))
    }

    /// `size` ≥ 2 and `values.len() == size²` (checked by the callers).
    fn from_values(size: usize, x: (f64, f64), y: (f64, f64), values: Vec<f32>) -> Self {
        assert!(size >= 2 && values.len() == size * size, "table invariant");
        let n = size as f64 - 1.0;
        let (sx, sy) = (n / (x.1 - x.0), n / (y.1 - y.0));
        let mut quads = vec![0.0; 4 * size * size];
        for iy in 0..size - 1 {
            for ix in 0..size - 1 {
                let i = iy * size + ix;
                quads[4 * i..4 * i + 4].copy_from_slice(&[
                    values[i],
                    values[i + 1],
                    values[i + size],
                    values[i + size + 1],
                ]);
            }
        }
        Self {
            size,
            quads,
            x0: x.0 as f32,
            x1: x.1 as f32,
            y0: y.0 as f32,
            y1: y.1 as f32,
            values,
            sx: sx as f32,
            ox: (-x.0 * sx) as f32,
            sy: sy as f32,
            oy: (-y.0 * sy) as f32,
            last: n as f32,
        }
    }

    /// Samples per axis.
    #[inline]
    #[must_use]
    pub fn size(&self) -> usize {
        self.size
    }

    /// The lookup's affine map and clamp: (sx, ox, sy, oy, size − 1), texel
    /// coordinate = x · sx + ox, y · sy + oy.
    #[inline]
    #[must_use]
    pub fn affine(&self) -> (f32, f32, f32, f32, f32) {
        (self.sx, self.ox, self.sy, self.oy, self.last)
    }

    /// The samples, row-major (`values()[y * size + x]`).
    #[inline]
    #[must_use]
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// Each cell's four corners (see the field), `4 · size²` values.
    #[inline]
    #[must_use]
    pub fn quads(&self) -> &[f32] {
        &self.quads
    }

    /// Bilinear lookup at (x, y), coordinates clamped to the axes
    /// (branch-free, no bounds checks; NaN reads the first texel).
    #[inline(always)]
    #[must_use]
    pub fn bilinear(&self, x: f32, y: f32) -> f32 {
        // `max(min)` maps NaN to 0.
        let fx = (x * self.sx + self.ox).max(0.0).min(self.last);
        let fy = (y * self.sy + self.oy).max(0.0).min(self.last);
        let n2 = self.size - 2;
        let ix = (fx as usize).min(n2);
        let iy = (fy as usize).min(n2);
        let (tx, ty) = (fx - ix as f32, fy - iy as f32);
        let i = iy * self.size + ix;
        debug_assert!(i + self.size + 1 < self.values.len());
        // SAFETY: ix, iy ≤ size − 2, so i + size + 1 ≤ size² − 1 <
        // values.len() by the type invariant.
        let (v00, v01, v10, v11) = unsafe {
            (
                *self.values.get_unchecked(i),
                *self.values.get_unchecked(i + 1),
                *self.values.get_unchecked(i + self.size),
                *self.values.get_unchecked(i + self.size + 1),
            )
        };
        let a = v00 + (v01 - v00) * tx;
        let b = v10 + (v11 - v10) * tx;
        a + (b - a) * ty
    }

    /// Nearest-texel lookup at (x, y), coordinates clamped to the axes.
    #[inline(always)]
    #[must_use]
    pub fn nearest(&self, x: f32, y: f32) -> f32 {
        let fx = (x * self.sx + self.ox).max(0.0).min(self.last) + 0.5;
        let fy = (y * self.sy + self.oy).max(0.0).min(self.last) + 0.5;
        let n1 = self.size - 1;
        let i = (fy as usize).min(n1) * self.size + (fx as usize).min(n1);
        // SAFETY: both indices ≤ size − 1, so i ≤ size² − 1 < values.len().
        unsafe { *self.values.get_unchecked(i) }
    }

    /// Lookup with the given interpolation.
    #[inline(always)]
    #[must_use]
    pub fn lookup(&self, interp: Interp, x: f32, y: f32) -> f32 {
        match interp {
            Interp::Bilinear => self.bilinear(x, y),
            Interp::Nearest => self.nearest(x, y),
        }
    }
}

/// G tables for every lobe exponent in `exps`, sharing the expensive part:
/// for each T column, H̃(T sin γ′, γ′/2) is evaluated once (adaptive, 1e-9)
/// at 1024 composite Gauss–Legendre nodes in γ′ (128 panels × 8, graded
/// towards both ends where H̃ has its u log u behaviour), then every cell is
/// the weighted sum with the lobe's azimuthal integral P_n. Agreement with
/// the adaptive [`crate::special::g_scaled`] is tested (≈1e-4 relative,
/// limited by the kinks of P_n between nodes).
fn g_tables(size: usize, w_max: f64, exps: &[u32]) -> Vec<(u32, Table2)> {
    let (gx, gw) = relight_sh::quadrature::gauss_legendre(8);
    let panels = 128;
    // Graded panel edges: γ = π (1 − cos(π s))/2, s uniform.
    let edge = |i: usize| {
        std::f64::consts::PI * 0.5 * (1.0 - (std::f64::consts::PI * i as f64 / panels as f64).cos())
    };
    let mut nodes = Vec::with_capacity(panels * 8);
    for p in 0..panels {
        let (a, b) = (edge(p), edge(p + 1));
        for (x, w) in gx.iter().zip(&gw) {
            nodes.push((0.5 * (a + b) + 0.5 * (b - a) * x, 0.5 * (b - a) * w));
        }
    }
    let n = size as f64 - 1.0;
    let tcol: Vec<f64> = (0..size)
        .map(|ix| {
            let w = w_max * ix as f64 / n;
            w / (1.0 - w)
        })
        .collect();
    let h: Vec<Vec<f64>> = tcol
        .par_iter()
        .map(|&t| {
            nodes
                .iter()
                .map(|&(g, w)| w * tail_scaled_tol(0, t * g.sin(), 0.5 * g, 1e-9))
                .collect()
        })
        .collect();
    // P_n(γ′, μ) does not depend on T: evaluate it once per (exponent, row,
    // node) instead of once per cell (the cells are then dot products).
    exps.iter()
        .map(|&e| {
            let lobes: Vec<Vec<f64>> = (0..size)
                .into_par_iter()
                .map(|iy| {
                    let mu = -1.0 + 2.0 * iy as f64 / n;
                    nodes
                        .iter()
                        .map(|&(g, _)| lobe_azimuthal(e, g, mu))
                        .collect()
                })
                .collect();
            let values: Vec<f32> = (0..size * size)
                .into_par_iter()
                .map(|i| {
                    let (ix, iy) = (i % size, i / size);
                    lobes[iy]
                        .iter()
                        .zip(&h[ix])
                        .map(|(p, hw)| hw * p)
                        .sum::<f64>() as f32
                })
                .collect();
            (
                e,
                Table2::from_values(size, (0.0, w_max), (-1.0, 1.0), values),
            )
        })
        .collect()
}

/// One table as a float image for export (`relight fog tables`): the value
/// in all three channels, row y = grid row y.
#[derive(Clone, Debug, PartialEq)]
pub struct TableImage {
    /// `f`, `tail_k0`…, `g_n1` (Lambert G₀), `g_n10`, ….
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Vec3>,
}

/// Every table the fog renderer reads.
#[derive(Clone, Debug)]
pub struct FogTables {
    pub size: usize,
    /// Rᵏ for k = 0..=max phase degree (index k).
    pub tail: Vec<Table2>,
    /// (lobe exponent n, e^{T} G_n table); n = 1 is the Lambertian G₀.
    pub g: Vec<(u32, Table2)>,
    /// The paper's F(u, v) (u ∈ [0, 10]), kept for export and comparison.
    pub f: Table2,
    /// The corner factor q(c) of [`crate::special::corner_factor`] on
    /// x = c/(1+c) ∈ [0, 1] ([`CORNER_SAMPLES`] values).
    corner: Vec<f32>,
}

/// Samples of the 1D corner table.
pub const CORNER_SAMPLES: usize = 256;

impl FogTables {
    /// The [`CORNER_SAMPLES`] samples of q on x = c/(1+c) ∈ [0, 1].
    #[inline]
    #[must_use]
    pub fn corner_values(&self) -> &[f32] {
        &self.corner
    }

    /// q(c) by linear interpolation in x = c/(1+c) (branch-free, no
    /// bounds checks; NaN and c < 0 read q(0)).
    #[inline(always)]
    #[must_use]
    pub fn corner(&self, c: f32) -> f32 {
        const LAST: f32 = (CORNER_SAMPLES - 1) as f32;
        let x = (c / (1.0 + c)).max(0.0).min(1.0) * LAST;
        let i = (x as usize).min(CORNER_SAMPLES - 2);
        let t = x - i as f32;
        // SAFETY: `corner` is private and always holds CORNER_SAMPLES
        // values; i + 1 ≤ CORNER_SAMPLES − 1.
        let (a, b) = unsafe {
            (
                *self.corner.get_unchecked(i),
                *self.corner.get_unchecked(i + 1),
            )
        };
        a + (b - a) * t
    }
}

/// Largest table side (samples per axis) the builders accept: one f32 table
/// is then 64 MB, well inside the AVX2 kernels' i32 gather indices.
pub const MAX_TABLE_SIZE: usize = 4096;

/// Phong exponents tabulated by [`FogTables::build`].
pub const DEFAULT_PHONG_EXPONENTS: [u32; 2] = [10, 20];
/// Highest phase-polynomial degree tabulated by [`FogTables::build`].
pub const DEFAULT_PHASE_DEGREE: u32 = 3;

impl FogTables {
    /// Builds the default tables at `size`×`size`: tails for phase degrees
    /// 0..=3, G for Lambert and Phong n = 10, 20, and the paper's F.
    /// Errors with [`FogError::TableSize`] when `size` is outside 2…[`MAX_TABLE_SIZE`].
    pub fn build(size: usize) -> Result<Self, FogError> {
        Self::build_with(size, DEFAULT_PHASE_DEGREE, &DEFAULT_PHONG_EXPONENTS)
    }

    /// [`FogTables::build`] plus a G table for every other Phong exponent
    /// that `materials` use (those with `ks` ≠ 0), so that any of them can
    /// be rendered.
    pub fn build_for<'a>(
        size: usize,
        materials: impl IntoIterator<Item = &'a crate::model::FogMaterial>,
    ) -> Result<Self, FogError> {
        let mut exponents = DEFAULT_PHONG_EXPONENTS.to_vec();
        for m in materials {
            if m.ks != glam::Vec3::ZERO && !exponents.contains(&m.n) {
                exponents.push(m.n);
            }
        }
        Self::build_with(size, DEFAULT_PHASE_DEGREE, &exponents)
    }

    /// Builds tails for phase degrees 0..=`max_phase_degree` and G tables for
    /// Lambert plus each Phong exponent in `phong` (each ≥ 1, ≤ 4096).
    pub fn build_with(size: usize, max_phase_degree: u32, phong: &[u32]) -> Result<Self, FogError> {
        Self::build_parts(size, max_phase_degree, Some(phong), true)
    }

    /// Builds only the parts asked for: tails for degrees 0..=`max_phase_degree`,
    /// G tables for Lambert and `phong` when `Some`, the paper's F when `with_f`
    /// (otherwise a 2×2 placeholder). Used by `verify_fog` to sweep sizes.
    pub fn build_parts(
        size: usize,
        max_phase_degree: u32,
        phong: Option<&[u32]>,
        with_f: bool,
    ) -> Result<Self, FogError> {
        if !(2..=MAX_TABLE_SIZE).contains(&size) {
            return Err(FogError::TableSize { size });
        }
        if let Some(&n) = phong.unwrap_or(&[]).iter().find(|&&n| n == 0 || n > 4096) {
            return Err(FogError::PhongExponent { n });
        }
        let tail = (0..=max_phase_degree.min(8))
            .map(|k| {
                Table2::tabulate(size, (0.0, 1.0), (0.0, FRAC_PI_2), |w, v| {
                    let u = if w >= 1.0 {
                        f64::INFINITY
                    } else {
                        w / (1.0 - w)
                    };
                    tail_ratio(k, u, v)
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let w_max = G_T_MAX / (1.0 + G_T_MAX);
        let mut exps = if phong.is_some() {
            vec![1u32]
        } else {
            Vec::new()
        };
        for &n in phong.unwrap_or(&[]) {
            if !exps.contains(&n) {
                exps.push(n);
            }
        }
        let g = if exps.is_empty() {
            Vec::new()
        } else {
            g_tables(size, w_max, &exps)
        };
        let f = Table2::tabulate(
            if with_f { size } else { 2 },
            (0.0, F_U_MAX),
            (0.0, FRAC_PI_2),
            |u, v| fk_special(0, u, v),
        )?;
        let corner = (0..CORNER_SAMPLES)
            .into_par_iter()
            .map(|i| {
                let x = i as f64 / (CORNER_SAMPLES - 1) as f64;
                crate::special::corner_factor(if x >= 1.0 {
                    f64::INFINITY
                } else {
                    x / (1.0 - x)
                }) as f32
            })
            .collect();
        Ok(Self {
            size,
            tail,
            g,
            f,
            corner,
        })
    }

    /// The G table for lobe exponent `n` (1 = Lambert), if built.
    #[must_use]
    pub fn g_table(&self, n: u32) -> Option<&Table2> {
        self.g.iter().find(|(m, _)| *m == n).map(|(_, t)| t)
    }

    /// Every table as a float image (`(width, height, pixels)` plus a name);
    /// the CLI writes them as EXR.
    #[must_use]
    pub fn images(&self) -> Vec<TableImage> {
        let img = |name: String, t: &Table2| TableImage {
            name,
            width: t.size,
            height: t.size,
            pixels: t.values.iter().map(|&v| Vec3::splat(v)).collect(),
        };
        let mut out = vec![img("f".into(), &self.f)];
        for (k, t) in self.tail.iter().enumerate() {
            out.push(img(format!("tail_k{k}"), t));
        }
        for (n, t) in &self.g {
            out.push(img(format!("g_n{n}"), t));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_size_outside_its_range_is_an_error() {
        assert!(matches!(
            Table2::tabulate(1, (0.0, 1.0), (0.0, 1.0), |_, _| 0.0),
            Err(FogError::TableSize { size: 1 })
        ));
        assert!(FogTables::build(0).is_err());
        assert!(matches!(
            FogTables::build(MAX_TABLE_SIZE + 1),
            Err(FogError::TableSize { .. })
        ));
    }

    #[test]
    fn lookups_reproduce_grid_and_linear_functions() {
        let t = Table2::tabulate(5, (0.0, 2.0), (-1.0, 1.0), |x, y| 3.0 * x - y + 0.5).unwrap();
        for &(x, y) in &[(0.0, -1.0), (0.5, 0.5), (1.3, -0.2), (2.0, 1.0)] {
            let want = 3.0 * x - y + 0.5;
            assert!(
                (f64::from(t.bilinear(x as f32, y as f32)) - want).abs() < 1e-5,
                "bilinear({x},{y})"
            );
        }
        assert_eq!(t.nearest(0.49, 0.0), t.values[2 * 5 + 1]);
        // Out of range clamps.
        assert_eq!(t.bilinear(-5.0, -5.0), t.values[0]);
        assert_eq!(t.nearest(9.0, 9.0), t.values[24]);
        assert!(t.bilinear(f32::NAN, 0.0).is_finite());
    }
}
