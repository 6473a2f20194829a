//! `relight verify nearfield`, `relight bench nearfield`, `relight bake
//! nearfield` and the nearfield method's flags: flags → relight-nearfield →
//! tables.

use crate::args::{BenchArgs, MethodFlags, SceneArgs, VerifyArgs};
use crate::output::{check_output, warn_all};
use crate::plot::{Plot, PlotSpec};
use crate::progress::Bar;
use crate::scene_args::build_scene;
use crate::table::Report;
use anyhow::{Result, anyhow, bail};
use relight_nearfield::bench::{BenchOptions, bench_nearfield};
use relight_nearfield::verify::{VerifyOptions, verify_rows};
use relight_nearfield::{NearfieldMethod, NearfieldOptions};
use relight_render::method::Relighter;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Applies `--order`, `--face`, `--source-terms`, `--source-ranking`,
/// `--target-terms` (ranges are checked by the method) and `--cache`.
///
/// # Errors
/// An unknown `--source-ranking`, naming the flag.
pub fn apply_flags(o: &mut NearfieldOptions, f: &MethodFlags) -> Result<()> {
    if let Some(n) = f.order {
        o.order = n;
    }
    if let Some(s) = f.face {
        o.face = s;
    }
    if let Some(s) = f.source_terms {
        o.source_terms = s;
    }
    if let Some(r) = &f.source_ranking {
        o.source_ranking = r.parse().map_err(|e| anyhow!("--source-ranking: {e}"))?;
    }
    if let Some(t) = f.target_terms {
        o.target_terms = t;
    }
    if let Some(r) = crate::method_args::refine_coarse(f)? {
        o.refine_coarse = r;
    }
    // The CLI keeps transport bakes: `--cache DIR`, else $RELIGHT_CACHE/nearfield
    // (`relight cache list`).
    o.cache_dir = Some(cache_dir(f.cache.as_deref()));
    Ok(())
}

/// The transport cache folder: `dir`, else
/// [`relight_nearfield::cache::default_cache_dir`].
fn cache_dir(dir: Option<&Path>) -> PathBuf {
    dir.map_or_else(
        relight_nearfield::cache::default_cache_dir,
        Path::to_path_buf,
    )
}

