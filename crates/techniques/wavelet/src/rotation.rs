//! Precomputed wavelet rotation matrices (wavelet-rotation-2006 §2, Eq. 4–5,
//! and §3 "Precomputing Rotation Matrices").
//!
//! # What
//! For every sampled normal `n_k` (texel centres of an `ntess × ntess`
//! octahedral grid, [`crate::octa::grid_normal`]) with local frame
//! `R_k = [x y n_k]` ([`crate::octa::shading_frame`]), the `M × N` matrix
//! `𝐑_k` maps Haar coefficients of the global lighting on the `n × n`
//! octahedral map (`N = n²`) to Haar coefficients of the local lighting
//! `L̃(ω) = L(R_k ω)` on the `m × m` hemi-octahedral map (`M = m²`, `m = n/2`
//! by default). Column `i` is the Haar transform of source basis ψ_i resampled
//! in the local frame (paper Fig. 4).
//!
//! # How (linearity instead of one resampling per basis)
//! Resampling is linear, so `𝐑_k = H_M · W_k · H_Nᵀ`, where `W_k[t][s]` is the
//! fraction of target texel `t`'s solid angle that falls in source texel `s`
//! (an area integral: each target texel is supersampled with `ss × ss`
//! stratified midpoints weighted by the exact area element `2/|P|³` of the
//! hemi-octahedral map; rows sum to 1, so the local lighting is the
//! solid-angle mean of the global radiance over each target texel). Then
//! 1. each row of `W_k` (≈ 5 source texels) is Haar-transformed along the
//!    source by enumerating the `3 log2 n + 1` ancestors of its texels
//!    (`relight_haar::ancestors`, compact support: nothing else is touched);
//! 2. the result is transposed to columns (counting sort) and every column is
//!    Haar-transformed along the target the same way into a dense
//!    `M`-accumulator with a touched list.
//!
//! The work is `O(M · ss² + M · log n · log m)` per normal instead of `N`
//! resamplings of `M · ss²` samples; normals run in parallel (rayon).
//!
//! # Quantization and storage
//! Each matrix has one scale `max|𝐑_k| / 32767`; entries are rounded to i16
//! and `|q| < ntrunc` dropped (paper Table 1). Non-zeros are stored **column
//! major** (CSC): per normal, `N + 1` column pointers (u32) and entries
//! `{row: u16, value: i16}` (4 bytes). The paper stores rows (CSR); a lighting
//! change with a `k`-term lighting vector then streams every non-zero of every
//! matrix (≈ 262 MB at N = 64²), while CSC reads only the `k` columns the
//! lighting uses (`bench_wavelet` measures both). Memory: 4 bytes per
//! non-zero in both layouts, plus `4 (N + 1)` bytes of column pointers per
//! normal for CSC (16 MB at N = 64², 6 % of the entries) versus `4 (M + 1)`
//! row pointers for CSR.
//!
//! # File (`RLWVROT1`, see [`crate::format`])
//! params = `[n, m, ntess, ntrunc, supersample, 0, 0, 0]`; sections:
//! `normal_base: [u64; T+1]` (first entry of each normal), `scales: [f32; T]`,
//! `col_ptr: [u32; T (N+1)]` (relative to the normal's base),
//! `entries: [Entry; normal_base[T]]`, with `T = ntess²`.

use crate::error::{WaveletError, bad};
use crate::format::{self, read_file, split_sections, write_file};
use crate::octa::{
    grid_normal, hemi_density, hemi_dir_from_uv, oct_uv_from_dir, shading_frame_f64, texel_of,
};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3A};
use rayon::prelude::*;
use relight_haar::{Quantizer, SparseRgb, ancestors};
use relight_render::Progress;
use std::path::Path;

const MAGIC: [u8; 8] = *b"RLWVROT1";

