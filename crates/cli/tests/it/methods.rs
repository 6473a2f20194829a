//! End-to-end tests of the method interface through the `relight` binary:
//! every scene feature reaches the reference, methods refuse what they
//! cannot render with a one-line error naming the method, and the CLI and
//! the viewer make the same image.

use crate::common;
use std::path::{Path, PathBuf};

use common::{assert_one_line_error, relight, tmp};
use std::process::{Command, Output};

fn assert_clean_error(out: &Output, needles: &[&str]) {
    assert!(!out.status.success(), "expected failure");
    assert_one_line_error(out, needles);
}

/// Runs `relight -q render ARGS --out <tmp>/NAME` (ARGS split at spaces),
/// asserts success and returns the EXR written beside the PNG and stderr.
fn rendered_log(args: &str, name: &str) -> (PathBuf, String) {
    let out = tmp(name);
    let mut all = vec!["-q", "render"];
    all.extend(args.split_whitespace());
    all.extend(["--out", out.to_str().unwrap()]);
    let o = relight(&all);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    (out.with_extension("exr"), err)
}

fn rendered(args: &str, name: &str) -> PathBuf {
    rendered_log(args, name).0
}

/// The relative RMS that `relight compare A B --region R` prints.
fn compared(a: &Path, b: &Path, region: &str) -> f64 {
    let out = relight(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--region",
        region,
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains(&format!("region {region}")), "{text}");
    text.split("relative RMS ")
        .nth(1)
        .and_then(|t| t.split(',').next())
        .and_then(|t| t.trim().parse().ok())
        .unwrap_or_else(|| panic!("no figure in {text}"))
}

fn pixels(exr: &Path) -> Vec<glam::Vec3> {
    relight_assets::read_image(exr).unwrap().0.pixels
}

#[test]
fn the_reference_renders_normal_maps_and_agrees_with_sh_within_its_band_limit() {
    let nm = "../../../shared/data/normalmaps/0000.png";
    if !Path::new(env!("CARGO_MANIFEST_DIR")).join(nm).exists() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set and {nm} is missing"
        );
        eprintln!("skipping: {nm} not found");
        return;
    }
    let base = "--mesh sphere --env studio --brdf lambert:0.8 --size 64x48";
    let plain = rendered(
        &format!("{base} --method reference --spp 256"),
        "ref-plain.png",
    );
    let mapped = rendered(
        &format!("{base} --method reference --spp 256 --normal-map {nm}"),
        "ref-nm.png",
    );
    let sh_plain = rendered(&format!("{base} --method sh --aa 4"), "sh-plain.png");
    let sh_mapped = rendered(
        &format!("{base} --method sh --aa 4 --normal-map {nm}"),
        "sh-nm.png",
    );
    let normal_map_effect = compared(&mapped, &plain, "object");
    let band_limit = compared(&sh_plain, &plain, "object");
    let mapped_error = compared(&sh_mapped, &mapped, "object");
    eprintln!(
        "normal map changes the reference by {normal_map_effect:.4}; SH vs reference: {band_limit:.4} plain, {mapped_error:.4} normal-mapped"
    );
    assert!(
        normal_map_effect > 0.02,
        "the reference ignores the normal map ({normal_map_effect})"
    );
    assert!(
        mapped_error <= 1.5 * band_limit + 0.02,
        "SH with the normal map {mapped_error} vs its band-limit error {band_limit}"
    );
}

