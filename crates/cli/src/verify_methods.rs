//! `relight verify methods`: the scene matrix and the cross-method table
//! (`relight_methods::verify`).
//!
//! The matrix: the embedded default scene; shared probes with a sun (`park`)
//! and indoors (`hall`) × BRDFs (Lambert, rough GGX α = 0.3, glossy GGX
//! α = 0.1) × meshes (the default scene's objects, the Stanford bunny); the
//! default scene with visibility (shadows), with a normal map, and in fog with
//! point lights (lit by them alone — the fog gate — and with the studio).
//! `--quick` keeps the default scene, its shadowed, normal-mapped
//! and foggy variants and one probe at a small size, the wavelet method at
//! n = 16 and the triple method at 80 terms with 320 visibility rays per
//! vertex, so that it fits in CI.

use crate::args::VerifyArgs;
use crate::commands::data_dir;
use crate::plot::{Plot, PlotSpec};
use crate::progress::Bar;
use crate::scene_args::load_normal_map;
use crate::table::Report;
use anyhow::{Result, anyhow};
use glam::Vec3;
use relight_brdf::BrdfSpec;
use relight_methods::MethodOptions;
use relight_methods::verify::{MatrixScene, VerifyMethodsOptions};
use relight_render::{Medium, Object, PointLight, Scene};
use std::sync::Arc;

/// CI-sized wavelet and triple configurations for `--quick`.
fn quick_options(mut o: VerifyMethodsOptions) -> VerifyMethodsOptions {
    for m in &mut o.methods {
        if let MethodOptions::Wavelet(w) = m {
            w.n = 16;
            w.ntess = 8;
            w.terms = 64;
        }
        if let MethodOptions::Triple(t) = m {
            t.terms = 80;
            t.vis_level = 2;
            t.brdf_views = 16;
        }
    }
    o.aa = 2;
    o
}

fn brdf(spec: &str) -> Result<Arc<dyn relight_brdf::Brdf>> {
    Ok(spec
        .parse::<BrdfSpec>()
        .map_err(|e| anyhow!("{spec}: {e}"))?
        .build())
}

/// The default scene in fog: a thin medium and two point lights above the objects.
fn foggy(mut s: Scene) -> Scene {
    s.medium = Some(Medium {
        beta: 0.1,
        albedo: 1.0,
        radius: 10.0,
    });
    s.point_lights = vec![
        PointLight::new(Vec3::new(-1.0, 2.4, 1.6), Vec3::splat(6.0)),
        PointLight::new(Vec3::new(1.4, 2.0, 1.2), Vec3::new(5.0, 4.0, 3.0)),
    ];
    s
}

