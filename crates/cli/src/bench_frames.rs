//! `relight bench frames`: the viewer's frame path per method and size
//! (`relight_viewer::bench`), printed as a table with the issue-11 targets
//! and plotted per interaction step.

use crate::args::BenchArgs;
use crate::plot::PlotSpec;
use crate::table::Report;
use anyhow::{Result, anyhow};
use relight_methods::MethodKind;
use relight_viewer::bench::{FrameBenchOptions, MACHINE_GFMA, bench_frames};

/// One plot per timed column: ms against image size, one line per method and case.
const PLOTS: [PlotSpec<'static>; 4] = [
    spec("bench-frames-view", "view_change_ms"),
    spec("bench-frames-light", "light_change_ms"),
    spec("bench-frames-first-still", "first_still_ms"),
    spec("bench-frames-refined", "refined_ms"),
];

const fn spec(name: &'static str, y: &'static str) -> PlotSpec<'static> {
    PlotSpec {
        name,
        x: "height",
        y,
        series: &["method", "case"],
        log_y: true,
    }
}

pub fn run(a: &BenchArgs, bar: &crate::progress::Bar) -> Result<()> {
    let mut opts = if a.quick {
        FrameBenchOptions::quick()
    } else {
        FrameBenchOptions::full()
    };
    if !a.methods.is_empty() {
        let kinds = a
            .methods
            .iter()
            .map(|m| {
                m.parse::<MethodKind>()
                    .map_err(|e| anyhow!("--method {m}: {e}"))
            })
            .collect::<Result<Vec<_>>>()?;
        opts.cases.retain(|c| kinds.contains(&c.options.kind()));
    }
    let rows = bench_frames(&opts, bar)?;
    let report = Report {
        json: a.json,
        plot_dir: a.plot.clone(),
    };
    report.table(
        &format!(
            "relight bench frames (the viewer's frame path, ms, medians; machine_fraction of {MACHINE_GFMA} GFMA/s)"
        ),
        &rows,
        &PLOTS,
    )
}
