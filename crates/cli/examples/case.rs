use relight_viewer::bench::{FrameBenchOptions, bench_case};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let idx: usize = args[1].parse().unwrap();
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let mut o = FrameBenchOptions::full();
    o.steps = 15;
    let case = o.cases[idx].clone();
    eprintln!("{} {}x{}", case.label, case.width, case.height);
    for _ in 0..reps {
        let r = bench_case(&case, &o, &relight_render::NoProgress).unwrap();
        println!(
            "view {:.1} light {:.1}",
            r.view_change_ms.unwrap_or(0.0),
            r.light_change_ms.unwrap_or(0.0)
        );
    }
}
