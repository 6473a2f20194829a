//! Each closed form of the NDF crate checked a second way (quadrature or
//! seeded Monte Carlo).

use glam::{DVec3, Mat3, Vec3};
use relight_ndf::effective::{Baseline, NdfBrdf, lambert_lobe, shade_baseline, shade_lobe};
use relight_ndf::em::{EmOptions, Lobe, fit_em, fit_em_on, seed_lobes};
use relight_ndf::pyramid::{VmfBakeOptions, unpack};
use relight_ndf::vmf::{
    KAPPA_MAX, Vmf, kappa_from_resultant, log_norm, mean_resultant, norm, sh_attenuation,
};
use relight_ndf::{MeanPyramid, ShNdfPyramid, VmfPyramid};

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A vMF sample about `mu` (Wood 1994 in 3D: exact inverse cdf of w = μ·n).
fn sample_vmf(rng: &mut Rng, mu: DVec3, kappa: f64) -> DVec3 {
    let u = rng.f();
    let w = 1.0 + (u + (1.0 - u) * (-2.0 * kappa).exp()).ln() / kappa;
    let w = w.clamp(-1.0, 1.0);
    let phi = 2.0 * std::f64::consts::PI * rng.f();
    let s = (1.0 - w * w).max(0.0).sqrt();
    let f = relight_sphere::Frame::from_z(mu.as_vec3());
    (f.x.as_dvec3() * (s * phi.cos()) + f.y.as_dvec3() * (s * phi.sin()) + mu * w).normalize()
}

fn legendre(l: usize, t: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, t);
    if l == 0 {
        return 1.0;
    }
    for k in 1..l {
        let p2 = ((2 * k + 1) as f64 * t * p1 - k as f64 * p0) / (k + 1) as f64;
        p0 = p1;
        p1 = p2;
    }
    p1
}

#[test]
fn attenuation_matches_quadrature_over_kappa() {
    // A_l(κ) = ∫ γ(t) P_l(t) over the sphere = ∫_0^{2κ} e^{−u} P_l(1 − u/κ) du / (1 − e^{−2κ}).
    for &kappa in &[1e-3, 0.1, 1.0, 7.0, 50.0, 1e3, 1e4, 1e6] {
        let mut a = [0.0f64; 9];
        sh_attenuation(kappa, &mut a);
        let umax = (2.0 * kappa).min(60.0);
        let n = 200_000;
        for (l, &al) in a.iter().enumerate() {
            let h = umax / n as f64;
            let f = |u: f64| (-u).exp() * legendre(l, 1.0 - u / kappa);
            let mut s = f(0.0) + f(umax);
            for i in 1..n {
                s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
            }
            let q = s * h / 3.0 / (-(-2.0 * kappa).exp_m1());
            assert!(
                (q - al).abs() < 1e-7 + 1e-6 * q.abs(),
                "κ={kappa} l={l}: recurrence {al} quadrature {q}"
            );
        }
        assert!((a[1] - mean_resultant(kappa)).abs() < 1e-9);
    }
}

#[test]
fn kappa_inverse_round_trips() {
    for &k in &[0.01, 0.5, 3.0, 40.0, 900.0, 5e4] {
        let back = kappa_from_resultant(mean_resultant(k));
        assert!((back / k - 1.0).abs() < 1e-6, "{k} -> {back}");
    }
}

fn random_map(n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = Rng(seed);
    (0..n * n)
        .map(|_| {
            let v = Vec3::new(r.f() as f32 - 0.5, r.f() as f32 - 0.5, 1.0);
            v.normalize()
        })
        .collect()
}

#[test]
fn sh_pyramid_is_the_box_average_and_keeps_gamma00() {
    let n = 16;
    let map = random_map(n, 7);
    let p = ShNdfPyramid::build(n, n, &map, 4);
    assert_eq!(p.levels.len(), 5);
    let y00 = 0.5 / std::f32::consts::PI.sqrt();
    for l in &p.levels {
        for c in l.coeffs.chunks(16) {
            assert!((c[0] - y00).abs() < 1e-6);
        }
    }
    // Level 2 texel (1, 2) = mean of y(n) over its 4×4 fine texels.
    let mut want = [0.0f32; 16];
    let mut y = [0.0f32; 16];
    for yy in 8..12 {
        for xx in 4..8 {
            relight_sh::eval_sh_into(4, map[yy * n + xx].to_array(), &mut y);
            for (w, v) in want.iter_mut().zip(&y) {
                *w += v / 16.0;
            }
        }
    }
    for (a, b) in p.texel(2, 1, 2).iter().zip(&want) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
    // Constant map: γ_lm = y_lm(n₀) at every level.
    let n0 = Vec3::new(0.2, -0.3, 0.9).normalize();
    let c = ShNdfPyramid::build(8, 8, &vec![n0; 64], 3);
    relight_sh::eval_sh_into(3, n0.to_array(), &mut y[..9]);
    for l in &c.levels {
        for t in l.coeffs.chunks(9) {
            for (a, b) in t.iter().zip(&y[..9]) {
                assert!((a - b).abs() < 1e-5);
            }
        }
    }
}

