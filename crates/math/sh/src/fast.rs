//! Fast f32 paths over the generated per-order kernels of `crate::kernels`:
//! single calls (what [`crate::eval_sh_into`], [`crate::rotation::ZyzRotation`]
//! and [`crate::product::TripleProduct`] run for f32 at low order), RGB
//! variants and **batch kernels** (eight directions or vectors per AVX2
//! register, lanes across items).
//!
//! # Which code runs
//! * Single calls: the generated straight-line code, compiled once in
//!   non-generic, non-inlined functions per operation, so a caller pays one
//!   call and downstream crates never re-instantiate the kernels (compile
//!   time). Evaluation, rotation and the product have two copies, plain
//!   multiply and add (`eval_one_portable`, `rotate_one_portable`,
//!   `product_one_portable`) and fused multiply–add for AVX2+FMA CPUs
//!   (`eval_one_fma`, `rotate_one_fma`, `product_one_fma`), chosen per call by
//!   a cached CPU-feature test (`eval_one`, `rotate_one`, `product_one`);
//!   `rotate_euler_one` (angles given) is plain only. Two exceptions:
//!   evaluation at n ≤ [`INLINE_EVAL_MAX_ORDER`] is inlined into the caller
//!   (`eval_inline`, plain multiply and add: no call; at n = 4 on a CPU with
//!   AVX-512 one call to `crate::simd_eval::eval_n4`, as the scalar
//!   kernel's ≈ 27 multiplies bound it there), and
//!   rotation has one non-inlined function per order and instruction set
//!   (no jump table, each order its own stack frame), and from order
//!   `AVX512_ROTATE_MIN_ORDER` (4) on a third copy for AVX-512 in which
//!   bands ≥ 3 (at order 4 bands 1–3) run with their coefficients across
//!   vector lanes (`crate::simd_bands`; the scalar copies are bound by
//!   their multiply count there). [`crate::eval_sh_array`] takes
//!   the order as an array length, so even the order dispatch goes.
//! * Rotation takes the 3×3 matrix: bands 1 and 2 come straight from it (a
//!   linear and a quadratic form, no Euler angles: order ≤ 3 needs no square
//!   root or division), bands ≥ 3 from its ZYZ angles (see
//!   [`crate::kernels_gen`]).
//! * RGB variants: one Euler decomposition (rotation), then the mono kernel per
//!   channel.
//! * Batches: on an x86-64 CPU with AVX2 and FMA (`crate::lanes::avx2_fma_available`),
//!   eight items per lane group in AVX registers (`crate::lanes::F8`), one
//!   loop per order (constant indices, values in registers): directions come
//!   in by a transposed load of 24 floats (`F8::load_xyz8`), rotation
//!   matrices and vectors by 8×8 transposes (`load_rows` / `store_rows`),
//!   evaluations go out as whole registers (coefficient-major). Elsewhere the
//!   single-call kernels one item at a time. The tail of a batch is padded by
//!   repeating its last item.
//!
//! Every kernel is tested against the portable recurrence / ZYZ / Gaunt code
//! (`src/fast_tests.rs`); under `CI` those tests fail on a CPU without
//! AVX2+FMA instead of comparing the portable path with itself.
//!
//! # Layouts
//! Directions are unit vectors `[x, y, z]` in the coefficients' frame. Batched
//! coefficient vectors of [`rotate_batch`] are item-major (item `i` occupies
//! `[i·n², (i+1)·n²)`); [`eval_batch`] writes coefficient-major
//! (`out[k·count + i]`), the layout lanes across directions store directly.

use crate::kernels;
use crate::lanes::V;
use crate::rotation::{EulerZyz, Rot3};
use crate::{MAX_ORDER, ShError, check_order};
use std::sync::OnceLock;

/// Largest order of the evaluation batch kernels (`eval_batch`,
/// `shade_batch`, `shade_rgb_batch`): kept low because each batch order is
/// one more eight-lane instantiation of a generated kernel (compile time).
pub const BATCH_MAX_ORDER: usize = 6;

/// Largest order of [`rotate_batch`]: every generated rotation kernel
/// ([`KERNEL_ROTATE_MAX_ORDER`]), as the per-pixel SH shading rotates order-6
/// transfer vectors eight pixels at a time.
pub const ROTATE_BATCH_MAX_ORDER: usize = KERNEL_ROTATE_MAX_ORDER;

pub use crate::kernels_gen::{
    KERNEL_EVAL_MAX_ORDER, KERNEL_PRODUCT_MAX_ORDER, KERNEL_ROTATE_MAX_ORDER,
};

type S = V<1, false>;

#[inline(always)]
fn as_v<const W: usize>(s: &[f32]) -> &[V<W, false>] {
    // SAFETY: V<1, F> is repr(C) around [f32; 1] (same size and alignment as f32
    // once the 32-byte alignment is not requested; see lanes.rs).
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast(), s.len() / W) }
}

#[inline(always)]
fn as_v_mut<const W: usize>(s: &mut [f32]) -> &mut [V<W, false>] {
    // SAFETY: as `as_v`.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast(), s.len() / W) }
}

/// One evaluation function per order and instruction set, each its own
/// non-inlined, non-generic function on a fixed-size output: a call runs one
/// order's straight-line code (no jump table, no length checks inside).
macro_rules! eval_per_order {
    ($($n:literal $nn:literal $kernel:ident $portable:ident $fma:ident;)*) => {$(
        /// [`eval_one`] at order
        #[doc = stringify!($n)]
        /// with plain multiply and add.
        #[inline(never)]
        fn $portable(x: f32, y: f32, z: f32, out: &mut [f32; $nn]) {
            // SAFETY: `S` is repr(transparent) around one f32 (see `as_v`).
            let o = unsafe { &mut *out.as_mut_ptr().cast::<[S; $nn]>() };
            kernels::$kernel(S::splat(x), S::splat(y), S::splat(z), o);
        }

        /// [`eval_one`] at order
        #[doc = stringify!($n)]
        /// with fused multiply–add.
        ///
        /// # Safety
        /// The CPU must support AVX2 and FMA.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        #[inline(never)]
        unsafe fn $fma(x: f32, y: f32, z: f32, out: &mut [f32; $nn]) {
            // SAFETY: `S1` is repr(transparent) around one f32 (see `as_v`).
            let o = unsafe { &mut *out.as_mut_ptr().cast::<[S1; $nn]>() };
            kernels::$kernel(S1::splat(x), S1::splat(y), S1::splat(z), o);
        }
    )*

    /// Generated f32 evaluation of all `order²` basis values at the unit
    /// direction `(x, y, z)`; `false` (nothing written) above
    /// [`KERNEL_EVAL_MAX_ORDER`].
    ///
    /// Orders up to [`INLINE_EVAL_MAX_ORDER`] are inlined ([`eval_inline`]);
    /// larger ones call the vector kernel of [`crate::simd_eval`] on a CPU
    /// with AVX-512, else the order's own AVX2+FMA function on a CPU with
    /// AVX2 and FMA ([`crate::lanes::avx2_fma_available`], a cached flag
    /// test per call), else its portable one ([`eval_path`] names the
    /// choice). The direction comes as three scalars, in registers: a `[f32; 3]` argument is passed through memory
    /// and the kernel's combined loads of it missed store forwarding (12 ns
    /// instead of 4 ns at n = 3).
    ///
    /// # Panics
    /// If `out` is shorter than `order²`.
    #[inline(always)]
    pub(crate) fn eval_one(order: usize, x: f32, y: f32, z: f32, out: &mut [f32]) -> bool {
        if order <= INLINE_EVAL_MAX_ORDER {
            return eval_inline(order, x, y, z, out);
        }
        match order {
            $($n => {
                let out = head_mut::<$nn>(out);
                #[cfg(target_arch = "x86_64")]
                if $n >= crate::simd_eval::EVAL_MIN_ORDER && crate::simd::available() {
                    // SAFETY: AVX-512 (F, VL), AVX2 and FMA were detected.
                    unsafe { crate::simd_eval::eval::<$n, $nn>(x, y, z, out) };
                    return true;
                }
                #[cfg(target_arch = "x86_64")]
                if crate::lanes::avx2_fma_available() {
                    // SAFETY: AVX2 and FMA were detected.
                    unsafe { $fma(x, y, z, out) };
                    return true;
                }
                $portable(x, y, z, out);
            })*
            _ => return false,
        }
        true
    }
    };
}

eval_per_order! {
    1 1 eval_n1 eval_n1_portable eval_n1_fma;
    2 4 eval_n2 eval_n2_portable eval_n2_fma;
    3 9 eval_n3 eval_n3_portable eval_n3_fma;
    4 16 eval_n4 eval_n4_portable eval_n4_fma;
    5 25 eval_n5 eval_n5_portable eval_n5_fma;
    6 36 eval_n6 eval_n6_portable eval_n6_fma;
    7 49 eval_n7 eval_n7_portable eval_n7_fma;
    8 64 eval_n8 eval_n8_portable eval_n8_fma;
}

/// Which code [`eval_one`] runs at `order` on this CPU (for reports).
pub(crate) fn eval_path(order: usize) -> &'static str {
    #[cfg(target_arch = "x86_64")]
    if (order == 4 || (crate::simd_eval::EVAL_MIN_ORDER..=KERNEL_EVAL_MAX_ORDER).contains(&order))
        && crate::simd::available()
    {
        return "AVX-512 lanes";
    }
    if order <= INLINE_EVAL_MAX_ORDER {
        "generated, inlined"
    } else if order > KERNEL_EVAL_MAX_ORDER {
        "recurrence"
    } else if crate::lanes::avx2_fma_available() {
        "generated, AVX2+FMA"
    } else {
        "generated"
    }
}

