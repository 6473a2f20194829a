//! Printing rows of benchmark and accuracy figures as an aligned table or JSON.

use crate::plot::{PlotSpec, write_plot};
use anyhow::Result;
use serde::Serialize;
use serde_json::Value;
use std::path::PathBuf;

/// Where the tables of a `bench` or `verify` run go: standard output (text or
/// JSON) and, with `--plot DIR`, one SVG plot per [`PlotSpec`].
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Print JSON arrays instead of text tables.
    pub json: bool,
    /// Directory for SVG plots (`--plot`), if any.
    pub plot_dir: Option<PathBuf>,
}

impl Report {
    /// Prints `rows` (flat serde structs) as an aligned text table (columns in
    /// the first row's field order) or as a JSON array, and writes the `plots`
    /// of them when a plot directory was given.
    pub fn table<T: Serialize>(&self, title: &str, rows: &[T], plots: &[PlotSpec]) -> Result<()> {
        let values = to_values(rows)?;
        print_values(title, &values, self.json)?;
        if let Some(dir) = &self.plot_dir {
            for spec in plots {
                let path = write_plot(dir, title, &values, spec)?;
                eprintln!("relight: wrote {}", path.display());
            }
        }
        Ok(())
    }
}

fn to_values<T: Serialize>(rows: &[T]) -> Result<Vec<Value>> {
    Ok(rows
        .iter()
        .map(serde_json::to_value)
        .collect::<Result<_, _>>()?)
}

fn print_values(title: &str, values: &[Value], json: bool) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(&values)?);
        return Ok(());
    }
    println!("{title}");
    let Some(Value::Object(first)) = values.first() else {
        println!("(no rows)");
        return Ok(());
    };
    let columns: Vec<String> = first.keys().cloned().collect();
    let cells: Vec<Vec<String>> = values
        .iter()
        .map(|v| {
            columns
                .iter()
                .map(|c| format_cell(v.get(c).unwrap_or(&Value::Null)))
                .collect()
        })
        .collect();
    let widths: Vec<usize> = columns
        .iter()
        .enumerate()
        .map(|(i, c)| {
            cells
                .iter()
                .map(|r| r[i].len())
                .chain([c.len()])
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
    println!("{}", line(&columns));
    println!(
        "{}",
        widths
            .iter()
            .map(|w| "-".repeat(*w))
            .collect::<Vec<_>>()
            .join("  ")
    );
    for r in &cells {
        println!("{}", line(r));
    }
    Ok(())
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
