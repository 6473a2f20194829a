//! The ZYZ ("ZXZXZ") rotation at orders 7…10 for CPUs with AVX2 + FMA but
//! no AVX-512F (where [`crate::simd`]'s register-resident kernels do not
//! run), f32, detected at run time.
//!
//! The two fixed X matrices `R_x(±90°)` dominate the ZYZ rotation
//! (Křivánek et al. 2006 §2.2): at order 10 each has several hundred
//! non-zeros. Here they are applied in column form over 8-lane registers —
//! for every 8-row piece of a column that holds a non-zero, one broadcast of
//! the input coefficient and one fused multiply-add — instead of the
//! portable row-by-row sparse dot products with their index loads. The three
//! Z rotations (Appendix C) turn each band's pairs `(c_{l,m}, c_{l,−m})`,
//! `m = 1…8`, with one masked load, one lane reversal and one masked store per
//! half-band (`cos mα, sin mα` by the multiple-angle recurrence, once per Z);
//! the pair `m = 9` of order 10 is scalar.
//! Below order 7 the generated straight-line kernels of [`crate::fast`] are
//! faster and keep running.
//!
//! The masked band stores defeat store-to-load forwarding for the next
//! step's loads; here that costs less than it saves (order 10: 2.8× faster
//! than the portable path), but the same Z rotation made the RGB Taylor
//! rotation slower than its unrolled portable loops, so it is not used there.

// Off x86-64 only the portable code runs.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code, unused_imports))]

use std::sync::OnceLock;

use crate::Real;
use crate::rotation::{EulerZyz, Rot3, ShRotation};

/// Lowest and highest order this kernel serves.
pub(crate) const AVX2_ZYZ_ORDERS: std::ops::RangeInclusive<usize> = 7..=10;
/// Lanes per register.
const LANES: usize = 8;
/// Padded length of an order-10 vector (100 coefficients → 13 registers).
const PADDED: usize = 104;

/// Eight f32, 32-byte aligned (one AVX2 register's worth).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
struct F8([f32; LANES]);

/// A fixed matrix in column pieces: register `k` of the output sums
/// `x[cols[p]] · vals[p]` over `p ∈ start[k]..start[k+1]`, where `vals[p]` are
/// the 8 rows of that column falling in register `k` (all-zero pieces
/// dropped).
#[derive(Clone, Debug)]
struct Pieces8 {
    start: Vec<usize>,
    cols: Vec<u32>,
    vals: Vec<F8>,
}

impl Pieces8 {
    fn from_rotation(r: &ShRotation<f64>) -> Self {
        let nv = (r.order() * r.order()).div_ceil(LANES);
        let (start, cols, vals) = crate::simd::column_pieces::<LANES>(r, nv);
        Self {
            start,
            cols,
            vals: vals.into_iter().map(F8).collect(),
        }
    }
}

/// The X matrices of one order.
#[derive(Clone, Debug)]
struct Plan {
    n: usize,
    x_plus: Pieces8,
    x_minus: Pieces8,
}

impl Plan {
    fn new(n: usize) -> Self {
        let xp = Rot3::from_axis_angle([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2)
            .and_then(|r| ShRotation::<f64>::from_rotation(n, &r))
            .expect("order ≤ 10");
        let xm = xp.inverse();
        Self {
            n,
            x_plus: Pieces8::from_rotation(&xp),
            x_minus: Pieces8::from_rotation(&xm),
        }
    }
}

/// The cached plan when this kernel applies (order in [`AVX2_ZYZ_ORDERS`],
/// the kernels' level is AVX2 exactly — with AVX-512F [`crate::simd`] runs).
#[inline]
fn plan_if_available(order: usize) -> Option<&'static Plan> {
    static PLANS: [OnceLock<Plan>; 11] = [const { OnceLock::new() }; 11];
    if !AVX2_ZYZ_ORDERS.contains(&order) || crate::isa::isa() != crate::isa::Isa::Avx2 {
        return None;
    }
    Some(PLANS[order].get_or_init(|| Plan::new(order)))
}

