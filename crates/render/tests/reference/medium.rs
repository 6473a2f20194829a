//! The fog ball: single-scattering glow against quadrature of the airlight
//! integral, energy conservation at albedo 1, a furnace in fog, and pure
//! absorption.

use super::common::*;
use glam::Vec3;
use relight_render::sampling::luminance;
use relight_render::{
    Medium, MediumMode, NoProgress, Object, PointLight, ReferenceImage, ReferenceOptions, Scene,
    render_reference,
};
use std::f64::consts::PI;
use std::sync::Arc;

fn render(scene: &Scene, mode: MediumMode, spp: u32, seed: u64) -> ReferenceImage {
    let o = ReferenceOptions {
        spp,
        pass_spp: 32,
        seed,
        medium_mode: mode,
        ..ReferenceOptions::default()
    };
    render_reference(scene, &o, &NoProgress).unwrap()
}

/// Eq. 3.5 of sun-thesis-2008 with scattering `σ_s = a·β`: the light of an
/// isotropic point source (intensity `i0`, at `c`) scattered once into the
/// ray `o + t d`, `0 ≤ t ≤ t_max`, all inside the medium,
/// `σ_s I₀/(4π) ∫ e^{−β r(t)} / r(t)² · e^{−β t} dt`, by composite Simpson
/// over the angle θ of `t = Δ + D tan θ` (where `dt / r² = dθ / D`).
fn airlight_quadrature(
    o: Vec3,
    d: Vec3,
    c: Vec3,
    i0: f64,
    beta: f64,
    albedo: f64,
    t_max: f64,
) -> f64 {
    let (o, d, c) = (o.as_dvec3(), d.as_dvec3(), c.as_dvec3());
    let delta = (c - o).dot(d);
    let dist = (c - o - delta * d).length();
    let (th0, th1) = ((-delta).atan2(dist), (t_max - delta).atan2(dist));
    let n = 400;
    let h = (th1 - th0) / n as f64;
    let f = |th: f64| {
        let t = delta + dist * th.tan();
        let r = dist / th.cos();
        (-beta * (t + r)).exp()
    };
    let mut s = f(th0) + f(th1);
    for k in 1..n {
        s += f(th0 + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    albedo * beta * i0 / (4.0 * PI) * s * h / 3.0 / dist
}

/// Single scattering of a point light in the fog ball (no surfaces, black
/// environment) against the airlight integral computed per pixel ray
/// (averaged over a 4 × 4 sub-pixel grid), away from the light's image.
#[test]
fn single_scattering_glow_matches_the_airlight_integral() {
    let (beta, albedo, radius, i0) = (0.4f32, 0.9f32, 5.0f32, 10.0f32);
    let light = Vec3::new(0.6, 0.3, -1.0);
    let mut scene = Scene::new(
        Vec::new(),
        black_env(),
        camera(
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(0.0, 0.0, -1.0),
            60.0,
            32,
            32,
        ),
    );
    scene
        .point_lights
        .push(PointLight::new(light, Vec3::splat(i0)));
    let medium = Medium {
        beta,
        albedo,
        radius,
    };
    scene.medium = Some(medium);
    let r = render(&scene, MediumMode::SingleScattering, 64, 3);
    let (w, h) = (scene.camera.width, scene.camera.height);
    let rays = scene.camera.ray_frame();
    // The light's pixel.
    let to_light = (light - scene.camera.eye).normalize();
    let (mut diff, mut sum, mut var, mut sq, mut sq_q, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0, 0);
    for i in 0..w * h {
        let centre = rays.dir((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        if centre.dot(to_light).acos().to_degrees() < 6.0 {
            continue; // the 1/γ peak: a 4 × 4 grid does not resolve it
        }
        let k = 4;
        let mut q = 0.0;
        for j in 0..k * k {
            let d = rays.dir(
                (i % w) as f32 + ((j % k) as f32 + 0.5) / k as f32,
                (i / w) as f32 + ((j / k) as f32 + 0.5) / k as f32,
            );
            let (_, t_out) = medium.ball_span(scene.camera.eye, d).unwrap();
            q += airlight_quadrature(
                scene.camera.eye,
                d,
                light,
                f64::from(i0),
                f64::from(beta),
                f64::from(albedo),
                f64::from(t_out),
            ) / (k * k) as f64;
        }
        let got = f64::from(luminance(r.image.pixels[i]));
        diff += got - q;
        sum += q;
        var += f64::from(r.std_error[i]).powi(2);
        sq += (got - q).powi(2);
        sq_q += q * q;
        n += 1;
    }
    let (rel_bias, rel_sigma) = (diff / sum, var.sqrt() / sum);
    let (rms, noise) = ((sq / sq_q).sqrt(), (var / sq_q).sqrt());
    eprintln!(
        "single-scattering glow vs eq. 3.5 quadrature ({n} px): MC − quadrature {rel_bias:+.2e} ± {rel_sigma:.1e} (relative), per-pixel relative RMS {rms:.4} vs reported noise {noise:.4}"
    );
    assert!(n > 800);
    assert!(rel_bias.abs() < 4.0 * rel_sigma + 1e-3, "bias {rel_bias}");
    assert!(rms < 1.5 * noise + 0.003, "rms {rms} vs noise {noise}");
    // Multiple scattering adds light.
    let m = render(&scene, MediumMode::MultipleScattering, 16, 4);
    let (ss, ms) = (
        lum(&r.image).iter().sum::<f64>(),
        lum(&m.image).iter().sum::<f64>(),
    );
    eprintln!(
        "multiple / single scattering over the image: {:.3}",
        ms / ss
    );
    assert!(ms > 1.05 * ss);
}

/// At albedo 1 nothing is absorbed: the flux leaving the ball is the
/// emitted `4π I`, of which `4π I e^{−T}` leaves unscattered. A spherically
/// symmetric source seen from distance `D` through vacuum gives the
/// irradiance `Φ / (4π D²)`, so the image of the scattered light must give
/// `E = Σ_pixels L cos⁴θ A_pixel = I (1 − e^{−T}) / D²` (T = βR).
#[test]
fn albedo_one_conserves_the_flux() {
    let (radius, dist, i0) = (1.0f32, 3.0f32, 1.0f32);
    let (size, vfov) = (40usize, 50.0f32);
    for (t, spp) in [(1.0f32, 64u32), (3.0, 32)] {
        let mut scene = Scene::new(
            Vec::new(),
            black_env(),
            camera(Vec3::new(0.0, 0.0, dist), Vec3::ZERO, vfov, size, size),
        );
        scene
            .point_lights
            .push(PointLight::new(Vec3::ZERO, Vec3::splat(i0)));
        scene.medium = Some(Medium {
            beta: t / radius,
            albedo: 1.0,
            radius,
        });
        let tan = f64::from((0.5 * vfov).to_radians().tan());
        let area = (2.0 * tan / size as f64).powi(2);
        let irradiance = |r: &ReferenceImage| -> (f64, f64) {
            let (mut e, mut var) = (0.0, 0.0);
            for i in 0..size * size {
                let x = (((i % size) as f64 + 0.5) / size as f64 * 2.0 - 1.0) * tan;
                let y = (((i / size) as f64 + 0.5) / size as f64 * 2.0 - 1.0) * tan;
                let c4 = (1.0 / (1.0 + x * x + y * y)).powi(2);
                e += f64::from(luminance(r.image.pixels[i])) * c4 * area;
                var += (f64::from(r.std_error[i]) * c4 * area).powi(2);
            }
            (e, var.sqrt())
        };
        let expect = f64::from(i0) * (1.0 - (-f64::from(t)).exp()) / f64::from(dist).powi(2);
        let ms = render(&scene, MediumMode::MultipleScattering, spp, 7);
        let (e, sigma) = irradiance(&ms);
        let ss = render(&scene, MediumMode::SingleScattering, 16, 8);
        let (e1, _) = irradiance(&ss);
        eprintln!(
            "albedo 1, T = {t}: scattered irradiance {e:.5e} ± {sigma:.1e} vs I(1 − e^−T)/D² = {expect:.5e} (ratio {:.4}); single scattering alone {:.3} of it",
            e / expect,
            e1 / expect
        );
        assert!(
            (e - expect).abs() < 4.0 * sigma + 0.005 * expect,
            "T {t}: {e} vs {expect}"
        );
        assert!(e1 < 0.97 * expect);
    }
}

/// A furnace in fog: at albedo 1 under a uniform environment of radiance 1
/// the radiance field is 1 everywhere, inside and outside the ball; a white
/// Lambert sphere inside (visibility off, so scattered light is not blocked
/// by it) receives 1 from every direction and shows 1. Multiple scattering
/// must give 1; single scattering alone loses the higher orders.
#[test]
fn furnace_in_fog() {
    let mesh = relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 0.5, 48, 24);
    let medium = Medium {
        beta: 1.0,
        albedo: 1.0,
        radius: 2.0,
    };
    for eye in [Vec3::new(0.0, 0.3, 5.0), Vec3::new(0.2, 0.1, 1.2)] {
        let mut scene = Scene::new(
            vec![Object::new(Arc::new(mesh.clone()), lambert(1.0))],
            constant_env(1.0),
            camera(eye, Vec3::ZERO, 50.0, 16, 16),
        );
        scene.medium = Some(medium);
        let r = render(&scene, MediumMode::MultipleScattering, 256, 1);
        let all = vec![true; 16 * 16];
        let (mean, sigma, _) = masked_mean(&r, &all);
        let worst = r
            .image
            .pixels
            .iter()
            .zip(&r.std_error)
            .map(|(p, se)| (luminance(*p) - 1.0).abs() / (se + 1e-4))
            .fold(0.0f32, f32::max);
        let s = render(&scene, MediumMode::SingleScattering, 16, 2);
        let (single, _, _) = masked_mean(&s, &all);
        eprintln!(
            "furnace in fog (T = 2, albedo 1, eye {eye}): multiple scattering {mean:.4} ± {sigma:.1e} (worst pixel {worst:.1} σ, rel. std error {:.3}); single scattering {single:.3}",
            r.relative_std_error
        );
        assert!((mean - 1.0).abs() < 4.0 * sigma + 0.005, "mean {mean}");
        assert!(worst < 6.0, "a pixel is {worst} σ from 1");
        assert!(single < 0.95);
    }
}

/// A purely absorbing ball (albedo 0) in a uniform environment: each pixel
/// is the pixel average of `e^{−β·chord}`, in both modes.
#[test]
fn absorbing_fog_attenuates_the_environment_by_the_chord() {
    let medium = Medium {
        beta: 0.8,
        albedo: 0.0,
        radius: 1.5,
    };
    let mut scene = Scene::new(
        Vec::new(),
        constant_env(1.0),
        camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 60.0, 16, 16),
    );
    scene.medium = Some(medium);
    let rays = scene.camera.ray_frame();
    for mode in [MediumMode::SingleScattering, MediumMode::MultipleScattering] {
        let r = render(&scene, mode, 64, 5);
        let mut worst = 0.0f64;
        for i in 0..16 * 16 {
            let k = 8;
            let mut expect = 0.0;
            for j in 0..k * k {
                let d = rays.dir(
                    (i % 16) as f32 + ((j % k) as f32 + 0.5) / k as f32,
                    (i / 16) as f32 + ((j / k) as f32 + 0.5) / k as f32,
                );
                let chord = medium
                    .ball_span(scene.camera.eye, d)
                    .map_or(0.0, |(a, b)| b - a);
                expect += f64::from((-medium.beta * chord).exp()) / (k * k) as f64;
            }
            let got = f64::from(luminance(r.image.pixels[i]));
            // Jitter noise only (steep at the silhouette): the reported error.
            let z = (got - expect).abs() / (f64::from(r.std_error[i]) + 1e-3);
            worst = worst.max(z);
            assert!(z < 5.0, "{mode:?} pixel {i}: {got} vs {expect} ({z} σ)");
        }
        eprintln!("absorbing fog, {mode:?}: worst |pixel − e^(−β chord)| = {worst:.2} σ");
    }
}
