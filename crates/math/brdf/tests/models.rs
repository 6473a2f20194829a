//! Property tests of every model: furnace, pdf normalization, sampling
//! consistency, estimator vs quadrature, histogram vs pdf, reciprocity and
//! distribution normalization. Seeded; failures print both values.

use glam::{DVec3, Vec2, Vec3};
use relight_brdf::merl::Merl;
use relight_brdf::microfacet::{ggx_d, ggx_vndf_pdf};
use relight_brdf::verify::{
    Pcg32, direction_deg, directional_albedo_quadrature, directional_albedo_sampled,
    pdf_integral_quadrature, reciprocity_error, sphere_quadrature,
};
use relight_brdf::ward::ward_d;
use relight_brdf::{AshikhminShirley, BlinnPhong, Brdf, BrdfSpec, Phong};
use std::f32::consts::FRAC_PI_2;
use std::sync::Arc;

const QUAD: (usize, usize) = (384, 96);

fn build(spec: &str) -> Arc<dyn Brdf> {
    spec.parse::<BrdfSpec>()
        .unwrap_or_else(|e| panic!("{spec}: {e}"))
        .build()
}

/// White models spanning each family's parameter range (furnace-ready).
const WHITE: &[&str] = &[
    "lambert",
    "oren-nayar:0.2",
    "oren-nayar:0.5",
    "oren-nayar:1.5707963",
    "phong:0",
    "phong:5",
    "phong:200",
    "blinn:0",
    "blinn:10",
    "blinn:300",
    "ward:0.05",
    "ward:0.3",
    "ward:1",
    "ward:0.05,0.5",
    "ggx:0.05",
    "ggx:0.3",
    "ggx:1",
    "ggx:0.05,0.6",
    "ashikhmin:0,0,1",
    "ashikhmin:50,50,1",
    "ashikhmin:500,20,1",
    "ashikhmin:10,10",
    "ashikhmin:100,5,0",
    "0.5*lambert+0.5*phong:50",
    "0.3*oren-nayar:0.4+0.7*ggx:0.2",
];

/// Smooth enough lobes for sampling and histogram checks.
const SAMPLED: &[&str] = &[
    "lambert@0.9,0.5,0.2",
    "oren-nayar:0.6",
    "phong:20",
    "blinn:40@1,0.8,0.5",
    "ward:0.25",
    "ward:0.15,0.45",
    "ggx:0.3",
    "ggx:0.15,0.5@0.9,0.6,0.3",
    "ashikhmin:60,10,0.3@0.6,0.6,0.9",
    "ashikhmin:20,80,1",
    "0.6*lambert+0.4*ggx:0.2",
];

fn sampled_models() -> Vec<(String, Arc<dyn Brdf>)> {
    let mut v: Vec<_> = SAMPLED.iter().map(|s| (s.to_string(), build(s))).collect();
    let blinn = BlinnPhong::new(15.0, Vec3::new(0.9, 0.7, 0.5)).unwrap();
    let merl = Merl::from_fn([24, 24, 48], |wo, wi| blinn.eval(wo, wi)).unwrap();
    v.push(("merl(blinn:15)".into(), Arc::new(merl)));
    v
}

fn wos() -> Vec<(f32, Vec3)> {
    [
        (0.0, 0.0),
        (25.0, 10.0),
        (50.0, 100.0),
        (70.0, 200.0),
        (85.0, 300.0),
    ]
    .into_iter()
    .map(|(t, p)| (t, direction_deg(t, p)))
    .collect()
}

#[test]
fn white_furnace_albedo_at_most_one() {
    let mut worst = (0.0f64, String::new());
    for spec in WHITE {
        let b = build(spec);
        for theta in [0.0f32, 20.0, 45.0, 60.0, 75.0, 85.0, 89.5] {
            for phi in [0.0f32, 37.0, 90.0] {
                let a = directional_albedo_quadrature(&*b, direction_deg(theta, phi), QUAD);
                let m = a.max_element();
                // Oren–Nayar's qualitative model is known to overshoot slightly
                // near grazing (measured 1.016 at σ = 0.2, θo = 89.5°; see its docs).
                let limit = if spec.contains("oren-nayar") {
                    1.02
                } else {
                    1.0 + 2e-3
                };
                assert!(
                    m <= limit,
                    "{spec} θo={theta} φo={phi}: albedo {a} > {limit}"
                );
                if m > worst.0 && !spec.contains("oren-nayar") {
                    worst = (m, format!("{spec} θo={theta} φo={phi}"));
                }
            }
        }
    }
    eprintln!(
        "largest white-furnace albedo (Oren–Nayar aside) {:.5} at {}",
        worst.0, worst.1
    );
}

