//! The light's wavelet coefficients and source-level compression (thesis
//! §4.5.5, "Source-Level Compression").
//!
//! The emitted radiance `F(u) = texture(u) × intensity` over the light's uv
//! square is box-averaged onto an `n × n` grid (`q × q` bilinear texture
//! reads per cell) and transformed to the standard 2D Haar basis
//! ([`relight_affine::standard`]), per RGB channel.
//!
//! # Source-level compression
//! The thesis keeps "the most significant" `n_s` coefficients, "as in
//! standard PRT". Two rankings ([`Ranking`]), both on the channel sum
//! `|F| = |F_r| + |F_g| + |F_b|`:
//! - [`Ranking::Magnitude`]: largest `|F|`, the L2-optimal set for the
//!   light's radiance itself;
//! - [`Ranking::AreaWeighted`] (the default): largest `|F| · √A`, `A =
//!   w(i₁) w(i₂)` the basis function's support area on the unit square
//!   (`w(i) = 1` for `i ≤ 1`, else `2^{1 − rank(i)}`), which orders like
//!   the `|F|² · A` of Ng, Ramamoorthi and Hanrahan (2003, §4) that the
//!   wavelet method offers. Why it suits propagation: a vertex integrates
//!   the light against its transport, which over most of the light is
//!   smooth at the light's scale (the light fills a small part of the
//!   face). Dropping `F_k ψ_k` then costs about `F_k ⟨ψ_k, T⟩`, and
//!   `|⟨ψ_k, T⟩| ≤ ‖ψ_k‖₁ · osc(T) = √A · osc(T)` over the support: a fine
//!   wavelet of a sharp edge has a large `|F_k|` but little effect on any
//!   vertex. The difference is largest for a light turned in its plane
//!   ([`crate::rotate`]), whose bounding rectangle's zero corners and
//!   diagonal edges fill the magnitude ranking with fine terms
//!   (`docs/nearfield.md` has both rankings' errors).
//!
//! The thesis does not say how ties are broken: here **coarse first**
//! (smaller `max(level(i₁), level(i₂))`, then smaller `i₂`, then `i₁`).
//! The scaling coefficient (the light's mean, all of its power) is always
//! kept: a sky texture with a sun has many wavelets larger than its mean,
//! and dropping the mean leaves a light that integrates to nothing.

use glam::{Vec2, Vec3};
use relight_affine::standard::{forward_2d, level_rank};
pub use relight_haar::Ranking;
use relight_render::AreaLight;

/// Texture reads per cell side when box-averaging the light.
pub const LIGHT_SUBSAMPLES: usize = 4;

/// Dense standard-basis coefficients of the light, per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct LightCoeffs {
    pub n: usize,
    /// `[channel][i2 · n + i1]`.
    pub c: [Vec<f64>; 3],
}

impl LightCoeffs {
    /// Box-averages and transforms `light`'s radiance at order `n`.
    #[must_use]
    pub fn of(light: &AreaLight, n: usize) -> Self {
        Self::of_at(light, n, n)
    }

    /// `light` box-averaged at order `coarse` (≤ `n`, powers of two),
    /// each cell repeated onto the `n × n` grid, transformed at order `n`:
    /// the order-`coarse` light exactly, in the order-`n` basis (its finer
    /// details are zero).
    #[must_use]
    pub fn of_at(light: &AreaLight, n: usize, coarse: usize) -> Self {
        let coarse = coarse.min(n);
        Self::of_cells(&light_cells(light, coarse), n, coarse)
    }

    /// Box-averaged cells at order `coarse` (from [`light_cells`] or
    /// [`cells_of`]), each repeated onto the `n × n` grid, transformed at
    /// order `n`.
    #[must_use]
    pub fn of_cells(cells: &[Vec<f64>; 3], n: usize, coarse: usize) -> Self {
        let r = n / coarse;
        let mut grids = [vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]];
        for (g, c) in grids.iter_mut().zip(cells) {
            for y in 0..n {
                for x in 0..n {
                    g[y * n + x] = c[(y / r) * coarse + x / r];
                }
            }
            forward_2d(g, n);
        }
        Self { n, c: grids }
    }

    /// The DC-only ("constant light") coefficients of the same mean: the
    /// heuristic light of eq. 4.38 and the distant baseline's light.
    #[must_use]
    pub fn mean(&self) -> Vec3 {
        Vec3::new(
            self.c[0][0] as f32,
            self.c[1][0] as f32,
            self.c[2][0] as f32,
        )
    }
}

/// The light's radiance box-averaged on an `n × n` grid of its uv square
/// (row `y` = uv.y, `q × q` texture reads per cell), per channel.
#[must_use]
pub fn light_cells(light: &AreaLight, n: usize) -> [Vec<f64>; 3] {
    cells_of(n, LIGHT_SUBSAMPLES, &|uv| light.radiance_at(uv))
}