/// Parameters of a rotation-matrix bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct RotationParams {
    /// Source octahedral side (N = n²), a power of two in 2..=512.
    pub n: usize,
    /// Target hemi-octahedral side (M = m²), a power of two ≤ n and ≤ 256;
    /// n/2 by default as in the paper. For narrow lobes the target grid is
    /// what limits accuracy: on the default scene with GGX α = 0.1 and
    /// ntess = 32², the per-pixel image error is 0.072 at m = 32 and 0.052
    /// at m = 64 (and at m = 32 a coarser ntess = 8² scores 0.065, because
    /// blending four distant sampled frames averages the target texels'
    /// phase against the sun; at m = 64 ntess = 8² is worse, 0.059).
    pub m: usize,
    /// Normal tessellation side (ntess² normals), ≥ 2.
    pub ntess: usize,
    /// Quantized values with |q| < ntrunc are dropped (≥ 1).
    pub ntrunc: u16,
    /// Supersampling per target texel side for the area integral (1..=32).
    pub supersample: usize,
}

impl RotationParams {
    /// Paper defaults: `m = n/2`; supersampling 8 × 8 per target texel.
    /// Measured convergence (test `supersampling_of_the_area_integral_converges`,
    /// n = 16): ‖R_ss − R_16‖_F / ‖R_16‖_F = 0.57, 0.22, 0.089 for ss = 2, 4, 8
    /// (O(1/ss), midpoint sampling of texel-boundary crossings) and 0.036 for
    /// ss = 32; the rotated lighting converges much faster than the matrix
    /// norm because the residual sits in fine-level coefficients.
    ///
    /// The supersampling also sets how many small entries survive
    /// quantization: at N = 64², ntess = 32², ntrunc = 1 the non-zeros per
    /// row are 39.1 / 62.4 / 70.0 / 73.7 / 75.6 for ss = 1 / 2 / 4 / 8 / 16
    /// (`relight bake rotation --supersample`). The paper's 62.2 per row
    /// (266 MB, Table 1) matches 2 × 2 (62.4, 278 MB); the converged
    /// integral adds sliver-overlap entries at the supports' edges.
    #[must_use]
    pub fn new(n: usize, ntess: usize, ntrunc: u16) -> Self {
        Self {
            n,
            m: (n / 2).max(1),
            ntess,
            ntrunc,
            supersample: 8,
        }
    }

    /// Checks every parameter.
    ///
    /// # Errors
    /// [`WaveletError::BadParam`] naming the parameter.
    pub fn validate(&self) -> Result<(), WaveletError> {
        if !self.n.is_power_of_two() || !(2..=512).contains(&self.n) {
            return Err(bad("n", self.n, "must be a power of two in 2..=512"));
        }
        if !self.m.is_power_of_two() || self.m > self.n || self.m > 256 {
            return Err(bad(
                "m",
                self.m,
                format!("must be a power of two ≤ n = {} and ≤ 256", self.n),
            ));
        }
        if self.ntess < 2 || self.ntess > 1024 {
            return Err(bad("ntess", self.ntess, "must be in 2..=1024"));
        }
        if self.ntrunc == 0 {
            return Err(bad(
                "ntrunc",
                self.ntrunc,
                "must be ≥ 1 (1 keeps every non-zero quantized value)",
            ));
        }
        if !(1..=32).contains(&self.supersample) {
            return Err(bad("supersample", self.supersample, "must be in 1..=32"));
        }
        Ok(())
    }

    fn header_params(&self) -> [u32; 8] {
        [
            self.n as u32,
            self.m as u32,
            self.ntess as u32,
            u32::from(self.ntrunc),
            self.supersample as u32,
            0,
            0,
            0,
        ]
    }

    /// Cache file name: includes a hash of every parameter and the format version.
    #[must_use]
    pub fn cache_file_name(&self) -> String {
        let mut key = Vec::new();
        for p in self.header_params() {
            key.extend_from_slice(&p.to_le_bytes());
        }
        key.extend_from_slice(&format::FORMAT_VERSION.to_le_bytes());
        format!(
            "rot-n{}-m{}-t{}-q{}-v{}-{:016x}.bin",
            self.n,
            self.m,
            self.ntess,
            self.ntrunc,
            format::FORMAT_VERSION,
            format::fnv1a64(&key)
        )
    }

    /// Number of source coefficients N = n².
    #[must_use]
    pub fn source_len(&self) -> usize {
        self.n * self.n
    }
    /// Number of target coefficients M = m².
    #[must_use]
    pub fn target_len(&self) -> usize {
        self.m * self.m
    }
    /// Number of sampled normals T = ntess².
    #[must_use]
    pub fn normals(&self) -> usize {
        self.ntess * self.ntess
    }
}