fn matrix(quick: bool) -> Result<Vec<MatrixScene>> {
    let (w, h) = if quick { (96, 54) } else { (240, 135) };
    let default = relight_scene::default_scene(w, h);
    let mut out = vec![MatrixScene {
        name: "default".into(),
        scene: default.clone(),
        fog_gate: false,
    }];
    let mut shadowed = default.clone();
    shadowed.visibility = true;
    out.push(MatrixScene {
        name: "default+visibility".into(),
        scene: shadowed,
        fog_gate: false,
    });
    let nm_path = data_dir().join("normalmaps/0000.png");
    let nm = if nm_path.exists() {
        Arc::new(load_normal_map(&nm_path)?)
    } else {
        eprintln!(
            "relight: {} not found; the normal-mapped scene uses a procedural bump map",
            nm_path.display()
        );
        Arc::new(relight_render::NormalMap::bumps(256, 8, 0.6))
    };
    let mut mapped = default.clone();
    for o in &mut mapped.objects {
        o.normal_map = Some(nm.clone());
    }
    out.push(MatrixScene {
        name: "default+normal-map".into(),
        scene: mapped,
        fog_gate: false,
    });
    // In fog: lit by point lights alone (the fog gate), and with the studio too.
    // The gate: Lambert surfaces lit by point lights alone, which the
    // analytic model renders exactly up to its tables. The scene's own
    // glossy materials (the model's Phong lobe drops cos θᵢ, §3.4.2) and the
    // studio in fog (the PSF model) are reported.
    let mut dark = foggy(default.clone());
    dark.env = relight_scene::load_environment("black")?.0;
    let mut gated = dark.clone();
    for (o, albedo) in gated
        .objects
        .iter_mut()
        .zip(["0.9,0.7,0.3", "0.9,0.3,0.25", "0.8,0.8,0.8"])
    {
        o.brdf = brdf(&format!("lambert@{albedo}"))?;
    }
    out.push(MatrixScene {
        name: "default-lambert+fog+point-lights".into(),
        scene: gated,
        fog_gate: true,
    });
    out.push(MatrixScene {
        name: "default+fog+point-lights".into(),
        scene: dark,
        fog_gate: false,
    });
    out.push(MatrixScene {
        name: "default+fog+studio".into(),
        scene: foggy(default.clone()),
        fog_gate: false,
    });
    // Area lights alone (nearfield, ltc and the reference render them; the
    // environment methods say why not): the textured ceiling panel of
    // `verify nearfield` over its floor and sphere, unshadowed (ltc ignores
    // shadows), and the same panel as a light field (ltc refuses it).
    let (floor, segments) = if quick { (16, 16) } else { (48, 32) };
    out.push(MatrixScene {
        name: "floor+sphere+area-light".into(),
        scene: relight_nearfield::scenes::floor_and_sphere(floor, segments, w, h, false),
        fog_gate: false,
    });
    out.push(MatrixScene {
        name: "floor+sphere+light-field".into(),
        scene: relight_nearfield::scenes::floor_and_sphere_light_field(
            floor,
            segments,
            [w, h],
            false,
            4,
            2.0,
        ),
        fog_gate: false,
    });
    let probes: &[&str] = if quick { &["park"] } else { &["park", "hall"] };
    let brdfs: &[(&str, &str)] = if quick {
        &[("lambert", "lambert:0.8")]
    } else {
        &[
            ("lambert", "lambert:0.8"),
            ("ggx0.3", "ggx:0.3@0.9,0.6,0.3"),
            ("ggx0.1", "ggx:0.1@0.9,0.9,0.9"),
        ]
    };
    let bunny = data_dir().join("mesh/bunny.obj");
    let bunny_mesh = if !quick && bunny.exists() {
        Some(Arc::new(
            relight_scene::load_mesh(&bunny.to_string_lossy())?.0,
        ))
    } else {
        None
    };
    for probe in probes {
        let path = data_dir().join(format!("hdri/{probe}.exr"));
        if !path.exists() {
            eprintln!("relight: {} not found; skipping that probe", path.display());
            continue;
        }
        let (env, warnings) = relight_scene::load_environment(&path.to_string_lossy())?;
        crate::output::warn_all(&warnings);
        for (bname, spec) in brdfs {
            let b = brdf(spec)?;
            let mut s = relight_scene::with_brdf(&default, &b);
            s.env = env.clone();
            out.push(MatrixScene {
                name: format!("{probe}/{bname}/default-objects"),
                scene: s,
                fog_gate: false,
            });
            if let Some(mesh) = &bunny_mesh {
                let objects = vec![Object::new(mesh.clone(), b.clone())];
                let camera = relight_scene::framing_camera(&objects, w, h, 40.0);
                let mut s = Scene::new(objects, env.clone(), camera);
                out.push(MatrixScene {
                    name: format!("{probe}/{bname}/bunny"),
                    scene: s.clone(),
                    fog_gate: false,
                });
                s.visibility = true;
                out.push(MatrixScene {
                    name: format!("{probe}/{bname}/bunny+visibility"),
                    scene: s,
                    fog_gate: false,
                });
            }
        }
    }
    Ok(out)
}

pub fn verify_methods(a: &VerifyArgs, report: &Report, bar: &Bar) -> Result<()> {
    let scenes = matrix(a.quick)?;
    let mut opts = VerifyMethodsOptions::new(a.quick);
    if a.quick {
        opts = quick_options(opts);
    }
    let rows = relight_methods::verify::verify_methods(&scenes, &opts, bar)?;
    // One plot per scene that some real-time method renders: error against
    // frame time, one point per method.
    let names: Vec<(String, String, String)> = scenes
        .iter()
        .filter(|s| {
            rows.iter()
                .any(|r| r.scene == s.name && r.rel_rms_error.is_some_and(f64::is_finite))
        })
        .map(|s| {
            (
                s.name.clone(),
                format!("verify-methods-{}", s.name.replace(['/', '+'], "-")),
                format!(
                    "relight verify methods, scene {}: error against frame time",
                    s.name
                ),
            )
        })
        .collect();
    if report.plot_dir.is_some() {
        for s in &scenes {
            if !names.iter().any(|n| n.0 == s.name) {
                eprintln!(
                    "relight: no plot for scene {}: no method but the reference renders it",
                    s.name
                );
            }
        }
    }
    let plots: Vec<Plot> = names
        .iter()
        .map(|(scene, name, title)| {
            Plot::new(PlotSpec {
                name,
                x: "view_ms",
                y: "rel_rms_error",
                series: &["method"],
                log_y: true,
            })
            .only("scene", scene)
            .titled(title)
            .labels(
                "ms per frame (view change)",
                "relative RMS error vs the reference",
            )
            .log_x()
        })
        .collect();
    report.table_plots(
        "relight verify methods: relative RMS error over object pixels vs one reference",
        &rows,
        &plots,
    )?;
    Ok(())
}