#[test]
fn fog_renders_glow_under_the_reference_and_the_fog_method_meets_the_gate() {
    let scene = "../../examples/foggy-lights.toml --size 64x36";
    let clear = rendered(
        &format!("{scene} --method reference --spp 64 --beta 0"),
        "fog-clear.png",
    );
    let (single, log) = rendered_log(
        &format!("{scene} --method reference --spp 2048 --scattering single"),
        "fog-single.png",
    );
    // The reference's own noise, as `render` reports it.
    let sigma: f64 = log
        .split("(RMS ")
        .nth(1)
        .and_then(|t| t.split(')').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no noise figure in {log}"));
    let analytic = rendered(&format!("{scene} --method fog --aa 4"), "fog-analytic.png");
    // Glow: the background around the lights is brighter in fog.
    let mean_bg = |p: &Path| {
        let m = relight_assets::read_mask_channels(p).unwrap();
        let cov = m.coverage.unwrap();
        let px = pixels(p);
        let (s, n) = px
            .iter()
            .zip(&cov)
            .filter(|(_, c)| **c <= 0.0)
            .fold((0.0f32, 0), |(s, n), (p, _)| (s + p.element_sum(), n + 1));
        s / n.max(1) as f32
    };
    let (glow, dark) = (mean_bg(&single), mean_bg(&clear));
    assert!(glow > dark + 1e-3, "no glow: fog {glow} vs clear {dark}");
    let err = compared(&analytic, &single, "all");
    let gate = 2.0 * sigma + 0.005;
    eprintln!(
        "fog method vs single-scattering reference: relative RMS {err:.4}, gate 2σ + 0.5 % = {gate:.4}"
    );
    // Issue 10's gate.
    assert!(
        err <= gate,
        "fog method vs single scattering: {err} > {gate}"
    );
}

#[test]
fn inapplicable_flags_and_features_are_one_line_errors_naming_the_method() {
    let o = tmp("never.png");
    let o = o.to_str().unwrap();
    let run = |args: &str| {
        let mut all = vec!["-q", "render", "--mesh", "sphere", "--size", "16x16"];
        all.extend(args.split_whitespace());
        all.extend(["--out", o]);
        relight(&all)
    };
    assert_clean_error(
        &run("--method sh --light 0,2,0,5"),
        &["method sh", "point lights"],
    );
    assert_clean_error(
        &run("--method sh --visibility"),
        &["method sh", "visibility"],
    );
    assert_clean_error(&run("--method sh --ao 8"), &["--ao", "method sh"]);
    assert_clean_error(&run("--method sh --beta 0.1"), &["method sh", "medium"]);
    assert_clean_error(
        &run("--method wavelet --normal-map ../../../shared/data/normalmaps/0000.png"),
        &["method wavelet", "normal maps"],
    );
    assert_clean_error(
        &run("--method reference --order 4"),
        &["--order", "method reference"],
    );
    assert_clean_error(
        &run("--method reference --aa 2"),
        &["--aa", "method reference"],
    );
    assert_clean_error(&run("--method fog --terms 8"), &["--terms", "method fog"]);
    assert_clean_error(
        &run("--method wavelet --visibility --n 16 --ntess 4"),
        &["method wavelet", "visibility"],
    );
    assert!(!Path::new(o).exists(), "no output may be written on error");
}

#[test]
fn exrs_carry_coverage_and_compare_uses_regions() {
    let a = rendered(
        "--mesh sphere --env studio --size 32x24 --method sh",
        "reg-a.png",
    );
    let m = relight_assets::read_mask_channels(&a).unwrap();
    let (cov, ids) = (m.coverage.unwrap(), m.object_id.unwrap());
    assert!(cov.iter().any(|&c| c >= 1.0) && cov.iter().any(|&c| c <= 0.0));
    for (c, id) in cov.iter().zip(&ids) {
        assert_eq!(*c > 0.0, *id > 0, "coverage {c} with object id {id}");
    }
    let b = rendered(
        "--mesh sphere --env studio --size 32x24 --method wavelet --n 16 --ntess 4",
        "reg-b.png",
    );
    let r = rendered(
        "--mesh sphere --env studio --size 32x24 --method reference --spp 4",
        "reg-r.png",
    );
    // One background for all methods, the reference included.
    assert!(compared(&a, &b, "background") < 1e-6);
    assert!(compared(&r, &a, "background") < 1e-6);
    assert!(compared(&a, &b, "object") > 0.0);
    // A PNG against an EXR is refused.
    let out = relight(&[
        "compare",
        a.with_extension("png").to_str().unwrap(),
        b.to_str().unwrap(),
    ]);
    assert_clean_error(&out, &["tone-mapped"]);
}

#[test]
fn cli_and_viewer_make_the_same_image() {
    for (method, kind, flags) in [
        ("sh", relight_methods::MethodKind::Sh, vec!["--order", "3"]),
        ("fog", relight_methods::MethodKind::Fog, vec![]),
    ] {
        let out = tmp(&format!("same-{method}.png"));
        let mut args = vec![
            "-q", "demo", "--size", "48x27", "--aa", "2", "--method", method, "--out",
        ];
        args.push(out.to_str().unwrap());
        args.extend(flags.iter().copied());
        let o = relight(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // The demo writes each method's linear EXR as STEM-METHOD.exr.
        let cli = pixels(&out.with_file_name(format!("same-{method}-{method}.exr")));
        let mut options = relight_viewer::ViewerOptions::default();
        for m in &mut options.methods {
            if let relight_methods::MethodOptions::Sh(s) = m {
                s.order = 3;
            }
        }
        options.aa = 2;
        let mut v =
            relight_viewer::Viewer::new(relight_scene::default_scene(48, 27), kind, options)
                .unwrap();
        // A still view refines by one sub-pixel pass per frame (aa² passes);
        // the refined frame is the CLI's aa × aa box filter.
        let mut frame = v.frame(48, 27, false, &relight_render::NoProgress).unwrap();
        while v.refining() {
            frame = v.frame(48, 27, false, &relight_render::NoProgress).unwrap();
        }
        assert_eq!(frame.passes, 4, "{method}: 2×2 AA is four passes");
        assert_eq!(frame.image.pixels.len(), cli.len());
        // Reading an image clamps negative radiance to 0, so compare the
        // clamped frame. Both sample the same sub-pixel positions. Fully
        // covered pixels differ only by the rasterizer's 1/256-pixel vertex
        // snapping (finer relative to the scene at the CLI's 2× resolution,
        // which moves the barycentrics of these sub-pixel triangles): 2 %
        // per pixel (floor 0.05). Edges and background differ by the
        // background's quadrature (the corners of each offset pass vs of the
        // pixel), largest where the floor's far edge meets the environment's
        // horizon: 3 % relative RMS.
        let cov = relight_assets::read_mask_channels(
            &out.with_file_name(format!("same-{method}-{method}.exr")),
        )
        .unwrap()
        .coverage
        .unwrap();
        let (mut worst, mut num, mut den) = (0.0f32, 0.0f64, 0.0f64);
        for ((a, b), c) in frame.image.pixels.iter().zip(&cli).zip(&cov) {
            let d = a.max(glam::Vec3::ZERO) - *b;
            if *c >= 1.0 {
                worst = worst.max(d.abs().max_element() / b.max_element().max(0.05));
            } else {
                num += f64::from(d.length_squared());
                den += f64::from(b.length_squared());
            }
        }
        let edges = (num / den.max(1e-12)).sqrt();
        assert!(
            worst <= 0.02,
            "{method}: objects differ by {worst} (relative)"
        );
        assert!(
            edges <= 0.02,
            "{method}: edges and background differ by {edges} (relative RMS)"
        );
        eprintln!("{method}: objects worst {worst:.2e}, edges and background RMS {edges:.2e}");
    }
}

#[test]
fn verify_methods_quick_has_a_row_per_method_and_scene_and_the_fog_gate_passes() {
    let cache = tmp("verify-methods-cache");
    let out = Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(["-q", "verify", "methods", "--quick", "--json"])
        .env("RELIGHT_CACHE", &cache)
        .env(
            "RELIGHT_DATA",
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data"),
        )
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run relight");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON rows");
    let rows = rows.as_array().unwrap();
    let scenes: std::collections::BTreeSet<&str> =
        rows.iter().map(|r| r["scene"].as_str().unwrap()).collect();
    assert!(scenes.len() >= 5, "{scenes:?}");
    for s in &scenes {
        for m in ["reference", "sh", "wavelet", "fog"] {
            assert!(
                rows.iter().any(|r| r["scene"] == *s && r["method"] == m),
                "no {m} row for {s}"
            );
        }
    }
    // A method that cannot render a scene says why; one that can has figures.
    for r in rows {
        let ok = r["status"] == "ok";
        assert_eq!(ok, r["rel_rms_error"].is_number(), "{r}");
        if !ok && r["method"] != "reference" {
            assert!(
                r["status"].as_str().unwrap().contains("cannot render"),
                "{r}"
            );
        }
        assert!(r.get("pass").is_some() && r.get("source").is_some(), "{r}");
    }
    let gates: Vec<&serde_json::Value> = rows.iter().filter(|r| r["pass"].is_boolean()).collect();
    assert!(!gates.is_empty(), "no fog gate row");
    for g in gates {
        assert_eq!(g["method"], "fog");
        assert_eq!(g["pass"], true, "fog gate fails: {g}");
    }
}

/// A light field (`examples/light-field.toml`): `nearfield` renders it close
/// to the reference, and a method that cannot is a one-line error naming
/// itself and the feature.
#[test]
fn light_fields_reach_nearfield_and_the_reference_and_others_refuse_them() {
    let scene = "../../examples/light-field.toml --size 64x40";
    let reference = rendered(
        &format!("{scene} --method reference --spp 256"),
        "lf-reference.png",
    );
    let nearfield = rendered(&format!("{scene} --method nearfield"), "lf-nearfield.png");
    let e = compared(&nearfield, &reference, "object");
    assert!(e < 0.15, "nearfield vs reference on the light field: {e}");
    for method in ["ltc", "shexp"] {
        let out = relight(&[
            "-q",
            "render",
            "../../examples/light-field.toml",
            "--method",
            method,
            "--out",
            tmp("lf-refused.png").to_str().unwrap(),
        ]);
        assert_clean_error(&out, &[method, "light fields"]);
    }
}