impl std::fmt::Display for RotationParams {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "n = {}, m = {}, ntess = {}, ntrunc = {}, supersample = {}",
            self.n, self.m, self.ntess, self.ntrunc, self.supersample
        )
    }
}

/// One stored non-zero: target coefficient (row) and quantized value.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Entry {
    /// Target coefficient index (< M).
    pub row: u16,
    /// Quantized value; multiply by the matrix scale.
    pub value: i16,
}

enum Store {
    Owned {
        normal_base: Vec<u64>,
        scales: Vec<f32>,
        col_ptr: Vec<u32>,
        entries: Vec<Entry>,
    },
    Mapped {
        file: format::MappedFile,
        ranges: [std::ops::Range<usize>; 4],
    },
}

/// All rotation matrices of one bake (owned after baking, memory-mapped after loading).
pub struct RotationMatrices {
    params: RotationParams,
    store: Store,
}

impl std::fmt::Debug for RotationMatrices {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RotationMatrices")
            .field("params", &self.params)
            .field("nnz", &self.nnz())
            .finish()
    }
}

/// Phase 1 of [`RotationMatrices::local_lighting`]: requests every cache
/// line of the column ranges `ranges` of `e` before any is read, so that the
/// core keeps many misses in flight instead of paying memory latency once per
/// column (the matrices are far larger than the caches; a column averages
/// ≈ 40 entries, 2–3 lines). On x86-64 a prefetch into L2 per line (no load
/// to retire, no register); elsewhere one load per line.
fn prefetch_ranges(e: &[Entry], ranges: &[(usize, usize)]) {
    /// Entries per 64-byte cache line.
    const LINE: usize = 64 / std::mem::size_of::<Entry>();
    #[cfg(target_arch = "x86_64")]
    for &(a, b) in ranges {
        // Line starts from the range's first entry on (the last line may
        // start before `b`'s line; one past the end is never touched).
        let mut p = a;
        while p < b {
            // SAFETY: `p < b ≤ e.len()`: the address is inside `e`;
            // a prefetch has no architectural effect.
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T1 }>(
                    e.as_ptr().add(p).cast(),
                );
            }
            p += LINE;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut touch = 0i32;
        for &(a, b) in ranges {
            for p in (a..b).step_by(LINE) {
                touch = touch.wrapping_add(i32::from(e[p].value));
            }
        }
        std::hint::black_box(touch);
    }
}

/// Per-target-texel supersample pattern: local directions and normalised weights.
struct TargetSamples {
    per_texel: usize,
    dirs: Vec<DVec3>,
    weights: Vec<f64>,
}

impl TargetSamples {
    fn new(m: usize, ss: usize) -> Self {
        let per_texel = ss * ss;
        let mut dirs = Vec::with_capacity(m * m * per_texel);
        let mut weights = Vec::with_capacity(m * m * per_texel);
        for t in 0..m * m {
            let (c, r) = (t % m, t / m);
            let start = weights.len();
            for sy in 0..ss {
                for sx in 0..ss {
                    let u = (c as f64 + (sx as f64 + 0.5) / ss as f64) / m as f64;
                    let v = (r as f64 + (sy as f64 + 0.5) / ss as f64) / m as f64;
                    dirs.push(hemi_dir_from_uv(u, v));
                    weights.push(hemi_density(u, v));
                }
            }
            let sum: f64 = weights[start..].iter().sum();
            for w in &mut weights[start..] {
                *w /= sum;
            }
        }
        Self {
            per_texel,
            dirs,
            weights,
        }
    }
}

/// The unquantized matrix of one normal in CSC form (f32 values).
pub(crate) struct DenseColumns {
    pub col_ptr: Vec<u32>,
    pub rows: Vec<u16>,
    pub values: Vec<f32>,
}

/// Scratch buffers reused across normals of one worker.
struct Scratch {
    wrow: Vec<(u32, f64)>,
    x_ptr: Vec<u32>,
    x: Vec<(u32, f32)>,
    col_count: Vec<u32>,
    col_t: Vec<(u16, f32)>,
    acc: Vec<f32>,
    mark: Vec<u32>,
    touched: Vec<u32>,
}

