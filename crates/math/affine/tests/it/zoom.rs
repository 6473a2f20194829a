//! The sparse zoom (§4.6.2) against the generic 2D propagation, which is
//! itself checked against inverse Haar → box resampling → forward Haar in
//! `separable.rs`: every kept block must agree to rounding.

use relight_affine::separable::propagate_2d;
use relight_affine::zoom::{ZoomScratch, zoom_sparse};

/// A small deterministic generator (no test-only dependency).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn check(n: usize, s: [f64; 2], o: [f64; 2], density: f64, seed: u64) {
    let mut rng = Lcg(seed);
    let mut dense = vec![0.0f32; n * n];
    let mut src = Vec::new();
    for (k, d) in dense.iter_mut().enumerate() {
        if k == 0 || rng.next() < density {
            let v = (rng.next() * 2.0 - 1.0) as f32;
            *d = v;
            src.push((k as u32, v));
        }
    }
    let mut want = vec![0.0f64; n * n];
    propagate_2d(&dense, n, s, o, &mut want);
    let top = want.iter().fold(0.0f64, |a, &b| a.max(b.abs())).max(1e-30);
    let mut scratch = ZoomScratch::default();
    let mut side = n;
    while side >= 1 {
        let mut got = vec![f64::NAN; side * side];
        zoom_sparse(&src, n, s, o, side, &mut got, &mut scratch);
        for r in 0..side {
            for c in 0..side {
                let (g, w) = (got[r * side + c], want[r * n + c]);
                assert!(
                    (g - w).abs() <= 1e-12 * top,
                    "n {n} s {s:?} o {o:?} side {side} ({r},{c}): {g} vs {w}"
                );
            }
        }
        side /= 2;
    }
}

#[test]
fn sparse_zoom_equals_the_generic_propagation_on_every_kept_block() {
    // Magnify, shrink, anisotropic, dyadic (break points on cell edges),
    // and offsets that push the image partly outside.
    let cases = [
        ([0.5, 0.5], [0.2, 0.3]),
        ([2.0, 2.0], [-0.4, -0.7]),
        ([0.37, 1.6], [0.11, -0.21]),
        ([0.25, 0.5], [0.25, 0.5]),
        ([1.0, 1.0], [0.0, 0.0]),
        ([0.8, 0.3], [0.9, -0.2]),
    ];
    for (k, (s, o)) in cases.into_iter().enumerate() {
        check(16, s, o, 0.5, 7 + k as u64);
        check(64, s, o, 0.05, 70 + k as u64);
    }
}

#[test]
fn sparse_zoom_of_a_single_coarse_source_is_not_empty() {
    // A guard that the enumeration finds the couplings at all: the scaling
    // function zoomed 2× about the centre stays a constant, all in φ.
    let n = 32;
    let mut out = vec![0.0; n * n];
    zoom_sparse(
        &[(0, 1.0)],
        n,
        [0.5, 0.5],
        [0.25, 0.25],
        n,
        &mut out,
        &mut ZoomScratch::default(),
    );
    assert!((out[0] - 1.0).abs() < 1e-12, "{}", out[0]);
    assert!(out[1..].iter().all(|&x| x.abs() < 1e-12));
}
