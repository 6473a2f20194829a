//! Media (sun-thesis-2008 §3.6.5): the foggy lighting against closed forms
//! computed a second way (midpoint quadrature of the ball's single
//! scattering), and the method's frame in a medium.

use glam::Vec3;
use relight_render::method::{FrameRequest, Relighter, render_frame};
use relight_render::{Medium, NoProgress, Scene};
use relight_sphere::{EnvMap, Param};
use relight_triple::medium::FoggyLighting;
use relight_triple::{TripleMethod, TripleOptions};

/// What a uniform sky of radiance 1 scatters into the view from the centre
/// of a ball of optical radius `t` (albedo 1): ∫₀^T e^{−s} J(s) ds with
/// J(s) = ½ ∫ e^{−(√(T² − s²(1 − μ²)) − sμ)} dμ, both by the midpoint rule.
fn uniform_sky_glow(t: f64) -> f64 {
    let n = 600;
    (0..n)
        .map(|i| {
            let s = t * (i as f64 + 0.5) / n as f64;
            let j: f64 = (0..n)
                .map(|k| {
                    let mu = -1.0 + 2.0 * (k as f64 + 0.5) / n as f64;
                    (-((t * t - s * s * (1.0 - mu * mu)).sqrt() - s * mu)).exp()
                })
                .sum::<f64>()
                / n as f64;
            (-s).exp() * j * t / n as f64
        })
        .sum()
}

fn sky(f: impl Fn(Vec3) -> Vec3 + Sync) -> EnvMap {
    EnvMap::from_fn(
        Param::LatLong {
            width: 256,
            height: 128,
        },
        f,
    )
}

const MEDIUM: Medium = Medium {
    beta: 0.1,
    albedo: 0.8,
    radius: 10.0,
};

#[test]
fn a_constant_sky_in_fog_is_attenuated_plus_the_balls_scattering() {
    let fog = FoggyLighting::new(&sky(|_| Vec3::ONE), &MEDIUM).unwrap();
    let t = f64::from(MEDIUM.env_thickness());
    let glow = uniform_sky_glow(t);
    let want = (-t).exp() + f64::from(MEDIUM.albedo) * glow;
    // From the centre every ray crosses T.
    for d in [Vec3::Y, Vec3::X, Vec3::new(0.3, -0.8, 0.5).normalize()] {
        let got = fog.background(&sky(|_| Vec3::ONE), Vec3::ZERO, d, d);
        for c in got.to_array() {
            assert!(
                (f64::from(c) - want).abs() < 1e-3 * want,
                "L′ = {c}, closed form {want}"
            );
        }
    }
    assert!(fog.clamped == 0.0);
    // A view segment of length 0 shows the surface; one from the centre to
    // the edge attenuates it by e^{−T} and adds the centre's whole glow.
    let s = Vec3::new(0.5, 1.0, 2.0);
    // (At the centre the surface's factor for its place in the ball is 1;
    // at the edge, facing the eye, it is the factor table's.)
    let centre = fog.segment(s, Vec3::Y, Vec3::ZERO, Vec3::Y, 0.0);
    assert!((centre - s).abs().max_element() < 1e-5, "{centre}");
    let edge = fog.segment(s, Vec3::NEG_Y, Vec3::ZERO, Vec3::Y, MEDIUM.radius);
    let air = (glow * f64::from(MEDIUM.albedo)) as f32;
    let k = fog.factors.factor(Vec3::Y * MEDIUM.radius, Vec3::NEG_Y);
    assert!((k - 1.0).abs() < 0.05, "{k}");
    let want = s * ((-t as f32).exp() * k) + Vec3::splat(air);
    assert!(
        (edge - want).abs().max_element() < 1e-3 * air,
        "{edge} vs {want}"
    );
}

#[test]
fn the_scattered_glow_keeps_its_energy_and_leans_to_the_sun() {
    let sun = Vec3::new(0.3, 0.9, 0.3).normalize();
    let env = sky(|d| Vec3::splat(0.05 + 40.0 * d.dot(sun).max(0.0).powi(200)));
    let fog = FoggyLighting::new(&env, &MEDIUM).unwrap();
    let t = f64::from(MEDIUM.env_thickness());
    let want = f64::from(MEDIUM.albedo) * uniform_sky_glow(t) * f64::from(env.integral().x);
    let got = f64::from(fog.scattered.integral().x);
    assert!(
        (got - want).abs() < 0.01 * want,
        "scattered energy {got}, the ball's glow × ∫L {want}"
    );
    // Light from the sun's side crosses less medium to the view ray: the
    // glow is brighter toward it, though without the thesis' 1/γ peak.
    let at = |d: Vec3| fog.scattered.eval(d).x;
    assert!(at(sun) > 1.3 * at(-sun), "{} vs {}", at(sun), at(-sun));
    assert!(fog.clamped < 0.01, "clamped {}", fog.clamped);
}