impl Scratch {
    fn new(p: &RotationParams) -> Self {
        let (nn, mm) = (p.source_len(), p.target_len());
        Self {
            wrow: Vec::new(),
            x_ptr: Vec::with_capacity(mm + 1),
            x: Vec::new(),
            col_count: vec![0; nn + 1],
            col_t: Vec::new(),
            acc: vec![0.0; mm],
            mark: vec![u32::MAX; mm],
            touched: Vec::new(),
        }
    }
}

/// The resampling matrix row of every target texel: `(source texel, weight)`
/// lists for the local frame `frame` (world_from_local axes).
fn resample_rows(
    p: &RotationParams,
    ts: &TargetSamples,
    frame: &[DVec3; 3],
    t: usize,
    wrow: &mut Vec<(u32, f64)>,
) {
    wrow.clear();
    let base = t * ts.per_texel;
    for s in base..base + ts.per_texel {
        let l = ts.dirs[s];
        let w = frame[0] * l.x + frame[1] * l.y + frame[2] * l.z;
        let (u, v) = oct_uv_from_dir(w);
        let src = texel_of(u, v, p.n) as u32;
        match wrow.iter_mut().find(|e| e.0 == src) {
            Some(e) => e.1 += ts.weights[s],
            None => wrow.push((src, ts.weights[s])),
        }
    }
}

/// Unquantized `H_M · W · H_Nᵀ` for the local frame `frame`, in CSC.
fn matrix_for_frame(
    p: &RotationParams,
    ts: &TargetSamples,
    frame: &[DVec3; 3],
    sc: &mut Scratch,
) -> DenseColumns {
    let (n, m) = (p.n, p.m);
    let (nn, mm) = (p.source_len(), p.target_len());
    // 1. Rows of W, Haar-transformed along the source: X[t] = H_N W[t].
    sc.x.clear();
    sc.x_ptr.clear();
    sc.x_ptr.push(0);
    for t in 0..mm {
        resample_rows(p, ts, frame, t, &mut sc.wrow);
        let start = sc.x.len();
        for &(src, w) in &sc.wrow {
            let (sx, sy) = (src as usize % n, src as usize / n);
            let x = &mut sc.x;
            ancestors(n, sx, sy, |i, psi| {
                x.push((i as u32, (w * f64::from(psi)) as f32))
            });
        }
        let seg = &mut sc.x[start..];
        seg.sort_unstable_by_key(|e| e.0);
        // Merge duplicates in place.
        let mut w = start;
        for r in start..sc.x.len() {
            if w > start && sc.x[w - 1].0 == sc.x[r].0 {
                sc.x[w - 1].1 += sc.x[r].1;
            } else {
                sc.x[w] = sc.x[r];
                w += 1;
            }
        }
        sc.x.truncate(w);
        sc.x_ptr.push(w as u32);
    }
    // 2. Transpose X to columns (counting sort over source coefficients).
    sc.col_count.iter_mut().for_each(|c| *c = 0);
    for e in &sc.x {
        sc.col_count[e.0 as usize + 1] += 1;
    }
    for i in 0..nn {
        sc.col_count[i + 1] += sc.col_count[i];
    }
    sc.col_t.clear();
    sc.col_t.resize(sc.x.len(), (0, 0.0));
    {
        let mut fill = sc.col_count.clone();
        for t in 0..mm {
            for e in &sc.x[sc.x_ptr[t] as usize..sc.x_ptr[t + 1] as usize] {
                let slot = &mut fill[e.0 as usize];
                sc.col_t[*slot as usize] = (t as u16, e.1);
                *slot += 1;
            }
        }
    }
    // 3. Haar transform of every column along the target.
    let mut out = DenseColumns {
        col_ptr: Vec::with_capacity(nn + 1),
        rows: Vec::new(),
        values: Vec::new(),
    };
    out.col_ptr.push(0);
    for i in 0..nn {
        let (a, b) = (sc.col_count[i] as usize, sc.col_count[i + 1] as usize);
        sc.touched.clear();
        for &(t, v) in &sc.col_t[a..b] {
            let (tx, ty) = (t as usize % m, t as usize / m);
            let (acc, mark, touched) = (&mut sc.acc, &mut sc.mark, &mut sc.touched);
            ancestors(m, tx, ty, |j, psi| {
                if mark[j] != i as u32 {
                    mark[j] = i as u32;
                    acc[j] = 0.0;
                    touched.push(j as u32);
                }
                acc[j] += v * psi;
            });
        }
        sc.touched.sort_unstable();
        for &j in &sc.touched {
            let v = sc.acc[j as usize];
            if v != 0.0 {
                out.rows.push(j as u16);
                out.values.push(v);
            }
        }
        out.col_ptr.push(out.rows.len() as u32);
    }
    sc.mark.iter_mut().for_each(|x| *x = u32::MAX);
    out
}