#[test]
fn normalizations_give_unit_albedo_at_normal_incidence() {
    // Lambert everywhere; Phong and Blinn–Phong at normal incidence (their
    // normalization constants, checked by quadrature instead of algebra).
    for (spec, theta) in [
        ("lambert", 0.0),
        ("lambert", 80.0),
        ("phong:0", 0.0),
        ("phong:1000", 0.0),
    ]
    .into_iter()
    .chain([("blinn:1", 0.0), ("blinn:30", 0.0), ("blinn:1000", 0.0)])
    {
        let a = directional_albedo_quadrature(&*build(spec), direction_deg(theta, 0.0), (1024, 64));
        assert!(
            (a - DVec3::ONE).abs().max_element() < 2e-3,
            "{spec} θo={theta}: albedo {a}, expected 1"
        );
    }
}

#[test]
fn pdf_integrates_to_acceptance_rate() {
    const N: usize = 40_000;
    for (name, b) in sampled_models() {
        for (k, (theta, wo)) in wos().into_iter().enumerate() {
            let integral = pdf_integral_quadrature(&*b, wo, QUAD);
            let mc = directional_albedo_sampled(&*b, wo, N, 1000 + k as u64);
            let p = mc.acceptance;
            let tol = 4.0 * (p * (1.0 - p) / N as f64).sqrt() + 2e-3;
            assert!(
                integral <= 1.0 + 2e-3,
                "{name} θo={theta}: ∫pdf = {integral} > 1"
            );
            assert!(
                (integral - p).abs() <= tol,
                "{name} θo={theta}: ∫pdf = {integral}, acceptance = {p} (tol {tol})"
            );
            let always =
                name.starts_with("lambert") || name.starts_with("oren") || name.starts_with("merl");
            if always {
                assert!(
                    (integral - 1.0).abs() < 2e-3,
                    "{name} θo={theta}: ∫pdf = {integral}, expected 1"
                );
            }
        }
    }
}

#[test]
fn sample_reports_eval_and_pdf_of_its_direction() {
    let mut rng = Pcg32::new(42);
    for (name, b) in sampled_models() {
        let mut ok = 0;
        for _ in 0..4000 {
            let wo = relight_brdf::sampling::sample_cosine_hemisphere(rng.next_vec2());
            if wo.z < 1e-3 {
                continue;
            }
            let u = rng.next_vec2();
            let Some(s) = b.sample(wo, u) else { continue };
            ok += 1;
            assert!(
                (s.wi.length() - 1.0).abs() < 1e-4,
                "{name}: |wi| = {}",
                s.wi.length()
            );
            assert!(
                s.wi.z > 0.0 && s.pdf > 0.0 && s.pdf.is_finite(),
                "{name}: wi {} pdf {}",
                s.wi,
                s.pdf
            );
            let p = b.pdf(wo, s.wi);
            assert!(
                (p - s.pdf).abs() <= 1e-5 * p.max(1.0),
                "{name}: pdf() {p} vs sample.pdf {}",
                s.pdf
            );
            let f = b.eval(wo, s.wi);
            assert!(
                (f - s.f).abs().max_element() <= 1e-5 * f.max_element().max(1.0),
                "{name}: eval {f} vs sample.f {}",
                s.f
            );
        }
        assert!(ok > 2000, "{name}: only {ok} of 4000 samples succeeded");
    }
}

