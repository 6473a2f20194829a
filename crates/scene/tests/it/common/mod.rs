//! Shared helpers for the scene-file tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The repository's `examples/` folder.
pub fn examples_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// True when `../shared/data` (reached from `examples/` as
/// `../../shared/data`) is present. Absent data fails the test under `CI`.
pub fn shared_data_present(what: &str) -> bool {
    let dir = examples_dir().join("../../shared/data");
    if dir.is_dir() {
        return true;
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but {} is missing (needed by {what})",
        dir.display()
    );
    eprintln!("skipping {what}: {} not found", dir.display());
    false
}

/// A fresh, empty temporary folder for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("relight-scene-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
