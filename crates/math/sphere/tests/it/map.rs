//! Tests of `EnvMap`: integrals (checked against closed forms and Monte
//! Carlo), area-correct resampling and rotation.

use crate::common;

use common::Rng;
use glam::{DVec3, Mat3, Vec3};
use relight_sphere::EnvMap;
use relight_sphere::param::Param;
use std::f64::consts::PI;

fn sphere_params() -> [Param; 3] {
    [
        Param::LatLong {
            width: 128,
            height: 64,
        },
        Param::Cube { n: 32 },
        Param::Octahedral { n: 64 },
    ]
}

fn smooth(d: Vec3) -> Vec3 {
    let a = (1.3 * d.x + 0.4 * d.y - 0.9 * d.z).sin();
    let b = (d.x * d.y + 0.7 * d.z).exp();
    Vec3::new(1.0 + a, b, 0.5 + d.y * d.z + d.x)
}

#[test]
fn integral_of_closed_form_functions() {
    // ∫ 1 dω = 4π, ∫ z² dω = 4π/3, ∫ (1 + x) dω = 4π; hemisphere: ∫ z dω = π.
    for p in sphere_params() {
        let m = EnvMap::from_fn(p, |d| Vec3::new(1.0, d.z * d.z, 1.0 + d.x));
        let got = m.integral_f64();
        let want = DVec3::new(4.0 * PI, 4.0 * PI / 3.0, 4.0 * PI);
        let rel = ((got - want) / want).abs().max_element();
        assert!(rel < 2e-3, "{p:?}: ∫ = {got}, want {want} (rel {rel:e})");
        assert!(
            ((got.x - 4.0 * PI) / (4.0 * PI)).abs() < 1e-12,
            "{p:?}: ∫1 = {}",
            got.x
        );
    }
    let m = EnvMap::from_fn(Param::HemiOctahedral { n: 64 }, |d| Vec3::splat(d.z));
    let got = m.integral_f64().x;
    assert!((got - PI).abs() / PI < 2e-3, "hemi ∫ cos = {got}, want π");
}

#[test]
fn integral_matches_monte_carlo() {
    // Second way: uniform Monte Carlo of the (bilinearly interpolated) map.
    let mut rng = Rng(2024);
    for p in sphere_params() {
        let m = EnvMap::from_fn(p, smooth);
        let n = 400_000;
        let mut sum = DVec3::ZERO;
        let mut sum2 = DVec3::ZERO;
        for _ in 0..n {
            let v = m.eval(rng.sphere().as_vec3()).as_dvec3() * (4.0 * PI);
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64)
            .max(DVec3::ZERO)
            .powf(0.5);
        let got = m.integral_f64();
        let dev = ((got - mean).abs() / se).max_element();
        assert!(
            dev < 5.0,
            "{p:?}: texel quadrature {got} vs Monte Carlo {mean} ± {se}"
        );
    }
}

#[test]
fn resample_keeps_constants_exactly() {
    let c = Vec3::new(0.25, 1.5, 3.0);
    let params = [
        Param::LatLong {
            width: 24,
            height: 12,
        },
        Param::LatLong {
            width: 7,
            height: 5,
        },
        Param::Cube { n: 5 },
        Param::Octahedral { n: 8 },
        Param::Octahedral { n: 5 },
        Param::HemiOctahedral { n: 6 },
    ];
    for src in params {
        let m = EnvMap::from_fn(src, |_| c);
        for dst in params {
            for ss in [1, 3] {
                let r = m.resample(dst, ss);
                assert_eq!(r.param, dst);
                assert!(
                    r.texels.iter().all(|&t| t == c),
                    "{src:?} → {dst:?} (ss {ss}): constant not kept: {:?}",
                    r.texels.iter().find(|&&t| t != c)
                );
            }
        }
    }
}

#[test]
fn resample_preserves_integral_and_values() {
    let ps = sphere_params();
    for src in ps {
        let m = EnvMap::from_fn(src, smooth);
        let want = m.integral_f64();
        for dst in ps {
            let r = m.resample(dst, 4);
            let got = r.integral_f64();
            let rel = ((got - want) / want).abs().max_element();
            assert!(
                rel < 1e-3,
                "{src:?} → {dst:?}: ∫ {got} vs {want} (rel {rel:e})"
            );
            // Texels agree with the function (up to filtering error).
            let worst = (0..dst.len())
                .map(|i| {
                    (r.texels[i] - smooth(dst.dir_from_texel(i)))
                        .abs()
                        .max_element()
                })
                .fold(0.0f32, f32::max);
            assert!(worst < 0.05, "{src:?} → {dst:?}: worst texel error {worst}");
        }
    }
}

#[test]
fn resample_is_area_weighted_not_point_sampled() {
    // A single bright lat-long texel near the pole carries a known energy; an
    // octahedral resampling must keep that energy (point sampling would miss
    // or inflate it).
    let src = Param::LatLong {
        width: 64,
        height: 32,
    };
    let mut texels = vec![Vec3::ZERO; src.len()];
    let i = 2 * 64 + 10;
    texels[i] = Vec3::ONE;
    let m = EnvMap::try_new(src, texels).unwrap();
    let want = m.integral_f64().x;
    let r = m.resample(Param::Octahedral { n: 32 }, 8);
    let got = r.integral_f64().x;
    assert!((got - want).abs() / want < 0.15, "energy {got} vs {want}");
}

