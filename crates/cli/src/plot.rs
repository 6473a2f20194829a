//! SVG plots of benchmark and accuracy tables (`relight bench|verify … --plot DIR`).
//!
//! A [`PlotSpec`] names the columns of a table to draw: `x` and `y` are numeric
//! fields; rows are grouped into one line per distinct value of the `series`
//! fields (e.g. one line per rotation method). A [`Plot`] adds how it is
//! presented: its own title (default: the table's), axis labels, a logarithmic
//! x axis, and a filter that keeps the rows of one kind (`verify fog` draws
//! one plot per check, because each check's parameter means something else).
//!
//! # Reading a plot
//! - The legend stands in its own panel right of the data, never over it. It
//!   names each line by the series columns that differ between lines
//!   (`rotation=zyz`); columns equal for every line are stated once above it.
//! - Both axes carry at least two numbered ticks. Logarithmic axes tick at
//!   1-2-5 × 10ᵏ (or at whole decades over a wide range) and the range is
//!   widened to the ticks around the data, so a narrow range never shows a
//!   single label.
//! - When every line has one point at the same x (a `--quick` run measures one
//!   size), the plot is a bar chart, one bar per series, with that x in the
//!   axis label. Lines of one point among longer lines are drawn as markers.
//! - Rows where `x` or `y` is not a finite number (or not positive on a
//!   logarithmic axis) are left out of the plot, never out of the table. A
//!   plot with no point left is skipped with a message, not written empty.
//!
//! Text is written as SVG `<text>` elements, so no font file is needed.

use anyhow::Result;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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

/// A [`PlotSpec`] with its presentation. `Plot::from(spec)` takes the table's
/// title, the column names as axis labels, a linear x axis and every row.
#[derive(Clone, Copy, Debug)]
pub struct Plot<'a> {
    /// The columns drawn.
    pub spec: PlotSpec<'a>,
    /// The plot's title; `None`: the table's title.
    pub title: Option<&'a str>,
    /// Horizontal axis label; `None`: the `x` column's name.
    pub x_label: Option<&'a str>,
    /// Vertical axis label; `None`: the `y` column's name.
    pub y_label: Option<&'a str>,
    /// Logarithmic horizontal axis.
    pub log_x: bool,
    /// Only the rows whose column (first) prints as the value (second).
    pub only: Option<(&'a str, &'a str)>,
}

impl<'a> From<PlotSpec<'a>> for Plot<'a> {
    fn from(spec: PlotSpec<'a>) -> Self {
        Self::new(spec)
    }
}

impl<'a> Plot<'a> {
    /// The plot of `spec` with the defaults of the type docs.
    #[must_use]
    pub const fn new(spec: PlotSpec<'a>) -> Self {
        Self {
            spec,
            title: None,
            x_label: None,
            y_label: None,
            log_x: false,
            only: None,
        }
    }
    /// With its own title.
    #[must_use]
    pub const fn titled(mut self, title: &'a str) -> Self {
        self.title = Some(title);
        self
    }
    /// With axis labels (units included).
    #[must_use]
    pub const fn labels(mut self, x: &'a str, y: &'a str) -> Self {
        self.x_label = Some(x);
        self.y_label = Some(y);
        self
    }
    /// With a logarithmic horizontal axis.
    #[must_use]
    pub const fn log_x(mut self) -> Self {
        self.log_x = true;
        self
    }
    /// Only the rows whose `column` prints as `value`.
    #[must_use]
    pub const fn only(mut self, column: &'a str, value: &'a str) -> Self {
        self.only = Some((column, value));
        self
    }
}

/// One named line: its (x, y) points sorted by x.
type Series = (Vec<String>, Vec<(f64, f64)>);

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

