//! The bands above 0 of the exact rotation from a matrix at n = 4 … 6 —
//! bands 1–3 at n = 4, bands 3 … n−1 at n = 5, 6 — with the band
//! coefficients across the lanes of AVX-512 registers.
//!
//! [`crate::fast::rotate_one`] computes bands 1 and 2 straight from the
//! matrix (a linear and a quadratic form) and the higher bands by the ZYZ
//! ("ZXZXZ") factorisation `R_z(α) X₋ R_z(β) X₊ R_z(γ)` of
//! [`crate::rotation::ZyzRotation`]. As scalar code those higher bands cost
//! about 75 multiplies per band: the scalar kernel is bound by its multiply
//! count (order 4: 106 of 238 instructions). Here the 7 + 9 + 11
//! coefficients of bands 3–5 sit in one register (n = 5) or two (n = 6; no
//! band crosses a register), so each stage is a few full-width operations on
//! constant per-order tables ([`BandTables`]). At n = 4 the 3 + 5 + 7
//! coefficients of bands 1–3 fill 15 lanes of one register: the same
//! stages then replace the ≈ 130 scalar instructions of bands 1 and 2 at no
//! extra vector instruction (figures: `relight bench sh`, row `zyz`, and
//! docs/performance.md).
//!
//! * **Z rotation** by θ: `out = C ∘ v + S ∘ v̄`, `v̄` the register with each
//!   band reversed (`v̄_{l,m} = v_{l,−m}`, one permute), `C_i = cos(|m_i|θ)`,
//!   `S_i = −sin(m_i θ)` (the sign convention of the scalar kernel:
//!   `out_{+m} = c v_{+m} − s v_{−m}`). `C` and `S` come from `cos θ = x`,
//!   `sin θ = y` lane by lane in Horner form: `cos kθ = T_k(x)` and
//!   `sin kθ = y U_{k−1}(x)` (Chebyshev polynomials of the first and second
//!   kind), with per-lane coefficient tables; no multiple-angle recurrence
//!   across lanes, no gathers.
//! * **Fixed X± = R_x(±90°)** band matrices: at most `K` non-zeros per row
//!   (`K` = 2 in band 3, 3 in bands 4 and 5), so `out = Σ_k W_k ∘ P_k(v)`
//!   with `P_k` the permutation that brings row `i`'s `k`-th non-zero column
//!   to lane `i`, and `W_k` its value (0 where a row has fewer non-zeros).
//!   The values are the same f64 Ivanic–Ruedenberg matrices the scalar
//!   kernel's literals come from, rounded to f32.
//!
//! At n = 5, 6 the bands 0–2 and 3+ are independent, so the scalar and
//! vector parts of a call overlap in the out-of-order core. Tested against
//! the portable scalar kernel and the f64 matrices in `fast_tests` (every
//! order 1–6).

#![cfg(target_arch = "x86_64")]

use std::arch::x86_64::*;
use std::sync::OnceLock;

use crate::lane_tables::{F16, I16};
use crate::rotation::{Rot3, ShRotation};

/// Smallest order with bands above 2.
pub(crate) const BANDS_MIN_ORDER: usize = 4;
/// Largest order this kernel covers (two registers).
pub(crate) const BANDS_MAX_ORDER: usize = 6;
/// First flat index this kernel handles at order `n`: `(1, −1)` at n = 4
/// (bands 1–3, 15 lanes), `(3, −3)` above (bands 1 and 2 stay with the
/// scalar code, beside the two registers that bands 3–5 fill).
pub(crate) const fn first(n: usize) -> usize {
    if n == 4 { 1 } else { 9 }
}
const LANES: usize = 16;
/// Registers for bands 3–5 (27 coefficients).
const REGS: usize = 2;
/// Largest `|m|` (band 5): the degree of `T_k`.
const DEG: usize = BANDS_MAX_ORDER - 1;
/// Most non-zeros in a row of `X±` over bands 3–5.
const SLOTS: usize = 3;

/// One fixed ±90° X matrix in permute form: register `r`'s output is
/// `Σ_k w[r][k] ∘ v_r[idx[r][k]]`.
#[derive(Clone, Copy, Debug, Default)]
struct XPerm {
    idx: [[I16; SLOTS]; REGS],
    w: [[F16; SLOTS]; REGS],
}