#[test]
fn em_recovers_a_known_three_lobe_mixture() {
    let truth = [
        (0.5, DVec3::new(0.0, 0.0, 1.0), 80.0),
        (0.3, DVec3::new(0.7, 0.0, 0.71).normalize(), 200.0),
        (0.2, DVec3::new(-0.3, -0.8, 0.5).normalize(), 30.0),
    ];
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let mut samples = Vec::with_capacity(100_000);
    for _ in 0..100_000 {
        let u = rng.f();
        let j = if u < 0.5 {
            0
        } else if u < 0.8 {
            1
        } else {
            2
        };
        samples.push(sample_vmf(&mut rng, truth[j].1, truth[j].2));
    }
    let w = vec![1.0; samples.len()];
    let mut lobes = seed_lobes(&samples, &w, 3);
    let trace = fit_em(
        &samples,
        &w,
        &mut lobes,
        &EmOptions {
            max_iter: 200,
            tol: 1e-9,
        },
    );
    for p in trace.log_likelihood.windows(2) {
        assert!(p[1] >= p[0] - 1e-9, "log-likelihood fell: {p:?}");
    }
    for (a, mu, k) in truth {
        let l = lobes
            .iter()
            .max_by(|x, y| x.vmf.mu.dot(mu).total_cmp(&y.vmf.mu.dot(mu)))
            .unwrap();
        let ang = l.vmf.mu.dot(mu).clamp(-1.0, 1.0).acos().to_degrees();
        assert!((l.alpha - a).abs() < 0.01, "α {} vs {a}", l.alpha);
        assert!(ang < 1.0, "angle {ang}°");
        assert!(
            (l.vmf.kappa / k - 1.0).abs() < 0.05,
            "κ {} vs {k}",
            l.vmf.kappa
        );
    }
    // Deterministic: the same input gives the same lobes.
    let mut again = seed_lobes(&samples, &w, 3);
    fit_em(
        &samples,
        &w,
        &mut again,
        &EmOptions {
            max_iter: 200,
            tol: 1e-9,
        },
    );
    assert_eq!(again, lobes);
}

/// `norm(κ)` is the density's normalization (`2π ∫ C e^{κ(t−1)} dt = 1` by
/// midpoint quadrature in `t = cos θ`, up to κ = 300) and
/// `exp(log_norm(κ))`.
#[test]
fn vmf_normalization_integrates_to_one() {
    for kappa in [1e-9, 1e-3, 0.5, 3.0, 19.9, 20.1, 300.0, 1e5] {
        let n = 200_000;
        let h = 2.0 / f64::from(n);
        let integral: f64 = (0..n)
            .map(|i| {
                let t = -1.0 + (f64::from(i) + 0.5) * h;
                (kappa * (t - 1.0)).exp() * h
            })
            .sum::<f64>()
            * 2.0
            * std::f64::consts::PI
            * norm(kappa);
        // Midpoint error ~ (hκ)²/24 relative: checked where that is small.
        if kappa <= 300.0 {
            let tol = 1e-9 + (h * kappa).powi(2) / 12.0;
            assert!((integral - 1.0).abs() < tol, "κ {kappa}: {integral}");
        }
        let rel = (norm(kappa) / log_norm(kappa).exp() - 1.0).abs();
        assert!(rel < 1e-14, "κ {kappa}: norm vs exp(log_norm) {rel:e}");
    }
}

/// The vectorized E-step's two copies (AVX2 + FMA where the CPU has it, and
/// the baseline one) fit the same lobes bit for bit, with weighted samples,
/// an empty lobe and a count that is not a whole number of blocks.
#[test]
fn em_gives_the_same_bits_with_and_without_simd() {
    let mut rng = Rng(0x5eed);
    let axes = [
        DVec3::Z,
        DVec3::new(0.6, 0.0, 0.8),
        DVec3::new(0.0, -0.6, 0.8),
    ];
    let samples: Vec<DVec3> = (0..1001)
        .map(|i| sample_vmf(&mut rng, axes[i % 3], [40.0, 200.0, 8.0][i % 3]))
        .collect();
    let w: Vec<f64> = (0..samples.len())
        .map(|i| if i % 5 == 0 { 2.0 } else { 1.0 })
        .collect();
    let mut start = seed_lobes(&samples, &w, 4);
    start[3].alpha = 0.0;
    let opts = EmOptions {
        max_iter: 30,
        tol: 0.0,
    };
    let (mut a, mut b) = (start.clone(), start);
    let ta = fit_em_on(&samples, &w, &mut a, &opts, true);
    let tb = fit_em_on(&samples, &w, &mut b, &opts, false);
    assert_eq!(ta, tb);
    assert_eq!(a, b);
    assert_eq!(a[3].alpha, 0.0, "an empty lobe stays empty");
    for p in ta.log_likelihood.windows(2) {
        assert!(p[1] >= p[0] - 1e-12, "log-likelihood fell: {p:?}");
    }
}

#[test]
fn constant_map_gives_one_clamped_lobe_at_every_level() {
    let n0 = Vec3::new(0.1, 0.2, 0.97).normalize();
    let p = VmfPyramid::build(8, 8, &vec![n0; 64], &VmfBakeOptions::default());
    for (k, l) in p.levels.iter().enumerate() {
        for t in l.lobes.chunks(p.lobes) {
            let live: Vec<_> = t
                .iter()
                .filter_map(|q| unpack(*q))
                .filter(|q| q.alpha > 1e-3)
                .collect();
            let sum: f32 = live.iter().map(|q| q.alpha).sum();
            assert!((sum - 1.0).abs() < 1e-4, "level {k}: weights {sum}");
            for q in live {
                assert!((q.mu - n0).length() < 1e-4, "level {k}: μ {}", q.mu);
                assert_eq!(q.inv_kappa, 0.0, "level {k}: κ not at its clamp");
            }
        }
    }
    let _ = KAPPA_MAX;
}

/// ∫ g(n) γ(n; μ, κ) dn by seeded Monte Carlo.
fn mc_vmf(mu: Vec3, kappa: f64, g: impl Fn(Vec3) -> f32) -> f64 {
    let mut rng = Rng(99);
    let n = 400_000;
    (0..n)
        .map(|_| g(sample_vmf(&mut rng, mu.as_dvec3(), kappa).as_vec3()) as f64)
        .sum::<f64>()
        / n as f64
}