/// Groups `rows` into the lines of `plot` (in order of first appearance);
/// each line is named by its values of the series columns.
fn collect_series(rows: &[Value], plot: &Plot) -> Vec<Series> {
    let spec = &plot.spec;
    let mut order: Vec<Vec<String>> = Vec::new();
    let mut points: BTreeMap<Vec<String>, Vec<(f64, f64)>> = BTreeMap::new();
    for row in rows {
        if let Some((col, value)) = plot.only
            && label(row.get(col)) != value
        {
            continue;
        }
        let (Some(x), Some(y)) = (number(row.get(spec.x)), number(row.get(spec.y))) else {
            continue;
        };
        if (spec.log_y && y <= 0.0) || (plot.log_x && x <= 0.0) {
            continue;
        }
        let key: Vec<String> = spec.series.iter().map(|s| label(row.get(*s))).collect();
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

/// The legend's names of `series`: the values of the series columns that
/// differ between lines (`column=value` when there are several columns),
/// less the words all lines share at the start; and the parts shared by all
/// lines (`column=value`, or `column: prefix…`), stated once.
fn legend_names(columns: &[&str], series: &[Series]) -> (Vec<String>, String) {
    let varies: Vec<bool> = (0..columns.len())
        .map(|c| series.iter().any(|s| s.0[c] != series[0].0[c]))
        .collect();
    // Per varying column: the common leading words of its values.
    let prefix: Vec<usize> = (0..columns.len())
        .map(|c| {
            if !varies[c] {
                return 0;
            }
            let first = &series[0].0[c];
            let mut n = series.iter().fold(first.len(), |n, s| {
                first
                    .bytes()
                    .zip(s.0[c].bytes())
                    .take(n)
                    .take_while(|(a, b)| a == b)
                    .count()
            });
            // Cut at a word boundary, and only when it saves real width.
            while n > 0 && !first.is_char_boundary(n) {
                n -= 1;
            }
            let cut = first[..n].rfind([' ', ',']).map_or(0, |i| i + 1);
            if cut >= 12 { cut } else { 0 }
        })
        .collect();
    let single = columns.len() == 1;
    let names = series
        .iter()
        .map(|(key, _)| {
            let parts: Vec<String> = (0..columns.len())
                .filter(|&c| varies[c])
                .map(|c| {
                    let v = &key[c][prefix[c]..];
                    if single {
                        v.to_string()
                    } else {
                        format!("{}={v}", columns[c])
                    }
                })
                .collect();
            if parts.is_empty() {
                key.join(" ")
            } else {
                parts.join(" ")
            }
        })
        .collect();
    let mut shared: Vec<String> = Vec::new();
    if let Some(first) = series.first()
        && series.len() > 1
    {
        for c in 0..columns.len() {
            if !varies[c] {
                shared.push(format!("{}={}", columns[c], first.0[c]));
            } else if prefix[c] > 0 {
                shared.push(format!(
                    "{}: {}…",
                    columns[c],
                    first.0[c][..prefix[c]].trim_end()
                ));
            }
        }
    }
    (names, shared.join(", "))
}

/// A number as a tick label: at most four significant digits, no trailing
/// zeros, exponent form outside [1e-3, 1e5).
#[must_use]
pub fn format_tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".into();
    }
    let trim = |s: String| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if (1e-3..1e5).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        trim(format!("{v:.decimals$}"))
    } else {
        let s = format!("{v:.3e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        format!("{}e{e}", trim(m.to_string()))
    }
}

/// A linear axis: the data range `[lo, hi]` widened to ticks at a 1-2-5 step
/// (about five of them); `from_zero` starts it at 0 when the data are positive.
fn linear_axis(mut lo: f64, mut hi: f64, from_zero: bool) -> (f64, f64, Vec<f64>) {
    if from_zero && lo > 0.0 {
        lo = 0.0;
    }
    if hi <= lo {
        let pad = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        (lo, hi) = (lo - pad, hi + pad);
        if from_zero && lo < 0.0 && hi > 0.0 && lo.abs() < hi {
            lo = 0.0;
        }
    }
    let raw = (hi - lo) / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let (a, b) = ((lo / step).floor(), (hi / step).ceil());
    let ticks = (a as i64..=b as i64).map(|k| k as f64 * step).collect();
    (a * step, b * step, ticks)
}

