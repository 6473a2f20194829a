//! The spherical triangular Haar basis on the icosahedral hierarchy
//! (spherical-wavelets-triple-product-2006 §3.1, Fig. 3–4).
//!
//! # Functions
//! The leaf level `L` (the paper's 4: `20·4^4 = 5120` triangles) holds the
//! sampled values. With `T_i^l` the triangles of level `l` (children
//! `4i + k` of [`relight_sphere::icosahedral`]) the basis is
//!
//! * the 20 level-0 **scaling functions** `φ_i^0 = 1` on `T_i^0`, else 0;
//! * per triangle `T_i^l`, `l < L`, three **wavelets** `ψ_{i,t}^l`, each a ±1
//!   pattern over the four children: `+1` on child `t` and on the centre
//!   child 3, `−1` on the other two ([`sign`]). The three patterns and the
//!   all-ones pattern are the rows of a 4×4 Hadamard matrix, so they are
//!   mutually orthogonal, and `ψ_0 ψ_1 ψ_2 = φ_i^l` (case 2 below).
//!
//! The paper's OCR does not let the exact sign patterns be read back; any
//! Hadamard assignment gives the same theorem, and this one is symmetric in
//! the three corner children.
//!
//! # Measure and normalisation
//! The paper sets the area of every level-0 triangle to 1, so
//! `A_l = 4^{−l}` ([`level_area`]) and `∫ f = A_L Σ_j f_j` over the leaves
//! (the *counting measure*). The basis is orthogonal, not orthonormal:
//! `⟨φ_i^0, φ_i^0⟩ = 1`, `⟨ψ_{i,t}^l, ψ_{i,t}^l⟩ = A_l`. The true geodesic
//! triangles are not equal (max/min leaf area 1.30 at level 4); the exact
//! solid angles enter through the BRDF term (`crate::quadrature`), so the
//! counting-measure product equals the true integral.
//!
//! # Layout (coarse levels first)
//! | index | function |
//! |---|---|
//! | `0 .. 20` | `φ_i^0` |
//! | `20·4^l + 3i + t` | `ψ_{i,t}^l`, `l = 0 .. L−1` |
//!
//! so the first `20·4^m` coefficients are exactly levels `< m` complete, and
//! they determine the averages over the `20·4^m` triangles of level `m`
//! ([`Basis::averages_at`]).
//!
//! # Transform
//! Forward, per parent from the leaves up: the average `a = ¼ Σ_k a_k` and
//! `d_t = ¼ Σ_k s_t(k) a_k` (`⟨f, ψ⟩ / ⟨ψ, ψ⟩`); inverse
//! `a_k = a + Σ_t s_t(k) d_t`. Both are exact up to rounding.
//!
//! # Tripling coefficients (the paper's theorem)
//! `C_{abc} = ∫ b_a b_b b_c` (counting measure) is non-zero only when
//! 1. all three are the same scaling function: `C = A_0 = 1`;
//! 2. all three are the three different wavelet types of one triangle
//!    `T_i^l`: `C = A_l`;
//! 3. two are the same wavelet `ψ_{i,t}^l` and the third is a scaling
//!    function or a wavelet of a strictly coarser level whose support holds
//!    `T_i^l`: `C = ± A_l`, the sign of the third on `T_i^l`.
//!
//! [`tripling`] evaluates it in O(L); [`Basis::function_on_leaves`] is the
//! brute-force form the tests compare it with.

/// Number of triangles of level `l`: `20·4^l`.
#[inline]
#[must_use]
pub const fn triangles(level: usize) -> usize {
    20 << (2 * level)
}

/// The paper's area of a level-`l` triangle, `A_l = 4^{−l}` (level 0 = 1).
#[inline]
#[must_use]
pub fn level_area(level: usize) -> f64 {
    0.25f64.powi(level as i32)
}