#[test]
fn lambert_lobe_matches_monte_carlo() {
    let mu = Vec3::Z;
    for &kappa in &[0.01f64, 1.0, 5.0, 30.0, 300.0] {
        for &th in &[0.0f32, 0.8, 1.4, 1.9, 2.6] {
            let l = Vec3::new(th.sin(), 0.0, th.cos());
            let mc = mc_vmf(mu, kappa, |n| n.dot(l).max(0.0));
            let got = f64::from(lambert_lobe(l.z, 1.0 / kappa as f32));
            assert!(
                (got - mc).abs() < 0.012,
                "κ={kappa} θ={th}: {got} vs MC {mc}"
            );
        }
    }
}

#[test]
fn glossy_effective_brdfs_match_monte_carlo() {
    let wo = Vec3::new(0.3, 0.0, 0.95).normalize();
    let wi = Vec3::new(-0.25, 0.1, 0.96).normalize();
    for (brdf, kappa, tol) in [
        (NdfBrdf::Blinn { s: 64.0 }, 200.0, 0.05),
        (NdfBrdf::Blinn { s: 16.0 }, 50.0, 0.05),
        (NdfBrdf::Ggx { alpha: 0.3 }, 100.0, 0.10),
        (NdfBrdf::Beckmann { alpha: 0.3 }, 100.0, 0.10),
    ] {
        let mc = mc_vmf(Vec3::Z, kappa, |n| shade_lobe(brdf, n, 0.0, wo, wi));
        let got = f64::from(shade_lobe(brdf, Vec3::Z, 1.0 / kappa as f32, wo, wi));
        assert!(
            (got / mc - 1.0).abs() < tol,
            "{brdf:?} κ={kappa}: effective {got} vs MC {mc}"
        );
    }
}

#[test]
fn one_lobe_agrees_with_toksvig_when_the_mean_normal_is_long() {
    let brdf = NdfBrdf::Blinn { s: 32.0 };
    let wo = Vec3::new(0.2, 0.0, 0.98).normalize();
    let wi = Vec3::new(-0.2, 0.05, 0.98).normalize();
    for &r in &[0.9f32, 0.95, 0.99] {
        let kappa = kappa_from_resultant(f64::from(r)) as f32;
        let v = shade_lobe(brdf, Vec3::Z, 1.0 / kappa, wo, wi);
        let t = shade_baseline(brdf, Baseline::Toksvig, Vec3::Z * r, wo, wi);
        assert!((v / t - 1.0).abs() < 0.10, "|n̄|={r}: vMF {v} Toksvig {t}");
    }
}

#[test]
fn mean_pyramid_averages() {
    let map = random_map(4, 3);
    let p = MeanPyramid::build(4, 4, &map);
    let mean = map.iter().copied().sum::<Vec3>() / 16.0;
    assert!((p.levels[2].2[0] - mean).length() < 1e-6);
}

#[test]
fn sh_rotation_convention_of_the_vertex_lighting() {
    // ShRotation::from_rotation(R) turns f into f∘Rᵀ (what set_lighting relies on).
    let r = Mat3::from_euler(glam::EulerRot::YXZ, 0.7, -0.4, 1.1);
    let mut c = [0.0f32; 9];
    let d0 = Vec3::new(0.3, 0.5, 0.8).normalize();
    relight_sh::eval_sh_into(3, d0.to_array(), &mut c); // a "lobe" toward d0
    let rot = relight_sh::rotation::ShRotation::<f32>::from_rotation(
        3,
        &relight_sh::rotation::Rot3::from_mat3_unchecked(r),
    )
    .unwrap();
    let mut out = [0.0f32; 9];
    rot.apply(&c, &mut out);
    let d = Vec3::new(-0.2, 0.4, 0.7).normalize();
    let mut y = [0.0f32; 9];
    relight_sh::eval_sh_into(3, d.to_array(), &mut y);
    let a: f32 = out.iter().zip(&y).map(|(p, q)| p * q).sum();
    relight_sh::eval_sh_into(3, (r.transpose() * d).to_array(), &mut y);
    let b: f32 = c.iter().zip(&y).map(|(p, q)| p * q).sum();
    assert!((a - b).abs() < 1e-4, "{a} vs {b}");
    let _ = Lobe {
        alpha: 1.0,
        vmf: Vmf {
            mu: DVec3::Z,
            kappa: 1.0,
        },
    };
}

#[test]
fn lean_moments_of_a_constant_map_and_a_two_normal_groove() {
    use relight_ndf::LeanPyramid;
    let slope = |bx: f32, by: f32| Vec3::new(bx, by, 1.0).normalize();
    // Constant: B = its slope, Σ = 0 at every level.
    let p = LeanPyramid::build(8, 8, &[slope(0.3, -0.2); 64]);
    for (_, _, t) in &p.levels {
        for t in t {
            assert!((t.b - glam::Vec2::new(0.3, -0.2)).abs().max_element() < 1e-6);
            assert!(t.covariance().abs().max_element() < 1e-6, "{t:?}");
        }
    }
    // Two slopes (0.4, 0.1) and (−0.2, 0.3) in a checkerboard: B = (0.1, 0.2),
    // Σ = ((0.09, −0.03), (−0.03, 0.01)) by hand.
    let g: Vec<Vec3> = (0..64)
        .map(|i| {
            if (i % 8 + i / 8) % 2 == 0 {
                slope(0.4, 0.1)
            } else {
                slope(-0.2, 0.3)
            }
        })
        .collect();
    let t = LeanPyramid::build(8, 8, &g).texel(3, 0, 0);
    assert!((t.b - glam::Vec2::new(0.1, 0.2)).abs().max_element() < 1e-6);
    let c = t.covariance();
    assert!(
        (c - Vec3::new(0.09, 0.01, -0.03)).abs().max_element() < 1e-5,
        "{c}"
    );
    // Level 1 of the checkerboard is the same mixture.
    assert!((LeanPyramid::build(8, 8, &g).texel(1, 2, 3).b - t.b).length() < 1e-6);
}

