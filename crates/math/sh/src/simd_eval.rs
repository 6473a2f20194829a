//! Evaluation of all `n²` basis functions at one direction with the
//! coefficients across the lanes of AVX-512 registers (used for n = 5 … 8,
//! and at n = 4 as [`eval_n4`]: the same scheme in two 256-bit halves).
//!
//! Every real SH basis value factors as
//!
//! ```text
//! y_{l,m}(x, y, z) = Q_l^{|m|}(z) · A_m(x, y),
//! A_m = Re (x + iy)^m (m > 0),   Im (x + iy)^{|m|} (m < 0),   1 (m = 0),
//! ```
//!
//! with `Q_l^m` the polynomials of [`crate::basis::legendre_polynomials`] (the
//! same factorisation the generated scalar kernels of [`crate::kernels`]
//! unroll). `Q_l^m` has the parity of `l − m`, so `Q = z^p H(z²)` with
//! `p = (l − m) mod 2` and `deg H ≤ ⌊(n − 1)/2⌋`.
//!
//! The scalar kernel spends one multiply and one store per value plus a
//! Horner chain per `(l, m)` pair: about 120 instructions at n = 6, which
//! bound it. Here:
//!
//! 1. The powers `(x + iy)^k`, `k = 1 … 7`, are built as `(re, im)` lane
//!    pairs by three complex multiplies (`k = 2`; `k = 3, 4` in one; `k = 5 … 8`
//!    in one 256-bit multiply), giving the table
//!    `T₀ = [c₁ s₁ c₂ s₂ … c₇ s₇ 1 ·]` (`c_k + i s_k = (x + iy)^k`) and
//!    `T₁ = z T₀`.
//! 2. Each register of 16 output values is one two-table permute (lane `i`
//!    picks `A_{m_i} z^{p_i}` from `T₀ ∪ T₁`), a Horner evaluation of
//!    `H_i(z²)` with per-lane coefficient tables ([`EvalTables`]), one
//!    multiply and one store (masked for the last register).
//!
//! About 45 instructions at n = 6. Tested against the f64 recurrence at every
//! order 1 … 8 in `fast_tests` (`eval_kernels_match_recurrence`).

#![cfg(target_arch = "x86_64")]

use std::arch::x86_64::*;
use std::sync::OnceLock;

use crate::lane_tables::{F16, I16, Row8};

/// Smallest order [`crate::fast::eval_one`] sends here: below it the inlined
/// scalar kernels are cheaper than a call.
pub(crate) const EVAL_MIN_ORDER: usize = 5;
/// Largest order: `c₇, s₇` and the constant 1 fill the 16 lanes of `T₀`.
pub(crate) const EVAL_MAX_ORDER: usize = 8;
const LANES: usize = 16;
/// Registers of output at the largest order (64 values).
const REGS: usize = EVAL_MAX_ORDER * EVAL_MAX_ORDER / LANES;
/// Largest degree of `H` (in `z²`).
const HDEG: usize = (EVAL_MAX_ORDER - 1) / 2;
/// Lane of `T₀` holding the constant 1 (the `A` of `m = 0`).
const ONE: i32 = 14;

/// The per-lane tables. The lane of flat index `i = l² + l + m` is the same
/// at every order, so one table (built for [`EVAL_MAX_ORDER`]) serves all:
/// a smaller order reads fewer registers and fewer Horner terms, whose
/// coefficients are zero for its bands anyway.
#[derive(Debug)]
struct EvalTables {
    /// Index into `T₀ ∪ T₁` (`+ 16` selects `T₁ = z T₀`).
    pick: [I16; REGS],
    /// `h[r][j]` lane `i`: the coefficient of `(z²)^j` in `H_i`.
    h: [[F16; HDEG + 1]; REGS],
}

impl EvalTables {
    fn new() -> Self {
        let polys = crate::basis::legendre_polynomials(EVAL_MAX_ORDER);
        let mut t = Self {
            pick: [I16::default(); REGS],
            h: [[F16::default(); HDEG + 1]; REGS],
        };
        for l in 0..EVAL_MAX_ORDER {
            for m in -(l as isize)..=l as isize {
                let i = ((l * (l + 1)) as isize + m) as usize;
                let (r, lane) = (i / LANES, i % LANES);
                let am = m.unsigned_abs();
                let q = &polys[am][l - am];
                let p = (l - am) % 2;
                let a = match m {
                    0 => ONE,
                    m if m > 0 => 2 * (am as i32 - 1),
                    _ => 2 * (am as i32 - 1) + 1,
                };
                t.pick[r].0[lane] = a + if p == 1 { LANES as i32 } else { 0 };
                for (j, c) in q.iter().skip(p).step_by(2).enumerate() {
                    t.h[r][j].0[lane] = *c as f32;
                }
            }
        }
        t
    }

