//! One function per subcommand: validate flags, call the library, report.

use crate::args::{
    BakeCommand, BenchArgs, Cli, Command, ConvertArgs, FogCommand, ParamKind, ShCommand, Suite,
    VerifyArgs, VerifySuite,
};
use crate::demo::demo;
use crate::output::{
    check_output, check_plot_dir, output_paths, output_paths_for, warn_all, write_outputs,
};
use crate::plot::{Plot, PlotSpec};
use crate::progress::Bar;
use crate::render_cmd::{render, view};
use crate::scene_args::load_normal_map;
use crate::table::Report;
use anyhow::{Result, anyhow, bail, ensure};
use glam::Vec3;
use relight_assets::{ToneMap, write_exr};
use relight_brdf::BrdfSpec;
use relight_render::Image;
use relight_sphere::Param;
use std::path::PathBuf;
use std::time::Instant;

pub fn run(cli: Cli) -> Result<()> {
    let bar = Bar::new(cli.quiet);
    match cli.command {
        Command::Demo(a) => demo(*a, &bar),
        Command::Render(a) => render(*a, &bar),
        Command::View(a) => view(*a, &bar),
        Command::Info { files } => info(&files),
        Command::Compare {
            image,
            reference,
            region,
            diff,
        } => {
            if let Some(d) = &diff {
                output_paths_for(d, "--diff")?;
            }
            crate::compare::compare(&image, &reference, region, diff.as_deref())
        }
        Command::Convert(a) => convert(a),
        Command::Sh(c) => sh(c),
        Command::Bake(c) => bake(c, &bar),
        Command::Fog(c) => fog(c),
        Command::Wavelet(c) => crate::zoom::run(c),
        Command::Bench(a) => bench(a, &bar),
        Command::Verify(a) => verify(a, &bar),
        Command::Spheres(c) => crate::shexp::spheres(c),
        Command::Cache(c) => crate::cache::run(c),
        Command::Ndf(c) => crate::ndf_bake::run(c),
    }
}

fn info(files: &[PathBuf]) -> Result<()> {
    let mut failed = 0;
    for f in files {
        let info = if crate::scene_info::is_scene_file(f) {
            crate::scene_info::describe_scene_file(f)
        } else {
            relight_assets::describe(f)
                .map(|i| i.to_string())
                .map_err(|e| match e {
                    // `info` also reads scene files, which the asset layer does not know.
                    relight_assets::AssetError::UnknownFormat { .. } => {
                        anyhow!("{e}, or a .toml scene file")
                    }
                    e => e.into(),
                })
        };
        match info {
            Ok(info) => println!("{info}"),
            Err(e) => {
                eprintln!("relight: {e:#}");
                failed += 1;
            }
        }
    }
    ensure!(
        failed == 0,
        "{failed} of {} files could not be read",
        files.len()
    );
    Ok(())
}

fn convert(a: ConvertArgs) -> Result<()> {
    check_output(&a.output, "output", &["exr", "hdr", "png"])?;
    let (env, report) = relight_assets::load_env_map(&a.input)?;
    warn_all(&report.warnings);
    ensure!(
        (1..=16).contains(&a.supersample),
        "--supersample must be 1…16 (got {})",
        a.supersample
    );
    let size = a.size.unwrap_or(match env.param {
        Param::LatLong { height, .. } => height,
        Param::Cube { n } | Param::Octahedral { n } | Param::HemiOctahedral { n } => n,
    });
    ensure!(
        (1..=8192).contains(&size),
        "--size must be 1…8192 (got {size})"
    );
    let target = match a.to {
        ParamKind::Latlong => Param::LatLong {
            width: 2 * size,
            height: size,
        },
        ParamKind::Cube => Param::Cube { n: size },
        ParamKind::Octahedral => Param::Octahedral { n: size },
        ParamKind::HemiOctahedral => Param::HemiOctahedral { n: size },
    };
    let out = env.resample(target, a.supersample);
    relight_assets::write_env_map(&a.output, &out, ToneMap::default())?;
    println!(
        "relight convert: {} ({}×{}) → {} ({}×{}, {:?})",
        a.input.display(),
        env.param.width(),
        env.param.height(),
        a.output.display(),
        target.width(),
        target.height(),
        a.to
    );
    Ok(())
}

