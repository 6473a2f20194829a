//! `relight bench affine`: the Fig. 4.6 curves, the §4.4.3 complexity
//! table, the §4.5.5 table's size and build time on its grid, the error its
//! quantisation adds, and computational vs table propagation time.
//! Measured figures belong in docs/affine.md, not here.

use crate::sparsity::{ComplexityRow, CurvePoint, complexity_table, fig46_curves, random_sets};
use crate::table::{AccTable, Grid, quantisation_error};
use std::time::Instant;

/// The thesis' §4.5.5 table: (order, resolution, MB, seconds) on a 3 GHz
/// machine (one thread).
pub const THESIS_TABLE: [(usize, usize, f64, f64); 20] = [
    (8, 64, 0.26, 0.011),
    (8, 128, 1.05, 0.044),
    (8, 256, 4.22, 0.176),
    (8, 512, 16.92, 0.708),
    (8, 1024, 67.74, 2.760),
    (16, 64, 0.56, 0.029),
    (16, 128, 2.25, 0.114),
    (16, 256, 9.03, 0.457),
    (16, 512, 36.24, 1.801),
    (16, 1024, 145.09, 7.093),
    (32, 64, 1.15, 0.066),
    (32, 128, 4.65, 0.257),
    (32, 256, 18.66, 1.059),
    (32, 512, 74.81, 4.236),
    (32, 1024, 299.45, 16.871),
    (64, 64, 2.33, 0.147),
    (64, 128, 9.44, 0.589),
    (64, 256, 37.83, 2.368),
    (64, 512, 151.60, 9.498),
    (64, 1024, 606.78, 37.768),
];

/// One table size/time point.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TableRow {
    /// Wavelet order N.
    pub order: usize,
    /// Grid points per axis R (R² cells).
    pub res: usize,
    /// Stored non-zeros.
    pub nonzeros: usize,
    /// Size in MB (10⁶ bytes).
    pub mb: f64,
    /// Build time, seconds (one thread).
    pub build_s: f64,
    /// The thesis' size, MB.
    pub thesis_mb: f64,
    /// The thesis' time, s.
    pub thesis_s: f64,
    /// RMS relative L2 error of a propagated random signal, nearest cell.
    pub quant_err_nearest: f64,
    /// Same, bilinear blend of four cells.
    pub quant_err_bilinear: f64,
}

/// Propagation time per (s, o) query.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RowTimeRow {
    /// Order N.
    pub order: usize,
    /// `computational` (exact rows from M), `table_nearest`, `table_bilinear`.
    pub method: &'static str,
    /// Microseconds per propagation of a dense N-vector.
    pub us_per_query: f64,
}

/// All tables of the bench.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchAffine {
    /// Fig. 4.6.
    pub fig46: Vec<CurvePoint>,
    /// §4.4.3 at N = 256 (quick: 64) for three (s, o).
    pub complexity: Vec<ComplexityRow>,
    /// §4.5.5 table grid.
    pub table: Vec<TableRow>,
    /// Computational vs memory-based propagation.
    pub row_time: Vec<RowTimeRow>,
}

fn signal(n: usize) -> Vec<f64> {
    random_sets(n, 77).iter().map(|p| p.1).collect()
}

/// Runs the bench (`quick`: N ≤ 256 curves, R ≤ 128, orders 8–32).
#[must_use]
pub fn bench_affine(quick: bool) -> BenchAffine {
    let sets = random_sets(50, 1);
    let fig46 = fig46_curves(&sets, if quick { 256 } else { 4096 });
    let cn = if quick { 64 } else { 256 };
    let mut complexity = Vec::new();
    for (s, o) in [(1.0, 0.0), (2.0, 0.3), (0.37, -0.21)] {
        complexity.extend(complexity_table(cn, s, o));
    }
    let orders: &[usize] = if quick { &[8, 32] } else { &[8, 16, 32, 64] };
    let resolutions: &[usize] = if quick {
        &[64, 128]
    } else {
        &[64, 128, 256, 512]
    };
    let queries = random_sets(200, 4242);
    let mut table = Vec::new();
    let mut row_time = Vec::new();
    for &order in orders {
        let f = signal(order);
        for &res in resolutions {
            let t0 = Instant::now();
            let t = AccTable::build(order, Grid::standard(res));
            let build_s = t0.elapsed().as_secs_f64();
            let (en, eb) = quantisation_error(&t, &f, &queries);
            let thesis = THESIS_TABLE
                .iter()
                .find(|r| r.0 == order && r.1 == res)
                .map_or((f64::NAN, f64::NAN), |r| (r.2, r.3));
            table.push(TableRow {
                order,
                res,
                nonzeros: t.nonzeros(),
                mb: t.bytes() as f64 / 1e6,
                build_s,
                thesis_mb: thesis.0,
                thesis_s: thesis.1,
                quant_err_nearest: en,
                quant_err_bilinear: eb,
            });
            if res == 256 || (quick && res == 128) {
                row_time.extend(time_rows(&t, &f, &queries));
            }
        }
    }
    BenchAffine {
        fig46,
        complexity,
        table,
        row_time,
    }
}

fn time_rows(t: &AccTable, f: &[f64], queries: &[(f64, f64)]) -> Vec<RowTimeRow> {
    let n = f.len();
    let mut out = vec![0.0; n];
    let mut row = Vec::new();
    let reps = 20;
    let mut time = |g: &mut dyn FnMut(f64, f64, &mut [f64])| {
        let t0 = Instant::now();
        let mut sink = 0.0;
        for _ in 0..reps {
            for &(s, o) in queries {
                g(s, o, &mut out);
                sink += out[0];
            }
        }
        std::hint::black_box(sink);
        t0.elapsed().as_secs_f64() * 1e6 / (reps * queries.len()) as f64
    };
    let comp = time(&mut |s, o, out| crate::rows::propagate(f, s, o, out, &mut row));
    let near = time(&mut |s, o, out| t.propagate_nearest(f, s, o, out));
    let bil = time(&mut |s, o, out| t.propagate_bilinear(f, s, o, out));
    vec![
        RowTimeRow {
            order: n,
            method: "computational",
            us_per_query: comp,
        },
        RowTimeRow {
            order: n,
            method: "table_nearest",
            us_per_query: near,
        },
        RowTimeRow {
            order: n,
            method: "table_bilinear",
            us_per_query: bil,
        },
    ]
}