#[test]
fn sampled_albedo_matches_quadrature() {
    const N: usize = 30_000;
    for (name, b) in sampled_models() {
        for (k, (theta, wo)) in wos().into_iter().enumerate() {
            let q = directional_albedo_quadrature(&*b, wo, QUAD);
            let mc = directional_albedo_sampled(&*b, wo, N, 77 + k as u64);
            for c in 0..3 {
                let tol = 5.0 * mc.std_error[c] + 2e-3;
                assert!(
                    (mc.mean[c] - q[c]).abs() <= tol,
                    "{name} θo={theta} channel {c}: sampled {} ± {} vs quadrature {}",
                    mc.mean[c],
                    mc.std_error[c],
                    q[c]
                );
            }
        }
    }
}

/// The sampled directions are distributed as `pdf` says: bin N samples on an
/// 8 (cos θ) × 16 (φ) grid of the hemisphere and compare each bin's count
/// with N ∫_bin pdf.
#[test]
fn sample_histogram_matches_pdf() {
    const N: usize = 100_000;
    const NT: usize = 8;
    const NP: usize = 16;
    const SUB: usize = 24;
    for (name, b) in sampled_models() {
        for (k, wo) in [direction_deg(30.0, 20.0), direction_deg(70.0, 250.0)]
            .into_iter()
            .enumerate()
        {
            let mut counts = [[0usize; NP]; NT];
            let mut rng = Pcg32::new(9000 + k as u64);
            for _ in 0..N {
                if let Some(s) = b.sample(wo, rng.next_vec2()) {
                    let it = ((s.wi.z * NT as f32) as usize).min(NT - 1);
                    let phi = s.wi.y.atan2(s.wi.x).rem_euclid(std::f32::consts::TAU);
                    let ip = ((phi / std::f32::consts::TAU * NP as f32) as usize).min(NP - 1);
                    counts[it][ip] += 1;
                }
            }
            for (it, row) in counts.iter().enumerate() {
                for (ip, &count) in row.iter().enumerate() {
                    // ∫ pdf dω over the bin, dω = dμ dφ, midpoint rule on SUB×SUB cells.
                    let (dmu, dphi) = (
                        1.0 / (NT * SUB) as f64,
                        std::f64::consts::TAU / (NP * SUB) as f64,
                    );
                    let mut p = 0.0;
                    for a in 0..SUB {
                        let mu = (it * SUB + a) as f64 * dmu + 0.5 * dmu;
                        let s = (1.0 - mu * mu).sqrt();
                        for c in 0..SUB {
                            let phi = (ip * SUB + c) as f64 * dphi + 0.5 * dphi;
                            let wi = Vec3::new(
                                (s * phi.cos()) as f32,
                                (s * phi.sin()) as f32,
                                mu as f32,
                            );
                            p += f64::from(b.pdf(wo, wi)) * dmu * dphi;
                        }
                    }
                    let expected = p * N as f64;
                    let got = count as f64;
                    let tol = 5.0 * expected.sqrt() + 0.02 * expected + 3.0;
                    assert!(
                        (got - expected).abs() <= tol,
                        "{name} wo#{k} bin (μ {it}, φ {ip}): {got} samples, pdf predicts {expected:.1}"
                    );
                }
            }
        }
    }
}

#[test]
fn analytic_models_are_reciprocal() {
    for spec in WHITE.iter().chain(SAMPLED) {
        let e = reciprocity_error(&*build(spec), 3000, 5);
        assert!(e < 1e-4, "{spec}: max relative |f(wo,wi) − f(wi,wo)| = {e}");
    }
}

#[test]
fn merl_is_reciprocal_up_to_bin_edges() {
    let blinn = BlinnPhong::new(15.0, Vec3::ONE).unwrap();
    let merl = Merl::from_fn([30, 30, 60], |wo, wi| blinn.eval(wo, wi)).unwrap();
    let mut rng = Pcg32::new(3);
    let (mut same, mut total) = (0, 0);
    for _ in 0..5000 {
        let a = relight_brdf::sampling::sample_cosine_hemisphere(rng.next_vec2());
        let b = relight_brdf::sampling::sample_cosine_hemisphere(rng.next_vec2());
        total += 1;
        same += usize::from(merl.eval(a, b) == merl.eval(b, a));
    }
    assert!(
        same as f64 >= 0.99 * total as f64,
        "MERL reciprocity: {same} of {total} pairs agree"
    );
}

