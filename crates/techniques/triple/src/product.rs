//! The fast triple-product integral `B = ∫ L V ρ̃` in the Haar basis
//! (spherical-wavelets-triple-product-2006 §3.1 after Ng et al. 2004 §5).
//!
//! # The tree sum
//! On a triangle `T_i^l` every function is its average `a` (from the coarser
//! coefficients) plus `Σ_t d_t ψ_t` plus finer detail. Integrating the
//! product of three piecewise-constant-on-children functions with the
//! tripling theorem ([`crate::basis`]) gives
//!
//! ```text
//! ∫_T L V ρ̃ = A_l [ a_L a_V a_ρ                                   (children's means: recursion)
//!             + Σ_t (d^L_t d^V_t a_ρ + d^L_t a_V d^ρ_t + a_L d^V_t d^ρ_t)   (case 3)
//!             + Σ_{σ ∈ S_3} d^L_{σ0} d^V_{σ1} d^ρ_{σ2} ]                       (case 2)
//! ```
//!
//! and the first term telescopes down the tree, so
//! `B = Σ_i a_L a_V a_ρ (level 0, case 1) + Σ_{l<L} Σ_i A_l [case 3 + case 2]`,
//! with the averages propagated top-down (`a_k = a + Σ_t s_t(k) d_t`).
//!
//! * [`dense`]: every node, O(N), allocation-free (depth-first).
//! * [`sparse`]: only nodes where at least two of the three functions have a
//!   wavelet coefficient contribute; the third function's average there is the
//!   sum of its ancestors' terms, found by binary search: O(n log n) for `n`
//!   terms (times the depth L).
//! * [`top_only`]: when each function keeps exactly the first `20·4^m`
//!   coefficients (complete levels), the finer detail is zero and the sum is
//!   the per-triangle product of the level-`m` averages,
//!   `B = A_m Σ_i a_L a_V a_ρ` — the runtime kernel.
//! * [`brute_force`]: `A_L Σ_j L_j V_j ρ_j` over the leaves, for tests.

use crate::basis::{Basis, Function, level_area, sign, triangles};
use crate::select::SparseVec;

/// `A_L Σ_j L_j V_j ρ_j` over the leaves (inverse transforms; for tests).
#[must_use]
pub fn brute_force(basis: Basis, l: &[f32], v: &[f32], r: &[f32]) -> f64 {
    let n = basis.len();
    let (mut a, mut b, mut c) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    basis.inverse(l, &mut a);
    basis.inverse(v, &mut b);
    basis.inverse(r, &mut c);
    basis.leaf_area()
        * a.iter()
            .zip(&b)
            .zip(&c)
            .map(|((x, y), z)| f64::from(*x) * f64::from(*y) * f64::from(*z))
            .sum::<f64>()
}

/// The case-2 and case-3 terms of one node (without `A_l`).
#[inline]
fn node_terms(a: [f64; 3], dl: [f64; 3], dv: [f64; 3], dr: [f64; 3]) -> f64 {
    let mut s = 0.0;
    for t in 0..3 {
        s += dl[t] * dv[t] * a[2] + dl[t] * a[1] * dr[t] + a[0] * dv[t] * dr[t];
    }
    s + dl[0] * (dv[1] * dr[2] + dv[2] * dr[1])
        + dl[1] * (dv[0] * dr[2] + dv[2] * dr[0])
        + dl[2] * (dv[0] * dr[1] + dv[1] * dr[0])
}

/// The tree sum over dense coefficient vectors (each `basis.len()` long), O(N).
///
/// # Panics
/// When a slice is not `basis.len()` long.
#[must_use]
pub fn dense(basis: Basis, l: &[f32], v: &[f32], r: &[f32]) -> f64 {
    let n = basis.len();
    assert!(
        l.len() == n && v.len() == n && r.len() == n,
        "dense product length"
    );
    let f = [l, v, r];
    let mut total = 0.0;
    for i in 0..20 {
        let a = [0, 1, 2].map(|q| f64::from(f[q][i]));
        total += a[0] * a[1] * a[2] + descend(basis, &f, 0, i, a);
    }
    total
}