#[test]
fn lean_isotropic_spread_is_the_widened_brdf() {
    use relight_ndf::LeanPyramid;
    use relight_ndf::lean::shade_lean;
    // Slopes (±d, 0), (0, ±d): B = 0, Σ = d²/2 I, so LEAN's lobe is the BRDF
    // widened by 1/κ = d²/2 (α′² = α² + 2/κ): exact for GGX and Beckmann at
    // every direction, and for Blinn at the peak h = +Z; at d = 0 the base BRDF.
    for d in [0.0f32, 0.3] {
        let n = |bx: f32, by: f32| Vec3::new(bx, by, 1.0).normalize();
        let map = [n(d, 0.0), n(-d, 0.0), n(0.0, -d), n(0.0, d)];
        let t = LeanPyramid::build(2, 2, &map).texel(1, 0, 0);
        let ik = 0.5 * d * d;
        let dirs = [
            Vec3::new(0.3, 0.1, 0.95),
            Vec3::new(-0.5, 0.2, 0.84),
            Vec3::new(0.1, -0.7, 0.7),
            Vec3::new(0.6, 0.5, 0.62),
        ];
        for brdf in [
            NdfBrdf::Ggx { alpha: 0.3 },
            NdfBrdf::Beckmann { alpha: 0.2 },
            NdfBrdf::Blinn { s: 64.0 },
        ] {
            for wo in dirs {
                let wo = wo.normalize();
                let peak = Vec3::new(-wo.x, -wo.y, wo.z);
                for wi in dirs.map(Vec3::normalize).into_iter().chain([peak]) {
                    if matches!(brdf, NdfBrdf::Blinn { .. }) && d > 0.0 && wi != peak {
                        continue;
                    }
                    let want = shade_lobe(brdf, Vec3::Z, ik, wo, wi);
                    let got = shade_lean(brdf, &t, wo, wi);
                    assert!(
                        (got - want).abs() <= 1e-4 * want.abs().max(1e-3),
                        "{brdf:?} d={d} wo={wo} wi={wi}: LEAN {got} vs widened {want}"
                    );
                }
            }
        }
    }
}