/// The per-order constant tables of the kernel.
#[derive(Debug)]
pub(crate) struct BandTables {
    /// Lanes holding coefficients (the rest are neither read nor written).
    mask: [u16; REGS],
    /// Band reversal `m ↔ −m` within each register.
    swap: [I16; REGS],
    /// `cos_poly[r][j]` lane `i`: the coefficient of `x^j` in `T_{|m_i|}(x)`.
    cos_poly: [[F16; DEG + 1]; REGS],
    /// `sin_poly[r][j]` lane `i`: the coefficient of `x^j` in
    /// `−sign(m_i) U_{|m_i|−1}(x)` (0 for `m = 0`), so that `S = y · poly`.
    sin_poly: [[F16; DEG]; REGS],
    x_plus: XPerm,
    x_minus: XPerm,
}

/// Coefficients (lowest first) of the Chebyshev polynomials `T_0 … T_DEG`
/// and `U_0 … U_DEG` (`T_{k+1} = 2x T_k − T_{k−1}`, the same for `U` from
/// `U_0 = 1`, `U_1 = 2x`).
fn chebyshev() -> ([[f64; DEG + 1]; DEG + 1], [[f64; DEG + 1]; DEG + 1]) {
    let mut t = [[0.0; DEG + 1]; DEG + 1];
    let mut u = [[0.0; DEG + 1]; DEG + 1];
    t[0][0] = 1.0;
    t[1][1] = 1.0;
    u[0][0] = 1.0;
    u[1][1] = 2.0;
    for k in 1..DEG {
        for j in 0..=DEG {
            let up = if j > 0 { 2.0 * t[k][j - 1] } else { 0.0 };
            t[k + 1][j] = up - t[k - 1][j];
            let up = if j > 0 { 2.0 * u[k][j - 1] } else { 0.0 };
            u[k + 1][j] = up - u[k - 1][j];
        }
    }
    (t, u)
}

/// `(l, m)` of flat index `i`.
fn lm(i: usize) -> (usize, isize) {
    let l = i.isqrt();
    (l, i as isize - (l * (l + 1)) as isize)
}

/// [`XPerm`] of the band matrices of `x` for the bands from [`first`]`(n)`.
fn x_perm(n: usize, x: &ShRotation<f64>) -> XPerm {
    let mut p = XPerm::default();
    let f0 = first(n);
    for i in f0..n * n {
        let (r, lane) = ((i - f0) / LANES, (i - f0) % LANES);
        let (l, m1) = lm(i);
        let b = (l * (l + 1)) as isize;
        let mut k = 0;
        for m2 in -(l as isize)..=l as isize {
            let v = x.get(l, m1, m2);
            // The fixed matrices' zeros are structural (|v| ~ 1e-17 in f64).
            if v.abs() < 1e-9 {
                continue;
            }
            assert!(
                k < SLOTS,
                "X± row ({l}, {m1}) has more than {SLOTS} non-zeros"
            );
            let j = (b + m2) as usize - f0;
            assert_eq!(j / LANES, r, "band {l} crosses a register");
            p.idx[r][k].0[lane] = (j % LANES) as i32;
            p.w[r][k].0[lane] = v as f32;
            k += 1;
        }
    }
    p
}

impl BandTables {
    fn new(n: usize) -> Self {
        assert!((BANDS_MIN_ORDER..=BANDS_MAX_ORDER).contains(&n));
        let (t, u) = chebyshev();
        let mut s = Self {
            mask: [0; REGS],
            swap: [I16::default(); REGS],
            cos_poly: [[F16::default(); DEG + 1]; REGS],
            sin_poly: [[F16::default(); DEG]; REGS],
            x_plus: XPerm::default(),
            x_minus: XPerm::default(),
        };
        let f0 = first(n);
        for i in f0..n * n {
            let (r, lane) = ((i - f0) / LANES, (i - f0) % LANES);
            let (l, m) = lm(i);
            let am = m.unsigned_abs();
            s.mask[r] |= 1 << lane;
            let mirror = (l * (l + 1)) as isize - m;
            s.swap[r].0[lane] = ((mirror as usize - f0) % LANES) as i32;
            for j in 0..=DEG {
                s.cos_poly[r][j].0[lane] = t[am][j] as f32;
            }
            if am > 0 {
                let sign = -(m.signum() as f64);
                for j in 0..DEG {
                    s.sin_poly[r][j].0[lane] = (sign * u[am - 1][j]) as f32;
                }
            }
        }
        let h = std::f64::consts::FRAC_PI_2;
        let xp = ShRotation::<f64>::from_rotation(
            n,
            &Rot3::from_axis_angle([1.0, 0.0, 0.0], h).expect("unit axis"),
        )
        .expect("order ≤ 6");
        s.x_plus = x_perm(n, &xp);
        s.x_minus = x_perm(n, &xp.inverse());
        s
    }

