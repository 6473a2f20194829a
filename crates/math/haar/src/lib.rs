//! 2D Haar wavelets on square `n × n` maps (n a power of two), sparse
//! coefficient vectors, non-linear approximation and 16-bit quantization.
//!
//! # What
//! The orthonormal **nonstandard** 2D Haar decomposition (Stollnitz, DeRose,
//! Salesin, *Wavelets for Computer Graphics*, 1996, §3.2; used on octahedral
//! maps by Wang, Ng, Luebke, Humphreys, "Efficient Wavelet Rotation for
//! Environment Map Rendering", EGSR 2006, §3). Each step replaces every 2×2
//! block `[a b; c d]` of the current `s × s` low-pass region by one average and
//! three details,
//!
//! ```text
//!   avg = (a + b + c + d) / 2     H = (a − b + c − d) / 2   (left − right)
//!   V   = (a + b − c − d) / 2     D = (a − b − c + d) / 2   (top − bottom, diagonal)
//! ```
//!
//! which is an orthonormal 4×4 matrix, so the whole transform is orthonormal:
//! inverse = transpose, and Parseval `Σ x² = Σ c²` holds.
//!
//! # Coefficient layout (Mallat layout, row-major `index = row * n + col`)
//! | index (row, col)                  | basis function                               |
//! |-----------------------------------|----------------------------------------------|
//! | (0, 0)                            | scaling function, value `1/n` on every texel |
//! | (py, h + px), `px, py < h`        | type H at level `log2 h`, support `n/h` texels |
//! | (h + py, px)                      | type V                                        |
//! | (h + py, h + px)                  | type D                                        |
//!
//! for `h = 1, 2, 4, …, n/2`. Level 0 is the coarsest (support the whole map).
//! A texel `(x, y)` (column, row) lies in the support of exactly one wavelet of
//! each type per level, so the transform of a sparse image is computed by
//! enumerating its [`ancestors`] (`3 log2 n + 1` coefficients per texel).
//!
//! Basis functions are explicit objects ([`Basis`]) that know their level,
//! offset, type and support and evaluate both as texel values (the discrete,
//! orthonormal-on-texels vectors of the transform) and as functions on the
//! unit square `[0,1]²` (orthonormal in L²(\[0,1\]²): value = texel value × n).
//!
//! # Sparse vectors and non-linear approximation
//! [`SparseVec`] and [`SparseRgb`] store sorted indices with values.
//! [`top_k_rgb`] keeps the `k` terms of largest RGB energy `r² + g² + b²`
//! (optionally multiplied by the support area, [`Ranking::AreaWeighted`], the
//! area weighting of Ng, Ramamoorthi, Hanrahan 2003 §4): **one index set shared
//! by the three channels**, chosen to minimise the summed squared L2 error of
//! R, G and B among shared sets of size `k`.
//!
//! # Quantization
//! [`quantize_i16`] maps values to `q = round(v / scale)` with one scale per
//! matrix, `scale = max|v| / 32767`, and drops `|q| < ntrunc` (paper §3 and
//! Table 1). Kept values have error ≤ `scale / 2`; dropped ones have magnitude
//! < `(ntrunc − ½) · scale`.

#![deny(missing_docs)]

/// Errors of this crate (bad sizes).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum HaarError {
    /// `n` is not a power of two ≥ 1.
    #[error("map side n = {0} is not a power of two")]
    NotPowerOfTwo(usize),
    /// The buffer length is not `n * n`.
    #[error("buffer has {got} values, expected n² = {expected}")]
    BadLength {
        /// Expected `n * n`.
        expected: usize,
        /// Given length.
        got: usize,
    },
}

fn check(n: usize, len: usize) -> Result<(), HaarError> {
    if n == 0 || !n.is_power_of_two() {
        return Err(HaarError::NotPowerOfTwo(n));
    }
    if len != n * n {
        return Err(HaarError::BadLength {
            expected: n * n,
            got: len,
        });
    }
    Ok(())
}

