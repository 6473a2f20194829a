//! AVX2 + FMA kernels of [`crate::shade`]: eight pixels per step, one light
//! at a time, the same arithmetic as [`crate::model::FogModel::surface_terms`]
//! and [`crate::fast`] (tested to agree with the scalar path). Bilinear
//! table lookups read each lane's cell with one 16-byte load
//! ([`crate::table::Table2::quads`]) and 1D lookups a pair with one 8-byte
//! load, transposed into lanes; nearest lookups gather. Only compiled on
//! x86-64 and only called after run-time feature detection.

#![cfg(target_arch = "x86_64")]
#![allow(unsafe_op_in_unsafe_fn, clippy::too_many_arguments)]

use crate::model::{
    CANCELLATION_RATIO, EYE_TAIL_INTERVALS, GAUSS6_W, GAUSS6_X, MIN_ANGLE, MIN_DISTANCE,
    PreparedLight,
};
use crate::shade::{MaterialConst, PixelBatch};
use crate::table::{CORNER_SAMPLES, FogTables, Table2};
use std::arch::x86_64::*;
use std::f32::consts::{FRAC_PI_2, LN_2, LOG2_E};

/// Largest table side the gathers index with i32 (size² < 2³¹).
pub const MAX_GATHER_SIZE: usize = 16384;

#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn splat(x: f32) -> __m256 {
    _mm256_set1_ps(x)
}

/// [`crate::fast::exp2`], eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn exp2(y: __m256) -> __m256 {
    let y = _mm256_max_ps(_mm256_min_ps(y, splat(127.0)), splat(-126.0));
    let k = _mm256_floor_ps(_mm256_add_ps(y, splat(0.5)));
    let f = _mm256_mul_ps(_mm256_sub_ps(y, k), splat(LN_2));
    let mut p = splat(1.0 / 720.0);
    for c in [1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
        p = _mm256_fmadd_ps(p, f, splat(c));
    }
    let ki = _mm256_add_epi32(_mm256_cvtps_epi32(k), _mm256_set1_epi32(127));
    _mm256_mul_ps(p, _mm256_castsi256_ps(_mm256_slli_epi32(ki, 23)))
}

/// [`crate::fast::exp`], eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn exp(x: __m256) -> __m256 {
    let y = _mm256_max_ps(
        _mm256_min_ps(_mm256_mul_ps(x, splat(LOG2_E)), splat(127.0)),
        splat(-126.0),
    );
    let k = _mm256_floor_ps(_mm256_add_ps(y, splat(0.5)));
    let x = _mm256_max_ps(_mm256_min_ps(x, splat(88.0)), splat(-88.0));
    let r = _mm256_fnmadd_ps(k, splat(0.693_145_75), x);
    let r = _mm256_fnmadd_ps(k, splat(1.428_606_8e-6), r);
    let mut p = splat(1.0 / 5040.0);
    for c in [
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
        1.0,
    ] {
        p = _mm256_fmadd_ps(p, r, splat(c));
    }
    let ki = _mm256_add_epi32(_mm256_cvtps_epi32(k), _mm256_set1_epi32(127));
    _mm256_mul_ps(p, _mm256_castsi256_ps(_mm256_slli_epi32(ki, 23)))
}

/// [`crate::fast::log2`], eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn log2(x: __m256) -> __m256 {
    let x = _mm256_max_ps(x, splat(f32::MIN_POSITIVE));
    let bits = _mm256_castps_si256(x);
    let off = _mm256_sub_epi32(bits, _mm256_set1_epi32(0x3f35_04f3));
    let e = _mm256_srai_epi32(off, 23);
    let m = _mm256_castsi256_ps(_mm256_sub_epi32(bits, _mm256_slli_epi32(e, 23)));
    let s = _mm256_div_ps(_mm256_sub_ps(m, splat(1.0)), _mm256_add_ps(m, splat(1.0)));
    let s2 = _mm256_mul_ps(s, s);
    let mut p = splat(2.0 / 9.0);
    for c in [2.0 / 7.0, 2.0 / 5.0, 2.0 / 3.0, 2.0] {
        p = _mm256_fmadd_ps(p, s2, splat(c));
    }
    _mm256_fmadd_ps(_mm256_mul_ps(p, s), splat(LOG2_E), _mm256_cvtepi32_ps(e))
}

