//! End-to-end tests of the `relight` binary: the fresh-machine demo, scene
//! files, and bad input (one-line error, non-zero exit, never a panic).

use crate::common;
use std::path::{Path, PathBuf};

use common::{relight, tmp};
use std::process::{Command, Output};

/// `relight info` of a scene file written to `path` with `toml`: its stdout.
fn info_of(path: &Path, toml: &str) -> String {
    std::fs::write(path, toml).unwrap();
    let out = relight(&["info", path.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The first line of `text` that starts (after indentation) with `key`, or "".
fn line_of<'a>(text: &'a str, key: &str) -> &'a str {
    text.lines()
        .find(|l| l.trim_start().starts_with(key))
        .unwrap_or("")
}

fn assert_clean_error(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "expected failure, got success; stderr: {err}"
    );
    assert_eq!(out.status.code(), Some(1), "exit code; stderr: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    assert!(
        err.starts_with("relight: "),
        "stderr should start with `relight: `: {err}"
    );
    assert!(
        err.contains(needle),
        "stderr should mention `{needle}`: {err}"
    );
}

#[test]
fn demo_writes_a_labelled_composite_and_an_exr_per_method() {
    let png = tmp("demo.png");
    let cache = tmp("demo-cache");
    // Small tiles and a small wavelet bake; every method, as `relight demo`.
    let out = Command::new(env!("CARGO_BIN_EXE_relight"))
        .args([
            "-q", "demo", "--size", "96x54", "--spp", "4", "--n", "16", "--ntess", "4", "--terms",
            "64", "--ao", "4", "--out",
        ])
        .arg(&png)
        .env("RELIGHT_CACHE", &cache)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run relight");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (sheet, _) =
        relight_assets::read_image(&png.with_extension("exr")).expect("demo.exr readable");
    // A 96-pixel tile holds 11 glyphs a row: the details wrap to the most
    // rows a header takes.
    let header = relight_viewer::sheet::header_height(96, relight_viewer::sheet::MAX_DETAIL_LINES);
    // Five tiles, two columns.
    assert_eq!((sheet.width, sheet.height), (2 * 96, 3 * (header + 54)));
    for method in ["reference", "wavelet", "sh", "fog", "shexp"] {
        let exr = png.with_file_name(format!("demo-{method}.exr"));
        let (img, _) = relight_assets::read_image(&exr).expect("per-method EXR readable");
        assert_eq!((img.width, img.height), (96, 54), "{method}");
        let mean: f32 = img.pixels.iter().map(|p| p.x + p.y + p.z).sum::<f32>()
            / (3.0 * img.pixels.len() as f32);
        assert!(
            mean > 0.05 && mean.is_finite(),
            "{method}: mean {mean} looks black or broken"
        );
    }
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("5 tiles"), "{text}");
    assert!(
        std::fs::metadata(&png).unwrap().len() > 1000,
        "png too small"
    );
}

