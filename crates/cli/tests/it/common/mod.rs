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

/// `name` in a scratch folder of this test binary and process. The tests
/// share it and a test binary has no hook at exit, so the folder outlives
/// the run; the first call removes the folders earlier runs left (those of
/// processes no longer alive, where `/proc` tells), so that at most one
/// run's outputs stay behind (they were ≈ 200 MB per run).
pub fn tmp(name: &str) -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let prefix = format!("relight-{}-test-", env!("CARGO_CRATE_NAME"));
        let root = std::env::temp_dir();
        if Path::new("/proc/self").exists()
            && let Ok(entries) = std::fs::read_dir(&root)
        {
            for e in entries.flatten() {
                let stale = e
                    .file_name()
                    .to_str()
                    .and_then(|n| n.strip_prefix(&prefix))
                    .and_then(|pid| pid.parse::<u32>().ok())
                    .is_some_and(|pid| {
                        pid != std::process::id()
                            && !Path::new("/proc").join(pid.to_string()).exists()
                    });
                if stale {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        let dir = root.join(format!("{prefix}{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    });
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
