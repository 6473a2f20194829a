//! Runs `verify_sh` on the default scene and on `park` with GGX 0.3 (what
//! `relight verify sh` does), printing JSON rows. `--full` for the full run.
//! Usage: cargo run --release -p relight-shlight --example verify_sh [-- --full] [-- --normal-map FILE]
use relight_brdf::BrdfSpec;
use relight_render::NoProgress;
use relight_shlight::{NormalMap, VerifyOptions, VerifyScene, verify_sh};
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let full = args.iter().any(|a| a == "--full");
    let nm_path = args
        .iter()
        .position(|a| a == "--normal-map")
        .map(|i| args[i + 1].clone());
    let opts = VerifyOptions::new(!full);
    let default = relight_scene::default_scene(opts.width, opts.height);
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../../shared/data");
    let mut scenes = vec![("default", default.clone())];
    match relight_scene::load_environment(&format!("{root}/hdri/park.exr")) {
        Ok((env, _)) => {
            let ggx = "ggx:0.3".parse::<BrdfSpec>().expect("spec").build();
            let mut park = relight_scene::with_brdf(&default, &ggx);
            park.env = env;
            scenes.push(("park-ggx0.3", park));
        }
        Err(e) => eprintln!("skipping park: {e}"),
    }
    let nm = nm_path.map(|p| {
        let (img, _) = relight_assets::image_io::read_image_with(
            Path::new(&p),
            relight_assets::image_io::ColorEncoding::Linear,
        )
        .expect("normal map");
        NormalMap::from_rgb(img.width, img.height, &img.pixels).expect("normal map")
    });
    let vs: Vec<VerifyScene> = scenes
        .iter()
        .map(|(n, s)| VerifyScene { name: n, scene: s })
        .collect();
    let t = std::time::Instant::now();
    let rows =
        verify_sh(&vs, nm.as_ref().map(|m| ("file", m)), &opts, &NoProgress).expect("verify");
    for r in &rows {
        println!(
            "{:<12} n={:<2} {:<8} nm={:<5} err={:.4} ref_se={:.4} px={} shade={:.1}ms",
            r.scene,
            r.order,
            r.rotation,
            r.normal_map,
            r.rel_rms_error,
            r.reference_rel_std_error,
            r.pixels,
            r.ms_shade
        );
    }
    eprintln!("total {:.1} s", t.elapsed().as_secs_f64());
}
