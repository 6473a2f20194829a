//! The `--light-*` area-light scene flags (issue 13): they add an
//! `[[area_light]]` or edit one (`--light-index` picks which) for every
//! method, and a bad value is a one-line error naming the flag.

use crate::common::{assert_one_line_error, tmp};
use std::process::{Command, Output};

/// Runs `relight` with the nearfield transport cache in a scratch folder.
fn relight(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(args)
        .env("RELIGHT_CACHE", tmp("flags-cache"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run relight")
}

/// A floor under a black sky: no scene file, no shared data.
const FLOOR: [&str; 6] = ["--mesh", "ground-grid", "--env", "black", "--size", "40x24"];

fn mean_of(exr: &std::path::Path) -> f32 {
    let (img, _) = relight_assets::read_image(exr).expect("EXR readable");
    img.pixels.iter().map(|p| p.x + p.y + p.z).sum::<f32>() / img.pixels.len() as f32
}

fn render(out: &std::path::Path, extra: &[&str]) {
    let mut args = vec!["-q", "render"];
    args.extend(FLOOR);
    args.extend(extra);
    args.extend(["--out", out.to_str().unwrap()]);
    let o = relight(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn flags_add_a_light_that_nearfield_and_the_reference_render() {
    let tex = tmp("light-texture.exr");
    let texels: Vec<glam::Vec3> = (0..64)
        .map(|i| glam::Vec3::new((i % 8) as f32 / 8.0, 1.0, 0.5))
        .collect();
    relight_assets::write_exr(&tex, 8, 8, &texels).unwrap();
    let light = [
        "--light-center",
        "0.2,1.2,-0.1",
        "--light-size",
        "1.2,0.8",
        "--light-orientation",
        "0,90,0",
    ];
    let (a, b) = (tmp("flags-a.png"), tmp("flags-b.png"));
    let mut one = light.to_vec();
    one.extend([
        "--method",
        "nearfield",
        "--order",
        "8",
        "--light-intensity",
        "2",
    ]);
    render(&a, &one);
    let mut two = light.to_vec();
    two.extend([
        "--method",
        "nearfield",
        "--order",
        "8",
        "--light-intensity",
        "4,4,4",
    ]);
    render(&b, &two);
    let (ma, mb) = (
        mean_of(&a.with_extension("exr")),
        mean_of(&b.with_extension("exr")),
    );
    assert!(ma > 0.01, "the added light lights the floor: mean {ma}");
    assert!(
        (mb / ma - 2.0).abs() < 1e-3,
        "twice the intensity: {ma} → {mb}"
    );
    // A texture and a turned light, through the reference too.
    let c = tmp("flags-c.png");
    let mut three = light[..4].to_vec();
    three.extend([
        "--light-texture",
        tex.to_str().unwrap(),
        "--light-orientation",
        "30,90,0",
        "--method",
        "reference",
        "--spp",
        "2",
    ]);
    render(&c, &three);
    assert!(mean_of(&c.with_extension("exr")) > 0.0);
}

#[test]
fn bad_light_values_name_the_flag() {
    let out = tmp("flags-bad.png");
    let out = out.to_str().unwrap();
    let cases: [(&[&str], &str); 6] = [
        (
            &["--light-center", "0,1,0", "--light-size", "1,0"],
            "--light-size",
        ),
        (&["--light-center", "0,inf,0"], "--light-center"),
        (
            &["--light-center", "0,1,0", "--light-intensity", "-1"],
            "--light-intensity",
        ),
        (
            &["--light-center", "0,1,0", "--light-orientation", "0,nan,0"],
            "--light-orientation",
        ),
        (
            &[
                "--light-center",
                "0,1,0",
                "--light-texture",
                "no-such-light.png",
            ],
            "--light-texture",
        ),
        (&["--light-size", "1,1"], "--light-center"),
    ];
    for (extra, flag) in cases {
        let mut args = vec!["render", "--method", "nearfield"];
        args.extend(FLOOR);
        args.extend(extra);
        args.extend(["--out", out]);
        assert_one_line_error(&relight(&args), &[flag]);
    }
    // A method without area lights refuses the added light by its usual error.
    let mut args = vec!["render", "--method", "sh"];
    args.extend(FLOOR);
    args.extend(["--light-center", "0,1,0", "--out", out]);
    assert_one_line_error(&relight(&args), &["sh"]);
}

/// `--light-sampling wavelet` (issue 13's wavelet importance sampling)
/// renders the same light as the default MIS (image means within 3 %, both
/// at 32 spp on ~900 floor pixels); a bad strategy or the flag on another
/// method is a one-line error naming the flag.
#[test]
fn light_sampling_flag_picks_the_reference_strategy() {
    let light = [
        "--light-center",
        "0.2,1.2,-0.1",
        "--light-size",
        "1.2,0.8",
        "--light-orientation",
        "0,90,0",
        "--light-intensity",
        "4",
        "--method",
        "reference",
        "--spp",
        "32",
    ];
    let (w, m) = (tmp("sampling-wavelet.png"), tmp("sampling-mis.png"));
    let mut a = light.to_vec();
    a.extend(["--light-sampling", "wavelet"]);
    render(&w, &a);
    render(&m, &light);
    let (mw, mm) = (
        mean_of(&w.with_extension("exr")),
        mean_of(&m.with_extension("exr")),
    );
    assert!(mm > 0.01, "the light lights the floor: {mm}");
    assert!((mw / mm - 1.0).abs() < 0.03, "wavelet {mw} vs MIS {mm}");
    let out = tmp("sampling-bad.png");
    let out = out.to_str().unwrap();
    let mut bad = vec!["render"];
    bad.extend(FLOOR);
    bad.extend(light);
    bad.extend(["--light-sampling", "best", "--out", out]);
    assert_one_line_error(&relight(&bad), &["--light-sampling", "best"]);
    let mut other = vec!["render"];
    other.extend(FLOOR);
    other.extend([
        "--method",
        "sh",
        "--light-sampling",
        "wavelet",
        "--out",
        out,
    ]);
    assert_one_line_error(&relight(&other), &["--light-sampling", "sh"]);
}

/// With several `[[area_light]]`s the flags need `--light-index` (from 1),
/// and edit only that light: the two lights' images, each with the other
/// turned off by `--light-intensity 0`, add up to the image of both
/// (nearfield propagates each light on its own).
#[test]
fn light_index_picks_the_light_the_flags_edit() {
    let scene = tmp("two-lights.toml");
    std::fs::write(
        &scene,
        r#"visibility = false
[environment]
builtin = "black"
[camera]
eye = [0.0, 2.0, 3.4]
target = [0.0, 0.3, 0.0]
fov = 45.0
size = [40, 24]
[[object]]
builtin = "ground-grid"
brdf = "lambert:0.7"
[[area_light]]
center = [0.0, 1.2, 0.0]
size = [1.0, 0.6]
normal = [0.0, -1.0, 0.0]
intensity = 2.0
[[area_light]]
center = [-1.0, 1.2, -0.5]
size = [0.4, 0.4]
normal = [0.0, -1.0, 0.0]
intensity = [1.0, 2.0, 3.0]
"#,
    )
    .unwrap();
    let scene = scene.to_str().unwrap();
    let run = |name: &str, extra: &[&str]| -> f32 {
        let out = tmp(name);
        let mut args = vec![
            "-q",
            "render",
            scene,
            "--method",
            "nearfield",
            "--order",
            "8",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = relight(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        mean_of(&out.with_extension("exr"))
    };
    let both = run("index-both.png", &[]);
    let first = run(
        "index-first.png",
        &["--light-index", "2", "--light-intensity", "0"],
    );
    let second = run(
        "index-second.png",
        &["--light-index", "1", "--light-intensity", "0"],
    );
    assert!(first > 0.01 && second > 0.01, "{first} {second}");
    assert!(
        ((first + second) / both - 1.0).abs() < 2e-3,
        "{first} + {second} vs {both}"
    );
    let out = tmp("index-bad.png");
    let out = out.to_str().unwrap();
    for (extra, words) in [
        (
            &["--light-intensity", "0"][..],
            &["--light-index", "has 2"][..],
        ),
        (
            &["--light-index", "3", "--light-intensity", "0"][..],
            &["--light-index", "1…2"][..],
        ),
        (
            &["--light-index", "0", "--light-intensity", "0"][..],
            &["--light-index", "1…2"][..],
        ),
        (
            &["--light-index", "2"][..],
            &["--light-index", "none is given"][..],
        ),
    ] {
        let mut args = vec!["render", scene, "--method", "nearfield", "--out", out];
        args.extend(extra);
        assert_one_line_error(&relight(&args), words);
    }
}

/// A light turned away from the floor lights nothing, in every method: the
/// scene check says which light and why, and the render that follows says
/// that the image is black. A floor with no light at all says that nothing
/// lights it. Both render (exit 0): the scene is valid, only dark.
#[test]
fn lighting_that_misses_the_objects_is_a_warning() {
    let out = tmp("away.png");
    let out = out.to_str().unwrap();
    for (method, extra, words) in [
        (
            "ltc",
            &[
                "--light-center",
                "0,1.2,0",
                "--light-orientation",
                "0,-90,0",
            ][..],
            &["area light 1 lights none of the objects", "image is black"][..],
        ),
        ("sh", &[][..], &["nothing lights it", "image is black"][..]),
    ] {
        let mut args = vec!["render"];
        args.extend(FLOOR);
        args.extend(extra);
        args.extend(["--method", method, "--out", out]);
        let o = relight(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        for w in words {
            assert!(
                err.lines().any(|l| l.contains("warning") && l.contains(w)),
                "{method}: no warning with {w:?} in\n{err}"
            );
        }
    }
}