/// An unquantized matrix in CSC form: column pointers (N + 1), row indices, values.
pub type CscF32 = (Vec<u32>, Vec<u16>, Vec<f32>);

/// Unquantized rotation matrix (CSC) for an arbitrary local frame
/// `[x, y, z]` (world_from_local axes); used by tests and the error studies.
///
/// # Errors
/// Invalid `params`.
pub fn rotation_matrix_f32(
    params: &RotationParams,
    frame: [DVec3; 3],
) -> Result<CscF32, WaveletError> {
    params.validate()?;
    let ts = TargetSamples::new(params.m, params.supersample);
    let mut sc = Scratch::new(params);
    let d = matrix_for_frame(params, &ts, &frame, &mut sc);
    Ok((d.col_ptr, d.rows, d.values))
}

fn quantize(d: &DenseColumns, ntrunc: u16) -> (f32, Vec<u32>, Vec<Entry>) {
    let max = d.values.iter().fold(0.0f32, |a, v| a.max(v.abs()));
    let qz = Quantizer::for_max(max, ntrunc);
    let mut ptr = Vec::with_capacity(d.col_ptr.len());
    let mut entries = Vec::with_capacity(d.values.len());
    ptr.push(0);
    for c in 0..d.col_ptr.len() - 1 {
        for k in d.col_ptr[c] as usize..d.col_ptr[c + 1] as usize {
            if let Some(q) = qz.quantize(d.values[k]) {
                entries.push(Entry {
                    row: d.rows[k],
                    value: q,
                });
            }
        }
        ptr.push(entries.len() as u32);
    }
    (qz.scale, ptr, entries)
}

/// Bakes every rotation matrix of `params` (parallel over normals; progress
/// counts normals; returns [`WaveletError::Cancelled`] when asked to stop).
///
/// # Errors
/// Invalid parameters or cancellation.
pub fn bake_rotation(
    params: &RotationParams,
    progress: &dyn Progress,
) -> Result<RotationMatrices, WaveletError> {
    params.validate()?;
    let p = *params;
    let ts = TargetSamples::new(p.m, p.supersample);
    let t_count = p.normals();
    let nn = p.source_len();
    let mut normal_base = Vec::with_capacity(t_count + 1);
    let mut scales = Vec::with_capacity(t_count);
    let mut col_ptr: Vec<u32> = Vec::with_capacity(t_count * (nn + 1));
    let mut entries: Vec<Entry> = Vec::new();
    normal_base.push(0u64);
    progress.start("bake rotation matrices", t_count as u64);
    let batch = 64;
    for b0 in (0..t_count).step_by(batch) {
        progress.check()?;
        let b1 = (b0 + batch).min(t_count);
        let results: Vec<(f32, Vec<u32>, Vec<Entry>)> = (b0..b1)
            .into_par_iter()
            .map_init(
                || Scratch::new(&p),
                |sc, k| {
                    let frame = shading_frame_f64(grid_normal(k, p.ntess));
                    let d = matrix_for_frame(&p, &ts, &frame, sc);
                    let r = quantize(&d, p.ntrunc);
                    progress.inc(1);
                    r
                },
            )
            .collect();
        for (scale, ptr, e) in results {
            scales.push(scale);
            col_ptr.extend_from_slice(&ptr);
            entries.extend_from_slice(&e);
            normal_base.push(entries.len() as u64);
        }
    }
    progress.finish();
    Ok(RotationMatrices {
        params: p,
        store: Store::Owned {
            normal_base,
            scales,
            col_ptr,
            entries,
        },
    })
}

