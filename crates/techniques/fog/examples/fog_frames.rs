//! The viewer's fog frame path without the viewer (for `perf`): the default
//! scene at 960×540, with or without a medium and four point lights; per
//! step a camera orbit (view change) or an environment + light yaw (light
//! change), as `relight bench frames` drives it. Prints medians in ms.
//!
//! `cargo run --release -p relight-fog --example fog_frames -- [medium] [steps]`

use glam::Mat3;
use relight_fog::method::{FogOptions, FogRelighter};
use relight_render::method::{FrameRequest, Relighter, render_frame};
use relight_render::{Medium, NoProgress};
use std::time::Instant;

/// "median (min)" of `v`.
fn median(mut v: Vec<f64>) -> String {
    v.sort_by(f64::total_cmp);
    format!("{:.1} ({:.1})", v[v.len() / 2], v[0])
}

/// CPU time of every thread of this process so far, ms (Linux
/// `/proc/self/task/*/schedstat`; 0 elsewhere): steady under other load,
/// unlike the wall clock.
fn cpu_ms() -> f64 {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    dir.filter_map(|e| std::fs::read_to_string(e.ok()?.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .sum::<f64>()
        * 1e-6
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let medium = args.iter().any(|a| a == "medium");
    let steps: usize = args
        .iter()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(15);
    let (w, h) = (960, 540);
    let mut scene = relight_scene::default_scene(w, h);
    if medium {
        scene.medium = Some(Medium {
            beta: 0.1,
            albedo: 1.0,
            radius: 10.0,
        });
        scene.point_lights = relight_fog::default_scene_lights(4);
    }
    let mut m = FogRelighter::new(FogOptions::default()).expect("options");
    m.prepare(&scene, &NoProgress).expect("prepare");
    let base = scene.camera;
    let lights0 = scene.point_lights.clone();
    let env0 = scene.world_from_env;
    let mut request = FrameRequest {
        camera: base,
        aa: 1,
        progressive: true,
    };
    let first = render_frame(&mut m, &scene, &request, &NoProgress).expect("frame");
    if let Some(c) = &first.coverage {
        let covered = c.object_id.iter().filter(|&&o| o != 0).count();
        println!(
            "{covered} of {} pixels covered ({:.0} %)",
            c.object_id.len(),
            100.0 * covered as f64 / c.object_id.len().max(1) as f64
        );
    }
    let mut view = Vec::new();
    let cpu0 = cpu_ms();
    for i in 0..steps {
        let r = Mat3::from_rotation_y((4.0 * (i + 1) as f32).to_radians());
        let mut c = base;
        c.eye = c.target + r * (base.eye - base.target);
        request.camera = c;
        let t = Instant::now();
        let out = render_frame(&mut m, &scene, &request, &NoProgress).expect("frame");
        view.push(t.elapsed().as_secs_f64() * 1e3);
        if std::env::var_os("FOG_T").is_some() {
            eprintln!(
                "total {:.1} (method view_ms {:.1})",
                view[view.len() - 1],
                out.timings.view_ms
            );
        }
        std::hint::black_box(out);
    }
    let cpu_view = (cpu_ms() - cpu0) / steps as f64;
    let mut light = Vec::new();
    let target = base.target;
    let cpu0 = cpu_ms();
    for i in 0..steps {
        // 5° steps up to 35°, as `relight bench frames` turns: further turns
        // carry the fourth light into an object, which the method refuses.
        let r = Mat3::from_rotation_y((5.0 * (i % 7 + 1) as f32).to_radians());
        scene.world_from_env = r * env0;
        for (l, l0) in scene.point_lights.iter_mut().zip(&lights0) {
            l.position = target + r * (l0.position - target);
        }
        let t = Instant::now();
        let sl = m.set_lighting(&scene, &NoProgress).expect("lighting");
        if std::env::var_os("FOG_T").is_some() {
            eprintln!("set_lighting {sl:.1}");
        }
        let out = render_frame(&mut m, &scene, &request, &NoProgress).expect("frame");
        light.push(t.elapsed().as_secs_f64() * 1e3);
        if std::env::var_os("FOG_T").is_some() {
            eprintln!(
                "total {:.1} (method view_ms {:.1})",
                light[light.len() - 1],
                out.timings.view_ms
            );
        }
        std::hint::black_box(out);
    }
    let cpu_light = (cpu_ms() - cpu0) / steps as f64;
    println!(
        "{} view {} ms, light {} ms (median (min)); CPU per frame: view {cpu_view:.1} ms, light {cpu_light:.1} ms",
        if medium {
            "medium + 4 lights"
        } else {
            "default scene"
        },
        median(view),
        median(light)
    );
}
