//! Wavelet importance sampling (`LightSampling::Wavelet`, sun-thesis-2008
//! §4.6.1): the density, its samples, the light on the face against the
//! affine wavelet propagation (eq. 4.35), unbiasedness against MIS and a
//! closed form with most of the light outside the face, and the variance
//! against light-area sampling (issue 13: ≥ 10× lower at 8 spp).

use super::common::*;
use super::lights::plane_under_rectangle;
use glam::Vec3;
use relight_render::reference::wavelet_sampling::{FaceProduct, LightGrid};
use relight_render::reference::wavelet_verify::{
    covered_pixels, glossy_face_product, glossy_scene, mean_agreement, pdf_sphere_integral,
    pixel_variance,
};
use relight_render::reference::{ReferenceError, WaveletSamplingOptions};
use relight_render::sampling::luminance;
use relight_render::{LightSampling, NoProgress, ReferenceOptions, Rng, render_reference};

/// Shading points of the glossy scene's sphere: top, front, side.
fn points() -> [(Vec3, Vec3); 3] {
    [
        (Vec3::new(0.0, 1.0, 0.0), Vec3::Y),
        (
            Vec3::new(0.0, 0.5 + 0.35, 0.35),
            Vec3::new(0.0, 1.0, 1.0).normalize(),
        ),
        (
            Vec3::new(-0.35, 0.5 + 0.35, 0.0),
            Vec3::new(-1.0, 1.0, 0.0).normalize(),
        ),
    ]
}

/// ∫ p dω = 1 over the sphere, by midpoint quadrature at two resolutions
/// (the error halves with the grid: it is the quadrature's, at the pdf's
/// jumps), at orders 16 and 32.
#[test]
fn density_integrates_to_one_over_the_sphere() {
    let scene = glossy_scene(8, 8);
    for order in [16, 32] {
        let o = WaveletSamplingOptions {
            order,
            ..WaveletSamplingOptions::default()
        };
        for (p, n) in points() {
            let f = glossy_face_product(&scene, &o, p, n, scene.camera.eye);
            assert!(f.total() > 0.0);
            let (a, b) = (pdf_sphere_integral(&f, 512), pdf_sphere_integral(&f, 2048));
            eprintln!("order {order}, point {p}: ∫p dω = {a:.5} (512), {b:.5} (2048)");
            assert!((b - 1.0).abs() < 3e-3, "order {order} at {p}: {b}");
            assert!(
                (b - 1.0).abs() <= (a - 1.0).abs() + 1e-4,
                "not converging: {a} → {b}"
            );
        }
    }
}

/// Samples carry the density of their own direction, fall in cells in
/// proportion to the cell probabilities (χ²), and `E[g/p]` equals `∫ g`
/// over the directions of positive density for the true integrand
/// `g = lum(L(ω) f cos)` (continuous texture, not the box averages).
#[test]
fn samples_follow_the_density() {
    let scene = glossy_scene(8, 8);
    let o = WaveletSamplingOptions::default();
    let light = &scene.area_lights[0];
    let brdf = relight_render::reference::wavelet_verify::glossy_brdf();
    for (p, n) in points() {
        let f = glossy_face_product(&scene, &o, p, n, scene.camera.eye);
        let frame = relight_sphere::Frame::from_z(n);
        let wo = frame.to_local((scene.camera.eye - p).normalize());
        let g = |d: Vec3| -> f64 {
            let l = frame.to_local(d);
            if l.z <= 0.0 {
                return 0.0;
            }
            light.intersect(p, d, 0.0).map_or(0.0, |(_, uv)| {
                if d.dot(light.normal()) < 0.0 {
                    f64::from(luminance(light.radiance_at(uv) * brdf.eval(wo, l) * l.z))
                } else {
                    0.0
                }
            })
        };
        let nn = f.order();
        let samples = 200_000u64;
        let mut counts = vec![0u64; nn * nn];
        let (mut sum, mut sq, mut mismatched) = (0.0f64, 0.0f64, 0u64);
        for s in 0..samples {
            let mut rng = Rng::for_sample(5, 0, s);
            let (d, pdf) = f.sample(rng.next_2d()).expect("a non-zero product");
            assert!((d.length() - 1.0).abs() < 1e-4);
            let q = f.pdf(d);
            if ((q - pdf) / pdf).abs() > 1e-3 {
                mismatched += 1;
            }
            let (i, j, _) = f.cell_of(d).expect("inside the face");
            counts[j * nn + i] += 1;
            let x = g(d) / f64::from(pdf);
            sum += x;
            sq += x * x;
        }
        // Rounding may put a point on a cell edge into its neighbour.
        assert!(mismatched * 10_000 < samples, "{mismatched} pdf mismatches");
        let (mut chi2, mut dof) = (0.0f64, 0usize);
        for j in 0..nn {
            for i in 0..nn {
                let e = f64::from(f.cell_probability(i, j)) * samples as f64;
                let c = counts[j * nn + i] as f64;
                if e == 0.0 {
                    assert_eq!(c, 0.0, "a sample in an empty cell ({i}, {j})");
                } else if e >= 5.0 {
                    chi2 += (c - e).powi(2) / e;
                    dof += 1;
                }
            }
        }
        // χ² of `dof` degrees: mean dof, sd √(2 dof).
        let z_chi = (chi2 - dof as f64) / (2.0 * dof as f64).sqrt();
        // ∫ g over positive-density directions, midpoint rule on the face.
        let res = 2048;
        let h = f64::from(f.face()) / res as f64;
        let mut quad = 0.0f64;
        for b in 0..res {
            let v2 = -0.5 * f64::from(f.face()) + (b as f64 + 0.5) * h;
            for a in 0..res {
                let v1 = -0.5 * f64::from(f.face()) + (a as f64 + 0.5) * h;
                let r2 = 1.0 + v1 * v1 + v2 * v2;
                let d = (light.world_from_light.x_axis * v1 as f32
                    - light.world_from_light.y_axis * v2 as f32
                    - light.world_from_light.z_axis)
                    .normalize();
                if f.pdf(d) > 0.0 {
                    quad += g(d) / (r2 * r2.sqrt());
                }
            }
        }
        quad *= h * h;
        let ns = samples as f64;
        let mean = sum / ns;
        let se = ((sq / ns - mean * mean) / (ns - 1.0)).sqrt();
        eprintln!(
            "point {p}: χ² {chi2:.0} on {dof} cells (z {z_chi:+.2}); E[g/p] {mean:.5} ± {se:.5} vs ∫g {quad:.5}"
        );
        assert!(z_chi.abs() < 5.0, "χ² z = {z_chi}");
        assert!(
            (mean - quad).abs() < 4.0 * se + 2e-3 * quad,
            "E[g/p] {mean} vs {quad} (se {se})"
        );
    }
}