/// Largest order whose evaluation `eval_one` inlines into its caller: plain
/// multiply and add, no CPU-feature test, no call, no order dispatch once the
/// caller's order is known. At n ≤ 4 (at most 16 values, ≈ 20 multiplies)
/// the test, the call and the jump table of the FMA copy cost more than FMA
/// saves; the code is small enough to copy into every caller. The one
/// exception is n = 4 on a CPU with AVX-512: there a flag test and a call to
/// the two-register kernel `crate::simd_eval::eval_n4` beat the inlined
/// multiplies (`relight bench sh`, rows `eval 4` and `eval_array 4`).
pub const INLINE_EVAL_MAX_ORDER: usize = 4;

/// [`eval_one`] for `order ≤` [`INLINE_EVAL_MAX_ORDER`], inlined: the
/// generated kernels with plain multiply and add; `false` (nothing written)
/// for larger orders. Each order checks its own output length (one compare),
/// so the caller needs no general length check on this path.
///
/// # Panics
/// If `out` is shorter than `order²`.
#[inline(always)]
pub(crate) fn eval_inline(order: usize, x: f32, y: f32, z: f32, out: &mut [f32]) -> bool {
    #[inline(always)]
    fn arr<const K: usize>(out: &mut [f32]) -> &mut [f32; K] {
        let len = out.len();
        match out.get_mut(..K) {
            Some(o) => o.try_into().expect("length K"),
            None => panic!("eval_sh_into: output has {len} values, the order needs {K}"),
        }
    }
    if order > INLINE_EVAL_MAX_ORDER {
        return false;
    }
    match order {
        1 => eval_array(x, y, z, arr::<1>(out)),
        2 => eval_array(x, y, z, arr::<4>(out)),
        3 => eval_array(x, y, z, arr::<9>(out)),
        4 => eval_array(x, y, z, arr::<16>(out)),
        _ => return false,
    }
    true
}

/// [`eval_inline`] with the direction by reference, as
/// [`crate::eval_sh_into`] has it: at n = 4 on a CPU with AVX-512 the
/// vector kernel [`crate::simd_eval::eval_n4`] reads it from memory (one
/// broadcast load per component) ahead of the order dispatch.
#[inline(always)]
pub(crate) fn eval_inline_dir(order: usize, dir: [f32; 3], out: &mut [f32]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if order == 4
        && crate::simd::available()
        && let Some(o) = out.get_mut(..16)
    {
        // SAFETY: AVX-512 (F, VL), AVX2 and FMA were detected.
        unsafe { crate::simd_eval::eval_n4(&dir, o.try_into().expect("16 values")) };
        return true;
    }
    eval_inline(order, dir[0], dir[1], dir[2], out)
}

/// All `NN = n²` basis values at `(x, y, z)` into a fixed-size array, the
/// order known at compile time: `n ≤` [`INLINE_EVAL_MAX_ORDER`] inlined
/// (plain multiply and add; n = 4 calls [`crate::simd_eval::eval_n4`] on a
/// CPU with AVX-512), larger `n ≤` [`KERNEL_EVAL_MAX_ORDER`] through
/// the out-of-line FMA dispatch of [`eval_one`]. `NN` must be one of
/// 1, 4, 9, …, 64 (a compile-time error otherwise).
#[inline(always)]
pub(crate) fn eval_array<const NN: usize>(x: f32, y: f32, z: f32, out: &mut [f32; NN]) {
    const {
        assert!(
            matches!(NN, 1 | 4 | 9 | 16 | 25 | 36 | 49 | 64),
            "eval_sh_array: NN must be n² for an order n = 1..=8"
        );
    }
    #[inline(always)]
    fn v<const K: usize>(out: &mut [f32]) -> &mut [S; K] {
        debug_assert!(out.len() == K);
        // SAFETY: `S` = V<1, false> is repr(C) around one f32 (see `as_v`) and
        // `out` holds exactly K values (the caller's array of that length).
        unsafe { &mut *out.as_mut_ptr().cast::<[S; K]>() }
    }
    let (xs, ys, zs) = (S::splat(x), S::splat(y), S::splat(z));
    match NN {
        1 => kernels::eval_n1(xs, ys, zs, v::<1>(out)),
        4 => kernels::eval_n2(xs, ys, zs, v::<4>(out)),
        #[cfg(target_arch = "x86_64")]
        9 => eval_n3_sse(x, y, z, v::<9>(out)),
        #[cfg(not(target_arch = "x86_64"))]
        9 => kernels::eval_n3(xs, ys, zs, v::<9>(out)),
        16 => {
            #[cfg(target_arch = "x86_64")]
            if crate::simd::available() {
                // SAFETY: AVX-512 (F, VL), AVX2 and FMA were detected; `out`
                // holds 16 values.
                unsafe { crate::simd_eval::eval_n4(&[x, y, z], &mut *out.as_mut_ptr().cast()) };
                return;
            }
            kernels::eval_n4(xs, ys, zs, v::<16>(out));
        }
        _ => {
            let n = if NN == 25 {
                5
            } else if NN == 36 {
                6
            } else if NN == 49 {
                7
            } else {
                8
            };
            eval_one(n, x, y, z, out);
        }
    }
}

/// Order 3 ([`kernels::eval_n3`]'s values) on the baseline SSE registers:
/// two 4-lane products and one scalar, written with three stores instead of
/// nine (the single-direction evaluation at this order is bound by its
/// stores and moves, not its eleven multiplies).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn eval_n3_sse(x: f32, y: f32, z: f32, o: &mut [S; 9]) {
    use std::arch::x86_64::*;
    // SAFETY: SSE and SSE2 are part of the x86-64 baseline; the stores write
    // o[0..4], o[4..8] and o[8] of a 9-value array.
    unsafe {
        let xy = _mm_unpacklo_ps(_mm_set_ss(x), _mm_set_ss(y)); // [x, y, 0, 0]
        let zx = _mm_unpacklo_ps(_mm_set_ss(z), _mm_set_ss(x)); // [z, x, 0, 0]
        let p = _mm_movelh_ps(xy, zx); // [x, y, z, x]
        // [y_00, y_1−1, y_10, y_11] = [·, y, z, x] ∘ k0 + [c00, 0, 0, 0]
        // (lane 0 is x · 0).
        let k0 = _mm_set_ps(-0.488_602_52, 0.488_602_52, -0.488_602_52, 0.0);
        let lo = _mm_add_ps(_mm_mul_ps(p, k0), _mm_set_ps(0.0, 0.0, 0.0, 0.282_094_8));
        // [y_2−2, y_2−1, y_20, y_21] = [x, y, z, x] ∘ [y, z, z, z] ∘ k1 + [0, 0, c, 0].
        let q = _mm_shuffle_ps::<0b10_10_10_01>(p, p); // [y, z, z, z]
        let k1 = _mm_set_ps(-1.092_548_5, 0.946_174_7, -1.092_548_5, 1.092_548_5);
        let hi = _mm_add_ps(
            _mm_mul_ps(_mm_mul_ps(p, q), k1),
            _mm_set_ps(0.0, -0.315_391_57, 0.0, 0.0),
        );
        let ptr = o.as_mut_ptr().cast::<f32>();
        _mm_storeu_ps(ptr, lo);
        _mm_storeu_ps(ptr.add(4), hi);
        *ptr.add(8) = 0.546_274_24 * ((x - y) * (x + y));
    }
}

/// [`eval_one`] with plain multiply and add (the portable path).
///
/// Not inlined (nor generic): the per-order kernels are compiled once, here,
/// and every caller pays one call (compile time; see the module docs).
///
/// # Panics
/// If `out` is shorter than `order²`.
#[inline(never)]
pub(crate) fn eval_one_portable(order: usize, x: f32, y: f32, z: f32, out: &mut [f32]) -> bool {
    kernels::eval::<V<1, false>>(order, S::splat(x), S::splat(y), S::splat(z), as_v_mut(out))
}

/// One f32 with fused multiply–add: only used inside
/// `#[target_feature(enable = "avx2,fma")]` functions.
#[cfg(target_arch = "x86_64")]
type S1 = V<1, true>;

#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn as_s1_mut(s: &mut [f32]) -> &mut [S1] {
    // SAFETY: as `as_v`.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast(), s.len()) }
}

/// [`eval_one`] with fused multiply–add: the same generated kernel, one copy
/// per order compiled for AVX2 + FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
///
/// # Panics
/// If `out` is shorter than `order²`.
#[cfg(all(test, target_arch = "x86_64"))]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
pub(crate) unsafe fn eval_one_fma(order: usize, x: f32, y: f32, z: f32, out: &mut [f32]) -> bool {
    kernels::eval::<V<1, true>>(
        order,
        S1::splat(x),
        S1::splat(y),
        S1::splat(z),
        as_s1_mut(out),
    )
}

// No `array::map` below: it was not inlined into the kernels' callers
// (three out-of-line `try_map` calls per rotation, copying through the stack).
#[inline(always)]
fn euler_array<const F: bool>(e: &EulerZyz<f32>) -> [V<1, F>; 6] {
    let s = V::splat;
    [
        s(e.cos_alpha),
        s(e.sin_alpha),
        s(e.cos_beta),
        s(e.sin_beta),
        s(e.cos_gamma),
        s(e.sin_gamma),
    ]
}

