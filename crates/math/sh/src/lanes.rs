//! The number types the generated kernels of [`crate::kernels`] are written
//! for: [`V`] (`W` f32 lanes as an array) and, on x86-64, [`F8`] (one AVX
//! register), both through the [`Lane`] trait (evaluation and rotation).
//!
//! `V<1, false>` is a plain f32 (the portable scalar path), `V<1, true>` an f32
//! whose `mul_add` is fused (the single-call AVX2+FMA copies), `F8` eight
//! directions or vectors side by side (lanes across items, the batch kernels).
//! `V`'s operations are element-wise loops over a fixed-size array marked
//! `#[inline(always)]`. `FMA = true` and `F8` must only be used where the
//! caller has checked (or enabled) the `avx2,fma` features: without them
//! `f32::mul_add` is a libm call and the intrinsics are not available.

use std::ops::{Add, Mul, Neg, Sub};

/// `W` f32 lanes; `FMA` selects fused multiply–add in [`V::mul_add`].
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct V<const W: usize, const FMA: bool>(pub [f32; W]);

impl<const W: usize, const FMA: bool> V<W, FMA> {
    /// All lanes `v`.
    #[inline(always)]
    pub(crate) fn splat(v: f32) -> Self {
        Self([v; W])
    }

    /// `self · b + c`, fused when `FMA`.
    #[inline(always)]
    pub(crate) fn mul_add(self, b: Self, c: Self) -> Self {
        let mut r = [0.0; W];
        for i in 0..W {
            r[i] = if FMA {
                self.0[i].mul_add(b.0[i], c.0[i])
            } else {
                self.0[i] * b.0[i] + c.0[i]
            };
        }
        Self(r)
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $op:tt) => {
        impl<const W: usize, const FMA: bool> $tr for V<W, FMA> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                let mut r = [0.0; W];
                for i in 0..W {
                    r[i] = self.0[i] $op o.0[i];
                }
                Self(r)
            }
        }
    };
}
binop!(Add, add, +);
binop!(Sub, sub, -);
binop!(Mul, mul, *);

impl<const W: usize, const FMA: bool> Neg for V<W, FMA> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        let mut r = [0.0; W];
        for i in 0..W {
            r[i] = -self.0[i];
        }
        Self(r)
    }
}

/// What the generated evaluation and rotation kernels need of a number
/// type: `V<W, F>` (scalar or array lanes) and [`F8`] (one AVX2 register).
pub(crate) trait Lane:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    /// All lanes `v`.
    fn splat(v: f32) -> Self;
    /// `self · b + c` (fused where the type says so).
    fn mul_add(self, b: Self, c: Self) -> Self;
}

impl<const W: usize, const FMA: bool> Lane for V<W, FMA> {
    #[inline(always)]
    fn splat(v: f32) -> Self {
        Self([v; W])
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        V::mul_add(self, b, c)
    }
}

/// Eight f32 lanes in one AVX register, fused multiply–add.
///
/// `V<8, true>` (an `[f32; 8]`) left LLVM to re-vectorise eight scalar
/// copies of every value, with shuffles at loads and stores; this type is
/// the register itself. **Only use it inside functions compiled with
/// `#[target_feature(enable = "avx2,fma")]` on a CPU that has them** (the
/// methods call the intrinsics unchecked; they inline into those functions).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct F8(pub(crate) std::arch::x86_64::__m256);

#[cfg(target_arch = "x86_64")]
mod f8 {
    use super::{F8, Lane};
    use std::arch::x86_64::*;
    use std::ops::{Add, Mul, Neg, Sub};

    // SAFETY (every `unsafe` block of this module): `F8` is only used inside
    // functions compiled for AVX2 + FMA on CPUs that have them (see the type).
    impl Lane for F8 {
        #[inline(always)]
        fn splat(v: f32) -> Self {
            Self(unsafe { _mm256_set1_ps(v) })
        }
        #[inline(always)]
        fn mul_add(self, b: Self, c: Self) -> Self {
            Self(unsafe { _mm256_fmadd_ps(self.0, b.0, c.0) })
        }
    }

