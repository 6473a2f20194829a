//! Per-vertex light propagation fused with the transport dot product
//! (thesis §4.5.5): two-step separable propagation (eq. 4.35 in 2D) of the
//! compressed source terms, evaluated only at the target terms the
//! constant-light heuristic (eq. 4.38) keeps.
//!
//! # Geometry (a light move or scale)
//! Per vertex, the dense 1D ACC matrices `D^x = D(s₁, o₁)`, `D^y = D(s₂,
//! o₂)` of [`relight_affine::standard::acc_matrix_fast`] (the primitive
//! form of `M`, the computational approach), and the target mask. The heuristic
//! light `F̃ = [1, 0, 0, …]` propagates to `L̃_{k1k2} = D^x_{0k1} D^y_{0k2}`
//! (row 0 of each matrix); the mask keeps the `m` largest `|L̃|`, ties
//! **coarse first** ([`crate::light::coarse_key`]), found by a k-way merge of
//! the two sorted factors (`O(m log n)`, no sort of all `n²`). Each mask
//! entry carries the transport coefficient it multiplies.
//!
//! # Lighting (every frame, e.g. a texture edit)
//! With `R` distinct source rows `i₂`, `n_s` source terms and `m` targets:
//!
//! ```text
//!   step 1:  Z_{r,k1}[c] = Σ_{i1 in row r} F_{i1 i2}[c] D^x_{i1 k1}     n_s · n · 3 FMA
//!   fuse:    W_{r,k1}    = Σ_{(k1,k2) in mask} D^y_{i2 k2} T_{k1 k2}      R · m FMA
//!   dot:     B[c]        = Σ_r Σ_{k1} Z_{r,k1}[c] W_{r,k1}               R · n · 3 FMA
//! ```
//!
//! `B[c] = Σ_{k ∈ mask} L_k[c] T_k`; step 2 of the thesis is folded into the
//! colour-independent `W` (the transport does not depend on the colour).

use crate::light::{SourceTerms, coarse_key};
use relight_affine::standard::acc_matrix_fast;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// One kept target coefficient: its 1D indices and the transport there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaskEntry {
    pub k1: u16,
    pub k2: u16,
    pub t: f32,
}

/// One kept target coefficient of an RGB transport ([`crate::specular`]):
/// its 1D indices and the transport there, per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaskEntryRgb {
    pub k1: u16,
    pub k2: u16,
    pub t: [f32; 3],
}

/// A mask entry's first 1D index (what [`sort_mask`] groups by).
pub trait MaskKey: Copy + Default {
    fn k1(&self) -> u16;
}

impl MaskKey for MaskEntry {
    #[inline]
    fn k1(&self) -> u16 {
        self.k1
    }
}

impl MaskKey for MaskEntryRgb {
    #[inline]
    fn k1(&self) -> u16 {
        self.k1
    }
}

/// Fills `dx`, `dy` (`n²` each) for the affine map `(s, o)`.
pub fn acc_pair(n: usize, s: [f64; 2], o: [f64; 2], dx: &mut [f32], dy: &mut [f32]) {
    acc_matrix_fast(n, s[0], o[0], dx);
    acc_matrix_fast(n, s[1], o[1], dy);
}

#[derive(PartialEq)]
struct Cursor {
    value: f32,
    key: (u32, usize, usize),
    row: usize,
    pos: usize,
}

impl Eq for Cursor {}

impl Ord for Cursor {
    fn cmp(&self, other: &Self) -> Ordering {
        // Max-heap: larger value first, then the smaller (coarser) key.
        self.value
            .total_cmp(&other.value)
            .then_with(|| other.key.cmp(&self.key))
    }
}