#[test]
fn scene_file_renders() {
    let png = tmp("scene.png");
    let out = relight(&[
        "-q",
        "render",
        "../../examples/studio-spheres.toml",
        "--size",
        "64x36",
        "--spp",
        "2",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(png.exists());
}

#[test]
fn window_flag_is_an_sh_option() {
    let out_path = tmp("window.png");
    let o = out_path.to_str().unwrap();
    assert_clean_error(
        &relight(&[
            "render", "--mesh", "sphere", "--method", "sh", "--window", "hamming", "--out", o,
        ]),
        "--window",
    );
    assert_clean_error(
        &relight(&[
            "render",
            "--mesh",
            "sphere",
            "--method",
            "reference",
            "--window",
            "hann",
            "--out",
            o,
        ]),
        "--window",
    );
}

#[test]
fn bad_flags_give_one_line_errors() {
    let out_path = tmp("bad.png");
    let o = out_path.to_str().unwrap();
    assert_clean_error(
        &relight(&[
            "render",
            "../../examples/foggy-lights.toml",
            "--env-glow",
            "maybe",
            "--out",
            o,
        ]),
        "--env-glow maybe: expected `ball`, `thesis` or `thesis-factorized`",
    );
    assert_clean_error(
        &relight(&[
            "render",
            "--mesh",
            "sphere",
            "--method",
            "sh",
            "--env-glow",
            "ball",
            "--out",
            o,
        ]),
        "--env-glow does not apply to method sh",
    );
    assert_clean_error(
        &relight(&["render", "--mesh", "sphere", "--spp", "0", "--out", o]),
        "spp",
    );
    assert_clean_error(
        &relight(&["render", "--mesh", "sphere", "--size", "0x2", "--out", o]),
        "--size",
    );
    assert_clean_error(
        &relight(&["render", "--mesh", "sphere", "--brdf", "glossy", "--out", o]),
        "unknown BRDF",
    );
    assert_clean_error(
        &relight(&["render", "--mesh", "no-such-mesh.obj", "--out", o]),
        "no-such-mesh.obj",
    );
    assert_clean_error(
        &relight(&[
            "render",
            "--mesh",
            "sphere",
            "--env",
            "missing.exr",
            "--out",
            o,
        ]),
        "missing.exr",
    );
    assert_clean_error(
        &relight(&[
            "render", "--mesh", "sphere", "--method", "sh", "--order", "0", "--out", o,
        ]),
        "order",
    );
    assert_clean_error(
        &relight(&[
            "render",
            "--mesh",
            "sphere",
            "--method",
            "fog",
            "--beta=-1",
            "--out",
            o,
        ]),
        "--beta",
    );
    assert_clean_error(
        &relight(&["bake", "rotation", "--n", "48", "--out", o]),
        "power of two",
    );
    assert_clean_error(&relight(&["info", "no-such-file.exr"]), "no-such-file.exr");
    assert_clean_error(
        &relight(&[
            "render",
            "--mesh",
            "sphere",
            "--camera",
            "0,1,0,0,1,0",
            "--out",
            o,
        ]),
        "--camera 0,1,0,0,1,0: the target must differ from the eye",
    );
    assert_clean_error(
        &relight(&[
            "render", "--mesh", "sphere", "--method", "sh", "--aa", "9", "--out", o,
        ]),
        "--aa 9: must be 1…8 samples per pixel side",
    );
    assert!(!out_path.exists(), "no output may be written on error");
    // A top-down `--camera` takes the vertical default up (it was refused
    // as "camera is invalid" by the method).
    let top = relight(&[
        "render",
        "--mesh",
        "sphere",
        "--camera",
        "0,5,0,0,0,0",
        "--size",
        "8x8",
        "--method",
        "sh",
        "--out",
        o,
    ]);
    assert!(
        top.status.success(),
        "{}",
        String::from_utf8_lossy(&top.stderr)
    );
}

#[test]
fn corrupt_scene_file_is_rejected_with_its_name() {
    let path = tmp("broken.toml");
    std::fs::write(&path, "[[object]\nbuiltin = ").unwrap();
    assert_clean_error(
        &relight(&[
            "render",
            path.to_str().unwrap(),
            "--out",
            tmp("x.png").to_str().unwrap(),
        ]),
        "broken.toml",
    );
}

#[test]
fn verify_writes_json_and_an_svg_plot() {
    let dir = tmp("plots");
    let out = relight(&[
        "-q",
        "verify",
        "reference",
        "--quick",
        "--json",
        "--plot",
        dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON");
    let rows = rows.as_array().expect("a JSON array of rows");
    assert!(!rows.is_empty());
    let svg = std::fs::read_to_string(dir.join("verify-brdf.svg")).expect("plot written");
    assert!(svg.starts_with("<svg") && svg.contains("viewing angle"));
    // One legend entry per BRDF in the table.
    let spec = rows[0]["spec"].as_str().unwrap();
    assert!(svg.contains(spec), "legend lacks {spec}");
}

/// `bench frames` reports both work counts of a method that counts them
/// (JSON), and `--plot` draws the machine fractions beside the ms columns.
#[test]
fn bench_frames_counts_and_plots_the_lighting_changes_work() {
    let dir = tmp("plots-frames");
    let _ = std::fs::remove_dir_all(&dir);
    let d = dir.to_str().unwrap();
    let out = relight(&[
        "-q",
        "bench",
        "frames",
        "--quick",
        "--method",
        "nearfield",
        "--json",
        "--plot",
        d,
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON");
    let row = &rows.as_array().expect("rows")[0];
    let (view, light) = (
        row["work_fma"].as_f64().unwrap_or(0.0),
        row["light_work_fma"].as_f64().unwrap_or(0.0),
    );
    assert!(view > 0.0 && light > view, "{row}");
    assert!(
        row["light_machine_fraction"]
            .as_f64()
            .is_some_and(|f| f > 0.0),
        "{row}"
    );
    for (name, y) in [
        ("bench-frames-view", "view_change_ms"),
        ("bench-frames-light", "light_change_ms"),
        ("bench-frames-view-fraction", "machine_fraction"),
        ("bench-frames-light-fraction", "light_machine_fraction"),
    ] {
        let svg = std::fs::read_to_string(dir.join(format!("{name}.svg"))).expect("plot written");
        assert!(svg.contains(y), "{name}: no {y} axis");
    }
}

/// `--plot` draws Fig. 4.11's rates for `bench nearfield`, and a suite
/// whose tables have no curves (`verify ltc`) says it wrote nothing
/// instead of leaving the folder empty without a word.
#[test]
fn plot_folder_gets_plots_or_a_warning() {
    let dir = tmp("plots-nearfield");
    let _ = std::fs::remove_dir_all(&dir);
    let d = dir.to_str().unwrap();
    let out = relight(&["-q", "bench", "nearfield", "--quick", "--plot", d]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    for name in ["bench-nearfield-propagation", "bench-nearfield-frame"] {
        let svg = std::fs::read_to_string(dir.join(format!("{name}.svg"))).expect("plot written");
        assert!(svg.contains("FMA per vertex"), "{name}: no axis label");
    }
    assert!(!err.contains("has no plots"), "{err}");
    let out = relight(&["-q", "verify", "ltc", "--quick", "--plot", d]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.lines()
            .any(|l| l.contains("warning: --plot") && l.contains("verify ltc has no plots")),
        "{err}"
    );
}

/// The relative RMS that `relight compare` prints.
fn compared(a: &Path, b: &Path) -> f64 {
    let out = relight(&["compare", a.to_str().unwrap(), b.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    text.split("relative RMS ")
        .nth(1)
        .and_then(|t| t.split(',').next())
        .and_then(|t| t.trim().parse().ok())
        .unwrap_or_else(|| panic!("no figure in {text}"))
}

/// Runs `relight -q render ARGS --out <tmp>/NAME` (ARGS split at spaces),
/// asserts success and returns the EXR written beside the PNG.
fn rendered(args: &str, name: &str) -> PathBuf {
    let out = tmp(name);
    let mut all = vec!["-q", "render"];
    all.extend(args.split_whitespace());
    all.extend(["--out", out.to_str().unwrap()]);
    let o = relight(&all);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out.with_extension("exr")
}

#[test]
fn light_rotation_and_aa_agree_with_the_reference_by_compare() {
    let sphere = "--mesh sphere --env studio --brdf lambert --size 48x36";
    let reference = rendered(
        &format!("{sphere} --method reference --spp 256 --light-rotate 90,30,0"),
        "cmp-ref.png",
    );
    let sh = rendered(
        &format!("{sphere} --method sh --aa 2 --light-rotate 90,30,0"),
        "cmp-sh.png",
    );
    let unrotated = rendered(&format!("{sphere} --method sh --aa 2"), "cmp-sh0.png");
    let near = compared(&sh, &reference);
    let far = compared(&unrotated, &reference);
    assert!(near < 0.12, "SH order 6 vs reference, both rotated: {near}");
    assert!(far > 2.0 * near, "unrotated {far} vs rotated {near}");
    // A size mismatch is a one-line error naming both files.
    let small = rendered(
        "--mesh sphere --env studio --size 8x8 --method sh",
        "cmp-small.png",
    );
    let out = relight(&[
        "compare",
        small.to_str().unwrap(),
        reference.to_str().unwrap(),
    ]);
    assert_clean_error(&out, "cmp-small.exr is 8×8");
    let out = relight(&[
        "-q", "render", "--mesh", "sphere", "--aa", "9", "--method", "sh",
    ]);
    assert_clean_error(&out, "--aa 9: must be 1…8");
    // Fog at T = β·radius = 1 changes the image; a negative β is a one-line error.
    let clear = rendered(&format!("{sphere} --method fog --aa 2"), "cmp-clear.png");
    let foggy = rendered(
        &format!("{sphere} --method fog --aa 2 --beta 0.1"),
        "cmp-fog.png",
    );
    let fog_vs_clear = compared(&foggy, &clear);
    assert!(
        fog_vs_clear > 0.1,
        "fog at T = 1 should change the image: {fog_vs_clear}"
    );
    let out = relight(&[
        "-q",
        "render",
        "--mesh",
        "sphere",
        "--method",
        "fog",
        "--beta=-1",
    ]);
    assert_clean_error(&out, "--beta -1");
}

#[test]
fn wavelet_render_bakes_into_its_cache_and_applies_ambient_occlusion() {
    let cache = tmp("wavelet-cache");
    let knot = format!(
        "--method wavelet --mesh knot --env studio --n 16 --ntess 4 --size 48x36 --cache {}",
        cache.display()
    );
    let plain = rendered(&knot, "wav-plain.png");
    let baked: Vec<_> = std::fs::read_dir(&cache).unwrap().collect();
    assert!(
        baked.len() >= 2,
        "rotation and BRDF bakes cached: {baked:?}"
    );
    let occluded = rendered(&format!("{knot} --ao 16"), "wav-ao.png");
    // The knot's bumps occlude themselves: darker, but far from black.
    let d = compared(&occluded, &plain);
    assert!(d > 0.01 && d < 0.6, "AO vs none: {d}");
}

/// A cached bake whose bytes changed (a flipped bit) fails its checksum: the
/// wavelet and triple methods re-bake it, say so in one warning naming the
/// file and the reason, and the next run reads the replacement silently.
#[test]
fn a_corrupt_cached_bake_is_rebaked_with_a_warning() {
    let cache = tmp("corrupt-bakes");
    let _ = std::fs::remove_dir_all(&cache);
    let png = tmp("corrupt-bakes.png");
    let runs: [(&str, &[&str]); 2] = [
        ("wavelet", &["--n", "16", "--ntess", "4", "--terms", "64"]),
        ("triple", &["--terms", "80"]),
    ];
    for (method, flags) in runs {
        let render = || {
            let out = Command::new(env!("CARGO_BIN_EXE_relight"))
                .args(["-q", "render", "--mesh", "sphere", "--size", "16x12"])
                .args(["--method", method])
                .args(flags)
                .arg("--out")
                .arg(&png)
                .env("RELIGHT_CACHE", &cache)
                .output()
                .expect("run relight");
            let err = String::from_utf8_lossy(&out.stderr).into_owned();
            assert!(out.status.success(), "{method}: {err}");
            err
        };
        let err = render();
        assert!(!err.contains("unusable"), "{method}, cold: {err}");
        let entries: Vec<PathBuf> = std::fs::read_dir(cache.join(method))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "bin"))
            .collect();
        assert!(!entries.is_empty(), "{method}: nothing cached");
        for e in &entries {
            let mut bytes = std::fs::read(e).unwrap();
            let at = bytes.len() / 2;
            bytes[at] ^= 1;
            std::fs::write(e, &bytes).unwrap();
        }
        let err = render();
        for e in &entries {
            let line = err
                .lines()
                .find(|l| l.contains(e.to_str().unwrap()))
                .unwrap_or_else(|| panic!("{method}: no warning for {}: {err}", e.display()));
            assert!(
                line.starts_with("relight: warning: method ")
                    && line.contains("checksum")
                    && line.ends_with("re-baked and replaced"),
                "{line}"
            );
        }
        let err = render();
        assert!(!err.contains("unusable"), "{method}, replaced: {err}");
    }
}

#[test]
fn view_without_a_display_is_a_one_line_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(["-q", "view", "--method", "fog", "--size", "64x36"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .expect("run relight");
    assert_clean_error(&out, "needs DISPLAY or WAYLAND_DISPLAY");
    let out = relight(&["-q", "view", "--aa", "0"]);
    assert_clean_error(&out, "--aa 0: must be 1…8 samples per pixel side");
    let out = relight(&["-q", "view", "--method", "radiance-cache"]);
    assert_clean_error(
        &out,
        "method radiance-cache is not among the viewer's methods (wavelet, sh, fog, shexp, reference, ndf, nearfield, triple, ltc)",
    );
}

#[test]
fn wavelet_zoom_refuses_what_would_draw_nothing() {
    // A 4×4 input made here: the checks run before any work.
    let input = tmp("zoom-in.png");
    let px = vec![glam::Vec3::splat(0.5); 16];
    relight_assets::write_image(&input, 4, 4, &px, relight_assets::ToneMap::default()).unwrap();
    let input = input.to_str().unwrap();
    let out = tmp("zoom-out.png");
    let out = out.to_str().unwrap();
    let zoom = |extra: &[&str]| {
        let mut a = vec!["wavelet", "zoom", input, out];
        a.extend_from_slice(extra);
        relight(&a)
    };
    assert_clean_error(&zoom(&["--center", "4,0.6"]), "--center 4,0.6");
    assert_clean_error(&zoom(&["--center", "0.5,-0.1"]), "--center");
    assert_clean_error(&zoom(&["--terms", "0"]), "--terms 0");
    let bad_out = tmp("zoom-out.txt");
    assert_clean_error(
        &relight(&["wavelet", "zoom", input, bad_out.to_str().unwrap()]),
        "zoom-out.txt",
    );
    // The edge of the image is a valid centre, and one term draws something.
    let ok = zoom(&["--center", "1,0", "--terms", "1"]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let (img, _) = relight_assets::read_image(std::path::Path::new(out)).unwrap();
    assert!(
        img.pixels.iter().any(|p| p.max_element() > 0.0),
        "black zoom"
    );
}

/// `relight info SCENE.toml` says what the scene holds and which methods
/// render it; a broken scene file is its one-line error.
#[test]
fn info_describes_a_scene_file_and_its_methods() {
    let out = relight(&["info", "../../examples/ltc.toml"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("scene, 2 objects, 0 point lights, 1 area light"),
        "{text}"
    );
    assert!(text.contains("features:   area lights"), "{text}");
    for (method, verdict) in [
        ("ltc", "renders every feature"),
        ("nearfield", "renders every feature"),
        ("sh", "cannot render area lights"),
    ] {
        assert!(
            text.lines()
                .any(|l| l.trim_start().starts_with(method) && l.ends_with(verdict)),
            "{method}: {verdict} in:\n{text}"
        );
    }
    // A method whose features fit but whose options do not model an
    // object's BRDF says so (`Relighter::check_objects`), as its render
    // would refuse it.
    let glossy = tmp("info-glossy.toml");
    let text = info_of(
        &glossy,
        "[[object]]\nbuiltin = \"sphere\"\nbrdf = \"phong:20\"\n",
    );
    assert!(
        line_of(&text, "ndf").contains("cannot render object 1: its BRDF phong:20 is not lambert"),
        "{text}"
    );
    let out = relight(&[
        "render",
        glossy.to_str().unwrap(),
        "--method",
        "ndf",
        "--size",
        "8x8",
        "--out",
        tmp("g.png").to_str().unwrap(),
    ]);
    assert_clean_error(&out, "its BRDF phong:20 is not lambert");
    // A ground quad under a sphere is named as too coarse for per-vertex
    // shadows (`Scene::coarse_objects`: its two triangles are √(2 · 8) = 4
    // across where the sphere, 1.7 across, casts its shadow); the sphere is
    // not.
    let text = info_of(
        &tmp("info-quad.toml"),
        "[[object]]\nbuiltin = \"ground\"\n[[object]]\nbuiltin = \"sphere\"\nscale = 0.5\ntranslate = [0.0, 0.6, 0.0]\n",
    );
    assert!(
        line_of(&text, "object 1:").contains(
            "vertices about 4.00 apart under object 2: too coarse for per-vertex shadows (triple, nearfield and wavelet --ao shade a copy refined to 4225 vertices)"
        ),
        "{text}"
    );
    assert!(!line_of(&text, "object 2:").contains("apart"), "{text}");
    // A ground 400 units across under the same sphere: the refined copy
    // stops at the vertex cap, and the line says the mesh must be finer.
    let text = info_of(
        &tmp("info-huge.toml"),
        "[[object]]\nbuiltin = \"ground\"\nscale = 100.0\n[[object]]\nbuiltin = \"sphere\"\nscale = 0.5\ntranslate = [0.0, 0.6, 0.0]\n",
    );
    assert!(
        line_of(&text, "object 1:").contains("still too coarse: give it a finer mesh"),
        "{text}"
    );
    // `--refine-coarse on` (the default) shades the quad on a refined copy,
    // `off` as given; each says so. Another value, or the flag on a method
    // without per-vertex visibility, is refused.
    let (quad, png, cache) = (
        tmp("info-quad.toml"),
        tmp("refine.png"),
        tmp("refine-cache"),
    );
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            quad.to_str().unwrap(),
            "--size",
            "16x9",
            "--out",
            png.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        relight(&args)
    };
    let ao = [
        "--cache",
        cache.to_str().unwrap(),
        "--method",
        "wavelet",
        "--ao",
        "8",
        "--n",
        "16",
        "--ntess",
        "4",
        "--terms",
        "32",
        "--visibility",
        "--approximate",
    ];
    for (switch, says) in [
        ("on", "shaded on a copy refined to 4225 vertices"),
        ("off", "the shadows between them are lost"),
    ] {
        let out = render(&[&ao[..], &["--refine-coarse", switch]].concat());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success() && err.contains(says),
            "{switch}: {err}"
        );
    }
    assert_clean_error(
        &render(&[&ao[..], &["--refine-coarse", "maybe"]].concat()),
        "--refine-coarse maybe: expected `on` or `off`",
    );
    assert_clean_error(
        &render(&["--method", "sh", "--refine-coarse", "off"]),
        "--refine-coarse does not apply to method sh",
    );
    let bad = tmp("info-bad.toml");
    std::fs::write(&bad, "[[object]]\nbuiltin = \"cube\"\n").unwrap();
    assert_clean_error(
        &relight(&["info", bad.to_str().unwrap()]),
        "object[1].builtin: unknown built-in mesh `cube`",
    );
    let other = tmp("info-other.xyz");
    std::fs::write(&other, "x").unwrap();
    assert_clean_error(
        &relight(&["info", other.to_str().unwrap()]),
        "or a .toml scene file",
    );
}

/// A warning is shown once per run even when its file is read twice, and
/// `ndf bake --out` naming a file is refused before the bake.
#[test]
fn warnings_once_and_ndf_bake_out_is_a_folder() {
    let neg = tmp("negative.exr");
    let mut px = vec![glam::Vec3::splat(0.5); 4];
    px[0].x = -1.0;
    relight_assets::write_exr(&neg, 2, 2, &px).unwrap();
    let neg = neg.to_str().unwrap();
    let out = relight(&["compare", neg, neg, "--region", "all"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert_eq!(err.matches("clamped 1 pixel(s)").count(), 1, "{err}");

    let file = tmp("not-a-folder");
    std::fs::write(&file, "x").unwrap();
    let Some(map) = common::data("normalmaps/0000.png") else {
        return;
    };
    assert_clean_error(
        &relight(&[
            "ndf",
            "bake",
            map.to_str().unwrap(),
            "--brdf",
            "ggx:0.3",
            "--out",
            file.to_str().unwrap(),
        ]),
        "is a file, not a folder",
    );
}

/// A method without environment lighting, asked to render a scene that has
/// one: `render` says how to turn the default studio map off; the demo,
/// whose scene is built in, shows the refusal without that advice and says
/// that no method rendered.
#[test]
fn a_refused_environment_is_explained_where_the_user_built_the_scene() {
    let out = relight(&[
        "render",
        "--mesh",
        "sphere",
        "--method",
        "ltc",
        "--size",
        "16x12",
        "--out",
        tmp("refused-env.png").to_str().unwrap(),
    ]);
    assert_clean_error(&out, "method ltc cannot render environment lighting");
    assert!(String::from_utf8_lossy(&out.stderr).contains("`--env black`"));

    let out = relight(&[
        "-q",
        "demo",
        "--method",
        "ltc",
        "--size",
        "32x18",
        "--out",
        tmp("demo-ltc.png").to_str().unwrap(),
    ]);
    let (err, text) = (
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout),
    );
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("cannot render environment lighting") && !err.contains("--env"),
        "{err}"
    );
    assert!(text.contains("(no method rendered the scene)"), "{text}");
}

/// A reader that stops early (`relight info … | head -1`) ends the run
/// quietly, not with a panic on the broken pipe.
#[cfg(unix)]
#[test]
fn a_closed_stdout_is_no_panic() {
    use std::io::{BufRead, BufReader};
    let exr = tmp("pipe.exr");
    relight_assets::write_exr(&exr, 2, 1, &[glam::Vec3::ONE; 2]).unwrap();
    let exr = exr.to_str().unwrap().to_string();
    // Far more than a pipe buffer holds (~300 bytes per file).
    let args: Vec<&str> = std::iter::once("info")
        .chain(std::iter::repeat_n(exr.as_str(), 2000))
        .collect();
    let mut child = Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(&args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run relight");
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.contains("pipe.exr"), "{first}");
    // stdout is dropped here: the pipe is closed.
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.status.success(), "the run should have been cut short");
}
