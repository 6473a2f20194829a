//! Sparse image dilation and translation in the wavelet domain (thesis
//! §4.6.2, Fig. 4.13): the 2D propagation `L_k = Σ_i F_i D_ik(s, o)` of
//! [`crate::separable::propagate_2d`], visiting only the couplings that can
//! be non-zero, with optional target compression by level.
//!
//! # Which couplings are non-zero
//! A nonstandard basis function is a product of two same-level atoms
//! ([`crate::separable::atoms_2d`]), so `D_ik = D¹_u · D¹_v` (eq. 4.31) and
//! the non-zeros are products of the 1D non-zeros per axis. In target
//! coordinates `v = (x − o)/s` a source atom is piecewise constant with
//! break points `v_a`, (`v_m` for a wavelet), `v_b`. Against one target
//! level `l`:
//! - a target **box** `φ_{l,t}` couples with every cell that meets
//!   `[v_a, v_b)`: a contiguous run of offsets;
//! - a target **wavelet** `ψ_{l,t}` integrates to zero over any cell where
//!   the source is constant, so only the ≤ 3 cells that hold a break point
//!   can be non-zero.
//!
//! Each 1D value is a signed sum of the target's primitive at the break
//! points (the primitive form of [`crate::standard::acc_matrix_fast`]):
//! `2^{−l/2} clamp(2^l v − t, 0, 1)` for a box, `2^{−l/2} tent(2^l v − t)`
//! for a wavelet. A type-H target `ψ(u) φ(v)` then costs `≤ 3 ×` (box run
//! in v), V the mirror, D `≤ 9`. A coarse source still reaches `O(N)`
//! targets (its edges, resampled off the dyadic grid, need one fine
//! coefficient per cell along them), against `O(N²)` candidates visited by
//! the generic loop.
//!
//! # Target compression
//! The levels `< L` of the nonstandard basis occupy the top-left `2^L × 2^L`
//! block of the Mallat layout, which is itself the Mallat layout of order
//! `2^L`. [`zoom_sparse`] computes only that block (`side = 2^L`), exactly:
//! compressing the target by level as Fig. 4.13's "dst" curves do. The cost
//! per source is then bounded by `O(side)` instead of `O(N)`.

use crate::atom::{Atom, Kind};
use crate::separable::atoms_2d;
use relight_haar::Basis;

/// `⌊x⌋` without a libm call (no SSE4.1 `round` on the baseline target);
/// saturates far outside `i64`, where callers clamp anyway.
#[inline]
fn floor_fast(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x { t - 1.0 } else { t }
}

/// The 1D couplings of one source atom against every target level `< L`:
/// per level, up to 3 wavelet values and, where the other axis needs them,
/// a contiguous run of box values.
#[derive(Default)]
struct AxisCouplings {
    /// The source's break points in target coordinates and its amplitude.
    va: f64,
    vm: f64,
    vb: f64,
    amp: f64,
    wave_src: bool,
    /// Per level: (first box offset, start in `box_vals`, count).
    box_runs: Vec<(u32, u32, u32)>,
    box_vals: Vec<f64>,
    /// Per level: up to 3 (offset, value) pairs; `wave_len[l]` used.
    wave: Vec<[(u32, f64); 3]>,
    wave_len: Vec<u8>,
}

impl AxisCouplings {
    /// The wavelet couplings of `atom` under `x = s v + o` (`s > 0`) for
    /// target levels `0..levels`; box runs are left empty until
    /// [`Self::fill_boxes`].
    fn fill_waves(&mut self, atom: Atom, s: f64, o: f64, levels: u32) {
        let (x0, x1) = atom.support();
        let (va, vb) = ((x0 - o) / s, (x1 - o) / s);
        let vm = 0.5 * (va + vb);
        let amp = atom.scale().sqrt(); // 2^{l/2}: L²-normalized atom
        let wave_src = atom.kind == Kind::Wave;
        (self.va, self.vm, self.vb, self.amp, self.wave_src) = (va, vm, vb, amp, wave_src);
        self.wave.clear();
        self.wave_len.clear();
        for l in 0..levels {
            let k = f64::from(1u32 << l);
            let an = amp / k.sqrt();
            // Wavelet cells: those holding a break point; in cell units the
            // target primitive is tent(x − t).
            let (xa, xm, xb) = (va * k, vm * k, vb * k);
            let mut w = [(0u32, 0.0f64); 3];
            let mut len = 0usize;
            let breaks = [xa, xm, xb];
            let used = if wave_src { &breaks[..] } else { &[xa, xb][..] };
            for &bp in used {
                let t = floor_fast(bp);
                if !(0.0..k).contains(&t) {
                    continue;
                }
                let ti = t as u32;
                if w[..len].iter().any(|e| e.0 == ti) {
                    continue;
                }
                let p = |x: f64| (0.5 - (x - t - 0.5).abs()).max(0.0);
                let d = an
                    * if wave_src {
                        2.0 * p(xm) - p(xa) - p(xb)
                    } else {
                        p(xb) - p(xa)
                    };
                if d != 0.0 {
                    w[len] = (ti, d);
                    len += 1;
                }
            }
            self.wave.push(w);
            self.wave_len.push(len as u8);
        }
    }