/// A logarithmic axis over positive data `[lo, hi]`, in log10 units: ticks
/// at 1-2-5 × 10ᵏ over at most ~2 decades, at decades (every few decades
/// over a wide range) otherwise; the range is widened to the ticks around
/// the data. Also returns the unlabelled minor ticks (2…9 × 10ᵏ).
fn log_axis(lo: f64, hi: f64) -> (f64, f64, Vec<f64>, Vec<f64>) {
    let (l0, l1) = (lo.log10(), hi.log10());
    let decades = l1 - l0;
    let mantissas: &[f64] = if decades <= 2.2 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let every = if decades > 16.0 {
        (decades / 8.0).ceil() as i64
    } else if decades > 8.0 {
        2
    } else {
        1
    };
    let mut candidates = Vec::new();
    for k in (l0.floor() as i64 - 1)..=(l1.ceil() as i64 + 1) {
        if k.rem_euclid(every) != 0 {
            continue;
        }
        for m in mantissas {
            candidates.push((m * 10f64.powi(k as i32)).log10());
        }
    }
    let eps = 1e-9;
    let below = candidates
        .iter()
        .copied()
        .filter(|t| *t <= l0 + eps)
        .fold(f64::NEG_INFINITY, f64::max);
    let above = candidates
        .iter()
        .copied()
        .filter(|t| *t >= l1 - eps)
        .fold(f64::INFINITY, f64::min);
    let (mut a, mut b) = (below, above);
    if b - a < eps {
        // One value on a tick: widen to the ticks either side.
        a = candidates
            .iter()
            .copied()
            .filter(|t| *t < a - eps)
            .fold(f64::NEG_INFINITY, f64::max);
        b = candidates
            .iter()
            .copied()
            .filter(|t| *t > b + eps)
            .fold(f64::INFINITY, f64::min);
    }
    let ticks: Vec<f64> = candidates
        .iter()
        .copied()
        .filter(|t| *t >= a - eps && *t <= b + eps)
        .collect();
    let minor = if every == 1 {
        (a.floor() as i64..=b.ceil() as i64)
            .flat_map(|k| (2..10).map(move |m| (f64::from(m) * 10f64.powi(k as i32)).log10()))
            .filter(|t| *t > a && *t < b && !ticks.iter().any(|x| (x - t).abs() < eps))
            .collect()
    } else {
        Vec::new()
    };
    (a, b, ticks, minor)
}

/// The axis of `values` (data units in, chart units out: log10 on a log
/// axis): range, labelled ticks and minor ticks in chart units.
struct Axis {
    range: (f64, f64),
    ticks: Vec<f64>,
    minor: Vec<f64>,
    log: bool,
}

impl Axis {
    fn new(lo: f64, hi: f64, log: bool, from_zero: bool) -> Self {
        if log {
            let (a, b, ticks, minor) = log_axis(lo, hi);
            Self {
                range: (a, b),
                ticks,
                minor,
                log,
            }
        } else {
            let (a, b, ticks) = linear_axis(lo, hi, from_zero);
            Self {
                range: (a, b),
                ticks,
                minor: Vec::new(),
                log,
            }
        }
    }
    /// A linear axis narrowed back to the data (a little padding), keeping
    /// the ticks inside it if at least two remain.
    fn fit(mut self, lo: f64, hi: f64) -> Self {
        if self.log || hi <= lo {
            return self;
        }
        let pad = 0.03 * (hi - lo);
        let (a, b) = (lo - pad, hi + pad);
        let inside: Vec<f64> = self
            .ticks
            .iter()
            .copied()
            .filter(|t| *t >= a && *t <= b)
            .collect();
        if inside.len() >= 2 {
            self.range = (a, b);
            self.ticks = inside;
        }
        self
    }
    fn to_chart(&self, v: f64) -> f64 {
        if self.log { v.log10() } else { v }
    }
    fn tick_label(&self, t: f64) -> String {
        if self.log {
            return format_tick(10f64.powf(t));
        }
        // One notation per linear axis: exponents when any tick needs one.
        let sci = self
            .ticks
            .iter()
            .any(|v| *v != 0.0 && !(1e-3..1e5).contains(&v.abs()));
        if sci && t != 0.0 {
            let s = format!("{t:.3e}");
            let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
            let m = m.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{e}")
        } else {
            format_tick(t)
        }
    }
}