/// `radiance(uv)` over the uv square box-averaged on an `n × n` grid by
/// `q × q` midpoint reads per cell, per channel (row `y` = uv.y).
#[must_use]
pub fn cells_of(n: usize, q: usize, radiance: &dyn Fn(Vec2) -> Vec3) -> [Vec<f64>; 3] {
    let mut grids = [vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]];
    let h = 1.0 / (n * q) as f32;
    for y in 0..n {
        for x in 0..n {
            let mut sum = Vec3::ZERO;
            for j in 0..q {
                for i in 0..q {
                    let uv = Vec2::new(
                        ((x * q + i) as f32 + 0.5) * h,
                        ((y * q + j) as f32 + 0.5) * h,
                    );
                    sum += radiance(uv);
                }
            }
            let m = sum / (q * q) as f32;
            for (c, g) in grids.iter_mut().enumerate() {
                g[y * n + x] = f64::from(m[c]);
            }
        }
    }
    grids
}

/// One retained source coefficient.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourceTerm {
    pub i1: u16,
    pub rgb: [f32; 3],
}

/// Source terms grouped by row `i2` (the order step 1 runs in).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SourceTerms {
    pub n: usize,
    /// `(i2, start, end)` into `terms`.
    pub rows: Vec<(u16, u32, u32)>,
    pub terms: Vec<SourceTerm>,
}

impl SourceTerms {
    /// Number of retained terms.
    #[must_use]
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// True when nothing is retained.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }
}

/// `max(1, round(fraction · n²))` terms, the count a fraction keeps.
#[must_use]
pub fn count_of(fraction: f64, n: usize) -> usize {
    ((fraction * (n * n) as f64).round() as usize).clamp(1, n * n)
}

/// Coarse-first tie-break key of 2D index `(i1, i2)`.
#[must_use]
pub fn coarse_key(i1: usize, i2: usize) -> (u32, usize, usize) {
    (level_rank(i1).max(level_rank(i2)), i2, i1)
}

/// Side of the support of 1D standard-basis index `i` on `[0, 1]`: 1 for
/// φ (`i = 0`) and the mother wavelet, halving per level.
#[must_use]
pub fn support_width(i: usize) -> f64 {
    if i <= 1 {
        1.0
    } else {
        0.5f64.powi(level_rank(i) as i32 - 1)
    }
}

/// The `count_of(fraction)` coefficients that rank highest under `ranking`
/// (module docs), zeros dropped.
#[must_use]
pub fn compress(light: &LightCoeffs, fraction: f64, ranking: Ranking) -> SourceTerms {
    let n = light.n;
    let mut idx = ranked(light, ranking, 1.0);
    idx.sort_by(|a, b| {
        b.0.total_cmp(&a.0)
            .then_with(|| coarse_key(a.1 % n, a.1 / n).cmp(&coarse_key(b.1 % n, b.1 / n)))
    });
    // The DC term first, always (module docs).
    if let Some(p) = idx.iter().position(|&(_, k)| k == 0) {
        let dc = idx.remove(p);
        idx.insert(0, dc);
    }
    idx.truncate(count_of(fraction, n));
    let kept: Vec<usize> = idx.iter().map(|&(_, k)| k).collect();
    terms_of(light, kept)
}

/// `(score, k)` of every non-zero coefficient of `light`: its magnitude
/// summed over the channels, times the support weight of `ranking` and
/// `weight` (unsorted).
#[must_use]
pub fn ranked(light: &LightCoeffs, ranking: Ranking, weight: f64) -> Vec<(f64, usize)> {
    let n = light.n;
    (0..n * n)
        .map(|k| {
            let m: f64 = light.c.iter().map(|c| c[k].abs()).sum();
            let w = match ranking {
                Ranking::Magnitude => 1.0,
                Ranking::AreaWeighted => (support_width(k % n) * support_width(k / n)).sqrt(),
            };
            (m * w * weight, k)
        })
        .filter(|(m, _)| *m > 0.0)
        .collect()
}

/// The coefficients `kept` (indices `i2 · n + i1`, any order) of `light`
/// as source terms, grouped by row.
#[must_use]
pub fn terms_of(light: &LightCoeffs, mut kept: Vec<usize>) -> SourceTerms {
    let n = light.n;
    kept.sort_by_key(|&k| (k / n, k % n));
    let mut out = SourceTerms {
        n,
        ..SourceTerms::default()
    };
    for k in kept {
        let (i1, i2) = (k % n, k / n);
        if out.rows.last().is_none_or(|r| r.0 as usize != i2) {
            let at = out.terms.len() as u32;
            out.rows.push((i2 as u16, at, at));
        }
        out.terms.push(SourceTerm {
            i1: i1 as u16,
            rgb: [0, 1, 2].map(|c| light.c[c][k] as f32),
        });
        out.rows.last_mut().expect("pushed").2 += 1;
    }
    out
}