#[inline(always)]
fn matrix_array<const F: bool>(m: &[[f32; 3]; 3]) -> [[V<1, F>; 3]; 3] {
    let s = V::splat;
    [
        [s(m[0][0]), s(m[0][1]), s(m[0][2])],
        [s(m[1][0]), s(m[1][1]), s(m[1][2])],
        [s(m[2][0]), s(m[2][1]), s(m[2][2])],
    ]
}

/// The generated kernel of order `N` (`NN = N²`) on one vector, from the
/// matrix: the ZYZ angles ([`crate::rotation::euler_zyz_direct`]) are only
/// computed from order 4 on (bands 1 and 2 come straight from the matrix).
/// The order is a constant here, so the dispatch and length checks of
/// [`kernels::rotate`] fold away.
#[inline(always)]
fn rotate_fixed<const F: bool, const N: usize, const NN: usize>(
    m: &[[f32; 3]; 3],
    src: &[f32; NN],
    dst: &mut [f32; NN],
) {
    const { assert!(NN == N * N) };
    let e = if N >= 4 {
        euler_array::<F>(&crate::rotation::euler_zyz_direct(&Rot3 { m: *m }))
    } else {
        [V::splat(0.0); 6]
    };
    kernels::rotate::<V<1, F>>(N, &matrix_array::<F>(m), &e, as_v1(src), as_v1_mut(dst));
}

/// [`rotate_fixed`] for the AVX-512 copies from order 4: the bands from
/// [`crate::simd_bands::first`] on in vector registers
/// ([`crate::simd_bands`], `K` non-zeros per row of `X±`): bands 1–3 at
/// order 4, bands 3 and up above it, where bands 0–2 run the same scalar
/// code as the other copies (straight from the matrix).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[inline]
fn rotate_fixed_avx512<const N: usize, const NN: usize, const K: usize>(
    m: &[[f32; 3]; 3],
    src: &[f32; NN],
    dst: &mut [f32; NN],
) {
    let Some(e) = crate::rotation::euler_zyz_off_pole(&Rot3 { m: *m }) else {
        // Near the poles: the scalar kernel with the general decomposition.
        rotate_fixed::<true, N, NN>(m, src, dst);
        return;
    };
    if crate::simd_bands::first(N) == 1 {
        dst[0] = src[0];
    } else {
        let head = [V::splat(0.0); 6];
        kernels::rotate::<V<1, true>>(
            3,
            &matrix_array::<true>(m),
            &head,
            as_v1(&src[..9]),
            as_v1_mut(&mut dst[..9]),
        );
    }
    let angles = [
        e.cos_alpha,
        e.sin_alpha,
        e.cos_beta,
        e.sin_beta,
        e.cos_gamma,
        e.sin_gamma,
    ];
    let t = crate::simd_bands::BandTables::get(N);
    crate::simd_bands::rotate_bands::<N, K>(t, angles, src, dst);
}

#[inline(always)]
fn as_v1<const F: bool>(s: &[f32]) -> &[V<1, F>] {
    // SAFETY: as `as_v`.
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast(), s.len()) }
}

#[inline(always)]
fn as_v1_mut<const F: bool>(s: &mut [f32]) -> &mut [V<1, F>] {
    // SAFETY: as `as_v`.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast(), s.len()) }
}

/// The first `K` values of `s` as an array.
///
/// # Panics
/// If `s` is shorter than `K`.
#[inline(always)]
fn head<const K: usize>(s: &[f32]) -> &[f32; K] {
    s[..K].try_into().expect("length K")
}

/// [`head`] for a mutable slice.
#[inline(always)]
fn head_mut<const K: usize>(s: &mut [f32]) -> &mut [f32; K] {
    (&mut s[..K]).try_into().expect("length K")
}

/// One rotation function per order and instruction set, each its own
/// non-inlined, non-generic function: a call runs exactly one order's
/// straight-line code with its own register allocation and stack frame. (One
/// function holding all orders behind a jump table shared one frame sized for
/// order 6, and order 4 spilled its values through it: 24–32 ns against
/// 10–13 ns at order 3.)
macro_rules! rotate_per_order {
    ($($n:literal $nn:literal $k:literal $portable:ident $fma:ident $avx512:ident;)*) => {$(
        /// [`rotate_one`] at order
        #[doc = stringify!($n)]
        /// with plain multiply and add.
        #[inline(never)]
        fn $portable(m: &[[f32; 3]; 3], src: &[f32; $nn], dst: &mut [f32; $nn]) {
            rotate_fixed::<false, $n, $nn>(m, src, dst);
        }

        /// [`rotate_one`] at order
        #[doc = stringify!($n)]
        /// with fused multiply–add.
        ///
        /// # Safety
        /// The CPU must support AVX2 and FMA.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        #[inline(never)]
        unsafe fn $fma(m: &[[f32; 3]; 3], src: &[f32; $nn], dst: &mut [f32; $nn]) {
            rotate_fixed::<true, $n, $nn>(m, src, dst);
        }

        /// [`rotate_one`] at order
        #[doc = stringify!($n)]
        /// compiled for AVX-512F (see [`AVX512_ROTATE_MIN_ORDER`]).
        ///
        /// # Safety
        /// The CPU must support AVX-512F, AVX-512VL, AVX2 and FMA.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
        #[inline(never)]
        unsafe fn $avx512(m: &[[f32; 3]; 3], src: &[f32; $nn], dst: &mut [f32; $nn]) {
            if $n >= crate::simd_bands::BANDS_MIN_ORDER {
                rotate_fixed_avx512::<$n, $nn, $k>(m, src, dst);
            } else {
                rotate_fixed::<true, $n, $nn>(m, src, dst);
            }
        }
    )*

    /// Generated exact rotation of one f32 vector by the rotation matrix `m`
    /// (`m[i][j] = R_ij`); `false` above [`KERNEL_ROTATE_MAX_ORDER`]. Runs
    /// the order's AVX-512 copy from [`AVX512_ROTATE_MIN_ORDER`] on where the
    /// CPU has AVX-512F, its AVX2+FMA copy on a CPU with AVX2 and FMA, else
    /// its portable copy; one call, no jump table.
    ///
    /// The matrix is passed by reference and read inside the kernel: the ZYZ
    /// angles are computed there, in registers (passing freshly computed
    /// angles through memory made the kernel's combined loads of them miss
    /// store forwarding).
    ///
    /// # Panics
    /// If a slice is shorter than `order²`.
    #[inline]
    pub(crate) fn rotate_one(order: usize, m: &[[f32; 3]; 3], src: &[f32], dst: &mut [f32]) -> bool {
        if order == 2 {
            // Band 1 is the matrix itself (nine multiplies and adds, plain):
            // inlined into the caller, no CPU test, no call.
            rotate_fixed::<false, 2, 4>(m, head(src), head_mut(dst));
            return true;
        }
        match order {
            $($n => {
                let (src, dst) = (head::<$nn>(src), head_mut::<$nn>(dst));
                #[cfg(target_arch = "x86_64")]
                if $n >= AVX512_ROTATE_MIN_ORDER && crate::simd::available() {
                    // SAFETY: AVX-512F (with VL, AVX2 and FMA) was detected.
                    unsafe { $avx512(m, src, dst) };
                    return true;
                }
                #[cfg(target_arch = "x86_64")]
                if crate::lanes::avx2_fma_available() {
                    // SAFETY: AVX2 and FMA were detected.
                    unsafe { $fma(m, src, dst) };
                    return true;
                }
                $portable(m, src, dst);
            })*
            _ => return false,
        }
        true
    }

    /// [`rotate_one`] with plain multiply and add (the portable path).
    ///
    /// # Panics
    /// If a slice is shorter than `order²`.
    pub(crate) fn rotate_one_portable(
        order: usize,
        m: &[[f32; 3]; 3],
        src: &[f32],
        dst: &mut [f32],
    ) -> bool {
        match order {
            $($n => $portable(m, head::<$nn>(src), head_mut::<$nn>(dst)),)*
            _ => return false,
        }
        true
    }

    /// [`rotate_one`] with fused multiply–add.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    ///
    /// # Panics
    /// If a slice is shorter than `order²`.
    #[cfg(all(test, target_arch = "x86_64"))]
    pub(crate) unsafe fn rotate_one_fma(
        order: usize,
        m: &[[f32; 3]; 3],
        src: &[f32],
        dst: &mut [f32],
    ) -> bool {
        match order {
            // SAFETY: the caller's contract.
            $($n => unsafe { $fma(m, head::<$nn>(src), head_mut::<$nn>(dst)) },)*
            _ => return false,
        }
        true
    }

    /// [`rotate_one`] compiled for AVX-512F at every order (the tests run
    /// each copy; [`rotate_one`] takes it from [`AVX512_ROTATE_MIN_ORDER`] on).
    ///
    /// # Safety
    /// The CPU must support AVX-512F, AVX-512VL, AVX2 and FMA.
    ///
    /// # Panics
    /// If a slice is shorter than `order²`.
    #[cfg(all(test, target_arch = "x86_64"))]
    pub(crate) unsafe fn rotate_one_avx512(
        order: usize,
        m: &[[f32; 3]; 3],
        src: &[f32],
        dst: &mut [f32],
    ) -> bool {
        match order {
            // SAFETY: the caller's contract.
            $($n => unsafe { $avx512(m, head::<$nn>(src), head_mut::<$nn>(dst)) },)*
            _ => return false,
        }
        true
    }
    };
}

