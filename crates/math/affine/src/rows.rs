//! The computational approach (§4.5.5): exact sparse rows and columns of the
//! ACC matrix from `M`, found by support overlap, and light propagation
//! `L_k = Σ_i F_i D_ik(s, o)` (eq. 4.35) in 1D.
//!
//! A transformed atom `Φ_i(s v + o)` has support
//! `[(t_i 2^{−l_i} − o)/s, ((t_i + 1) 2^{−l_i} − o)/s)` in v; at each target
//! level only the offsets whose support meets it can give a non-zero
//! coupling, about `s^{−1} 2^{l_j − l_i} + 1` of them (§4.4.2's counting
//! argument), so a row costs `O(log N + N/s)` evaluations rather than `N`.

use crate::atom::Atom;
use crate::coupling::affine_coupling;

/// Calls `f(t)` for every offset `t < 2^level` whose dyadic cell
/// `[t 2^{−level}, (t+1) 2^{−level})` meets the open interval `(lo, hi)`.
pub fn overlapping_offsets(level: u32, lo: f64, hi: f64, mut f: impl FnMut(u32)) {
    let k = f64::from(level).exp2();
    let count = 1u64 << level;
    let t0 = (lo * k).floor().max(0.0);
    let t1 = (hi * k).ceil().min(count as f64);
    if t1.is_nan() || t0.is_nan() || t1 <= t0 {
        return;
    }
    for t in t0 as u64..t1 as u64 {
        f(t as u32);
    }
}

/// The non-zero entries `(j, D_ij(s, o))` of row `i` of the ACC matrix of
/// the order-`n` 1D basis, in increasing `j`, appended to `out` (cleared).
pub fn acc_row(i: usize, n: usize, s: f64, o: f64, out: &mut Vec<(u32, f64)>) {
    out.clear();
    let ai = Atom::from_index(i);
    let (x0, x1) = ai.support();
    let (v0, v1) = ((x0 - o) / s, (x1 - o) / s);
    push_if(out, 0, affine_coupling(ai, Atom::from_index(0), s, o));
    let levels = n.trailing_zeros();
    for l in 0..levels {
        overlapping_offsets(l, v0, v1, |t| {
            let aj = Atom::wave(l, t);
            push_if(out, (1u32 << l) + t, affine_coupling(ai, aj, s, o));
        });
    }
}

/// The non-zero entries `(i, D_ij(s, o))` of the column of target atom `j`
/// (any atom, e.g. a box from a product) over sources `i` of the order-`n`
/// basis, appended to `out` (cleared).
pub fn acc_column(j: Atom, n: usize, s: f64, o: f64, out: &mut Vec<(u32, f64)>) {
    out.clear();
    let (v0, v1) = j.support();
    let (x0, x1) = (s * v0 + o, s * v1 + o);
    push_if(out, 0, affine_coupling(Atom::from_index(0), j, s, o));
    for l in 0..n.trailing_zeros() {
        overlapping_offsets(l, x0, x1, |t| {
            push_if(
                out,
                (1u32 << l) + t,
                affine_coupling(Atom::wave(l, t), j, s, o),
            );
        });
    }
}

fn push_if(out: &mut Vec<(u32, f64)>, idx: u32, v: f64) {
    if v != 0.0 {
        out.push((idx, v));
    }
}

/// Light propagation in 1D (eq. 4.35): `L_k = Σ_i F_i D_ik(s, o)` for a
/// coefficient vector `f` of the order-`n` basis (`f.len() == n`); exact
/// rows from `M`, skipping zero sources. Writes `out` (length `n`).
pub fn propagate(f: &[f64], s: f64, o: f64, out: &mut [f64], row: &mut Vec<(u32, f64)>) {
    let n = f.len();
    out.iter_mut().for_each(|x| *x = 0.0);
    for (i, &fi) in f.iter().enumerate() {
        if fi == 0.0 {
            continue;
        }
        acc_row(i, n, s, o, row);
        for &(k, d) in row.iter() {
            out[k as usize] += fi * d;
        }
    }
}

/// The dense ACC matrix `D[i][j]` (row-major `i * n + j`) by evaluating
/// every pair: the brute-force reference for [`acc_row`].
#[must_use]
pub fn acc_dense(n: usize, s: f64, o: f64) -> Vec<f64> {
    let mut d = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            d[i * n + j] = affine_coupling(Atom::from_index(i), Atom::from_index(j), s, o);
        }
    }
    d
}