    /// The cached tables of order `n` (`BANDS_MIN_ORDER ..= BANDS_MAX_ORDER`).
    pub(crate) fn get(n: usize) -> &'static Self {
        static T: [OnceLock<BandTables>; BANDS_MAX_ORDER + 1] =
            [const { OnceLock::new() }; BANDS_MAX_ORDER + 1];
        T[n].get_or_init(|| Self::new(n))
    }
}

// Thin wrappers over the 512-bit intrinsics the stages use, so that the
// stages read as vector algebra.
//
// SAFETY (all): AVX-512F must be enabled in the caller; `F16`/`I16` are
// 64-byte aligned; `load_masked`/`store_masked` touch only the lanes of
// `mask`, which the caller keeps within its slice.
#[inline(always)]
unsafe fn ld(v: &F16) -> __m512 {
    unsafe { _mm512_load_ps(v.0.as_ptr()) }
}
#[inline(always)]
unsafe fn perm(idx: &I16, v: __m512) -> __m512 {
    unsafe { _mm512_permutexvar_ps(_mm512_load_si512(idx.0.as_ptr().cast()), v) }
}
#[inline(always)]
unsafe fn set1(x: f32) -> __m512 {
    unsafe { _mm512_set1_ps(x) }
}
/// `a · b + c`.
#[inline(always)]
unsafe fn fmadd(a: __m512, b: __m512, c: __m512) -> __m512 {
    unsafe { _mm512_fmadd_ps(a, b, c) }
}
#[inline(always)]
unsafe fn mul(a: __m512, b: __m512) -> __m512 {
    unsafe { _mm512_mul_ps(a, b) }
}
#[inline(always)]
unsafe fn load_masked(mask: u16, p: *const f32) -> __m512 {
    unsafe { _mm512_maskz_loadu_ps(mask, p) }
}
#[inline(always)]
unsafe fn store_masked(p: *mut f32, mask: u16, v: __m512) {
    unsafe { _mm512_mask_storeu_ps(p, mask, v) }
}

/// One Z rotation of register `r` by the angle with `cos = x`, `sin = y`.
///
/// # Safety
/// AVX-512F and AVX-512VL must be enabled in the caller.
#[inline(always)]
unsafe fn z_stage<const N: usize>(
    t: &BandTables,
    r: usize,
    (x, y): (f32, f32),
    v: __m512,
) -> __m512 {
    let (cp, sp) = (&t.cos_poly[r], &t.sin_poly[r]);
    // SAFETY: the caller's contract.
    unsafe {
        let (xb, yb) = (set1(x), set1(y));
        // `C` of degree N − 1 (the order's largest |m|), `S / y` of degree
        // N − 2; constant bounds, unrolled.
        let mut c = ld(&cp[N.saturating_sub(1)]);
        for j in (0..N.saturating_sub(1)).rev() {
            c = fmadd(c, xb, ld(&cp[j]));
        }
        let mut s = ld(&sp[N.saturating_sub(2)]);
        for j in (0..N.saturating_sub(2)).rev() {
            s = fmadd(s, xb, ld(&sp[j]));
        }
        let vr = perm(&t.swap[r], v);
        fmadd(vr, mul(s, yb), mul(v, c))
    }
}

/// One fixed X matrix on register `r` (`K` non-zeros per row at most).
///
/// # Safety
/// As [`z_stage`].
#[inline(always)]
unsafe fn x_stage<const K: usize>(p: &XPerm, r: usize, v: __m512) -> __m512 {
    // SAFETY: the caller's contract.
    unsafe {
        let mut o = mul(perm(&p.idx[r][0], v), ld(&p.w[r][0]));
        for k in 1..K {
            o = fmadd(perm(&p.idx[r][k], v), ld(&p.w[r][k]), o);
        }
        o
    }
}