/// Sign of wavelet type `t` (0..3) on child `k` (0..4): `+1` on child `t`
/// and on the centre child 3, `−1` on the others.
#[inline]
#[must_use]
pub const fn sign(t: usize, k: usize) -> f32 {
    if k == t || k == 3 { 1.0 } else { -1.0 }
}

/// One basis function, decoded from its index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Function {
    /// `φ_i^0`.
    Scaling(usize),
    /// `ψ_{i,t}^l`.
    Wavelet {
        level: usize,
        index: usize,
        kind: usize,
    },
}

impl Function {
    /// Decodes coefficient index `k` (the layout in the module docs).
    #[must_use]
    pub fn decode(k: usize) -> Self {
        if k < 20 {
            return Self::Scaling(k);
        }
        let mut level = 0;
        while triangles(level + 1) <= k {
            level += 1;
        }
        let r = k - triangles(level);
        Self::Wavelet {
            level,
            index: r / 3,
            kind: r % 3,
        }
    }

    /// The coefficient index of this function.
    #[must_use]
    pub fn encode(self) -> usize {
        match self {
            Self::Scaling(i) => i,
            Self::Wavelet { level, index, kind } => triangles(level) + 3 * index + kind,
        }
    }

    /// Value of this function on the (paper-area) triangle `index` of
    /// `level`, where the function is constant there (`level` finer than the
    /// function's own), else `None` (outside its support is `Some(0)`).
    fn value_on(self, level: usize, index: usize) -> Option<f32> {
        match self {
            Self::Scaling(i) => Some(if index >> (2 * level) == i { 1.0 } else { 0.0 }),
            Self::Wavelet {
                level: l,
                index: i,
                kind,
            } => {
                if level <= l {
                    return None;
                }
                if index >> (2 * (level - l)) != i {
                    return Some(0.0);
                }
                let child = (index >> (2 * (level - l - 1))) & 3;
                Some(sign(kind, child))
            }
        }
    }
}

/// The tripling coefficient `∫ b_a b_b b_c` in the counting measure (the
/// theorem in the module docs), O(L).
#[must_use]
pub fn tripling(a: usize, b: usize, c: usize) -> f64 {
    use Function::{Scaling, Wavelet};
    let f = [a, b, c].map(Function::decode);
    match f {
        [Scaling(i), Scaling(j), Scaling(k)] => {
            if i == j && j == k {
                1.0
            } else {
                0.0
            }
        }
        _ => {
            // Case 2: the three types of one triangle.
            if let [
                Wavelet {
                    level: l0,
                    index: i0,
                    kind: t0,
                },
                Wavelet {
                    level: l1,
                    index: i1,
                    kind: t1,
                },
                Wavelet {
                    level: l2,
                    index: i2,
                    kind: t2,
                },
            ] = f
                && l0 == l1
                && l1 == l2
                && i0 == i1
                && i1 == i2
                && t0 != t1
                && t1 != t2
                && t0 != t2
            {
                return level_area(l0);
            }
            // Case 3: two equal wavelets, the third strictly coarser.
            for (p, q, r) in [(0, 1, 2), (0, 2, 1), (1, 2, 0)] {
                if f[p] == f[q]
                    && let Wavelet { level, index, .. } = f[p]
                    && let Some(v) = f[r].value_on(level, index)
                {
                    return f64::from(v) * level_area(level);
                }
            }
            0.0
        }
    }
}

/// The basis of one leaf level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Basis {
    leaf_level: usize,
}

/// Deepest supported leaf level (the hierarchy has 7; quadrature needs some below).
pub const MAX_LEAF_LEVEL: usize = 5;

impl Basis {
    /// The basis with leaves at `leaf_level` (1..=[`MAX_LEAF_LEVEL`]), `None`
    /// outside.
    #[must_use]
    pub fn new(leaf_level: usize) -> Option<Self> {
        (1..=MAX_LEAF_LEVEL)
            .contains(&leaf_level)
            .then_some(Self { leaf_level })
    }