    fn get() -> &'static Self {
        static T: OnceLock<EvalTables> = OnceLock::new();
        T.get_or_init(Self::new)
    }
}

/// [`EvalTables`]' first register (the 16 values of order 4) as two 8-lane
/// halves for [`eval_n4`], whose power table is `[c₁ s₁ c₂ s₂ c₃ s₃ 1 1]`
/// (8 lanes: `T₀`'s lane [`ONE`] moves to lane 6) and `z` times it.
#[derive(Debug)]
struct EvalTables4 {
    /// Index into `T₀ ∪ T₁` (`+ 8` selects `T₁`).
    pick: [Row8<i32>; 2],
    /// `h0[r]`, `h1[r]`: the coefficients of `1` and `z²` in `H`.
    h0: [Row8<f32>; 2],
    h1: [Row8<f32>; 2],
}

impl EvalTables4 {
    fn new() -> Self {
        let t = EvalTables::get();
        let mut t4 = Self {
            pick: [Row8::default(); 2],
            h0: [Row8::default(); 2],
            h1: [Row8::default(); 2],
        };
        for i in 0..LANES {
            let (r, lane) = (i / 8, i % 8);
            let pick = t.pick[0].0[i];
            let a = pick % LANES as i32;
            let a = if a == ONE { 6 } else { a };
            debug_assert!(a <= 6, "order 4 needs powers up to 3 only");
            t4.pick[r].0[lane] = a + if pick >= LANES as i32 { 8 } else { 0 };
            t4.h0[r].0[lane] = t.h[0][0].0[i];
            t4.h1[r].0[lane] = t.h[0][1].0[i];
            debug_assert!(t.h[0][2..].iter().all(|h| h.0[i] == 0.0));
        }
        t4
    }

    fn get() -> &'static Self {
        static T: OnceLock<EvalTables4> = OnceLock::new();
        T.get_or_init(Self::new)
    }
}

/// `a ∘ b` for complex numbers stored as `(re, im)` lane pairs.
///
/// # Safety
/// FMA must be enabled in the caller.
#[inline(always)]
unsafe fn cmul(a: __m128, b: __m128) -> __m128 {
    // SAFETY: the caller's contract.
    unsafe {
        let swapped = _mm_permute_ps::<0b10_11_00_01>(a);
        _mm_fmaddsub_ps(
            a,
            _mm_moveldup_ps(b),
            _mm_mul_ps(swapped, _mm_movehdup_ps(b)),
        )
    }
}

/// [`cmul`] on four pairs.
///
/// # Safety
/// AVX and FMA must be enabled in the caller.
#[inline(always)]
unsafe fn cmul256(a: __m256, b: __m256) -> __m256 {
    // SAFETY: the caller's contract.
    unsafe {
        let swapped = _mm256_permute_ps::<0b10_11_00_01>(a);
        _mm256_fmaddsub_ps(
            a,
            _mm256_moveldup_ps(b),
            _mm256_mul_ps(swapped, _mm256_movehdup_ps(b)),
        )
    }
}