rotate_per_order! {
    1 1 0 rotate_n1_portable rotate_n1_fma rotate_n1_avx512;
    2 4 0 rotate_n2_portable rotate_n2_fma rotate_n2_avx512;
    3 9 0 rotate_n3_portable rotate_n3_fma rotate_n3_avx512;
    4 16 2 rotate_n4_portable rotate_n4_fma rotate_n4_avx512;
    5 25 3 rotate_n5_portable rotate_n5_fma rotate_n5_avx512;
    6 36 3 rotate_n6_portable rotate_n6_fma rotate_n6_avx512;
}

/// Smallest order at which [`rotate_one`] takes the AVX-512 copy: bands ≥ 3
/// in vector registers, and bands 1–2 with them at order 4
/// ([`crate::simd_bands`]). Figures: `relight bench sh`, row `zyz`, and
/// docs/performance.md.
pub(crate) const AVX512_ROTATE_MIN_ORDER: usize = 4;

/// Generated rotation of one f32 vector given its ZYZ angles (the matrix is
/// rebuilt from them, [`Rot3::from_euler_zyz`]); `false` above
/// [`KERNEL_ROTATE_MAX_ORDER`]. Plain multiply and add.
///
/// # Panics
/// If a slice is shorter than `order²`.
#[inline(never)]
pub(crate) fn rotate_euler_one(
    order: usize,
    e: &EulerZyz<f32>,
    src: &[f32],
    dst: &mut [f32],
) -> bool {
    let m = matrix_array::<false>(&Rot3::from_euler_zyz(e).m);
    kernels::rotate::<V<1, false>>(order, &m, &euler_array(e), as_v(src), as_v_mut(dst))
}

/// The three channels of [`rotate_rgb`]: one decomposition, then the kernel
/// per channel (one copy of it, in a loop).
#[inline(always)]
fn rotate_rgb_mat<const F: bool>(
    order: usize,
    rot: &Rot3<f32>,
    src: [&[f32]; 3],
    dst: [&mut [f32]; 3],
) {
    let e = if order >= 4 {
        euler_array::<F>(&crate::rotation::euler_zyz_direct(rot))
    } else {
        [V::splat(0.0); 6]
    };
    let m = matrix_array::<F>(&rot.m);
    for (src, dst) in src.into_iter().zip(dst) {
        kernels::rotate::<V<1, F>>(order, &m, &e, as_v1(src), as_v1_mut(dst));
    }
}

#[inline(never)]
fn rotate_rgb_portable(order: usize, rot: &Rot3<f32>, src: [&[f32]; 3], dst: [&mut [f32]; 3]) {
    rotate_rgb_mat::<false>(order, rot, src, dst);
}

/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn rotate_rgb_fma(order: usize, rot: &Rot3<f32>, src: [&[f32]; 3], dst: [&mut [f32]; 3]) {
    rotate_rgb_mat::<true>(order, rot, src, dst);
}

/// Truncated product of two f32 vectors; `false` above [`KERNEL_PRODUCT_MAX_ORDER`].
/// On a CPU with AVX-512: the lane-slot kernels of [`crate::simd_product`]
/// at n = 3, 4, else [`product_one_avx512`]; with AVX2 and FMA
/// [`product_one_fma`]; else [`product_one_portable`] ([`product_path`]
/// names the choice).
///
/// # Panics
/// If a slice is shorter than `order²`.
#[inline]
pub(crate) fn product_one(order: usize, f: &[f32], g: &[f32], out: &mut [f32]) -> bool {
    if order == 2 {
        product_n2_inline(head(f), head(g), head_mut(out));
        return true;
    }
    #[cfg(target_arch = "x86_64")]
    if crate::simd::available() {
        use crate::simd_product::{product_n3, product_n4};
        // SAFETY (all three): AVX-512F (with VL, AVX2 and FMA) was detected.
        match order {
            3 => unsafe { product_n3(head(f), head(g), head_mut(out)) },
            4 => unsafe { product_n4(head(f), head(g), head_mut(out)) },
            _ => return unsafe { product_one_avx512(order, f, g, out) },
        }
        return true;
    }
    #[cfg(target_arch = "x86_64")]
    if crate::lanes::avx2_fma_available() {
        // SAFETY: AVX2 and FMA were detected.
        return unsafe { product_one_fma(order, f, g, out) };
    }
    product_one_portable(order, f, g, out)
}

/// The order-2 truncated product, inlined into [`product_one`]'s caller (no
/// CPU test, no call): with `Y₀₀ = 1/(2√π)` the only Gaunt terms are
/// `∫ y₀ y_i y_i = Y₀₀` (band 1 times band 1 has no band-1 part, by parity),
/// so `o₀ = Y₀₀ f·g` and `o_k = Y₀₀ (f₀ g_k + g₀ f_k)`, eleven multiplies and
/// adds with the sum in registers. (The generated kernel, shared with the
/// larger orders, accumulates `o₀` through memory: a chain of four
/// store-to-load forwards, 4.6 ns against DirectXMath's 3.6.)
#[inline(always)]
fn product_n2_inline(f: &[f32; 4], g: &[f32; 4], o: &mut [f32; 4]) {
    const Y00: f32 = 0.282_094_8;
    let (cf, cg) = (Y00 * f[0], Y00 * g[0]);
    o[0] = Y00 * ((f[0] * g[0] + f[1] * g[1]) + (f[2] * g[2] + f[3] * g[3]));
    for k in 1..4 {
        o[k] = cf * g[k] + cg * f[k];
    }
}

/// Which code [`product_one`] runs at `order` on this CPU (for reports).
pub(crate) fn product_path(order: usize) -> &'static str {
    let avx512 = crate::simd::available();
    if order == 2 {
        "inlined straight-line code, sums in registers"
    } else if avx512 && (order == 3 || order == 4) {
        "AVX-512 lane slots (Gaunt terms across output lanes)"
    } else if avx512 || crate::lanes::avx2_fma_available() {
        "generated straight-line kernel (Gaunt triples grouped by pair), FMA"
    } else {
        "generated straight-line kernel (Gaunt triples grouped by pair)"
    }
}

/// [`product_one`] with plain multiply and add (the portable path).
///
/// # Panics
/// If a slice is shorter than `order²`.
#[inline(never)]
pub(crate) fn product_one_portable(order: usize, f: &[f32], g: &[f32], out: &mut [f32]) -> bool {
    kernels::product_plain(order, as_v(f), as_v(g), as_v_mut(out))
}

#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn as_s1(s: &[f32]) -> &[S1] {
    // SAFETY: as `as_v`.
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast(), s.len()) }
}

/// [`product_one`] with fused multiply–add: inlined into the caller, which
/// then makes one call, straight into the order's (first) chunk.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
///
/// # Panics
/// If a slice is shorter than `order²`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn product_one_fma(order: usize, f: &[f32], g: &[f32], out: &mut [f32]) -> bool {
    // SAFETY: the caller's contract.
    unsafe { kernels::product_fma(order, as_s1(f), as_s1(g), as_s1_mut(out)) }
}

/// [`product_one`] with the copies compiled for AVX-512F: the FMA kernels
/// with 32 vector registers, so the one-chunk kernels (n ≤ 4) keep their
/// accumulators in registers. Inlined as [`product_one_fma`].
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512VL, AVX2 and FMA.
///
/// # Panics
/// If a slice is shorter than `order²`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn product_one_avx512(
    order: usize,
    f: &[f32],
    g: &[f32],
    out: &mut [f32],
) -> bool {
    // SAFETY: the caller's contract.
    unsafe { kernels::product_avx512(order, as_s1(f), as_s1(g), as_s1_mut(out)) }
}

fn check_len(what: &'static str, order: usize, got: usize, want: usize) -> Result<(), ShError> {
    if got == want {
        Ok(())
    } else {
        Err(ShError::LengthMismatch {
            what,
            order,
            expected: want,
            got,
        })
    }
}

/// Rotates three coefficient vectors (R, G, B) by one rotation `rot` with the
/// generated ZYZ kernel: one Euler decomposition, the mono kernel per channel. Orders `1 ..=` [`KERNEL_ROTATE_MAX_ORDER`].
///
/// # Errors
/// [`ShError::OrderOutOfRange`] or [`ShError::LengthMismatch`] (every slice must
/// hold `order²` values).
pub fn rotate_rgb(
    order: usize,
    rot: &Rot3<f32>,
    src: [&[f32]; 3],
    dst: [&mut [f32]; 3],
) -> Result<(), ShError> {
    check_order("order (fast::rotate_rgb)", order, KERNEL_ROTATE_MAX_ORDER)?;
    let nn = order * order;
    for c in src {
        check_len("src channel", order, c.len(), nn)?;
    }
    for c in &dst {
        check_len("dst channel", order, c.len(), nn)?;
    }
    // One decomposition; the channels run the same kernel one after another.
    #[cfg(target_arch = "x86_64")]
    if crate::lanes::avx2_fma_available() {
        // SAFETY: AVX2 and FMA were detected.
        unsafe { rotate_rgb_fma(order, rot, src, dst) };
        return Ok(());
    }
    rotate_rgb_portable(order, rot, src, dst);
    Ok(())
}

