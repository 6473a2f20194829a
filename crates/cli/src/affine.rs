//! `relight verify affine` and `relight bench affine`: the affine Haar
//! product-integral theory of `relight-affine` (thesis ch. 4 §4.3–4.5.5).

use crate::args::{BenchArgs, VerifyArgs};
use crate::plot::{Plot, PlotSpec};
use crate::table::Report;
use anyhow::{Result, bail};

/// `relight verify affine`: fails (exit 1) when any gated row fails.
pub fn verify(a: &VerifyArgs, report: &Report) -> Result<()> {
    let rows = relight_affine::verify::verify_affine(a.quick);
    let v = report.table_verdicts("relight verify affine", &rows, &[])?;
    if let Some(v) = v
        && v.fail > 0
    {
        bail!(
            "verify affine: {} of {} gated rows fail",
            v.fail,
            v.fail + v.pass
        );
    }
    Ok(())
}

/// `relight bench affine`: five tables (sparsity curves, complexity,
/// 4D table cost, propagation time, zoom), each one JSON array with `--json` (as
/// `bench sh` prints its two).
pub fn bench(a: &BenchArgs, report: &Report) -> Result<()> {
    let b = relight_affine::bench::bench_affine(a.quick);
    report.table_plots(
        "relight bench affine: Fig. 4.6 exact ACC non-zeros per (s, o)",
        &b.fig46,
        &[Plot::new(PlotSpec {
            name: "bench-affine-fig46",
            x: "n",
            y: "per_n",
            series: &["set"],
            log_y: false,
        })
        .log_x()
        .labels("wavelets N", "non-zero ACCs / N (Fig. 4.6B)")],
    )?;
    report.table(
        "relight bench affine: §4.4.3 complexity (exact non-zeros)",
        &b.complexity,
        &[],
    )?;
    report.table_plots(
        "relight bench affine: §4.5.5 memory-based 4D table (s ∈ [1/8, 8] log, o ∈ [−1, 1])",
        &b.table,
        &[Plot::new(PlotSpec {
            name: "bench-affine-table",
            x: "res",
            y: "mb",
            series: &["order"],
            log_y: true,
        })
        .log_x()
        .labels("grid points per axis R", "table size (MB)")],
    )?;
    report.table(
        "relight bench affine: propagation per (s, o), computational vs table",
        &b.row_time,
        &[],
    )?;
    report.table(
        "relight bench affine: §4.6.2 zoom, wavelet domain (sparse couplings, zoom_sparse) vs pixel path (inverse Haar → box resampling → forward Haar), one thread",
        &b.zoom,
        &[],
    )
}