/// `relight bake nearfield SCENE [scene flags] [--order N] [--face S] [--out FILE]`:
/// the transport of the scene as `render --method nearfield` would prepare
/// it (the pose at `--time`), baked or loaded into the cache, and with
/// `--out` also written to FILE.
pub fn bake(
    a: &SceneArgs,
    order: Option<usize>,
    face: Option<f64>,
    cache: Option<&Path>,
    out: Option<&Path>,
    bar: &Bar,
) -> Result<()> {
    if let Some(o) = out {
        check_output(o, "--out", &[])?;
    }
    if let Some(c) = cache {
        crate::output::check_out_dir(c, "--cache")?;
    }
    let t = Instant::now();
    let built = build_scene(a, None)?;
    let scene = built.scene.at_time(built.time);
    let mut o = NearfieldOptions {
        cache_dir: Some(cache_dir(cache)),
        ..NearfieldOptions::default()
    };
    if let Some(n) = order {
        o.order = n;
    }
    if let Some(f) = face {
        o.face = f;
    }
    let mut m = NearfieldMethod::new(o.clone())?;
    m.bake_scene(&scene, bar)?;
    warn_all(&m.warnings());
    let vertices: usize = scene.objects.iter().map(|o| o.mesh.positions.len()).sum();
    let bytes = m.data_bytes();
    let how = if m.loads() > 0 {
        "loaded from the cache"
    } else {
        "baked"
    };
    let paths = m.cache_paths();
    let cached = if paths.is_empty() {
        "-".to_string()
    } else {
        paths
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let written = match out {
        Some(path) => m.save_bakes(path)?,
        None => Vec::new(),
    };
    println!(
        "relight bake nearfield: {vertices} vertices in {} objects, {} light plane(s), order {}, face {}, {}: {how} in {:.1} s, {:.1} MB, cached as {cached}{}",
        scene.objects.len(),
        m.planes(),
        o.order,
        o.face,
        if scene.visibility {
            "shadows"
        } else {
            "unshadowed"
        },
        t.elapsed().as_secs_f64(),
        bytes as f64 / 1e6,
        if written.is_empty() {
            String::new()
        } else {
            format!(
                ", wrote {}",
                written
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }
    );
    Ok(())
}

/// `relight verify nearfield` (`per_vertex_only`: `nearfield-vertex`, the
/// rows before the reference render): fails (exit 1) when any gated row
/// fails.
pub fn verify(a: &VerifyArgs, report: &Report, bar: &Bar, per_vertex_only: bool) -> Result<()> {
    let opts = VerifyOptions {
        per_vertex_only,
        ..VerifyOptions::new(a.quick)
    };
    let rows = verify_rows(&opts, bar).map_err(|e| anyhow!(e))?;
    let v = report.table_verdicts(
        "relight verify nearfield (floor + sphere under a textured ceiling light)",
        &rows,
        &[],
    )?;
    if let Some(v) = v
        && v.fail > 0
    {
        bail!(
            "verify nearfield: {} of {} gated rows fail",
            v.fail,
            v.fail + v.pass
        );
    }
    Ok(())
}

/// `relight bench nearfield`: Fig. 4.11's table and the bake.
pub fn bench(a: &BenchArgs, report: &Report, bar: &Bar) -> Result<()> {
    let opts = BenchOptions::new(a.quick, relight_viewer::bench::MACHINE_GFMA);
    let b = bench_nearfield(&opts, bar)?;
    report.table_plots(
        &format!(
            "relight bench nearfield: Fig. 4.11 (order 32, face 4, shadows; frame = propagation + Gouraud raster at {}×{}; thesis 3 GHz 1/8 threads)",
            opts.width, opts.height
        ),
        &b.rows,
        &[
            Plot::new(PlotSpec {
                name: "bench-nearfield-propagation",
                x: "fma_per_vertex",
                y: "propagate_fps_1t",
                series: &["scene"],
                log_y: true,
            })
            .log_x()
            .titled("relight bench nearfield: propagation rate against work per vertex (Fig. 4.11's compressions, 1 thread)")
            .labels(
                "FMA per vertex (compression 1 %/1 % … 100 %/100 %)",
                "propagations per second, 1 thread",
            ),
            Plot::new(PlotSpec {
                name: "bench-nearfield-frame",
                x: "fma_per_vertex",
                y: "frame_fps_1t",
                series: &["scene"],
                log_y: true,
            })
            .log_x()
            .titled("relight bench nearfield: frame rate (propagation + Gouraud raster) against work per vertex, 1 thread")
            .labels(
                "FMA per vertex (compression 1 %/1 % … 100 %/100 %)",
                "frames per second, 1 thread",
            ),
        ],
    )?;
    report.table(
        "relight bench nearfield: bake (transport with shadows)",
        &b.bakes,
        &[],
    )?;
    report.table(
        "relight bench nearfield: several lights (one bake per light plane, one propagation per light; propagation alone, both threads, wall clock)",
        &b.lights,
        &[],
    )?;
    report.table(
        "relight bench nearfield: a light field (eq. 4.37; 4 × 4 views, one kernel per kept angular slice) against the plain textured light on the same bake (propagation alone, both threads, wall clock)",
        &b.light_fields,
        &[],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_nearfield::Ranking;

    /// `--source-ranking` spells both rankings; anything else is an error
    /// naming the flag and the choices.
    #[test]
    fn source_ranking_flag() {
        let flags = |r: &str| MethodFlags {
            source_ranking: Some(r.into()),
            cache: Some(PathBuf::from("unused")),
            ..MethodFlags::default()
        };
        let mut o = NearfieldOptions::default();
        assert_eq!(o.source_ranking, Ranking::AreaWeighted);
        apply_flags(&mut o, &flags("magnitude")).unwrap();
        assert_eq!(o.source_ranking, Ranking::Magnitude);
        apply_flags(&mut o, &flags("area-weighted")).unwrap();
        assert_eq!(o.source_ranking, Ranking::AreaWeighted);
        let e = apply_flags(&mut o, &flags("largest"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--source-ranking:") && e.contains("magnitude or area-weighted"),
            "{e}"
        );
    }
}
