//! Fast f32 paths over the generated per-order kernels of [`crate::kernels`]:
//! single calls (what [`crate::eval_sh_into`], [`crate::rotation::ZyzRotation`]
//! and [`crate::product::TripleProduct`] run for f32 at low order), RGB
//! variants (the three channels as three lanes) and **batch kernels** (eight
//! directions or vectors per AVX2 register, lanes across items).
//!
//! # Which code runs
//! * Single calls and RGB variants: the generated straight-line code with
//!   plain multiply and add, inlined into the caller (no run-time check).
//! * Batches: on an x86-64 CPU with AVX2 and FMA ([`crate::lanes::avx2_fma_available`]),
//!   eight items per lane group with fused multiply–add; elsewhere the same
//!   generated code one item at a time without FMA. The tail of a
//!   batch is padded by repeating its last item.
//!
//! Every kernel is tested against the portable recurrence / ZYZ / Gaunt code
//! (`src/fast_tests.rs`); under `CI` those tests fail on a CPU without
//! AVX2+FMA instead of comparing the portable path with itself.
//!
//! # Layouts
//! Directions are unit vectors `[x, y, z]` in the coefficients' frame. Batched
//! coefficient vectors are item-major: item `i` occupies `[i·n², (i+1)·n²)`.

use crate::kernels;
use crate::lanes::V;
use crate::rotation::{EulerZyz, Rot3};
use crate::{MAX_ORDER, ShError, check_order};

/// Largest order of the batch kernels (`eval_batch`, `shade_batch`,
/// `shade_rgb_batch`, `rotate_batch`): kept low because each batch order is
/// one more eight-lane instantiation of a generated kernel (compile time).
pub const BATCH_MAX_ORDER: usize = 4;

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

/// Generated f32 evaluation of all `order²` basis values at `dir`; `false`
/// (nothing written) above [`KERNEL_EVAL_MAX_ORDER`].
///
/// # Panics
/// If `out` is shorter than `order²`.
#[inline(always)]
pub(crate) fn eval_one(order: usize, dir: [f32; 3], out: &mut [f32]) -> bool {
    let [x, y, z] = dir;
    kernels::eval::<1, false>(order, S::splat(x), S::splat(y), S::splat(z), as_v_mut(out))
}

#[inline(always)]
fn euler_lanes<const W: usize, const F: bool>(e: &[EulerZyz<f32>; W]) -> [V<W, F>; 6] {
    let mut a = [V::<W, F>::splat(0.0); 6];
    for (i, e) in e.iter().enumerate() {
        a[0].0[i] = e.cos_alpha;
        a[1].0[i] = e.sin_alpha;
        a[2].0[i] = e.cos_beta;
        a[3].0[i] = e.sin_beta;
        a[4].0[i] = e.cos_gamma;
        a[5].0[i] = e.sin_gamma;
    }
    a
}

/// Generated ZYZ rotation of one f32 vector; `false` above [`KERNEL_ROTATE_MAX_ORDER`].
///
/// # Panics
/// If a slice is shorter than `order²`.
#[inline(always)]
pub(crate) fn rotate_one(order: usize, e: &EulerZyz<f32>, src: &[f32], dst: &mut [f32]) -> bool {
    let e = euler_lanes::<1, false>(&[*e]);
    kernels::rotate::<1, false>(order, &e, as_v(src), as_v_mut(dst))
}

/// Generated truncated product of two f32 vectors; `false` above [`KERNEL_PRODUCT_MAX_ORDER`].
///
/// # Panics
/// If a slice is shorter than `order²`.
#[inline(always)]
pub(crate) fn product_one(order: usize, f: &[f32], g: &[f32], out: &mut [f32]) -> bool {
    kernels::product::<1, false>(order, as_v(f), as_v(g), as_v_mut(out))
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

/// Gathers channel `k` of three slices into lanes.
#[inline(always)]
fn rgb_in(c: [&[f32]; 3], nn: usize, buf: &mut [V<3, false>; MAX_KERNEL_NN]) {
    for k in 0..nn {
        buf[k] = V([c[0][k], c[1][k], c[2][k]]);
    }
}

#[inline(always)]
fn rgb_out(buf: &[V<3, false>; MAX_KERNEL_NN], nn: usize, out: [&mut [f32]; 3]) {
    let [r, g, b] = out;
    for k in 0..nn {
        r[k] = buf[k].0[0];
        g[k] = buf[k].0[1];
        b[k] = buf[k].0[2];
    }
}

const MAX_KERNEL_NN: usize = KERNEL_EVAL_MAX_ORDER * KERNEL_EVAL_MAX_ORDER;

/// Rotates three coefficient vectors (R, G, B) by one rotation `rot` with the
/// generated ZYZ kernel, the channels as three lanes (one Euler decomposition,
/// one set of multiple angles). Orders `1 ..=` [`KERNEL_ROTATE_MAX_ORDER`].
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
    let e = rot.euler_zyz();
    let ev = euler_lanes::<1, false>(&[e]);
    let e3: [V<3, false>; 6] = std::array::from_fn(|i| V::splat(ev[i].0[0]));
    let mut a = [V::splat(0.0); MAX_KERNEL_NN];
    let mut b = [V::splat(0.0); MAX_KERNEL_NN];
    rgb_in(src, nn, &mut a);
    kernels::rotate::<3, false>(order, &e3, &a[..nn], &mut b[..nn]);
    rgb_out(&b, nn, dst);
    Ok(())
}

