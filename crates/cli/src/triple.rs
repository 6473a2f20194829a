//! `relight verify triple` and `relight bench triple`: flags → the
//! relight-triple rows → tables.

use crate::args::{BenchArgs, VerifyArgs};
use crate::commands::data_dir;
use crate::progress::Bar;
use crate::table::Report;
use anyhow::Result;
use glam::Vec3;
use relight_sphere::{EnvMap, Param};
use relight_triple::bench::{BenchOptions, bench_triple, place_on_floor};
use relight_triple::verify::{
    ErrorOptions, bump_rows, error_rows, figure6_rows, figure7_rows, identity_rows, medium_rows,
    storage_rows, wavelet_comparison_rows,
};
use std::sync::Arc;

/// The indoor and sun probes of `../shared/data/hdri` that exist (`indoor`
/// flag), or the embedded studio environment when none do.
fn probes(names: &[(&str, bool)]) -> Result<Vec<(String, EnvMap, bool)>> {
    let mut out = Vec::new();
    for &(name, indoor) in names {
        let p = data_dir().join(format!("hdri/{name}.exr"));
        if p.exists() {
            let (env, _) = relight_assets::load_env_map(&p)?;
            out.push((name.to_string(), env, indoor));
        } else {
            eprintln!("relight: {} not found; skipping that probe", p.display());
        }
    }
    if out.is_empty() {
        let env = EnvMap::from_fn(
            Param::LatLong {
                width: 256,
                height: 128,
            },
            |d: Vec3| relight_scene::studio_radiance(d),
        );
        out.push(("studio (embedded)".into(), env, false));
    }
    Ok(out)
}

fn cache_dir() -> std::path::PathBuf {
    relight_triple::cache::default_cache_dir()
}

/// `relight verify triple`.
pub fn verify(a: &VerifyArgs, report: &Report, bar: &Bar) -> Result<()> {
    report.table(
        "relight verify triple: exact identities",
        &identity_rows(a.quick),
        &[],
    )?;
    let list: &[(&str, bool)] = if a.quick {
        &[("hall", true)]
    } else {
        &[("hall", true), ("lobby", true), ("park", false)]
    };
    let probes = probes(list)?;
    let opts = ErrorOptions::new(a.quick, cache_dir());
    let rows = error_rows(&probes, &opts, bar)?;
    report.table(
        "relight verify triple: relative RMS error vs the reference with visibility (object pixels)",
        &rows,
        &[],
    )?;
    report.table(
        "relight verify triple: against the wavelet-rotation method (unshadowed, equal n)",
        &wavelet_comparison_rows(&probes, a.quick, cache_dir(), bar)?,
        &[],
    )?;
    let (name, env, _) = &probes[0];
    let points = if a.quick { 16 } else { 200 };
    let mut fig7 = figure7_rows(name, env, "phong:16", points)?;
    if !a.quick {
        fig7.extend(figure7_rows(name, env, "lambert:0.8", points)?);
    }
    report.table(
        "relight verify triple: Fig. 7, adaptive vs top-only selection at equal n",
        &fig7,
        &[],
    )?;
    report.table(
        "relight verify triple: Fig. 6, a visibility texture on a 2-triangle floor",
        &figure6_rows(env, a.quick, cache_dir(), bar)?,
        &[],
    )?;
    report.table(
        "relight verify triple: bump mapping (§3.3)",
        &bump_rows(env, a.quick, cache_dir(), bar)?,
        &[],
    )?;
    report.table(
        "relight verify triple: storage (what each compact table costs)",
        &storage_rows(env, a.quick, cache_dir(), bar)?,
        &[],
    )?;
    report.table(
        "relight verify triple: media (sun-thesis §3.6.5, the lighting convolved by the fog ball's kernel)",
        &medium_rows(env, a.quick, cache_dir(), bar)?,
        &[],
    )?;
    Ok(())
}

/// `relight bench triple`.
pub fn bench(a: &BenchArgs, report: &Report, bar: &Bar) -> Result<()> {
    let probes = probes(&[("hall", true)])?;
    let env = &probes[0].1;
    let opts = BenchOptions::new(a.quick, cache_dir());
    let targets: &[usize] = if a.quick { &[2_000] } else { &[25_000, 50_000] };
    let bunny = data_dir().join("mesh/bunny.obj");
    let mut meshes = Vec::new();
    for &t in targets {
        let m = if bunny.exists() {
            let (mesh, _) = relight_assets::load_mesh(&bunny)?;
            let mut m = mesh.refine_to_vertices(t);
            place_on_floor(&mut m);
            m
        } else {
            relight_triple::bench::sphere_mesh(t)
        };
        meshes.push(Arc::new(m));
    }
    let relight_triple::bench::BenchTables {
        frames,
        timings,
        storage,
    } = bench_triple(env, &meshes, &opts, bar)?;
    report.table(
        "relight bench triple: frames (per pixel, per-vertex visibility; FMA/bytes per shaded pixel)",
        &frames,
        &[],
    )?;
    report.table("relight bench triple: timings", &timings, &[])?;
    report.table(
        "relight bench triple: storage (compact, the default: lighting f16, BRDF 8-bit, judged; f32 beside)",
        &storage,
        &[],
    )
}
