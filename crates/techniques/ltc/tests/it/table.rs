//! The committed table against a re-fit, and the regeneration hook.
//!
//! `RELIGHT_LTC_REGENERATE=1 cargo test --release -p relight-ltc --test it table::`
//! re-fits the whole table and rewrites `src/table_data.rs`.

use relight_ltc::fit::{FitOptions, fit_row, fit_table, table_source};
use relight_ltc::table;

#[test]
fn committed_table_matches_a_refit_of_two_rows() {
    let opts = FitOptions::default();
    if std::env::var_os("RELIGHT_LTC_REGENERATE").is_some() {
        let t = std::time::Instant::now();
        let cells = fit_table(&opts);
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/table_data.rs");
        std::fs::write(path, table_source(&cells, &opts)).expect("write src/table_data.rs");
        eprintln!(
            "fitted {} cells in {:.1} s",
            cells.len(),
            t.elapsed().as_secs_f64()
        );
        return;
    }
    assert_eq!(
        table::size(),
        opts.size,
        "table size differs from FitOptions::default()"
    );
    // Rows are fitted independently (each from its own θ_o = 0 start), so a
    // row re-fits alone. A rough and a glossy row.
    for i in [opts.size / 4, 3 * opts.size / 4] {
        let row = fit_row(i, &opts);
        for (j, got) in row.iter().enumerate() {
            let want = table::cell(i, j);
            for k in 0..6 {
                let tol = 1e-4 * want[k].abs().max(1e-2);
                assert!(
                    (got[k] - want[k]).abs() <= tol,
                    "cell ({i}, {j}) entry {k}: refit {} vs committed {} — regenerate (module docs)",
                    got[k],
                    want[k]
                );
            }
        }
    }
}