/// Channel-wise truncated product of two RGB coefficient triples,
/// `out_c = f_c ∗ g_c` for c = R, G, B, with the mono product per channel:
/// the generated kernel below `crate::product_high::HIGH_MIN_ORDER`, the
/// pseudo-spectral one from there (tables built once per order). Orders
/// `1 ..=` [`KERNEL_PRODUCT_MAX_ORDER`].
///
/// # Errors
/// [`ShError::OrderOutOfRange`] or [`ShError::LengthMismatch`].
pub fn product_rgb(
    order: usize,
    f: [&[f32]; 3],
    g: [&[f32]; 3],
    out: [&mut [f32]; 3],
) -> Result<(), ShError> {
    check_order("order (fast::product_rgb)", order, KERNEL_PRODUCT_MAX_ORDER)?;
    let nn = order * order;
    for c in f.iter().chain(&g) {
        check_len("input channel", order, c.len(), nn)?;
    }
    for c in &out {
        check_len("output channel", order, c.len(), nn)?;
    }
    let high = crate::product_high::HighProduct::cached(order);
    for ((f, g), out) in f.into_iter().zip(g).zip(out) {
        match high {
            Some(h) => h.product(f, g, out),
            None => {
                product_one(order, f, g, out);
            }
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// Batches
// ---------------------------------------------------------------------------

/// Which batch code ran.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BatchPath {
    /// AVX2 + FMA, eight items per group.
    Avx2Fma,
    /// Portable, one item at a time, no FMA.
    Portable,
}

/// The batch path this CPU runs.
#[must_use]
pub fn batch_path() -> BatchPath {
    if crate::lanes::avx2_fma_available() {
        BatchPath::Avx2Fma
    } else {
        BatchPath::Portable
    }
}

/// Eight f32 lanes in one AVX register with fused multiply–add: only used
/// inside `#[target_feature(enable = "avx2,fma")]` functions.
#[cfg(target_arch = "x86_64")]
type V8 = crate::lanes::F8;

#[cfg(target_arch = "x86_64")]
use crate::lanes::Lane;

const BATCH_NN: usize = BATCH_MAX_ORDER * BATCH_MAX_ORDER;
const ROTATE_BATCH_NN: usize = ROTATE_BATCH_MAX_ORDER * ROTATE_BATCH_MAX_ORDER;

/// Runs `f` with the order-`n` evaluation kernel on eight directions as a
/// closure over a fixed-size output (`n ≤` [`BATCH_MAX_ORDER`]): one loop per
/// order, so every coefficient index is a constant and the values stay in
/// registers.
#[cfg(target_arch = "x86_64")]
macro_rules! with_eval8 {
    ($n:expr, |$nn:ident, $k:ident| $body:expr) => {
        match $n {
            1 => {
                const $nn: usize = 1;
                let $k = |x, y, z, o: &mut [V8; 1]| kernels::eval_n1(x, y, z, o);
                $body
            }
            2 => {
                const $nn: usize = 4;
                let $k = |x, y, z, o: &mut [V8; 4]| kernels::eval_n2(x, y, z, o);
                $body
            }
            3 => {
                const $nn: usize = 9;
                let $k = |x, y, z, o: &mut [V8; 9]| kernels::eval_n3(x, y, z, o);
                $body
            }
            4 => {
                const $nn: usize = 16;
                let $k = |x, y, z, o: &mut [V8; 16]| kernels::eval_n4(x, y, z, o);
                $body
            }
            5 => {
                const $nn: usize = 25;
                let $k = |x, y, z, o: &mut [V8; 25]| kernels::eval_n5(x, y, z, o);
                $body
            }
            6 => {
                const $nn: usize = 36;
                let $k = |x, y, z, o: &mut [V8; 36]| kernels::eval_n6(x, y, z, o);
                $body
            }
            _ => unreachable!("batch order checked against BATCH_MAX_ORDER"),
        }
    };
}

/// The rotation kernel of the order with `NN` = n² coefficients on eight
/// vectors (`n ≤` [`ROTATE_BATCH_MAX_ORDER`]): matrices `m`, their ZYZ
/// angles `e` (read from order 4 on). The arrays are the order's own size,
/// so the batch loop copies nothing between its load, this kernel and its
/// store.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn rotate8<const NN: usize>(m: &[[V8; 3]; 3], e: &[V8; 6], v: &[V8; NN], d: &mut [V8; NN]) {
    fn fit<'a, const A: usize, const B: usize>(
        v: &'a [V8; A],
        d: &'a mut [V8; A],
    ) -> (&'a [V8; B], &'a mut [V8; B]) {
        (
            v.as_slice().try_into().expect("length"),
            d.as_mut_slice().try_into().expect("length"),
        )
    }
    match NN {
        1 => {
            let (v, d) = fit::<NN, 1>(v, d);
            kernels::rotate_n1(m, e, v, d);
        }
        4 => {
            let (v, d) = fit::<NN, 4>(v, d);
            kernels::rotate_n2(m, e, v, d);
        }
        9 => {
            let (v, d) = fit::<NN, 9>(v, d);
            kernels::rotate_n3(m, e, v, d);
        }
        16 => {
            let (v, d) = fit::<NN, 16>(v, d);
            kernels::rotate_n4(m, e, v, d);
        }
        25 => {
            let (v, d) = fit::<NN, 25>(v, d);
            kernels::rotate_n5(m, e, v, d);
        }
        36 => {
            let (v, d) = fit::<NN, 36>(v, d);
            kernels::rotate_n6(m, e, v, d);
        }
        _ => unreachable!("rotation batch order checked against ROTATE_BATCH_MAX_ORDER"),
    }
}

/// Directions `i0 .. i0 + 8` as lanes `x, y, z`: a transposed load of 24
/// floats where eight remain, else a padded copy (the last item repeated).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn dir_lanes(dirs: &[[f32; 3]], i0: usize) -> [V8; 3] {
    if i0 + 8 <= dirs.len() {
        // SAFETY: 8 directions = 24 f32 from `i0` are in the slice.
        return unsafe { V8::load_xyz8(dirs[i0..i0 + 8].as_flattened().as_ptr()) };
    }
    let last = dirs.len() - 1;
    let mut pad = [[0.0f32; 3]; 8];
    for (j, p) in pad.iter_mut().enumerate() {
        *p = dirs[(i0 + j).min(last)];
    }
    // SAFETY: `pad` holds 24 f32.
    unsafe { V8::load_xyz8(pad.as_flattened().as_ptr()) }
}

/// # Safety
/// The CPU must support AVX2 and FMA; `out.len() == dirs.len() · order²`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn eval_batch_avx2(order: usize, dirs: &[[f32; 3]], out: &mut [f32]) {
    let count = dirs.len();
    assert_eq!(
        out.len(),
        order * order * count,
        "eval_batch_avx2 output length"
    );
    with_eval8!(order, |NN, kernel| {
        let mut y = [V8::splat(0.0); NN];
        for i0 in (0..count).step_by(8) {
            // SAFETY: the caller checked the features.
            let [dx, dy, dz] = unsafe { dir_lanes(dirs, i0) };
            kernel(dx, dy, dz, &mut y);
            if i0 + 8 <= count {
                for (k, yk) in y.iter().enumerate() {
                    // SAFETY: `k·count + i0 + 8 ≤ NN·count = out.len()`.
                    unsafe { yk.store(out.as_mut_ptr().add(k * count + i0)) };
                }
            } else {
                let cnt = count - i0;
                for (k, yk) in y.iter().enumerate() {
                    out[k * count + i0..k * count + i0 + cnt]
                        .copy_from_slice(&yk.to_array()[..cnt]);
                }
            }
        }
    });
}

/// # Safety
/// The CPU must support AVX2 and FMA; lengths as [`shade_batch`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn shade_batch_avx2<const C: usize>(
    order: usize,
    coeffs: [&[f32]; C],
    dirs: &[[f32; 3]],
    out: &mut [[f32; C]],
) {
    assert_eq!(out.len(), dirs.len(), "shade_batch_avx2 output length");
    with_eval8!(order, |NN, kernel| {
        let mut ck = [[V8::splat(0.0); NN]; C];
        for c in 0..C {
            for k in 0..NN {
                ck[c][k] = V8::splat(coeffs[c][k]);
            }
        }
        let mut y = [V8::splat(0.0); NN];
        for i0 in (0..dirs.len()).step_by(8) {
            // SAFETY: the caller checked the features.
            let [dx, dy, dz] = unsafe { dir_lanes(dirs, i0) };
            kernel(dx, dy, dz, &mut y);
            let mut acc = [V8::splat(0.0); C];
            for k in 0..NN {
                for c in 0..C {
                    acc[c] = y[k].mul_add(ck[c][k], acc[c]);
                }
            }
            if C == 1 && i0 + 8 <= dirs.len() {
                // SAFETY: `out[i0 .. i0 + 8]` is in the slice (one f32 each).
                unsafe { acc[0].store(out[i0..i0 + 8].as_flattened_mut().as_mut_ptr()) };
                continue;
            }
            let cnt = 8.min(dirs.len() - i0);
            let a = acc.map(V8::to_array);
            for j in 0..cnt {
                for c in 0..C {
                    out[i0 + j][c] = a[c][j];
                }
            }
        }
    });
}

