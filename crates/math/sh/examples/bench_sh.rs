//! Prints `relight_sh::bench_sh` as a table: `cargo run --release -p relight-sh --example bench_sh [quick]`.
fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    println!(
        "{:<18} {:>5} {:>10} {:>10} {:>10}  note",
        "method", "order", "ns_build", "ns_apply", "ns_total"
    );
    for r in relight_sh::bench_sh(quick) {
        println!(
            "{:<18} {:>5} {:>10.1} {:>10.1} {:>10.1}  {}",
            r.method, r.order, r.ns_build, r.ns_apply, r.ns_total, r.note
        );
    }
}