impl RotationMatrices {
    /// The bake parameters.
    #[must_use]
    pub fn params(&self) -> &RotationParams {
        &self.params
    }

    fn sections(&self) -> (&[u64], &[f32], &[u32], &[Entry]) {
        match &self.store {
            Store::Owned {
                normal_base,
                scales,
                col_ptr,
                entries,
            } => (normal_base, scales, col_ptr, entries),
            Store::Mapped { file, ranges } => {
                let pl = file.payload();
                (
                    bytemuck::cast_slice(&pl[ranges[0].clone()]),
                    bytemuck::cast_slice(&pl[ranges[1].clone()]),
                    bytemuck::cast_slice(&pl[ranges[2].clone()]),
                    bytemuck::cast_slice(&pl[ranges[3].clone()]),
                )
            }
        }
    }

    /// Total stored non-zeros over all matrices.
    #[must_use]
    pub fn nnz(&self) -> u64 {
        *self.sections().0.last().unwrap_or(&0)
    }

    /// Average non-zeros per row (paper Table 1 "avg.#").
    #[must_use]
    pub fn nnz_per_row(&self) -> f64 {
        self.nnz() as f64 / (self.params.normals() * self.params.target_len()) as f64
    }

    /// Fraction of non-zero entries (paper Table 1 "Spars.").
    #[must_use]
    pub fn sparsity(&self) -> f64 {
        self.nnz_per_row() / self.params.source_len() as f64
    }

    /// Bytes of the stored matrices (entries + column pointers + scales).
    #[must_use]
    pub fn size_bytes(&self) -> u64 {
        let (nb, s, c, e) = self.sections();
        (nb.len() * 8 + s.len() * 4 + c.len() * 4 + e.len() * 4) as u64
    }

    /// Column `i` of matrix `k`: (scale, entries).
    #[must_use]
    pub fn column(&self, k: usize, i: usize) -> (f32, &[Entry]) {
        let (nb, s, c, e) = self.sections();
        let nn = self.params.source_len();
        let base = nb[k] as usize;
        let cp = &c[k * (nn + 1)..(k + 1) * (nn + 1)];
        (s[k], &e[base + cp[i] as usize..base + cp[i + 1] as usize])
    }

    /// Dequantized dense matrix `k` (M × N row-major); for tests and studies.
    #[must_use]
    pub fn dense(&self, k: usize) -> Vec<f32> {
        let (nn, mm) = (self.params.source_len(), self.params.target_len());
        let mut d = vec![0.0; mm * nn];
        for i in 0..nn {
            let (s, col) = self.column(k, i);
            for e in col {
                d[e.row as usize * nn + i] = f32::from(e.value) * s;
            }
        }
        d
    }

    /// Lighting change (paper §3 step one, Eq. 5): `out[k·M + j] = (𝐑_k 𝐋)_j`
    /// for every sampled normal `k`, RGB in a `Vec3A`. Reads only the columns
    /// used by `light` (CSC). `out.len()` must be `T · M`.
    ///
    /// # Errors
    /// A light index ≥ N or a wrong `out` length.
    pub fn local_lighting(&self, light: &SparseRgb, out: &mut [Vec3A]) -> Result<(), WaveletError> {
        self.local_lighting_of(light, out, None)
    }

    /// [`RotationMatrices::local_lighting`] for the sampled normals `k` with
    /// `wanted[k]` only (`wanted.len()` = T); the other rows of `out` are
    /// left as they are.
    ///
    /// # Errors
    /// As [`RotationMatrices::local_lighting`], or a wrong `wanted` length.
    pub fn local_lighting_some(
        &self,
        light: &SparseRgb,
        out: &mut [Vec3A],
        wanted: &[bool],
    ) -> Result<(), WaveletError> {
        if wanted.len() != self.params.normals() {
            return Err(bad(
                "wanted",
                wanted.len(),
                format!("must hold ntess² = {}", self.params.normals()),
            ));
        }
        self.local_lighting_of(light, out, Some(wanted))
    }