/// [`crate::fast::atan2_pos`], eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn atan2_pos(y: __m256, x: __m256) -> __m256 {
    let mn = _mm256_min_ps(y, x);
    let mx = _mm256_max_ps(_mm256_max_ps(y, x), splat(1e-30));
    let a = _mm256_div_ps(mn, mx);
    let s = _mm256_mul_ps(a, a);
    let mut p = splat(-0.011_721_2);
    for c in [
        0.052_653_32,
        -0.116_432_87,
        0.193_543_46,
        -0.332_623_47,
        0.999_977_26,
    ] {
        p = _mm256_fmadd_ps(p, s, splat(c));
    }
    let r = _mm256_mul_ps(a, p);
    let swap = _mm256_cmp_ps(y, x, _CMP_GT_OQ);
    _mm256_blendv_ps(r, _mm256_sub_ps(splat(FRAC_PI_2), r), swap)
}

/// Clamped texel coordinate: (integer part ≤ size − 2, fraction).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn texel(x: __m256, s: f32, o: f32, last: f32) -> (__m256i, __m256) {
    // max/min with the constant second: NaN → 0 (as the scalar lookup).
    let f = _mm256_min_ps(
        _mm256_max_ps(_mm256_fmadd_ps(x, splat(s), splat(o)), splat(0.0)),
        splat(last),
    );
    let i = _mm256_min_epi32(_mm256_cvttps_epi32(f), _mm256_set1_epi32(last as i32 - 1));
    (i, _mm256_sub_ps(f, _mm256_cvtepi32_ps(i)))
}

/// [`crate::fast::atan2_precise`], eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn atan2_precise(y: __m256, x: __m256) -> __m256 {
    let t = atan2_pos(y, x);
    let (s, c) = sin_cos(t);
    let num = _mm256_fmsub_ps(y, c, _mm256_mul_ps(x, s));
    let den = _mm256_fmadd_ps(x, c, _mm256_mul_ps(y, s));
    _mm256_add_ps(t, _mm256_div_ps(num, den))
}

/// [`crate::fast::atan_ratio`], eight lanes (x > 0).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn atan_ratio(y: __m256, x: __m256) -> __m256 {
    let sign = _mm256_and_ps(y, splat(-0.0));
    let a = atan2_precise(_mm256_andnot_ps(splat(-0.0), y), x);
    _mm256_or_ps(a, sign)
}

/// [`crate::fast::sin_cos`], eight lanes (|x| ≤ π/2).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn sin_cos(x: __m256) -> (__m256, __m256) {
    let x2 = _mm256_mul_ps(x, x);
    let mut s = splat(-1.0 / 39_916_800.0);
    for c in [1.0 / 362_880.0, -1.0 / 5040.0, 1.0 / 120.0, -1.0 / 6.0, 1.0] {
        s = _mm256_fmadd_ps(s, x2, splat(c));
    }
    let mut c = splat(1.0 / 479_001_600.0);
    for k in [
        -1.0 / 3_628_800.0,
        1.0 / 40320.0,
        -1.0 / 720.0,
        1.0 / 24.0,
        -0.5,
        1.0,
    ] {
        c = _mm256_fmadd_ps(c, x2, splat(k));
    }
    (_mm256_mul_ps(s, x), c)
}

/// [`crate::model::FogModel::segment_gauss`], eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn segment_gauss(ctx: &Ctx, along: __m256, h: __m256, d_vp: __m256) -> __m256 {
    let th0 = atan_ratio(_mm256_sub_ps(_mm256_setzero_ps(), along), h);
    let y = _mm256_mul_ps(d_vp, h);
    let x = _mm256_fnmadd_ps(along, _mm256_sub_ps(d_vp, along), _mm256_mul_ps(h, h));
    let a = atan2_precise(y, _mm256_andnot_ps(splat(-0.0), x));
    let neg = _mm256_cmp_ps(x, _mm256_setzero_ps(), _CMP_LT_OQ);
    let dth = _mm256_blendv_ps(a, _mm256_sub_ps(splat(std::f32::consts::PI), a), neg);
    let half = _mm256_mul_ps(splat(0.5), dth);
    let mid = _mm256_add_ps(th0, half);
    let mut s = _mm256_setzero_ps();
    let mbeta = splat(-ctx.beta);
    for (x, w) in GAUSS6_X.iter().zip(GAUSS6_W) {
        let (sn, cs) = sin_cos(_mm256_fmadd_ps(half, splat(*x), mid));
        let inv_c = _mm256_div_ps(splat(1.0), _mm256_max_ps(cs, splat(1e-30)));
        let t_plus_d = _mm256_fmadd_ps(
            _mm256_mul_ps(h, _mm256_add_ps(splat(1.0), sn)),
            inv_c,
            along,
        );
        let c = _mm256_sub_ps(_mm256_setzero_ps(), sn);
        let mut k = _mm256_setzero_ps();
        for &pw in ctx.phase.iter().rev() {
            k = _mm256_fmadd_ps(k, c, splat(pw));
        }
        s = _mm256_fmadd_ps(
            _mm256_mul_ps(splat(w), k),
            exp(_mm256_mul_ps(mbeta, t_plus_d)),
            s,
        );
    }
    let r = _mm256_div_ps(
        _mm256_mul_ps(
            _mm256_mul_ps(splat(ctx.sigma_s / (4.0 * std::f32::consts::PI)), half),
            s,
        ),
        h,
    );
    _mm256_max_ps(r, _mm256_setzero_ps())
}

