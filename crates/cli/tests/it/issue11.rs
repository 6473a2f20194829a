//! Issue 11's "smaller things", end to end through the `relight` binary:
//! outputs checked before any work, the bake cache, and one-line messages
//! that name the problem once (bad files, typos, wrong kinds of image).

use crate::common;

use common::{assert_one_line_error, data, relight, tmp};

/// Every command that writes a file refuses a path in a missing folder
/// before it starts (the render would take seconds, the bake minutes, and
/// nothing is printed about them).
#[test]
fn r11_output_paths_are_checked_before_work_starts() {
    let missing = "/nonexistent-relight-dir/x";
    let png = format!("{missing}.png");
    let exr = format!("{missing}.exr");
    let bin = format!("{missing}.bin");
    let json = format!("{missing}.json");
    let exr_in = tmp("in.exr");
    relight_assets::write_exr(&exr_in, 8, 4, &vec![glam::Vec3::ONE; 32]).unwrap();
    let exr_in = exr_in.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["render", "--mesh", "sphere", "--out", &png], "--out"),
        (vec!["demo", "--out", &png], "--out"),
        (vec!["bake", "rotation", "--out", &bin], "--out"),
        (
            vec!["bake", "brdf", "--brdf", "ggx:0.2", "--out", &bin],
            "--out",
        ),
        (vec!["fog", "tables", "--out", &exr], "--out"),
        (vec!["convert", exr_in, &exr], "output"),
        (vec!["sh", "irradiance", exr_in, "--out", &png], "--out"),
        (vec!["sh", "project", exr_in, "--out", &json], "--out"),
        (vec!["compare", exr_in, exr_in, "--diff", &png], "--diff"),
    ];
    for (args, flag) in cases {
        let out = relight(&args);
        let err =
            assert_one_line_error(&out, &[flag, "/nonexistent-relight-dir", "does not exist"]);
        assert!(
            !err.contains("prepared") && out.stdout.is_empty(),
            "{args:?} did work before failing: {err}"
        );
    }
    // A --plot folder that is a file.
    let file = tmp("not-a-folder");
    std::fs::write(&file, b"x").unwrap();
    let out = relight(&[
        "bench",
        "raster",
        "--quick",
        "--plot",
        file.to_str().unwrap(),
    ]);
    assert_one_line_error(&out, &["--plot", "is a file"]);
    assert!(out.stdout.is_empty(), "bench ran before the check");
    // A --cache folder that is a file, or lies under one: named by the flag,
    // in words (not "(os error 20)"), before the method prepares.
    let under = file.join("sub");
    for (dir, why) in [
        (file.to_str().unwrap(), "is a file, not a folder"),
        (under.to_str().unwrap(), "a part of the path is a file"),
    ] {
        for args in [
            vec!["render", "--method", "wavelet", "--mesh", "sphere"],
            vec!["render", "--method", "triple", "--mesh", "sphere"],
            vec!["bake", "nearfield", "../../examples/nearfield.toml"],
        ] {
            let mut args = args.clone();
            args.extend(["--cache", dir]);
            let out = relight(&args);
            let err = assert_one_line_error(&out, &["--cache", why]);
            assert!(
                !err.contains("os error") && !err.contains("prepared"),
                "{args:?}: {err}"
            );
        }
    }
    // The same through $RELIGHT_CACHE (no flag to name): the method's own
    // error names the folder, in words.
    for method in ["wavelet", "triple"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_relight"))
            .args(["-q", "render", "--method", method, "--mesh", "sphere"])
            .args(["--size", "16x8", "--out"])
            .arg(tmp("env-cache.png"))
            .env("RELIGHT_CACHE", &under)
            .output()
            .unwrap();
        let err = assert_one_line_error(
            &out,
            &[under.to_str().unwrap(), "a part of the path is a file"],
        );
        assert!(!err.contains("os error"), "{method}: {err}");
    }
}

