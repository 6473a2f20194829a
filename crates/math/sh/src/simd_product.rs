//! The truncated product `y = f ∗ g` at orders 3 and 4 with the output
//! coefficients across vector lanes (AVX-512).
//!
//! `y_k = Σ_{i,j} Γ_{ijk} f_i g_j` over the Gaunt coefficients of
//! [`crate::product::TripleProduct`]. At n ≤ 4 the `n² ≤ 16` coefficients of
//! `f` and `g` fit one 512-bit register (or two 256-bit ones) each, so the
//! sum runs as "slots": slot `s` holds, in lane `k`, the `s`-th term
//! `(i, j, Γ)` of output `k` (zero weight where `k` has fewer terms), and
//!
//! ```text
//! y = Σ_s W_s ∘ P_{i_s}(f) ∘ P_{j_s}(g),
//! ```
//!
//! `P` a lane permute. Order 4 has 353 ordered terms, at most 28 for one
//! output: 28 slots of two permutes, a multiply and a multiply–add on 16
//! lanes, against ≈ 400 scalar multiplies and multiply–adds in the
//! generated scalar kernel (which is bound by them, as DirectXMath's
//! `XMSHMultiply` is). Order 3 (83 terms, at most 10 per output) runs
//! outputs 0 … 7 on 256-bit registers and output 8 as one more slot summed
//! across its lanes: half the vector work of a 16-lane register whose
//! lanes 9 … 15 would idle. (Order 4 on two 256-bit halves measured 2.8×
//! slower than on one 512-bit register: twice the two-source permutes.)
//!
//! Both permute indices of a slot share one integer vector (`i | j << 4`):
//! the permute reads only the low four bits, so `j` is one shift away.
//! Tested against the f64 triple product in `fast_tests`.

#![cfg(target_arch = "x86_64")]

use std::arch::x86_64::*;
use std::sync::OnceLock;

use crate::lane_tables::{F16, I16, Row8};

/// Most terms of one output at n = 4 (checked when the tables are built), a
/// multiple of [`N4_ACC`].
const N4_SLOTS: usize = 28;
/// Independent accumulators at n = 4.
const N4_ACC: usize = 4;

/// Every ordered term `(i, j, Γ_{ijk})` of each output `k` at order `n`
/// (each stored triple `i ≤ j ≤ k` of [`crate::product::TripleProduct`] in
/// all its distinct orders).
fn terms(n: usize) -> Vec<Vec<(usize, usize, f64)>> {
    let tp = crate::product::TripleProduct::<f64>::new(n).expect("order ≤ 4");
    let mut terms: Vec<Vec<(usize, usize, f64)>> = vec![Vec::new(); n * n];
    for (i, j, k, w) in tp.entries() {
        for [a, b, c] in crate::product::distinct_orderings(i, j, k) {
            terms[c].push((a, b, w));
        }
    }
    terms
}

/// The slots of order 4.
#[derive(Debug)]
struct SlotsN4 {
    /// Lane `k`: `i | j << 4` of its term in this slot.
    idx: [I16; N4_SLOTS],
    /// Lane `k`: `Γ_{ijk}` of that term (0 for padding), rounded to f32.
    w: [F16; N4_SLOTS],
}

impl SlotsN4 {
    fn new() -> Self {
        let terms = terms(4);
        let most = terms.iter().map(Vec::len).max().unwrap_or(0);
        assert_eq!(most, N4_SLOTS, "slots at order 4");
        let mut s = Self {
            idx: [I16::default(); N4_SLOTS],
            w: [F16::default(); N4_SLOTS],
        };
        for (k, ts) in terms.iter().enumerate() {
            for (slot, &(i, j, w)) in ts.iter().enumerate() {
                s.idx[slot].0[k] = (i | j << 4) as i32;
                s.w[slot].0[k] = w as f32;
            }
        }
        s
    }

    fn get() -> &'static Self {
        static T: OnceLock<SlotsN4> = OnceLock::new();
        T.get_or_init(Self::new)
    }
}

/// `out = f ∗ g` truncated to order 4 ([`SlotsN4`]).
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512VL, AVX2 and FMA.
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[inline(never)]
pub(crate) unsafe fn product_n4(f: &[f32; 16], g: &[f32; 16], out: &mut [f32; 16]) {
    let t = SlotsN4::get();
    // SAFETY: the features are enabled; the loads and the store cover the
    // 16 values of each array; the tables are 64-byte aligned.
    unsafe {
        let fv = _mm512_loadu_ps(f.as_ptr());
        let gv = _mm512_loadu_ps(g.as_ptr());
        let mut acc = [_mm512_setzero_ps(); N4_ACC];
        // (Chunked: written as one loop over the slots with `acc[s % 4]`, it
        // was not unrolled and ran 50 % slower.)
        for (idx, w) in t.idx.chunks_exact(N4_ACC).zip(t.w.chunks_exact(N4_ACC)) {
            for a in 0..N4_ACC {
                let ij = _mm512_load_si512(idx[a].0.as_ptr().cast());
                let fi = _mm512_permutexvar_ps(ij, fv);
                let gj = _mm512_permutexvar_ps(_mm512_srli_epi32::<4>(ij), gv);
                let wf = _mm512_mul_ps(_mm512_load_ps(w[a].0.as_ptr()), fi);
                acc[a] = _mm512_fmadd_ps(wf, gj, acc[a]);
            }
        }
        let y = _mm512_add_ps(_mm512_add_ps(acc[0], acc[1]), _mm512_add_ps(acc[2], acc[3]));
        _mm512_storeu_ps(out.as_mut_ptr(), y);
    }
}