#[test]
fn clamped_cosine_factors_match_quadrature() {
    use relight_ndf::effective::clamped_cosine_factor;
    for l in 0..16 {
        // 2π ∫_0^1 t P_l(t) dt by composite Simpson (a polynomial: exact).
        let m = 2000;
        let h = 1.0 / m as f64;
        let f = |t: f64| t * legendre(l, t);
        let mut s = f(0.0) + f(1.0);
        for i in 1..m {
            s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        let q = 2.0 * std::f64::consts::PI * s * h / 3.0;
        let got = clamped_cosine_factor(l);
        assert!((got - q).abs() < 1e-9, "Λ_{l}: {got} vs {q}");
    }
}

#[test]
fn lambert_tail_of_a_delta_completes_the_irradiance() {
    use relight_ndf::effective::{clamped_cosine_factor, lambert_sh_env, lambert_tail_env};
    // A lighting of 9 bands, arbitrary coefficients; the normal a delta.
    let n = 9;
    let light: Vec<f32> = (0..n * n)
        .map(|i| ((i * 37 % 11) as f32 - 5.0) * 0.1)
        .collect();
    let nrm = Vec3::new(0.3, -0.4, 0.866).normalize();
    let mut y = vec![0.0f32; n * n];
    relight_sh::eval_sh_into(n, nrm.to_array(), &mut y);
    let want: f64 = (0..n * n)
        .map(|i| {
            let l = (i as f64).sqrt() as usize;
            clamped_cosine_factor(l) * f64::from(y[i] * light[i])
        })
        .sum::<f64>()
        / std::f64::consts::PI;
    let mut scratch = vec![0.0f32; n * n];
    let got = lambert_sh_env(&y, &light) + lambert_tail_env(nrm, &light, &mut scratch);
    assert!((f64::from(got) - want).abs() < 1e-5, "{got} vs {want}");
    // A wide lobe's tail is attenuated by A_l(κ) < 1.
    let wide = lambert_tail_env(nrm * 0.5, &light, &mut scratch);
    let full = lambert_tail_env(nrm, &light, &mut scratch);
    assert!(wide.abs() < 0.2 * full.abs(), "{wide} vs {full}");
}

#[test]
fn prepared_lambert_tail_matches_the_portable_one() {
    use relight_ndf::effective::{LAMBERT_TAIL_ORDER, LambertTail, lambert_tail_channels};
    let nn = LAMBERT_TAIL_ORDER * LAMBERT_TAIL_ORDER;
    let chan = |k: usize| -> Vec<f32> {
        (0..nn)
            .map(|i| (((i * 37 + k * 13) % 11) as f32 - 5.0) * 0.1)
            .collect()
    };
    let (r, g, b) = (chan(0), chan(1), chan(2));
    let tail = LambertTail::new([&r, &g, &b]);
    let mut rng = Rng(0x5eed_7a11);
    let mut scratch = vec![0.0f32; nn];
    let mut worst = 0.0f32;
    // Delta (|m| = 1), sharp, wide and near-isotropic lobes.
    for len in [1.0f32, 0.999_9, 0.99, 0.9, 0.6, 0.2, 0.01] {
        for _ in 0..20 {
            let d = Vec3::new(
                rng.f() as f32 - 0.5,
                rng.f() as f32 - 0.5,
                rng.f() as f32 - 0.5,
            )
            .normalize();
            let m = d * len;
            let want = Vec3::from(lambert_tail_channels(m, [&r, &g, &b], &mut scratch));
            let got = tail.eval_exact(m);
            worst = worst.max((got - want).abs().max_element());
        }
    }
    // The tail's scale here is ~0.1 (coefficients ≤ 0.5).
    assert!(worst < 1e-6, "prepared vs portable: {worst}");
    assert_eq!(LambertTail::new([&[], &[], &[]]).eval(Vec3::Z), Vec3::ZERO);
    assert_eq!(
        LambertTail::new([&[], &[], &[]]).eval_exact(Vec3::Z),
        Vec3::ZERO
    );
}

#[test]
fn baked_lambert_tail_matches_the_portable_one() {
    use relight_ndf::effective::{LAMBERT_TAIL_ORDER, LambertTail, lambert_tail_channels};
    let nn = LAMBERT_TAIL_ORDER * LAMBERT_TAIL_ORDER;
    // Every coefficient of the same size: band 8 as strong as band 4, a
    // harder case than an environment's falling spectrum.
    let chan = |k: usize| -> Vec<f32> {
        (0..nn)
            .map(|i| (((i * 37 + k * 13) % 11) as f32 - 5.0) * 0.1)
            .collect()
    };
    let (r, g, b) = (chan(0), chan(1), chan(2));
    let tail = LambertTail::new([&r, &g, &b]);
    let mut rng = Rng(0x7ab1_e5ed);
    let mut scratch = vec![0.0f32; nn];
    let (mut worst, mut scale) = (0.0f32, 0.0f32);
    let mut dirs: Vec<Vec3> = (0..2000)
        .map(|_| {
            Vec3::new(
                rng.f() as f32 - 0.5,
                rng.f() as f32 - 0.5,
                rng.f() as f32 - 0.5,
            )
            .normalize()
        })
        .collect();
    // The octahedral map's seams, folds and corners.
    for t in [-0.999f32, -0.5, -1e-4, 0.0, 1e-4, 0.3, 0.999] {
        dirs.push(Vec3::new(t, 1e-6, -(1.0 - t * t).sqrt()).normalize());
        dirs.push(Vec3::new(1e-6, t, -(1.0 - t * t).sqrt()).normalize());
        dirs.push(Vec3::new(t, -1e-6, -0.999).normalize());
    }
    dirs.extend([Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::Y]);
    for len in [1.0f32, 0.999_9, 0.99, 0.9, 0.6, 0.2] {
        for d in &dirs {
            let m = *d * len;
            let want = Vec3::from(lambert_tail_channels(m, [&r, &g, &b], &mut scratch));
            let got = tail.eval(m);
            worst = worst.max((got - want).abs().max_element());
            scale = scale.max(want.abs().max_element());
        }
    }
    eprintln!("baked tail: worst {worst:.3e} at scale {scale:.3e}");
    // Interpolation error of band-8 content on a 256² octahedral grid:
    // within 1 % of the tail's scale.
    assert!(
        worst < 1e-2 * scale,
        "baked vs portable: {worst} (scale {scale})"
    );
}

#[test]
fn footprint_sampling_is_the_mean_of_the_probes_samples() {
    use glam::{Vec2, Vec4};
    use relight_ndf::Footprint;
    let map = relight_render::NormalMap::bumps(32, 4, 0.8);
    let (w, h) = (map.width, map.height);
    let sh = ShNdfPyramid::build(w, h, &map.texels, 3);
    let sh5 = ShNdfPyramid::build(w, h, &map.texels, 5);
    let mean = MeanPyramid::build(w, h, &map.texels);
    let vmf = VmfPyramid::build(
        w,
        h,
        &map.texels,
        &VmfBakeOptions {
            lobes: 3,
            ..VmfBakeOptions::default()
        },
    );
    let uv = Vec2::new(0.37, 0.61);
    // Isotropic, 3:1, 40:1 (capped), magnified.
    for (dx, dy) in [
        (Vec2::new(3.0, 0.5), Vec2::new(-0.5, 3.0)),
        (Vec2::new(1.0, 0.2), Vec2::new(0.3, 3.0)),
        (Vec2::new(40.0, 1.0), Vec2::new(0.0, 1.0)),
        (Vec2::new(0.3, 0.0), Vec2::new(0.0, 0.2)),
    ] {
        let fp = Footprint::of(uv, dx / w as f32, dy / h as f32, w, h);
        let n = fp.count as f32;
        for pyr in [&sh, &sh5] {
            let nn = pyr.order * pyr.order;
            let mut want = vec![0.0f32; nn];
            let mut one = vec![0.0f32; nn];
            for p in fp.probes() {
                pyr.sample(*p, fp.lod, &mut one);
                for (a, b) in want.iter_mut().zip(&one) {
                    *a += b / n;
                }
            }
            let mut got = vec![0.0f32; nn];
            pyr.sample_footprint(&fp, &mut got);
            for (a, b) in got.iter().zip(&want) {
                assert!((a - b).abs() < 1e-6, "sh order {}: {a} vs {b}", pyr.order);
            }
        }
        let mut want = [Vec4::ZERO; 3];
        let mut one = [Vec4::ZERO; 3];
        for p in fp.probes() {
            vmf.sample(*p, fp.lod, &mut one);
            for (a, b) in want.iter_mut().zip(&one) {
                *a += *b / n;
            }
        }
        let mut got = [Vec4::ZERO; 3];
        vmf.sample_footprint(&fp, &mut got);
        for (a, b) in got.iter().zip(&want) {
            assert!((*a - *b).abs().max_element() < 1e-6, "vmf: {a} vs {b}");
        }
        let want: Vec3 = fp
            .probes()
            .iter()
            .map(|p| mean.sample(*p, fp.lod))
            .sum::<Vec3>()
            / n;
        let got = mean.sample_footprint(&fp);
        assert!(
            (got - want).abs().max_element() < 1e-6,
            "mean: {got} vs {want}"
        );
    }
}

#[test]
fn visible_fraction_matches_monte_carlo() {
    use relight_ndf::effective::visible_fraction;
    for &kappa in &[3.0f64, 20.0, 100.0, 1000.0] {
        for &th in &[0.3f32, 1.2, 1.5, 1.65, 2.2] {
            let v = Vec3::new(th.sin(), 0.0, th.cos());
            let mc = mc_vmf(Vec3::Z, kappa, |n| if n.dot(v) > 0.0 { 1.0 } else { 0.0 });
            let got = f64::from(visible_fraction(v.z, 1.0 / kappa as f32));
            assert!(
                (got - mc).abs() < 0.04,
                "κ={kappa} θ={th}: {got} vs MC {mc}"
            );
        }
    }
    assert_eq!(visible_fraction(0.1, 0.0), 1.0);
    assert_eq!(visible_fraction(-0.1, 0.0), 0.0);
}

#[test]
fn masked_lobes_match_monte_carlo_at_grazing_views() {
    // Views 8°–25° above the plane, lobes whose normals partly face away
    // from them: the view mask (plain normal mapping's, per normal) matters.
    // (Far off the highlight — μ·ω_o < 0, ĥ 50° from μ — the Blinn closed
    // form is ~45 % low: its lobe shape, not the mask; the axis mask gave 0.)
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z).normalize();
    let lam = NdfBrdf::Lambert;
    let cases = [
        (
            lam,
            v(0.25, 0.0, 0.97),
            v(-0.99, 0.0, 0.14),
            v(0.2, 0.3, 0.93),
            30.0,
            0.05,
        ),
        (
            lam,
            v(0.25, 0.0, 0.97),
            v(-0.99, 0.0, 0.14),
            v(0.2, 0.3, 0.93),
            300.0,
            0.05,
        ),
        (
            NdfBrdf::Blinn { s: 16.0 },
            v(0.1, 0.0, 0.99),
            v(-0.97, 0.0, 0.25),
            v(0.6, 0.2, 0.77),
            30.0,
            0.05,
        ),
        (
            NdfBrdf::Blinn { s: 64.0 },
            v(0.1, 0.0, 0.99),
            v(-0.97, 0.0, 0.25),
            v(0.6, 0.2, 0.77),
            100.0,
            0.15,
        ),
        (
            NdfBrdf::Blinn { s: 16.0 },
            v(-0.1, 0.0, 0.99),
            v(-0.97, 0.0, 0.25),
            v(0.9, 0.1, 0.42),
            20.0,
            0.10,
        ),
        (
            NdfBrdf::Blinn { s: 64.0 },
            v(0.3, 0.0, 0.95),
            v(-0.9, 0.0, 0.43),
            v(0.9, 0.0, 0.43),
            60.0,
            0.05,
        ),
    ];
    for (brdf, mu, wo, wi, kappa, tol) in cases {
        let mc = mc_vmf(mu, kappa, |n| shade_lobe(brdf, n, 0.0, wo, wi));
        let got = f64::from(shade_lobe(brdf, mu, 1.0 / kappa as f32, wo, wi));
        assert!(
            (got / mc - 1.0).abs() < tol,
            "{brdf:?} κ={kappa}: effective {got} vs MC {mc}"
        );
    }
}