fn parse_window(w: &str) -> Result<relight_sh::project::Window> {
    use relight_sh::project::Window;
    let (name, arg) = w.split_once(':').map_or((w, None), |(n, a)| (n, Some(a)));
    let value = |default: f64| -> Result<f64> {
        arg.map_or(Ok(default), |a| {
            a.parse::<f64>()
                .map_err(|_| anyhow!("--window {w}: `{a}` is not a number"))
        })
    };
    Ok(match name {
        "none" => Window::None,
        "hanning" => Window::Hanning { width: value(8.0)? },
        "lanczos" => Window::Lanczos { width: value(8.0)? },
        "sloan" => Window::Sloan {
            lambda: value(0.001)?,
        },
        _ => {
            bail!("--window {w}: expected none, hanning[:WIDTH], lanczos[:WIDTH] or sloan[:LAMBDA]")
        }
    })
}

fn sh(c: ShCommand) -> Result<()> {
    match c {
        ShCommand::Project {
            file,
            order,
            window,
            json,
            out,
        } => {
            ensure!(
                (1..=30).contains(&order),
                "--order must be 1…30 bands (got {order})"
            );
            if let Some(out) = &out {
                check_output(out, "--out", &[])?;
            }
            let (env, report) = relight_assets::load_env_map(&file)?;
            warn_all(&report.warnings);
            let w = parse_window(&window)?;
            let coeffs = relight_shlight::project_env(&env, order, w)?;
            let doc = serde_json::json!({
                "file": file.display().to_string(),
                "convention": relight_sh::CONVENTION,
                "order": order,
                "window": w.describe(),
                "coefficients": coeffs,
            });
            if let Some(out) = &out {
                relight_assets::write_atomic(out, serde_json::to_string_pretty(&doc)?.as_bytes())?;
                eprintln!("relight: wrote {}", out.display());
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&doc)?);
            } else {
                println!(
                    "{}: {order} bands ({} coefficients per channel), window {}",
                    file.display(),
                    order * order,
                    w.describe()
                );
                println!("convention: {}", relight_sh::CONVENTION);
                println!("{:>4} {:>4} {:>14} {:>14} {:>14}", "l", "m", "R", "G", "B");
                for l in 0..order as i64 {
                    for m in -l..=l {
                        let i = (l * (l + 1) + m) as usize;
                        println!(
                            "{l:>4} {m:>4} {:>14.6e} {:>14.6e} {:>14.6e}",
                            coeffs.channels[0][i], coeffs.channels[1][i], coeffs.channels[2][i]
                        );
                    }
                }
            }
            Ok(())
        }
        ShCommand::LogTable { order, json } => crate::shexp::log_table(order, json),
        ShCommand::Irradiance { file, out, json } => {
            output_paths(&out)?;
            let (env, report) = relight_assets::load_env_map(&file)?;
            warn_all(&report.warnings);
            let (coeffs, map) = relight_shlight::irradiance_map(
                &env,
                Param::LatLong {
                    width: 256,
                    height: 128,
                },
            )?;
            let img = Image {
                width: map.param.width(),
                height: map.param.height(),
                pixels: map.texels,
            };
            let (png, exr) = write_outputs(&img, None, &out)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&coeffs)?);
            } else {
                println!(
                    "{}: irradiance E(n), 9 coefficients per channel ({})",
                    file.display(),
                    relight_sh::CONVENTION
                );
                for i in 0..9 {
                    println!(
                        "{i:>2} {:>14.6e} {:>14.6e} {:>14.6e}",
                        coeffs.channels[0][i], coeffs.channels[1][i], coeffs.channels[2][i]
                    );
                }
            }
            eprintln!("relight: wrote {} and {}", png.display(), exr.display());
            Ok(())
        }
    }
}

