//! SVG plots of benchmark and accuracy tables (`relight bench|verify … --plot DIR`).
//!
//! A [`PlotSpec`] names the columns of a table to draw: `x` and `y` are numeric
//! fields; rows are grouped into one line per distinct value of the `series`
//! fields (e.g. one line per rotation method). Rows where `x` or `y` is not a
//! finite number (or `y ≤ 0` on a logarithmic axis) are left out of the plot,
//! never out of the table. Text is written as SVG `<text>` elements, so no
//! font file is needed.

use anyhow::{Context, Result, bail};
use plotters::prelude::*;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// Which columns of a table to plot, and how.
#[derive(Clone, Copy, Debug)]
pub struct PlotSpec<'a> {
    /// Short file name (without extension) of the plot, e.g. `"bench-sh"`.
    pub name: &'a str,
    /// Numeric column on the horizontal axis.
    pub x: &'a str,
    /// Numeric column on the vertical axis.
    pub y: &'a str,
    /// Columns whose values, joined, name one line of the plot.
    pub series: &'a [&'a str],
    /// Logarithmic vertical axis (for timings and errors spanning decades).
    pub log_y: bool,
}

/// One named line: its (x, y) points sorted by x.
type Series = (String, Vec<(f64, f64)>);

fn number(v: Option<&Value>) -> Option<f64> {
    v.and_then(Value::as_f64).filter(|x| x.is_finite())
}

fn label(v: Option<&Value>) -> String {
    match v {
        Some(Value::String(s)) => s.clone(),
        Some(Value::Null) | None => "-".into(),
        Some(other) => other.to_string(),
    }
}

/// Groups `rows` into the lines of `spec` (in order of first appearance).
fn collect_series(rows: &[Value], spec: &PlotSpec) -> Vec<Series> {
    let mut order: Vec<String> = Vec::new();
    let mut points: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for row in rows {
        let (Some(x), Some(y)) = (number(row.get(spec.x)), number(row.get(spec.y))) else {
            continue;
        };
        if spec.log_y && y <= 0.0 {
            continue;
        }
        let key = spec
            .series
            .iter()
            .map(|s| label(row.get(*s)))
            .collect::<Vec<_>>()
            .join(" ");
        if !points.contains_key(&key) {
            order.push(key.clone());
        }
        points.entry(key).or_default().push((x, y));
    }
    order
        .into_iter()
        .map(|k| {
            let mut p = points.remove(&k).unwrap_or_default();
            p.sort_by(|a, b| a.0.total_cmp(&b.0));
            (k, p)
        })
        .collect()
}

/// Renders the plot of `rows` (JSON objects, as the tables print them) to an
/// SVG string.
pub fn render_svg(title: &str, rows: &[Value], spec: &PlotSpec) -> Result<String> {
    let series = collect_series(rows, spec);
    let all: Vec<(f64, f64)> = series.iter().flat_map(|(_, p)| p.iter().copied()).collect();
    if all.is_empty() {
        bail!(
            "plot {}: no row has numeric `{}` and `{}`",
            spec.name,
            spec.x,
            spec.y
        );
    }
    let (mut x0, mut x1) = all
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    let (mut y0, mut y1) = all
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    if x1 <= x0 {
        (x0, x1) = (x0 - 0.5, x1 + 0.5);
    }
    if spec.log_y {
        (y0, y1) = (y0 / 1.5, y1 * 1.5);
    } else {
        let pad = if y1 > y0 { 0.05 * (y1 - y0) } else { 0.5 };
        (y0, y1) = (y0.min(0.0), y1 + pad);
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 560)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(72);
        if spec.log_y {
            let mut chart = builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale())?;
            chart
                .configure_mesh()
                .x_desc(spec.x)
                .y_desc(spec.y)
                .y_label_formatter(&|v| format!("{v:.3e}"))
                .draw()?;
            draw_lines(&mut chart, &series)?;
        } else {
            let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1)?;
            chart
                .configure_mesh()
                .x_desc(spec.x)
                .y_desc(spec.y)
                .draw()?;
            draw_lines(&mut chart, &series)?;
        }
        root.present()?;
    }
    Ok(svg)
}

fn draw_lines<'a, DB, CT>(chart: &mut ChartContext<'a, DB, CT>, series: &[Series]) -> Result<()>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: CoordTranslate<From = (f64, f64)>,
{
    for (i, (name, points)) in series.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                colour.stroke_width(2),
            ))
            .map_err(|e| anyhow::anyhow!("{e}"))?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(())
}

/// Writes the plot of `rows` to `dir/<spec.name>.svg` (atomically) and
/// returns the path written.
pub fn write_plot(
    dir: &Path,
    title: &str,
    rows: &[Value],
    spec: &PlotSpec,
) -> Result<std::path::PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let path = dir.join(format!("{}.svg", spec.name));
    let svg = render_svg(title, rows, spec)?;
    relight_assets::write_atomic(&path, svg.as_bytes())?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn rows() -> Vec<Value> {
        vec![
            json!({"method": "zyz", "order": 3, "ns": 40.0}),
            json!({"method": "zyz", "order": 6, "ns": 90.0}),
            json!({"method": "taylor", "order": 6, "ns": 20.0}),
            json!({"method": "taylor", "order": 3, "ns": 10.0}),
            json!({"method": "taylor", "order": 9, "ns": null}),
        ]
    }

    #[test]
    fn series_group_by_column_and_sort_by_x() {
        let spec = PlotSpec {
            name: "t",
            x: "order",
            y: "ns",
            series: &["method"],
            log_y: true,
        };
        let s = collect_series(&rows(), &spec);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].0, "zyz");
        assert_eq!(s[1].1, vec![(3.0, 10.0), (6.0, 20.0)]);
    }

    #[test]
    fn svg_names_every_series_and_axis() {
        for log_y in [false, true] {
            let spec = PlotSpec {
                name: "t",
                x: "order",
                y: "ns",
                series: &["method"],
                log_y,
            };
            let svg = render_svg("timings", &rows(), &spec).unwrap();
            assert!(svg.starts_with("<svg"), "{}", &svg[..40]);
            for text in ["timings", "zyz", "taylor", "order", "ns"] {
                assert!(svg.contains(text), "{text} missing from the plot");
            }
        }
    }

    #[test]
    fn a_table_without_numbers_is_an_error() {
        let spec = PlotSpec {
            name: "t",
            x: "order",
            y: "missing",
            series: &[],
            log_y: false,
        };
        let e = render_svg("x", &rows(), &spec).unwrap_err().to_string();
        assert!(e.contains("missing"), "{e}");
    }
}
