//! `relight verify ltc`: the LTC baseline's fit and images (issue 13).

use crate::args::VerifyArgs;
use crate::progress::Bar;
use crate::table::Report;
use anyhow::{Result, anyhow, bail};
use relight_ltc::verify::{VerifyOptions, verify_rows};

/// `relight verify ltc`.
pub fn verify(a: &VerifyArgs, report: &Report, bar: &Bar) -> Result<()> {
    let rows = verify_rows(&VerifyOptions::new(a.quick), bar).map_err(|e| anyhow!(e))?;
    let v = report.table_verdicts(
        "relight verify ltc (the fitted table; ltc and nearfield against the reference)",
        &rows,
        &[],
    )?;
    if let Some(v) = v
        && v.fail > 0
    {
        bail!(
            "verify ltc: {} of {} gated rows fail",
            v.fail,
            v.fail + v.pass
        );
    }
    Ok(())
}