/// [`Table2::bilinear`] (or [`Table2::nearest`]), eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn lookup<const NEAREST: bool>(t: &Table2, x: __m256, y: __m256) -> __m256 {
    let (sx, ox, sy, oy, last) = t.affine();
    let size = t.size() as i32;
    let base = t.values().as_ptr();
    if NEAREST {
        let fx = _mm256_min_ps(
            _mm256_max_ps(_mm256_fmadd_ps(x, splat(sx), splat(ox)), splat(0.0)),
            splat(last),
        );
        let fy = _mm256_min_ps(
            _mm256_max_ps(_mm256_fmadd_ps(y, splat(sy), splat(oy)), splat(0.0)),
            splat(last),
        );
        let ix = _mm256_cvttps_epi32(_mm256_add_ps(fx, splat(0.5)));
        let iy = _mm256_cvttps_epi32(_mm256_add_ps(fy, splat(0.5)));
        let n1 = _mm256_set1_epi32(size - 1);
        let i = _mm256_add_epi32(
            _mm256_mullo_epi32(_mm256_min_epi32(iy, n1), _mm256_set1_epi32(size)),
            _mm256_min_epi32(ix, n1),
        );
        // SAFETY: both indices ≤ size − 1, so i < size² = values.len().
        return _mm256_i32gather_ps::<4>(base, i);
    }
    let (ix, tx) = texel(x, sx, ox, last);
    let (iy, ty) = texel(y, sy, oy, last);
    let i = _mm256_add_epi32(_mm256_mullo_epi32(iy, _mm256_set1_epi32(size)), ix);
    let (v00, v01, v10, v11) = cell_corners(t.quads(), i);
    let a = _mm256_fmadd_ps(_mm256_sub_ps(v01, v00), tx, v00);
    let b = _mm256_fmadd_ps(_mm256_sub_ps(v11, v10), tx, v10);
    _mm256_fmadd_ps(_mm256_sub_ps(b, a), ty, a)
}

/// The four corners of cell `i` of eight lanes from [`Table2::quads`]: one
/// 16-byte load per lane and a 4 × 8 transpose (fewer operations than
/// four eight-lane gathers).
///
/// # Safety
/// AVX2; every lane of `i` < size² (ix, iy ≤ size − 2).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn cell_corners(quads: &[f32], i: __m256i) -> (__m256, __m256, __m256, __m256) {
    let mut at = [0i32; 8];
    _mm256_storeu_si256(at.as_mut_ptr().cast(), i);
    let q = quads.as_ptr();
    debug_assert!(at.iter().all(|&k| (k as usize) < quads.len() / 4));
    // SAFETY: each index < size², quads holds 4 · size² values.
    let load = |k: usize| _mm_loadu_ps(q.add(4 * at[k] as usize));
    let pair =
        |a: usize, b: usize| _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(load(a)), load(b));
    // Row r holds lane r's corners in its low half, lane r + 4's in its high.
    let (r0, r1, r2, r3) = (pair(0, 4), pair(1, 5), pair(2, 6), pair(3, 7));
    let t0 = _mm256_castps_pd(_mm256_unpacklo_ps(r0, r1));
    let t1 = _mm256_castps_pd(_mm256_unpackhi_ps(r0, r1));
    let t2 = _mm256_castps_pd(_mm256_unpacklo_ps(r2, r3));
    let t3 = _mm256_castps_pd(_mm256_unpackhi_ps(r2, r3));
    (
        _mm256_castpd_ps(_mm256_unpacklo_pd(t0, t2)),
        _mm256_castpd_ps(_mm256_unpackhi_pd(t0, t2)),
        _mm256_castpd_ps(_mm256_unpacklo_pd(t1, t3)),
        _mm256_castpd_ps(_mm256_unpackhi_pd(t1, t3)),
    )
}