/// Lane Euler decomposition, branch-free: [`Rot3::euler_zyz`] with both pole
/// branches computed and blended per lane. Compiled for AVX2 + FMA itself
/// (its closure too): a plain `#[inline(always)]` function left the
/// intrinsics of its closure as out-of-line calls (36 ns per item at n = 4).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn euler_of_lanes(m: &[[V8; 3]; 3]) -> [V8; 6] {
    let one = V8::splat(1.0);
    let zero = V8::splat(0.0);
    let norm2 = |c: V8, s: V8| {
        let n2 = c.mul_add(c, s * s);
        let inv = n2.sqrt().recip();
        (
            n2.select_gt(0.0, c * inv, one),
            n2.select_gt(0.0, s * inv, zero),
        )
    };
    let cb = m[2][2];
    let sb = m[0][2].mul_add(m[0][2], m[1][2] * m[1][2]).sqrt();
    let (ca, sa) = norm2(m[0][2], m[1][2]);
    let (cs, ss) = norm2(m[0][0] + m[1][1], m[1][0] - m[0][1]);
    let (cd, sd) = norm2(m[1][1] - m[0][0], -(m[1][0] + m[0][1]));
    let cg_p = cs.mul_add(ca, ss * sa);
    let sg_p = ss.mul_add(ca, -(cs * sa));
    let cg_m = ca.mul_add(cd, sa * sd);
    let sg_m = sa.mul_add(cd, -(ca * sd));
    [
        ca,
        sa,
        cb.clamp(-1.0, 1.0),
        sb,
        cb.select_ge0(cg_p, cg_m),
        cb.select_ge0(sg_p, sg_m),
    ]
}

/// Runs `$body` with `$nn` = the order's coefficient count as a constant
/// (one loop per order: every index is constant, the lanes stay in registers).
#[cfg(target_arch = "x86_64")]
macro_rules! with_nn {
    ($n:expr, |$nn:ident| $body:expr) => {
        match $n {
            1 => {
                const $nn: usize = 1;
                $body
            }
            2 => {
                const $nn: usize = 4;
                $body
            }
            3 => {
                const $nn: usize = 9;
                $body
            }
            4 => {
                const $nn: usize = 16;
                $body
            }
            5 => {
                const $nn: usize = 25;
                $body
            }
            6 => {
                const $nn: usize = 36;
                $body
            }
            _ => unreachable!("rotation batch order checked against ROTATE_BATCH_MAX_ORDER"),
        }
    };
}

/// Eight rows of `len` f32 (row `j` at `rows[j]`) as `len` lane vectors:
/// 8×8 transposes of whole blocks, element loads for the rest.
///
/// # Safety
/// The CPU must support AVX2 and FMA; every row valid for `len` reads.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn load_rows<const N: usize>(rows: [*const f32; 8]) -> [V8; N] {
    let mut out = [V8::splat(0.0); N];
    let full = N / 8 * 8;
    for kb in (0..full).step_by(8) {
        // SAFETY: `kb + 8 ≤ N`, inside every row.
        let r = rows.map(|p| unsafe { V8::load(p.add(kb)) });
        out[kb..kb + 8].copy_from_slice(&V8::transpose8(r));
    }
    for k in full..N {
        // SAFETY: `k < N`, inside every row.
        out[k] = unsafe { V8::from_ptrs(rows.map(|p| p.add(k))) };
    }
    out
}

/// The inverse of [`load_rows`]: lane `j` of `v[k]` to `rows[j][k]`.
///
/// # Safety
/// The CPU must support AVX2 and FMA; every row valid for `N` writes, rows
/// disjoint.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn store_rows<const N: usize>(v: &[V8; N], rows: [*mut f32; 8]) {
    let full = N / 8 * 8;
    for kb in (0..full).step_by(8) {
        let t = V8::transpose8(v[kb..kb + 8].try_into().expect("eight"));
        for (j, tj) in t.iter().enumerate() {
            // SAFETY: `kb + 8 ≤ N`, inside row `j`.
            unsafe { tj.store(rows[j].add(kb)) };
        }
    }
    for k in full..N {
        let a = v[k].to_array();
        for j in 0..8 {
            // SAFETY: `k < N`, inside row `j`.
            unsafe { *rows[j].add(k) = a[j] };
        }
    }
}

/// Items `i0 .. i0 + 8` of a rotation batch as lanes: the matrices (nine
/// lane vectors, row-major) and the vectors (`NN`); past the end the last
/// item repeats.
///
/// # Safety
/// The CPU must support AVX2 and FMA; `src.len() ≥ rots.len() · NN`, `i0 < rots.len()`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn load_group<const NN: usize>(
    rots: &[Rot3<f32>],
    src: &[f32],
    i0: usize,
) -> ([V8; 9], [V8; NN]) {
    let item = |j: usize| (i0 + j).min(rots.len() - 1);
    let vrows: [*const f32; 8] = std::array::from_fn(|j| src[item(j) * NN..].as_ptr());
    // SAFETY: every row pointer is a whole vector (NN f32) of an item
    // ≤ rots.len() − 1; the caller's features and `i0` as `load_rots`.
    unsafe { (load_rots(rots, i0), load_rows(vrows)) }
}

/// The matrices of items `i0 .. i0 + 8` as lanes (nine lane vectors,
/// row-major); past the end the last item repeats.
///
/// # Safety
/// The CPU must support AVX2 and FMA; `i0 < rots.len()`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn load_rots(rots: &[Rot3<f32>], i0: usize) -> [V8; 9] {
    let item = |j: usize| (i0 + j).min(rots.len() - 1);
    let mrows: [*const f32; 8] = std::array::from_fn(|j| rots[item(j)].m.as_flattened().as_ptr());
    // SAFETY: every row pointer is a whole matrix (9 f32) of an item.
    unsafe { load_rows(mrows) }
}

/// The 3 × 3 lanes of nine loaded matrix rows and, from order 4, their ZYZ
/// angles ([`euler_of_lanes`]; below it the kernels read the matrix alone).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn rotation_lanes(mf: &[V8; 9], order: usize) -> ([[V8; 3]; 3], [V8; 6]) {
    let m = [
        [mf[0], mf[1], mf[2]],
        [mf[3], mf[4], mf[5]],
        [mf[6], mf[7], mf[8]],
    ];
    let e = if order >= 4 {
        // SAFETY: the caller checked the features.
        unsafe { euler_of_lanes(&m) }
    } else {
        [V8::splat(0.0); 6]
    };
    (m, e)
}

/// Stores lanes `v` as items `i0 .. i0 + 8` of `dst`; lanes past `count`
/// go to `spill` (8 rows of `NN`).
///
/// # Safety
/// The CPU must support AVX2 and FMA; `dst.len() ≥ count · NN`, `i0 < count`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn store_group<const NN: usize>(
    v: &[V8; NN],
    dst: &mut [f32],
    i0: usize,
    count: usize,
    spill: &mut [f32],
) {
    // SAFETY: as `store_group_at` with items NN apart.
    unsafe { store_group_at(v, dst, i0, count, spill, NN, 0) };
}

/// [`store_group`] into items `stride` floats apart, lane `j` at
/// `dst[(i0 + j)·stride + offset ..]` (one of an item's several vectors).
///
/// # Safety
/// The CPU must support AVX2 and FMA; `offset + NN ≤ stride`,
/// `dst.len() ≥ count · stride`, `i0 < count`, `spill` 8 rows of `NN`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn store_group_at<const NN: usize>(
    v: &[V8; NN],
    dst: &mut [f32],
    i0: usize,
    count: usize,
    spill: &mut [f32],
    stride: usize,
    offset: usize,
) {
    let cnt = 8.min(count - i0);
    let base = dst.as_mut_ptr();
    let sp = spill.as_mut_ptr();
    let drows: [*mut f32; 8] = std::array::from_fn(|j| {
        // SAFETY: `(i0 + j)·stride + offset + NN ≤ dst.len()` for j < cnt;
        // `spill` holds 8 rows of NN.
        unsafe {
            if j < cnt {
                base.add((i0 + j) * stride + offset)
            } else {
                sp.add(j * NN)
            }
        }
    });
    // SAFETY: disjoint rows of NN f32 each (above).
    unsafe { store_rows(v, drows) };
}

/// # Safety
/// The CPU must support AVX2 and FMA; lengths as [`rotate_batch`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn rotate_batch_avx2(
    order: usize,
    rots: &[Rot3<f32>],
    src: &[f32],
    dst: &mut [f32],
) {
    let count = rots.len();
    assert!(
        src.len() == order * order * count && dst.len() == order * order * count,
        "rotate_batch_avx2 lengths"
    );
    with_nn!(order, |NN| {
        let mut spill = [0.0f32; 8 * NN];
        for i0 in (0..count).step_by(8) {
            // SAFETY: the caller checked the features and lengths.
            let (mf, a) = unsafe { load_group::<NN>(rots, src, i0) };
            // SAFETY: the caller checked the features.
            let (m, e) = unsafe { rotation_lanes(&mf, order) };
            let mut b = [V8::splat(0.0); NN];
            // SAFETY: the caller checked the features.
            unsafe { rotate8::<NN>(&m, &e, &a, &mut b) };
            // SAFETY: as the load.
            unsafe { store_group(&b, dst, i0, count, &mut spill) };
        }
    });
}