#[test]
fn footprint_probes_span_the_major_axis() {
    use glam::Vec2;
    use relight_ndf::Footprint;
    // The level whose texel ⊗ bilinear tent has the variance of a ρ-texel box
    // over bilinear level 0: 4^k/4 = ρ²/12 + 1/6.
    // Read `LEVEL_BIAS` finer, clamped at 0.
    let matched = |rho: f32| 0.5 * ((rho * rho + 2.0) / 3.0).log2();
    let level = |rho: f32| (matched(rho) - relight_ndf::LEVEL_BIAS).max(0.0);
    let uv = Vec2::new(0.3, 0.6);
    // Isotropic: one probe.
    let (dx, dy) = (Vec2::new(4.0, 0.0) / 64.0, Vec2::new(0.0, 4.0) / 64.0);
    let f = Footprint::of(uv, dx, dy, 64, 64);
    assert_eq!(f.count, 1);
    assert!((f.lod - level(4.0)).abs() < 1e-6);
    let k = f.lod + relight_ndf::LEVEL_BIAS;
    assert!((4.0f32.powf(k) / 4.0 - (16.0 / 12.0 + 1.0 / 6.0)).abs() < 1e-5);
    // 4:1 along y: 4 probes over ∂uv/∂y at the minor axis' level (2 texels).
    let (dx, dy) = (Vec2::new(2.0, 0.0) / 64.0, Vec2::new(0.0, 8.0) / 64.0);
    let f = Footprint::of(uv, dx, dy, 64, 64);
    assert_eq!(f.count, 4);
    assert!((f.lod - level(2.0)).abs() < 1e-6, "{}", f.lod);
    let mean = f.probes().iter().copied().sum::<Vec2>() / 4.0;
    assert!((mean - uv).length() < 1e-6);
    let span = f.probes()[3] - f.probes()[0];
    assert!((span - dy * 0.75).length() < 1e-6, "{span}");
    // 100:1 is capped at MAX_PROBES = 4 probes of 25 texels.
    let f = Footprint::of(
        uv,
        Vec2::new(1.0, 0.0) / 64.0,
        Vec2::new(0.0, 100.0) / 64.0,
        64,
        64,
    );
    assert_eq!(f.count, relight_ndf::MAX_PROBES);
    assert!((f.lod - level(100.0 / relight_ndf::MAX_PROBES as f32)).abs() < 1e-5);
    // Magnified: level 0.
    let f = Footprint::of(uv, dx / 4.0, dy / 16.0, 64, 64);
    assert_eq!((f.count, f.lod), (1, 0.0));
}