    macro_rules! binop {
        ($tr:ident, $f:ident, $i:ident) => {
            impl $tr for F8 {
                type Output = Self;
                #[inline(always)]
                fn $f(self, o: Self) -> Self {
                    Self(unsafe { $i(self.0, o.0) })
                }
            }
        };
    }
    binop!(Add, add, _mm256_add_ps);
    binop!(Sub, sub, _mm256_sub_ps);
    binop!(Mul, mul, _mm256_mul_ps);

    impl Neg for F8 {
        type Output = Self;
        #[inline(always)]
        fn neg(self) -> Self {
            Self(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
        }
    }

    impl F8 {
        /// Eight values from `p[0..8]` (unaligned).
        ///
        /// # Safety
        /// `p` must be valid for reading eight f32.
        #[inline(always)]
        pub(crate) unsafe fn load(p: *const f32) -> Self {
            Self(unsafe { _mm256_loadu_ps(p) })
        }
        /// Lane `j` = `*p[j]`.
        ///
        /// # Safety
        /// Every `p[j]` must be valid for reading an f32.
        #[inline(always)]
        pub(crate) unsafe fn from_ptrs(p: [*const f32; 8]) -> Self {
            unsafe {
                Self(_mm256_setr_ps(
                    *p[0], *p[1], *p[2], *p[3], *p[4], *p[5], *p[6], *p[7],
                ))
            }
        }
        /// The 8×8 transpose: lane `j` of output `i` is lane `i` of input `j`
        /// (unpack, shuffle, 128-bit permute: 24 shuffles).
        #[inline(always)]
        pub(crate) fn transpose8(r: [Self; 8]) -> [Self; 8] {
            unsafe {
                let t0 = _mm256_unpacklo_ps(r[0].0, r[1].0);
                let t1 = _mm256_unpackhi_ps(r[0].0, r[1].0);
                let t2 = _mm256_unpacklo_ps(r[2].0, r[3].0);
                let t3 = _mm256_unpackhi_ps(r[2].0, r[3].0);
                let t4 = _mm256_unpacklo_ps(r[4].0, r[5].0);
                let t5 = _mm256_unpackhi_ps(r[4].0, r[5].0);
                let t6 = _mm256_unpacklo_ps(r[6].0, r[7].0);
                let t7 = _mm256_unpackhi_ps(r[6].0, r[7].0);
                let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
                let u1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
                let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
                let u3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
                let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
                let u5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
                let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
                let u7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
                [
                    Self(_mm256_permute2f128_ps::<0x20>(u0, u4)),
                    Self(_mm256_permute2f128_ps::<0x20>(u1, u5)),
                    Self(_mm256_permute2f128_ps::<0x20>(u2, u6)),
                    Self(_mm256_permute2f128_ps::<0x20>(u3, u7)),
                    Self(_mm256_permute2f128_ps::<0x31>(u0, u4)),
                    Self(_mm256_permute2f128_ps::<0x31>(u1, u5)),
                    Self(_mm256_permute2f128_ps::<0x31>(u2, u6)),
                    Self(_mm256_permute2f128_ps::<0x31>(u3, u7)),
                ]
            }
        }
        /// Stores the lanes to `p[0..8]` (unaligned).
        ///
        /// # Safety
        /// `p` must be valid for writing eight f32.
        #[inline(always)]
        pub(crate) unsafe fn store(self, p: *mut f32) {
            unsafe { _mm256_storeu_ps(p, self.0) }
        }
        /// The lanes as an array.
        #[inline(always)]
        pub(crate) fn to_array(self) -> [f32; 8] {
            let mut a = [0.0f32; 8];
            // SAFETY: `a` holds eight f32.
            unsafe { self.store(a.as_mut_ptr()) };
            a
        }
        /// Element-wise `√x`.
        #[inline(always)]
        pub(crate) fn sqrt(self) -> Self {
            Self(unsafe { _mm256_sqrt_ps(self.0) })
        }
        /// Element-wise `1 / x`.
        #[inline(always)]
        pub(crate) fn recip(self) -> Self {
            Self(unsafe { _mm256_div_ps(_mm256_set1_ps(1.0), self.0) })
        }
        /// Per lane: `a` where `self ≥ 0`, else `b`.
        #[inline(always)]
        pub(crate) fn select_ge0(self, a: Self, b: Self) -> Self {
            unsafe {
                let m = _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, _mm256_setzero_ps());
                Self(_mm256_blendv_ps(b.0, a.0, m))
            }
        }
        /// Per lane: `a` where `self > t`, else `b`.
        #[inline(always)]
        pub(crate) fn select_gt(self, t: f32, a: Self, b: Self) -> Self {
            unsafe {
                let m = _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, _mm256_set1_ps(t));
                Self(_mm256_blendv_ps(b.0, a.0, m))
            }
        }
        /// Element-wise clamp to `[lo, hi]`.
        #[inline(always)]
        pub(crate) fn clamp(self, lo: f32, hi: f32) -> Self {
            unsafe {
                Self(_mm256_min_ps(
                    _mm256_max_ps(self.0, _mm256_set1_ps(lo)),
                    _mm256_set1_ps(hi),
                ))
            }
        }
        /// Eight directions `[x, y, z]` stored one after another at `p`
        /// (24 f32) as three lane vectors `x`, `y`, `z`: three loads, six
        /// blends, three permutes.
        ///
        /// # Safety
        /// `p` must be valid for reading 24 f32.
        #[inline(always)]
        pub(crate) unsafe fn load_xyz8(p: *const f32) -> [Self; 3] {
            unsafe {
                let a = _mm256_loadu_ps(p);
                let b = _mm256_loadu_ps(p.add(8));
                let c = _mm256_loadu_ps(p.add(16));
                // Lane j of a, b, c holds component (j mod 3), (j + 2) mod 3,
                // (j + 1) mod 3 of items ⌊j/3⌋, ⌊(j+8)/3⌋, ⌊(j+16)/3⌋.
                let x = _mm256_blend_ps::<0b0010_0100>(_mm256_blend_ps::<0b1001_0010>(a, b), c);
                let y = _mm256_blend_ps::<0b0100_1001>(_mm256_blend_ps::<0b0010_0100>(a, b), c);
                let z = _mm256_blend_ps::<0b1001_0010>(_mm256_blend_ps::<0b0100_1001>(a, b), c);
                let px = _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5);
                let py = _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6);
                let pz = _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7);
                [
                    Self(_mm256_permutevar8x32_ps(x, px)),
                    Self(_mm256_permutevar8x32_ps(y, py)),
                    Self(_mm256_permutevar8x32_ps(z, pz)),
                ]
            }
        }
    }
}