/// Channel-wise truncated product of two RGB coefficient triples,
/// `out_c = f_c ∗ g_c` for c = R, G, B, with the generated kernel, channels as
/// lanes. Orders `1 ..=` [`KERNEL_PRODUCT_MAX_ORDER`].
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
    let mut a = [V::splat(0.0); MAX_KERNEL_NN];
    let mut b = [V::splat(0.0); MAX_KERNEL_NN];
    let mut o = [V::splat(0.0); MAX_KERNEL_NN];
    rgb_in(f, nn, &mut a);
    rgb_in(g, nn, &mut b);
    kernels::product::<3, false>(order, &a[..nn], &b[..nn], &mut o[..nn]);
    rgb_out(&o, nn, out);
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

#[inline(always)]
fn batch_eval<const W: usize, const F: bool>(
    n: usize,
    x: V<W, F>,
    y: V<W, F>,
    z: V<W, F>,
    o: &mut [V<W, F>],
) {
    match n {
        1 => kernels::eval_n1(x, y, z, (&mut o[..1]).try_into().expect("length")),
        2 => kernels::eval_n2(x, y, z, (&mut o[..4]).try_into().expect("length")),
        3 => kernels::eval_n3(x, y, z, (&mut o[..9]).try_into().expect("length")),
        4 => kernels::eval_n4(x, y, z, (&mut o[..16]).try_into().expect("length")),
        _ => unreachable!("batch order checked against BATCH_MAX_ORDER"),
    }
}

#[inline(always)]
fn batch_rotate<const W: usize, const F: bool>(
    n: usize,
    e: &[V<W, F>; 6],
    v: &[V<W, F>],
    d: &mut [V<W, F>],
) {
    match n {
        1 => kernels::rotate_n1(
            e,
            (&v[..1]).try_into().expect("length"),
            (&mut d[..1]).try_into().expect("length"),
        ),
        2 => kernels::rotate_n2(
            e,
            (&v[..4]).try_into().expect("length"),
            (&mut d[..4]).try_into().expect("length"),
        ),
        3 => kernels::rotate_n3(
            e,
            (&v[..9]).try_into().expect("length"),
            (&mut d[..9]).try_into().expect("length"),
        ),
        4 => kernels::rotate_n4(
            e,
            (&v[..16]).try_into().expect("length"),
            (&mut d[..16]).try_into().expect("length"),
        ),
        _ => unreachable!("batch order checked against BATCH_MAX_ORDER"),
    }
}

/// Loads item `i0 + j` (clamped to the last item) into lane `j`.
#[inline(always)]
fn dir_lanes<const W: usize, const F: bool>(dirs: &[[f32; 3]], i0: usize) -> [V<W, F>; 3] {
    let last = dirs.len() - 1;
    let mut v = [V::<W, F>::splat(0.0); 3];
    for j in 0..W {
        let d = dirs[(i0 + j).min(last)];
        v[0].0[j] = d[0];
        v[1].0[j] = d[1];
        v[2].0[j] = d[2];
    }
    v
}

#[inline(always)]
fn eval_batch_body<const W: usize, const F: bool>(
    order: usize,
    dirs: &[[f32; 3]],
    out: &mut [f32],
) {
    let nn = order * order;
    let mut y = [V::<W, F>::splat(0.0); MAX_KERNEL_NN];
    for i0 in (0..dirs.len()).step_by(W) {
        let [x, yy, z] = dir_lanes::<W, F>(dirs, i0);
        batch_eval::<W, F>(order, x, yy, z, &mut y[..nn]);
        let cnt = W.min(dirs.len() - i0);
        for j in 0..cnt {
            let o = &mut out[(i0 + j) * nn..(i0 + j + 1) * nn];
            for k in 0..nn {
                o[k] = y[k].0[j];
            }
        }
    }
}

#[inline(always)]
fn shade_batch_body<const W: usize, const F: bool, const C: usize>(
    order: usize,
    coeffs: [&[f32]; C],
    dirs: &[[f32; 3]],
    out: &mut [[f32; C]],
) {
    let nn = order * order;
    let mut y = [V::<W, F>::splat(0.0); MAX_KERNEL_NN];
    for i0 in (0..dirs.len()).step_by(W) {
        let [x, yy, z] = dir_lanes::<W, F>(dirs, i0);
        batch_eval::<W, F>(order, x, yy, z, &mut y[..nn]);
        let mut acc = [V::<W, F>::splat(0.0); C];
        for k in 0..nn {
            for c in 0..C {
                acc[c] = y[k].mul_add(V::splat(coeffs[c][k]), acc[c]);
            }
        }
        let cnt = W.min(dirs.len() - i0);
        for j in 0..cnt {
            for c in 0..C {
                out[i0 + j][c] = acc[c].0[j];
            }
        }
    }
}