fn bake(c: BakeCommand, bar: &Bar) -> Result<()> {
    let t = Instant::now();
    match c {
        BakeCommand::Nearfield {
            scene,
            order,
            face,
            cache,
            out,
        } => {
            crate::nearfield::bake(&scene, order, face, cache.as_deref(), out.as_deref(), bar)?;
        }
        BakeCommand::Rotation {
            n,
            ntess,
            ntrunc,
            m,
            supersample,
            out,
        } => {
            let mut p = relight_wavelet::RotationParams::new(n, ntess, ntrunc);
            if let Some(m) = m {
                p.m = m;
            }
            p.supersample = supersample;
            p.validate()?;
            check_output(&out, "--out", &[])?;
            let rot = relight_wavelet::bake_rotation(&p, bar)?;
            rot.save(&out)?;
            println!(
                "relight bake rotation: n={n} ntess={ntess} ntrunc={ntrunc} m={} supersample={supersample}: {:.1} nnz/row, {:.1} MB, wrote {} in {:.1} s",
                p.m,
                rot.nnz_per_row(),
                rot.size_bytes() as f64 / 1e6,
                out.display(),
                t.elapsed().as_secs_f64()
            );
        }
        BakeCommand::Brdf {
            brdf,
            m,
            views,
            terms,
            out,
        } => {
            let spec = brdf
                .parse::<BrdfSpec>()
                .map_err(|e| anyhow!("--brdf {brdf}: {e}"))?;
            check_output(&out, "--out", &[])?;
            let b = spec.build();
            let p = relight_wavelet::BrdfBakeParams::new(&spec.to_string(), m, views, terms);
            let bake = relight_wavelet::bake_brdf(&p, b.as_ref(), bar)?;
            bake.save(&out)?;
            println!(
                "relight bake brdf: {spec} m={m} views={views}² terms={terms}: L2 energy kept {:.4}, wrote {} in {:.1} s",
                bake.energy_fraction,
                out.display(),
                t.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}

fn fog(c: FogCommand) -> Result<()> {
    match c {
        FogCommand::Tables { size, out } => {
            ensure!(
                (2..=relight_fog::MAX_TABLE_SIZE).contains(&size),
                "--size {size}: must be 2…{}",
                relight_fog::MAX_TABLE_SIZE
            );
            check_output(&out, "--out", &["exr"])?;
            let t = Instant::now();
            let tables = relight_fog::FogTables::build(size)?;
            let stem = out.with_extension("");
            for img in tables.images() {
                let path = PathBuf::from(format!("{}-{}.exr", stem.display(), img.name));
                write_exr(&path, img.width, img.height, &img.pixels)?;
                println!("wrote {} ({}×{})", path.display(), img.width, img.height);
            }
            println!(
                "relight fog tables: size {size}, built in {:.2} s",
                t.elapsed().as_secs_f64()
            );
            Ok(())
        }
    }
}

fn bench(a: BenchArgs, bar: &Bar) -> Result<()> {
    check_plot_dir(a.plot.as_deref())?;
    let report = Report::new(a.json, a.plot.clone());
    if a.suite != Suite::Frames && !a.methods.is_empty() {
        bail!("--method applies to `bench frames` only");
    }
    if let Some(isa) = a.isa {
        relight_sh::set_isa_limit(isa.into());
    }
    let result = match a.suite {
        Suite::Frames => crate::bench_frames::run(&a, &report, bar),
        Suite::Shexp => crate::shexp::bench(&a, &report),
        Suite::RadianceCache => crate::radcache::bench(a.quick, &report, bar),
        Suite::Affine => crate::affine::bench(&a, &report),
        Suite::Triple => crate::triple::bench(&a, &report, bar),
        Suite::Nearfield => crate::nearfield::bench(&a, &report, bar),
        Suite::Raster => {
            let rows = if a.quick {
                relight_render::raster::bench_raster(100_000, 640, 360, 3)
            } else {
                relight_render::raster::bench_raster(1_000_000, 1920, 1080, 10)
            };
            report.table_plots(
                "relight bench raster",
                &rows,
                &[Plot::new(PlotSpec {
                    name: "bench-raster",
                    x: "triangles",
                    y: "ms_per_frame",
                    series: &["mode"],
                    log_y: false,
                })
                .labels("triangles", "ms per frame")],
            )?;
            Ok(())
        }
        Suite::Reference => {
            let rows = if a.quick {
                relight_render::reference::bench_reference(160, 90, 4)
            } else {
                relight_render::reference::bench_reference(640, 360, 16)
            };
            report.table_plots(
                "relight bench reference",
                &rows,
                &[Plot::new(PlotSpec {
                    name: "bench-reference",
                    x: "spp",
                    y: "samples_per_s",
                    series: &["scene", "visibility"],
                    log_y: false,
                })
                .labels("samples per pixel", "pixel samples per second")],
            )?;
            Ok(())
        }
        Suite::Sh => {
            let sh_rows = relight_sh::bench_sh(a.quick);
            report.table_plots(
                "relight bench sh (single thread, f32, ns)",
                &sh_rows,
                &[Plot::new(PlotSpec {
                    name: "bench-sh",
                    x: "order",
                    y: "ns_total",
                    series: &["method"],
                    log_y: true,
                })
                .titled("relight bench sh: one SH rotation (build + apply, single thread)")
                .labels("SH order (bands)", "ns per rotation")],
            )?;
            if let Some(p) = &a.peers {
                report.table(
                    "relight bench sh --peers: speedup = peer ns / relight ns (targets: issue 17)",
                    &crate::bench_sh_peers::compare(&sh_rows, p)?,
                    &[],
                )?;
            }
            let (w, h, orders): (usize, usize, &[usize]) = if a.quick {
                (320, 180, &[3, 6])
            } else {
                (1280, 720, &[3, 6, 10])
            };
            let scene = relight_scene::default_scene(w, h);
            // Per-pixel rotation under a procedural bump map, every method.
            let bumps = relight_shlight::NormalMap::bumps(256, 8, 0.6);
            let rows = relight_shlight::bench_sh_render(
                &scene,
                Some(&bumps),
                w,
                h,
                orders,
                &relight_shlight::ShRotationMethod::ALL,
                if a.quick { 1 } else { 3 },
            )?;
            report.table_plots(
                "relight bench sh: SH shading frame time",
                &rows,
                &[Plot::new(PlotSpec {
                    name: "bench-sh-frame",
                    x: "order",
                    y: "ms_frame",
                    series: &["rotation", "normal_map"],
                    log_y: false,
                })
                .titled(&format!(
                    "relight bench sh: SH shading frame time at {w}×{h}"
                ))
                .labels("SH order (bands)", "ms per frame")],
            )?;
            let frames = relight_shlight::bench_sh_frames(
                &relight_scene::default_scene(960, 540),
                if a.quick { 2 } else { 9 },
                if a.quick { 0.25 } else { 1.0 },
            )?;
            report.table(
                "relight bench sh: the sh method's frame (render_frame, normal-mapped, aa 1)",
                &frames,
                &[],
            )
        }
        Suite::Wavelet => {
            let opts = if a.quick {
                relight_wavelet::BenchOptions::quick()
            } else {
                relight_wavelet::BenchOptions::full()
            };
            let bunny = data_dir().join("mesh/bunny.obj");
            let mut meshes = Vec::new();
            if bunny.exists() {
                let (mesh, _) = relight_assets::load_mesh(&bunny)?;
                for &target in &opts.vertices {
                    let m = mesh.refine_to_vertices(target);
                    meshes.push((target, std::sync::Arc::new(m)));
                }
            } else {
                eprintln!(
                    "relight: {} not found; view-change rows use UV spheres",
                    bunny.display()
                );
            }
            let rows = relight_wavelet::bench_wavelet(&opts, &meshes, &Bar::new(true))?;
            report.table_plots(
                "relight bench wavelet",
                &rows,
                &[
                    Plot::new(PlotSpec {
                        name: "bench-wavelet-view",
                        x: "vertices",
                        y: "view_change_ms",
                        series: &["n", "ntess"],
                        log_y: false,
                    })
                    .titled("relight bench wavelet: view change (per-vertex BRDF slices)")
                    .labels("mesh vertices", "ms per view change")
                    .log_x(),
                    Plot::new(PlotSpec {
                        name: "bench-wavelet-light",
                        x: "terms",
                        y: "light_change_ms",
                        series: &["n", "ntess", "layout"],
                        log_y: true,
                    })
                    .titled("relight bench wavelet: lighting change (rotation matrices × lighting)")
                    .labels("wavelet terms kept", "ms per lighting change")
                    .log_x(),
                ],
            )?;
            Ok(())
        }
        Suite::Ndf => crate::ndf::bench(&a, &report, bar),
        Suite::Fog => {
            report.table(
                "relight bench fog (fog bench scene: floor + 9 spheres, 4 lights)",
                &relight_fog::bench_fog(a.quick),
                &[PlotSpec {
                    name: "bench-fog",
                    x: "width",
                    y: "frame_ms",
                    series: &["interp"],
                    log_y: false,
                }],
            )?;
            let (w, h) = if a.quick { (320, 180) } else { (1280, 720) };
            let scene = relight_scene::default_scene(w, h);
            let rows = relight_fog::bench_fog_scene(
                a.quick,
                &relight_fog::scene_objects(&scene),
                &scene.camera,
                &relight_fog::default_scene_lights(4),
            );
            report.table(
                "relight bench fog (default scene, 4 lights)",
                &rows,
                &[PlotSpec {
                    name: "bench-fog-default-scene",
                    x: "width",
                    y: "frame_ms",
                    series: &["interp"],
                    log_y: false,
                }],
            )
        }
    };
    report.finish(&format!("bench {}", suite_name(&a.suite)));
    result
}

/// `../shared/data` beside the working directory, or `$RELIGHT_DATA`.
pub fn data_dir() -> PathBuf {
    std::env::var_os("RELIGHT_DATA").map_or_else(|| PathBuf::from("../shared/data"), PathBuf::from)
}

fn verify(a: VerifyArgs, bar: &Bar) -> Result<()> {
    check_plot_dir(a.plot.as_deref())?;
    let report = Report::new(a.json, a.plot.clone());
    let result = match a.suite {
        VerifySuite::Methods => crate::verify_methods::verify_methods(&a, &report, bar),
        VerifySuite::Shexp => crate::shexp::verify(&a, &report),
        VerifySuite::RadianceCache => crate::radcache::verify(a.quick, &report, bar),
        VerifySuite::Affine => crate::affine::verify(&a, &report),
        VerifySuite::Triple => crate::triple::verify(&a, &report, bar),
        VerifySuite::Nearfield => crate::nearfield::verify(&a, &report, bar, false),
        VerifySuite::NearfieldVertex => crate::nearfield::verify(&a, &report, bar, true),
        VerifySuite::Importance => verify_importance(&a, &report),
        VerifySuite::Ltc => crate::ltc::verify(&a, &report, bar),
        VerifySuite::Sh => {
            let opts = relight_shlight::VerifyOptions::new(a.quick);
            let default = relight_scene::default_scene(opts.width, opts.height);
            let mut scenes = vec![("default".to_string(), default.clone())];
            let park = data_dir().join("hdri/park.exr");
            if park.exists() {
                let (env, _) = relight_assets::load_env_map(&park)?;
                let ggx = "ggx:0.3"
                    .parse::<BrdfSpec>()
                    .map_err(|e| anyhow!("{e}"))?
                    .build();
                let mut s = relight_scene::with_brdf(&default, &ggx);
                s.env = env;
                scenes.push(("park-ggx0.3".to_string(), s));
            } else {
                eprintln!(
                    "relight: {} not found; verifying the default scene only",
                    park.display()
                );
            }
            let nm_path = data_dir().join("normalmaps/0000.png");
            let nm = if nm_path.exists() {
                Some(load_normal_map(&nm_path)?)
            } else {
                None
            };
            let vs: Vec<relight_shlight::VerifyScene> = scenes
                .iter()
                .map(|(n, s)| relight_shlight::VerifyScene { name: n, scene: s })
                .collect();
            let rows =
                relight_shlight::verify_sh(&vs, nm.as_ref().map(|m| ("0000.png", m)), &opts, bar)?;
            report.table_plots(
                "relight verify sh: relative RMS error vs the reference renderer",
                &rows,
                &[
                    Plot::new(PlotSpec {
                        name: "verify-sh",
                        x: "order",
                        y: "rel_rms_error",
                        series: &["scene", "normal_map", "rotation", "window"],
                        log_y: true,
                    })
                    .labels("SH order (bands)", "relative RMS error vs the reference"),
                    Plot::new(PlotSpec {
                        name: "verify-sh-rotation",
                        x: "order",
                        y: "rel_rms_vs_exact",
                        series: &["scene", "rotation"],
                        log_y: true,
                    })
                    .titled("relight verify sh: per-pixel rotation methods against exact rotation")
                    .labels(
                        "SH order (bands)",
                        "relative RMS difference from exact rotation",
                    ),
                ],
            )?;
            Ok(())
        }
        VerifySuite::Wavelet => {
            let opts = if a.quick {
                relight_wavelet::VerifyOptions::quick()
            } else {
                relight_wavelet::VerifyOptions::full()
            };
            let (w, h) = if a.quick { (160, 90) } else { (320, 180) };
            let default = relight_scene::default_scene(w, h);
            let mut scenes = vec![("default".to_string(), default.clone())];
            if !a.quick {
                for name in ["park", "sky", "studio"] {
                    let p = data_dir().join(format!("hdri/{name}.exr"));
                    if p.exists() {
                        let (env, _) = relight_assets::load_env_map(&p)?;
                        let mut s = default.clone();
                        s.env = env;
                        scenes.push((name.to_string(), s));
                    }
                }
            }
            let (rows, compare) = relight_wavelet::verify_wavelet_with_sh(&scenes, &opts, bar)?;
            report.table_plots(
                "relight verify wavelet: relative RMS error vs the reference renderer",
                &rows,
                &[Plot::new(PlotSpec {
                    name: "verify-wavelet",
                    x: "terms",
                    y: "rel_rms_error",
                    series: &["scene", "brdf", "n", "ntess", "ntrunc"],
                    log_y: true,
                })
                .labels("wavelet terms kept", "relative RMS error vs the reference")
                .log_x()],
            )?;
            report.table(
                "relight verify wavelet: wavelets beside SH (antialiased, same reference)",
                &compare,
                &[],
            )?;
            // Figure 7 used N = 128² matrices; 64² is the renderer's default.
            let light = |d: Vec3| relight_scene::studio_radiance(d);
            let mut rows = Vec::new();
            for &n in if a.quick { &[32][..] } else { &[64, 128][..] } {
                rows.extend(relight_wavelet::verify_rotation("studio", &light, n, bar)?);
            }
            report.table_plots(
                "relight verify wavelet: rotated lighting (Figure 7)",
                &rows,
                &[Plot::new(PlotSpec {
                    name: "verify-wavelet-rotation",
                    x: "terms",
                    y: "rel_rms_error",
                    series: &["lighting", "n", "method"],
                    log_y: true,
                })
                .labels(
                    "wavelet terms kept",
                    "relative RMS error of the rotated lighting",
                )
                .log_x()],
            )?;
            Ok(())
        }
        VerifySuite::Ndf => crate::ndf::verify(&a, &report, bar),
        VerifySuite::Fog => {
            let rows = relight_fog::verify_fog(a.quick);
            let titles: Vec<String> = FOG_PLOTS
                .iter()
                .map(|p| format!("relight verify fog: {}", p.check))
                .collect();
            let plots: Vec<Plot> = FOG_PLOTS
                .iter()
                .zip(&titles)
                .map(|(p, title)| {
                    let plot = Plot::new(PlotSpec {
                        name: p.name,
                        x: "param",
                        y: p.y,
                        series: &["variant"],
                        log_y: true,
                    })
                    .only("check", p.check)
                    .titled(title)
                    .labels(p.x_label, p.y_label);
                    if p.log_x { plot.log_x() } else { plot }
                })
                .collect();
            report.table_plots("relight verify fog", &rows, &plots)?;
            Ok(())
        }
        VerifySuite::Reference => {
            let rows = relight_brdf::verify::verify_brdfs(if a.quick { 20_000 } else { 200_000 });
            report.table_plots(
                "relight verify reference: BRDF sampling used by the reference renderer",
                &rows,
                &[Plot::new(PlotSpec {
                    name: "verify-brdf",
                    x: "theta_o_deg",
                    y: "albedo_z_score",
                    series: &["spec"],
                    log_y: false,
                })
                .titled("relight verify reference: sampled against quadrature albedo per BRDF")
                .labels(
                    "viewing angle θo (degrees)",
                    "|sampled − quadrature albedo| / standard error",
                )],
            )?;
            Ok(())
        }
    };
    report.finish(&format!("verify {}", suite_name(&a.suite)));
    result
}

/// `relight verify importance`: wavelet importance sampling of area lights
/// (issue 13); fails (exit 1) when a gated row fails.
fn verify_importance(a: &VerifyArgs, report: &Report) -> Result<()> {
    let o = relight_render::reference::WaveletVerifyOptions::new(a.quick);
    let rows = relight_render::reference::verify_wavelet_sampling(&o)?;
    let v = report.table_verdicts(
        &format!(
            "relight verify importance (glossy sphere under a textured area light, {}x{}, wavelet order {}, face {})",
            o.size, o.size, o.wavelet.order, o.wavelet.face
        ),
        &rows,
        &[],
    )?;
    if let Some(v) = v
        && v.fail > 0
    {
        bail!(
            "verify importance: {} of {} gated rows fail",
            v.fail,
            v.fail + v.pass
        );
    }
    Ok(())
}

/// One `verify fog` plot: the rows of one check, whose `param` means
/// something of its own (the fog crate's `VerifyRow::param`).
struct FogPlot {
    check: &'static str,
    name: &'static str,
    y: &'static str,
    x_label: &'static str,
    y_label: &'static str,
    /// The parameter spans decades (table sizes, optical thickness).
    log_x: bool,
}

const FOG_PLOTS: [FogPlot; 7] = [
    FogPlot {
        check: "airlight",
        name: "verify-fog-airlight",
        y: "max_error",
        x_label: "F table size (texels per side)",
        y_label: "max relative error of the airlight",
        log_x: true,
    },
    FogPlot {
        check: "airlight_paper_f",
        name: "verify-fog-airlight-paper-f",
        y: "max_error",
        x_label: "F table size (texels per side)",
        y_label: "max relative error (paper's F fit)",
        log_x: true,
    },
    FogPlot {
        check: "glow_single",
        name: "verify-fog-glow-single",
        y: "mean_error",
        x_label: "T_sv, optical thickness from viewer to light",
        y_label: "relative RMS error vs Monte Carlo",
        log_x: true,
    },
    FogPlot {
        check: "glow_multiple",
        name: "verify-fog-glow-multiple",
        y: "mean_error",
        x_label: "T_sv, optical thickness from viewer to light",
        y_label: "relative RMS error vs Monte Carlo",
        log_x: true,
    },
    FogPlot {
        check: "surface_lambert",
        name: "verify-fog-surface-lambert",
        y: "max_error",
        x_label: "table size (texels per side)",
        y_label: "max relative error of surface radiance",
        log_x: true,
    },
    FogPlot {
        check: "surface_phong",
        name: "verify-fog-surface-phong",
        y: "max_error",
        x_label: "Phong exponent n",
        y_label: "max relative error of surface radiance",
        log_x: false,
    },
    FogPlot {
        check: "psf_factorization",
        name: "verify-fog-psf",
        y: "mean_error",
        x_label: "γ, angle from the light (degrees)",
        y_label: "mean error over T",
        log_x: false,
    },
];

/// A suite's name as the command line spells it.
fn suite_name(suite: &impl clap::ValueEnum) -> String {
    suite
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_string())
}