#[test]
fn r11_cache_lists_and_clears_entries() {
    let dir = tmp("cache");
    std::fs::create_dir_all(&dir).unwrap();
    let rot = "rot-n16-m8-t4-q1-v1-0123456789abcdef.bin";
    let brdf = "brdf-ggx_0.2-m8-v8-k128-v1-fedcba9876543210.bin";
    std::fs::write(dir.join(rot), vec![0u8; 2_000_000]).unwrap();
    std::fs::write(dir.join(brdf), vec![0u8; 500_000]).unwrap();
    std::fs::write(dir.join("notes.txt"), b"not a cache entry").unwrap();
    let d = dir.to_str().unwrap();
    let out = relight(&["cache", "list", "--cache", d]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for want in [
        "rotation",
        "n=16 m=8 ntess=4 ntrunc=1",
        "2.0 MB",
        "brdf",
        "ggx_0.2 m=8 views=8 terms=128",
        "0.5 MB",
        "2 entries, 2.5 MB",
    ] {
        assert!(text.contains(want), "`{want}` missing from:\n{text}");
    }
    assert!(!text.contains("notes.txt"), "{text}");
    // The date column is today's (UTC), as YYYY-MM-DD HH:MM.
    let row = text.lines().find(|l| l.contains(rot)).unwrap();
    assert!(
        row.split_whitespace()
            .any(|w| w.len() == 10 && w.as_bytes()[4] == b'-' && w.starts_with("20")),
        "{row}"
    );
    // Filtered list and clear.
    let out = relight(&["cache", "list", "rot-", "--cache", d]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 entries"));
    let out = relight(&["cache", "clear", "rot-", "--cache", d]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("deleted 1 of 2 entries (2.0 MB)"));
    assert!(!dir.join(rot).exists() && dir.join(brdf).exists());
    let out = relight(&["cache", "clear", "--cache", d]);
    assert!(out.status.success());
    assert!(
        !dir.join(brdf).exists(),
        "clear without a pattern clears all"
    );
    assert!(dir.join("notes.txt").exists(), "other files are left alone");
    let out = relight(&["cache", "list", "--cache", d]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("(no entries)"));

    // The triple method's bakes, and the temp file of a write killed
    // mid-way (`.NAME.tmp-PID-N`, hidden), are entries too.
    let vis = "vis-m1-2-0123456789abcdef.bin";
    let partial = ".brdf-m2-32-fedcba9876543210.bin.tmp-4242-0";
    std::fs::write(dir.join(vis), vec![0u8; 1_000_000]).unwrap();
    std::fs::write(dir.join(partial), vec![0u8; 300_000]).unwrap();
    let out = relight(&["cache", "list", "--cache", d]);
    let text = String::from_utf8_lossy(&out.stdout);
    for want in [
        "triple",
        "visibility n=80 level 2",
        "partial",
        "interrupted bake: triple BRDF table n=320 views=32",
        "2 entries, 1.3 MB",
    ] {
        assert!(text.contains(want), "`{want}` missing from:\n{text}");
    }
    let out = relight(&["cache", "clear", "--cache", d]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("deleted 2 of 2 entries (1.3 MB)"));
    assert!(!dir.join(vis).exists() && !dir.join(partial).exists());
    assert!(dir.join("notes.txt").exists());

    // A cache path through a file: one line, the reason in words.
    let through = dir.join("notes.txt").join("cache");
    let out = relight(&["cache", "list", "--cache", through.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("reading cache folder")
            && err.contains("a part of the path is a file")
            && !err.contains("os error")
            && err.trim().lines().count() == 1,
        "{err}"
    );
}

#[test]
fn r11_messages_name_the_problem_once() {
    // A mistyped built-in lists the built-ins.
    let out = relight(&[
        "render",
        "--mesh",
        "spere",
        "--out",
        tmp("s.png").to_str().unwrap(),
    ]);
    assert_one_line_error(&out, &["--mesh spere", "sphere, torus, knot, ground"]);

    // A Radiance file cut after 20 bytes is truncated, not "format '32'".
    let short = tmp("short.hdr");
    std::fs::write(
        &short,
        &b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n"[..20],
    )
    .unwrap();
    let out = relight(&["info", short.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("short.hdr: truncated file") && !err.contains("'32'"),
        "{err}"
    );

    // A scene file naming a missing environment says so once.
    let scene = tmp("missing-env.toml");
    std::fs::write(
        &scene,
        "[environment]\nfile = \"nothere.exr\"\n\n[[object]]\nbuiltin = \"sphere\"\n",
    )
    .unwrap();
    let out = relight(&[
        "render",
        scene.to_str().unwrap(),
        "--out",
        tmp("m.png").to_str().unwrap(),
    ]);
    let err = assert_one_line_error(&out, &["missing-env.toml", "nothere.exr: file not found"]);
    assert_eq!(err.matches("not found").count(), 1, "{err}");
    assert_eq!(err.matches("nothere.exr").count(), 1, "{err}");

    // An HDR image is not a normal map.
    let hdr = tmp("env.hdr");
    std::fs::write(&hdr, b"#?RADIANCE\n").unwrap();
    let out = relight(&[
        "render",
        "--mesh",
        "sphere",
        "--method",
        "sh",
        "--normal-map",
        hdr.to_str().unwrap(),
        "--out",
        tmp("n.png").to_str().unwrap(),
    ]);
    assert_one_line_error(
        &out,
        &[
            "--normal-map",
            "env.hdr",
            "a Radiance HDR image is linear radiance, not a normal map",
        ],
    );

    // One triangle is "1 triangle".
    let obj = tmp("one.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let out = relight(&["info", obj.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("3 vertices, 1 triangle\n"), "{text}");

    // A NaN corner is named as such, and the warning names the file once.
    let nan = tmp("nan-corner.obj");
    std::fs::write(
        &nan,
        "v nan 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n",
    )
    .unwrap();
    let out = relight(&[
        "-q",
        "render",
        "--mesh",
        nan.to_str().unwrap(),
        "--method",
        "sh",
        "--size",
        "16x12",
        "--out",
        tmp("nan-corner.png").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let warning = err
        .lines()
        .find(|l| l.contains("nan-corner.obj"))
        .unwrap_or_else(|| panic!("no warning naming the file: {err}"));
    assert!(
        warning.contains("dropped 1 triangle(s) with a NaN or infinite vertex position"),
        "{warning}"
    );
    assert_eq!(warning.matches("nan-corner.obj").count(), 1, "{warning}");

    // `verify raster` was `verify reference` twice: it is gone.
    let out = relight(&["verify", "raster", "--quick"]);
    assert_eq!(out.status.code(), Some(2), "clap refuses the value");
    assert!(String::from_utf8_lossy(&out.stderr).contains("invalid value 'raster'"));
}

/// The truncated GLB of ../shared/data (the first 3000 bytes of the bunny)
/// is reported in words, not as Rust `Debug` output.
#[test]
fn r11_truncated_glb_error_is_words() {
    let Some(glb) = data("mesh/bunny.glb") else {
        return;
    };
    let cut = tmp("cut.glb");
    std::fs::write(&cut, &std::fs::read(glb).unwrap()[..3000]).unwrap();
    let out = relight(&["info", cut.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cut.glb: truncated file: GLB header says"),
        "{err}"
    );
    for debug in ["{", "length_read", "Length"] {
        assert!(!err.contains(debug), "Debug output `{debug}` in: {err}");
    }
}

/// Issue 14's `relight render --method sh --normal-filter …`: the SH
/// method's filtering mode renders (and changes the normal-mapped
/// Lambertian pixels), `none` is plain normal mapping, and a method
/// without the mode refuses the flag by name.
#[test]
fn sh_takes_a_normal_filter() {
    let Some(map) = data("normalmaps/0001.png") else {
        return;
    };
    let map = map.to_str().unwrap();
    let render = |filter: Option<&str>, name: &str| -> Vec<glam::Vec3> {
        let out = tmp(name);
        let mut args = vec![
            "-q",
            "render",
            "--mesh",
            "torus",
            "--brdf",
            "lambert:0.8",
            "--env",
            "studio",
            "--normal-map",
            map,
            "--size",
            "64x40",
            "--method",
            "sh",
            "--out",
        ];
        args.push(out.to_str().unwrap());
        if let Some(f) = filter {
            args.extend(["--normal-filter", f]);
        }
        let o = relight(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        relight_assets::read_image(&out.with_extension("exr"))
            .unwrap()
            .0
            .pixels
    };
    let plain = render(None, "nf-plain.png");
    assert_eq!(render(Some("none"), "nf-none.png"), plain);
    let filtered = render(Some("sh"), "nf-sh.png");
    let changed = filtered.iter().zip(&plain).filter(|(a, b)| a != b).count();
    assert!(changed > 100, "{changed} pixels changed");
    let out = tmp("nf-wavelet.png");
    let o = relight(&[
        "render",
        "--mesh",
        "torus",
        "--env",
        "studio",
        "--normal-filter",
        "sh",
        "--method",
        "wavelet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_one_line_error(&o, &["--normal-filter", "wavelet"]);
}
