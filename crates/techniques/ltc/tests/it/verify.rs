//! `relight verify ltc --quick` through the library: every gated row passes.

use relight_ltc::verify::{VerifyOptions, verify_rows};
use relight_render::NoProgress;

#[test]
fn quick_verify_rows_pass() {
    let rows = verify_rows(&VerifyOptions::new(true), &NoProgress).unwrap();
    let gated: Vec<_> = rows.iter().filter(|r| r.pass.is_some()).collect();
    assert!(gated.len() >= 10, "{} gated rows", gated.len());
    for r in gated {
        assert_eq!(
            r.pass,
            Some(true),
            "{}: {} (target {:?})",
            r.check,
            r.value,
            r.target
        );
    }
}