/// Whether this CPU runs the AVX2 + FMA kernels (x86-64 only).
///
/// One relaxed load of a cached level ([`crate::isa::isa`]): the single-call
/// kernels test it on every call, and two `is_x86_feature_detected!` tests
/// measured 0.4 ns more per call than one flag (a 3.5 ns evaluation at n = 3).
#[inline]
#[must_use]
pub fn avx2_fma_available() -> bool {
    crate::isa::isa() >= crate::isa::Isa::Avx2
}

/// `p` itself, but LLVM may not assume so: loads through the result cannot
/// be merged with earlier loads through `p`. The generated one-chunk product
/// kernels take fresh input pointers per pair block, so each block reads its
/// few inputs from memory (as operands of its multiply–adds) while the `n²`
/// accumulators stay in registers; otherwise LLVM loads every input once,
/// keeps all `2n²` of them and the accumulators live, and spills (order 4:
/// 334 stack accesses in 748 instructions).
#[inline(always)]
#[allow(clippy::pointers_in_nomem_asm_block)] // the asm only launders the pointer
pub(crate) fn fresh<T>(p: *const T) -> *const T {
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    {
        let mut q = p;
        // SAFETY: an empty asm block that only claims to change `q` (not
        // `pure`, so two calls are not merged).
        unsafe {
            std::arch::asm!("/* {0} */", inout(reg) q, options(nomem, nostack, preserves_flags));
        }
        q
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    std::hint::black_box(p)
}