impl PartialOrd for Cursor {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Scratch of [`select_targets`].
#[derive(Default)]
pub struct SelectScratch {
    a: Vec<(f32, usize)>,
    b: Vec<(f32, usize)>,
    heap: Vec<Cursor>,
}

/// The `m` target indices `(k1, k2)` of largest `|a_{k1} b_{k2}|`, ties
/// coarse first (module docs), appended to `out` (cleared). `a`, `b` are
/// the heuristic's 1D predictions (row 0 of `D^x`, `D^y`).
pub fn select_targets(
    a: &[f32],
    b: &[f32],
    m: usize,
    scratch: &mut SelectScratch,
    out: &mut Vec<(u16, u16)>,
) {
    let n = a.len();
    out.clear();
    if m >= n * n {
        for k2 in 0..n {
            for k1 in 0..n {
                out.push((k1 as u16, k2 as u16));
            }
        }
        return;
    }
    // Each factor sorted by |value| desc, then index asc (= coarse first).
    let sort = |v: &[f32], s: &mut Vec<(f32, usize)>| {
        s.clear();
        s.extend(v.iter().enumerate().map(|(i, x)| (x.abs(), i)));
        s.sort_by(|p, q| q.0.total_cmp(&p.0).then(p.1.cmp(&q.1)));
    };
    sort(a, &mut scratch.a);
    sort(b, &mut scratch.b);
    let (sa, sb) = (&scratch.a, &scratch.b);
    let mut heap = BinaryHeap::from(std::mem::take(&mut scratch.heap));
    heap.clear();
    for (row, &(av, k1)) in sa.iter().enumerate() {
        let (bv, k2) = if av == 0.0 { (0.0, 0) } else { sb[0] };
        heap.push(Cursor {
            value: av * bv,
            key: coarse_key(k1, k2),
            row,
            pos: 0,
        });
    }
    // A row whose factor is zero is all ties: it runs in index order (=
    // coarse first), not in the order of `b`.
    let col = |row: usize, pos: usize| -> (f32, usize) {
        if sa[row].0 == 0.0 {
            (0.0, pos)
        } else {
            sb[pos]
        }
    };
    while out.len() < m {
        let Some(c) = heap.pop() else { break };
        let k1 = sa[c.row].1;
        let k2 = col(c.row, c.pos).1;
        out.push((k1 as u16, k2 as u16));
        if c.pos + 1 < n {
            let (bv, k2) = col(c.row, c.pos + 1);
            heap.push(Cursor {
                value: sa[c.row].0 * bv,
                key: coarse_key(k1, k2),
                row: c.row,
                pos: c.pos + 1,
            });
        }
    }
    scratch.heap = heap.into_vec();
}

/// Per-thread scratch of [`shade`].
#[derive(Clone, Debug, Default)]
pub struct ShadeScratch {
    z: Vec<f32>,
    dyt: Vec<f32>,
    w: Vec<f32>,
    acc: Vec<f32>,
}

/// Step 1 of the kernel (module docs) into `z` (`[r][c][k1]`), and
/// `D^y`'s source rows transposed into `dyt` (`[k2][r]`).
fn step_one(src: &SourceTerms, dx: &[f32], dy: &[f32], z: &mut [f32], dyt: &mut [f32]) {
    let n = src.n;
    let rows = src.rows.len();
    for (r, &(i2, start, end)) in src.rows.iter().enumerate() {
        let z = &mut z[r * 3 * n..(r + 1) * 3 * n];
        z.fill(0.0);
        let (z0, rest) = z.split_at_mut(n);
        let (z1, z2) = rest.split_at_mut(n);
        for t in &src.terms[start as usize..end as usize] {
            let d = &dx[t.i1 as usize * n..(t.i1 as usize + 1) * n];
            let [c0, c1, c2] = t.rgb;
            for (((a, b), c), &dk) in z0.iter_mut().zip(z1.iter_mut()).zip(z2.iter_mut()).zip(d) {
                *a += c0 * dk;
                *b += c1 * dk;
                *c += c2 * dk;
            }
        }
        let dyr = &dy[i2 as usize * n..(i2 as usize + 1) * n];
        for (k2, &d) in dyr.iter().enumerate() {
            dyt[k2 * rows + r] = d;
        }
    }
}

/// [`shade`] for an RGB transport: `B[c] = Σ_{k ∈ mask} L_k[c] T_k[c]`.
/// Step 1 is shared; the fuse runs per channel (`W_c`, `3 R m` FMA) and
/// the dot pairs `Z[c]` with `W_c`. `mask` sorted by `k1` ([`sort_mask`]).
#[must_use]
pub fn shade_rgb(
    src: &SourceTerms,
    dx: &[f32],
    dy: &[f32],
    mask: &[MaskEntryRgb],
    scratch: &mut ShadeScratch,
) -> [f32; 3] {
    let n = src.n;
    let rows = src.rows.len();
    if rows == 0 {
        return [0.0; 3];
    }
    scratch.z.resize(rows * 3 * n, 0.0);
    scratch.dyt.resize(n * rows, 0.0);
    scratch.w.resize(3 * n * rows, 0.0);
    scratch.acc.resize(3 * rows, 0.0);
    step_one(src, dx, dy, &mut scratch.z, &mut scratch.dyt);
    // Fuse: W_c[k1][r] = Σ_{(k1,k2) ∈ mask} D^y[i2_r][k2] T_c.
    scratch.w.fill(0.0);
    let acc = &mut scratch.acc;
    let mut i = 0;
    while i < mask.len() {
        let k1 = mask[i].k1 as usize;
        acc.fill(0.0);
        while i < mask.len() && mask[i].k1 as usize == k1 {
            let e = mask[i];
            let k2 = (e.k2 as usize).min(n - 1);
            let d = &scratch.dyt[k2 * rows..(k2 + 1) * rows];
            let (a0, rest) = acc.split_at_mut(rows);
            let (a1, a2) = rest.split_at_mut(rows);
            for (((x0, x1), x2), &dv) in a0.iter_mut().zip(a1.iter_mut()).zip(a2.iter_mut()).zip(d)
            {
                *x0 += dv * e.t[0];
                *x1 += dv * e.t[1];
                *x2 += dv * e.t[2];
            }
            i += 1;
        }
        let k1 = k1.min(n - 1);
        for c in 0..3 {
            let at = (c * n + k1) * rows;
            scratch.w[at..at + rows].copy_from_slice(&acc[c * rows..(c + 1) * rows]);
        }
    }
    // Dot: B[c] = Σ_r Σ_k1 Z[r][c][k1] W_c[k1][r].
    let mut out = [0.0f32; 3];
    for r in 0..rows {
        let z = &scratch.z[r * 3 * n..(r + 1) * 3 * n];
        for (c, o) in out.iter_mut().enumerate() {
            let w = &scratch.w[c * n * rows..(c + 1) * n * rows];
            let mut b = 0.0f32;
            for k1 in 0..n {
                b += z[c * n + k1] * w[k1 * rows + r];
            }
            *o += b;
        }
    }
    out
}

/// The fused kernel (module docs): `Σ_{k ∈ mask} L_k[c] T_k` for one vertex.
/// `mask` is sorted by `k1` ([`sort_mask`]), so each `W_{·,k1}` is summed in
/// registers over its group and stored once; the `R` source rows are the
/// vector lanes of that sum (`D^y` transposed to `[k2][r]`).
#[must_use]
pub fn shade(
    src: &SourceTerms,
    dx: &[f32],
    dy: &[f32],
    mask: &[MaskEntry],
    scratch: &mut ShadeScratch,
) -> [f32; 3] {
    let n = src.n;
    let rows = src.rows.len();
    if rows == 0 {
        return [0.0; 3];
    }
    scratch.z.resize(rows * 3 * n, 0.0);
    scratch.dyt.resize(n * rows, 0.0);
    scratch.w.resize(n * rows, 0.0);
    scratch.acc.resize(rows, 0.0);
    // Step 1, and D^y's source rows transposed.
    step_one(src, dx, dy, &mut scratch.z, &mut scratch.dyt);
    // Fuse: W[k1][r] = Σ_{(k1,k2) ∈ mask} D^y[i2_r][k2] T.
    scratch.w.fill(0.0);
    let acc = &mut scratch.acc;
    let mut i = 0;
    while i < mask.len() {
        let k1 = mask[i].k1 as usize;
        acc.fill(0.0);
        while i < mask.len() && mask[i].k1 as usize == k1 {
            let e = mask[i];
            let k2 = (e.k2 as usize).min(n - 1);
            let d = &scratch.dyt[k2 * rows..(k2 + 1) * rows];
            for (a, &dv) in acc.iter_mut().zip(d) {
                *a += dv * e.t;
            }
            i += 1;
        }
        let k1 = k1.min(n - 1);
        scratch.w[k1 * rows..(k1 + 1) * rows].copy_from_slice(acc);
    }
    // Dot: B[c] = Σ_r Σ_k1 Z[r][c][k1] W[k1][r].
    let mut out = [0.0f32; 3];
    for r in 0..rows {
        let z = &scratch.z[r * 3 * n..(r + 1) * 3 * n];
        let (mut b0, mut b1, mut b2) = (0.0f32, 0.0f32, 0.0f32);
        for k1 in 0..n {
            let wk = scratch.w[k1 * rows + r];
            b0 += z[k1] * wk;
            b1 += z[n + k1] * wk;
            b2 += z[2 * n + k1] * wk;
        }
        out[0] += b0;
        out[1] += b1;
        out[2] += b2;
    }
    out
}

/// Sorts mask entries by `k1` (counting sort, stable in `k2` order of
/// selection): the order [`shade`] needs.
pub fn sort_mask<E: MaskKey>(mask: &mut [E], n: usize, tmp: &mut Vec<E>, counts: &mut Vec<u32>) {
    counts.clear();
    counts.resize(n + 1, 0);
    for e in mask.iter() {
        counts[e.k1() as usize + 1] += 1;
    }
    for k in 0..n {
        counts[k + 1] += counts[k];
    }
    tmp.clear();
    tmp.resize(mask.len(), E::default());
    for e in mask.iter() {
        let at = &mut counts[e.k1() as usize];
        tmp[*at as usize] = *e;
        *at += 1;
    }
    mask.copy_from_slice(tmp);
}

/// FMAs of one [`shade`] call (module docs' counts).
#[must_use]
pub fn shade_fma(src: &SourceTerms, m: usize) -> usize {
    let n = src.n;
    let r = src.rows.len();
    src.len() * n * 3 + r * m + r * n * 3
}

/// FMAs of one [`shade_rgb`] call: the fuse three times.
#[must_use]
pub fn shade_rgb_fma(src: &SourceTerms, m: usize) -> usize {
    shade_fma(src, m) + 2 * src.rows.len() * m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sort_mask_groups_by_k1_keeping_order() {
        let mut m: Vec<MaskEntry> = [(3, 1), (0, 2), (3, 0), (1, 1), (0, 0)]
            .iter()
            .map(|&(k1, k2)| MaskEntry {
                k1,
                k2,
                t: f32::from(k2),
            })
            .collect();
        sort_mask(&mut m, 4, &mut Vec::new(), &mut Vec::new());
        let got: Vec<(u16, u16)> = m.iter().map(|e| (e.k1, e.k2)).collect();
        assert_eq!(got, vec![(0, 2), (0, 0), (1, 1), (3, 1), (3, 0)]);
    }
}