/// `dst = R_z(α) R_x(−90°) R_z(β) R_x(90°) R_z(γ) src` when this kernel
/// applies (f32, AVX2 level, orders 7…10); `false`, nothing written, otherwise.
#[inline]
pub(crate) fn try_zyz<T: Real>(order: usize, e: &EulerZyz<T>, src: &[T], dst: &mut [T]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let (Some(src), Some(dst)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst))
        && let Some(p) = plan_if_available(order)
    {
        let f = |v: T| v.to_f64() as f32;
        let e = EulerZyz {
            cos_alpha: f(e.cos_alpha),
            sin_alpha: f(e.sin_alpha),
            cos_beta: f(e.cos_beta),
            sin_beta: f(e.sin_beta),
            cos_gamma: f(e.cos_gamma),
            sin_gamma: f(e.sin_gamma),
        };
        assert!(
            src.len() >= order * order && dst.len() >= order * order,
            "SH vector shorter than order²"
        );
        // SAFETY: `plan_if_available` checked that the level is AVX2 (+FMA),
        // which `isa` never reports above what the CPU has.
        unsafe { x86::zyz(p, &e, src, dst) };
        return true;
    }
    let _ = (order, e, src, dst);
    false
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{F8, LANES, PADDED, Pieces8, Plan};
    use crate::rotation::EulerZyz;
    use std::arch::x86_64::*;

    /// `y = M x` for a matrix in column pieces, four accumulators per register.
    #[inline(always)]
    unsafe fn apply_columns(m: &Pieces8, nv: usize, x: &[f32], y: &mut [f32]) {
        assert!(x.len() >= PADDED && y.len() >= PADDED);
        // SAFETY (whole body): the caller has AVX2 + FMA; every column index is
        // `< n² ≤ PADDED ≤ x.len()` and every register `k < nv ≤ PADDED / 8`.
        unsafe {
            let xs = x.as_ptr();
            for k in 0..nv {
                let (s, e) = (m.start[k], m.start[k + 1]);
                let (cols, vals) = (&m.cols[s..e], &m.vals[s..e]);
                let mut acc = [_mm256_setzero_ps(); 4];
                let mut it = cols.chunks_exact(4).zip(vals.chunks_exact(4));
                for (c, v) in &mut it {
                    for q in 0..4 {
                        let xj = _mm256_broadcast_ss(&*xs.add(c[q] as usize));
                        acc[q] = _mm256_fmadd_ps(xj, ld(&v[q]), acc[q]);
                    }
                }
                let rest = cols.len() % 4;
                let base = cols.len() - rest;
                for q in 0..rest {
                    let xj = _mm256_broadcast_ss(&*xs.add(cols[base + q] as usize));
                    acc[q] = _mm256_fmadd_ps(xj, ld(&vals[base + q]), acc[q]);
                }
                let sum =
                    _mm256_add_ps(_mm256_add_ps(acc[0], acc[1]), _mm256_add_ps(acc[2], acc[3]));
                _mm256_storeu_ps(y.as_mut_ptr().add(k * LANES), sum);
            }
        }
    }

    #[inline(always)]
    unsafe fn ld(v: &F8) -> __m256 {
        // SAFETY: `F8` is 8 aligned f32; the caller has AVX2.
        unsafe { _mm256_load_ps(v.0.as_ptr()) }
    }

    /// Leading zero lanes of the work buffers (the negative half of band 1
    /// is loaded from eight lanes below its start).
    const LEAD: usize = LANES;
    /// A work buffer: `LEAD` zeros, the padded vector, one spare register.
    type Buf = [f32; LEAD + PADDED + LANES];

    /// Lane masks: the first `h` lanes, and the last `h` lanes (`h ≤ 8`).
    #[inline(always)]
    unsafe fn masks(h: usize) -> (__m256i, __m256i) {
        // SAFETY (whole body): the caller has AVX2.
        unsafe {
            let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            let h = _mm256_set1_epi32(h as i32);
            let first = _mm256_cmpgt_epi32(h, lane);
            let last = _mm256_cmpgt_epi32(_mm256_add_epi32(lane, h), _mm256_set1_epi32(7));
            (first, last)
        }
    }

    /// `y = R_z(α) x` on buffers (coefficient `i` at `LEAD + i`); `x` and `y`
    /// may be the same buffer (each band is read before it is written).
    #[inline(always)]
    unsafe fn rot_z(n: usize, ca: f32, sa: f32, x: *const f32, y: *mut f32) {
        // SAFETY (whole body): the caller has AVX2 + FMA and passes buffers of
        // type `Buf`; every access is inside `[b − 8, b + 8]` of a band start
        // `b = l(l+1) ≤ 90`, shifted by `LEAD`, so inside the buffer.
        unsafe {
            let (mut c, mut s) = ([0.0f32; 10], [0.0f32; 10]);
            (c[0], s[0]) = (1.0, 0.0);
            (c[1], s[1]) = (ca, sa);
            for m in 2..10 {
                c[m] = 2.0 * ca * c[m - 1] - c[m - 2];
                s[m] = 2.0 * ca * s[m - 1] - s[m - 2];
            }
            let cv = _mm256_loadu_ps(c.as_ptr().add(1));
            let sv = _mm256_loadu_ps(s.as_ptr().add(1));
            let rev = _mm256_setr_epi32(7, 6, 5, 4, 3, 2, 1, 0);
            let (x, y) = (x.add(LEAD), y.add(LEAD));
            *y = *x;
            for l in 1..n {
                let b = l * (l + 1);
                let h = l.min(LANES);
                let (first, last) = masks(h);
                // Lane j: m = j + 1.
                let p = _mm256_maskload_ps(x.add(b + 1), first);
                let q =
                    _mm256_permutevar8x32_ps(_mm256_maskload_ps(x.add(b).sub(LANES), last), rev);
                let tail = (l > LANES).then(|| (*x.add(b + 9), *x.add(b - 9)));
                let xc = *x.add(b);
                let yp = _mm256_fmsub_ps(p, cv, _mm256_mul_ps(q, sv));
                let yq = _mm256_fmadd_ps(q, cv, _mm256_mul_ps(p, sv));
                _mm256_maskstore_ps(y.add(b + 1), first, yp);
                _mm256_maskstore_ps(y.add(b).sub(LANES), last, _mm256_permutevar8x32_ps(yq, rev));
                *y.add(b) = xc;
                if let Some((pp, qq)) = tail {
                    *y.add(b + 9) = pp * c[9] - qq * s[9];
                    *y.add(b - 9) = qq * c[9] + pp * s[9];
                }
            }
        }
    }

    /// The ZYZ rotation of one f32 vector (`src`, `dst`: at least `n²`).
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn zyz(p: &Plan, e: &EulerZyz<f32>, src: &[f32], dst: &mut [f32]) {
        let n = p.n;
        let nn = n * n;
        let nv = nn.div_ceil(LANES);
        let mut a: Buf = [0.0; LEAD + PADDED + LANES];
        let mut b: Buf = [0.0; LEAD + PADDED + LANES];
        a[LEAD..LEAD + nn].copy_from_slice(&src[..nn]);
        // SAFETY: AVX2 + FMA are enabled here; the buffers are `Buf`s.
        unsafe {
            rot_z(n, e.cos_gamma, e.sin_gamma, a.as_ptr(), b.as_mut_ptr());
            apply_columns(&p.x_plus, nv, &b[LEAD..], &mut a[LEAD..]);
            let ap = a.as_mut_ptr();
            rot_z(n, e.cos_beta, e.sin_beta, ap, ap);
            apply_columns(&p.x_minus, nv, &a[LEAD..], &mut b[LEAD..]);
            rot_z(n, e.cos_alpha, e.sin_alpha, b.as_ptr(), a.as_mut_ptr());
        }
        dst[..nn].copy_from_slice(&a[LEAD..LEAD + nn]);
    }
}