/// An axis as plotters sees it: a linear range in chart units with exactly
/// our ticks (labelled) and minor ticks (light grid lines).
struct Ticked {
    range: (f64, f64),
    ticks: Vec<f64>,
    minor: Vec<f64>,
}

impl Ranged for Ticked {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;
    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let (a, b) = self.range;
        let t = (value - a) / (b - a);
        (f64::from(limit.0) + t * f64::from(limit.1 - limit.0)).round() as i32
    }
    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.ticks.clone()
        }
    }
    fn range(&self) -> std::ops::Range<f64> {
        self.range.0..self.range.1
    }
}

/// A plot drawn: the SVG and where its parts lie (pixels; the layout is
/// read by the tests, which check it against the SVG itself).
#[derive(Debug)]
#[cfg_attr(not(test), allow(dead_code))]
pub struct Drawn {
    /// The SVG document.
    pub svg: String,
    /// The data area `(x0, y0, x1, y1)`.
    pub plot_area: (i32, i32, i32, i32),
    /// The legend panel `(x0, y0, x1, y1)`, if the plot has more than one series.
    pub legend: Option<(i32, i32, i32, i32)>,
    /// The labels of the x and y ticks.
    pub x_ticks: Vec<String>,
    pub y_ticks: Vec<String>,
    /// Drawn as one bar per series (every series is one point at one x).
    pub bars: bool,
}

/// Why a plot was not drawn.
#[derive(Debug)]
pub struct Skipped(pub String);

const WIDTH: u32 = 900;
const LEGEND_FONT: u32 = 13;
const LEGEND_ROW: i32 = 18;
const MAX_LEGEND_CHARS: usize = 60;
/// Bars are labelled by their series names up to this length.
const BAR_NAME_CHARS: usize = 14;

fn legend_text(s: &str) -> String {
    if s.chars().count() > MAX_LEGEND_CHARS {
        let t: String = s.chars().take(MAX_LEGEND_CHARS - 1).collect();
        format!("{t}…")
    } else {
        s.to_string()
    }
}