/// The light on the face (exact box averages of the affinely mapped light
/// grid) equals eq. 4.35's propagation in the standard Haar basis by the
/// affine coupling coefficients of `relight-affine`, inverse-transformed.
#[test]
fn light_on_face_is_the_affine_wavelet_propagation() {
    let scene = glossy_scene(8, 8);
    let light = &scene.area_lights[0];
    let n = 32;
    let o = WaveletSamplingOptions {
        order: n,
        light_order: n,
        ..WaveletSamplingOptions::default()
    };
    let grid = LightGrid::of(light, n);
    let mut f = FaceProduct::new(&o);
    for p in [
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.6, 0.3, -0.4),
        Vec3::new(-1.5, 0.9, 0.8),
        Vec3::new(0.1, 1.55, -0.1),
    ] {
        f.build(&grid, light, p, |_| Vec3::ONE);
        // (s, o) of relight-nearfield's face.rs.
        let d = p - light.center;
        let (px, py, z) = (
            f64::from(d.dot(light.world_from_light.x_axis)),
            f64::from(d.dot(light.world_from_light.y_axis)),
            f64::from(d.dot(light.world_from_light.z_axis)),
        );
        let (w, h, face) = (
            f64::from(light.size.x),
            f64::from(light.size.y),
            f64::from(o.face),
        );
        let s = [z * face / w, z * face / h];
        let off = [0.5 + px / w - 0.5 * s[0], 0.5 - py / h - 0.5 * s[1]];
        let mut worst = 0.0f64;
        let mut peak = 0.0f64;
        for c in 0..3 {
            let mut src: Vec<f64> = grid.cells.iter().map(|v| f64::from(v[c])).collect();
            relight_affine::standard::forward_2d(&mut src, n);
            let mut out = vec![0.0; n * n];
            relight_affine::standard::propagate_two_step(&src, n, s, off, &mut out);
            relight_affine::standard::inverse_2d(&mut out, n);
            for i2 in 0..n {
                for i1 in 0..n {
                    let mine = f64::from(f.light_on_face(i1, i2)[c]);
                    worst = worst.max((mine - out[i2 * n + i1]).abs());
                    peak = peak.max(out[i2 * n + i1].abs());
                }
            }
        }
        eprintln!("point {p}: max |face − eq. 4.35| = {worst:.2e} (peak {peak:.3})");
        assert!(peak > 0.1, "the light must reach the face");
        assert!(worst <= 1e-5 * peak, "{worst} vs peak {peak}");
    }
}