/// Forward orthonormal nonstandard 2D Haar transform of an `n × n` row-major
/// map, in place (a scratch copy of one `s × s` block per step is made).
///
/// # Errors
/// [`HaarError`] when `n` is not a power of two or `data.len() != n²`.
pub fn try_forward_2d(data: &mut [f32], n: usize) -> Result<(), HaarError> {
    check(n, data.len())?;
    let mut scratch = vec![0.0f32; n * n];
    forward_2d_with_scratch(data, n, &mut scratch);
    Ok(())
}

/// Inverse of [`try_forward_2d`], in place.
///
/// # Errors
/// [`HaarError`] when `n` is not a power of two or `data.len() != n²`.
pub fn try_inverse_2d(data: &mut [f32], n: usize) -> Result<(), HaarError> {
    check(n, data.len())?;
    let mut scratch = vec![0.0f32; n * n];
    inverse_2d_with_scratch(data, n, &mut scratch);
    Ok(())
}

/// [`try_forward_2d`] for a caller that has validated `n` (allocation-free
/// given `scratch.len() >= n * n`).
///
/// # Panics
/// When `data.len() != n * n` or the scratch is too small.
pub fn forward_2d_with_scratch(data: &mut [f32], n: usize, scratch: &mut [f32]) {
    assert_eq!(data.len(), n * n, "haar2d: buffer is not n²");
    let mut s = n;
    while s > 1 {
        let h = s / 2;
        // Read the s×s low-pass region from data into scratch (row stride n).
        for y in 0..h {
            for x in 0..h {
                let a = data[(2 * y) * n + 2 * x];
                let b = data[(2 * y) * n + 2 * x + 1];
                let c = data[(2 * y + 1) * n + 2 * x];
                let d = data[(2 * y + 1) * n + 2 * x + 1];
                scratch[y * n + x] = 0.5 * (a + b + c + d);
                scratch[y * n + h + x] = 0.5 * (a - b + c - d);
                scratch[(h + y) * n + x] = 0.5 * (a + b - c - d);
                scratch[(h + y) * n + h + x] = 0.5 * (a - b - c + d);
            }
        }
        for y in 0..s {
            data[y * n..y * n + s].copy_from_slice(&scratch[y * n..y * n + s]);
        }
        s = h;
    }
}

/// [`try_inverse_2d`] for a caller that has validated `n`.
///
/// # Panics
/// When `data.len() != n * n` or the scratch is too small.
pub fn inverse_2d_with_scratch(data: &mut [f32], n: usize, scratch: &mut [f32]) {
    assert_eq!(data.len(), n * n, "haar2d: buffer is not n²");
    let mut s = 2;
    while s <= n {
        let h = s / 2;
        for y in 0..h {
            for x in 0..h {
                let avg = data[y * n + x];
                let hh = data[y * n + h + x];
                let vv = data[(h + y) * n + x];
                let dd = data[(h + y) * n + h + x];
                scratch[(2 * y) * n + 2 * x] = 0.5 * (avg + hh + vv + dd);
                scratch[(2 * y) * n + 2 * x + 1] = 0.5 * (avg - hh + vv - dd);
                scratch[(2 * y + 1) * n + 2 * x] = 0.5 * (avg + hh - vv - dd);
                scratch[(2 * y + 1) * n + 2 * x + 1] = 0.5 * (avg - hh - vv + dd);
            }
        }
        for y in 0..s {
            data[y * n..y * n + s].copy_from_slice(&scratch[y * n..y * n + s]);
        }
        s *= 2;
    }
}

/// Forward transform of three channels stored as `[r, g, b]` texels.
///
/// # Errors
/// As [`try_forward_2d`].
pub fn try_forward_2d_rgb(data: &mut [[f32; 3]], n: usize) -> Result<(), HaarError> {
    check(n, data.len())?;
    let mut chan = vec![0.0f32; n * n];
    let mut scratch = vec![0.0f32; n * n];
    for c in 0..3 {
        for (d, s) in chan.iter_mut().zip(data.iter()) {
            *d = s[c];
        }
        forward_2d_with_scratch(&mut chan, n, &mut scratch);
        for (s, d) in data.iter_mut().zip(&chan) {
            s[c] = *d;
        }
    }
    Ok(())
}

