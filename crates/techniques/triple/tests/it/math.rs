//! The exact identities of the basis and the product (issue 12, "Verify").

use glam::Vec3;
use relight_triple::basis::{Basis, Function, triangles, tripling};
use relight_triple::product::{brute_force, dense, sparse, top_only};
use relight_triple::{LeafGrid, Selection, Weighting, select};

/// A small deterministic generator (xorshift), values in [−1, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }
    fn below(&mut self, n: usize) -> usize {
        (((self.next() + 1.0) * 0.5) * n as f32) as usize % n
    }
    fn vec(&mut self, n: usize) -> Vec<f32> {
        (0..n).map(|_| self.next()).collect()
    }
}

fn inner(basis: Basis, a: &[f32], b: &[f32]) -> f64 {
    basis.leaf_area()
        * a.iter()
            .zip(b)
            .map(|(x, y)| f64::from(*x) * f64::from(*y))
            .sum::<f64>()
}

#[test]
fn layout_round_trips_and_counts() {
    let b = Basis::paper();
    assert_eq!(b.len(), 5120);
    for k in 0..b.len() {
        assert_eq!(Function::decode(k).encode(), k);
    }
    // The first 20·4^m coefficients are the complete levels < m.
    for m in 1..4 {
        let Function::Wavelet { level, index, kind } = Function::decode(triangles(m) - 1) else {
            panic!("wavelet expected");
        };
        assert_eq!((level, index, kind), (m - 1, triangles(m - 1) - 1, 2));
    }
}

#[test]
fn basis_is_orthogonal_with_norms_a_l() {
    // Every pair of the 320 functions of leaf level 2.
    let b = Basis::new(2).unwrap();
    let f: Vec<Vec<f32>> = (0..b.len()).map(|k| b.function_on_leaves(k)).collect();
    for i in 0..b.len() {
        for j in i..b.len() {
            let g = inner(b, &f[i], &f[j]);
            let want = if i == j { b.norm2(i) } else { 0.0 };
            assert!((g - want).abs() < 1e-12, "<b{i}, b{j}> = {g}, want {want}");
        }
    }
}

#[test]
fn transform_reconstructs_perfectly_and_coefficients_are_projections() {
    let b = Basis::paper();
    let mut rng = Rng(7);
    let leaves = rng.vec(b.len());
    let mut c = vec![0.0; b.len()];
    b.forward(&leaves, &mut c);
    let mut back = vec![0.0; b.len()];
    b.inverse(&c, &mut back);
    let err = leaves
        .iter()
        .zip(&back)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    assert!(err < 2e-6, "reconstruction error {err}");
    for _ in 0..40 {
        let k = rng.below(b.len());
        let proj = inner(b, &leaves, &b.function_on_leaves(k)) / b.norm2(k);
        assert!(
            (proj - f64::from(c[k])).abs() < 1e-5,
            "c[{k}] = {} but <f, b>/|b|² = {proj}",
            c[k]
        );
    }
}

fn brute_tripling(b: Basis, f: &[Vec<f32>], i: usize, j: usize, k: usize) -> f64 {
    b.leaf_area()
        * f[i]
            .iter()
            .zip(&f[j])
            .zip(&f[k])
            .map(|((x, y), z)| f64::from(x * y * z))
            .sum::<f64>()
}

#[test]
fn tripling_coefficients_of_the_first_80_match_brute_force() {
    let b = Basis::new(2).unwrap();
    let f: Vec<Vec<f32>> = (0..80).map(|k| b.function_on_leaves(k)).collect();
    let mut nonzero = 0;
    for i in 0..80 {
        for j in 0..80 {
            for k in 0..80 {
                let want = brute_tripling(b, &f, i, j, k);
                let got = tripling(i, j, k);
                assert!(
                    (got - want).abs() < 1e-12,
                    "C({i},{j},{k}) = {got}, brute {want}"
                );
                nonzero += usize::from(want != 0.0);
            }
        }
    }
    // Case 1: 20; case 2: 20 triangles × 6 orders; case 3: 60 wavelets × (1 scaling × 3 orders).
    assert_eq!(nonzero, 20 + 120 + 180);
}

