//! Printing rows of benchmark and accuracy figures as an aligned table or JSON.
//!
//! # Verdicts
//! A verify row that is judged against a target carries three fields,
//! `pass: Option<bool>`, `target: Option<f64>` and `source: Option<String>`
//! (where the target comes from: a paper's equation, table or figure, or the
//! issue that set it). A row that is only a report has `pass = null`. The
//! text table shows the `pass` column as `pass`, `FAIL` or `report`, the
//! `source` column as footnote keys `[k]` with the sources listed under the
//! table, and ends with one summary line, [`Verdicts::line`]
//! (`verify: 12 pass, 0 fail, 5 report rows`). JSON output is the rows as
//! they serialize (`"pass": true|false|null`, `"target"`, `"source"`); its
//! summary line goes to standard error so standard output stays one JSON
//! document. Tables whose rows have no `pass` field (benchmarks) print no
//! summary.

use crate::plot::{Plot, PlotSpec, write_plot};
use anyhow::Result;
use serde::Serialize;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Where the tables of a `bench` or `verify` run go: standard output (text or
/// JSON) and, with `--plot DIR`, one SVG plot per [`PlotSpec`].
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Print JSON arrays instead of text tables.
    pub json: bool,
    /// Directory for SVG plots (`--plot`), if any.
    pub plot_dir: Option<PathBuf>,
    /// Tables printed and plots they asked for (drawn or skipped with a
    /// reason), so far.
    counts: std::sync::Arc<[std::sync::atomic::AtomicUsize; 2]>,
}

impl Report {
    /// A report to standard output (`json`: JSON arrays) with plots into
    /// `plot_dir`.
    #[must_use]
    pub fn new(json: bool, plot_dir: Option<PathBuf>) -> Self {
        Self {
            json,
            plot_dir,
            counts: std::sync::Arc::default(),
        }
    }

    /// Says so when `--plot` was given, tables were printed and none of
    /// them has a plot, instead of leaving the folder empty without a word.
    pub fn finish(&self, what: &str) {
        let [tables, plots] = &*self.counts;
        let relaxed = std::sync::atomic::Ordering::Relaxed;
        if let Some(dir) = &self.plot_dir
            && tables.load(relaxed) > 0
            && plots.load(relaxed) == 0
        {
            eprintln!(
                "relight: warning: --plot {}: {what} has no plots (its tables are not curves); nothing written",
                dir.display()
            );
        }
    }

    /// Prints `rows` (flat serde structs) as an aligned text table (columns in
    /// the first row's field order) or as a JSON array, and writes the `plots`
    /// of them when a plot directory was given.
    pub fn table<T: Serialize>(&self, title: &str, rows: &[T], plots: &[PlotSpec]) -> Result<()> {
        self.table_verdicts(title, rows, plots).map(|_| ())
    }

    /// [`Report::table`], returning the verdict counts of the rows (`None`
    /// when they carry no `pass` field), e.g. for an exit code.
    pub fn table_verdicts<T: Serialize>(
        &self,
        title: &str,
        rows: &[T],
        plots: &[PlotSpec],
    ) -> Result<Option<Verdicts>> {
        let plots: Vec<Plot> = plots.iter().copied().map(Plot::from).collect();
        self.table_plots(title, rows, &plots)
    }

    /// [`Report::table_verdicts`] with plots that carry their own titles,
    /// axis labels or row filters ([`Plot`]).
    pub fn table_plots<T: Serialize>(
        &self,
        title: &str,
        rows: &[T],
        plots: &[Plot],
    ) -> Result<Option<Verdicts>> {
        let values = to_values(rows)?;
        let verdicts = Verdicts::of(&values);
        if self.json {
            println!("{}", serde_json::to_string_pretty(&values)?);
            if let Some(v) = verdicts {
                eprintln!("relight: {title}: {}", v.line());
            }
        } else {
            print!("{}", render_text(title, &values));
        }
        let relaxed = std::sync::atomic::Ordering::Relaxed;
        self.counts[0].fetch_add(1, relaxed);
        self.counts[1].fetch_add(plots.len(), relaxed);
        if let Some(dir) = &self.plot_dir {
            for plot in plots {
                if let Some(path) = write_plot(dir, title, &values, plot)? {
                    eprintln!("relight: wrote {}", path.display());
                }
            }
        }
        Ok(verdicts)
    }
}

/// How many rows of a verify table passed, failed, or are reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Verdicts {
    /// Rows with `"pass": true`.
    pub pass: usize,
    /// Rows with `"pass": false`.
    pub fail: usize,
    /// Rows with `"pass": null` (no target).
    pub report: usize,
}

impl Verdicts {
    /// Counts the `pass` fields of `values`; `None` when no row has one.
    #[must_use]
    pub fn of(values: &[Value]) -> Option<Self> {
        let mut v = Self::default();
        let mut any = false;
        for row in values {
            match row.get("pass") {
                None => {}
                Some(Value::Bool(true)) => (any, v.pass) = (true, v.pass + 1),
                Some(Value::Bool(false)) => (any, v.fail) = (true, v.fail + 1),
                Some(_) => (any, v.report) = (true, v.report + 1),
            }
        }
        any.then_some(v)
    }

    /// The table's last line: `verify: P pass, F fail, R report rows`.
    #[must_use]
    pub fn line(&self) -> String {
        format!(
            "verify: {} pass, {} fail, {} report rows",
            self.pass, self.fail, self.report
        )
    }
}