/// `dst[f..N²] = (R_z(α) X₋ R_z(β) X₊ R_z(γ) src)[f..N²]`, `f =`
/// [`first`]`(N)`, with `e = [cos α, sin α, cos β, sin β, cos γ, sin γ]`;
/// `K` is the most non-zeros per row of `X±` at this order (2 for `N = 4`,
/// bands 1–3; else 3).
///
/// # Panics
/// If a slice is shorter than `N²`.
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[inline]
pub(crate) fn rotate_bands<const N: usize, const K: usize>(
    t: &BandTables,
    e: [f32; 6],
    src: &[f32],
    dst: &mut [f32],
) {
    // Not a `const` assertion: the per-order dispatch instantiates this for
    // orders 1–3 too, on a branch that never runs.
    assert!((BANDS_MIN_ORDER..=BANDS_MAX_ORDER).contains(&N) && (1..=SLOTS).contains(&K));
    assert!(
        src.len() >= N * N && dst.len() >= N * N,
        "slices hold N² values"
    );
    let f0 = first(N);
    let regs = (N * N - f0).div_ceil(LANES);
    for r in 0..regs {
        // SAFETY: the features are enabled; the mask selects lanes
        // f0 + 16r + i < N² ≤ len.
        unsafe {
            let v = load_masked(t.mask[r], src.as_ptr().add(f0 + LANES * r));
            let a = z_stage::<N>(t, r, (e[4], e[5]), v);
            let b = x_stage::<K>(&t.x_plus, r, a);
            let c = z_stage::<N>(t, r, (e[2], e[3]), b);
            let d = x_stage::<K>(&t.x_minus, r, c);
            let o = z_stage::<N>(t, r, (e[0], e[1]), d);
            store_masked(dst.as_mut_ptr().add(f0 + LANES * r), t.mask[r], o);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chebyshev_tables_give_multiple_angles() {
        let (t, u) = chebyshev();
        for a in [0.0f64, 0.3, 1.7, 2.9, -1.2] {
            let (y, x) = a.sin_cos();
            for k in 0..=DEG {
                let tk: f64 = (0..=DEG).map(|j| t[k][j] * x.powi(j as i32)).sum();
                assert!((tk - (k as f64 * a).cos()).abs() < 1e-12);
                let uk: f64 = (0..=DEG).map(|j| u[k][j] * x.powi(j as i32)).sum();
                assert!((y * uk - ((k + 1) as f64 * a).sin()).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn writes_only_its_bands_and_matches_the_scalar_kernel() {
        if !crate::fast::tests::avx512_or_skip() {
            return;
        }
        let rot = Rot3::from_euler_zyz(&crate::rotation::EulerZyz::from_angles(0.4f32, 1.1, -2.3));
        let e = crate::rotation::euler_zyz_off_pole(&rot).expect("off the pole");
        let angles = [
            e.cos_alpha,
            e.sin_alpha,
            e.cos_beta,
            e.sin_beta,
            e.cos_gamma,
            e.sin_gamma,
        ];
        for n in BANDS_MIN_ORDER..=BANDS_MAX_ORDER {
            let nn = n * n;
            let src: Vec<f32> = (0..nn + 20)
                .map(|i| ((i * 7919) % 23) as f32 / 23.0 - 0.5)
                .collect();
            let mut dst = vec![f32::NAN; nn + 20];
            // SAFETY: AVX-512F was detected (VL, AVX2 and FMA with it: `isa`).
            unsafe {
                match n {
                    4 => rotate_bands::<4, 2>(BandTables::get(4), angles, &src, &mut dst),
                    5 => rotate_bands::<5, 3>(BandTables::get(5), angles, &src, &mut dst),
                    _ => rotate_bands::<6, 3>(BandTables::get(6), angles, &src, &mut dst),
                }
            }
            let f0 = first(n);
            assert!(
                dst[..f0].iter().chain(&dst[nn..]).all(|v| v.is_nan()),
                "n = {n}"
            );
            let mut want = vec![0.0f32; nn];
            let z = crate::rotation::ZyzRotation::<f32>::new(n).expect("order");
            let mut scratch = vec![0.0f32; nn];
            z.apply_euler_portable(&e, &src[..nn], &mut want, &mut scratch);
            for i in f0..nn {
                assert!(
                    (dst[i] - want[i]).abs() < 2e-6,
                    "n = {n}, i = {i}: {} vs {}",
                    dst[i],
                    want[i]
                );
            }
        }
    }

    #[test]
    fn tables_build_at_every_order() {
        // `x_perm` asserts the slot count and that no band crosses a register.
        for n in BANDS_MIN_ORDER..=BANDS_MAX_ORDER {
            let t = BandTables::get(n);
            let lanes: u32 = t.mask.iter().map(|m| m.count_ones()).sum();
            assert_eq!(lanes as usize, n * n - first(n));
            // The dispatch in `fast` runs order 4 with two slots: the rows
            // of bands 1–3 have at most two non-zeros.
            if n == 4 {
                for x in [&t.x_plus, &t.x_minus] {
                    assert!(x.w[0][2].0.iter().all(|&w| w == 0.0));
                }
            }
        }
    }
}