/// Inverse of [`try_forward_2d_rgb`].
///
/// # Errors
/// As [`try_forward_2d`].
pub fn try_inverse_2d_rgb(data: &mut [[f32; 3]], n: usize) -> Result<(), HaarError> {
    check(n, data.len())?;
    let mut chan = vec![0.0f32; n * n];
    let mut scratch = vec![0.0f32; n * n];
    for c in 0..3 {
        for (d, s) in chan.iter_mut().zip(data.iter()) {
            *d = s[c];
        }
        inverse_2d_with_scratch(&mut chan, n, &mut scratch);
        for (s, d) in data.iter_mut().zip(&chan) {
            s[c] = *d;
        }
    }
    Ok(())
}

/// The three wavelet types of the nonstandard 2D Haar basis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WaveletType {
    /// Horizontal difference: + on the left half of the support, − on the right.
    H,
    /// Vertical difference: + on the top half (smaller rows), − on the bottom.
    V,
    /// Diagonal: + on top-left and bottom-right quadrants, − elsewhere.
    D,
}

/// One basis function ψ_i of the `n × n` nonstandard Haar basis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Basis {
    /// The constant scaling function (index 0).
    Scaling,
    /// A wavelet at `level` (0 = coarsest; `2^level × 2^level` wavelets of each
    /// type), offset (`px`, `py`) in units of its support.
    Wavelet {
        /// Type H, V or D.
        ty: WaveletType,
        /// 0 ..= log2(n) − 1.
        level: u32,
        /// Column offset in supports, `< 2^level`.
        px: u32,
        /// Row offset in supports, `< 2^level`.
        py: u32,
    },
}

/// A texel rectangle: columns `x0..x0+size`, rows `y0..y0+size`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Support {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// Side in texels.
    pub size: usize,
}

impl Basis {
    /// The basis function of coefficient `index` in an `n × n` map (Mallat layout).
    ///
    /// # Panics
    /// When `index >= n * n` (caller validates).
    #[must_use]
    pub fn from_index(index: usize, n: usize) -> Self {
        assert!(
            index < n * n,
            "basis index {index} out of range for n = {n}"
        );
        let (r, c) = (index / n, index % n);
        if r == 0 && c == 0 {
            return Self::Scaling;
        }
        let h = 1usize << (usize::BITS - 1 - r.max(c).leading_zeros());
        let level = h.trailing_zeros();
        let (ty, px, py) = if r < h {
            (WaveletType::H, c - h, r)
        } else if c < h {
            (WaveletType::V, c, r - h)
        } else {
            (WaveletType::D, c - h, r - h)
        };
        Self::Wavelet {
            ty,
            level,
            px: px as u32,
            py: py as u32,
        }
    }

    /// Coefficient index in an `n × n` map (inverse of [`Basis::from_index`]).
    #[must_use]
    pub fn index(&self, n: usize) -> usize {
        match *self {
            Self::Scaling => 0,
            Self::Wavelet { ty, level, px, py } => {
                let h = 1usize << level;
                let (px, py) = (px as usize, py as usize);
                match ty {
                    WaveletType::H => py * n + h + px,
                    WaveletType::V => (h + py) * n + px,
                    WaveletType::D => (h + py) * n + h + px,
                }
            }
        }
    }

    /// The texels where the function is non-zero.
    #[must_use]
    pub fn support(&self, n: usize) -> Support {
        match *self {
            Self::Scaling => Support {
                x0: 0,
                y0: 0,
                size: n,
            },
            Self::Wavelet { level, px, py, .. } => {
                let size = n >> level;
                Support {
                    x0: px as usize * size,
                    y0: py as usize * size,
                    size,
                }
            }
        }
    }

    /// Value on texel (`x` column, `y` row): the entry of the orthonormal
    /// discrete basis vector (Σ over texels of value² = 1).
    #[must_use]
    pub fn texel_value(&self, n: usize, x: usize, y: usize) -> f32 {
        let s = self.support(n);
        if x < s.x0 || y < s.y0 || x >= s.x0 + s.size || y >= s.y0 + s.size {
            return 0.0;
        }
        let mag = 1.0 / s.size as f32;
        match *self {
            Self::Scaling => mag,
            Self::Wavelet { ty, .. } => {
                let left = (x - s.x0) < s.size / 2;
                let top = (y - s.y0) < s.size / 2;
                let sign = match ty {
                    WaveletType::H => left,
                    WaveletType::V => top,
                    WaveletType::D => left == top,
                };
                if sign { mag } else { -mag }
            }
        }
    }