fn scene(env: EnvMap, medium: Option<Medium>) -> Scene {
    // Unshadowed: a white Lambert under a constant sky is then a furnace.
    let mut s = crate::method::scene(env, false);
    s.medium = medium;
    s
}

fn render(sc: &Scene, name: &str) -> relight_render::method::Rendered {
    let dir = std::env::temp_dir().join(format!("relight-triple-{name}-{}", std::process::id()));
    let mut m = TripleMethod::new(TripleOptions {
        terms: 80,
        vis_level: 2,
        brdf_views: 8,
        twists: 4,
        cache_dir: dir,
        ..TripleOptions::default()
    })
    .unwrap();
    m.prepare(sc, &NoProgress).unwrap();
    render_frame(&mut m, sc, &FrameRequest::new(sc.camera), &NoProgress).unwrap()
}

#[test]
fn the_method_in_fog_attenuates_objects_and_draws_the_foggy_sky() {
    let env = sky(|_| Vec3::ONE);
    let clear = render(&scene(env.clone(), None), "clear");
    let zero = render(
        &scene(
            env.clone(),
            Some(Medium {
                beta: 0.0,
                ..MEDIUM
            }),
        ),
        "zero",
    );
    assert_eq!(clear.image.pixels, zero.image.pixels, "β = 0 is no medium");
    let foggy = render(&scene(env.clone(), Some(MEDIUM)), "foggy");
    let fog = FoggyLighting::new(&env, &MEDIUM).unwrap();
    let sky_value = fog.background(&env, Vec3::ZERO, Vec3::Y, Vec3::Y).x;
    let camera = scene(env.clone(), None).camera;
    let rays = camera.ray_frame();
    let cov = foggy.coverage.as_deref().unwrap();
    let (mut objects, mut changed) = (0, 0);
    for (i, ((p, c), q)) in foggy
        .image
        .pixels
        .iter()
        .zip(&cov.coverage)
        .zip(&clear.image.pixels)
        .enumerate()
    {
        if *c <= 0.0 {
            // The sky through the medium ahead of the eye, per ray: thicker
            // than T (the eye is off centre, looking past it), so dimmer than
            // from the centre, brighter than the airlight alone.
            let (x, y) = (i % camera.width, i / camera.width);
            let d = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
            let want = fog.background(&env, camera.eye, d, d).x;
            assert!((p.x - want).abs() < 1e-4, "sky pixel {p} vs {want}");
            assert!(p.x > fog.airlight.x && p.x < sky_value, "sky pixel {p}");
        } else if *c >= 1.0 {
            objects += 1;
            // e^{−βD} k L′ + s·airlight: between the two (the unshadowed
            // white Lambert shades L′ to the furnace's 2e-3, and k, the
            // surface's factor for its place near the centre, is near 1).
            assert!(
                p.x >= fog.airlight.x - 2e-3 && p.x <= sky_value + 2e-3,
                "{p}"
            );
            changed += usize::from((p.x - q.x).abs() > 1e-3);
        }
    }
    assert!(
        objects > 200 && changed * 2 > objects,
        "{changed} of {objects}"
    );
}

/// From outside the fog ball (the eye at 1.5 R, which the method once
/// refused) it draws: every sky pixel is the per-ray formula, the probe
/// itself where the ray misses the ball, and the objects are seen through
/// the medium from the ray's entry.
#[test]
fn the_method_draws_the_fog_ball_from_outside() {
    let env = sky(|_| Vec3::ONE);
    let mut sc = scene(env.clone(), Some(MEDIUM));
    let back = (sc.camera.eye - sc.camera.target).normalize();
    sc.camera.eye = back * (1.5 * MEDIUM.radius);
    sc.camera.target = Vec3::ZERO;
    sc.camera.vfov_deg = 110.0;
    let out = render(&sc, "outside");
    let fog = FoggyLighting::new(&env, &MEDIUM).unwrap();
    let rays = sc.camera.ray_frame();
    let cov = out.coverage.as_deref().unwrap();
    let (mut missed, mut through, mut objects) = (0, 0, 0);
    for (i, (p, c)) in out.image.pixels.iter().zip(&cov.coverage).enumerate() {
        if *c <= 0.0 {
            let (x, y) = (i % sc.camera.width, i / sc.camera.width);
            let d = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
            let want = fog.background(&env, sc.camera.eye, d, d).x;
            assert!((p.x - want).abs() < 1e-4, "sky pixel {p} vs {want}");
            if MEDIUM.ball_span(sc.camera.eye, d).is_none() {
                assert!((p.x - 1.0).abs() < 1e-6, "a ray past the ball: {p}");
                missed += 1;
            } else {
                through += 1;
            }
        } else if *c >= 1.0 {
            objects += 1;
            assert!(p.is_finite() && p.x > 0.0, "{p}");
        }
    }
    assert!(
        missed > 20 && through > 20 && objects > 10,
        "{missed} missed, {through} through, {objects} objects"
    );
}