/// [`rotate_shared_batch`] in AVX2 lanes: per group of eight items the
/// matrices are transposed in and their ZYZ angles found once, each shared
/// source broadcast (the same lane values [`load_group`] gives copies of
/// it), and the lanes stored straight into their items' slots of `dst`.
///
/// # Safety
/// The CPU must support AVX2 and FMA; lengths as [`rotate_shared_batch`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn rotate_shared_batch_avx2<const C: usize>(
    order: usize,
    rots: &[Rot3<f32>],
    srcs: [&[f32]; C],
    dst: &mut [f32],
) {
    let count = rots.len();
    with_nn!(order, |NN| {
        assert!(
            srcs.iter().all(|s| s.len() >= NN) && dst.len() == count * C * NN,
            "rotate_shared_batch_avx2 lengths"
        );
        let mut a = [[V8::splat(0.0); NN]; C];
        for (a, s) in a.iter_mut().zip(srcs) {
            for (v, &x) in a.iter_mut().zip(s) {
                *v = V8::splat(x);
            }
        }
        let mut spill = [0.0f32; 8 * NN];
        for i0 in (0..count).step_by(8) {
            // SAFETY: the caller checked the features; i0 < count.
            let (m, e) = unsafe { rotation_lanes(&load_rots(rots, i0), order) };
            for (c, a) in a.iter().enumerate() {
                let mut b = [V8::splat(0.0); NN];
                // SAFETY: the caller checked the features.
                unsafe { rotate8::<NN>(&m, &e, a, &mut b) };
                // SAFETY: item i's vector c is at (i·C + c)·NN, inside `dst`
                // (its length checked above).
                unsafe { store_group_at(&b, dst, i0, count, &mut spill, C * NN, c * NN) };
            }
        }
    });
}

/// Portable batch evaluation: [`eval_one_portable`] per direction (coefficient-major output).
pub(crate) fn eval_batch_portable(order: usize, dirs: &[[f32; 3]], out: &mut [f32]) {
    let (nn, count) = (order * order, dirs.len());
    let mut y = [0.0f32; BATCH_NN];
    for (i, &[x, yy, z]) in dirs.iter().enumerate() {
        eval_one_portable(order, x, yy, z, &mut y);
        for k in 0..nn {
            out[k * count + i] = y[k];
        }
    }
}

/// Portable batch rotation: [`rotate_one_portable`] per item.
pub(crate) fn rotate_batch_portable(
    order: usize,
    rots: &[Rot3<f32>],
    src: &[f32],
    dst: &mut [f32],
) {
    let nn = order * order;
    for (i, r) in rots.iter().enumerate() {
        let span = i * nn..(i + 1) * nn;
        rotate_one_portable(order, &r.m, &src[span.clone()], &mut dst[span]);
    }
}

/// Portable batch shading: [`eval_one_portable`] and a dot product per direction.
pub(crate) fn shade_batch_portable<const C: usize>(
    order: usize,
    coeffs: [&[f32]; C],
    dirs: &[[f32; 3]],
    out: &mut [[f32; C]],
) {
    let nn = order * order;
    let mut y = [0.0f32; BATCH_NN];
    for (&[x, yy, z], o) in dirs.iter().zip(out) {
        eval_one_portable(order, x, yy, z, &mut y);
        for c in 0..C {
            o[c] = coeffs[c][..nn].iter().zip(&y).map(|(a, b)| a * b).sum();
        }
    }
}

/// Evaluates all `order²` basis functions at every direction, lanes across
/// directions: **coefficient-major** output, `out[k·count + i] = y_k(dirs[i])`
/// with `count = dirs.len()` (each basis function's values over the batch are
/// contiguous, so the eight-lane kernel stores whole registers).
/// Orders `1 ..=` [`BATCH_MAX_ORDER`].
///
/// # Errors
/// [`ShError::OrderOutOfRange`]; [`ShError::LengthMismatch`] unless
/// `out.len() == dirs.len() · order²`.
pub fn eval_batch(order: usize, dirs: &[[f32; 3]], out: &mut [f32]) -> Result<(), ShError> {
    check_order("order (fast::eval_batch)", order, BATCH_MAX_ORDER)?;
    check_len(
        "eval_batch output",
        order,
        out.len(),
        dirs.len() * order * order,
    )?;
    if dirs.is_empty() {
        return Ok(());
    }
    #[cfg(target_arch = "x86_64")]
    if batch_path() == BatchPath::Avx2Fma {
        // SAFETY: AVX2 and FMA were detected.
        unsafe { eval_batch_avx2(order, dirs, out) };
        return Ok(());
    }
    eval_batch_portable(order, dirs, out);
    Ok(())
}

/// Shades every direction with one coefficient vector (radiance or
/// irradiance already convolved): `out[i] = Σ_k c_k y_k(dirs[i])`.
/// Orders `1 ..=` [`BATCH_MAX_ORDER`].
///
/// # Errors
/// [`ShError::OrderOutOfRange`]; [`ShError::LengthMismatch`] unless
/// `coeffs.len() == order²` and `out.len() == dirs.len()`.
pub fn shade_batch(
    order: usize,
    coeffs: &[f32],
    dirs: &[[f32; 3]],
    out: &mut [f32],
) -> Result<(), ShError> {
    check_order("order (fast::shade_batch)", order, BATCH_MAX_ORDER)?;
    check_len(
        "shade_batch coefficients",
        order,
        coeffs.len(),
        order * order,
    )?;
    check_len(
        "shade_batch output (one per direction)",
        order,
        out.len(),
        dirs.len(),
    )?;
    if dirs.is_empty() {
        return Ok(());
    }
    let out1: &mut [[f32; 1]] = out.as_chunks_mut::<1>().0;
    #[cfg(target_arch = "x86_64")]
    if batch_path() == BatchPath::Avx2Fma {
        // SAFETY: AVX2 and FMA were detected.
        unsafe { shade_batch_avx2::<1>(order, [coeffs], dirs, out1) };
        return Ok(());
    }
    shade_batch_portable::<1>(order, [coeffs], dirs, out1);
    Ok(())
}

/// [`shade_batch`] for an RGB coefficient triple: `out[i][c] = Σ_k c_{c,k} y_k(dirs[i])`.
///
/// # Errors
/// As [`shade_batch`], for each channel.
pub fn shade_rgb_batch(
    order: usize,
    coeffs: [&[f32]; 3],
    dirs: &[[f32; 3]],
    out: &mut [[f32; 3]],
) -> Result<(), ShError> {
    check_order("order (fast::shade_rgb_batch)", order, BATCH_MAX_ORDER)?;
    for c in coeffs {
        check_len(
            "shade_rgb_batch coefficients",
            order,
            c.len(),
            order * order,
        )?;
    }
    check_len(
        "shade_rgb_batch output (one per direction)",
        order,
        out.len(),
        dirs.len(),
    )?;
    if dirs.is_empty() {
        return Ok(());
    }
    #[cfg(target_arch = "x86_64")]
    if batch_path() == BatchPath::Avx2Fma {
        // SAFETY: AVX2 and FMA were detected.
        unsafe { shade_batch_avx2::<3>(order, coeffs, dirs, out) };
        return Ok(());
    }
    shade_batch_portable::<3>(order, coeffs, dirs, out);
    Ok(())
}

/// Rotates vector `i` (item-major in `src`) by `rots[i]` into `dst`, exactly
/// (ZYZ with fixed X matrices, Euler angles per item, no inverse trigonometry).
/// Orders `1 ..=` [`ROTATE_BATCH_MAX_ORDER`].
///
/// # Errors
/// [`ShError::OrderOutOfRange`]; [`ShError::LengthMismatch`] unless
/// `src.len() == dst.len() == rots.len() · order²`.
pub fn rotate_batch(
    order: usize,
    rots: &[Rot3<f32>],
    src: &[f32],
    dst: &mut [f32],
) -> Result<(), ShError> {
    check_order("order (fast::rotate_batch)", order, ROTATE_BATCH_MAX_ORDER)?;
    let want = rots.len() * order * order;
    check_len("rotate_batch src", order, src.len(), want)?;
    check_len("rotate_batch dst", order, dst.len(), want)?;
    if rots.is_empty() {
        return Ok(());
    }
    #[cfg(target_arch = "x86_64")]
    if batch_path() == BatchPath::Avx2Fma {
        // SAFETY: AVX2 and FMA were detected.
        unsafe { rotate_batch_avx2(order, rots, src, dst) };
        return Ok(());
    }
    rotate_batch_portable(order, rots, src, dst);
    Ok(())
}

/// Rotates `C` vectors shared by every item (`srcs`, each at least
/// `order²` long: the world lighting's colour channels, say) by each item's
/// rotation: item `i`'s copy of `srcs[c]` into `dst[(i·C + c)·order²..]`.
/// The same values as [`rotate_batch`] with each rotation repeated `C`
/// times and the sources copied per item, bit for bit, without those
/// copies: on a CPU with AVX2 and FMA, at orders up to
/// [`ROTATE_BATCH_MAX_ORDER`], eight items run at a time with the sources
/// broadcast across the lanes, each group's ZYZ angles found once for its
/// `C` vectors and the lanes stored straight into `dst`; elsewhere
/// `rotate_one_portable` per item and vector.
///
/// # Errors
/// As [`rotate_batch`]; [`ShError::LengthMismatch`] unless every source
/// holds `order²` values and `dst.len() == rots.len() · C · order²`.
pub fn rotate_shared_batch<const C: usize>(
    order: usize,
    rots: &[Rot3<f32>],
    srcs: [&[f32]; C],
    dst: &mut [f32],
) -> Result<(), ShError> {
    check_order(
        "order (fast::rotate_shared_batch)",
        order,
        ROTATE_BATCH_MAX_ORDER,
    )?;
    let nn = order * order;
    for s in srcs {
        check_len("rotate_shared_batch src", order, s.len().min(nn), nn)?;
    }
    check_len(
        "rotate_shared_batch dst",
        order,
        dst.len(),
        rots.len() * C * nn,
    )?;
    if rots.is_empty() {
        return Ok(());
    }
    #[cfg(target_arch = "x86_64")]
    if batch_path() == BatchPath::Avx2Fma {
        // SAFETY: AVX2 and FMA were detected; lengths checked above.
        unsafe { rotate_shared_batch_avx2(order, rots, srcs, dst) };
        return Ok(());
    }
    rotate_shared_batch_portable(order, rots, srcs, dst);
    Ok(())
}