    /// Value at the continuous map point `uv` ∈ \[0,1\]² (u along columns, v
    /// along rows), normalised so that ∫∫ ψ² du dv = 1: `texel_value × n`.
    #[must_use]
    pub fn eval(&self, n: usize, u: f64, v: f64) -> f64 {
        if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&v) {
            return 0.0;
        }
        let x = ((u * n as f64) as usize).min(n - 1);
        let y = ((v * n as f64) as usize).min(n - 1);
        f64::from(self.texel_value(n, x, y)) * n as f64
    }

    /// Area of the support as a fraction of the map, in (0, 1].
    #[must_use]
    pub fn support_area(&self, n: usize) -> f32 {
        let s = self.support(n).size as f32 / n as f32;
        s * s
    }
}

/// Calls `f(index, value)` for every basis function whose support contains
/// texel (`x`, `y`) of an `n × n` map, `value` = [`Basis::texel_value`]:
/// the scaling function and three wavelets per level (`3 log2 n + 1` calls).
/// The Haar transform of a sparse image is the sum over its texels of
/// texel × these.
#[inline]
pub fn ancestors(n: usize, x: usize, y: usize, mut f: impl FnMut(usize, f32)) {
    f(0, 1.0 / n as f32);
    let mut h = 1usize;
    while h < n {
        let size = n / h;
        let (px, py) = (x / size, y / size);
        let left = (x % size) < size / 2;
        let top = (y % size) < size / 2;
        let mag = 1.0 / size as f32;
        f(py * n + h + px, if left { mag } else { -mag });
        f((h + py) * n + px, if top { mag } else { -mag });
        f((h + py) * n + h + px, if left == top { mag } else { -mag });
        h *= 2;
    }
}

/// A sparse scalar vector: sorted unique `indices` and their `values`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseVec {
    /// Strictly increasing indices.
    pub indices: Vec<u32>,
    /// One value per index.
    pub values: Vec<f32>,
}

impl SparseVec {
    /// Builds from unsorted `(index, value)` pairs, summing duplicates and
    /// dropping exact zeros.
    #[must_use]
    pub fn from_pairs(mut pairs: Vec<(u32, f32)>) -> Self {
        pairs.sort_unstable_by_key(|p| p.0);
        let mut merged: Vec<(u32, f32)> = Vec::with_capacity(pairs.len());
        for (i, v) in pairs {
            match merged.last_mut() {
                Some(last) if last.0 == i => last.1 += v,
                _ => merged.push((i, v)),
            }
        }
        let (indices, values) = merged.into_iter().filter(|p| p.1 != 0.0).unzip();
        Self { indices, values }
    }

    /// Number of stored terms.
    #[must_use]
    pub fn nnz(&self) -> usize {
        self.indices.len()
    }

    /// Dense vector of length `len`.
    #[must_use]
    pub fn to_dense(&self, len: usize) -> Vec<f32> {
        let mut d = vec![0.0; len];
        for (i, v) in self.indices.iter().zip(&self.values) {
            d[*i as usize] = *v;
        }
        d
    }

    /// Dot product of two sparse vectors (merge of sorted index lists).
    #[must_use]
    pub fn dot(&self, other: &SparseVec) -> f32 {
        let (mut a, mut b, mut s) = (0, 0, 0.0);
        while a < self.indices.len() && b < other.indices.len() {
            match self.indices[a].cmp(&other.indices[b]) {
                std::cmp::Ordering::Less => a += 1,
                std::cmp::Ordering::Greater => b += 1,
                std::cmp::Ordering::Equal => {
                    s += self.values[a] * other.values[b];
                    a += 1;
                    b += 1;
                }
            }
        }
        s
    }
}

/// A sparse RGB vector: sorted unique indices shared by the three channels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseRgb {
    /// Strictly increasing indices.
    pub indices: Vec<u32>,
    /// `[r, g, b]` per index.
    pub values: Vec<[f32; 3]>,
}