#[test]
fn distributions_are_normalized() {
    let z = Vec3::Z;
    let project = |d: &dyn Fn(Vec3) -> f32| {
        let mut s = 0.0;
        sphere_quadrature(z, 2048, 128, |h, w| s += f64::from(d(h) * h.z.max(0.0)) * w);
        s
    };
    for (ax, ay) in [
        (0.05, 0.05),
        (0.2, 0.2),
        (0.5, 0.5),
        (1.0, 1.0),
        (0.05, 0.6),
        (0.8, 0.1),
    ] {
        let g = project(&|h| ggx_d(h, ax, ay));
        assert!(
            (g - 1.0).abs() < 2e-3,
            "GGX α=({ax},{ay}): ∫D cosθh = {g}, expected 1"
        );
        let w = project(&|h| ward_d(h, ax, ay));
        assert!(
            (w - 1.0).abs() < 2e-3,
            "Ward α=({ax},{ay}): ∫D cosθh = {w}, expected 1"
        );
        // Visible normals: ∫ D_wo(h) dω_h = 1 for any wo (checks G₁ against D).
        for theta in [0.0, 45.0, 80.0] {
            let wo = direction_deg(theta, 30.0);
            let mut s = 0.0;
            sphere_quadrature(z, 2048, 128, |h, wt| {
                s += f64::from(ggx_vndf_pdf(wo, h, ax, ay)) * wt
            });
            assert!(
                (s - 1.0).abs() < 3e-3,
                "GGX VNDF α=({ax},{ay}) θo={theta}: ∫D_wo = {s}"
            );
        }
    }
    for (nu, nv) in [(0.0, 0.0), (10.0, 10.0), (100.0, 5.0)] {
        let a = AshikhminShirley::new(nu, nv, Vec3::ONE, Vec3::ONE).unwrap();
        let mut s = 0.0;
        sphere_quadrature(z, 2048, 128, |h, w| s += f64::from(a.half_pdf(h)) * w);
        assert!(
            (s - 1.0).abs() < 2e-3,
            "Ashikhmin–Shirley ({nu},{nv}): ∫p_h = {s}, expected 1"
        );
    }
}

#[test]
fn quadrature_rule_sums_to_4pi() {
    let mut s = 0.0;
    sphere_quadrature(direction_deg(33.0, 12.0), QUAD.0, QUAD.1, |_, w| s += w);
    let e = 4.0 * std::f64::consts::PI;
    assert!((s - e).abs() < 1e-4 * e, "weights sum {s}, expected {e}");
}

#[test]
fn below_horizon_is_zero() {
    let up = direction_deg(30.0, 0.0);
    let down = Vec3::new(0.3, 0.1, -0.9).normalize();
    for (name, b) in sampled_models() {
        assert_eq!(b.eval(up, down), Vec3::ZERO, "{name}");
        assert_eq!(b.eval(down, up), Vec3::ZERO, "{name}");
        assert_eq!(b.pdf(down, up), 0.0, "{name}");
        assert!(b.sample(down, Vec2::splat(0.3)).is_none(), "{name}");
    }
}

#[test]
fn phong_lobe_peaks_at_mirror_direction() {
    // Independent check of eval: the value at the mirror direction is
    // ρ (n+2)/(2π), and at 60° from it cos⁶⁰ⁿ… falls as cosⁿ.
    let p = Phong::new(10.0, Vec3::ONE).unwrap();
    let wo = direction_deg(40.0, 0.0);
    let r = Vec3::new(-wo.x, -wo.y, wo.z);
    let peak = p.eval(wo, r).x;
    let expected = 12.0 / (2.0 * std::f32::consts::PI);
    assert!(
        (peak - expected).abs() < 1e-5,
        "peak {peak}, expected {expected}"
    );
    let off = direction_deg(20.0, 180.0);
    let c = off.dot(r);
    let want = expected * c.powi(10);
    assert!(
        (p.eval(wo, off).x - want).abs() < 1e-5,
        "off-peak {} vs {want}",
        p.eval(wo, off).x
    );
    let _ = FRAC_PI_2;
}