#[test]
fn forward_attenuation_matches_the_backward_recurrence() {
    use relight_ndf::vmf::sh_attenuation_forward;
    let mut worst = 0.0f64;
    for i in 0..=80 {
        let kappa = 10f64.powf(-3.0 + i as f64 * 0.1); // 1e-3 … 1e5
        let (mut a, mut b) = ([0.0f64; 16], [0.0f64; 16]);
        sh_attenuation(kappa, &mut a);
        sh_attenuation_forward(kappa, &mut b);
        for (x, y) in a.iter().zip(&b) {
            worst = worst.max((x - y).abs());
        }
    }
    assert!(worst < 1e-6, "max |forward − backward| = {worst}");
}

#[test]
fn footprint_taps_equal_the_per_probe_trilinear_taps() {
    // The straightforward form the tap list replaced: per probe, per level,
    // the shared bilinear taps times (1 − t)/count and t/count.
    let dims = |k: usize| (512usize >> k, 512usize >> k);
    let levels = 10;
    let mut rng = relight_ndf::vmf::Xorshift(7);
    for _ in 0..2000 {
        let uv = glam::Vec2::new(rng.next_f64() as f32 * 16.0, rng.next_f64() as f32 * 16.0);
        let dx = glam::Vec2::new(rng.next_f64() as f32 - 0.5, rng.next_f64() as f32 - 0.5) * 0.2;
        let dy = glam::Vec2::new(rng.next_f64() as f32 - 0.5, rng.next_f64() as f32 - 0.5) * 0.02;
        let fp = relight_ndf::Footprint::of(uv, dx, dy, 512, 512);
        let mut want = Vec::new();
        let lod = fp.lod.clamp(0.0, (levels - 1) as f32);
        let k0 = lod.floor() as usize;
        let t = lod - k0 as f32;
        let w = 1.0 / fp.count as f32;
        let mut level = |k: usize, wk: f32| {
            let (lw, lh) = dims(k);
            for p in fp.probes() {
                for (i, wt) in relight_render::texture::bilinear_taps(lw, lh, *p) {
                    want.push((k, i, wt * wk));
                }
            }
        };
        level(k0, (1.0 - t) * w);
        if t > 0.0 && k0 + 1 < levels {
            level(k0 + 1, t * w);
        }
        let mut got = Vec::new();
        fp.for_each_tap(levels, dims, |k, i, w| got.push((k, i, w)));
        assert_eq!(got, want);
    }
}

#[test]
fn footprint_samplers_equal_the_plain_tap_loop_bit_for_bit() {
    // The samplers' register accumulators against the plain loop they
    // replaced (`out[c] += w · texel[c]` per tap, in tap order).
    let map = relight_render::NormalMap::bumps(64, 4, 0.8);
    let sh = ShNdfPyramid::build(64, 64, &map.texels, 3);
    let sh4 = ShNdfPyramid::build(64, 64, &map.texels, 4);
    let vmf = VmfPyramid::build(64, 64, &map.texels, &VmfBakeOptions::default());
    let mut rng = relight_ndf::vmf::Xorshift(11);
    for _ in 0..500 {
        let uv = glam::Vec2::new(rng.next_f64() as f32 * 4.0, rng.next_f64() as f32 * 4.0);
        let dx = glam::Vec2::new(rng.next_f64() as f32 - 0.5, rng.next_f64() as f32 - 0.5) * 0.3;
        let dy = glam::Vec2::new(rng.next_f64() as f32 - 0.5, rng.next_f64() as f32 - 0.5) * 0.05;
        let fp = relight_ndf::Footprint::of(uv, dx, dy, 64, 64);
        for p in [&sh, &sh4] {
            let nn = p.order * p.order;
            let mut want = vec![0.0f32; nn];
            fp.for_each_tap(
                p.levels.len(),
                |k| (p.levels[k].width, p.levels[k].height),
                |k, i, w| {
                    for (o, c) in want
                        .iter_mut()
                        .zip(&p.levels[k].coeffs[i * nn..(i + 1) * nn])
                    {
                        *o += w * c;
                    }
                },
            );
            let mut got = vec![0.0f32; nn];
            p.sample_footprint(&fp, &mut got);
            assert_eq!(
                got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                want.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            );
        }
        let j = vmf.lobes;
        let mut want = vec![glam::Vec4::ZERO; j];
        fp.for_each_tap(
            vmf.levels.len(),
            |k| (vmf.levels[k].width, vmf.levels[k].height),
            |k, i, w| {
                for (o, v) in want
                    .iter_mut()
                    .zip(&vmf.levels[k].lobes[i * j..(i + 1) * j])
                {
                    *o += *v * w;
                }
            },
        );
        let mut got = vec![glam::Vec4::ZERO; j];
        vmf.sample_footprint(&fp, &mut got);
        assert_eq!(got, want);
    }
}

#[test]
fn tabulated_tail_attenuation_matches_the_recurrence() {
    use relight_ndf::effective::LambertTail;
    let mut worst = 0.0f32;
    let mut rng = relight_ndf::vmf::Xorshift(3);
    let mut rs: Vec<f32> = (0..20000).map(|_| rng.next_f64() as f32).collect();
    // Near 1 (κ up to the clamp) and near 0, and the nodes themselves.
    rs.extend((0..2000).map(|i| 1.0 - 1e-6 * i as f32));
    rs.extend((0..2000).map(|i| 1e-5 * i as f32));
    rs.extend((0..=4096).map(|i| i as f32 / 4096.0));
    for r in rs {
        let (a, b) = (
            LambertTail::attenuation_468(r),
            LambertTail::attenuation_468_exact(r),
        );
        for c in 0..3 {
            worst = worst.max((a[c] - b[c]).abs());
        }
    }
    // The tail these multiply is ≲ 0.1 of a pixel's radiance: ≤ 5e-7 of it.
    assert!(worst <= 5e-6, "worst |ΔA_l| {worst}");
}