/// Most terms of one output among 0 … 7 at n = 3 (checked at build).
const N3_SLOTS: usize = 10;
/// Terms of output 8 at n = 3 (checked at build).
const N3_LAST: usize = 8;

/// Order 3 on 256-bit registers: outputs 0 … 7 as slots of eight lanes
/// (the inputs' nine values reach them through a two-source permute, `f₈`
/// broadcast as the second source), output 8 by its eight scalar terms.
/// Half the vector work of the 16-lane form, whose lanes 9 … 15 idle.
#[derive(Debug)]
struct SlotsN3 {
    idx: [Row8<i32>; N3_SLOTS],
    w: [Row8<f32>; N3_SLOTS],
    /// Output 8: its eight terms across the lanes of one more slot, summed
    /// across lanes at the end.
    last_idx: Row8<i32>,
    last_w: Row8<f32>,
}

impl SlotsN3 {
    fn new() -> Self {
        let terms = terms(3);
        let most = terms[..8].iter().map(Vec::len).max().unwrap_or(0);
        assert_eq!(most, N3_SLOTS, "slots of outputs 0 … 7 at order 3");
        assert_eq!(terms[8].len(), N3_LAST, "terms of output 8 at order 3");
        let mut s = Self {
            idx: [Row8::default(); N3_SLOTS],
            w: [Row8::default(); N3_SLOTS],
            last_idx: Row8::default(),
            last_w: Row8::default(),
        };
        for (k, ts) in terms[..8].iter().enumerate() {
            for (slot, &(i, j, w)) in ts.iter().enumerate() {
                s.idx[slot].0[k] = (i | j << 4) as i32;
                s.w[slot].0[k] = w as f32;
            }
        }
        for (lane, &(i, j, w)) in terms[8].iter().enumerate() {
            s.last_idx.0[lane] = (i | j << 4) as i32;
            s.last_w.0[lane] = w as f32;
        }
        s
    }

    fn get() -> &'static Self {
        static T: OnceLock<SlotsN3> = OnceLock::new();
        T.get_or_init(Self::new)
    }
}

/// `out = f ∗ g` truncated to order 3 ([`SlotsN3`]).
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512VL, AVX2 and FMA.
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[inline(never)]
pub(crate) unsafe fn product_n3(f: &[f32; 9], g: &[f32; 9], out: &mut [f32; 9]) {
    let t = SlotsN3::get();
    // SAFETY: the features are enabled; the loads read f[0..8], g[0..8],
    // f[8] and g[8], the store out[0..8]; the tables are 32-byte aligned.
    unsafe {
        let (f0, f1) = (_mm256_loadu_ps(f.as_ptr()), _mm256_set1_ps(f[8]));
        let (g0, g1) = (_mm256_loadu_ps(g.as_ptr()), _mm256_set1_ps(g[8]));
        let term = |idx: &Row8<i32>, w: &Row8<f32>| {
            let ij = _mm256_load_si256(idx.0.as_ptr().cast());
            let fi = _mm256_permutex2var_ps(f0, ij, f1);
            let gj = _mm256_permutex2var_ps(g0, _mm256_srli_epi32::<4>(ij), g1);
            (_mm256_mul_ps(_mm256_load_ps(w.0.as_ptr()), fi), gj)
        };
        let mut acc = [_mm256_setzero_ps(); 2];
        for s in 0..N3_SLOTS {
            let (wf, gj) = term(&t.idx[s], &t.w[s]);
            acc[s % 2] = _mm256_fmadd_ps(wf, gj, acc[s % 2]);
        }
        _mm256_storeu_ps(out.as_mut_ptr(), _mm256_add_ps(acc[0], acc[1]));
        // Output 8: the lanes' sum.
        let (wf, gj) = term(&t.last_idx, &t.last_w);
        let v = _mm256_mul_ps(wf, gj);
        let v = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
        let v = _mm_add_ps(v, _mm_movehl_ps(v, v));
        out[8] = _mm_cvtss_f32(_mm_add_ss(v, _mm_movehdup_ps(v)));
    }
}