impl SparseRgb {
    /// Number of stored terms.
    #[must_use]
    pub fn nnz(&self) -> usize {
        self.indices.len()
    }
    /// Dense vector of length `len`.
    #[must_use]
    pub fn to_dense(&self, len: usize) -> Vec<[f32; 3]> {
        let mut d = vec![[0.0; 3]; len];
        for (i, v) in self.indices.iter().zip(&self.values) {
            d[*i as usize] = *v;
        }
        d
    }
}

/// How [`top_k_rgb`] ranks coefficients.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Ranking {
    /// By RGB energy `r² + g² + b²` (optimal shared set for the L2 error).
    #[default]
    Magnitude,
    /// By energy × support area (Ng et al. 2003 area weighting; favours coarse terms).
    AreaWeighted,
}

impl Ranking {
    /// Every ranking, in CLI order.
    pub const ALL: [Self; 2] = [Self::Magnitude, Self::AreaWeighted];

    /// The CLI spelling.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Magnitude => "magnitude",
            Self::AreaWeighted => "area-weighted",
        }
    }
}

impl std::str::FromStr for Ranking {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|r| r.name() == s)
            .ok_or_else(|| format!("`{s}`: expected magnitude or area-weighted"))
    }
}

/// Non-linear approximation: the `k` coefficients of a dense RGB coefficient
/// vector (`n × n` Mallat layout) with the largest score under `ranking`,
/// one index set shared by R, G and B; ties broken by lower index. Returns all
/// non-zero terms when `k` exceeds their count.
#[must_use]
pub fn top_k_rgb(coeffs: &[[f32; 3]], n: usize, k: usize, ranking: Ranking) -> SparseRgb {
    let score = |i: usize| {
        let c = coeffs[i];
        let e = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        match ranking {
            Ranking::Magnitude => e,
            Ranking::AreaWeighted => e * Basis::from_index(i, n).support_area(n),
        }
    };
    let mut order: Vec<(f32, u32)> = (0..coeffs.len())
        .map(|i| (score(i), i as u32))
        .filter(|p| p.0 > 0.0)
        .collect();
    let cmp = |a: &(f32, u32), b: &(f32, u32)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
    if k < order.len() {
        if k == 0 {
            order.clear();
        } else {
            order.select_nth_unstable_by(k - 1, cmp);
            order.truncate(k);
        }
    }
    let mut idx: Vec<u32> = order.into_iter().map(|p| p.1).collect();
    idx.sort_unstable();
    let values = idx.iter().map(|&i| coeffs[i as usize]).collect();
    SparseRgb {
        indices: idx,
        values,
    }
}

/// Scalar version of [`top_k_rgb`] (ranking by |value|).
#[must_use]
pub fn top_k(coeffs: &[f32], k: usize) -> SparseVec {
    let rgb: Vec<[f32; 3]> = coeffs.iter().map(|&v| [v, 0.0, 0.0]).collect();
    let s = top_k_rgb(&rgb, 1, k, Ranking::Magnitude);
    SparseVec {
        indices: s.indices,
        values: s.values.iter().map(|v| v[0]).collect(),
    }
}

/// Fraction of the L2 energy (summed over channels) that `kept` retains of `all`.
#[must_use]
pub fn energy_fraction(kept: &SparseRgb, all: &[[f32; 3]]) -> f64 {
    let e = |v: &[f32; 3]| v.iter().map(|c| f64::from(*c) * f64::from(*c)).sum::<f64>();
    let total: f64 = all.iter().map(e).sum();
    if total == 0.0 {
        return 1.0;
    }
    kept.values.iter().map(e).sum::<f64>() / total
}

/// Uniform 16-bit quantization with one scale (paper §3 "quantize each
/// matrix element uniformly to a 16-bit integer").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantizer {
    /// Value of one quantization step; `max|v| / 32767` (1 when all zero).
    pub scale: f32,
    /// Quantized values with `|q| < ntrunc` are dropped.
    pub ntrunc: u16,
}