/// Renders the plot of `rows` (JSON objects, as the tables print them) with
/// the table's `title` (used when the plot has none).
///
/// # Errors
/// [`Skipped`] when no row gives a point, or when drawing fails.
pub fn render_svg(title: &str, rows: &[Value], plot: &Plot) -> std::result::Result<Drawn, Skipped> {
    let spec = &plot.spec;
    let series = collect_series(rows, plot);
    let all: Vec<(f64, f64)> = series.iter().flat_map(|(_, p)| p.iter().copied()).collect();
    if all.is_empty() {
        let filter = plot
            .only
            .map_or(String::new(), |(c, v)| format!(" with {c} = {v}"));
        let positive = if spec.log_y {
            " (positive, log axis)"
        } else {
            ""
        };
        return Err(Skipped(format!(
            "no row{filter} has numeric `{}` and `{}`{positive}",
            spec.x, spec.y
        )));
    }
    let bars = series.iter().all(|s| s.1.len() == 1)
        && all.iter().all(|p| p.0 == all[0].0)
        && !spec.series.is_empty();
    let (names, shared) = legend_names(spec.series, &series);
    let title = plot.title.unwrap_or(title);
    let x_name = plot.x_label.unwrap_or(spec.x);
    let y_name = plot.y_label.unwrap_or(spec.y);
    let y_desc = if spec.log_y {
        format!("{y_name} (log scale)")
    } else {
        y_name.to_string()
    };

    // Layout: chart on the left, the legend panel (if any) on the right.
    let show_legend = names.len() > 1 || bars;
    let legend_chars = names
        .iter()
        .map(|n| legend_text(n).chars().count() + if bars { 4 } else { 0 })
        .chain([legend_text(&shared).chars().count()])
        .max()
        .unwrap_or(0);
    let legend_w = if show_legend {
        (legend_chars as u32 * 7 + 48).clamp(140, 480)
    } else {
        0
    };
    let height = (100 + LEGEND_ROW * (names.len() as i32 + 2)).max(560) as u32;
    let total_w = WIDTH + legend_w;

    let y_vals = all.iter().map(|p| p.1);
    let (ylo, yhi) = y_vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    let y_axis = Axis::new(ylo, yhi, spec.log_y, true);
    let x_axis = if bars {
        None
    } else {
        let (xlo, xhi) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.0), b.max(p.0))
            });
        Some(Axis::new(xlo, xhi, plot.log_x, false).fit(xlo, xhi))
    };
    let y_ticks: Vec<String> = y_axis.ticks.iter().map(|t| y_axis.tick_label(*t)).collect();
    let mut plot_area = (0, 0, 0, 0);
    let mut legend = None;
    let short_names = names.iter().all(|n| n.chars().count() <= BAR_NAME_CHARS);
    let bar_label = |i: usize| {
        if short_names {
            names.get(i).cloned().unwrap_or_default()
        } else {
            format!("#{}", i + 1)
        }
    };
    let mut svg = String::new();
    let draw = |svg: &mut String,
                plot_area: &mut (i32, i32, i32, i32),
                legend: &mut Option<(i32, i32, i32, i32)>,
                x_ticks: &mut Vec<String>|
     -> Result<()> {
        let root = SVGBackend::with_string(svg, (total_w, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let (left, right) = root.split_horizontally(WIDTH);
        let mut builder = ChartBuilder::on(&left);
        builder
            .caption(title, ("sans-serif", 18))
            .margin(14)
            .x_label_area_size(48)
            .y_label_area_size(78);
        let (ya, yb) = y_axis.range;
        let y_range = Ticked {
            range: (ya, yb),
            ticks: y_axis.ticks.clone(),
            minor: y_axis.minor.clone(),
        };
        let colour = |i: usize| Palette99::pick(i).to_rgba();
        if let Some(xa) = &x_axis {
            let x_range = Ticked {
                range: xa.range,
                ticks: xa.ticks.clone(),
                minor: xa.minor.clone(),
            };
            *x_ticks = xa.ticks.iter().map(|t| xa.tick_label(*t)).collect();
            let mut chart = builder.build_cartesian_2d(x_range, y_range)?;
            let x_desc = if xa.log {
                format!("{x_name} (log scale)")
            } else {
                x_name.to_string()
            };
            let xf = |v: &f64| xa.tick_label(*v);
            let yf = |v: &f64| y_axis.tick_label(*v);
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .y_desc(&y_desc)
                .x_label_formatter(&xf)
                .y_label_formatter(&yf)
                .label_style(("sans-serif", 13))
                .draw()?;
            for (i, (_, points)) in series.iter().enumerate() {
                let c = colour(i);
                let pts: Vec<(f64, f64)> = points
                    .iter()
                    .map(|&(x, y)| (xa.to_chart(x), y_axis.to_chart(y)))
                    .collect();
                if pts.len() > 1 {
                    chart.draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))?;
                }
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
            }
            let (xr, yr) = chart.plotting_area().get_pixel_range();
            *plot_area = (xr.start, yr.start, xr.end, yr.end);
        } else {
            // Bars: one per series at x = 0, 1, …; labelled by name when
            // the names are short, else by number (#k in the legend).
            let n = series.len();
            let keys: Vec<f64> = (0..n).map(|i| i as f64).collect();
            *x_ticks = (0..n).map(&bar_label).collect();
            let x_range = Ticked {
                range: (-0.6, n as f64 - 0.4),
                ticks: keys,
                minor: Vec::new(),
            };
            let mut chart = builder.build_cartesian_2d(x_range, y_range)?;
            let x_desc = format!(
                "{}, at {x_name} = {}",
                spec.series.join(", "),
                format_tick(all[0].0)
            );
            let xf = |v: &f64| bar_label(v.round().max(0.0) as usize);
            let yf = |v: &f64| y_axis.tick_label(*v);
            chart
                .configure_mesh()
                .disable_x_mesh()
                .x_desc(x_desc)
                .y_desc(&y_desc)
                .x_label_formatter(&xf)
                .y_label_formatter(&yf)
                .label_style(("sans-serif", 13))
                .draw()?;
            for (i, (_, points)) in series.iter().enumerate() {
                let y = y_axis.to_chart(points[0].1);
                let x = i as f64;
                chart.draw_series([Rectangle::new(
                    [(x - 0.35, ya), (x + 0.35, y)],
                    colour(i).filled(),
                )])?;
            }
            let (xr, yr) = chart.plotting_area().get_pixel_range();
            *plot_area = (xr.start, yr.start, xr.end, yr.end);
        }
        if show_legend {
            let (rx, _) = right.get_pixel_range();
            let x0 = rx.start + 8;
            let mut y = plot_area.1 + 4;
            let font = ("sans-serif", LEGEND_FONT)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center));
            let header = if spec.series.is_empty() {
                "series".to_string()
            } else {
                spec.series.join(", ")
            };
            let top = y - 4;
            right.draw(&Text::new(header, (x0 - rx.start, y + 6), font.clone()))?;
            y += LEGEND_ROW;
            if !shared.is_empty() {
                right.draw(&Text::new(
                    legend_text(&format!("all: {shared}")),
                    (x0 - rx.start, y + 6),
                    font.clone(),
                ))?;
                y += LEGEND_ROW;
            }
            for (i, n) in names.iter().enumerate() {
                let c = colour(i);
                let yy = y + 6;
                let lx = x0 - rx.start;
                right.draw(&PathElement::new(
                    [(lx, yy), (lx + 18, yy)],
                    c.stroke_width(3),
                ))?;
                let text = if bars && !short_names {
                    format!("#{} {}", i + 1, legend_text(n))
                } else {
                    legend_text(n)
                };
                right.draw(&Text::new(text, (lx + 24, yy), font.clone()))?;
                y += LEGEND_ROW;
            }
            let bottom = y + 2;
            let (rx1, _) = right.get_pixel_range();
            right.draw(&Rectangle::new(
                [(2, top), (rx1.end - rx1.start - 8, bottom)],
                BLACK.stroke_width(1),
            ))?;
            *legend = Some((rx1.start + 2, top, rx1.end - 8, bottom));
        }
        root.present()?;
        Ok(())
    };
    let mut xt = Vec::new();
    draw(&mut svg, &mut plot_area, &mut legend, &mut xt)
        .map_err(|e| Skipped(format!("drawing failed: {e}")))?;
    Ok(Drawn {
        svg,
        plot_area,
        legend,
        x_ticks: xt,
        y_ticks,
        bars,
    })
}