/// Entries `i` and `i + 1` of `values` for eight lanes: one 8-byte load
/// per lane and two shuffles (fewer operations than two eight-lane
/// gathers).
///
/// # Safety
/// AVX2; every lane of `i` ≤ `values.len()` − 2.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn neighbours(values: &[f32], i: __m256i) -> (__m256, __m256) {
    let mut at = [0i32; 8];
    _mm256_storeu_si256(at.as_mut_ptr().cast(), i);
    let v = values.as_ptr();
    debug_assert!(at.iter().all(|&k| (k as usize) + 1 < values.len()));
    // SAFETY: each index + 1 < values.len().
    let load = |k: usize| _mm_load_sd(v.add(at[k] as usize).cast());
    let two = |a: usize, b: usize| _mm_unpacklo_pd(load(a), load(b));
    let r0 = _mm256_castpd_ps(_mm256_insertf128_pd::<1>(
        _mm256_castpd128_pd256(two(0, 1)),
        two(4, 5),
    ));
    let r1 = _mm256_castpd_ps(_mm256_insertf128_pd::<1>(
        _mm256_castpd128_pd256(two(2, 3)),
        two(6, 7),
    ));
    (
        _mm256_shuffle_ps::<0b10_00_10_00>(r0, r1),
        _mm256_shuffle_ps::<0b11_01_11_01>(r0, r1),
    )
}

/// [`FogTables::corner`], eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn corner(t: &FogTables, c: __m256) -> __m256 {
    let last = (CORNER_SAMPLES - 1) as f32;
    let x = _mm256_div_ps(c, _mm256_add_ps(splat(1.0), c));
    let x = _mm256_mul_ps(
        _mm256_min_ps(_mm256_max_ps(x, splat(0.0)), splat(1.0)),
        splat(last),
    );
    let i = _mm256_min_epi32(
        _mm256_cvttps_epi32(x),
        _mm256_set1_epi32(CORNER_SAMPLES as i32 - 2),
    );
    let f = _mm256_sub_ps(x, _mm256_cvtepi32_ps(i));
    // i + 1 ≤ CORNER_SAMPLES − 1 < corner_values().len().
    let (a, b) = neighbours(t.corner_values(), i);
    _mm256_fmadd_ps(_mm256_sub_ps(b, a), f, a)
}

/// The per-frame view of the model the kernels need.
pub struct Ctx<'a> {
    /// Extinction β.
    pub beta: f32,
    /// Scattering σ_s = albedo · β.
    pub sigma_s: f32,
    pub tables: &'a FogTables,
    pub tails: &'a [Table2],
    pub phase: &'a [f32],
    pub g_lambert: Option<&'a Table2>,
}

#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn ld(v: &[f32], i: usize) -> __m256 {
    debug_assert!(i + 8 <= v.len());
    _mm256_loadu_ps(v.as_ptr().add(i))
}

#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn store(v: &mut [f32], i: usize, x: __m256) {
    debug_assert!(i + 8 <= v.len());
    _mm256_storeu_ps(v.as_mut_ptr().add(i), x);
}

#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn add_to(v: &mut [f32], i: usize, x: __m256) {
    debug_assert!(i + 8 <= v.len());
    let p = v.as_mut_ptr().add(i);
    _mm256_storeu_ps(p, _mm256_add_ps(_mm256_loadu_ps(p), x));
}

/// [`crate::model::half_angle`], eight lanes: (s, 1 + cos γ, v).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn half_angle(inv_d: __m256, along: __m256, h: __m256) -> (__m256, __m256, __m256) {
    let one = splat(1.0);
    let s = _mm256_min_ps(_mm256_mul_ps(h, inv_d), one);
    let c = _mm256_min_ps(_mm256_max_ps(_mm256_mul_ps(along, inv_d), splat(-1.0)), one);
    let back = _mm256_div_ps(_mm256_mul_ps(s, s), _mm256_sub_ps(one, c));
    let ge = _mm256_cmp_ps(c, splat(0.0), _CMP_GE_OQ);
    let opc = _mm256_max_ps(
        _mm256_blendv_ps(back, _mm256_add_ps(one, c), ge),
        splat(1e-30),
    );
    (s, opc, atan2_pos(s, opc))
}

