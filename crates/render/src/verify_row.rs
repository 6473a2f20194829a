//! One row of the area-light verify suites (`relight verify importance`,
//! `nearfield`, `nearfield-vertex`, `ltc`): a measured figure, what it
//! measures, and its target with the verdict.

use serde::Serialize;

/// One verify row.
#[derive(Clone, Debug, Serialize)]
pub struct VerifyRow {
    pub check: String,
    /// The measured figure (see `what`).
    pub value: f64,
    pub what: String,
    pub target: Option<String>,
    pub pass: Option<bool>,
    pub source: String,
}

/// A row of `value`; `target = (t, upper)` passes when `value ≤ t` (upper)
/// or `value ≥ t`, and `None` makes a report row.
#[must_use]
pub fn row(
    check: impl Into<String>,
    value: f64,
    what: &str,
    target: Option<(f64, bool)>,
    source: &str,
) -> VerifyRow {
    let (target, pass) = match target {
        Some((t, true)) => (Some(format!("≤ {t}")), Some(value <= t)),
        Some((t, false)) => (Some(format!("≥ {t}")), Some(value >= t)),
        None => (None, None),
    };
    VerifyRow {
        check: check.into(),
        value,
        what: what.into(),
        target,
        pass,
        source: source.into(),
    }
}