impl Quantizer {
    /// A quantizer for values whose largest magnitude is `max_abs`.
    #[must_use]
    pub fn for_max(max_abs: f32, ntrunc: u16) -> Self {
        let scale = if max_abs > 0.0 && max_abs.is_finite() {
            max_abs / 32767.0
        } else {
            1.0
        };
        Self { scale, ntrunc }
    }
    /// Quantized value, or `None` when it is truncated.
    #[inline]
    #[must_use]
    pub fn quantize(&self, v: f32) -> Option<i16> {
        let q = (v / self.scale).round().clamp(-32767.0, 32767.0) as i16;
        (q.unsigned_abs() >= self.ntrunc.max(1)).then_some(q)
    }
    /// Value of a quantized integer.
    #[inline]
    #[must_use]
    pub fn dequantize(&self, q: i16) -> f32 {
        f32::from(q) * self.scale
    }
}

/// Quantizes `values` with a shared scale; returns the quantizer and
/// `(position, q)` for each kept value.
#[must_use]
pub fn quantize_i16(values: &[f32], ntrunc: u16) -> (Quantizer, Vec<(usize, i16)>) {
    let max = values.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let qz = Quantizer::for_max(max, ntrunc);
    let kept = values
        .iter()
        .enumerate()
        .filter_map(|(i, &v)| qz.quantize(v).map(|q| (i, q)))
        .collect();
    (qz, kept)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random values (xorshift), seeded.
    fn rand_vec(len: usize, seed: u64) -> Vec<f32> {
        let mut s = seed.max(1);
        (0..len)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
            })
            .collect()
    }

    #[test]
    fn inverse_of_forward_is_identity_and_parseval_holds() {
        for n in [1, 2, 4, 16, 32] {
            let x = rand_vec(n * n, 7 + n as u64);
            let mut c = x.clone();
            try_forward_2d(&mut c, n).unwrap();
            let ex: f64 = x.iter().map(|v| f64::from(*v).powi(2)).sum();
            let ec: f64 = c.iter().map(|v| f64::from(*v).powi(2)).sum();
            assert!(
                (ex - ec).abs() < 1e-4 * ex.max(1.0),
                "Parseval n={n}: {ex} vs {ec}"
            );
            try_inverse_2d(&mut c, n).unwrap();
            let err = x
                .iter()
                .zip(&c)
                .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
            assert!(err < 1e-5, "n={n}: max round-trip error {err}");
        }
    }

    #[test]
    fn basis_vectors_are_orthonormal() {
        let n = 8;
        let vecs: Vec<Vec<f32>> = (0..n * n)
            .map(|i| {
                let b = Basis::from_index(i, n);
                (0..n * n).map(|t| b.texel_value(n, t % n, t / n)).collect()
            })
            .collect();
        for i in 0..n * n {
            for j in 0..n * n {
                let d: f32 = vecs[i].iter().zip(&vecs[j]).map(|(a, b)| a * b).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((d - want).abs() < 1e-6, "<ψ{i},ψ{j}> = {d}, want {want}");
            }
        }
    }

    #[test]
    fn basis_eval_equals_inverse_transform_of_unit_vector() {
        let n = 16;
        for i in 0..n * n {
            let b = Basis::from_index(i, n);
            assert_eq!(b.index(n), i, "index round trip");
            let mut e = vec![0.0f32; n * n];
            e[i] = 1.0;
            try_inverse_2d(&mut e, n).unwrap();
            for y in 0..n {
                for x in 0..n {
                    let tv = b.texel_value(n, x, y);
                    let u = (x as f64 + 0.5) / n as f64;
                    let v = (y as f64 + 0.5) / n as f64;
                    let ev = b.eval(n, u, v) / n as f64;
                    assert!(
                        (tv - e[y * n + x]).abs() < 1e-6,
                        "ψ{i} ({x},{y}): {tv} vs inverse {}",
                        e[y * n + x]
                    );
                    assert!((ev - f64::from(tv)).abs() < 1e-6);
                }
            }
        }
    }

    #[test]
    fn continuous_basis_is_l2_normalised_by_quadrature() {
        // Second way: midpoint quadrature of ψ² over [0,1]² with 4× finer grid.
        let n = 8;
        let q = 4 * n;
        for i in [0, 1, 5, 17, 63] {
            let b = Basis::from_index(i, n);
            let mut s = 0.0;
            for y in 0..q {
                for x in 0..q {
                    let v = b.eval(n, (x as f64 + 0.5) / q as f64, (y as f64 + 0.5) / q as f64);
                    s += v * v / (q * q) as f64;
                }
            }
            assert!((s - 1.0).abs() < 1e-9, "∫ψ{i}² = {s}");
        }
    }

    #[test]
    fn ancestors_give_the_transform_of_a_sparse_image() {
        let n = 16;
        let texels = [(3usize, 5usize, 1.5f32), (15, 0, -2.0), (7, 7, 0.25)];
        let mut dense = vec![0.0f32; n * n];
        let mut pairs = Vec::new();
        for &(x, y, v) in &texels {
            dense[y * n + x] = v;
            ancestors(n, x, y, |i, w| pairs.push((i as u32, w * v)));
        }
        try_forward_2d(&mut dense, n).unwrap();
        let sp = SparseVec::from_pairs(pairs).to_dense(n * n);
        for i in 0..n * n {
            assert!(
                (sp[i] - dense[i]).abs() < 1e-6,
                "coef {i}: sparse {} vs dense {}",
                sp[i],
                dense[i]
            );
        }
    }

    #[test]
    fn top_k_keeps_the_largest_with_shared_rgb_set() {
        let n = 8;
        let r = rand_vec(n * n, 3);
        let coeffs: Vec<[f32; 3]> = r.iter().map(|&v| [v, 0.5 * v, -v]).collect();
        let k = 10;
        let s = top_k_rgb(&coeffs, n, k, Ranking::Magnitude);
        assert_eq!(s.nnz(), k);
        let min_kept = s
            .values
            .iter()
            .map(|v| v[0].abs())
            .fold(f32::INFINITY, f32::min);
        let kept: std::collections::HashSet<u32> = s.indices.iter().copied().collect();
        for (i, c) in coeffs.iter().enumerate() {
            if !kept.contains(&(i as u32)) {
                assert!(
                    c[0].abs() <= min_kept,
                    "dropped {} > kept min {min_kept}",
                    c[0]
                );
            }
        }
        let ef = energy_fraction(&s, &coeffs);
        assert!(ef > 0.0 && ef < 1.0);
        let all = top_k_rgb(&coeffs, n, 1000, Ranking::Magnitude);
        assert!((energy_fraction(&all, &coeffs) - 1.0).abs() < 1e-9);
        // Area weighting prefers coarse terms of equal magnitude.
        let mut flat = vec![[0.0f32; 3]; n * n];
        flat[1] = [1.0, 1.0, 1.0];
        flat[63] = [1.5, 1.5, 1.5];
        assert_eq!(
            top_k_rgb(&flat, n, 1, Ranking::AreaWeighted).indices,
            vec![1]
        );
        assert_eq!(top_k_rgb(&flat, n, 1, Ranking::Magnitude).indices, vec![63]);
    }

    #[test]
    fn quantization_error_is_bounded() {
        let v = rand_vec(4096, 11);
        for ntrunc in [1u16, 16, 128] {
            let (qz, kept) = quantize_i16(&v, ntrunc);
            let mut deq = vec![0.0f32; v.len()];
            for &(i, q) in &kept {
                deq[i] = qz.dequantize(q);
                assert!(
                    (deq[i] - v[i]).abs() <= 0.5 * qz.scale * 1.0001,
                    "kept error too large"
                );
            }
            for (i, x) in v.iter().enumerate() {
                if deq[i] == 0.0 {
                    assert!(
                        x.abs() < (f32::from(ntrunc) - 0.5 + 1e-3) * qz.scale,
                        "dropped {x} too large"
                    );
                }
            }
        }
    }

    #[test]
    fn bad_sizes_are_errors() {
        let mut d = vec![0.0f32; 9];
        assert_eq!(try_forward_2d(&mut d, 3), Err(HaarError::NotPowerOfTwo(3)));
        let mut d = vec![0.0f32; 15];
        assert!(matches!(
            try_inverse_2d(&mut d, 4),
            Err(HaarError::BadLength { .. })
        ));
    }
}