fn descend(basis: Basis, f: &[&[f32]; 3], level: usize, i: usize, a: [f64; 3]) -> f64 {
    if level == basis.leaf_level() {
        return 0.0;
    }
    let base = triangles(level) + 3 * i;
    let d = [0, 1, 2].map(|q| [0, 1, 2].map(|t| f64::from(f[q][base + t])));
    let mut s = level_area(level) * node_terms(a, d[0], d[1], d[2]);
    for k in 0..4 {
        let child =
            [0, 1, 2].map(|q| a[q] + (0..3).map(|t| f64::from(sign(t, k)) * d[q][t]).sum::<f64>());
        s += descend(basis, f, level + 1, 4 * i + k, child);
    }
    s
}

/// The tree sum over sparse vectors (sorted indices, each below `basis.len()`),
/// O(n log n · L).
#[must_use]
pub fn sparse(basis: Basis, l: &SparseVec, v: &SparseVec, r: &SparseVec) -> f64 {
    let f = [l, v, r];
    // Case 1: the level-0 scaling terms.
    let mut total = 0.0;
    for (&k, &x) in l.indices.iter().zip(&l.values) {
        if k >= 20 {
            break;
        }
        total += f64::from(x) * v.get(k as usize) * r.get(k as usize);
    }
    // Nodes (as the index of their first wavelet, 20·4^l + 3i) where at
    // least two functions have a wavelet coefficient.
    let mut nodes: Vec<u32> = Vec::with_capacity(l.len() + v.len() + r.len());
    for g in f {
        let mut last = u32::MAX;
        for &k in g.indices.iter().filter(|&&k| k >= 20) {
            let node = node_start(k);
            if node != last {
                nodes.push(node);
                last = node;
            }
        }
    }
    nodes.sort_unstable();
    let mut j = 0;
    while j < nodes.len() {
        let node = nodes[j];
        let mut count = 0;
        while j < nodes.len() && nodes[j] == node {
            count += 1;
            j += 1;
        }
        if count < 2 {
            continue;
        }
        let Function::Wavelet { level, index, .. } = Function::decode(node as usize) else {
            unreachable!("nodes are wavelet indices");
        };
        let d = f.map(|g| [0, 1, 2].map(|t| g.get(node as usize + t)));
        let a = f.map(|g| average(g, level, index));
        total += level_area(level) * node_terms(a, d[0], d[1], d[2]);
    }
    let _ = basis;
    total
}

/// The first index `20·4^l + 3i` of the node of wavelet index `k`.
fn node_start(k: u32) -> u32 {
    let Function::Wavelet { level, index, .. } = Function::decode(k as usize) else {
        return k;
    };
    (triangles(level) + 3 * index) as u32
}

/// Average of the sparse function `g` over `T_index^level` (from its coarser terms).
fn average(g: &SparseVec, level: usize, index: usize) -> f64 {
    let mut a = g.get(index >> (2 * level));
    for l in 0..level {
        let i = index >> (2 * (level - l));
        let child = (index >> (2 * (level - l - 1))) & 3;
        let base = triangles(l) + 3 * i;
        for t in 0..3 {
            let d = g.get(base + t);
            if d != 0.0 {
                a += f64::from(sign(t, child)) * d;
            }
        }
    }
    a
}

/// The top-only kernel: `A_m Σ_i a_L a_V a_ρ` over the level-`m` averages
/// (three slices of `20·4^m`).
///
/// # Panics
/// When the slices differ in length.
#[must_use]
pub fn top_only(l: &[f32], v: &[f32], r: &[f32]) -> f64 {
    assert!(l.len() == v.len() && v.len() == r.len(), "top-only lengths");
    let area = 20.0 / l.len() as f64;
    area * l
        .iter()
        .zip(v)
        .zip(r)
        .map(|((x, y), z)| f64::from(x * y * z))
        .sum::<f64>()
}
