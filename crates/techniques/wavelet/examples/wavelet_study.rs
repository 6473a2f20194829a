//! Runs the wavelet studies and prints JSON rows:
//! `cargo run --release -p relight-wavelet --example wavelet_study -- bench|bench-quick|verify-sphere|rotation`.

use relight_render::NoProgress;
use relight_wavelet::study::{
    BenchOptions, VerifyOptions, bench_wavelet, smooth_sky, sphere_scene, sun_sky, verify_rotation,
    verify_wavelet,
};

fn main() {
    let what = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "bench-quick".into());
    let arg2: Option<String> = std::env::args().nth(2);
    match what.as_str() {
        "bench" | "bench-quick" => {
            let mut o = if what == "bench" {
                BenchOptions::full()
            } else {
                BenchOptions::quick()
            };
            if let Some(b) = arg2 {
                // e.g. "64,32,1;128,32,1"
                o.bakes = b
                    .split(';')
                    .map(|t| {
                        let v: Vec<usize> = t.split(',').map(|x| x.parse().unwrap()).collect();
                        (v[0], v[1], v[2] as u16)
                    })
                    .collect();
            }
            if let Some(v) = std::env::args().nth(3) {
                o.vertices = v.split(',').map(|x| x.parse().unwrap()).collect();
            }
            for r in bench_wavelet(&o, &[], &NoProgress).unwrap() {
                println!("{}", serde_json::to_string(&r).unwrap());
            }
        }
        "verify-sphere" => {
            let brdf = "ggx:0.1".parse::<relight_brdf::BrdfSpec>().unwrap().build();
            let scenes = vec![("sphere".to_string(), sphere_scene(brdf, 256, 256))];
            let mut o = VerifyOptions::quick();
            o.cache_dir = None;
            o.brdfs = vec!["ggx:0.1".into(), "lambert".into()];
            if let Ok(t) = std::env::var("VIEWS") {
                o.views = t.parse().unwrap();
            }
            if let Ok(t) = std::env::var("SPP") {
                o.spp = t.parse().unwrap();
            }
            if let Ok(t) = std::env::var("BRDFS") {
                o.brdfs = t.split(';').map(String::from).collect();
            }
            if let Ok(t) = std::env::var("BRDF_TERMS") {
                o.brdf_terms = t.parse().unwrap();
            }
            if let Some(c) = arg2 {
                o.configs = c
                    .split(';')
                    .map(|t| {
                        let v: Vec<usize> = t.split(',').map(|x| x.parse().unwrap()).collect();
                        (v[0], v[1], v[2] as u16, v[3])
                    })
                    .collect();
            }
            for r in verify_wavelet(&scenes, &o, &NoProgress).unwrap() {
                println!("{}", serde_json::to_string(&r).unwrap());
            }
        }
        "verify-default" => {
            let scenes = vec![(
                "default".to_string(),
                relight_scene::default_scene(320, 180),
            )];
            let mut o = VerifyOptions::quick();
            o.cache_dir = None;
            o.spp = 256;
            o.views = 64;
            o.brdfs = vec!["ggx:0.1".into(), "lambert".into()];
            if let Ok(t) = std::env::var("VIEWS") {
                o.views = t.parse().unwrap();
            }
            if let Ok(t) = std::env::var("SPP") {
                o.spp = t.parse().unwrap();
            }
            if let Ok(t) = std::env::var("BRDFS") {
                o.brdfs = t.split(';').map(String::from).collect();
            }
            if let Ok(t) = std::env::var("BRDF_TERMS") {
                o.brdf_terms = t.parse().unwrap();
            }
            if let Some(c) = arg2 {
                o.configs = c
                    .split(';')
                    .map(|t| {
                        let v: Vec<usize> = t.split(',').map(|x| x.parse().unwrap()).collect();
                        (v[0], v[1], v[2] as u16, v[3])
                    })
                    .collect();
            }
            for r in verify_wavelet(&scenes, &o, &NoProgress).unwrap() {
                println!("{}", serde_json::to_string(&r).unwrap());
            }
        }
        "rotation" => {
            for (name, f) in [
                (
                    "smooth",
                    &smooth_sky() as &(dyn Fn(glam::Vec3) -> glam::Vec3 + Sync),
                ),
                ("sun", &sun_sky()),
            ] {
                for r in verify_rotation(name, f, 64, &NoProgress).unwrap() {
                    println!("{}", serde_json::to_string(&r).unwrap());
                }
            }
        }
        "vertex-check" => {
            use relight_wavelet::render::WaveletRenderer;
            use relight_wavelet::study::direct_radiance;
            use relight_wavelet::{BrdfBakeParams, RotationParams, bake_brdf, bake_rotation};
            use std::sync::Arc;
            let n: usize = arg2.as_deref().unwrap_or("64").parse().unwrap();
            let rot = Arc::new(bake_rotation(&RotationParams::new(n, 32, 1), &NoProgress).unwrap());
            let scene = sphere_scene(
                "lambert".parse::<relight_brdf::BrdfSpec>().unwrap().build(),
                64,
                64,
            );
            let env = scene.env.clone();
            let f = move |d: glam::Vec3| env.eval(d);
            for terms in [256usize] {
                let mut r = WaveletRenderer::new(rot.clone(), terms).unwrap();
                r.set_lighting(&scene.env, glam::Mat3::IDENTITY).unwrap();
                for spec in ["lambert", "ggx:0.1"] {
                    let brdf = spec.parse::<relight_brdf::BrdfSpec>().unwrap().build();
                    let bb = bake_brdf(
                        &BrdfBakeParams::new(spec, n / 2, 64, 128),
                        brdf.as_ref(),
                        &NoProgress,
                    )
                    .unwrap();
                    let mesh = &scene.objects[0].mesh;
                    let eye = scene.camera.eye;
                    let idx: Vec<usize> = (0..mesh.positions.len())
                        .step_by(7)
                        .filter(|&i| {
                            mesh.normals[i].dot((eye - mesh.positions[i]).normalize()) > 0.1
                        })
                        .collect();
                    let grid = std::env::args().nth(3).is_some();
                    let nor: Vec<glam::Vec3> = idx
                        .iter()
                        .map(|&i| {
                            let nn = mesh.normals[i];
                            if grid {
                                let (k, w) = relight_wavelet::octa::normal_bilinear(nn, 32);
                                let b = (0..4).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap();
                                relight_wavelet::octa::grid_normal(k[b] as usize, 32).as_vec3()
                            } else {
                                nn
                            }
                        })
                        .collect();
                    let pos: Vec<glam::Vec3> = nor.clone();
                    let mut got = vec![glam::Vec3::ZERO; pos.len()];
                    r.shade_vertices(&pos, &nor, &bb, eye, None, &mut got)
                        .unwrap();
                    let (mut num, mut den) = (0.0f64, 0.0f64);
                    for i in 0..pos.len() {
                        let w = direct_radiance(
                            &f,
                            brdf.as_ref(),
                            nor[i],
                            (eye - pos[i]).normalize(),
                            512,
                        );
                        num += f64::from((got[i] - w).length_squared());
                        den += f64::from(w.length_squared());
                    }
                    println!(
                        "n {n} terms {terms} {spec}: per-vertex rel RMS vs quadrature = {:.4} ({} vertices), brdf energy kept {:.4}",
                        (num / den).sqrt(),
                        pos.len(),
                        bb.energy_fraction
                    );
                }
            }
        }
        other => eprintln!("unknown study {other}"),
    }
}
