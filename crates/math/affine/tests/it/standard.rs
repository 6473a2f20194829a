//! The standard 2D basis and two-step propagation (§4.5.5) against the
//! transform round trip and brute-force projection of the transformed map.

use relight_affine::atom::Atom;
use relight_affine::standard::{
    acc_matrix_f32, acc_matrix_fast, cell_means, forward_1d, forward_2d, inverse_2d,
    propagate_two_step,
};

fn tex(x: f64, y: f64) -> f64 {
    1.0 + (7.0 * x).sin() * (3.0 * y + 1.0).cos() + if x > 0.6 && y < 0.3 { 2.0 } else { 0.0 }
}

#[test]
fn forward_1d_matches_inner_products() {
    let n = 16;
    let means: Vec<f64> = (0..n).map(|i| ((i * 7 % 5) as f64) - 1.3).collect();
    let mut c = means.clone();
    let mut tmp = vec![0.0; n];
    forward_1d(&mut c, &mut tmp);
    for (k, ck) in c.iter().enumerate() {
        let a = Atom::from_index(k);
        // ∫ f Φ_k with f piecewise constant: midpoint per cell is exact.
        let direct: f64 = (0..n)
            .map(|i| means[i] * a.eval((i as f64 + 0.5) / n as f64) / n as f64)
            .sum();
        assert!((ck - direct).abs() < 1e-12, "k {k}: {ck} vs {direct}");
    }
}

#[test]
fn round_trip_2d() {
    let n = 16;
    let g = cell_means(n, 2, tex);
    let mut c = g.clone();
    forward_2d(&mut c, n);
    inverse_2d(&mut c, n);
    for (a, b) in g.iter().zip(&c) {
        assert!((a - b).abs() < 1e-12);
    }
}

/// L_k = ∫ F(s t + o) Φ_k(t) dt by fine midpoint sampling of the box map F.
#[test]
fn two_step_equals_projection_of_the_transformed_map() {
    let n = 8;
    let grid = cell_means(n, 2, tex);
    let mut f = grid.clone();
    forward_2d(&mut f, n);
    let (s, o) = ([1.7, 0.6], [-0.3, 0.25]);
    let mut l = vec![0.0; n * n];
    propagate_two_step(&f, n, s, o, &mut l);
    let box_map = |u: f64, v: f64| {
        if !(0.0..1.0).contains(&u) || !(0.0..1.0).contains(&v) {
            return 0.0;
        }
        grid[(v * n as f64) as usize * n + (u * n as f64) as usize]
    };
    let m = 512;
    let mut target = cell_means(n, m / n, |x, y| box_map(s[0] * x + o[0], s[1] * y + o[1]));
    forward_2d(&mut target, n);
    let err = l
        .iter()
        .zip(&target)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    // Midpoint sampling of a map with jumps: error ~ jump length × 1/m.
    assert!(err < 5e-3, "max coefficient error {err}");
}

/// The primitive-form matrix equals the exact rows from `M`.
#[test]
fn fast_matrix_equals_exact_rows() {
    let n = 32;
    let mut row = Vec::new();
    let (mut a, mut b) = (vec![0.0f32; n * n], vec![0.0f32; n * n]);
    for (s, o) in [
        (1.0, 0.0),
        (4.0, -1.5),
        (0.3, 0.2),
        (7.3, -3.1),
        (0.9, 0.77),
        (2.5, 0.9),
    ] {
        acc_matrix_f32(n, s, o, &mut a, &mut row);
        acc_matrix_fast(n, s, o, &mut b);
        let err = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
        assert!(err < 2e-6, "s {s} o {o}: max difference {err}");
    }
}
