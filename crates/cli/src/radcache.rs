//! `relight verify radiance-cache` and `relight bench radiance-cache`
//! (issue 16): flags → `relight_radcache::verify` → table.

use crate::plot::{Plot, PlotSpec};
use crate::progress::Bar;
use crate::table::Report;
use anyhow::{Context, Result, bail};
use relight_assets::{ToneMap, ToneOperator, write_png};
use relight_radcache::verify::{
    BenchSettings, FIG7_CHECK, VerifySettings, bench_radiance_cache, verify_radiance_cache,
};

/// The verify table; with `--plot DIR` also the Fig. 7 plot (difference
/// from the exact rotation by `a`, per method) and one false-colour
/// difference image per method. Exits non-zero when a row fails.
pub fn verify(quick: bool, report: &Report, bar: &Bar) -> Result<()> {
    let s = if quick {
        VerifySettings {
            width: 32,
            height: 24,
            reference_spp: 256,
            record_rays_side: 16,
            ..VerifySettings::default()
        }
    } else {
        VerifySettings::default()
    };
    let out = verify_radiance_cache(&s, bar)?;
    let fig7 = Plot::new(PlotSpec {
        name: "verify-radiance-cache-fig7",
        x: "error_a",
        y: "rel_rms",
        series: &["rotation"],
        log_y: true,
    })
    .titled("Fig. 7: indirect image vs the exact rotation's, by allowed error a")
    .labels(
        "allowed error a",
        "relative RMS difference from the exact rotation",
    )
    .only("check", FIG7_CHECK);
    report.table_plots("relight verify radiance-cache", &out.rows, &[fig7])?;
    if let Some(dir) = &report.plot_dir {
        crate::output::check_out_dir(dir, "--plot")?;
        for d in &out.fig7 {
            let path = dir.join(format!("{}.png", d.name));
            write_png(
                &path,
                d.image.width,
                d.image.height,
                &d.image.pixels,
                ToneMap {
                    operator: ToneOperator::Clamp,
                    ..ToneMap::default()
                },
            )
            .with_context(|| format!("--plot: {}", path.display()))?;
            eprintln!("relight: wrote {}", path.display());
        }
    }
    let failed: Vec<String> = out
        .rows
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
    eprintln!("verify radiance-cache: all {} rows pass", out.rows.len());
    Ok(())
}

/// Table 1: time per rotation by method at orders 6 and 10.
pub fn bench(quick: bool, report: &Report, bar: &Bar) -> Result<()> {
    let s = if quick {
        BenchSettings {
            width: 32,
            height: 24,
            orders: vec![6],
            error: 0.2,
            max_rotations: 20_000,
            min_rotations: 20_000,
            repeats: 1,
        }
    } else {
        BenchSettings {
            width: 160,
            height: 120,
            orders: vec![6, 10],
            error: 0.1,
            max_rotations: 1_000_000,
            min_rotations: 1_000_000,
            repeats: 3,
        }
    };
    let rows = bench_radiance_cache(&s, bar)?;
    report.table_plots(
        &format!(
            "relight bench radiance-cache (the paper's Table 1; times per single-channel rotation \
             including the ZYZ split / matrix build, as the paper's TPR = (RT − RT_ignore) / \
             (3 · rotations); paper_us: 2006 CPU; pass = 10× faster; kernels: {})",
            relight_sh::isa().name()
        ),
        &rows,
        &[],
    )?;
    Ok(())
}