    /// Checks a source lighting's indices against N.
    ///
    /// # Errors
    /// The first index ≥ N.
    pub fn check_light(&self, light: &SparseRgb) -> Result<(), WaveletError> {
        let nn = self.params.source_len();
        match light.indices.iter().find(|&&i| i as usize >= nn) {
            Some(&i) => Err(bad("light index", i, format!("must be < N = {nn}"))),
            None => Ok(()),
        }
    }

    fn local_lighting_of(
        &self,
        light: &SparseRgb,
        out: &mut [Vec3A],
        wanted: Option<&[bool]>,
    ) -> Result<(), WaveletError> {
        let (nn, mm) = (self.params.source_len(), self.params.target_len());
        if out.len() != self.params.normals() * mm {
            return Err(bad(
                "out",
                out.len(),
                format!("must hold ntess² · M = {}", self.params.normals() * mm),
            ));
        }
        self.check_light(light)?;
        let (nb, s, c, e) = self.sections();
        let lights: Vec<Vec3A> = light.values.iter().map(|v| Vec3A::from_array(*v)).collect();
        // The wanted rows as a list, so that rayon splits the work between
        // threads evenly however the wanted normals cluster on the grid.
        let rows: Vec<(usize, &mut [Vec3A])> = out
            .chunks_mut(mm)
            .enumerate()
            .filter(|(k, _)| wanted.is_none_or(|w| w[*k]))
            .collect();
        rows.into_par_iter().for_each_init(
            || Vec::with_capacity(light.nnz()),
            |ranges: &mut Vec<(usize, usize)>, (k, o)| {
                o.fill(Vec3A::ZERO);
                let base = nb[k] as usize;
                let cp = &c[k * (nn + 1)..(k + 1) * (nn + 1)];
                let scale = s[k];
                // Phase 1: all column ranges, then every line of them
                // requested (`prefetch_ranges`).
                ranges.clear();
                ranges.extend(light.indices.iter().map(|&i| {
                    (
                        base + cp[i as usize] as usize,
                        base + cp[i as usize + 1] as usize,
                    )
                }));
                prefetch_ranges(e, ranges);
                // Phase 2: scatter-add every used column.
                for (&(a, b), &l) in ranges.iter().zip(&lights) {
                    let l = l * scale;
                    for en in &e[a..b] {
                        o[en.row as usize] += l * f32::from(en.value);
                    }
                }
            },
        );
        Ok(())
    }

    /// The paper's row-major layout (CSR) of all matrices, for the layout benchmark.
    #[must_use]
    pub fn to_csr(&self) -> CsrMatrices {
        let (nn, mm, tc) = (
            self.params.source_len(),
            self.params.target_len(),
            self.params.normals(),
        );
        let per: Vec<(Vec<u32>, Vec<u16>, Vec<i16>)> = (0..tc)
            .into_par_iter()
            .map(|k| {
                let mut count = vec![0u32; mm + 1];
                for i in 0..nn {
                    for en in self.column(k, i).1 {
                        count[en.row as usize + 1] += 1;
                    }
                }
                for j in 0..mm {
                    count[j + 1] += count[j];
                }
                let total = count[mm] as usize;
                let (mut cols, mut vals) = (vec![0u16; total], vec![0i16; total]);
                let mut fill = count.clone();
                for i in 0..nn {
                    for en in self.column(k, i).1 {
                        let f = &mut fill[en.row as usize];
                        cols[*f as usize] = i as u16;
                        vals[*f as usize] = en.value;
                        *f += 1;
                    }
                }
                (count, cols, vals)
            })
            .collect();
        let scales = self.sections().1.to_vec();
        CsrMatrices {
            params: self.params,
            per,
            scales,
        }
    }

    /// Writes the bake file atomically.
    ///
    /// # Errors
    /// IO errors, naming `path`.
    pub fn save(&self, path: &Path) -> Result<(), WaveletError> {
        let (nb, s, c, e) = self.sections();
        write_file(
            path,
            MAGIC,
            self.params.header_params(),
            &[
                bytemuck::cast_slice(nb),
                bytemuck::cast_slice(s),
                bytemuck::cast_slice(c),
                bytemuck::cast_slice(e),
            ],
        )
    }

