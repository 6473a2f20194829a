//! Helpers every CLI test binary shares: run the built `relight`, a scratch
//! folder per test binary and process, and the shared data (which must be
//! there when `CI` is set).
// Each test binary uses its own subset of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the built `relight` with `args` from the cli crate's folder.
pub fn relight(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run relight")
}

/// `name` in a scratch folder of this test binary and process.
pub fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "relight-{}-test-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// `rel` under `../shared/data`, or `None` (with a message) when it is
/// absent; absent data fails the test when `CI` is set.
pub fn data(rel: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data")
        .join(rel);
    if p.exists() {
        Some(p)
    } else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set and {} is missing",
            p.display()
        );
        eprintln!("skipping: {} is absent", p.display());
        None
    }
}

/// Exit code 1, one line on stderr starting `relight: `, containing every needle.
pub fn assert_one_line_error(out: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "exit code; stderr: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    assert!(err.starts_with("relight: "), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr should mention `{n}`: {err}");
    }
    err
}
