//! Shared helpers for the tests that read `../shared/data`.

use std::path::PathBuf;

/// `../shared/data` relative to the workspace root, or `None` (with a
/// message) when it is absent. With `CI` set a missing directory fails.
pub fn data_dir() -> Option<PathBuf> {
    let root = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    let dir = root.join("../shared/data");
    if dir.join("hdri").is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but the shared test data is missing at {}",
        dir.display()
    );
    eprintln!(
        "skipping: shared test data not found at {} (set up ../shared/data to run)",
        dir.display()
    );
    None
}

/// Files of `sub` with extension `ext`, sorted.
pub fn files(dir: &std::path::Path, sub: &str, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir.join(sub))
        .map(|r| r.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    v.retain(|p| p.extension().and_then(|e| e.to_str()) == Some(ext));
    v.sort();
    v
}