/// Unbiased: the wavelet strategy's image mean over the glossy sphere
/// agrees with the default MIS within 3σ (issue 13) at 128 spp.
#[test]
fn wavelet_agrees_with_mis_on_a_glossy_sphere() {
    let scene = glossy_scene(20, 20);
    let mask = covered_pixels(&scene, 0);
    let o = |strategy, seed| ReferenceOptions {
        spp: 128,
        pass_spp: 128,
        seed,
        light_sampling: strategy,
        ..ReferenceOptions::default()
    };
    let (mw, mm, z) = mean_agreement(
        &scene,
        &o(LightSampling::Wavelet, 3),
        &o(LightSampling::Mis, 4),
        &mask,
    )
    .unwrap();
    eprintln!("glossy sphere, 128 spp: wavelet {mw:.5}, MIS {mm:.5}, |Δ| = {z:.2} σ");
    assert!(mask.iter().filter(|&&m| m).count() > 100);
    assert!(mw > 0.01);
    assert!(z < 3.0, "{z} σ");
}

/// Light the face misses is still counted: a Lambert plane under a uniform
/// rectangle with a face of side 0.5 (most of the light outside it at
/// most points) against the closed form (Lambert's edge sum), within 4σ.
#[test]
fn light_outside_the_face_leaves_no_bias() {
    let (rho, radiance) = (0.8f32, 2.0f32);
    let (scene, closed) = plane_under_rectangle(rho, radiance, 24);
    let mask = object_mask(&scene, 0);
    let (w, h) = (scene.camera.width, scene.camera.height);
    let o = ReferenceOptions {
        spp: 64,
        pass_spp: 64,
        seed: 9,
        light_sampling: LightSampling::Wavelet,
        wavelet: WaveletSamplingOptions {
            face: 0.5,
            ..WaveletSamplingOptions::default()
        },
        ..ReferenceOptions::default()
    };
    let r = render_reference(&scene, &o, &NoProgress).unwrap();
    let (mut diff, mut sum_cf, mut var, mut n) = (0.0f64, 0.0f64, 0.0f64, 0);
    for i in (0..w * h).filter(|&i| mask[i]) {
        let cf = closed[i];
        diff += f64::from(luminance(r.image.pixels[i])) - cf;
        sum_cf += cf;
        var += f64::from(r.std_error[i]).powi(2);
        n += 1;
    }
    let (bias, sigma) = (diff / sum_cf, var.sqrt() / sum_cf);
    eprintln!("face 0.5, {n} px: relative bias {bias:+.2e} ± {sigma:.1e}");
    assert!(n > 200);
    assert!(bias.abs() < 4.0 * sigma + 2e-3, "bias {bias} (σ {sigma})");
}

/// Issue 13: at 8 spp on a glossy object under a textured area light, the
/// wavelet strategy's per-pixel variance (6 seeds) is ≥ 10× lower than
/// light-area sampling's.
#[test]
fn eight_spp_variance_is_ten_times_below_light_sampling() {
    let scene = glossy_scene(24, 24);
    let mask = covered_pixels(&scene, 0);
    let o = |strategy| ReferenceOptions {
        spp: 8,
        light_sampling: strategy,
        ..ReferenceOptions::default()
    };
    let (vw, _) = pixel_variance(&scene, &o(LightSampling::Wavelet), 6, &mask).unwrap();
    let (vl, _) = pixel_variance(&scene, &o(LightSampling::LightOnly), 6, &mask).unwrap();
    let (vm, _) = pixel_variance(&scene, &o(LightSampling::Mis), 6, &mask).unwrap();
    eprintln!(
        "8 spp variance: light {vl:.3e}, MIS {vm:.3e}, wavelet {vw:.3e}; light/wavelet {:.1}×, MIS/wavelet {:.1}×",
        vl / vw,
        vm / vw
    );
    assert!(vw > 0.0);
    assert!(vl / vw >= 10.0, "ratio {}", vl / vw);
}

/// Bad options are one-line errors naming the option; strategy names
/// round-trip.
#[test]
fn options_are_checked_and_named() {
    let scene = glossy_scene(4, 4);
    for (wavelet, name) in [
        (
            WaveletSamplingOptions {
                order: 24,
                ..WaveletSamplingOptions::default()
            },
            "wavelet.order",
        ),
        (
            WaveletSamplingOptions {
                face: 0.0,
                ..WaveletSamplingOptions::default()
            },
            "wavelet.face",
        ),
        (
            WaveletSamplingOptions {
                light_order: 0,
                ..WaveletSamplingOptions::default()
            },
            "wavelet.light_order",
        ),
    ] {
        let o = ReferenceOptions {
            spp: 1,
            light_sampling: LightSampling::Wavelet,
            wavelet,
            ..ReferenceOptions::default()
        };
        match render_reference(&scene, &o, &NoProgress) {
            Err(e @ ReferenceError::InvalidOption { parameter, .. }) => {
                assert_eq!(parameter, name);
                assert!(!e.to_string().contains('\n'));
            }
            other => panic!("{name}: expected an error, got {:?}", other.map(|_| ())),
        }
    }
    for s in LightSampling::ALL {
        assert_eq!(s.name().parse::<LightSampling>(), Ok(s));
    }
    let e = "bogus".parse::<LightSampling>().unwrap_err();
    assert!(e.contains("wavelet") && !e.contains('\n'), "{e}");
}