#[cfg(test)]
mod tests {
    use crate::rotation::tests::{rand_rot, rand_vec};
    use crate::rotation::{ShRotation, ZyzRotation};

    /// The AVX2 kernel (when the CPU has AVX2) agrees with the exact
    /// Ivanic–Ruedenberg matrix at every order it serves, including
    /// rotations near the poles (β ≈ 0, π).
    #[test]
    fn avx2_zyz_matches_the_exact_matrix() {
        if crate::isa::detected_isa() < crate::isa::Isa::Avx2 {
            eprintln!("no AVX2 here: the portable path alone runs");
            return;
        }
        let angles = [1e-4, 0.3, 1.7, std::f64::consts::PI - 1e-4];
        for order in super::AVX2_ZYZ_ORDERS {
            let plan = super::Plan::new(order);
            let zyz = ZyzRotation::<f32>::new(order).unwrap();
            for (seed, beta) in angles.iter().enumerate() {
                let r = rand_rot(seed as u64 + 7)
                    .mul(&crate::rotation::Rot3::from_axis_angle([0.0, 1.0, 0.0], *beta).unwrap());
                let exact = ShRotation::from_rotation(order, &r).unwrap();
                let src = rand_vec(seed as u64, order * order);
                let mut want = vec![0.0; order * order];
                exact.apply(&src, &mut want);
                let s32: Vec<f32> = src.iter().map(|v| *v as f32).collect();
                let mut got = vec![0.0f32; order * order];
                let e = r.to_f32().euler_zyz();
                // SAFETY: the CPU has AVX2 + FMA (checked above).
                unsafe { super::x86::zyz(&plan, &e, &s32, &mut got) };
                let mut portable = vec![0.0f32; order * order];
                let mut scratch = vec![0.0f32; order * order];
                zyz.apply_euler_portable(&e, &s32, &mut portable, &mut scratch);
                for i in 0..order * order {
                    assert!(
                        (f64::from(got[i]) - want[i]).abs() < 2e-5,
                        "order {order} β {beta} [{i}]: {} vs {}",
                        got[i],
                        want[i]
                    );
                    assert!((got[i] - portable[i]).abs() < 2e-5);
                }
            }
        }
    }
}