/// Writes the plot of `rows` to `dir/<name>.svg` (atomically) and returns
/// the path written, or `None` after printing why the plot was skipped.
///
/// # Errors
/// Creating `dir` or writing the file.
pub fn write_plot(dir: &Path, title: &str, rows: &[Value], plot: &Plot) -> Result<Option<PathBuf>> {
    let drawn = match render_svg(title, rows, plot) {
        Ok(d) => d,
        Err(Skipped(why)) => {
            eprintln!("relight: plot {} skipped: {why}", plot.spec.name);
            return Ok(None);
        }
    };
    crate::output::check_out_dir(dir, "--plot")?;
    let path = dir.join(format!("{}.svg", plot.spec.name));
    relight_assets::write_atomic(&path, drawn.svg.as_bytes())?;
    Ok(Some(path))
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

    fn spec(log_y: bool) -> PlotSpec<'static> {
        PlotSpec {
            name: "t",
            x: "order",
            y: "ns",
            series: &["method"],
            log_y,
        }
    }

    /// `(x, text)` of every `<text>` element of `svg` (text unescaped only
    /// as far as the tests need).
    fn texts(svg: &str) -> Vec<(f64, f64, String)> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let attr = |name: &str| -> Option<f64> {
                    let s = t.split(&format!(" {name}=\"")).nth(1)?;
                    s.split('"').next()?.parse().ok()
                };
                let body = t
                    .split_once('>')?
                    .1
                    .split("</text>")
                    .next()?
                    .trim()
                    .to_string();
                Some((attr("x")?, attr("y")?, body))
            })
            .collect()
    }

    #[test]
    fn series_group_by_column_and_sort_by_x() {
        let plot = Plot::new(spec(true));
        let s = collect_series(&rows(), &plot);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].0, vec!["zyz".to_string()]);
        assert_eq!(s[1].1, vec![(3.0, 10.0), (6.0, 20.0)]);
        let only = Plot::new(spec(true)).only("method", "taylor");
        assert_eq!(collect_series(&rows(), &only).len(), 1);
    }

    #[test]
    fn svg_names_every_series_and_axis() {
        for log_y in [false, true] {
            let d = render_svg("timings", &rows(), &Plot::new(spec(log_y))).unwrap();
            assert!(d.svg.starts_with("<svg"), "{}", &d.svg[..40]);
            let drawn: Vec<String> = texts(&d.svg).into_iter().map(|t| t.2).collect();
            for text in ["timings", "zyz", "taylor", "order"] {
                assert!(drawn.iter().any(|t| t == text), "{text} missing: {drawn:?}");
            }
            assert!(drawn.iter().any(|t| t.starts_with("ns")), "{drawn:?}");
        }
    }

    /// Every axis has at least two numbered ticks, each drawn as text,
    /// including narrow ranges on a log axis (once a single `1.000e0`).
    #[test]
    fn at_least_two_tick_labels_per_axis() {
        let narrow = vec![
            json!({"s": "a", "x": 3, "e": 0.31}),
            json!({"s": "a", "x": 10, "e": 0.45}),
            json!({"s": "b", "x": 3, "e": 0.52}),
            json!({"s": "b", "x": 10, "e": 0.6}),
        ];
        let wide = vec![
            json!({"s": "a", "x": 128, "e": 1e-7}),
            json!({"s": "a", "x": 2048, "e": 0.2}),
        ];
        for (data, log_x) in [(&narrow, false), (&wide, true), (&rows(), false)] {
            for log_y in [false, true] {
                let (x, y) = if data.len() == 5 {
                    ("order", "ns")
                } else {
                    ("x", "e")
                };
                let mut plot = Plot::new(PlotSpec {
                    name: "t",
                    x,
                    y,
                    series: &["s"],
                    log_y,
                });
                if log_x {
                    plot = plot.log_x();
                }
                let d = render_svg("t", data, &plot).unwrap();
                let drawn: Vec<String> = texts(&d.svg).into_iter().map(|t| t.2).collect();
                for (axis, ticks) in [("x", &d.x_ticks), ("y", &d.y_ticks)] {
                    assert!(ticks.len() >= 2, "{axis} ticks {ticks:?} (log_y {log_y})");
                    for t in ticks.iter() {
                        assert!(drawn.contains(t), "{axis} tick {t} not drawn: {drawn:?}");
                    }
                }
            }
        }
    }

    /// The legend panel lies right of the data area, and every series name
    /// is drawn inside it.
    #[test]
    fn legend_lies_outside_the_data_area() {
        let d = render_svg("t", &rows(), &Plot::new(spec(true))).unwrap();
        let (px0, py0, px1, py1) = d.plot_area;
        let (lx0, ly0, lx1, ly1) = d.legend.expect("two series have a legend");
        assert!(px1 > px0 && py1 > py0 && lx1 > lx0 && ly1 > ly0);
        assert!(
            lx0 >= px1,
            "legend {:?} overlaps data {:?}",
            d.legend,
            d.plot_area
        );
        for name in ["zyz", "taylor"] {
            let (x, y, _) = texts(&d.svg)
                .into_iter()
                .find(|t| t.2 == name)
                .unwrap_or_else(|| panic!("{name} not drawn"));
            assert!(
                x >= f64::from(lx0)
                    && x <= f64::from(lx1)
                    && y >= f64::from(ly0)
                    && y <= f64::from(ly1),
                "{name} at ({x}, {y}) outside the legend {:?}",
                d.legend
            );
        }
    }

    /// A quick run (every series one point at one x) is a bar chart with a
    /// real y axis, not a dot in an empty frame; one point alone too.
    #[test]
    fn one_point_series_are_bars() {
        let quick = vec![
            json!({"n": 32, "terms": 256, "err": 0.18}),
            json!({"n": 64, "terms": 256, "err": 0.16}),
        ];
        let plot = Plot::new(PlotSpec {
            name: "t",
            x: "terms",
            y: "err",
            series: &["n"],
            log_y: true,
        });
        let d = render_svg("t", &quick, &plot).unwrap();
        assert!(d.bars);
        assert_eq!(d.x_ticks, ["32", "64"], "short names label the bars");
        assert!(d.y_ticks.len() >= 2, "{:?}", d.y_ticks);
        assert!(d.svg.contains("at terms = 256"), "the x value is stated");
        assert!(
            d.svg.matches("<rect").count() > 2,
            "two bars and the background"
        );
        let single = render_svg("t", &quick[..1], &plot).unwrap();
        assert!(single.bars && single.y_ticks.len() >= 2, "{single:?}");
    }

    #[test]
    fn a_table_without_numbers_is_skipped_with_a_reason() {
        let plot = Plot::new(PlotSpec {
            name: "t",
            x: "order",
            y: "missing",
            series: &[],
            log_y: false,
        });
        let Skipped(why) = render_svg("x", &rows(), &plot).unwrap_err();
        assert!(why.contains("missing"), "{why}");
    }

    /// Long series values lose the words every line shares (stated once
    /// instead), so truncation never hides what tells lines apart.
    #[test]
    fn legend_drops_shared_prefixes() {
        let key = |a: &str, b: &str| (vec![a.to_string(), b.to_string()], vec![(0.0, 1.0)]);
        let series = vec![
            key("uv-sphere 65K tris + floor, environment", "false"),
            key("uv-sphere 65K tris + floor, environment", "true"),
            key("uv-sphere 65K tris + floor, + fog ball", "true"),
        ];
        let (names, shared) = legend_names(&["scene", "visibility"], &series);
        assert_eq!(names[0], "scene=environment visibility=false");
        assert_eq!(names[2], "scene=+ fog ball visibility=true");
        assert_eq!(shared, "scene: uv-sphere 65K tris + floor,…");
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(format_tick(0.2), "0.2");
        assert_eq!(format_tick(10f64.powf(0.2f64.log10())), "0.2");
        assert_eq!(format_tick(1500.0), "1500");
        assert_eq!(format_tick(2e-5), "2e-5");
        assert_eq!(format_tick(1e7), "1e7");
        assert_eq!(format_tick(3.0), "3");
        assert_eq!(format_tick(0.0), "0");
    }

    #[test]
    fn log_axis_widens_to_ticks_around_the_data() {
        let (a, b, ticks, _) = log_axis(0.31, 0.6);
        assert!(a <= 0.31f64.log10() && b >= 0.6f64.log10());
        assert!(ticks.len() >= 2, "{ticks:?}");
        let (_, _, ticks, _) = log_axis(0.2, 0.2);
        assert!(ticks.len() >= 2, "{ticks:?}");
        let (_, _, ticks, _) = log_axis(1e-7, 1e12);
        assert!((2..=12).contains(&ticks.len()), "{ticks:?}");
    }
}
