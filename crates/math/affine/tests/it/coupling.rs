//! ACC and ATC (eqs. 4.8–4.17, 4.20–4.23, 4.29) against direct overlap,
//! quadrature, Lemma 1 and the identities 4.11–4.13.

use relight_affine::Atom;
use relight_affine::canonical::canonical;
use relight_affine::coupling::{
    affine_coupling, affine_coupling_gradient, affine_coupling_overlap, affine_coupling_quadrature,
    affine_tripling, affine_tripling_quadrature, property2, standard_coupling, standard_tripling,
    tripling_by_lemma1,
};
use relight_affine::sparsity::random_sets;

/// All atoms up to level 3: the order-16 basis plus boxes at every level.
fn atoms() -> Vec<Atom> {
    let mut v: Vec<Atom> = (0..16).map(Atom::from_index).collect();
    for l in 1..4 {
        v.extend((0..1u32 << l).map(|t| Atom::new_box(l, t)));
    }
    v
}

fn level_factor(i: Atom, j: Atom) -> f64 {
    (0.5 * (f64::from(i.level) - f64::from(j.level))).exp2()
}

#[test]
fn acc_matches_direct_overlap_in_v() {
    let mut sets = random_sets(12, 5);
    sets.extend([(1.0, 0.0), (0.5, 0.25), (2.0, -0.375), (0.3, 0.0)]);
    for (s, o) in sets {
        for &i in &atoms() {
            for &j in &atoms() {
                let d = affine_coupling(i, j, s, o);
                let ov = affine_coupling_overlap(i, j, s, o);
                assert!(
                    (d - ov).abs() <= 1e-12 * level_factor(i, j).max(1.0),
                    "{i:?} {j:?} s={s} o={o}: {d} vs {ov}"
                );
            }
        }
    }
}

/// The OCR'd eq. 4.23 (`2^{l_i} o`) disagrees with the overlap (correction 1).
#[test]
fn ocr_offset_term_is_wrong() {
    let (i, j, s, o) = (Atom::wave(1, 0), Atom::wave(3, 1), 0.8, 0.1);
    let dl = (f64::from(j.level) - f64::from(i.level)).exp2();
    let r = 0.5 * dl / s;
    let c_ocr = (dl * f64::from(i.offset) - i.scale() * o + 0.5 * dl) / s - f64::from(j.offset);
    let wrong = level_factor(i, j) * canonical(i.kind, j.kind, r, c_ocr);
    let right = affine_coupling_overlap(i, j, s, o);
    assert!(
        right.abs() > 0.1 && (wrong - right).abs() > 0.1,
        "{wrong} vs {right}"
    );
}

#[test]
fn acc_matches_quadrature() {
    for (s, o) in random_sets(3, 9) {
        for &i in atoms().iter().step_by(3) {
            for &j in atoms().iter().step_by(4) {
                let q = affine_coupling_quadrature(i, j, s, o, 100_000);
                let d = affine_coupling(i, j, s, o);
                let tol = 2e-5 * level_factor(i, j).max(1.0) * (1.0 + (s * i.scale() / j.scale()));
                assert!((q - d).abs() <= tol, "{i:?} {j:?} s={s} o={o}: {d} vs {q}");
            }
        }
    }
}

#[test]
fn standard_coefficients_and_identities() {
    let b: Vec<Atom> = (0..32).map(Atom::from_index).collect();
    for &i in &b {
        for &j in &b {
            assert_eq!(
                standard_coupling(i, j),
                if i == j { 1.0 } else { 0.0 },
                "4.12 C_ij"
            );
        }
    }
    // eq. 4.11: the STC is symmetric under permutations.
    let few: Vec<Atom> = (0..16).map(Atom::from_index).collect();
    for &i in &few {
        for &j in &few {
            for &k in &few {
                let c = standard_tripling(i, j, k);
                for p in [
                    standard_tripling(j, i, k),
                    standard_tripling(k, j, i),
                    standard_tripling(i, k, j),
                ] {
                    assert!((c - p).abs() <= 1e-12, "4.11");
                }
            }
        }
    }
    // eq. 4.13.
    for (s, o) in random_sets(10, 17) {
        for &i in &atoms() {
            for &j in &atoms() {
                let a = affine_coupling(i, j, s, o);
                let b = affine_coupling(j, i, 1.0 / s, -o / s) / s;
                assert!(
                    (a - b).abs() <= 1e-12 * level_factor(i, j).max(level_factor(j, i)),
                    "4.13 {i:?} {j:?}"
                );
            }
        }
    }
}