    /// The box runs of the levels where `needed(l)`: cells meeting
    /// `[v_a, v_b) ∩ [0, 1)`, by the primitive `clamp(x − t, 0, 1)`.
    fn fill_boxes(&mut self, levels: u32, needed: impl Fn(usize) -> bool) {
        let (va, vm, vb, amp, wave_src) = (self.va, self.vm, self.vb, self.amp, self.wave_src);
        self.box_runs.clear();
        self.box_vals.clear();
        for l in 0..levels {
            let start = self.box_vals.len() as u32;
            let k = f64::from(1u32 << l);
            let (xa, xm, xb) = (va * k, vm * k, vb * k);
            let t0 = floor_fast(xa).max(0.0);
            let t1 = (-floor_fast(-xb)).min(k);
            if !needed(l as usize) || t1 <= t0 {
                self.box_runs.push((0, start, 0));
                continue;
            }
            let an = amp / k.sqrt();
            let first = t0 as u32;
            for t in first..t1 as u32 {
                let tf = f64::from(t);
                let p = |x: f64| (x - tf).clamp(0.0, 1.0);
                self.box_vals.push(if wave_src {
                    an * (2.0 * p(xm) - p(xa) - p(xb))
                } else {
                    an * (p(xb) - p(xa))
                });
            }
            self.box_runs.push((first, start, t1 as u32 - first));
        }
    }

    fn boxes(&self, l: usize) -> (u32, &[f64]) {
        let (first, start, count) = self.box_runs[l];
        (
            first,
            &self.box_vals[start as usize..(start + count) as usize],
        )
    }

    fn waves(&self, l: usize) -> &[(u32, f64)] {
        &self.wave[l][..usize::from(self.wave_len[l])]
    }
}

/// Reusable scratch of [`zoom_sparse`] (no allocation after warm-up).
#[derive(Default)]
pub struct ZoomScratch {
    u: AxisCouplings,
    v: AxisCouplings,
}

/// The affine transform `out(x) = F(s ⊙ x + o)` (`s > 0` per axis) of an
/// `n × n` nonstandard Haar image given by its non-zero coefficients
/// `src` = (Mallat index, value), computed for the target levels `< log₂
/// side` only: `out` is the `side × side` Mallat block (layout `r · side +
/// c`, equal to the top-left block of the order-`n` result; `side` a power
/// of two `≤ n`). Exact: equal to [`crate::separable::propagate_2d`] on that
/// block up to rounding (`tests/it/zoom.rs`). Indices `≥ n²` are ignored.
pub fn zoom_sparse(
    src: &[(u32, f32)],
    n: usize,
    s: [f64; 2],
    o: [f64; 2],
    side: usize,
    out: &mut [f64],
    scratch: &mut ZoomScratch,
) {
    let side = side.min(n);
    let levels = side.trailing_zeros();
    out[..side * side].iter_mut().for_each(|x| *x = 0.0);
    for &(idx, fi) in src {
        let idx = idx as usize;
        if fi == 0.0 || idx >= n * n {
            continue;
        }
        let (iu, iv) = atoms_2d(Basis::from_index(idx, n));
        // Level 0's boxes give the scaling target even when `side == 1`;
        // a level's boxes on one axis are needed only where the other axis
        // has wavelet couplings (types H and V).
        let lv = levels.max(1);
        scratch.u.fill_waves(iu, s[0], o[0], lv);
        scratch.v.fill_waves(iv, s[1], o[1], lv);
        let ZoomScratch { u, v } = scratch;
        v.fill_boxes(lv, |l| l == 0 || u.wave_len[l] > 0);
        u.fill_boxes(lv, |l| l == 0 || v.wave_len[l] > 0);
        let fi = f64::from(fi);
        let (cu, cv) = (&scratch.u, &scratch.v);
        // Scaling: φ(u) φ(v) at level 0 (one cell each).
        if let (Some(&a), Some(&b)) = (cu.boxes(0).1.first(), cv.boxes(0).1.first()) {
            out[0] += fi * a * b;
        }
        for l in 0..levels as usize {
            let h = 1usize << l;
            let (bu0, bu) = cu.boxes(l);
            let (bv0, bv) = cv.boxes(l);
            let (wu, wv) = (cu.waves(l), cv.waves(l));
            // H: ψ_{l,px}(u) φ_{l,py}(v), index py·side + h + px.
            for &(px, a) in wu {
                let fa = fi * a;
                for (j, &b) in bv.iter().enumerate() {
                    let py = bv0 as usize + j;
                    out[py * side + h + px as usize] += fa * b;
                }
            }
            // V: φ_{l,px}(u) ψ_{l,py}(v), index (h + py)·side + px.
            for &(py, b) in wv {
                let fb = fi * b;
                let row = &mut out[(h + py as usize) * side + bu0 as usize..][..bu.len()];
                for (d, &a) in row.iter_mut().zip(bu) {
                    *d += fb * a;
                }
            }
            // D: ψ(u) ψ(v), index (h + py)·side + h + px.
            for &(py, b) in wv {
                for &(px, a) in wu {
                    out[(h + py as usize) * side + h + px as usize] += fi * a * b;
                }
            }
        }
    }
}
