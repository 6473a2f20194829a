//! Exact non-zero counts of the Haar ACC and ATC (§4.4.2, Fig. 4.6) and the
//! complexity table of §4.4.3.
//!
//! "Non-zero" means the coefficient is not exactly `0.0`; [`canonical`]
//! returns structural zeros as exact zeros, so these are counts of the
//! integrals that do not vanish, not of values above a threshold.
//! The thesis bounds the ACC count by `N log N + log² N` (§4.4.2).
//!
//! [`canonical`]: crate::canonical::canonical

use crate::atom::Atom;
use crate::rows::{acc_column, acc_row, overlapping_offsets};
use std::collections::HashMap;

/// Number of non-zero `D_ij(s, o)` over the order-`n` 1D Haar basis.
#[must_use]
pub fn acc_nonzeros(n: usize, s: f64, o: f64) -> usize {
    let mut row = Vec::new();
    (0..n)
        .map(|i| {
            acc_row(i, n, s, o, &mut row);
            row.len()
        })
        .sum()
}

/// Calls `f(k)` for every basis index `k < n` whose support overlaps that of
/// basis function `j` (itself, ancestors, descendants and φ_0).
pub fn overlapping_pairs(j: usize, n: usize, mut f: impl FnMut(usize)) {
    let aj = Atom::from_index(j);
    let (lo, hi) = aj.support();
    f(0);
    for l in 0..n.trailing_zeros() {
        overlapping_offsets(l, lo, hi, |t| f((1usize << l) + t as usize));
    }
}

/// Number of non-zero `D_ijk(s, o)` over ordered triples of the order-`n`
/// basis: for each overlapping ordered pair `(j, k)`, the non-zeros of the
/// column of their product atom (Property 2).
#[must_use]
pub fn atc_nonzeros(n: usize, s: f64, o: f64) -> usize {
    let mut cache: HashMap<Atom, usize> = HashMap::new();
    let mut col = Vec::new();
    let mut total = 0;
    for j in 0..n {
        let aj = Atom::from_index(j);
        overlapping_pairs(j, n, |k| {
            if let Some((_, m)) = aj.product(Atom::from_index(k)) {
                total += *cache.entry(m).or_insert_with(|| {
                    acc_column(m, n, s, o, &mut col);
                    col.len()
                });
            }
        });
    }
    total
}

/// The thesis' ACC bound `N log₂N + log₂²N`.
#[must_use]
pub fn thesis_acc_bound(n: usize) -> f64 {
    let l = (n as f64).log2();
    n as f64 * l + l * l
}

/// One point of a Fig. 4.6 curve.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CurvePoint {
    /// Which random (s, o) set (0-based).
    pub set: usize,
    /// Scale s.
    pub s: f64,
    /// Offset o.
    pub o: f64,
    /// Order N of the 1D basis.
    pub n: usize,
    /// Exact non-zero ACCs.
    pub acc_nonzeros: usize,
    /// `acc_nonzeros / N` (Fig. 4.6B).
    pub per_n: f64,
    /// `N log₂ N` (Fig. 4.6's cyan line).
    pub n_log_n: f64,
}

/// Deterministic (s, o) sets: `s` log-uniform in \[1/8, 8\], `o` uniform
/// in \[−1, 1\] (the thesis does not give its ranges), from an xorshift seed.
#[must_use]
pub fn random_sets(count: usize, seed: u64) -> Vec<(f64, f64)> {
    let mut x = seed.max(1);
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..count)
        .map(|_| {
            let s = (8f64).powf(2.0 * next() - 1.0);
            let o = 2.0 * next() - 1.0;
            (s, o)
        })
        .collect()
}

/// Fig. 4.6's curves: exact ACC non-zeros for `N = 2, 4, …, max_n` at each set.
#[must_use]
pub fn fig46_curves(sets: &[(f64, f64)], max_n: usize) -> Vec<CurvePoint> {
    let mut rows = Vec::new();
    for (set, &(s, o)) in sets.iter().enumerate() {
        let mut n = 2;
        while n <= max_n {
            let nz = acc_nonzeros(n, s, o);
            rows.push(CurvePoint {
                set,
                s,
                o,
                n,
                acc_nonzeros: nz,
                per_n: nz as f64 / n as f64,
                n_log_n: n as f64 * (n as f64).log2(),
            });
            n *= 2;
        }
    }
    rows
}

/// One row of the §4.4.3 complexity table at one (N, s, o): exact counts.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ComplexityRow {
    /// `pixel`, `fourier` or `haar`.
    pub basis: &'static str,
    /// Order N.
    pub n: usize,
    /// Scale s.
    pub s: f64,
    /// Offset o.
    pub o: f64,
    /// Non-zero SCC `C_ij` (= N: Kronecker delta).
    pub scc: usize,
    /// Non-zero ACC.
    pub acc: usize,
    /// Non-zero STC.
    pub stc: usize,
    /// Non-zero ATC.
    pub atc: usize,
    /// `acc / (N log₂ N)`.
    pub acc_per_n_log_n: f64,
    /// `atc / (N log₂² N)`.
    pub atc_per_n_log2_n: f64,
}

/// The §4.4.3 table at `(n, s, o)`; the Fourier row uses `round(s)` (≥ 1)
/// since eqs. 4.18–4.19 need an integer scale.
#[must_use]
pub fn complexity_table(n: usize, s: f64, o: f64) -> Vec<ComplexityRow> {
    let l = (n as f64).log2().max(1.0);
    let nf = n as f64;
    let row = |basis, s, scc, acc, stc, atc| ComplexityRow {
        basis,
        n,
        s,
        o,
        scc,
        acc,
        stc,
        atc,
        acc_per_n_log_n: acc as f64 / (nf * l),
        atc_per_n_log2_n: atc as f64 / (nf * l * l),
    };
    let pix = crate::other_bases::pixel_acc_nonzeros(n, s, o);
    let si = s.round().max(1.0) as i64;
    let f_acc = crate::other_bases::fourier_acc_nonzeros(n, si);
    let f_stc = crate::other_bases::fourier_atc_nonzeros(n, 1);
    let f_atc = crate::other_bases::fourier_atc_nonzeros(n, si);
    let h_acc = acc_nonzeros(n, s, o);
    let h_stc = atc_nonzeros(n, 1.0, 0.0);
    let h_atc = atc_nonzeros(n, s, o);
    vec![
        row("pixel", s, n, pix, n, pix),
        row("fourier", si as f64, n, f_acc, f_stc, f_atc),
        row("haar", s, acc_nonzeros(n, 1.0, 0.0), h_acc, h_stc, h_atc),
    ]
}
