//! Windows: the σ-factor formulas against their closed forms and, a second
//! way, against the zonal convolution they stand for (quadrature); Sloan's
//! deringing leaves Phong lobes non-negative on a grid 4× finer than the one
//! it was chosen on.

use glam::DVec3;
use relight_sh::convolve::phong;
use relight_sh::project::Window;
use relight_sh::quadrature::SphereQuadrature;
use relight_sh::rotation::rotate_zonal;
use relight_sh::window::{LobeSet, WindowChoice, dering, factors, hann, lanczos};
use std::f64::consts::PI;

fn legendre(l: usize, t: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, t);
    if l == 0 {
        return 1.0;
    }
    for k in 2..=l {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * t * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    p1
}

#[test]
fn sigma_factors_match_their_closed_forms() {
    for n in [3usize, 6, 10] {
        let h = factors(&hann(n), n);
        let s = factors(&lanczos(n), n);
        for l in 0..n {
            let x = PI * l as f64 / n as f64;
            assert!(
                (h[l] - 0.5 * (1.0 + x.cos())).abs() < 1e-15,
                "hann n={n} l={l}"
            );
            let want = if l == 0 { 1.0 } else { x.sin() / x };
            assert!((s[l] - want).abs() < 1e-15, "lanczos n={n} l={l}");
        }
        // Both fall monotonically from h_0 = 1 and stay positive below N.
        assert_eq!(h[0], 1.0);
        assert!(h.windows(2).all(|w| w[1] < w[0]) && h[n - 1] > 0.0);
        assert!(s.windows(2).all(|w| w[1] < w[0]) && s[n - 1] > 0.0);
    }
}

/// Windowing the coefficients = convolving with the zonal kernel
/// `k(t) = Σ_l (2l+1)/(4π) h_l P_l(t)` (Funk–Hecke), checked by quadrature.
#[test]
fn window_is_the_zonal_convolution_by_quadrature() {
    let n = 6;
    let f: Vec<f64> = (0..n * n)
        .map(|i| ((i * 5 + 1) % 7) as f64 * 0.3 - 0.8)
        .collect();
    let q = SphereQuadrature::new(40, 80); // exact for degree ≤ 2·(n−1)
    for w in [hann(n), lanczos(n), Window::Sloan { lambda: 0.01 }] {
        let h = factors(&w, n);
        let mut g = f.clone();
        w.apply(n, &mut g);
        for d in [DVec3::new(0.3, -0.5, 0.8), DVec3::new(-0.9, 0.1, -0.2)] {
            let d = d.normalize();
            let direct = relight_sh::basis::eval_fn_f64(&g, d);
            let conv = q.integrate(|o| {
                let k: f64 = (0..n)
                    .map(|l| (2 * l + 1) as f64 / (4.0 * PI) * h[l] * legendre(l, d.dot(o)))
                    .sum();
                relight_sh::basis::eval_fn_f64(&f, o) * k
            });
            assert!((direct - conv).abs() < 1e-9, "{w:?}: {direct} vs {conv}");
        }
    }
}

fn phong_lobe(order: usize, s: f64, axis: [f32; 3]) -> Vec<f32> {
    // Zonal coefficients of the normalised Phong lobe: f_l0 = Â_l √((2l+1)/4π).
    let a = phong(order, s).unwrap();
    let zonal: Vec<f32> = (0..order)
        .map(|l| (a[l] * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt()) as f32)
        .collect();
    let mut out = vec![0.0f32; order * order];
    rotate_zonal(order, &zonal, axis, &mut out);
    out
}

#[test]
fn deringed_phong_lobes_are_non_negative_on_a_finer_grid() {
    let order = 6;
    let lobes: Vec<Vec<f32>> = [
        (20.0, [0.0, 0.0, 1.0]),
        (40.0, [0.6, 0.0, 0.8]),
        (80.0, [0.0, 0.8, 0.6]),
    ]
    .iter()
    .map(|&(s, axis)| phong_lobe(order, s, axis))
    .collect();
    let refs: Vec<&[f32]> = lobes.iter().map(Vec::as_slice).collect();
    let set = LobeSet::new(order, &refs).unwrap();
    let ones = vec![1.0; order];
    assert!(
        set.min_ratio(&ones) < -0.01,
        "the raw lobes ring: {}",
        set.min_ratio(&ones)
    );
    let h = dering(&set);
    assert_eq!(h[0], 1.0, "band 0 (the albedo) is kept");
    assert!(h.iter().all(|&v| (0.0..=1.0).contains(&v)), "{h:?}");
    let rows = 4 * (8 * order).max(48);
    let fine = LobeSet::with_grid(order, &refs, &SphereQuadrature::new(rows, 2 * rows)).unwrap();
    let m = fine.min_ratio(&h);
    assert!(
        m >= -1e-3,
        "deringed minimum {m} of the peak on the fine grid"
    );
    // Least change: no more than Hann's or Lanczos's where those are
    // non-negative too.
    let chosen = set.choose(WindowChoice::Dering);
    for w in [hann(order), lanczos(order)] {
        let hw = factors(&w, order);
        if set.nonneg(&hw) {
            assert!(
                chosen.change <= set.change(&hw) + 1e-6,
                "dering change {} above {w:?}'s {}",
                chosen.change,
                set.change(&hw)
            );
        }
    }
    // ... and no more than the best non-negative Hann, Lanczos or Gaussian-like
    // window of any width (a scan of each family).
    let mut best = f64::INFINITY;
    for i in 0..400 {
        let x = 1.0 + 0.1 * f64::from(i);
        for w in [
            Window::Hanning { width: x },
            Window::Lanczos { width: x },
            Window::Sloan {
                lambda: 1e-8 * 1.06f64.powi(i),
            },
        ] {
            let hw = factors(&w, order);
            if set.nonneg(&hw) {
                best = best.min(set.change(&hw));
            }
        }
    }
    assert!(
        chosen.change <= best + 1e-3,
        "dering change {} above the best family member's {best}",
        chosen.change
    );
    assert_eq!(set.choose(WindowChoice::Auto).factors, chosen.factors);
    // Auto leaves a non-negative lobe alone.
    let dc = [1.0f32, 0.0, 0.0, 0.0];
    let flat = LobeSet::new(2, &[&dc]).unwrap();
    assert_eq!(flat.choose(WindowChoice::Auto).factors, vec![1.0, 1.0]);
}

#[test]
fn window_choice_names_round_trip_and_bad_names_are_errors() {
    for w in WindowChoice::ALL {
        assert_eq!(w.name().parse::<WindowChoice>().unwrap(), w);
    }
    let e = "hanning2".parse::<WindowChoice>().unwrap_err().to_string();
    assert!(e.contains("--window") && e.contains("dering"), "{e}");
}
