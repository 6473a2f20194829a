//! `relight demo`: flags → [`relight_viewer::demo`] (which renders and
//! composes every method's tile) → files: the labelled composite PNG, its
//! linear EXR, and one EXR per method.

use crate::args::DemoArgs;
use crate::method_args::{clear_foreign, kind_of, options_for};
use crate::output::output_paths;
use crate::parse::parse_size;
use crate::progress::Bar;
use anyhow::{Result, ensure};
use relight_assets::{MaskChannels, ToneMap, ToneOperator, write_exr, write_png, write_render_exr};
use relight_methods::MethodKind;
use relight_viewer::demo::{
    DEMO_AA, DEMO_METHODS, DEMO_TILE, DemoTile, DemoUserSet, apply_demo_defaults, demo_scene,
    demo_sheet, render_demo,
};
use relight_viewer::sheet::words_to_display_linear;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `STEM-METHOD.exr` beside the composite.
fn method_exr(png: &Path, kind: MethodKind) -> PathBuf {
    let stem = png.file_stem().and_then(|s| s.to_str()).unwrap_or("demo");
    png.with_file_name(format!("{stem}-{kind}.exr"))
}

fn log_tile(t: &DemoTile) {
    match &t.rendered {
        Ok(_) if t.method == MethodKind::Reference => {
            eprintln!("relight: demo: {}: {:.1} s", t.method, t.frame_ms / 1e3)
        }
        Ok(_) => eprintln!(
            "relight: demo: {}: prepared in {:.2} s; frame {:.1} ms, lighting change {:.1} ms",
            t.method, t.prepare_s, t.frame_ms, t.lighting_ms
        ),
        Err(why) => eprintln!("relight: demo: {}: {why}", t.method),
    }
    for n in &t.notes {
        eprintln!("relight: demo: {}: {n}", t.method);
    }
}

pub fn demo(a: DemoArgs, bar: &Bar) -> Result<()> {
    let start = Instant::now();
    let (png, exr) = output_paths(&a.out)?;
    let (w, h) = match &a.size {
        Some(s) => parse_size(s, "--size")?,
        None => DEMO_TILE,
    };
    let aa = crate::render_cmd::checked_aa(a.aa.unwrap_or(DEMO_AA))?;
    let kinds: Vec<MethodKind> = if a.method.is_empty() {
        DEMO_METHODS.to_vec()
    } else {
        a.method.iter().map(|m| kind_of(*m)).collect()
    };
    let user = DemoUserSet {
        spp: a.options.spp.is_some(),
        ao: a.options.ao.is_some(),
        n: a.options.n.is_some(),
    };
    // Each method gets the flags that belong to it; a flag no shown
    // method takes is an error.
    for name in crate::method_args::given(&a.options) {
        ensure!(
            kinds.iter().any(|k| {
                let mut f = a.options.clone();
                clear_foreign(*k, &mut f);
                crate::method_args::given(&f).contains(&name)
            }),
            "{name} does not apply to any method shown ({})",
            kinds
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let methods = kinds
        .iter()
        .map(|&k| {
            let mut f = a.options.clone();
            clear_foreign(k, &mut f);
            let mut o = options_for(k, &f)?;
            apply_demo_defaults(&mut o, &user);
            Ok(o)
        })
        .collect::<Result<Vec<_>>>()?;
    let scene = demo_scene(w, h);
    let tiles = render_demo(&scene, &methods, aa, bar, &mut log_tile)?;
    let sheet = demo_sheet(&tiles, w, h);
    for t in &tiles {
        if let Ok(r) = &t.rendered {
            let path = method_exr(&png, t.method);
            ensure!(
                r.image.pixels.iter().all(|p| p.is_finite()),
                "internal error: method {} rendered non-finite pixels; nothing written",
                t.method
            );
            match &r.coverage {
                Some(c) => write_render_exr(
                    &path,
                    w,
                    h,
                    &r.image.pixels,
                    MaskChannels {
                        coverage: &c.coverage,
                        object_id: &c.object_id,
                    },
                )?,
                None => write_exr(&path, w, h, &r.image.pixels)?,
            }
        }
    }
    write_exr(&exr, sheet.width, sheet.height, &sheet.linear.pixels)?;
    write_png(
        &png,
        sheet.width,
        sheet.height,
        &words_to_display_linear(&sheet.words),
        ToneMap {
            exposure_ev: 0.0,
            operator: ToneOperator::Clamp,
        },
    )?;
    let per_method: Vec<String> = tiles
        .iter()
        .filter(|t| t.rendered.is_ok())
        .map(|t| method_exr(&png, t.method).display().to_string())
        .collect();
    let written = if per_method.is_empty() {
        format!("{} (no method rendered the scene)", exr.display())
    } else {
        format!("{} and {}", exr.display(), per_method.join(", "))
    };
    println!(
        "relight demo: {} of {w}×{h}; wrote {} ({}×{}), {written} in {:.1} s",
        match tiles.len() {
            1 => "1 tile".to_string(),
            n => format!("{n} tiles"),
        },
        png.display(),
        sheet.width,
        sheet.height,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