fn to_values<T: Serialize>(rows: &[T]) -> Result<Vec<Value>> {
    Ok(rows
        .iter()
        .map(serde_json::to_value)
        .collect::<Result<_, _>>()?)
}

/// The text form of a table: title, header, rule, rows, the list of
/// footnoted sources and the verdict summary (module docs).
fn render_text(title: &str, values: &[Value]) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{title}");
    let Some(Value::Object(first)) = values.first() else {
        let _ = writeln!(out, "(no rows)");
        return out;
    };
    let columns: Vec<String> = first.keys().cloned().collect();
    let mut sources: Vec<String> = Vec::new();
    let cells: Vec<Vec<String>> = values
        .iter()
        .map(|v| {
            columns
                .iter()
                .map(|c| {
                    let cell = v.get(c).unwrap_or(&Value::Null);
                    match (c.as_str(), cell) {
                        ("pass", v) => verdict_cell(v).to_string(),
                        ("source", Value::String(s)) => {
                            let k = sources.iter().position(|x| x == s).unwrap_or_else(|| {
                                sources.push(s.clone());
                                sources.len() - 1
                            });
                            format!("[{}]", k + 1)
                        }
                        (_, v) => format_cell(v),
                    }
                })
                .collect()
        })
        .collect();
    let widths: Vec<usize> = columns
        .iter()
        .enumerate()
        .map(|(i, c)| {
            cells
                .iter()
                .map(|r| r[i].chars().count())
                .chain([c.chars().count()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |r: &[String]| {
        r.iter()
            .zip(&widths)
            .map(|(s, w)| format!("{s:>w$}"))
            .collect::<Vec<_>>()
            .join("  ")
    };
    let _ = writeln!(out, "{}", line(&columns));
    let _ = writeln!(
        out,
        "{}",
        widths
            .iter()
            .map(|w| "-".repeat(*w))
            .collect::<Vec<_>>()
            .join("  ")
    );
    for r in &cells {
        let _ = writeln!(out, "{}", line(r));
    }
    for (k, s) in sources.iter().enumerate() {
        let _ = writeln!(out, "[{}] {s}", k + 1);
    }
    if let Some(v) = Verdicts::of(values) {
        let _ = writeln!(out, "{}", v.line());
    }
    out
}

/// `pass` / `FAIL` / `report` for a row's `pass` field.
fn verdict_cell(v: &Value) -> &'static str {
    match v {
        Value::Bool(true) => "pass",
        Value::Bool(false) => "FAIL",
        _ => "report",
    }
}

fn format_cell(v: &Value) -> String {
    match v {
        Value::Null => "-".into(),
        Value::Number(n) => match n.as_f64() {
            Some(x) if n.is_f64() => {
                let a = x.abs();
                if a == 0.0 {
                    "0".into()
                } else if !(1e-3..1e6).contains(&a) {
                    format!("{x:.3e}")
                } else if a >= 100.0 {
                    format!("{x:.1}")
                } else {
                    format!("{x:.4}")
                }
            }
            _ => n.to_string(),
        },
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn rows() -> Vec<Value> {
        vec![
            json!({"case": "a", "error": 0.05, "pass": true, "target": 0.07, "source": "issue 4"}),
            json!({"case": "b", "error": 0.0701, "pass": false, "target": 0.07, "source": "issue 4"}),
            json!({"case": "c", "error": 0.3, "pass": null, "target": null, "source": "report: no target"}),
            json!({"case": "d", "error": 0.2, "pass": null, "target": null, "source": null}),
        ]
    }

    /// The pass column reads pass / FAIL / report, sources become footnotes
    /// listed once each, and the last line is the summary.
    #[test]
    fn verdict_cells_footnotes_and_summary() {
        let text = render_text("relight verify x", &rows());
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "relight verify x");
        let header: Vec<&str> = lines[1].split_whitespace().collect();
        assert_eq!(header, ["case", "error", "pass", "target", "source"]);
        let cell = |row: usize, col: usize| -> String {
            lines[3 + row]
                .split_whitespace()
                .nth(col)
                .unwrap()
                .to_string()
        };
        assert_eq!(cell(0, 2), "pass");
        assert_eq!(cell(1, 2), "FAIL");
        assert_eq!(cell(2, 2), "report");
        assert_eq!(cell(3, 2), "report");
        assert_eq!(
            (cell(0, 4), cell(1, 4), cell(2, 4)),
            ("[1]".into(), "[1]".into(), "[2]".into())
        );
        assert_eq!(cell(3, 4), "-", "a null source prints as a dash");
        assert_eq!(cell(2, 3), "-", "a null target prints as a dash");
        assert_eq!(lines[7], "[1] issue 4");
        assert_eq!(lines[8], "[2] report: no target");
        assert_eq!(
            *lines.last().unwrap(),
            "verify: 1 pass, 1 fail, 2 report rows"
        );
        assert_eq!(lines.len(), 10);
        // CI parses cargo's "N passed; N failed": the summary must not look like it.
        assert!(!text.contains("passed") && !text.contains("failed"));
    }

    #[test]
    fn counts_and_tables_without_verdicts() {
        assert_eq!(
            Verdicts::of(&rows()),
            Some(Verdicts {
                pass: 1,
                fail: 1,
                report: 2
            })
        );
        let bench = vec![json!({"op": "eval", "ns": 12.5})];
        assert_eq!(Verdicts::of(&bench), None);
        let text = render_text("relight bench x", &bench);
        assert!(!text.contains("verify:"), "{text}");
        assert!(text.lines().last().unwrap().contains("12.5"));
        assert_eq!(render_text("t", &[]), "t\n(no rows)\n");
    }
}