/// The 16 basis values of order 4 at the unit direction `dir` in two 256-bit
/// registers (the values of [`crate::kernels`]' `eval_n4` up to rounding),
/// for [`crate::fast::eval_inline`] and [`crate::fast::eval_array`]. The
/// scalar kernel issues ≈ 27 multiplies (the core has two multiply pipes);
/// here ten, and five shuffles: `x`, `y`, `z` are broadcast from memory
/// (loads, no shuffle), the powers `(x + iy)²` and `(x + iy)³` are two
/// complex multiplies, then per half one two-table permute of
/// `T₀ = [c₁ s₁ c₂ s₂ c₃ s₃ 1 1]` and `T₁ = z T₀`, one `H(z²)` multiply–add
/// with per-lane tables, one multiply and one store.
///
/// The direction comes by reference: each broadcast reads one f32, so a
/// caller that has just stored the three values separately still gets them
/// by store forwarding.
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512VL, AVX2 and FMA.
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[inline(never)]
pub(crate) unsafe fn eval_n4(dir: &[f32; 3], out: &mut [f32; 16]) {
    let tab = EvalTables4::get();
    // SAFETY: the features are enabled; the tables are 32-byte aligned; the
    // two stores write out[0..8] and out[8..16].
    unsafe {
        let bx = _mm_broadcast_ss(&dir[0]);
        let by = _mm_broadcast_ss(&dir[1]);
        let zb = _mm256_broadcast_ss(&dir[2]);
        let p = _mm_blend_ps::<0b1010>(bx, by); // c₁ s₁ c₁ s₁
        let p_swapped = _mm_blend_ps::<0b1010>(by, bx); // s₁ c₁ s₁ c₁
        // (x + iy) w = x w + i y w: fmaddsub(x, w, y · swap(w)).
        let sq = _mm_fmaddsub_ps(bx, p, _mm_mul_ps(by, p_swapped));
        let cube = _mm_fmaddsub_ps(bx, sq, _mm_mul_ps(by, _mm_permute_ps::<0b10_11_00_01>(sq)));
        let t0 = _mm256_set_m128(
            _mm_blend_ps::<0b1100>(cube, _mm_set1_ps(1.0)), // c₃ s₃ 1 1
            _mm_movelh_ps(p, sq),                           // c₁ s₁ c₂ s₂
        );
        let t1 = _mm256_mul_ps(t0, zb);
        let z2 = _mm256_mul_ps(zb, zb);
        let dst = out.as_mut_ptr();
        for r in 0..2 {
            let h = _mm256_fmadd_ps(
                _mm256_load_ps(tab.h1[r].0.as_ptr()),
                z2,
                _mm256_load_ps(tab.h0[r].0.as_ptr()),
            );
            let pick = _mm256_load_si256(tab.pick[r].0.as_ptr().cast());
            let a = _mm256_permutex2var_ps(t0, pick, t1);
            _mm256_storeu_ps(dst.add(8 * r), _mm256_mul_ps(h, a));
        }
    }
}

/// All `NN = N²` basis values at the unit direction `(x, y, z)` (`1 ≤ N ≤`
/// [`EVAL_MAX_ORDER`]), the values of [`crate::kernels`]' `eval_n{N}` up to
/// rounding.
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512VL, AVX2 and FMA.
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[inline(never)]
pub(crate) unsafe fn eval<const N: usize, const NN: usize>(
    x: f32,
    y: f32,
    z: f32,
    out: &mut [f32; NN],
) {
    const {
        assert!(NN == N * N && N >= 1 && N <= EVAL_MAX_ORDER);
    }
    let tab = EvalTables::get();
    let hdeg = (N - 1) / 2;
    // SAFETY: the features are enabled; the tables are 64-byte aligned; the
    // stores write lanes `16r .. min(16r + 16, NN)` of `out`.
    unsafe {
        let u = _mm_setr_ps(x, y, x, y); // (x + iy) twice
        let sq = cmul(u, u); // (x + iy)² twice
        let a = _mm_blend_ps::<0b1100>(u, sq); // c₁ s₁ c₂ s₂
        let b = cmul(a, sq); // c₃ s₃ c₄ s₄
        let lo = _mm256_set_m128(b, a);
        let hi = if N > 5 {
            let fourth = _mm_shuffle_ps::<0b11_10_11_10>(b, b);
            // c₅ s₅ c₆ s₆ c₇ s₇ (c₈ s₈ ← 1, ·)
            let hi = cmul256(lo, _mm256_set_m128(fourth, fourth));
            _mm256_blend_ps::<0b0100_0000>(hi, _mm256_set1_ps(1.0))
        } else {
            _mm256_set1_ps(1.0)
        };
        let t0 = _mm512_castpd_ps(_mm512_insertf64x4::<1>(
            _mm512_castpd256_pd512(_mm256_castps_pd(lo)),
            _mm256_castps_pd(hi),
        ));
        let zb = _mm512_set1_ps(z);
        let t1 = _mm512_mul_ps(t0, zb);
        let z2 = _mm512_mul_ps(zb, zb);
        let dst = out.as_mut_ptr();
        for r in 0..NN.div_ceil(LANES) {
            let h = &tab.h[r];
            let mut acc = _mm512_load_ps(h[hdeg].0.as_ptr());
            for j in (0..hdeg).rev() {
                acc = _mm512_fmadd_ps(acc, z2, _mm512_load_ps(h[j].0.as_ptr()));
            }
            let pick = _mm512_load_si512(tab.pick[r].0.as_ptr().cast());
            let v = _mm512_mul_ps(acc, _mm512_permutex2var_ps(t0, pick, t1));
            let p = dst.add(r * LANES);
            match NN - r * LANES {
                LANES.. => _mm512_storeu_ps(p, v),
                8 => _mm256_storeu_ps(p, _mm512_castps512_ps256(v)),
                4 => _mm_storeu_ps(p, _mm512_castps512_ps128(v)),
                1 => _mm_store_ss(p, _mm512_castps512_ps128(v)),
                left => _mm512_mask_storeu_ps(p, (1u16 << left) - 1, v),
            }
        }
    }
}