/// N(u, v) q R(w, v) of `l_inf_kernel`, eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn l_inf<const NEAREST: bool>(
    ctx: &Ctx,
    inv_d: __m256,
    along: __m256,
    h: __m256,
    u: __m256,
    w: __m256,
) -> __m256 {
    let (s, opc, v) = half_angle(inv_d, along, h);
    let cos2v = _mm256_mul_ps(splat(0.5), opc);
    let cosv = _mm256_sqrt_ps(cos2v);
    let q = corner(ctx.tables, _mm256_div_ps(_mm256_mul_ps(u, s), opc));
    let mut r = _mm256_setzero_ps();
    for (k, t) in ctx.phase.iter().zip(ctx.tails) {
        r = _mm256_fmadd_ps(splat(*k), lookup::<NEAREST>(t, w, v), r);
    }
    _mm256_mul_ps(
        _mm256_div_ps(cos2v, _mm256_add_ps(cosv, u)),
        _mm256_mul_ps(q, r),
    )
}

/// [`PreparedLight::eye_tail`], eight lanes (the same arithmetic).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn eye_tail(light: &PreparedLight, along: __m256, h: __m256) -> __m256 {
    let (_, _, v) = half_angle(splat(1.0 / light.d_sv), along, h);
    let x = _mm256_add_ps(
        v,
        _mm256_div_ps(
            _mm256_mul_ps(splat(light.eye_tail_kc), v),
            _mm256_add_ps(v, splat(light.eye_tail_c)),
        ),
    );
    // max/min with the constant second: NaN → 0 (as the scalar lookup).
    let x = _mm256_min_ps(
        _mm256_max_ps(_mm256_mul_ps(x, splat(light.eye_tail_scale)), splat(0.0)),
        splat(EYE_TAIL_INTERVALS as f32),
    );
    let i = _mm256_min_epi32(
        _mm256_cvttps_epi32(x),
        _mm256_set1_epi32(EYE_TAIL_INTERVALS as i32 - 1),
    );
    let f = _mm256_sub_ps(x, _mm256_cvtepi32_ps(i));
    debug_assert_eq!(light.eye_tail.len(), EYE_TAIL_INTERVALS + 1);
    // 0 ≤ i ≤ EYE_TAIL_INTERVALS − 1, the table has EYE_TAIL_INTERVALS + 1
    // entries.
    let (t0, t1) = neighbours(&light.eye_tail, i);
    _mm256_fmadd_ps(_mm256_sub_ps(t1, t0), f, t0)
}

/// Adds every light's complete model to pixels `start..start + m` of
/// `lanes`, m = ⌊(end − start)/8⌋·8 (the caller does the rest); returns m.
///
/// # Safety
/// The CPU must support AVX2 and FMA; every table side ≤ [`MAX_GATHER_SIZE`];
/// `end` ≤ `lanes.len()`.
#[target_feature(enable = "avx2,fma")]
pub unsafe fn surface_run<const NEAREST: bool>(
    ctx: &Ctx,
    lights: &[PreparedLight],
    mat: &MaterialConst,
    lanes: &mut PixelBatch,
    start: usize,
    end: usize,
) -> usize {
    if mat.kd == glam::Vec3::ZERO && mat.ks == glam::Vec3::ZERO {
        surface_run_impl::<NEAREST, false>(ctx, lights, mat, lanes, start, end)
    } else {
        surface_run_impl::<NEAREST, true>(ctx, lights, mat, lanes, start, end)
    }
}

