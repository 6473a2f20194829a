//! `relight verify shexp`, `relight bench shexp`, `relight spheres fit` and
//! `relight sh log-table`: flags → `relight_shexp` → tables and files.

use crate::args::{BenchArgs, VerifyArgs};
use crate::table::Report;
use anyhow::{Context, Result, bail};
use clap::Subcommand;
use relight_shexp::spheres::{FitOptions, fit_spheres};
use std::path::PathBuf;
use std::time::Instant;

/// `relight spheres …`.
#[derive(Subcommand, Debug)]
pub enum SpheresCommand {
    /// Fit a set of bounding spheres (and their hierarchy) to a mesh and
    /// write it as JSON, for use as sphere/capsule shadow proxies.
    Fit {
        /// Mesh (OBJ, PLY, glTF), or the name of a built-in shape such as `sphere`.
        mesh: PathBuf,
        /// Leaf spheres (≥ 1).
        #[arg(long, default_value_t = 32)]
        spheres: usize,
        /// Output JSON file.
        #[arg(long)]
        out: PathBuf,
    },
}

/// `relight spheres fit`.
pub fn spheres(c: SpheresCommand) -> Result<()> {
    match c {
        SpheresCommand::Fit { mesh, spheres, out } => {
            if spheres == 0 {
                bail!("--spheres {spheres}: need at least one sphere");
            }
            crate::output::check_output(&out, "--out", &["json"])?;
            let (m, warnings) = relight_scene::load_mesh(&mesh.to_string_lossy())?;
            crate::output::warn_all(&warnings);
            let t = Instant::now();
            let set = fit_spheres(
                &m,
                &FitOptions {
                    spheres,
                    ..FitOptions::default()
                },
            )
            .with_context(|| format!("{}", mesh.display()))?;
            let secs = t.elapsed().as_secs_f64();
            let json = serde_json::to_vec_pretty(&set)?;
            relight_assets::write_atomic(&out, &json)?;
            eprintln!(
                "relight: {} spheres ({} hierarchy nodes, depth {}) fitted to {} triangles in {:.2} s → {}",
                set.spheres.len(),
                set.nodes.len(),
                set.depth(),
                m.indices.len(),
                secs,
                out.display()
            );
            Ok(())
        }
    }
}

/// One row of `relight sh log-table`.
#[derive(serde::Serialize)]
struct LogRow {
    theta_deg: f64,
    zonal: Vec<f64>,
}

/// `relight sh log-table --order N [--json]`: every 5° from 0° to 90°.
pub fn log_table(order: usize, json: bool) -> Result<()> {
    if !(1..=relight_sh::product::MAX_PRODUCT_ORDER).contains(&order) {
        bail!(
            "--order {order}: must be 1…{}",
            relight_sh::product::MAX_PRODUCT_ORDER
        );
    }
    let tp = relight_sh::product::TripleProduct::<f64>::new(order)?;
    let mut rows = Vec::new();
    for k in 0..=18 {
        let deg = 5.0 * f64::from(k);
        let z = relight_shexp::log_table::cap_log_zonal(
            &tp,
            deg.to_radians(),
            relight_shexp::DEFAULT_EIGEN_CLIP,
        )?;
        rows.push(LogRow {
            theta_deg: deg,
            zonal: z,
        });
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        println!(
            "# relight sh log-table: zonal log of cap visibility, order {order} (eigen-analysis log, ε = 0.02)"
        );
        for r in &rows {
            let z: Vec<String> = r.zonal.iter().map(|v| format!("{v:+.4}")).collect();
            println!("{:5.1}°  {}", r.theta_deg, z.join("  "));
        }
    }
    Ok(())
}

/// `relight verify shexp`.
pub fn verify(a: &VerifyArgs, report: &Report) -> Result<()> {
    let (sets, floor) = if a.quick { (20, 16) } else { (200, 40) };
    let mut rows = relight_shexp::verify::verify_math(4, sets)?;
    let bunny_path = crate::commands::data_dir().join("mesh/bunny.obj");
    let bunny = if bunny_path.exists() {
        Some(relight_assets::load_mesh(&bunny_path)?.0)
    } else {
        eprintln!(
            "relight: {} not found; the sphere-count curve is skipped",
            bunny_path.display()
        );
        None
    };
    rows.extend(relight_shexp::verify_scene::verify_scene(
        floor,
        bunny.as_ref(),
    )?);
    rows.extend(relight_shexp::bench::verify_culling()?);
    report.table("relight verify shexp", &rows, &[])?;
    Ok(())
}

/// `relight bench shexp`.
pub fn bench(a: &BenchArgs, report: &Report) -> Result<()> {
    let b = relight_shexp::bench::bench_shexp(a.quick)?;
    report.table(
        "relight bench shexp: Fig. 5.5, 60 blockers per receiver, log + PS*-2 vs products (1 thread)",
        &b.accumulation,
        &[],
    )?;
    report.table(
        "relight bench shexp: thesis-like scenes, per-vertex shadow work per frame",
        &b.scenes,
        &[],
    )?;
    report.table(
        "relight bench shexp: sphere fitting",
        std::slice::from_ref(&b.fit),
        &[],
    )?;
    Ok(())
}
