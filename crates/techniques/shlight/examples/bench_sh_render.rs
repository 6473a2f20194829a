//! Per-frame time of the SH renderer on the default scene at 1280×720.
//! Usage: cargo run --release -p relight-shlight --example bench_sh_render
use relight_shlight::{NormalMap, ShRotationMethod, bench_sh_render};

fn main() {
    let scene = relight_scene::default_scene(1280, 720);
    let nm = NormalMap::bumps(256, 8, 0.6);
    let methods = [
        ShRotationMethod::Exact,
        ShRotationMethod::Zyz,
        ShRotationMethod::Taylor15,
        ShRotationMethod::None,
    ];
    let rows =
        bench_sh_render(&scene, Some(&nm), 1280, 720, &[3, 6, 10], &methods, 3).expect("bench");
    for r in rows {
        println!(
            "n={:<2} {:<8} nm={:<5} {}x{}: {:.1} ms/frame (first {:.1} ms)",
            r.order, r.rotation, r.normal_map, r.width, r.height, r.ms_frame, r.ms_first_frame
        );
    }
}