/// [`surface_run`]; `SURFACE = false` for a surface that reflects nothing
/// (kd = ks = 0, the fog ball's edge behind empty pixels): only the
/// airlight term, without the G lookups and the Phong power whose
/// products with zero the full kernel would add (the same sums where they
/// are finite, as they always are: d ≥ MIN_DISTANCE, μ clamped).
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn surface_run_impl<const NEAREST: bool, const SURFACE: bool>(
    ctx: &Ctx,
    lights: &[PreparedLight],
    mat: &MaterialConst,
    lanes: &mut PixelBatch,
    start: usize,
    end: usize,
) -> usize {
    let m = end.saturating_sub(start) / 8 * 8;
    let stop = start + m;
    let beta = splat(ctx.beta);
    let beta_2pi = splat(ctx.sigma_s / (2.0 * std::f32::consts::PI));
    let one = splat(1.0);
    let zero = _mm256_setzero_ps();
    let phong_n = splat(mat.n);
    for light in lights {
        let (lx0, ly0, lz0) = (
            splat(light.position.x),
            splat(light.position.y),
            splat(light.position.z),
        );
        let (tx, ty, tz) = (
            splat(light.to_light.x),
            splat(light.to_light.y),
            splat(light.to_light.z),
        );
        let h_min_sv = splat(light.h_min_sv);
        let li = light.intensity;
        let kd = [
            splat(mat.kd.x * li.x),
            splat(mat.kd.y * li.y),
            splat(mat.kd.z * li.z),
        ];
        let ks = [
            splat(mat.ks.x * li.x),
            splat(mat.ks.y * li.y),
            splat(mat.ks.z * li.z),
        ];
        let il = [splat(li.x), splat(li.y), splat(li.z)];
        let mut i = start;
        while i < stop {
            let (px, py, pz) = (ld(&lanes.px, i), ld(&lanes.py, i), ld(&lanes.pz, i));
            let (dx, dy, dz) = (ld(&lanes.dx, i), ld(&lanes.dy, i), ld(&lanes.dz, i));
            let lx = _mm256_sub_ps(lx0, px);
            let ly = _mm256_sub_ps(ly0, py);
            let lz = _mm256_sub_ps(lz0, pz);
            let d2 = _mm256_fmadd_ps(lx, lx, _mm256_fmadd_ps(ly, ly, _mm256_mul_ps(lz, lz)));
            let d2 = _mm256_max_ps(d2, splat(MIN_DISTANCE * MIN_DISTANCE));
            let d_sp = _mm256_sqrt_ps(d2);
            let inv_d = _mm256_div_ps(one, d_sp);
            let t_sp = _mm256_mul_ps(beta, d_sp);
            let e_sp = exp(_mm256_sub_ps(zero, t_sp));
            let along = _mm256_fmadd_ps(tx, dx, _mm256_fmadd_ps(ty, dy, _mm256_mul_ps(tz, dz)));
            let cx = _mm256_fmsub_ps(ty, dz, _mm256_mul_ps(tz, dy));
            let cy = _mm256_fmsub_ps(tz, dx, _mm256_mul_ps(tx, dz));
            let cz = _mm256_fmsub_ps(tx, dy, _mm256_mul_ps(ty, dx));
            let h_raw = _mm256_sqrt_ps(_mm256_fmadd_ps(
                cx,
                cx,
                _mm256_fmadd_ps(cy, cy, _mm256_mul_ps(cz, cz)),
            ));
            let along_p = _mm256_fmadd_ps(lx, dx, _mm256_fmadd_ps(ly, dy, _mm256_mul_ps(lz, dz)));
            let hmin = _mm256_max_ps(
                _mm256_min_ps(h_min_sv, _mm256_mul_ps(splat(MIN_ANGLE), d_sp)),
                splat(MIN_DISTANCE),
            );
            let h = _mm256_max_ps(h_raw, hmin);
            let u = _mm256_mul_ps(beta, h);
            let w = _mm256_div_ps(u, _mm256_add_ps(one, u));
            let e_vp = ld(&lanes.e_vp, i);
            let a = eye_tail(light, along, h);
            let b = _mm256_mul_ps(
                _mm256_mul_ps(e_vp, e_sp),
                l_inf::<NEAREST>(ctx, inv_d, along_p, h, u, w),
            );
            let cancel = _mm256_cmp_ps(b, _mm256_mul_ps(splat(CANCELLATION_RATIO), a), _CMP_GT_OQ);
            let air = _mm256_mul_ps(
                _mm256_max_ps(_mm256_sub_ps(a, b), zero),
                _mm256_div_ps(beta_2pi, h),
            );
            // Where the tails nearly cancel: the segment quadrature instead.
            let air = if _mm256_movemask_ps(cancel) == 0 {
                air
            } else {
                _mm256_blendv_ps(
                    air,
                    segment_gauss(ctx, along, h, ld(&lanes.d_vp, i)),
                    cancel,
                )
            };
            if !SURFACE {
                for (c, l) in il.iter().enumerate() {
                    add_to(lanes.acc_mut(c), i, _mm256_mul_ps(*l, air));
                }
                i += 8;
                continue;
            }
            // Surface radiance (eq. 3.20–3.28).
            let w_t = _mm256_div_ps(t_sp, _mm256_add_ps(one, t_sp));
            let direct = _mm256_mul_ps(e_sp, _mm256_mul_ps(inv_d, inv_d));
            let scat = _mm256_mul_ps(beta_2pi, _mm256_mul_ps(e_sp, inv_d));
            let (nx, ny, nz) = (ld(&lanes.nx, i), ld(&lanes.ny, i), ld(&lanes.nz, i));
            let (rx, ry, rz) = (ld(&lanes.rx, i), ld(&lanes.ry, i), ld(&lanes.rz, i));
            let mu = _mm256_mul_ps(
                _mm256_fmadd_ps(nx, lx, _mm256_fmadd_ps(ny, ly, _mm256_mul_ps(nz, lz))),
                inv_d,
            );
            let mu_r = _mm256_mul_ps(
                _mm256_fmadd_ps(rx, lx, _mm256_fmadd_ps(ry, ly, _mm256_mul_ps(rz, lz))),
                inv_d,
            );
            let g0 = match ctx.g_lambert {
                Some(g) => lookup::<NEAREST>(g, w_t, mu),
                None => zero,
            };
            let gn = lookup::<NEAREST>(mat.g, w_t, mu_r);
            let pw = exp2(_mm256_mul_ps(phong_n, log2(mu_r)));
            let lit = _mm256_and_ps(
                _mm256_cmp_ps(mu, zero, _CMP_GT_OQ),
                _mm256_cmp_ps(mu_r, zero, _CMP_GT_OQ),
            );
            let lobe = _mm256_and_ps(lit, pw);
            let diffuse = _mm256_fmadd_ps(direct, _mm256_max_ps(mu, zero), _mm256_mul_ps(scat, g0));
            let spec = _mm256_fmadd_ps(direct, lobe, _mm256_mul_ps(scat, gn));
            let sd = _mm256_mul_ps(e_vp, diffuse);
            let ss = _mm256_mul_ps(e_vp, spec);
            for c in 0..3 {
                let v = _mm256_fmadd_ps(
                    kd[c],
                    sd,
                    _mm256_fmadd_ps(ks[c], ss, _mm256_mul_ps(il[c], air)),
                );
                add_to(lanes.acc_mut(c), i, v);
            }
            i += 8;
        }
    }
    m
}