#[test]
fn acc_derivatives_match_finite_differences() {
    let h = 1e-7;
    let mut checked = 0;
    for (s, o) in random_sets(20, 23) {
        for &i in &atoms() {
            for &j in &atoms() {
                let f = |s: f64, o: f64| affine_coupling_overlap(i, j, s, o);
                let (fs, bs) = ((f(s + h, o) - f(s, o)) / h, (f(s, o) - f(s - h, o)) / h);
                let (fo, bo) = ((f(s, o + h) - f(s, o)) / h, (f(s, o) - f(s, o - h)) / h);
                let scale = 16.0 * level_factor(i, j).max(1.0) * j.scale();
                if (fs - bs).abs() > 1e-4 * scale || (fo - bo).abs() > 1e-4 * scale {
                    continue;
                }
                let (ds, d_o) = affine_coupling_gradient(i, j, s, o);
                assert!(
                    (ds - fs).abs() <= 1e-4 * scale && (d_o - fo).abs() <= 1e-4 * scale,
                    "{i:?} {j:?} s={s} o={o}: ({ds},{d_o}) vs ({fs},{fo})"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 10_000, "{checked}");
}

#[test]
fn atc_matches_quadrature_lemma1_and_corrected_property2() {
    let b: Vec<Atom> = (0..16).map(Atom::from_index).collect();
    let mut sigma_matters = false;
    for (s, o) in random_sets(3, 31) {
        for &i in &atoms() {
            for &j in &b {
                for &k in &b {
                    let d = affine_tripling(i, j, k, s, o);
                    let lemma = tripling_by_lemma1(i, j, k, s, o, 16);
                    let amp = level_factor(i, j).max(1.0) * j.scale().max(k.scale()).sqrt() * 4.0;
                    assert!(
                        (d - lemma).abs() <= 1e-12 * amp,
                        "Lemma 1 {i:?} {j:?} {k:?}: {d} vs {lemma}"
                    );
                    if let Some(p2) = property2(i, j, k, s, o) {
                        assert!((d - p2).abs() <= 1e-12 * amp, "4.29 {i:?} {j:?} {k:?}");
                        sigma_matters |= p2 != 0.0 && p2 < 0.0 && d < 0.0;
                    }
                }
            }
        }
    }
    assert!(sigma_matters);
    for (s, o) in random_sets(2, 41) {
        for &i in atoms().iter().step_by(5) {
            for j in [0usize, 1, 5, 9].map(Atom::from_index) {
                for k in [0usize, 3, 9, 13].map(Atom::from_index) {
                    let d = affine_tripling(i, j, k, s, o);
                    let q = affine_tripling_quadrature(i, j, k, s, o, 100_000);
                    let amp = level_factor(i, j).max(1.0)
                        * j.scale().max(k.scale()).sqrt()
                        * (1.0 + s * i.scale());
                    assert!(
                        (d - q).abs() <= 2e-5 * amp,
                        "ATC {i:?} {j:?} {k:?} s={s} o={o}: {d} vs {q}"
                    );
                }
            }
        }
    }
    // j = k: D_ijj = 2^{l_i/2} M_ψφ (the case Property 2 omits).
    let (i, j, s, o) = (Atom::wave(1, 1), Atom::wave(2, 1), 0.9, 0.2);
    let q = affine_tripling_quadrature(i, j, j, s, o, 400_000);
    assert!((affine_tripling(i, j, j, s, o) - q).abs() < 1e-4 && q.abs() > 0.05);
}
