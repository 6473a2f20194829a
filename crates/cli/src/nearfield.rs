//! `relight verify nearfield`, `relight bench nearfield` and the nearfield
//! method's flags: flags → relight-nearfield → tables.

use crate::args::{BenchArgs, MethodFlags, VerifyArgs};
use crate::progress::Bar;
use crate::table::Report;
use anyhow::{Result, anyhow, bail};
use relight_nearfield::NearfieldOptions;
use relight_nearfield::bench::{BenchOptions, bench_nearfield};
use relight_nearfield::verify::{VerifyOptions, verify_rows};

/// Applies `--order`, `--face`, `--source-terms`, `--target-terms` (ranges
/// are checked by the method).
pub fn apply_flags(o: &mut NearfieldOptions, f: &MethodFlags) {
    if let Some(n) = f.order {
        o.order = n;
    }
    if let Some(s) = f.face {
        o.face = s;
    }
    if let Some(s) = f.source_terms {
        o.source_terms = s;
    }
    if let Some(t) = f.target_terms {
        o.target_terms = t;
    }
}

/// `relight verify nearfield` (`per_vertex_only`: `nearfield-vertex`, the
/// rows before the reference render): fails (exit 1) when any gated row
/// fails.
pub fn verify(a: &VerifyArgs, report: &Report, bar: &Bar, per_vertex_only: bool) -> Result<()> {
    let opts = VerifyOptions {
        per_vertex_only,
        ..VerifyOptions::new(a.quick)
    };
    let rows = verify_rows(&opts, bar).map_err(|e| anyhow!(e))?;
    let v = report.table_verdicts(
        "relight verify nearfield (floor + sphere under a textured ceiling light)",
        &rows,
        &[],
    )?;
    if let Some(v) = v
        && v.fail > 0
    {
        bail!(
            "verify nearfield: {} of {} gated rows fail",
            v.fail,
            v.fail + v.pass
        );
    }
    Ok(())
}

/// `relight bench nearfield`: Fig. 4.11's table and the bake.
pub fn bench(a: &BenchArgs, report: &Report, bar: &Bar) -> Result<()> {
    let opts = BenchOptions::new(a.quick, relight_viewer::bench::MACHINE_GFMA);
    let (rows, bakes) = bench_nearfield(&opts, bar)?;
    report.table(
        &format!(
            "relight bench nearfield: Fig. 4.11 (order 32, face 4, shadows; frame = propagation + Gouraud raster at {}×{}; thesis 3 GHz 1/8 threads)",
            opts.width, opts.height
        ),
        &rows,
        &[],
    )?;
    report.table(
        "relight bench nearfield: bake (transport with shadows)",
        &bakes,
        &[],
    )
}
