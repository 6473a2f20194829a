//! Times light moves and texture-only frames of the near-field method on
//! `bench nearfield`'s first scene (≈ 39 K vertices, shadows), without the
//! rest of the bench: `cargo run --release -p relight-nearfield --example
//! nearfield_frames -- [source] [target] [steps]` (fractions, e.g. 0.01 0.2).
//! Prints wall ms per move (a new light position: affine maps, masks and
//! propagation) and per propagation (the light's texture edited in place);
//! with `RASTER` set in the environment also per rendered frame (the
//! Gouraud raster at 1200 × 900), and per reading of the warnings after a
//! lighting change (the face-clipping measure, which the viewer reads each
//! frame).

use relight_nearfield::face::LightFrame;
use relight_nearfield::method::{NearfieldMethod, NearfieldOptions};
use relight_nearfield::scenes::floor_and_sphere;
use relight_render::NoProgress;
use relight_render::method::Relighter;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: f64| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let (src, tgt, steps) = (arg(0, 0.01), arg(1, 0.2), arg(2, 10.0) as usize);
    let scene = floor_and_sphere(140, 196, 1200, 900, true);
    let mut m = NearfieldMethod::new(NearfieldOptions {
        source_terms: src,
        target_terms: tgt,
        ..NearfieldOptions::default()
    })?;
    let t = Instant::now();
    m.prepare(&scene, &NoProgress)?;
    println!("prepare {:.1} s", t.elapsed().as_secs_f64());
    let light = scene.area_lights[0].clone();
    let mut moved = light.clone();
    let (mut best_move, mut best_prop) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..steps {
        moved.center.x += 1e-3;
        let t = Instant::now();
        m.set_light_frame(&LightFrame::of(&moved));
        m.propagate();
        best_move = best_move.min(t.elapsed().as_secs_f64() * 1e3);
        best_prop = best_prop.min(m.propagate());
    }
    if std::env::var_os("RASTER").is_some() {
        let mut best = f64::INFINITY;
        let mut lit = scene.clone();
        for _ in 0..steps {
            lit.area_lights[0].center.x += 1e-3;
            m.set_lighting(&lit, &NoProgress)?;
            let t = Instant::now();
            let w = m.warnings();
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(w);
        }
        println!("warnings after a lighting change {best:.1} ms");
        let request = relight_render::method::FrameRequest::new(scene.camera);
        let mut best = f64::INFINITY;
        for _ in 0..steps * 10 {
            let t = Instant::now();
            m.render(&scene, &request, &NoProgress)?;
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
        }
        println!("raster {best:.1} ms");
    }
    println!(
        "{} %/{} %: move {best_move:.1} ms, propagate {best_prop:.1} ms (best of {steps})",
        src * 100.0,
        tgt * 100.0
    );
    Ok(())
}