/// [`rotate_shared_batch`] one item and vector at a time.
pub(crate) fn rotate_shared_batch_portable<const C: usize>(
    order: usize,
    rots: &[Rot3<f32>],
    srcs: [&[f32]; C],
    dst: &mut [f32],
) {
    let nn = order * order;
    for (r, out) in rots.iter().zip(dst.chunks_exact_mut(C * nn)) {
        for (s, o) in srcs.iter().zip(out.chunks_exact_mut(nn)) {
            rotate_one_portable(order, &r.m, &s[..nn], o);
        }
    }
}

/// Applies `taylor` (Křivánek et al.'s approximate rotation) to every vector:
/// vector `i` (item-major in `src`) by `rots[i]` into `dst`, the same result
/// as [`crate::taylor::TaylorRotation::apply`] item by item, to rounding.
///
/// On a CPU with AVX2 and FMA, at orders `2 ..=` [`ROTATE_BATCH_MAX_ORDER`]
/// and the 1st or 1.5th order, eight items run at a time with lanes across
/// items: the fused step `R_z(α+γ) [I + β cos γ R_y'(0) + β sin γ G_x (+ the
/// conjugated ½β²R'' diagonal)]` of [`crate::taylor`]'s module docs, every
/// angle a polynomial in the matrix entries (no inverse trigonometry). A group
/// of eight with any rotation beyond `min(β_lim, SMALL_BETA_MAX)` (where those
/// polynomials stop) goes item by item. Elsewhere every item goes through
/// `apply`.
///
/// # Errors
/// [`ShError::LengthMismatch`] unless `src.len() == dst.len() == rots.len() · order²`.
pub fn taylor_batch(
    taylor: &crate::taylor::TaylorRotation<f32>,
    rots: &[Rot3<f32>],
    src: &[f32],
    dst: &mut [f32],
) -> Result<(), ShError> {
    let order = taylor.taylor_y().order();
    let want = rots.len() * order * order;
    check_len("taylor_batch src", order, src.len(), want)?;
    check_len("taylor_batch dst", order, dst.len(), want)?;
    if rots.is_empty() {
        return Ok(());
    }
    #[cfg(target_arch = "x86_64")]
    if batch_path() == BatchPath::Avx2Fma
        && (2..=ROTATE_BATCH_MAX_ORDER).contains(&order)
        && taylor.kind != crate::taylor::TaylorOrder::Second
    {
        static COEFFICIENTS: [OnceLock<crate::simd::TaylorCoefficients>;
            ROTATE_BATCH_MAX_ORDER + 1] = [const { OnceLock::new() }; ROTATE_BATCH_MAX_ORDER + 1];
        let co = COEFFICIENTS[order].get_or_init(|| crate::simd::taylor_coefficients(order));
        // SAFETY: AVX2 and FMA were detected.
        unsafe { taylor_batch_avx2(taylor, co, order, rots, src, dst) };
        return Ok(());
    }
    taylor_batch_portable(taylor, order, rots, src, dst);
    Ok(())
}

/// [`taylor_batch`] item by item.
fn taylor_batch_portable(
    taylor: &crate::taylor::TaylorRotation<f32>,
    order: usize,
    rots: &[Rot3<f32>],
    src: &[f32],
    dst: &mut [f32],
) {
    let nn = order * order;
    let mut scratch = [0.0f32; MAX_ORDER * MAX_ORDER];
    for (i, r) in rots.iter().enumerate() {
        taylor.apply(
            r,
            &src[i * nn..(i + 1) * nn],
            &mut dst[i * nn..(i + 1) * nn],
            &mut scratch,
        );
    }
}

/// `Σ_k c_k u^k` by Horner's rule on lanes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn poly_lanes(c: &[f64], u: V8) -> V8 {
    let mut acc = V8::splat(c[c.len() - 1] as f32);
    for &ck in c[..c.len() - 1].iter().rev() {
        acc = acc.mul_add(u, V8::splat(ck as f32));
    }
    acc
}

/// # Safety
/// The CPU must support AVX2 and FMA; lengths as [`taylor_batch`];
/// `2 ≤ order ≤` [`ROTATE_BATCH_MAX_ORDER`], first or 1.5th order.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn taylor_batch_avx2(
    taylor: &crate::taylor::TaylorRotation<f32>,
    co: &crate::simd::TaylorCoefficients,
    order: usize,
    rots: &[Rot3<f32>],
    src: &[f32],
    dst: &mut [f32],
) {
    use crate::taylor::{BETA_OVER_SIN, INV_ONE_PLUS_COS, SMALL_BETA_MAX, TaylorOrder};
    let count = rots.len();
    let half = taylor.kind == TaylorOrder::OneAndHalf;
    let cos_lim = taylor.beta_lim.min(SMALL_BETA_MAX as f32).cos();
    let mut scratch = [0.0f32; ROTATE_BATCH_NN];
    with_nn!(order, |NN| {
        let mut spill = [0.0f32; 8 * NN];
        for i0 in (0..count).step_by(8) {
            let cnt = 8.min(count - i0);
            // A NaN entry goes item by item too.
            if rots[i0..i0 + cnt]
                .iter()
                .any(|r| r.m[2][2].is_nan() || r.m[2][2] < cos_lim)
            {
                for i in i0..i0 + cnt {
                    let span = i * NN..(i + 1) * NN;
                    taylor.apply(&rots[i], &src[span.clone()], &mut dst[span], &mut scratch);
                }
                continue;
            }
            // SAFETY: the caller checked the features and lengths.
            let (mf, x) = unsafe { load_group::<NN>(rots, src, i0) };
            let (r20, r21, r22) = (mf[6], mf[7], mf[8]);
            let s2 = r20.mul_add(r20, r21 * r21);
            let k = poly_lanes(&BETA_OVER_SIN, s2);
            // β cos γ = −k R₂₀, β sin γ = k R₂₁ (crate::taylor, `apply`).
            let (bc, bs) = (-(k * r20), k * r21);
            let ip = poly_lanes(&INV_ONE_PLUS_COS, V8::splat(1.0) - r22);
            let (ca, sa) = ((mf[0] + mf[4]) * ip, (mf[3] - mf[1]) * ip);
            let k2 = k * k;
            let c2 = r20.mul_add(r20, -(r21 * r21));
            let n2 = (r20 + r20) * r21;
            let mut y = [V8::splat(0.0); NN];
            for l in 0..order {
                let b = l * (l + 1);
                let li = l as isize;
                for m in -li..=li {
                    let i = (b as isize + m) as usize;
                    let r = (b as isize - m) as usize;
                    let (mut gy, mut gx) = (V8::splat(0.0), V8::splat(0.0));
                    if m > -li {
                        gy = V8::splat(co.sub[i]) * x[i - 1];
                        gx = V8::splat(co.g_prev[i]) * x[r + 1];
                    }
                    if m < li {
                        gy = V8::splat(-co.sub[i + 1]).mul_add(x[i + 1], gy);
                        gx = V8::splat(co.g_next[i]).mul_add(x[r - 1], gx);
                    }
                    let mut v = bs.mul_add(gx, bc.mul_add(gy, x[i]));
                    if half {
                        let q = (s2 * V8::splat(co.dbar[i])).mul_add(
                            x[i],
                            (c2 * V8::splat(co.dsig[i]))
                                .mul_add(x[i], (n2 * V8::splat(co.dhalf[i])) * x[r]),
                        );
                        v = k2.mul_add(q, v);
                    }
                    y[i] = v;
                }
            }
            // R_z(α+γ): cos mθ, sin mθ by the Chebyshev recurrence.
            let mut out = [V8::splat(0.0); NN];
            let two_c = ca + ca;
            let (mut cm1, mut sm1) = (V8::splat(1.0), V8::splat(0.0));
            let (mut cm, mut sm) = (ca, sa);
            for m in 0..order {
                if m > 0 {
                    for l in m..order {
                        let b = l * (l + 1);
                        let (p, q) = (y[b + m], y[b - m]);
                        out[b + m] = p.mul_add(cm, -(q * sm));
                        out[b - m] = q.mul_add(cm, p * sm);
                    }
                    let (cn, sn) = (two_c.mul_add(cm, -cm1), two_c.mul_add(sm, -sm1));
                    (cm1, sm1, cm, sm) = (cm, sm, cn, sn);
                } else {
                    for l in 0..order {
                        out[l * (l + 1)] = y[l * (l + 1)];
                    }
                }
            }
            // SAFETY: as the load.
            unsafe { store_group(&out, dst, i0, count, &mut spill) };
        }
    });
}

const _: () = assert!(KERNEL_EVAL_MAX_ORDER <= MAX_ORDER);

#[cfg(test)]
#[path = "fast_tests.rs"]
pub(crate) mod tests;
