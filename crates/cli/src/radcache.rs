//! `relight verify radiance-cache` and `relight bench radiance-cache`
//! (issue 16): flags → `relight_radcache::verify` → table.

use crate::progress::Bar;
use crate::table::Report;
use anyhow::{Result, bail};
use relight_radcache::verify::{VerifySettings, bench_radiance_cache, verify_radiance_cache};

/// The verify table; exits non-zero when a row fails.
pub fn verify(quick: bool, report: &Report, bar: &Bar) -> Result<()> {
    let s = if quick {
        VerifySettings {
            width: 32,
            height: 24,
            reference_spp: 256,
            ..VerifySettings::default()
        }
    } else {
        VerifySettings::default()
    };
    let rows = verify_radiance_cache(&s, bar)?;
    report.table_plots("relight verify radiance-cache", &rows, &[])?;
    let failed: Vec<String> = rows
        .iter()
        .filter(|r| !r.pass)
        .map(|r| format!("{} ({}, a {})", r.check, r.rotation, r.error_a))
        .collect();
    if !failed.is_empty() {
        bail!(
            "verify radiance-cache: {} row(s) failed: {}",
            failed.len(),
            failed.join("; ")
        );
    }
    eprintln!("verify radiance-cache: all {} rows pass", rows.len());
    Ok(())
}

/// Table 1: time per rotation by method at orders 6 and 10.
pub fn bench(quick: bool, report: &Report, bar: &Bar) -> Result<()> {
    let rows = if quick {
        bench_radiance_cache(32, 24, &[6], 0.2, 20_000, 20_000, bar)?
    } else {
        bench_radiance_cache(160, 120, &[6, 10], 0.1, 1_000_000, 1_000_000, bar)?
    };
    report.table_plots(
        "relight bench radiance-cache (the paper's Table 1: 2006 CPU figures in paper_us; pass = 10× faster)",
        &rows,
        &[],
    )?;
    Ok(())
}