    /// Memory-maps and validates a bake file (magic, version, size, checksum, structure).
    ///
    /// # Errors
    /// IO, foreign, stale-version, truncated or corrupted files.
    pub fn load(path: &Path) -> Result<Self, WaveletError> {
        let file = read_file(path, MAGIC, "rotation")?;
        let h = file.header.params;
        let params = RotationParams {
            n: h[0] as usize,
            m: h[1] as usize,
            ntess: h[2] as usize,
            ntrunc: u16::try_from(h[3]).unwrap_or(0),
            supersample: h[4] as usize,
        };
        let corrupt = |why: &str| WaveletError::Corrupt {
            path: path.to_path_buf(),
            why: why.to_string(),
        };
        params
            .validate()
            .map_err(|e| corrupt(&format!("bad parameters in header: {e}")))?;
        let (tc, nn, mm) = (params.normals(), params.source_len(), params.target_len());
        let pl = file.payload();
        let nb_len = (tc + 1) * 8;
        let nb: &[u64] =
            bytemuck::try_cast_slice(pl.get(..nb_len).ok_or_else(|| corrupt("short payload"))?)
                .map_err(|_| corrupt("misaligned"))?;
        let total = *nb.last().unwrap_or(&0) as usize;
        let lens = [nb_len, tc * 4, tc * (nn + 1) * 4, total * 4];
        let secs = split_sections(pl, &lens)
            .ok_or_else(|| corrupt("section sizes do not match the header"))?;
        let mut ranges: [std::ops::Range<usize>; 4] = Default::default();
        let mut off = 0;
        for (r, (s, l)) in ranges.iter_mut().zip(secs.iter().zip(lens)) {
            *r = off..off + s.len();
            off += l.div_ceil(8) * 8;
        }
        let m = Self {
            params,
            store: Store::Mapped { file, ranges },
        };
        // Structural checks so that the hot loops can trust the indices.
        let (nb, _, c, e) = m.sections();
        for k in 0..tc {
            let cp = &c[k * (nn + 1)..(k + 1) * (nn + 1)];
            if nb[k + 1] < nb[k]
                || cp[0] != 0
                || u64::from(cp[nn]) != nb[k + 1] - nb[k]
                || cp.windows(2).any(|w| w[1] < w[0])
            {
                return Err(corrupt("inconsistent column pointers"));
            }
        }
        if e.iter().any(|en| en.row as usize >= mm) {
            return Err(corrupt("row index out of range"));
        }
        Ok(m)
    }

    /// [`RotationMatrices::load`], then checks the file was baked with `want`.
    ///
    /// # Errors
    /// As `load`, plus [`WaveletError::ParamMismatch`].
    pub fn load_expect(path: &Path, want: &RotationParams) -> Result<Self, WaveletError> {
        let m = Self::load(path)?;
        if m.params != *want {
            return Err(WaveletError::ParamMismatch {
                path: path.to_path_buf(),
                found: m.params.to_string(),
                requested: want.to_string(),
            });
        }
        Ok(m)
    }
}

/// Row-major copy of the matrices (the paper's layout): per normal, row
/// pointers, column indices (u16, so N ≤ 65536) and values.
pub struct CsrMatrices {
    params: RotationParams,
    per: Vec<(Vec<u32>, Vec<u16>, Vec<i16>)>,
    scales: Vec<f32>,
}

impl CsrMatrices {
    /// Lighting change with row-major storage: every row is a sparse dot
    /// product against the dense lighting vector (all non-zeros are read).
    pub fn local_lighting(&self, light: &SparseRgb, out: &mut [Vec3A]) {
        let (nn, mm) = (self.params.source_len(), self.params.target_len());
        let dense: Vec<Vec3A> = {
            let mut d = vec![Vec3A::ZERO; nn];
            for (&i, v) in light.indices.iter().zip(&light.values) {
                d[i as usize] = Vec3A::from_array(*v);
            }
            d
        };
        out.par_chunks_mut(mm).enumerate().for_each(|(k, o)| {
            let (ptr, cols, vals) = &self.per[k];
            let s = self.scales[k];
            for (j, oj) in o.iter_mut().enumerate() {
                let mut acc = Vec3A::ZERO;
                for q in ptr[j] as usize..ptr[j + 1] as usize {
                    acc += dense[cols[q] as usize] * f32::from(vals[q]);
                }
                *oj = acc * s;
            }
        });
    }
}
