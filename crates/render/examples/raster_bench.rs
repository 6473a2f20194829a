//! `cargo run --release -p relight-render --example raster_bench [triangles] [repeats]`:
//! prints [`relight_render::raster::bench_raster`] rows, then the process CPU
//! time per frame of each pass (a load-independent figure on a shared machine).
use glam::Vec3;
use relight_render::raster::{
    Background, DrawCall, RasterOptions, Rasterizer, bench_raster, torus_grid,
};
use relight_render::{Camera, Image};

/// User + system CPU time of this process in ms (from /proc; 0 elsewhere).
fn cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) * 10.0
}

fn main() {
    let mut args = std::env::args().skip(1);
    let tris: usize = args
        .next()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let repeats: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(10);
    for row in bench_raster(tris, 1920, 1080, repeats) {
        println!(
            "{:10} tris {:8} {}x{} covered {:8} threads {} : {:7.2} ms/frame (min {:7.2}) {:6.1} Mtri/s",
            row.mode,
            row.triangles,
            row.width,
            row.height,
            row.covered_pixels,
            row.threads,
            row.ms_per_frame,
            row.ms_min,
            row.mtri_per_s
        );
    }
    // CPU time per pass (same scene as bench_raster).
    let quads = tris / 2;
    let nv = ((quads as f64 / 2.5).sqrt().round() as usize).max(3);
    let (positions, triangles, uv) = torus_grid(quads.div_ceil(nv), nv);
    let colors: Vec<Vec3> = positions
        .iter()
        .map(|p| *p * 0.5 + Vec3::splat(0.5))
        .collect();
    let draws = [DrawCall::new(&positions, &triangles).with_attributes(2, &uv)];
    let camera = Camera {
        eye: Vec3::new(0.0, 1.6, 2.2),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
        width: 1920,
        height: 1080,
    };
    let options = RasterOptions::default()
        .cull_back()
        .fit_depth(&camera, &draws);
    let mut r = Rasterizer::new();
    let mut img = Image::new(1, 1);
    let bg = Background::Color(Vec3::ZERO);
    r.rasterize(&camera, &draws, &options).unwrap();
    let c = cpu_ms();
    for _ in 0..repeats {
        r.rasterize(&camera, &draws, &options).unwrap();
    }
    let raster = (cpu_ms() - c) / repeats as f64;
    let c = cpu_ms();
    for _ in 0..repeats {
        r.shade_gouraud(&draws, &[&colors], bg, &mut img).unwrap();
    }
    let gouraud = (cpu_ms() - c) / repeats as f64;
    let c = cpu_ms();
    for _ in 0..repeats {
        r.shade(
            &draws,
            |f| f.normal.abs() * (0.5 + 0.5 * f.attributes[0]),
            bg,
            &mut img,
        )
        .unwrap();
    }
    let pixel = (cpu_ms() - c) / repeats as f64;
    println!(
        "CPU ms per frame (all threads): rasterize {raster:.1}, gouraud shade {gouraud:.1}, per-pixel shade {pixel:.1}"
    );
}