    /// The paper's basis: leaves at level 4 (5120 functions).
    #[must_use]
    pub fn paper() -> Self {
        Self { leaf_level: 4 }
    }

    /// Leaf level `L`.
    #[must_use]
    pub fn leaf_level(self) -> usize {
        self.leaf_level
    }

    /// Number of functions = number of leaves, `20·4^L`.
    #[must_use]
    pub fn len(self) -> usize {
        triangles(self.leaf_level)
    }

    /// Never empty.
    #[must_use]
    pub fn is_empty(self) -> bool {
        false
    }

    /// `A_L`, the counting-measure weight of one leaf.
    #[must_use]
    pub fn leaf_area(self) -> f64 {
        level_area(self.leaf_level)
    }

    /// Squared norm `⟨b_k, b_k⟩` of function `k`: 1 for scaling, `A_l` for wavelets.
    #[must_use]
    pub fn norm2(self, k: usize) -> f64 {
        match Function::decode(k) {
            Function::Scaling(_) => 1.0,
            Function::Wavelet { level, .. } => level_area(level),
        }
    }

    /// Forward transform: leaf values (leaf triangle order) → coefficients.
    ///
    /// # Panics
    /// When the slices are not both `len()` long.
    pub fn forward(self, leaves: &[f32], coeffs: &mut [f32]) {
        let n = self.len();
        assert!(leaves.len() == n && coeffs.len() == n, "transform length");
        let mut avg = leaves.to_vec();
        for l in (0..self.leaf_level).rev() {
            let base = triangles(l);
            for i in 0..triangles(l) {
                let a = [avg[4 * i], avg[4 * i + 1], avg[4 * i + 2], avg[4 * i + 3]];
                for t in 0..3 {
                    let d: f32 = (0..4).map(|k| sign(t, k) * a[k]).sum();
                    coeffs[base + 3 * i + t] = 0.25 * d;
                }
                avg[i] = 0.25 * (a[0] + a[1] + a[2] + a[3]);
            }
        }
        coeffs[..20].copy_from_slice(&avg[..20]);
    }

    /// Inverse transform: coefficients → leaf values.
    ///
    /// # Panics
    /// When the slices are not both `len()` long.
    pub fn inverse(self, coeffs: &[f32], leaves: &mut [f32]) {
        assert!(coeffs.len() == self.len() && leaves.len() == self.len());
        let out = self.averages_at(coeffs, self.leaf_level);
        leaves.copy_from_slice(&out);
    }

    /// The averages over the `20·4^m` triangles of level `m` (`m ≤ L`),
    /// from the first `20·4^m` coefficients (the complete levels `< m`); the
    /// top-only reconstruction.
    ///
    /// # Panics
    /// When `m > L` or `coeffs` is shorter than `20·4^m`.
    #[must_use]
    pub fn averages_at(self, coeffs: &[f32], m: usize) -> Vec<f32> {
        assert!(m <= self.leaf_level && coeffs.len() >= triangles(m));
        let mut avg = vec![0.0f32; triangles(m)];
        avg[..20].copy_from_slice(&coeffs[..20]);
        for l in 0..m {
            let base = triangles(l);
            for i in (0..triangles(l)).rev() {
                let a = avg[i];
                let d = &coeffs[base + 3 * i..base + 3 * i + 3];
                for k in 0..4 {
                    avg[4 * i + k] = a + sign(0, k) * d[0] + sign(1, k) * d[1] + sign(2, k) * d[2];
                }
            }
        }
        avg
    }

    /// Brute force: the values of function `k` on every leaf (±1 or 0).
    #[must_use]
    pub fn function_on_leaves(self, k: usize) -> Vec<f32> {
        let f = Function::decode(k);
        (0..self.len())
            .map(|j| {
                f.value_on(self.leaf_level, j)
                    .expect("leaf level is finer than every function")
            })
            .collect()
    }
}