/// Lane Euler decomposition, branch-free: [`Rot3::euler_zyz`] with both pole
/// branches computed and blended per lane.
#[inline(always)]
fn euler_of_lanes<const W: usize, const F: bool>(m: &[[V<W, F>; 3]; 3]) -> [V<W, F>; 6] {
    let one = V::<W, F>::splat(1.0);
    let zero = V::<W, F>::splat(0.0);
    let norm2 = |c: V<W, F>, s: V<W, F>| {
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

#[inline(always)]
fn rotate_batch_body<const W: usize, const F: bool>(
    order: usize,
    rots: &[Rot3<f32>],
    src: &[f32],
    dst: &mut [f32],
) {
    let nn = order * order;
    let last = rots.len() - 1;
    let mut a = [V::<W, F>::splat(0.0); MAX_KERNEL_NN];
    let mut b = [V::<W, F>::splat(0.0); MAX_KERNEL_NN];
    for i0 in (0..rots.len()).step_by(W) {
        let mut m = [[V::<W, F>::splat(0.0); 3]; 3];
        for j in 0..W {
            let it = (i0 + j).min(last);
            let r = &rots[it].m;
            for p in 0..3 {
                for q in 0..3 {
                    m[p][q].0[j] = r[p][q];
                }
            }
            let v = &src[it * nn..(it + 1) * nn];
            for k in 0..nn {
                a[k].0[j] = v[k];
            }
        }
        let e = euler_of_lanes(&m);
        batch_rotate::<W, F>(order, &e, &a[..nn], &mut b[..nn]);
        let cnt = W.min(rots.len() - i0);
        for j in 0..cnt {
            let o = &mut dst[(i0 + j) * nn..(i0 + j + 1) * nn];
            for k in 0..nn {
                o[k] = b[k].0[j];
            }
        }
    }
}

macro_rules! avx2_entry {
    ($name:ident, $body:ident, ($($arg:ident: $ty:ty),*)) => {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        /// # Safety
        /// The CPU must support AVX2 and FMA.
        pub(crate) unsafe fn $name($($arg: $ty),*) {
            $body::<8, true>($($arg),*)
        }
    };
}
avx2_entry!(eval_batch_avx2, eval_batch_body, (order: usize, dirs: &[[f32; 3]], out: &mut [f32]));
avx2_entry!(rotate_batch_avx2, rotate_batch_body, (order: usize, rots: &[Rot3<f32>], src: &[f32], dst: &mut [f32]));

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
/// # Safety
/// The CPU must support AVX2 and FMA.
pub(crate) unsafe fn shade_batch_avx2<const C: usize>(
    order: usize,
    coeffs: [&[f32]; C],
    dirs: &[[f32; 3]],
    out: &mut [[f32; C]],
) {
    shade_batch_body::<8, true, C>(order, coeffs, dirs, out);
}

/// Portable entry points (one lane, no FMA), public to the crate's tests.
pub(crate) fn eval_batch_portable(order: usize, dirs: &[[f32; 3]], out: &mut [f32]) {
    eval_batch_body::<1, false>(order, dirs, out);
}
pub(crate) fn rotate_batch_portable(
    order: usize,
    rots: &[Rot3<f32>],
    src: &[f32],
    dst: &mut [f32],
) {
    rotate_batch_body::<1, false>(order, rots, src, dst);
}
pub(crate) fn shade_batch_portable<const C: usize>(
    order: usize,
    coeffs: [&[f32]; C],
    dirs: &[[f32; 3]],
    out: &mut [[f32; C]],
) {
    shade_batch_body::<1, false, C>(order, coeffs, dirs, out);
}

/// Evaluates all `order²` basis functions at every direction:
/// `out[i·n² + k] = y_k(dirs[i])`. Orders `1 ..=` [`BATCH_MAX_ORDER`].
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
    // SAFETY: [f32] and [[f32; 1]] have the same layout.
    let out1: &mut [[f32; 1]] =
        unsafe { std::slice::from_raw_parts_mut(out.as_mut_ptr().cast(), out.len()) };
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
    check_order(
        "order (fast::shade_rgb_batch)",
        order,
        KERNEL_EVAL_MAX_ORDER,
    )?;
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
/// Orders `1 ..=` [`BATCH_MAX_ORDER`].
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
    check_order("order (fast::rotate_batch)", order, BATCH_MAX_ORDER)?;
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

const _: () = assert!(KERNEL_EVAL_MAX_ORDER <= MAX_ORDER);

#[cfg(test)]
#[path = "fast_tests.rs"]
mod tests;