#[test]
fn fast_unpack_matches_unpack() {
    // Packed lobes over the whole range of resultants (uniform to the
    // clamp), weights from tiny to 1: the same lobe up to f32 rounding.
    use glam::Vec4;
    use relight_ndf::pyramid::unpack_fast;
    let mut rng = relight_ndf::vmf::Xorshift(0xface_b00c_1234_5678);
    let mut n = 0;
    for k in 0..100_000 {
        let alpha = [1.0, 0.3, 1e-3, 2e-6][k % 4] as f32;
        let r = match k % 5 {
            0 => rng.next_f64(),
            1 => 1.0 - rng.next_f64() * 1e-3,
            2 => 1.0 - rng.next_f64() * 1e-5,
            3 => rng.next_f64() * 1e-3,
            _ => 0.9 + 0.1 * rng.next_f64(),
        } as f32;
        let d = Vec3::new(
            rng.next_f64() as f32 - 0.5,
            rng.next_f64() as f32 - 0.5,
            rng.next_f64() as f32 - 0.5,
        )
        .normalize_or(Vec3::Z);
        let m = d * (alpha * r);
        let p = Vec4::new(alpha, m.x, m.y, m.z);
        match (unpack(p), unpack_fast(p)) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                n += 1;
                assert_eq!(a.alpha, b.alpha);
                assert!((a.mu - b.mu).length() <= 1e-6, "{a:?} {b:?}");
                if a.inv_kappa == 0.0 || b.inv_kappa == 0.0 {
                    // The delta branch: decided on the same `r` up to an ulp.
                    assert!(a.inv_kappa.max(b.inv_kappa) < 2e-5, "{a:?} {b:?}");
                } else {
                    // `1 − r²` cancels near r = 1: an ulp of r (the two
                    // forms round `m` differently) moves 1/κ ≈ 1 − r by
                    // ~6e-8, as it moves `unpack`'s own.
                    let d = (a.inv_kappa - b.inv_kappa).abs();
                    assert!(d <= 1e-5 * a.inv_kappa + 3e-7, "{a:?} {b:?}: {d}");
                }
            }
            (a, b) => panic!("{p}: {a:?} vs {b:?}"),
        }
    }
    assert!(n > 50_000);
}

#[test]
fn per_frame_blinn_mixture_matches_shade_mixture() {
    // The renderer's Blinn mixture (normalization passed in) against
    // `shade_mixture`, over lobes from wide to deltas and directions over the
    // hemisphere: within 1e-5 of the mixture's scale.
    use relight_brdf::phong::blinn_phong_normalization;
    use relight_ndf::effective::{shade_mixture, shade_mixture_blinn};
    use relight_ndf::pyramid::ShadeLobe;
    let mut rng = relight_ndf::vmf::Xorshift(0x0b1e_55ed_cafe_0001);
    let mut dir = |up: bool| {
        let v = Vec3::new(
            rng.next_f64() as f32 * 2.0 - 1.0,
            rng.next_f64() as f32 * 2.0 - 1.0,
            rng.next_f64() as f32 * 2.0 - 1.0,
        )
        .normalize_or(Vec3::Z);
        if up {
            Vec3::new(v.x, v.y, v.z.abs())
        } else {
            v
        }
    };
    let mut worst = 0.0f32;
    for s in [1.0f32, 8.0, 64.0, 1000.0] {
        let c = blinn_phong_normalization(s);
        for k in 0..20_000 {
            let lobes: Vec<ShadeLobe> = (0..6)
                .map(|j| ShadeLobe {
                    alpha: 1.0 / 6.0,
                    mu: Vec3::Z.lerp(dir(false), 0.4).normalize(),
                    inv_kappa: [0.0, 1e-4, 0.01, 0.2, 1.0, 500.0][(j + k) % 6],
                })
                .collect();
            let (wo, wi) = (dir(true), dir(true));
            let want = shade_mixture(NdfBrdf::Blinn { s }, &lobes, wo, wi);
            let got = shade_mixture_blinn(s, c, &lobes, wo, wi);
            // Scale: the mixture's peak, the normalization times Σ α.
            worst = worst.max((want - got).abs() / c);
        }
    }
    assert!(worst <= 1e-5, "worst difference {worst} of the scale");
}

/// `VmfBakeOptions::max_samples`: a footprint within the cap reads every
/// normal (the bake is the uncapped one, bit for bit), and a bake capped at
/// 256 keeps each coarser texel's mean normal (the packed lobes' summed
/// first moments) within 0.05 of the full fit's — the error of a mean of
/// 256 normals of spread ≈ 0.35 (measured up to 0.033 at the 1 × 1 level;
/// the default cap, 1024, halves it).
#[test]
fn a_capped_vmf_bake_samples_large_footprints_and_keeps_their_mean() {
    let map = relight_render::NormalMap::bumps(128, 8, 0.8);
    let uncapped = VmfBakeOptions {
        max_samples: usize::MAX,
        ..VmfBakeOptions::default()
    };
    let small = &map.texels[..32 * 32];
    assert_eq!(
        VmfPyramid::build(32, 32, small, &VmfBakeOptions::default()),
        VmfPyramid::build(32, 32, small, &uncapped)
    );
    let full = VmfPyramid::build(128, 128, &map.texels, &uncapped);
    let capped = VmfPyramid::build(
        128,
        128,
        &map.texels,
        &VmfBakeOptions {
            max_samples: 256,
            ..VmfBakeOptions::default()
        },
    );
    assert_ne!(full, capped);
    for k in 5..full.levels.len() {
        let (a, b) = (&full.levels[k], &capped.levels[k]);
        for t in 0..a.width * a.height {
            let mean = |l: &relight_ndf::pyramid::VmfLevel| -> Vec3 {
                l.lobes[t * full.lobes..(t + 1) * full.lobes]
                    .iter()
                    .map(|p| Vec3::new(p.y, p.z, p.w))
                    .sum()
            };
            let d = (mean(a) - mean(b)).length();
            assert!(d < 0.05, "level {k} texel {t}: mean normals differ by {d}");
        }
    }
}