/// Airlight to infinity of every light for background directions (the
/// first `len / 8 · 8` of them); returns how many were done.
///
/// # Safety
/// As [`surface_run`].
#[target_feature(enable = "avx2,fma")]
pub unsafe fn background(
    ctx: &Ctx,
    lights: &[PreparedLight],
    dx: &[f32],
    dy: &[f32],
    dz: &[f32],
    r: &mut [f32],
    g: &mut [f32],
    b: &mut [f32],
) -> usize {
    let m = dx
        .len()
        .min(dy.len())
        .min(dz.len())
        .min(r.len())
        .min(g.len())
        .min(b.len())
        / 8
        * 8;
    let beta_2pi = splat(ctx.sigma_s / (2.0 * std::f32::consts::PI));
    for light in lights {
        let (tx, ty, tz) = (
            splat(light.to_light.x),
            splat(light.to_light.y),
            splat(light.to_light.z),
        );
        let h_min_sv = splat(light.h_min_sv);
        let li = light.intensity;
        let il = [splat(li.x), splat(li.y), splat(li.z)];
        let mut i = 0;
        while i < m {
            let (ddx, ddy, ddz) = (ld(dx, i), ld(dy, i), ld(dz, i));
            let along = _mm256_fmadd_ps(tx, ddx, _mm256_fmadd_ps(ty, ddy, _mm256_mul_ps(tz, ddz)));
            let cx = _mm256_fmsub_ps(ty, ddz, _mm256_mul_ps(tz, ddy));
            let cy = _mm256_fmsub_ps(tz, ddx, _mm256_mul_ps(tx, ddz));
            let cz = _mm256_fmsub_ps(tx, ddy, _mm256_mul_ps(ty, ddx));
            let h_raw = _mm256_sqrt_ps(_mm256_fmadd_ps(
                cx,
                cx,
                _mm256_fmadd_ps(cy, cy, _mm256_mul_ps(cz, cz)),
            ));
            let h = _mm256_max_ps(h_raw, h_min_sv);
            let a = _mm256_mul_ps(eye_tail(light, along, h), _mm256_div_ps(beta_2pi, h));
            add_to(r, i, _mm256_mul_ps(il[0], a));
            add_to(g, i, _mm256_mul_ps(il[1], a));
            add_to(b, i, _mm256_mul_ps(il[2], a));
            i += 8;
        }
    }
    m
}