#[test]
fn rotation_matches_function_and_round_trips() {
    let rot = Mat3::from_euler(glam::EulerRot::YXZ, 0.7, -0.4, 1.9);
    for p in sphere_params() {
        let m = EnvMap::from_fn(p, smooth);
        let r = m.rotated(rot, 3);
        // out(d) = f(R⁻¹ d)
        let worst = (0..p.len())
            .map(|i| {
                let d = p.dir_from_texel(i);
                (r.texels[i] - smooth(rot.transpose() * d))
                    .abs()
                    .max_element()
            })
            .fold(0.0f32, f32::max);
        assert!(worst < 0.05, "{p:?}: rotated map off by {worst}");
        let (a, b) = (m.integral_f64(), r.integral_f64());
        assert!(
            ((a - b) / a).abs().max_element() < 1e-3,
            "{p:?}: ∫ {a} vs rotated {b}"
        );
        let back = r.rotated(rot.transpose(), 3);
        let err = m
            .texels
            .iter()
            .zip(&back.texels)
            .map(|(x, y)| (*x - *y).abs().max_element())
            .fold(0.0f32, f32::max);
        assert!(err < 0.05, "{p:?}: rotate there and back off by {err}");
    }
}

#[test]
fn try_new_checks_length() {
    let p = Param::Cube { n: 2 };
    assert!(EnvMap::try_new(p, vec![Vec3::ZERO; 24]).is_some());
    assert!(EnvMap::try_new(p, vec![Vec3::ZERO; 23]).is_none());
    assert!(EnvMap::try_new(Param::Octahedral { n: 0 }, Vec::new()).is_none());
}

#[test]
fn verify_and_bench_report_sane_rows() {
    let rows = relight_sphere::verify::verify_sphere(true);
    assert!(rows.len() >= 10);
    for r in &rows {
        assert!(r.solid_angle_rel_error < 1e-6, "{r:?}");
        let tol = 6.0 * (2.0 / r.cells as f64).sqrt();
        assert!((r.mc_chi2_per_dof - 1.0).abs() < tol, "{r:?} (tol {tol})");
        assert_eq!(r.round_trip_failures, 0, "{r:?}");
        assert_eq!(r.pass, Some(true), "{r:?}");
        assert_eq!(r.target, Some(relight_sphere::verify::SOLID_ANGLE_TARGET));
    }
    let bench = relight_sphere::verify::bench_sphere(8);
    assert!(
        bench
            .iter()
            .all(|b| b.ns_per_op.is_finite() && b.ns_per_op >= 0.0)
    );
}

#[test]
fn the_black_map_is_valid_and_zero_everywhere() {
    let b = EnvMap::black();
    assert!(b.param.validate().is_ok());
    assert_eq!(b.texels.len(), b.param.len());
    assert_eq!(b.integral(), Vec3::ZERO);
    assert_eq!(b.eval(Vec3::new(0.3, -0.8, 0.5).normalize()), Vec3::ZERO);
}

/// `is_black` holds for `+0.0` texels only: one non-zero channel, or a
/// `-0.0`, anywhere makes it false; every lookup of a black map is `+0.0`.
#[test]
fn is_black_means_every_texel_is_positive_zero() {
    let b = EnvMap::black();
    assert!(b.is_black());
    for i in [0, 13, b.texels.len() - 1] {
        for v in [Vec3::new(0.0, 1e-30, 0.0), Vec3::new(-0.0, 0.0, 0.0)] {
            let mut m = b.clone();
            m.texels[i] = v;
            assert!(!m.is_black(), "texel {i} = {v:?}");
        }
    }
    for k in 0..50 {
        let t = k as f32 * 0.77;
        let d = Vec3::new(t.sin(), (1.3 * t).cos(), 0.4 * t.cos()).normalize();
        let got = b.eval(d);
        assert_eq!(got.to_array().map(f32::to_bits), [0; 3], "{d:?}");
    }
}

/// Equal maps give equal fingerprints; one texel's channel changed (in
/// each of the six streams and in an odd map's last texel), the size or
/// the parameterization changed, give another.
#[test]
fn fingerprint_follows_every_texel() {
    let map = |w: usize| {
        EnvMap::from_fn(
            Param::LatLong {
                width: w,
                height: 3,
            },
            |d| Vec3::new(1.0 + d.x, 0.5 + d.y * d.y, 0.25 + d.z),
        )
    };
    let base = map(7);
    assert_eq!(base.fingerprint(), map(7).fingerprint());
    let mut seen = vec![base.fingerprint()];
    for (t, c) in [(0, 0), (0, 2), (1, 1), (10, 0), (11, 2), (20, 1)] {
        let mut m = base.clone();
        m.texels[t][c] += 1e-3;
        let f = m.fingerprint();
        assert!(!seen.contains(&f), "texel {t} channel {c}");
        seen.push(f);
    }
    assert!(!seen.contains(&map(8).fingerprint()));
    let mut swapped = base.clone();
    swapped.texels.swap(0, 1);
    assert!(!seen.contains(&swapped.fingerprint()));
}
