//! M(r, c) (eq. 4.22, Fig. 4.4) against exact overlap and quadrature, and
//! its properties (eqs. 4.24–4.28, bounds).

use relight_affine::Kind;
use relight_affine::Kind::{Box, Wave};
use relight_affine::canonical::{
    canonical, canonical_fig44, canonical_gradient, canonical_overlap, canonical_quadrature,
    is_structural_zero, primitive_form,
};

const KINDS: [(Kind, Kind); 4] = [(Box, Box), (Box, Wave), (Wave, Box), (Wave, Wave)];

fn radii() -> Vec<f64> {
    let mut r = vec![
        0.03, 0.1, 0.25, 0.3, 0.45, 0.5, 0.55, 0.75, 1.0, 1.3, 2.0, 3.7,
    ];
    r.extend((1..40).map(|k| 0.05 * k as f64 + 0.0123));
    r
}

fn centres(r: f64) -> Vec<f64> {
    let mut c: Vec<f64> = (0..=400)
        .map(|k| -r - 0.7 + (2.0 * r + 2.4) * k as f64 / 400.0)
        .collect();
    c.extend([0.0, 0.5, 1.0, r + 0.5, 0.5 - r, -r, 1.0 + r]);
    c
}

#[test]
fn closed_forms_match_exact_overlap() {
    for r in radii() {
        for c in centres(r) {
            for (a, b) in KINDS {
                let ov = canonical_overlap(a, b, r, c);
                let m = canonical(a, b, r, c);
                assert!(
                    (m - ov).abs() <= 1e-12,
                    "{a:?}{b:?} r={r} c={c}: {m} vs {ov}"
                );
            }
            let f = canonical_fig44(r, c);
            let ov = canonical_overlap(Wave, Wave, r, c);
            assert!((f - ov).abs() <= 1e-12, "Fig 4.4 r={r} c={c}: {f} vs {ov}");
        }
    }
}

/// The OCR'd Fig. 4.4 with a signed `dr = r − ½` is wrong (correction 2).
#[test]
fn signed_dr_of_the_ocr_is_wrong() {
    let signed = |r: f64, c: f64| {
        let d = (c - 0.5f64).abs();
        let (sr, dr, maxr, minr) = (r + 0.5, r - 0.5, r.max(0.5), r.min(0.5));
        if d >= sr {
            0.0
        } else if d >= maxr {
            d - sr
        } else if d >= dr.max(minr) {
            dr - d
        } else if d >= dr.min(minr) {
            if dr >= minr { 0.0 } else { sr - 3.0 * d }
        } else {
            2.0 * (minr - d)
        }
    };
    let (r, c) = (0.2, 0.85); // α across β's right end
    assert!((signed(r, c) - canonical_overlap(Wave, Wave, r, c)).abs() > 0.1);
    assert!((canonical_fig44(r, c) - canonical_overlap(Wave, Wave, r, c)).abs() < 1e-12);
}

#[test]
fn closed_forms_match_quadrature_on_a_million_samples() {
    let pts = [
        (0.13, 0.41),
        (0.3, 0.9),
        (0.5, 0.5),
        (0.7, -0.1),
        (1.6, 0.2),
        (0.37, 1.2),
        (2.5, 1.9),
    ];
    for (r, c) in pts {
        for (a, b) in KINDS {
            let q = canonical_quadrature(a, b, r, c, 1_000_000);
            let m = canonical(a, b, r, c);
            assert!(
                (q - m).abs() <= 2e-5,
                "{a:?}{b:?} r={r} c={c}: {m} vs quadrature {q}"
            );
        }
    }
}

#[test]
fn sparsity_symmetry_and_inversion() {
    for r in radii() {
        for c in centres(r) {
            for (a, b) in KINDS {
                let m = canonical(a, b, r, c);
                if (c - 0.5).abs() > r + 0.5 {
                    assert_eq!(m, 0.0, "eq. 4.24 r={r} c={c}");
                }
                // eq. 4.27 (even for equal kinds, odd for mixed ones).
                let sign = if a == b { 1.0 } else { -1.0 };
                let mirror = canonical(a, b, r, 1.0 - c);
                assert!(
                    (m - sign * mirror).abs() <= 1e-12,
                    "4.27 {a:?}{b:?} r={r} c={c}"
                );
                // eq. 4.28 with 1/(4r) (correction 3); roles swap for mixed kinds.
                let inv = 2.0 * r * canonical(b, a, 0.25 / r, 0.5 + 0.25 / r - c / (2.0 * r));
                assert!(
                    (m - inv).abs() <= 1e-12,
                    "4.28 {a:?}{b:?} r={r} c={c}: {m} vs {inv}"
                );
            }
        }
    }
}

#[test]
fn bounds_hold_and_are_attained() {
    for r in radii() {
        let cs = centres(r);
        let vals: Vec<f64> = cs.iter().map(|&c| canonical(Wave, Wave, r, c)).collect();
        let (hi, lo) = (2.0 * r.min(0.5), -r.min(0.5));
        let max = vals.iter().copied().fold(f64::MIN, f64::max);
        let min = vals.iter().copied().fold(f64::MAX, f64::min);
        assert!(
            max <= hi + 1e-12 && min >= lo - 1e-12,
            "r={r}: [{min}, {max}]"
        );
        assert!(
            (max - hi).abs() < 1e-12 && (min - lo).abs() < 1e-12,
            "r={r}: not attained"
        );
        assert!(hi <= 1.0 && lo >= -0.5);
    }
}

#[test]
fn derivatives_match_finite_differences() {
    let h = 1e-7;
    let mut checked = 0;
    for r in radii() {
        for c in centres(r) {
            for (a, b) in KINDS {
                let f = |r: f64, c: f64| primitive_form(a, b, r, c);
                let (fc, bc) = ((f(r, c + h) - f(r, c)) / h, (f(r, c) - f(r, c - h)) / h);
                let (fr, br) = ((f(r + h, c) - f(r, c)) / h, (f(r, c) - f(r - h, c)) / h);
                if (fc - bc).abs() > 1e-5 || (fr - br).abs() > 1e-5 {
                    continue; // a kink within h
                }
                let (dr, dc) = canonical_gradient(a, b, r, c);
                assert!(
                    (dc - fc).abs() < 1e-5 && (dr - fr).abs() < 1e-5,
                    "{a:?}{b:?} r={r} c={c}"
                );
                if (a, b) == (Wave, Wave) {
                    assert!([0.0, 1.0, 2.0, 3.0].contains(&dc.abs()), "4.25 slope {dc}");
                    assert!([0.0, 1.0, 2.0].contains(&dr.abs()), "4.26 slope {dr}");
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 50_000, "only {checked} smooth points");
}

#[test]
fn structural_zeros_are_true_zeros_and_exact() {
    for r in radii() {
        for c in centres(r) {
            for (a, b) in KINDS {
                if is_structural_zero(a, b, r, c) {
                    assert!(
                        canonical_overlap(a, b, r, c).abs() <= 1e-15,
                        "{a:?}{b:?} r={r} c={c}"
                    );
                    assert_eq!(canonical(a, b, r, c), 0.0);
                }
            }
        }
    }
}
