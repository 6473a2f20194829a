//! `relight bench frames`: the viewer's frame path per method and size
//! (`relight_viewer::bench`), printed as a table with each case's target
//! (issue 11's, and the later methods' own issues') and plotted per
//! interaction step.

use crate::args::BenchArgs;
use crate::plot::PlotSpec;
use crate::table::Report;
use anyhow::{Result, anyhow};
use relight_methods::MethodKind;
use relight_viewer::bench::{FrameBenchOptions, FrameBenchRow, MACHINE_GFMA, bench_frames};

/// One plot per timed column: ms against image size, one line per method and case.
const PLOTS: [PlotSpec<'static>; 6] = [
    spec("bench-frames-view", "view_change_ms"),
    spec("bench-frames-light", "light_change_ms"),
    spec("bench-frames-first-still", "first_still_ms"),
    spec("bench-frames-refined", "refined_ms"),
    // How far from the machine's f32 rate each counted row is.
    spec("bench-frames-view-fraction", "machine_fraction"),
    spec("bench-frames-light-fraction", "light_machine_fraction"),
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

pub fn run(a: &BenchArgs, report: &Report, bar: &crate::progress::Bar) -> Result<()> {
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
    let mut rows = bench_frames(&opts, bar)?;
    // JSON keeps each row's note whole; the text table names it by a key and
    // lists every distinct note once under the table.
    let notes = if a.json {
        Vec::new()
    } else {
        note_keys(&mut rows)
    };
    report.table(
        &format!(
            "relight bench frames (the viewer's frame path, ms, medians; machine_fraction of {MACHINE_GFMA} GFMA/s; kernels: {})",
            relight_sh::isa().name()
        ),
        &rows,
        &PLOTS,
    )?;
    for (k, n) in notes.iter().enumerate() {
        println!("{}: {n}", note_key(k));
    }
    Ok(())
}

/// The key of the `k`-th distinct note (`n1`, `n2`, …).
fn note_key(k: usize) -> String {
    format!("n{}", k + 1)
}

/// Replaces every row's note by the key of its text ([`note_key`]) and
/// returns the distinct texts in order of first appearance.
fn note_keys(rows: &mut [FrameBenchRow]) -> Vec<String> {
    let mut notes: Vec<String> = Vec::new();
    for r in rows {
        if let Some(n) = r.note.take() {
            let k = notes.iter().position(|x| *x == n).unwrap_or_else(|| {
                notes.push(n);
                notes.len() - 1
            });
            r.note = Some(note_key(k));
        }
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(note: Option<&str>) -> FrameBenchRow {
        FrameBenchRow {
            method: "sh".into(),
            case: "c".into(),
            width: 1,
            height: 1,
            prepare_ms: 0.0,
            view_change_ms: None,
            light_change_ms: None,
            first_still_ms: None,
            refined_ms: None,
            passes: 0,
            work_fma: None,
            machine_fraction: None,
            light_work_fma: None,
            light_machine_fraction: None,
            note: note.map(str::to_string),
            target: None,
            pass: None,
            source: None,
        }
    }

    /// A note repeated on several rows is listed once; rows keep a key.
    #[test]
    fn distinct_notes_listed_once() {
        let mut rows = vec![
            row(Some("long ring warning")),
            row(None),
            row(Some("other")),
            row(Some("long ring warning")),
        ];
        let notes = note_keys(&mut rows);
        assert_eq!(notes, ["long ring warning", "other"]);
        let keys: Vec<Option<&str>> = rows.iter().map(|r| r.note.as_deref()).collect();
        assert_eq!(keys, [Some("n1"), None, Some("n2"), Some("n1")]);
    }
}
