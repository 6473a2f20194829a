//! `relight bake nearfield` and the nearfield transport cache through the
//! CLI: a bake then a load, `relight cache list` shows the entry, a render
//! reads it, a corrupted entry is re-baked with a warning, bad flags are one
//! line.

use crate::common::{assert_one_line_error, tmp};
use std::path::Path;
use std::process::{Command, Output};

const SCENE: [&str; 7] = [
    "--mesh",
    "ground-grid",
    "--env",
    "black",
    "--light-center",
    "0,1.5,0",
    "--visibility",
];

fn run(cache: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(args)
        .env("RELIGHT_CACHE", cache)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run relight")
}

fn ok(out: &Output) -> (String, String) {
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    );
    assert!(out.status.success(), "{se}");
    (so, se)
}

#[test]
fn bake_load_list_render_and_a_corrupt_entry() {
    let cache = tmp("nf-cache");
    let _ = std::fs::remove_dir_all(&cache);
    let copy = tmp("nf-bake.bin");
    let mut bake = vec!["bake", "nearfield"];
    bake.extend(SCENE);
    bake.extend(["--order", "8"]);
    let mut with_out = bake.clone();
    with_out.extend(["--out", copy.to_str().unwrap()]);
    let (text, _) = ok(&run(&cache, &with_out));
    assert!(text.contains(": baked in"), "{text}");
    let (text, _) = ok(&run(&cache, &bake));
    assert!(text.contains("loaded from the cache"), "{text}");
    let (list, _) = ok(&run(&cache, &["cache", "list"]));
    assert!(
        list.contains("nearfield") && list.contains("n=8 face=4 objects=1 shadows format v1"),
        "{list}"
    );
    let entry = std::fs::read_dir(cache.join("nearfield"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "bin"))
        .expect("a cache entry");
    assert_eq!(
        std::fs::read(&entry).unwrap(),
        std::fs::read(&copy).unwrap()
    );
    // A render of the same scene reads it; a corrupted one is re-baked with a warning.
    let png = tmp("nf-cached.png");
    let mut render = vec!["render", "--method", "nearfield", "--size", "32x20"];
    render.extend(SCENE);
    render.extend(["--order", "8", "--out", png.to_str().unwrap()]);
    let (_, err) = ok(&run(&cache, &render));
    assert!(!err.contains("re-baked"), "{err}");
    let mut bytes = std::fs::read(&entry).unwrap();
    let at = bytes.len() - 8;
    bytes[at] ^= 1;
    std::fs::write(&entry, &bytes).unwrap();
    let (_, err) = ok(&run(&cache, &render));
    assert!(
        err.contains("re-baked") && err.contains("checksum") && !err.contains("panicked"),
        "{err}"
    );
    let (text, _) = ok(&run(&cache, &bake));
    assert!(text.contains("loaded from the cache"), "replaced: {text}");
    // `cache clear nearfield` deletes it.
    let (text, _) = ok(&run(&cache, &["cache", "clear", "nearfield"]));
    assert!(text.contains("deleted 1 of 1 entries"), "{text}");
}

#[test]
fn bad_bake_flags_are_one_line() {
    let cache = tmp("nf-cache-bad");
    let mut a = vec!["bake", "nearfield"];
    a.extend(SCENE);
    a.extend(["--order", "12"]);
    assert_one_line_error(&run(&cache, &a), &["order", "power of two"]);
    // The studio environment: the method refuses it by name.
    assert_one_line_error(
        &run(
            &cache,
            &[
                "bake",
                "nearfield",
                "--mesh",
                "ground-grid",
                "--light-center",
                "0,1.5,0",
            ],
        ),
        &["nearfield"],
    );
    let mut a = vec!["bake", "nearfield"];
    a.extend(SCENE);
    a.extend(["--out", "/nonexistent-dir/x.bin"]);
    assert_one_line_error(&run(&cache, &a), &["--out"]);
}

/// `--cache DIR` puts the transport bake in DIR instead of
/// `$RELIGHT_CACHE/nearfield`, for `bake nearfield` and for a render, and
/// `cache list --cache DIR` lists it.
#[test]
fn cache_flag_picks_the_folder() {
    let env_cache = tmp("nf-cache-env");
    let _ = std::fs::remove_dir_all(&env_cache);
    let dir = tmp("nf-cache-flag");
    let _ = std::fs::remove_dir_all(&dir);
    let entries = |d: &Path| -> usize {
        std::fs::read_dir(d).map_or(0, |r| {
            r.filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "bin"))
            })
            .count()
        })
    };
    let flag = dir.to_str().unwrap();
    let mut bake = vec!["bake", "nearfield"];
    bake.extend(SCENE);
    bake.extend(["--order", "8", "--cache", flag]);
    let (text, _) = ok(&run(&env_cache, &bake));
    assert!(text.contains(": baked in"), "{text}");
    assert_eq!(entries(&dir), 1, "the bake is in --cache");
    assert_eq!(
        entries(&env_cache.join("nearfield")),
        0,
        "nothing in $RELIGHT_CACHE"
    );
    let png = tmp("nf-cache-flag.png");
    let mut render = vec!["render", "--method", "nearfield", "--size", "32x20"];
    render.extend(SCENE);
    render.extend([
        "--order",
        "8",
        "--cache",
        flag,
        "--out",
        png.to_str().unwrap(),
    ]);
    let (_, err) = ok(&run(&env_cache, &render));
    assert!(!err.contains("re-baked"), "{err}");
    assert_eq!(entries(&dir), 1, "the render read the same entry");
    assert_eq!(entries(&env_cache.join("nearfield")), 0);
    let (list, _) = ok(&run(&env_cache, &["cache", "list", "--cache", flag]));
    assert!(list.contains("n=8 face=4 objects=1 shadows"), "{list}");
}
