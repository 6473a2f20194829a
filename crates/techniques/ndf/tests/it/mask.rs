//! The view mask from an NDF's moments (`relight_ndf::mask`), each piece
//! checked a second way: Φ₂ and the closed form of `R` by direct
//! quadrature, the table against the closed form, the moments against
//! sums over the normals, and the shading against sums over normals.

use glam::Vec3;
use relight_ndf::effective::{NdfBrdf, lambert_sh_dir_seen, shade_lobe};
use relight_ndf::mask::{ShMoments, bivariate_normal_cdf, mask_share, mask_share_exact};

fn phi(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// `Φ` by the midpoint rule (an oracle independent of the module's erfc).
fn cdf_quad(x: f64) -> f64 {
    let lo = -12.0;
    if x <= lo {
        return 0.0;
    }
    let n = 4_000;
    let h = (x - lo) / n as f64;
    (0..n).map(|i| phi(lo + (i as f64 + 0.5) * h) * h).sum()
}

/// `E[X⁺ 1(Y>0)] / E[X⁺]` for standardized `h_x, h_y, ρ`, by quadrature
/// over `X` of `P(Y > 0 | X)`.
fn share_quad(hx: f64, hy: f64, rho: f64) -> f64 {
    // σ_X = 1, μ_X = h_x; Y | X=x has mean h_y + ρ(x − h_x), sd √(1−ρ²).
    let (lo, hi) = (0.0f64.max(hx - 10.0), hx + 10.0);
    let n = 4_000;
    let h = (hi - lo) / n as f64;
    let q = (1.0 - rho * rho).sqrt();
    let (mut a, mut b) = (0.0, 0.0);
    for i in 0..n {
        let x = lo + (i as f64 + 0.5) * h;
        let w = x * phi(x - hx) * h;
        let z = (hy + rho * (x - hx)) / q;
        a += w * cdf_quad(z.clamp(-12.0, 12.0)).min(1.0);
        b += w;
    }
    a / b
}

#[test]
fn bivariate_cdf_matches_quadrature() {
    for &(a, b, rho) in &[
        (0.0, 0.0, 0.0),
        (0.5, -0.3, 0.4),
        (-1.2, 0.8, -0.7),
        (1.5, 1.4, 0.95),
        (-0.4, 2.0, -0.98),
        (2.5, -2.5, 0.6),
    ] {
        // Φ₂(a, b; ρ) = ∫_{−∞}^a φ(x) Φ((b − ρx)/√(1−ρ²)) dx.
        let q = (1.0f64 - rho * rho).sqrt();
        let (lo, n) = (-10.0f64, 4000);
        let h = (a - lo) / n as f64;
        let want: f64 = (0..n)
            .map(|i| {
                let x = lo + (i as f64 + 0.5) * h;
                phi(x) * cdf_quad((b - rho * x) / q) * h
            })
            .sum();
        let got = bivariate_normal_cdf(a, b, rho);
        assert!(
            (got - want).abs() < 2e-6,
            "Φ₂({a}, {b}; {rho}) = {got} vs {want}"
        );
    }
}

#[test]
fn closed_form_share_matches_quadrature() {
    for &(hx, hy, rho) in &[
        (0.0, 0.0, 0.0),
        (1.0, -0.5, 0.6),
        (-1.5, 0.7, 0.8),
        (0.3, 0.2, -0.9),
        (3.0, -1.0, 0.3),
        (-3.0, -0.5, -0.4),
    ] {
        let got = mask_share_exact(hx, hy, rho);
        let want = share_quad(hx, hy, rho);
        assert!(
            (got - want).abs() < 1e-5,
            "R({hx}, {hy}, {rho}) = {got} vs {want}"
        );
    }
    // Limits: uncorrelated is P(Y > 0); h_y = ±∞ is 1 or 0.
    assert!((mask_share_exact(0.7, 0.4, 0.0) - cdf_quad(0.4)).abs() < 1e-6);
    assert_eq!(mask_share_exact(0.7, f64::INFINITY, 0.5), 1.0);
    assert_eq!(mask_share_exact(0.7, f64::NEG_INFINITY, 0.5), 0.0);
}

#[test]
fn the_table_follows_the_closed_form() {
    // Random points in the compressed coordinates. Where `h_x` < −2 the
    // light reaches a vanishing tail of the normals and R turns steep in
    // ρ; there the error is weighed by the irradiance it scales,
    // `E[X⁺]/(σ + |μ|)`, which the shading sees.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut r = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let h = |s: f64| s / (1.0 - s.abs());
    let (mut worst, mut worst_weighed) = (0.0f64, 0.0f64);
    for _ in 0..20_000 {
        let (sx, sy, rho) = (0.999 * r(), 0.999 * r(), r());
        let got = f64::from(mask_share(sx as f32, sy as f32, rho as f32));
        let hx = h(sx);
        let want = mask_share_exact(hx, h(sy), rho);
        let e = (got - want).abs();
        let irradiance = hx * (1.0 - 0.5 * libm_erfc_quad(hx)) + phi(hx);
        worst_weighed = worst_weighed.max(e * irradiance / (1.0 + hx.abs()));
        if hx > -2.0 && rho.abs() < 0.95 {
            worst = worst.max(e);
        }
    }
    // Measured 0.011 (near |ρ| = 0.88, h_x ≈ −1.5).
    assert!(worst < 0.015, "table error {worst}");
    eprintln!("table error {worst}, weighed {worst_weighed}");
    // Measured 0.0010.
    assert!(worst_weighed < 0.002, "weighed table error {worst_weighed}");
    // A delta: s_y = ±1 is the exact step, whatever s_x and ρ.
    for (sx, rho) in [(0.9, 0.3), (-0.2, -0.8), (1.0, 0.0)] {
        assert_eq!(mask_share(sx, 1.0, rho), 1.0);
        assert_eq!(mask_share(sx, -1.0, rho), 0.0);
    }
}

/// `2 (1 − Φ(x))`, through [`cdf_quad`].
fn libm_erfc_quad(x: f64) -> f64 {
    2.0 * (1.0 - cdf_quad(x))
}

/// Normals spread about `axis` (a deterministic, lopsided set).
fn normals(axis: Vec3, spread: f32, n: usize) -> Vec<Vec3> {
    let f = relight_sphere::Frame::from_z(axis);
    (0..n)
        .map(|i| {
            let t = i as f32 / n as f32;
            let a = spread * (0.3 + t) * (1.0 + 0.5 * (i % 3) as f32);
            let p = i as f32 * 2.399_963;
            (f.z + f.x * (a * p.cos()) + f.y * (0.6 * a * p.sin())).normalize()
        })
        .collect()
}

fn sh_of(ns: &[Vec3]) -> [f32; 9] {
    let mut g = [0.0f32; 9];
    let mut y = [0.0f32; 9];
    for n in ns {
        relight_sh::eval_sh_into(3, n.to_array(), &mut y);
        for (a, b) in g.iter_mut().zip(y) {
            *a += b / ns.len() as f32;
        }
    }
    g
}

#[test]
fn moments_of_sh_are_the_normals_moments() {
    let ns = normals(Vec3::new(0.3, -0.2, 0.9).normalize(), 0.5, 400);
    let m = ShMoments::of_sh(&sh_of(&ns));
    let k = ns.len() as f32;
    let mean: Vec3 = ns.iter().copied().sum::<Vec3>() / k;
    assert!((m.mean - mean).length() < 1e-5, "{} vs {mean}", m.mean);
    for (a, b) in [(Vec3::X, Vec3::Y), (Vec3::Z, Vec3::Z), (Vec3::X, Vec3::Z)] {
        let want = ns
            .iter()
            .map(|n| (n.dot(a) - mean.dot(a)) * (n.dot(b) - mean.dot(b)))
            .sum::<f32>()
            / k;
        let got = m.cov_form(a, b);
        assert!((got - want).abs() < 1e-5, "cov({a}, {b}) = {got} vs {want}");
    }
}

#[test]
fn the_seen_share_follows_the_normals_at_grazing_views() {
    // Lambert under one light of a spread of normals, against the sum over
    // them (each masked by its own n·ω_o): the moments' mask beats the
    // mean lobe's visible share where light and view are on one side.
    let ns = normals(Vec3::new(0.1, 0.4, 0.9).normalize(), 0.6, 2000);
    let g = sh_of(&ns);
    let mut worst = 0.0f32;
    for (wo, wi) in [
        (Vec3::new(0.0, 0.97, 0.25), Vec3::new(0.2, 0.8, 0.56)),
        (Vec3::new(0.9, 0.1, 0.42), Vec3::new(-0.5, 0.3, 0.81)),
        (Vec3::new(-0.6, -0.7, 0.39), Vec3::new(-0.4, -0.6, 0.69)),
    ] {
        let (wo, wi) = (wo.normalize(), wi.normalize());
        let truth = ns
            .iter()
            .map(|n| shade_lobe(NdfBrdf::Lambert, *n, 0.0, wo, wi))
            .sum::<f32>()
            / ns.len() as f32;
        let got = lambert_sh_dir_seen(&g, wo, wi);
        worst = worst.max((got - truth).abs() / truth);
    }
    assert!(worst < 0.06, "relative error {worst}");
    // A delta: plain normal mapping's mask exactly.
    let n = Vec3::new(0.3, 0.1, 0.95).normalize();
    let g = sh_of(&[n]);
    let wi = Vec3::new(0.1, 0.2, 0.97).normalize();
    for wo in [Vec3::new(-0.99, 0.0, 0.12), Vec3::new(0.99, 0.0, 0.12)] {
        let wo = wo.normalize();
        let want = shade_lobe(NdfBrdf::Lambert, n, 0.0, wo, wi);
        let got = lambert_sh_dir_seen(&g, wo, wi);
        assert!((got - want).abs() < 1e-3 * want.max(0.1), "{got} vs {want}");
    }
}

/// The seen NDF's bands 0–2 (`mask::seen_sh9`, the environment light's
/// mask) against the sum of `y_i(n)` over the normals that face the viewer:
/// exact where all do, within a few percent of the irradiance at grazing
/// views, and a delta's step to rounding.
#[test]
fn the_seen_sh_follows_the_normals_that_face_the_viewer() {
    use relight_ndf::mask::seen_sh9;
    let ns = normals(Vec3::new(0.1, 0.4, 0.9).normalize(), 0.6, 2000);
    let g = sh_of(&ns);
    // Every normal faces +Z's viewer: the NDF itself, share 1.
    let (all, share) = seen_sh9(&g, Vec3::Z);
    assert!(ns.iter().all(|n| n.z > 0.0));
    assert!(share > 0.999, "share {share}");
    for (a, b) in all.iter().zip(&g) {
        assert!((a - b).abs() < 2e-3 * g[0], "{all:?} vs {g:?}");
    }
    // Grazing views: the share and a Lambert shading under a smooth light
    // (SH of a clamped cosine about `l`: its bands 0–2 with Λ_l/π) against
    // the sums over the facing normals.
    let mut worst = (0.0f32, 0.0f32);
    for wo in [
        Vec3::new(0.0, 0.97, 0.25),
        Vec3::new(0.9, 0.1, 0.42),
        Vec3::new(-0.6, -0.7, 0.39),
        Vec3::new(0.0, -0.95, 0.3),
    ] {
        let wo = wo.normalize();
        let facing: Vec<Vec3> = ns.iter().copied().filter(|n| n.dot(wo) > 0.0).collect();
        let true_share = facing.len() as f32 / ns.len() as f32;
        let true_sh = sh_of(&facing).map(|v| v * true_share);
        let (got, share) = seen_sh9(&g, wo);
        worst.0 = worst.0.max((share - true_share).abs());
        for l in [Vec3::Z, Vec3::new(0.5, 0.5, 0.7).normalize(), Vec3::X] {
            let mut y = [0.0f32; 9];
            relight_sh::eval_sh_into(3, l.to_array(), &mut y);
            let shade = |c: &[f32; 9]| relight_ndf::effective::lambert_sh_env(c, &y);
            let (a, b) = (shade(&got), shade(&true_sh));
            worst.1 = worst.1.max((a - b).abs() / shade(&g).abs().max(1e-3));
        }
    }
    // The normal model of this lopsided spread: 0.033 and 0.031 measured.
    assert!(worst.0 < 0.05, "seen share off by {}", worst.0);
    assert!(worst.1 < 0.05, "shading off by {} of the unmasked", worst.1);
    // A delta: its own SH where it faces the viewer, zero where it does not.
    let n = Vec3::new(0.3, 0.1, 0.95).normalize();
    let d = sh_of(&[n]);
    let (front, s1) = seen_sh9(&d, Vec3::new(0.99, 0.0, 0.12).normalize());
    let (back, s0) = seen_sh9(&d, Vec3::new(-0.99, 0.0, 0.12).normalize());
    assert!(s1 > 0.999_999 && s0 < 1e-6, "{s1}, {s0}");
    for ((f, b), want) in front.iter().zip(&back).zip(&d) {
        assert!(
            (f - want).abs() < 1e-5 && b.abs() < 1e-5,
            "{front:?} / {back:?} vs {d:?}"
        );
    }
}

/// A footprint whose two probes hold NDFs leaning apart, seen from a
/// grazing eye on one side: masking each probe's NDF and averaging the
/// seen moments (the sh filter's `probe_masks`) follows the normals that
/// face the viewer more closely than one Gaussian for the footprint's
/// mean NDF, which spreads the two clusters into one wide lobe.
#[test]
fn masking_each_probe_beats_one_gaussian_for_a_split_footprint() {
    use relight_ndf::mask::{seen_moments, seen_sh9, sh9_of_seen_moments};
    let a = normals(Vec3::new(0.5, 0.0, 0.87).normalize(), 0.25, 1000);
    let b = normals(Vec3::new(-0.5, 0.0, 0.87).normalize(), 0.25, 1000);
    let (ga, gb) = (sh_of(&a), sh_of(&b));
    let all: Vec<Vec3> = a.iter().chain(&b).copied().collect();
    let mean: [f32; 9] = std::array::from_fn(|i| 0.5 * (ga[i] + gb[i]));
    let (mut worst_one, mut worst_probes) = (0.0f32, 0.0f32);
    for wo in [
        Vec3::new(-0.95, 0.0, 0.31),
        Vec3::new(-0.9, 0.3, 0.3),
        Vec3::new(0.0, -0.96, 0.28),
        Vec3::new(0.97, 0.0, 0.24),
    ] {
        let wo = wo.normalize();
        let facing: Vec<Vec3> = all.iter().copied().filter(|n| n.dot(wo) > 0.0).collect();
        let share = facing.len() as f32 / all.len() as f32;
        let truth = sh_of(&facing).map(|v| v * share);
        let (one, _) = seen_sh9(&mean, wo);
        let mut e = [0.0f32; 9];
        for g in [&ga, &gb] {
            let (ej, _) = seen_moments(&ShMoments::of_sh(g), wo);
            for (e, v) in e.iter_mut().zip(ej) {
                *e += 0.5 * v;
            }
        }
        let probes = sh9_of_seen_moments(&e);
        for l in [Vec3::Z, Vec3::new(0.6, 0.2, 0.77).normalize(), -wo] {
            let mut y = [0.0f32; 9];
            relight_sh::eval_sh_into(3, l.to_array(), &mut y);
            let shade = |c: &[f32; 9]| relight_ndf::effective::lambert_sh_env(c, &y);
            let scale = shade(&mean).abs().max(1e-3);
            worst_one = worst_one.max((shade(&one) - shade(&truth)).abs() / scale);
            worst_probes = worst_probes.max((shade(&probes) - shade(&truth)).abs() / scale);
        }
    }
    // Measured: 0.0073 per probe, 0.113 for one Gaussian.
    assert!(
        worst_probes < 0.02 && worst_one > 0.05,
        "per probe {worst_probes}, one Gaussian {worst_one}"
    );
}