#[test]
fn deeper_tripling_coefficients_match_brute_force() {
    let b = Basis::paper();
    let mut rng = Rng(11);
    let mut nonzero = 0;
    for _ in 0..600 {
        // A random wavelet, twice or with its siblings, plus a random
        // ancestor or sibling — biased toward the non-zero cases.
        let k = 20 + rng.below(b.len() - 20);
        let Function::Wavelet { level, index, kind } = Function::decode(k) else {
            unreachable!()
        };
        let lp = rng.below(level + 1);
        let third = if rng.next() < 0.0 || lp == level {
            Function::Scaling(index >> (2 * level)).encode()
        } else {
            Function::Wavelet {
                level: lp,
                index: index >> (2 * (level - lp)),
                kind: rng.below(3),
            }
            .encode()
        };
        let sib = Function::Wavelet {
            level,
            index,
            kind: (kind + 1) % 3,
        }
        .encode();
        let other = Function::Wavelet {
            level,
            index,
            kind: (kind + 2) % 3,
        }
        .encode();
        for (i, j, l) in [
            (k, k, third),
            (third, k, k),
            (k, sib, other),
            (k, sib, third),
        ] {
            let f: Vec<Vec<f32>> = [i, j, l].iter().map(|&q| b.function_on_leaves(q)).collect();
            let want = brute_tripling(b, &f, 0, 1, 2);
            let got = tripling(i, j, l);
            assert!(
                (got - want).abs() < 1e-12,
                "C({i},{j},{l}) = {got}, brute {want}"
            );
            nonzero += usize::from(want != 0.0);
        }
    }
    assert!(nonzero > 1000, "only {nonzero} non-zero triples exercised");
}

#[test]
fn dense_fast_product_matches_brute_force() {
    let b = Basis::paper();
    let mut rng = Rng(3);
    for _ in 0..5 {
        let (l, v, r) = (rng.vec(b.len()), rng.vec(b.len()), rng.vec(b.len()));
        let want = brute_force(b, &l, &v, &r);
        let got = dense(b, &l, &v, &r);
        assert!(
            (got - want).abs() < 1e-4 * (1.0 + want.abs()),
            "{got} vs {want}"
        );
    }
}

#[test]
fn sparse_fast_product_matches_brute_force() {
    let b = Basis::paper();
    let mut rng = Rng(5);
    for (n, sel) in [
        (80, Selection::Adaptive),
        (300, Selection::Adaptive),
        (320, Selection::Top),
    ] {
        let f: Vec<_> = (0..3)
            .map(|_| {
                let leaves: Vec<f32> = rng.vec(b.len()).iter().map(|x| x * x * x).collect();
                let mut c = vec![0.0; b.len()];
                b.forward(&leaves, &mut c);
                select(b, &c, n, sel)
            })
            .collect();
        let d: Vec<Vec<f32>> = f.iter().map(|s| s.to_dense(b.len())).collect();
        let want = brute_force(b, &d[0], &d[1], &d[2]);
        let got = sparse(b, &f[0], &f[1], &f[2]);
        assert!(
            (got - want).abs() < 1e-5 * (1.0 + want.abs()),
            "n {n}: {got} vs {want}"
        );
        assert!((dense(b, &d[0], &d[1], &d[2]) - want).abs() < 1e-5 * (1.0 + want.abs()));
    }
}

#[test]
fn top_only_kernel_is_the_product_of_complete_levels() {
    let b = Basis::paper();
    let mut rng = Rng(9);
    for m in 1..=3 {
        let n = triangles(m);
        let c: Vec<Vec<f32>> = (0..3).map(|_| rng.vec(b.len())).collect();
        let trunc: Vec<Vec<f32>> = c
            .iter()
            .map(|x| {
                let mut t = x.clone();
                t[n..].fill(0.0);
                t
            })
            .collect();
        let want = dense(b, &trunc[0], &trunc[1], &trunc[2]);
        let a: Vec<Vec<f32>> = c.iter().map(|x| b.averages_at(x, m)).collect();
        let got = top_only(&a[0], &a[1], &a[2]);
        assert!(
            (got - want).abs() < 1e-4 * (1.0 + want.abs()),
            "m {m}: {got} vs {want}"
        );
    }
}

#[test]
fn furnace_lambert_under_unit_lighting_is_one() {
    let b = Basis::paper();
    let grid = LeafGrid::new(b, 2).unwrap();
    let mut rng = Rng(13);
    let ones = vec![1.0f32; b.len()];
    let mut ones_c = vec![0.0; b.len()];
    b.forward(&ones, &mut ones_c);
    for _ in 0..12 {
        let n = Vec3::new(rng.next(), rng.next(), rng.next()).normalize();
        let mut rho = vec![0.0; b.len()];
        grid.brdf_term(
            |w| n.dot(w).max(0.0) / std::f32::consts::PI,
            Weighting::Exact,
            &mut rho,
        );
        let mut rc = vec![0.0; b.len()];
        b.forward(&rho, &mut rc);
        let got = dense(b, &ones_c, &ones_c, &rc);
        assert!((got - 1.0).abs() < 1e-4, "furnace B = {got} for normal {n}");
    }
}
