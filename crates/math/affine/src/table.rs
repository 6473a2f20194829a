//! The memory-based approach of §4.5.5: every non-zero 1D ACC `D_ij(s, o)`
//! of an order-`N` basis tabulated on an `R × R` grid of (s, o) — a sparse
//! 4D table — and propagation by table look-up.
//!
//! The grid: `s` log-spaced over `[s_min, s_max]`, `o` uniform over
//! `[o_min, o_max]` ([`Grid`]; the thesis does not give its ranges). Each
//! cell stores its non-zeros as `(i: u16, j: u16, D: f32)`, 8 bytes, plus a
//! `u32` start offset per cell. A query at an off-grid (s, o) either takes
//! the nearest cell or blends the four surrounding cells bilinearly; the
//! error this quantisation adds is measured by [`quantisation_error`].

use crate::rows::{acc_row, propagate};

/// The (s, o) grid of an [`AccTable`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Grid {
    /// Points per axis, ≥ 2.
    pub res: usize,
    /// Smallest scale, > 0.
    pub s_min: f64,
    /// Largest scale.
    pub s_max: f64,
    /// Smallest offset.
    pub o_min: f64,
    /// Largest offset.
    pub o_max: f64,
}

impl Grid {
    /// `res` points per axis over s ∈ \[1/8, 8\], o ∈ \[−1, 1\] (the
    /// ranges of [`crate::sparsity::random_sets`]).
    #[must_use]
    pub fn standard(res: usize) -> Self {
        Self {
            res: res.max(2),
            s_min: 0.125,
            s_max: 8.0,
            o_min: -1.0,
            o_max: 1.0,
        }
    }
    /// Scale at grid index `a`.
    #[must_use]
    pub fn s_at(&self, a: usize) -> f64 {
        let t = a as f64 / (self.res - 1) as f64;
        self.s_min * (self.s_max / self.s_min).powf(t)
    }
    /// Offset at grid index `b`.
    #[must_use]
    pub fn o_at(&self, b: usize) -> f64 {
        self.o_min + (self.o_max - self.o_min) * b as f64 / (self.res - 1) as f64
    }
    /// Continuous grid coordinates of (s, o), clamped to the grid.
    #[must_use]
    pub fn coords(&self, s: f64, o: f64) -> (f64, f64) {
        let m = (self.res - 1) as f64;
        let a = ((s / self.s_min).ln() / (self.s_max / self.s_min).ln() * m).clamp(0.0, m);
        let b = ((o - self.o_min) / (self.o_max - self.o_min) * m).clamp(0.0, m);
        (a, b)
    }
}

/// The sparse 4D ACC table.
#[derive(Clone, Debug)]
pub struct AccTable {
    /// Order N of the 1D basis (≤ 65536).
    pub n: usize,
    /// The grid.
    pub grid: Grid,
    starts: Vec<u32>,
    entries: Vec<(u16, u16, f32)>,
}

impl AccTable {
    /// Tabulates all non-zero ACCs by exact rows ([`acc_row`]).
    #[must_use]
    pub fn build(n: usize, grid: Grid) -> Self {
        let mut starts = Vec::with_capacity(grid.res * grid.res + 1);
        let mut entries = Vec::new();
        let mut row = Vec::new();
        for a in 0..grid.res {
            let s = grid.s_at(a);
            for b in 0..grid.res {
                let o = grid.o_at(b);
                starts.push(entries.len() as u32);
                for i in 0..n {
                    acc_row(i, n, s, o, &mut row);
                    entries.extend(row.iter().map(|&(j, d)| (i as u16, j as u16, d as f32)));
                }
            }
        }
        starts.push(entries.len() as u32);
        Self {
            n,
            grid,
            starts,
            entries,
        }
    }

    /// Stored non-zeros.
    #[must_use]
    pub fn nonzeros(&self) -> usize {
        self.entries.len()
    }

    /// Bytes of the table (8 per entry, 4 per cell start).
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.entries.len() * 8 + self.starts.len() * 4
    }

    fn cell(&self, a: usize, b: usize) -> &[(u16, u16, f32)] {
        let c = a * self.grid.res + b;
        &self.entries[self.starts[c] as usize..self.starts[c + 1] as usize]
    }

    fn accumulate(&self, a: usize, b: usize, w: f64, f: &[f64], out: &mut [f64]) {
        for &(i, j, d) in self.cell(a, b) {
            out[j as usize] += w * f[i as usize] * f64::from(d);
        }
    }

    /// Propagation by the nearest cell: `out_k = Σ_i f_i D_ik(s̃, õ)`.
    pub fn propagate_nearest(&self, f: &[f64], s: f64, o: f64, out: &mut [f64]) {
        out.iter_mut().for_each(|x| *x = 0.0);
        let (a, b) = self.grid.coords(s, o);
        self.accumulate(a.round() as usize, b.round() as usize, 1.0, f, out);
    }

    /// Propagation blending the four surrounding cells bilinearly in the
    /// grid coordinates.
    pub fn propagate_bilinear(&self, f: &[f64], s: f64, o: f64, out: &mut [f64]) {
        out.iter_mut().for_each(|x| *x = 0.0);
        let (a, b) = self.grid.coords(s, o);
        let m = self.grid.res - 1;
        let (a0, b0) = (
            (a.floor() as usize).min(m - 1),
            (b.floor() as usize).min(m - 1),
        );
        let (fa, fb) = (a - a0 as f64, b - b0 as f64);
        for (da, wa) in [(0, 1.0 - fa), (1, fa)] {
            for (db, wb) in [(0, 1.0 - fb), (1, fb)] {
                if wa * wb != 0.0 {
                    self.accumulate(a0 + da, b0 + db, wa * wb, f, out);
                }
            }
        }
    }
}

/// The relative L2 error `‖L_table − L_exact‖ / ‖L_exact‖` that the table
/// adds, over the queries `(s, o)` for signal `f` (length `n`): returns
/// `(nearest, bilinear)` as RMS over queries of the per-query relative error.
#[must_use]
pub fn quantisation_error(table: &AccTable, f: &[f64], queries: &[(f64, f64)]) -> (f64, f64) {
    let n = f.len();
    let (mut exact, mut near, mut bil) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut row = Vec::new();
    let (mut en, mut eb, mut count) = (0.0, 0.0, 0usize);
    for &(s, o) in queries {
        propagate(f, s, o, &mut exact, &mut row);
        let norm: f64 = exact.iter().map(|x| x * x).sum();
        if norm == 0.0 {
            continue;
        }
        table.propagate_nearest(f, s, o, &mut near);
        table.propagate_bilinear(f, s, o, &mut bil);
        let err = |y: &[f64]| {
            exact
                .iter()
                .zip(y)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                / norm
        };
        en += err(&near);
        eb += err(&bil);
        count += 1;
    }
    let c = count.max(1) as f64;
    ((en / c).sqrt(), (eb / c).sqrt())
}
