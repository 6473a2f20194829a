//! Printing rows of benchmark and accuracy figures as an aligned table or JSON.

use anyhow::Result;
use serde::Serialize;
use serde_json::Value;

/// Prints `rows` (flat serde structs) as an aligned text table, or as a JSON
/// array when `json` is set. Columns follow the first row's field order.
pub fn print_rows<T: Serialize>(title: &str, rows: &[T], json: bool) -> Result<()> {
    let values: Vec<Value> = rows
        .iter()
        .map(serde_json::to_value)
        .collect::<Result<_, _>>()?;
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
