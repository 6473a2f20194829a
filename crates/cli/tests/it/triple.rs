//! `relight verify triple --quick` in CI: every identity and error row with a
//! target passes; the method's flags and refusals are one-line errors.

use crate::common;

use common::{assert_one_line_error, relight, tmp};

#[test]
fn verify_triple_quick_passes_every_target() {
    let cache = tmp("triple-cache");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(["-q", "verify", "triple", "--quick", "--json"])
        .env("RELIGHT_CACHE", &cache)
        .env(
            "RELIGHT_DATA",
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data"),
        )
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run relight");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    // Three JSON tables, one after another.
    let text = String::from_utf8_lossy(&out.stdout);
    let rows: Vec<serde_json::Value> = serde_json::Deserializer::from_str(&text)
        .into_iter::<serde_json::Value>()
        .map(|v| v.expect("JSON"))
        .flat_map(|v| v.as_array().cloned().unwrap_or_default())
        .collect();
    assert!(rows.len() >= 12, "{} rows", rows.len());
    for r in &rows {
        assert_ne!(r["pass"], serde_json::Value::Bool(false), "failed row {r}");
    }
}

#[test]
fn bad_terms_and_features_are_one_line_errors() {
    let png = tmp("bad.png");
    let out = relight(&[
        "-q",
        "render",
        "--mesh",
        "sphere",
        "--size",
        "16x12",
        "--method",
        "triple",
        "--terms",
        "100",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert_one_line_error(&out, &["triple", "terms"]);
    let out = relight(&[
        "-q",
        "render",
        "--mesh",
        "sphere",
        "--size",
        "16x12",
        "--method",
        "wavelet",
        "--twists",
        "4",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert_one_line_error(&out, &["--twists", "triple"]);
    // Adaptive selection shades per vertex from the isotropic table.
    let out = relight(&[
        "-q",
        "render",
        "--mesh",
        "sphere",
        "--size",
        "16x12",
        "--method",
        "triple",
        "--select",
        "adaptive",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert_one_line_error(&out, &["triple", "--shading vertex"]);
}