/// [`PixelBatch::prepare`] for pixels `start..start + m`, m = ⌊(len −
/// start)/8⌋·8; returns m.
///
/// # Safety
/// The CPU must support AVX2 and FMA; `start` ≤ `batch.len()`.
#[target_feature(enable = "avx2,fma")]
pub unsafe fn prepare(batch: &mut PixelBatch, start: usize, eye: glam::Vec3, beta: f32) -> usize {
    let m = batch.len().saturating_sub(start) / 8 * 8;
    let (ex, ey, ez) = (splat(eye.x), splat(eye.y), splat(eye.z));
    let zero = _mm256_setzero_ps();
    let mbeta = splat(-beta);
    let f = batch.fields_mut();
    let mut i = start;
    while i < start + m {
        let vx = _mm256_sub_ps(ld(f.px, i), ex);
        let vy = _mm256_sub_ps(ld(f.py, i), ey);
        let vz = _mm256_sub_ps(ld(f.pz, i), ez);
        let d2 = _mm256_fmadd_ps(vx, vx, _mm256_fmadd_ps(vy, vy, _mm256_mul_ps(vz, vz)));
        let d = _mm256_max_ps(_mm256_sqrt_ps(d2), splat(MIN_DISTANCE));
        let inv = _mm256_div_ps(splat(1.0), d);
        let (dx, dy, dz) = (
            _mm256_mul_ps(vx, inv),
            _mm256_mul_ps(vy, inv),
            _mm256_mul_ps(vz, inv),
        );
        let (nx, ny, nz) = (ld(f.nx, i), ld(f.ny, i), ld(f.nz, i));
        let nd = _mm256_fmadd_ps(nx, dx, _mm256_fmadd_ps(ny, dy, _mm256_mul_ps(nz, dz)));
        // Flip toward the viewer: negate where n · dir > 0.
        let flip = _mm256_and_ps(_mm256_cmp_ps(nd, zero, _CMP_GT_OQ), splat(-0.0));
        let (nx, ny, nz) = (
            _mm256_xor_ps(nx, flip),
            _mm256_xor_ps(ny, flip),
            _mm256_xor_ps(nz, flip),
        );
        let nd2 = _mm256_mul_ps(splat(2.0), _mm256_xor_ps(nd, flip));
        store(&mut *f.nx, i, nx);
        store(&mut *f.ny, i, ny);
        store(&mut *f.nz, i, nz);
        store(&mut *f.dx, i, dx);
        store(&mut *f.dy, i, dy);
        store(&mut *f.dz, i, dz);
        store(&mut *f.rx, i, _mm256_fnmadd_ps(nd2, nx, dx));
        store(&mut *f.ry, i, _mm256_fnmadd_ps(nd2, ny, dy));
        store(&mut *f.rz, i, _mm256_fnmadd_ps(nd2, nz, dz));
        store(&mut *f.d_vp, i, d);
        store(&mut *f.e_vp, i, exp(_mm256_mul_ps(mbeta, d)));
        store(&mut *f.r, i, zero);
        store(&mut *f.g, i, zero);
        store(&mut *f.b, i, zero);
        i += 8;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `cell_corners` and `neighbours` read exactly the values the
    /// gathers they replace read, at the table's first and last cells and
    /// at scattered ones.
    #[test]
    fn cell_loads_equal_indexed_reads() {
        if !relight_isa::avx2() {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI: no AVX2 + FMA on this CPU, so the loads are not tested"
            );
            return;
        }
        let size = 7;
        let t = Table2::tabulate(size, (0.0, 1.0), (0.0, 2.0), |x, y| {
            x * 10.0 + y * 100.0 + 0.5
        })
        .expect("table");
        let v = t.values();
        for start in [0, 3, 17, 27] {
            let cells: Vec<i32> = (0..8)
                .map(|k| {
                    let c = (start + 5 * k) % ((size - 1) * (size - 1));
                    ((c / (size - 1)) * size + c % (size - 1)) as i32
                })
                .collect();
            let mut got = [[0.0f32; 8]; 4];
            let mut pair = [[0.0f32; 8]; 2];
            // SAFETY: AVX2 and FMA detected above; every index is a cell
            // (x, y ≤ size − 2) and < values.len() − 1.
            unsafe {
                let i = _mm256_loadu_si256(cells.as_ptr().cast());
                let (a, b, c, d) = cell_corners(t.quads(), i);
                for (o, r) in got.iter_mut().zip([a, b, c, d]) {
                    _mm256_storeu_ps(o.as_mut_ptr(), r);
                }
                let (a, b) = neighbours(v, i);
                _mm256_storeu_ps(pair[0].as_mut_ptr(), a);
                _mm256_storeu_ps(pair[1].as_mut_ptr(), b);
            }
            for (lane, &c) in cells.iter().enumerate() {
                let c = c as usize;
                let want = [v[c], v[c + 1], v[c + size], v[c + size + 1]];
                for (k, w) in want.iter().enumerate() {
                    assert_eq!(got[k][lane].to_bits(), w.to_bits(), "cell {c}, corner {k}");
                }
                assert_eq!(pair[0][lane], v[c]);
                assert_eq!(pair[1][lane], v[c + 1]);
            }
        }
    }
}
