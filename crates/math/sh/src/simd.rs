//! Vectorised f32 kernels for the O(n²)/O(n³) rotations at orders `n ≤ 10`
//! (AVX-512F, detected at run time; every caller keeps a portable path that
//! computes the same thing and is tested against this one).
//!
//! The coefficient vector stays in its flat layout `i = l(l+1)+m`, held in
//! 16-lane registers (`⌈n²/16⌉ ≤ 7` of them, lanes past `n²` are zero). Each
//! step of a rotation is a handful of full-width operations with constant
//! per-order tables ([`Plan`], built once per order and cached):
//!
//! * **Z rotation** (Křivánek et al. 2006, Appendix C): `dst = C ∘ x + S ∘ x̄`,
//!   where `x̄` is `x` with every band reversed (`x̄_{l,m} = x_{l,−m}`, a fixed
//!   lane permutation, at most three masked permutes per register) and
//!   `C_i = cos(|m_i|α)`, `S_i = −sin(m_i α)`, gathered with one permute per
//!   register from the vectors `cos(mα), sin(mα)`, `m = 0…15`. Those are formed
//!   by binary powers of `e^{iα}` (`e^{imα} = Π_b e^{i2^bα}` over the set bits
//!   of `m`) — the same multiple angles as the recurrence of Appendix C.
//! * **Taylor Y step** (§3, `shRotYdiff15`): `R'` couples index `i` only to
//!   `i ± 1` and `R''` to `i, i ± 2`, so the step is a few multiply-adds with
//!   the register shifted by one or two lanes (`valignd`).
//! * **Fixed ±90° X rotations** of the ZYZ ("ZXZXZ") method: column form, one
//!   broadcast multiply-add per non-zero 16-row piece of a matrix column.
//!
//! When the last register holds at most eight coefficients (n = 2, 6, 10),
//! its element-wise arithmetic runs on 256-bit registers (CPUs that split
//! 512-bit operations in two then do half the work for it); the Taylor
//! kernels that start from a rotation matrix compute their per-rotation
//! scalars inside the vectorised function (fused multiply-adds, no call
//! boundary between the scalars and their broadcasts).

// Off x86-64 only the portable code runs; the tables and dispatch stay compiled.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code, unused_imports))]

use std::sync::OnceLock;

use crate::Real;
use crate::rotation::{EulerZyz, Rot3, ShRotation};

/// Largest order with a vectorised kernel.
pub(crate) const SIMD_MAX_ORDER: usize = 10;
/// Smallest order at which the vectorised Z rotation beats the portable code
/// (below it the multiple-angle setup costs more than it saves; measured with
/// `relight bench sh`).
pub(crate) const SIMD_MIN_ORDER_Z: usize = 4;
/// The same for the ZYZ rotation. The Taylor kernels run from order 2.
pub(crate) const SIMD_MIN_ORDER_ZYZ: usize = 3;
/// Lanes per register.
const LANES: usize = 16;
/// Registers for `SIMD_MAX_ORDER² = 100` coefficients.
const MAXV: usize = 7;

/// Sixteen f32, 64-byte aligned (one AVX-512 register's worth).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct F16(pub [f32; LANES]);

/// Sixteen i32 lane indices, 64-byte aligned.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct I16(pub [i32; LANES]);

/// One piece of a fixed lane permutation: lanes in `mask` of the output
/// register take lane `idx[lane]` of the input register the piece belongs to.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PermPiece {
    mask: u16,
    idx: I16,
}

/// The Z-rotation tables of one order, evaluated at compile time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ZTables {
    /// Lane `i` selects `cos(|m_i|α)` from the multiple-angle register.
    cidx: [I16; MAXV],
    /// Lane `i` selects `S_i = −sin(m_i α)` from `[sin(kα) | −sin(kα)]`:
    /// `|m_i|` for `m_i ≤ 0`, `16 + m_i` for `m_i > 0`.
    sidx: [I16; MAXV],
    /// Band reversal: register `k` of `x̄` takes the lanes of `rev[k][d]` from
    /// register `k − 1 + d` of `x` (`d = 0, 1, 2`; bands are at most 19 wide).
    rev: [[PermPiece; 3]; MAXV],
}

/// [`ZTables`] for `n ≤ SIMD_MAX_ORDER` bands.
pub(crate) const fn z_tables(n: usize) -> ZTables {
    let empty = PermPiece {
        mask: 0,
        idx: I16([0; LANES]),
    };
    let mut t = ZTables {
        cidx: [I16([0; LANES]); MAXV],
        sidx: [I16([0; LANES]); MAXV],
        rev: [[empty; 3]; MAXV],
    };
    let mut l = 0;
    while l < n {
        let b = (l * (l + 1)) as isize;
        let mut m = -(l as isize);
        while m <= l as isize {
            let i = (b + m) as usize;
            let (k, lane) = (i / LANES, i % LANES);
            let am = m.unsigned_abs() as i32;
            t.cidx[k].0[lane] = am;
            t.sidx[k].0[lane] = if m > 0 { 16 + am } else { am };
            let from = (b - m) as usize;
            let src = from / LANES;
            assert!(
                src + 1 >= k && src <= k + 1,
                "band reversal spans > 3 registers"
            );
            let d = src + 1 - k;
            t.rev[k][d].mask |= 1 << lane;
            t.rev[k][d].idx.0[lane] = (from % LANES) as i32;
            m += 1;
        }
        l += 1;
    }
    t
}

/// A sparse block-diagonal matrix in column pieces: for output register `k`,
/// `pieces[start[k]..start[k+1]]` are `(input coefficient j, the 16 rows of
/// column j that fall in register k)`, all-zero pieces dropped.
#[derive(Clone, Debug, Default)]
pub(crate) struct ColumnPieces {
    start: Vec<usize>,
    cols: Vec<u32>,
    vals: Vec<F16>,
}

impl ColumnPieces {
    fn from_rotation(r: &ShRotation<f64>, nv: usize) -> Self {
        let (start, cols, vals) = column_pieces::<LANES>(r, nv);
        Self {
            start,
            cols,
            vals: vals.into_iter().map(F16).collect(),
        }
    }
}

/// A fixed matrix cut into column pieces of `L` rows, for `nv` registers of
/// `L` lanes: `(start, cols, vals)` with register `k`'s pieces at
/// `start[k]..start[k+1]`, each `(input coefficient, the L rows of that
/// column that fall in register k)`; all-zero pieces dropped. Shared by the
/// AVX-512 (`L = 16`) and AVX2 (`L = 8`) kernels.
pub(crate) fn column_pieces<const L: usize>(
    r: &ShRotation<f64>,
    nv: usize,
) -> (Vec<usize>, Vec<u32>, Vec<[f32; L]>) {
    let n = r.order();
    let (mut start, mut cols, mut vals) = (vec![0], Vec::new(), Vec::new());
    for k in 0..nv {
        for l in 0..n {
            let w = 2 * l + 1;
            let base = l * l;
            if base + w <= k * L || base >= (k + 1) * L {
                continue;
            }
            for j in 0..w {
                let mut v = [0.0f32; L];
                let mut any = false;
                for i in 0..w {
                    let row = base + i;
                    if (k * L..(k + 1) * L).contains(&row) {
                        let x = r.block(l)[i * w + j];
                        if x.abs() > 1e-12 {
                            v[row - k * L] = x as f32;
                            any = true;
                        }
                    }
                }
                if any {
                    cols.push((base + j) as u32);
                    vals.push(v);
                }
            }
        }
        start.push(cols.len());
    }
    (start, cols, vals)
}

/// The constant tables of one order.
#[derive(Clone, Debug)]
pub(crate) struct Plan {
    pub(crate) n: usize,
    /// Taylor tables: `R'[i][i−1]`, `R'[i+1][i]`, `½R''[i][i]`, `½R''[i][i−2]`, `½R''[i][i+2]`.
    t_sub: [F16; MAXV],
    t_sup: [F16; MAXV],
    t_d2: [F16; MAXV],
    t_s2: [F16; MAXV],
    t_p2: [F16; MAXV],
    /// Fused Taylor step (first and 1.5th order): the X-axis generator
    /// `G_x = Z(−90°) R_y'(0) Z(90°)` as `G_x[i][rev(i)+1]` and `G_x[i][rev(i)−1]`
    /// (it couples `(l, m)` only with `(l, −m ± 1)`).
    g_prev: [F16; MAXV],
    g_next: [F16; MAXV],
    /// `½R''` conjugated by `R_z(γ)`: `½R''ᵢᵢ` averaged over the pair `(l, ±1)`
    /// (`t_dbar`), the half-difference signed by `m` (`t_dsig`) and unsigned (`t_dhalf`).
    t_dbar: [F16; MAXV],
    t_dsig: [F16; MAXV],
    t_dhalf: [F16; MAXV],
    /// Largest entry of `G_x` not captured by `g_prev`, `g_next` (0 up to rounding).
    #[cfg_attr(not(test), allow(dead_code))]
    gx_residual: f64,
    /// `R_x(+90°)` and `R_x(−90°)`.
    x_plus: ColumnPieces,
    x_minus: ColumnPieces,
}

impl Plan {
    fn new(n: usize) -> Self {
        assert!((1..=SIMD_MAX_ORDER).contains(&n));
        let nn = n * n;
        let nv = nn.div_ceil(LANES);
        let ty = crate::taylor::TaylorY::<f32>::new(n).expect("order ≤ 10");
        let (sub, d2, s2, p2) = ty.tables();
        let mut t_sub = [F16::default(); MAXV];
        let mut t_sup = [F16::default(); MAXV];
        let mut t_d2 = [F16::default(); MAXV];
        let mut t_s2 = [F16::default(); MAXV];
        let mut t_p2 = [F16::default(); MAXV];
        for i in 0..nn {
            let (k, lane) = (i / LANES, i % LANES);
            t_sub[k].0[lane] = sub[i];
            t_sup[k].0[lane] = sub[i + 1];
            t_d2[k].0[lane] = d2[i];
            t_s2[k].0[lane] = s2[i];
            t_p2[k].0[lane] = p2[i];
        }
        // G_x column by column: e_j → Z(90°) → R_y'(0) → Z(−90°).
        let (d1, _) = crate::taylor::y_rotation_derivatives(n);
        let mut gx = vec![0.0f64; nn * nn]; // row-major
        let (mut e, mut v, mut w, mut u) =
            (vec![0.0; nn], vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]);
        for j in 0..nn {
            e.fill(0.0);
            e[j] = 1.0;
            crate::rotation::rotate_z_portable(n, 0.0, 1.0, &e, &mut v);
            for l in 0..n {
                let wd = 2 * l + 1;
                let blk = &d1[crate::rotation::block_offset(l)..];
                for a in 0..wd {
                    w[l * l + a] = (0..wd).map(|b| blk[a * wd + b] * v[l * l + b]).sum();
                }
            }
            crate::rotation::rotate_z_portable(n, 0.0, -1.0, &w, &mut u);
            for i in 0..nn {
                gx[i * nn + j] = u[i];
            }
        }
        let mut g_prev = [F16::default(); MAXV];
        let mut g_next = [F16::default(); MAXV];
        let mut t_dbar = [F16::default(); MAXV];
        let mut t_dsig = [F16::default(); MAXV];
        let mut t_dhalf = [F16::default(); MAXV];
        let mut captured = vec![false; nn * nn];
        for l in 0..n {
            let b = (l * (l + 1)) as isize;
            let li = l as isize;
            for m in -li..=li {
                let i = (b + m) as usize;
                let (k, lane) = (i / LANES, i % LANES);
                let r = b - m; // rev(i)
                if m > -li {
                    // prev(x̄)_i = x_{rev(i)+1}
                    let j = (r + 1) as usize;
                    g_prev[k].0[lane] = gx[i * nn + j] as f32;
                    captured[i * nn + j] = true;
                }
                if m < li {
                    let j = (r - 1) as usize;
                    g_next[k].0[lane] = gx[i * nn + j] as f32;
                    captured[i * nn + j] = true;
                }
                let di = d2[i] as f64;
                if m.abs() == 1 {
                    let dp = d2[(b + 1) as usize] as f64;
                    let dm = d2[(b - 1) as usize] as f64;
                    let half = 0.5 * (dp - dm);
                    t_dbar[k].0[lane] = (0.5 * (dp + dm)) as f32;
                    t_dsig[k].0[lane] = (half * m as f64) as f32;
                    t_dhalf[k].0[lane] = half as f32;
                } else {
                    t_dbar[k].0[lane] = di as f32;
                }
            }
        }
        let gx_residual = gx
            .iter()
            .zip(&captured)
            .filter(|(_, c)| !**c)
            .map(|(v, _)| v.abs())
            .fold(0.0, f64::max);
        let xp = Rot3::from_axis_angle([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2)
            .and_then(|r| ShRotation::<f64>::from_rotation(n, &r))
            .expect("order ≤ 10");
        let xm = xp.inverse();
        Self {
            g_prev,
            g_next,
            t_dbar,
            t_dsig,
            t_dhalf,
            gx_residual,
            n,
            t_sub,
            t_sup,
            t_d2,
            t_s2,
            t_p2,
            x_plus: ColumnPieces::from_rotation(&xp, nv),
            x_minus: ColumnPieces::from_rotation(&xm, nv),
        }
    }
}

/// The cached plan of `order` (`1 ..= SIMD_MAX_ORDER`), built regardless of the CPU.
pub(crate) fn plan(order: usize) -> &'static Plan {
    static PLANS: [OnceLock<Plan>; SIMD_MAX_ORDER + 1] =
        [const { OnceLock::new() }; SIMD_MAX_ORDER + 1];
    PLANS[order].get_or_init(|| Plan::new(order))
}

/// The fused first- and 1.5th-order Taylor step's constants of one order,
/// one value per coefficient index (the [`Plan`]'s 16-lane tables
/// flattened), for kernels with lanes across vectors
/// ([`crate::fast::taylor_batch`]).
#[derive(Clone, Debug)]
pub(crate) struct TaylorCoefficients {
    /// `R'[i][i−1]` (`sub[i]`), `nn + 1` entries (`R'[i][i+1] = −sub[i+1]`).
    pub(crate) sub: Vec<f32>,
    /// `G_x[i][rev(i)+1]`, `G_x[i][rev(i)−1]`.
    pub(crate) g_prev: Vec<f32>,
    pub(crate) g_next: Vec<f32>,
    /// The conjugated `½R''` diagonal: mean, signed and unsigned half-difference.
    pub(crate) dbar: Vec<f32>,
    pub(crate) dsig: Vec<f32>,
    pub(crate) dhalf: Vec<f32>,
}

/// [`TaylorCoefficients`] of `order` (`1 ..= SIMD_MAX_ORDER`).
pub(crate) fn taylor_coefficients(order: usize) -> TaylorCoefficients {
    let p = plan(order);
    let nn = order * order;
    let flat = |t: &[F16; MAXV], len: usize| -> Vec<f32> {
        (0..len)
            .map(|i| {
                if i < MAXV * LANES {
                    t[i / LANES].0[i % LANES]
                } else {
                    0.0
                }
            })
            .collect()
    };
    let mut sub = flat(&p.t_sub, nn);
    sub.push(0.0);
    TaylorCoefficients {
        sub,
        g_prev: flat(&p.g_prev, nn),
        g_next: flat(&p.g_next, nn),
        dbar: flat(&p.t_dbar, nn),
        dsig: flat(&p.t_dsig, nn),
        dhalf: flat(&p.t_dhalf, nn),
    }
}

/// Whether the vectorised kernels can run on this CPU (std caches the answer).
#[inline]
pub(crate) fn available() -> bool {
    crate::isa::isa() == crate::isa::Isa::Avx512
}

/// The plan for `order` when the vectorised kernels apply (`2 ≤ order ≤ 10`
/// and the CPU has AVX-512F; f32 callers only). The CPU check is made once per
/// order and cached with the plan, so the fast path costs one atomic load.
#[inline]
pub(crate) fn plan_if_available(order: usize) -> Option<&'static Plan> {
    static PLANS: [OnceLock<Plan>; SIMD_MAX_ORDER + 1] =
        [const { OnceLock::new() }; SIMD_MAX_ORDER + 1];
    if !(2..=SIMD_MAX_ORDER).contains(&order) || !available() {
        return None;
    }
    Some(PLANS[order].get_or_init(|| Plan::new(order)))
}

/// Which Taylor expansion (mirrors [`crate::taylor::TaylorOrder`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TaylorKind {
    First,
    OneAndHalf,
    Second,
}

impl From<crate::taylor::TaylorOrder> for TaylorKind {
    fn from(k: crate::taylor::TaylorOrder) -> Self {
        match k {
            crate::taylor::TaylorOrder::First => Self::First,
            crate::taylor::TaylorOrder::OneAndHalf => Self::OneAndHalf,
            crate::taylor::TaylorOrder::Second => Self::Second,
        }
    }
}

#[inline(always)]
fn f<T: Real>(v: T) -> f32 {
    v.to_f64() as f32
}

/// Runs the vectorised Z rotation when it applies (f32, `4 ≤ order ≤ 10`,
/// AVX-512F); returns `false` (and does nothing) otherwise.
#[inline]
pub(crate) fn try_rotate_z<T: Real>(order: usize, c: T, s: T, src: &[T], dst: &mut [T]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let (Some(src), Some(dst)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst))
        && (SIMD_MIN_ORDER_Z..=SIMD_MAX_ORDER).contains(&order)
        && available()
    {
        // SAFETY: AVX-512F was checked.
        unsafe { x86::rotate_z(order, f(c), f(s), src, dst) };
        return true;
    }
    let _ = (order, c, s, src, dst);
    false
}

/// In-place [`try_rotate_z`].
#[inline]
pub(crate) fn try_rotate_z_in_place<T: Real>(order: usize, c: T, s: T, v: &mut [T]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let Some(v) = T::as_f32_slice_mut(v)
        && (SIMD_MIN_ORDER_Z..=SIMD_MAX_ORDER).contains(&order)
        && available()
    {
        // SAFETY: AVX-512F was checked.
        unsafe { x86::rotate_z_in_place(order, f(c), f(s), v) };
        return true;
    }
    let _ = (order, c, s, v);
    false
}

/// The vectorised Taylor Y step when it applies.
#[inline]
pub(crate) fn try_taylor_y<T: Real>(
    order: usize,
    kind: TaylorKind,
    beta: T,
    src: &[T],
    dst: &mut [T],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let (Some(src), Some(dst)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst))
        && let Some(p) = plan_if_available(order)
    {
        // SAFETY: `plan_if_available` checked AVX-512F.
        unsafe { x86::taylor_y_only(p, kind, f(beta), src, dst) };
        return true;
    }
    let _ = (order, kind, beta, src, dst);
    false
}

/// The vectorised `R_z(α) R̃_y(β) R_z(γ)` when it applies (the 1st and 1.5th
/// order through the fused kernel `R_z(α+γ) · [R_z(−γ) R̃_y(β) R_z(γ)]`).
#[inline]
pub(crate) fn try_taylor_rotation<T: Real>(
    order: usize,
    kind: TaylorKind,
    e: &EulerZyz<T>,
    beta: T,
    src: &[T],
    dst: &mut [T],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let (Some(src), Some(dst)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst))
        && let Some(p) = plan_if_available(order)
    {
        let (ca, sa, cg, sg) = (
            f(e.cos_alpha),
            f(e.sin_alpha),
            f(e.cos_gamma),
            f(e.sin_gamma),
        );
        let beta = f(beta);
        if kind == TaylorKind::Second {
            // SAFETY: `plan_if_available` checked AVX-512F.
            unsafe { x86::taylor_rotation3(p, kind, [ca, sa, beta, cg, sg], src, dst) };
        } else {
            let sigma = (ca * cg - sa * sg, sa * cg + ca * sg);
            // SAFETY: `plan_if_available` checked AVX-512F.
            unsafe { x86::taylor_fused(p, kind, sigma, (beta, cg, sg), src, dst) };
        }
        return true;
    }
    let _ = (order, kind, e, beta, src, dst);
    false
}

/// The fused 1st/1.5th-order kernel straight from a rotation matrix, its
/// scalars read off the matrix inside the vectorised function (see
/// [`crate::taylor::TaylorRotation::apply`]). `true` when it ran; `false` (nothing written) when it
/// does not apply: not f32, no AVX-512F, order outside 2…10, the 2nd order,
/// `cos β < 0`, β > [`crate::taylor::SMALL_BETA_MAX`] or `β² > beta_lim²`.
#[inline]
pub(crate) fn try_taylor_fused_matrix<T: Real>(
    order: usize,
    kind: TaylorKind,
    rot: &Rot3<T>,
    beta_lim: T,
    src: &[T],
    dst: &mut [T],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if kind != TaylorKind::Second
        && let (Some(src), Some(dst)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst))
        && let Some(p) = plan_if_available(order)
    {
        let m = T::as_f32_slice(rot.m.as_flattened()).expect("T is f32 here");
        let lim = f(beta_lim);
        // SAFETY: `plan_if_available` checked AVX-512F.
        return unsafe { x86::taylor_fused_matrix(p, kind, m, lim * lim, src, dst) };
    }
    let _ = (order, kind, rot, beta_lim, src, dst);
    false
}

/// The vectorised three-step Taylor rotation (any order of expansion) straight
/// from a rotation matrix: the ZYZ angles ([`Rot3::euler_zyz`]) and β
/// ([`crate::taylor::taylor_beta`]) are computed inside the vectorised
/// function. `true` when it ran; `false` (nothing written) when it does not
/// apply (not f32, no AVX-512F, order outside 2…10) or `β > beta_lim`.
#[inline]
pub(crate) fn try_taylor3_matrix<T: Real>(
    order: usize,
    kind: TaylorKind,
    rot: &Rot3<T>,
    beta_lim: T,
    src: &[T],
    dst: &mut [T],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let (Some(src), Some(dst)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst))
        && let Some(p) = plan_if_available(order)
    {
        let m = T::as_f32_slice(rot.m.as_flattened()).expect("T is f32 here");
        // SAFETY: `plan_if_available` checked AVX-512F.
        return unsafe { x86::taylor3_matrix(p, kind, m, f(beta_lim), src, dst) };
    }
    let _ = (order, kind, rot, beta_lim, src, dst);
    false
}

/// The vectorised ZYZ rotation when it applies.
#[inline]
pub(crate) fn try_zyz<T: Real>(order: usize, e: &EulerZyz<T>, src: &[T], dst: &mut [T]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let (Some(src), Some(dst)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst))
        && order >= SIMD_MIN_ORDER_ZYZ
        && let Some(p) = plan_if_available(order)
    {
        let angles = [
            f(e.cos_alpha),
            f(e.sin_alpha),
            f(e.cos_beta),
            f(e.sin_beta),
            f(e.cos_gamma),
            f(e.sin_gamma),
        ];
        // SAFETY: `plan_if_available` checked AVX-512F.
        unsafe { x86::zyz(p, angles, src, dst) };
        return true;
    }
    let _ = (order, e, src, dst);
    false
}

/// The vectorised exact Y rotation of the ZYZ method when it applies.
#[inline]
pub(crate) fn try_zyz_y<T: Real>(order: usize, c: T, s: T, src: &[T], dst: &mut [T]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let (Some(src), Some(dst)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst))
        && order >= SIMD_MIN_ORDER_ZYZ
        && let Some(p) = plan_if_available(order)
    {
        // SAFETY: `plan_if_available` checked AVX-512F.
        unsafe { x86::zyz_y(p, f(c), f(s), src, dst) };
        return true;
    }
    let _ = (order, c, s, src, dst);
    false
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! The kernels are generic over the order `N` so that every loop over the
    //! `⌈N²/16⌉` registers unrolls and the vector stays in registers.
    use super::{ColumnPieces, LANES, MAXV, Plan, TaylorKind, z_tables};
    use std::arch::x86_64::*;

    type Regs = [__m512; MAXV];

    const fn nv(n: usize) -> usize {
        (n * n).div_ceil(LANES)
    }

    /// Whether register `k` holds a coefficient `(l, ±1)` at order `n` (where
    /// the conjugated `½R''` tables `t_dsig`, `t_dhalf` can be non-zero).
    const fn has_m_pm1(n: usize, k: usize) -> bool {
        let mut l = 1;
        while l < n {
            let (a, b) = (l * l + l - 1, l * l + l + 1);
            if a / LANES == k || b / LANES == k {
                return true;
            }
            l += 1;
        }
        false
    }

    const fn mask_of(nn: usize, k: usize) -> u16 {
        let left = nn - k * LANES;
        if left >= LANES {
            0xFFFF
        } else {
            ((1u32 << left) - 1) as u16
        }
    }

    #[inline(always)]
    fn load<const N: usize>(src: &[f32]) -> Regs {
        assert!(src.len() >= N * N, "SH vector shorter than order²");
        let mut x = [unsafe { _mm512_setzero_ps() }; MAXV];
        for k in 0..nv(N) {
            // SAFETY: AVX-512F is enabled in every caller; lanes outside the
            // mask are not read, masked lanes are `k·16 + lane < N² ≤ src.len()`.
            x[k] = unsafe { _mm512_maskz_loadu_ps(mask_of(N * N, k), src.as_ptr().add(k * LANES)) };
        }
        x
    }

    #[inline(always)]
    fn store<const N: usize>(x: &Regs, dst: &mut [f32]) {
        assert!(dst.len() >= N * N, "SH vector shorter than order²");
        for k in 0..nv(N) {
            // SAFETY: AVX-512F is enabled in every caller; only lanes
            // `k·16 + lane < N² ≤ dst.len()` are written.
            unsafe {
                _mm512_mask_storeu_ps(dst.as_mut_ptr().add(k * LANES), mask_of(N * N, k), x[k]);
            }
        }
    }

    /// Whether register `k` is the last one and holds at most 8 coefficients:
    /// its element-wise arithmetic then runs on 256-bit registers (half the
    /// work on CPUs that split 512-bit operations), upper lanes kept zero.
    const fn narrow<const N: usize>(k: usize) -> bool {
        let left = N * N - k * LANES;
        k + 1 == nv(N) && left <= 8
    }

    /// The low eight lanes.
    #[inline(always)]
    fn lo(v: __m512) -> __m256 {
        // SAFETY: a register reinterpretation; the callers have AVX-512F.
        unsafe { _mm512_castps512_ps256(v) }
    }

    /// [`next`]`::<1>` for the last register when [`narrow`]: lanes 1…7 moved
    /// down one (lane 7 repeats the zero above the last coefficient, where
    /// the tables that multiply it are zero too).
    #[inline(always)]
    fn next8(v: __m512) -> __m256 {
        // SAFETY: the callers have AVX-512F (which implies AVX2).
        unsafe { _mm256_permutevar8x32_ps(lo(v), _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7)) }
    }

    /// The first eight entries of a table register.
    #[inline(always)]
    unsafe fn ld8(v: &super::F16) -> __m256 {
        // SAFETY: `F16` is 64-byte aligned; the caller has AVX-512F.
        unsafe { _mm256_load_ps(v.0.as_ptr()) }
    }

    #[inline(always)]
    unsafe fn ld16(v: &super::F16) -> __m512 {
        // SAFETY: `F16` is 16 aligned f32; the caller has AVX-512F.
        unsafe { _mm512_load_ps(v.0.as_ptr()) }
    }

    #[inline(always)]
    unsafe fn ldi16(v: &super::I16) -> __m512i {
        // SAFETY: `I16` is 16 aligned i32; the caller has AVX-512F.
        unsafe { _mm512_load_si512(v.0.as_ptr().cast()) }
    }

    /// `cos(mα), sin(mα)` in lane `m` (0…15) by binary powers of `e^{iα}`.
    #[inline(always)]
    unsafe fn multiple_angles<const N: usize>(c: f32, s: f32) -> (__m512, __m512) {
        // SAFETY (whole body): the caller has AVX-512F.
        unsafe {
            let mut cv = _mm512_mask_blend_ps(0xAAAA, _mm512_set1_ps(1.0), _mm512_set1_ps(c));
            let mut sv = _mm512_mask_blend_ps(0xAAAA, _mm512_setzero_ps(), _mm512_set1_ps(s));
            let (mut cb, mut sb) = (c, s);
            for (bit, mask) in [(2usize, 0xCCCCu16), (4, 0xF0F0), (8, 0xFF00)] {
                if bit >= N {
                    break;
                }
                (cb, sb) = (cb * cb - sb * sb, 2.0 * cb * sb);
                let (vc, vs) = (_mm512_set1_ps(cb), _mm512_set1_ps(sb));
                let (svs, cvs) = (_mm512_mul_ps(sv, vs), _mm512_mul_ps(cv, vs));
                cv = _mm512_mask_fmsub_ps(cv, mask, vc, svs);
                sv = _mm512_mask_fmadd_ps(sv, mask, vc, cvs);
            }
            (cv, sv)
        }
    }

    /// The band reversal `x̄_{l,m} = x_{l,−m}` (registers k−1, k, k+1 feed register k).
    #[inline(always)]
    unsafe fn reverse<const N: usize>(x: &Regs) -> Regs {
        // SAFETY (whole body): the caller has AVX-512F.
        unsafe {
            let t = const { z_tables(N) };
            let mut out = [_mm512_setzero_ps(); MAXV];
            for k in 0..nv(N) {
                let pc = &t.rev[k];
                let mut r = _mm512_maskz_permutexvar_ps(pc[1].mask, ldi16(&pc[1].idx), x[k]);
                if k > 0 && pc[0].mask != 0 {
                    r = _mm512_mask_permutexvar_ps(r, pc[0].mask, ldi16(&pc[0].idx), x[k - 1]);
                }
                if k + 1 < nv(N) && pc[2].mask != 0 {
                    r = _mm512_mask_permutexvar_ps(r, pc[2].mask, ldi16(&pc[2].idx), x[k + 1]);
                }
                out[k] = r;
            }
            out
        }
    }

    /// Rotation about +Z: `C ∘ x + S ∘ x̄` with `x̄` the band reversal.
    #[inline(always)]
    unsafe fn rot_z<const N: usize>(c: f32, s: f32, x: &Regs) -> Regs {
        // SAFETY (whole body): the caller has AVX-512F.
        unsafe {
            let t = const { z_tables(N) };
            let (cv, sv) = multiple_angles::<N>(c, s);
            let nsv = _mm512_sub_ps(_mm512_setzero_ps(), sv);
            let r = reverse::<N>(x);
            let mut out = [_mm512_setzero_ps(); MAXV];
            for k in 0..nv(N) {
                let ck = _mm512_permutexvar_ps(ldi16(&t.cidx[k]), cv);
                let sk = _mm512_permutex2var_ps(sv, ldi16(&t.sidx[k]), nsv);
                out[k] = if narrow::<N>(k) {
                    let (ck, sk, xk, rk) = (lo(ck), lo(sk), lo(x[k]), lo(r[k]));
                    _mm512_zextps256_ps512(_mm256_fmadd_ps(ck, xk, _mm256_mul_ps(sk, rk)))
                } else {
                    _mm512_fmadd_ps(ck, x[k], _mm512_mul_ps(sk, r[k]))
                };
            }
            out
        }
    }

    /// `x` shifted so that lane `i` holds coefficient `i − D`.
    #[inline(always)]
    unsafe fn prev<const D: i32>(x: &Regs, k: usize) -> __m512 {
        // SAFETY (whole body): the caller has AVX-512F.
        unsafe {
            let lo = if k == 0 {
                _mm512_setzero_si512()
            } else {
                _mm512_castps_si512(x[k - 1])
            };
            let hi = _mm512_castps_si512(x[k]);
            _mm512_castsi512_ps(if D == 1 {
                _mm512_alignr_epi32::<15>(hi, lo)
            } else {
                _mm512_alignr_epi32::<14>(hi, lo)
            })
        }
    }

    /// `x` shifted so that lane `i` holds coefficient `i + D`.
    #[inline(always)]
    unsafe fn next<const D: i32>(x: &Regs, k: usize) -> __m512 {
        // SAFETY (whole body): the caller has AVX-512F.
        unsafe {
            let lo = _mm512_castps_si512(x[k]);
            let hi = if k + 1 < MAXV {
                _mm512_castps_si512(x[k + 1])
            } else {
                _mm512_setzero_si512()
            };
            _mm512_castsi512_ps(if D == 1 {
                _mm512_alignr_epi32::<1>(hi, lo)
            } else {
                _mm512_alignr_epi32::<2>(hi, lo)
            })
        }
    }

    /// The Taylor-expanded Y rotation by β (Křivánek et al. §3).
    #[inline(always)]
    unsafe fn taylor_y<const N: usize>(p: &Plan, kind: TaylorKind, beta: f32, x: &Regs) -> Regs {
        // SAFETY (whole body): the caller has AVX-512F.
        unsafe {
            let bb = _mm512_set1_ps(beta * beta);
            let b = _mm512_set1_ps(beta);
            let one = _mm512_set1_ps(1.0);
            let mut out = [_mm512_setzero_ps(); MAXV];
            for k in 0..nv(N) {
                let d1 = _mm512_sub_ps(
                    _mm512_mul_ps(ld16(&p.t_sub[k]), prev::<1>(x, k)),
                    _mm512_mul_ps(ld16(&p.t_sup[k]), next::<1>(x, k)),
                );
                let diag = if kind == TaylorKind::First {
                    x[k]
                } else {
                    _mm512_mul_ps(x[k], _mm512_fmadd_ps(bb, ld16(&p.t_d2[k]), one))
                };
                let mut v = _mm512_fmadd_ps(b, d1, diag);
                if kind == TaylorKind::Second {
                    let d2 = _mm512_fmadd_ps(
                        ld16(&p.t_s2[k]),
                        prev::<2>(x, k),
                        _mm512_mul_ps(ld16(&p.t_p2[k]), next::<2>(x, k)),
                    );
                    v = _mm512_fmadd_ps(bb, d2, v);
                }
                out[k] = v;
            }
            out
        }
    }

    /// `R_z(−γ) R̃_y(β) R_z(γ) x` for the first and 1.5th order, without the Z
    /// rotations: `R_z(−γ) R_y(β) R_z(γ)` turns by β about `(sin γ, cos γ, 0)`,
    /// whose generator is `cos γ R_y'(0) + sin γ G_x`; the diagonal `½R''`
    /// of the 1.5th order conjugates to itself except on the pairs `(l, ±1)`,
    /// where it picks up `cos 2γ, sin 2γ` terms. Algebraically identical to
    /// `R_z(−γ) · [R_z(γ)` then `shRotYdiff15` `]`; then `R_z(α+γ)` finishes the rotation.
    ///
    /// Scalars `[β cos γ, β sin γ, κ², s², c₂, n₂]` with `κ² s² = β²`,
    /// `κ² c₂ = β² cos 2γ`, `κ² n₂ = −β² sin 2γ` (from angles: `κ = β`, `s² = 1`);
    /// the 1.5th-order term is `κ² (s² d̄ ∘ x + c₂ δσ ∘ x + n₂ δ ∘ x̄)`.
    #[inline(always)]
    unsafe fn taylor_y_conjugated<const N: usize>(
        p: &Plan,
        kind: TaylorKind,
        [bc, bs, k2, s2, c2, n2]: [f32; 6],
        x: &Regs,
    ) -> Regs {
        // SAFETY (whole body): the caller has AVX-512F.
        unsafe {
            let xr = reverse::<N>(x);
            let [vbc, vbs, vk2, vs2, vc2, vn2] =
                [bc, bs, k2, s2, c2, n2].map(|v| _mm512_set1_ps(v));
            let mut out = [_mm512_setzero_ps(); MAXV];
            for k in 0..nv(N) {
                let dm1 = has_m_pm1(N, k);
                if narrow::<N>(k) {
                    // The same arithmetic on the low eight lanes.
                    let gy = _mm256_fmsub_ps(
                        ld8(&p.t_sub[k]),
                        lo(prev::<1>(x, k)),
                        _mm256_mul_ps(ld8(&p.t_sup[k]), next8(x[k])),
                    );
                    let gx = _mm256_fmadd_ps(
                        ld8(&p.g_prev[k]),
                        lo(prev::<1>(&xr, k)),
                        _mm256_mul_ps(ld8(&p.g_next[k]), next8(xr[k])),
                    );
                    let (xk, xrk) = (lo(x[k]), lo(xr[k]));
                    let mut v = _mm256_fmadd_ps(lo(vbs), gx, _mm256_fmadd_ps(lo(vbc), gy, xk));
                    if kind != TaylorKind::First {
                        let e = _mm256_mul_ps(lo(vs2), ld8(&p.t_dbar[k]));
                        let sd = if dm1 {
                            let e = _mm256_fmadd_ps(lo(vc2), ld8(&p.t_dsig[k]), e);
                            let h = _mm256_mul_ps(lo(vn2), ld8(&p.t_dhalf[k]));
                            _mm256_fmadd_ps(xk, e, _mm256_mul_ps(h, xrk))
                        } else {
                            _mm256_mul_ps(xk, e)
                        };
                        v = _mm256_fmadd_ps(lo(vk2), sd, v);
                    }
                    out[k] = _mm512_zextps256_ps512(v);
                    continue;
                }
                let gy = _mm512_fmsub_ps(
                    ld16(&p.t_sub[k]),
                    prev::<1>(x, k),
                    _mm512_mul_ps(ld16(&p.t_sup[k]), next::<1>(x, k)),
                );
                let gx = _mm512_fmadd_ps(
                    ld16(&p.g_prev[k]),
                    prev::<1>(&xr, k),
                    _mm512_mul_ps(ld16(&p.g_next[k]), next::<1>(&xr, k)),
                );
                // First order: x + β cos γ G_y x + β sin γ G_x x.
                let mut v = _mm512_fmadd_ps(vbs, gx, _mm512_fmadd_ps(vbc, gy, x[k]));
                if kind != TaylorKind::First {
                    // + κ² (s² d̄ ∘ x + c₂ δσ ∘ x + n₂ δ ∘ x̄)
                    let e = _mm512_mul_ps(vs2, ld16(&p.t_dbar[k]));
                    let sd = if dm1 {
                        let e = _mm512_fmadd_ps(vc2, ld16(&p.t_dsig[k]), e);
                        let h = _mm512_mul_ps(vn2, ld16(&p.t_dhalf[k]));
                        _mm512_fmadd_ps(x[k], e, _mm512_mul_ps(h, xr[k]))
                    } else {
                        // No (l, ±1) lane here: the δ tables are zero.
                        _mm512_mul_ps(x[k], e)
                    };
                    v = _mm512_fmadd_ps(vk2, sd, v);
                }
                out[k] = v;
            }
            out
        }
    }

    /// `M x` for a matrix in column pieces (four accumulators per register).
    #[inline(always)]
    unsafe fn apply_columns<const N: usize>(m: &ColumnPieces, x: &Regs) -> Regs {
        // SAFETY (whole body): the caller has AVX-512F; column indices are
        // `< N² ≤ 16·nv(N)`, inside `x`.
        unsafe {
            let xs = x.as_ptr().cast::<f32>();
            let mut out = [_mm512_setzero_ps(); MAXV];
            for k in 0..nv(N) {
                let (s, e) = (m.start[k], m.start[k + 1]);
                let (cols, vals) = (&m.cols[s..e], &m.vals[s..e]);
                let mut acc = [_mm512_setzero_ps(); 4];
                let mut it = cols.chunks_exact(4).zip(vals.chunks_exact(4));
                for (c, v) in &mut it {
                    for q in 0..4 {
                        let xj = _mm512_set1_ps(*xs.add(c[q] as usize));
                        acc[q] = _mm512_fmadd_ps(xj, ld16(&v[q]), acc[q]);
                    }
                }
                let rest = cols.len() % 4;
                let base = cols.len() - rest;
                for q in 0..rest {
                    let xj = _mm512_set1_ps(*xs.add(cols[base + q] as usize));
                    acc[q] = _mm512_fmadd_ps(xj, ld16(&vals[base + q]), acc[q]);
                }
                out[k] =
                    _mm512_add_ps(_mm512_add_ps(acc[0], acc[1]), _mm512_add_ps(acc[2], acc[3]));
            }
            out
        }
    }

    macro_rules! by_order {
        ($n:expr, $f:ident, $($arg:expr),*) => {
            match $n {
                2 => $f::<2>($($arg),*),
                3 => $f::<3>($($arg),*),
                4 => $f::<4>($($arg),*),
                5 => $f::<5>($($arg),*),
                6 => $f::<6>($($arg),*),
                7 => $f::<7>($($arg),*),
                8 => $f::<8>($($arg),*),
                9 => $f::<9>($($arg),*),
                10 => $f::<10>($($arg),*),
                _ => unreachable!("vectorised kernels cover orders 2..=10"),
            }
        };
    }

    #[target_feature(enable = "avx512f")]
    fn rotate_z_n<const N: usize>(c: f32, s: f32, src: &[f32], dst: &mut [f32]) {
        let x = load::<N>(src);
        // SAFETY: AVX-512F is enabled here.
        let y = unsafe { rot_z::<N>(c, s, &x) };
        store::<N>(&y, dst);
    }

    #[target_feature(enable = "avx512f")]
    fn rotate_z_in_place_n<const N: usize>(c: f32, s: f32, v: &mut [f32]) {
        let x = load::<N>(v);
        // SAFETY: AVX-512F is enabled here.
        let y = unsafe { rot_z::<N>(c, s, &x) };
        store::<N>(&y, v);
    }

    #[target_feature(enable = "avx512f")]
    fn taylor_y_n<const N: usize>(
        p: &Plan,
        kind: TaylorKind,
        beta: f32,
        src: &[f32],
        dst: &mut [f32],
    ) {
        let x = load::<N>(src);
        // SAFETY: AVX-512F is enabled here.
        let y = unsafe { taylor_y::<N>(p, kind, beta, &x) };
        store::<N>(&y, dst);
    }

    #[target_feature(enable = "avx512f")]
    fn taylor_rotation3_n<const N: usize>(
        p: &Plan,
        kind: TaylorKind,
        (ca, sa): (f32, f32),
        beta: f32,
        (cg, sg): (f32, f32),
        src: &[f32],
        dst: &mut [f32],
    ) {
        let x = load::<N>(src);
        // SAFETY: AVX-512F is enabled here.
        let y = unsafe {
            let u = rot_z::<N>(cg, sg, &x);
            let t = taylor_y::<N>(p, kind, beta, &u);
            rot_z::<N>(ca, sa, &t)
        };
        store::<N>(&y, dst);
    }

    #[target_feature(enable = "avx512f")]
    fn taylor3_matrix_n<const N: usize>(
        p: &Plan,
        kind: TaylorKind,
        m: &[f32],
        lim: f32,
        src: &[f32],
        dst: &mut [f32],
    ) -> bool {
        let m: &[f32; 9] = m.try_into().expect("3×3 matrix");
        let e = crate::rotation::Rot3::new_unchecked([
            [m[0], m[1], m[2]],
            [m[3], m[4], m[5]],
            [m[6], m[7], m[8]],
        ])
        .euler_zyz();
        let beta = crate::taylor::taylor_beta(e.sin_beta, e.cos_beta);
        if beta > lim {
            return false;
        }
        let x = load::<N>(src);
        // SAFETY: AVX-512F is enabled here.
        let y = unsafe {
            let u = rot_z::<N>(e.cos_gamma, e.sin_gamma, &x);
            let t = taylor_y::<N>(p, kind, beta, &u);
            rot_z::<N>(e.cos_alpha, e.sin_alpha, &t)
        };
        store::<N>(&y, dst);
        true
    }

    #[target_feature(enable = "avx512f")]
    #[allow(clippy::too_many_arguments)]
    fn taylor_fused_n<const N: usize>(
        p: &Plan,
        kind: TaylorKind,
        (cs, ss): (f32, f32),
        (beta, cg, sg): (f32, f32, f32),
        src: &[f32],
        dst: &mut [f32],
    ) {
        let x = load::<N>(src);
        // Y-step scalars from the angles: κ = β, (g_c, g_s) = (cos γ, sin γ), s² = 1.
        let ystep = [
            beta * cg,
            beta * sg,
            beta * beta,
            1.0,
            cg * cg - sg * sg,
            -2.0 * cg * sg,
        ];
        // SAFETY: AVX-512F is enabled here.
        let y = unsafe {
            let t = taylor_y_conjugated::<N>(p, kind, ystep, &x);
            rot_z::<N>(cs, ss, &t)
        };
        store::<N>(&y, dst);
    }

    /// The fused kernel's scalars read off a row-major rotation matrix `m`
    /// without angles (see [`crate::taylor::TaylorRotation::apply`]):
    /// `([R₀₀+R₁₁, R₁₀−R₀₁, 1/(1+cos β)], [β cos γ, β sin γ, κ², s², c₂, n₂])`
    /// with `κ = β/sin β` ([`crate::taylor::beta_over_sin`]), `β cos γ = −κR₂₀`,
    /// `β sin γ = κR₂₁`, `s² = sin²β = R₂₀² + R₂₁²`, `c₂ = R₂₀² − R₂₁²`,
    /// `n₂ = 2 R₂₀ R₂₁`, so that `κ² s² = β²`, `κ² c₂ = β² cos 2γ`,
    /// `κ² n₂ = −β² sin 2γ`. `None` when `cos β < 0` or
    /// `sin²β > sin²(`[`crate::taylor::SMALL_BETA_MAX`]`)`. Same polynomials
    /// as the generic functions, evaluated with fused multiply-adds.
    #[inline(always)]
    fn fused_scalars(m: &[f32; 9]) -> Option<([f32; 3], [f32; 6])> {
        use crate::taylor::{BETA_OVER_SIN as K, INV_ONE_PLUS_COS as Q, SMALL_SIN2_MAX};
        let fma = f32::mul_add;
        let (r20, r21, r22) = (m[6], m[7], m[8]);
        let r21sq = r21 * r21;
        let s2 = fma(r20, r20, r21sq);
        if !(r22 >= 0.0 && s2 <= SMALL_SIN2_MAX as f32) {
            return None;
        }
        // β / sin β in s² (lane 0) and 1 / (1 + cos β) in u = 1 − cos β
        // (lane 1), both by Estrin's scheme side by side (the second has degree
        // 5: its sixth coefficient is 0).
        let (k, inv) = {
            let c = |i: usize| {
                let q6 = if i < 6 { Q[i] as f32 } else { 0.0 };
                // SAFETY: the caller has AVX-512F (so SSE).
                unsafe { _mm_setr_ps(K[i] as f32, q6, 0.0, 0.0) }
            };
            // SAFETY (block): the caller has AVX-512F, which implies FMA.
            unsafe {
                let x = _mm_unpacklo_ps(_mm_set_ss(s2), _mm_set_ss(1.0 - r22));
                let x2 = _mm_mul_ps(x, x);
                let a = _mm_fmadd_ps(x, c(1), c(0));
                let b = _mm_fmadd_ps(x, c(3), c(2));
                let d = _mm_fmadd_ps(x, c(5), c(4));
                let e = _mm_fmadd_ps(x2, c(6), d);
                let r = _mm_fmadd_ps(x2, _mm_fmadd_ps(x2, e, b), a);
                (_mm_cvtss_f32(r), _mm_cvtss_f32(_mm_movehdup_ps(r)))
            }
        };
        Some((
            [m[0] + m[4], m[3] - m[1], inv],
            [
                -(k * r20),
                k * r21,
                k * k,
                s2,
                fma(r20, r20, -r21sq),
                (r20 + r20) * r21,
            ],
        ))
    }

    #[target_feature(enable = "avx512f")]
    fn taylor_fused_matrix_n<const N: usize>(
        p: &Plan,
        kind: TaylorKind,
        m: &[f32],
        lim2: f32,
        src: &[f32],
        dst: &mut [f32],
    ) -> bool {
        let m: &[f32; 9] = m.try_into().expect("3×3 matrix");
        match fused_scalars(m) {
            Some(([wc, ws, q], ystep)) if ystep[2] * ystep[3] <= lim2 => {
                let x = load::<N>(src);
                // SAFETY: AVX-512F is enabled here.
                let y = unsafe {
                    // R_z(α) R̃_y(β) R_z(γ) = R_z(α+γ) · [R_z(−γ) R̃_y(β) R_z(γ)],
                    // e^{i(α+γ)} = (R₀₀+R₁₁ + i(R₁₀−R₀₁)) / (1+cos β).
                    let t = taylor_y_conjugated::<N>(p, kind, ystep, &x);
                    rot_z::<N>(wc * q, ws * q, &t)
                };
                store::<N>(&y, dst);
                true
            }
            _ => false,
        }
    }

    #[target_feature(enable = "avx512f")]
    fn zyz_y_n<const N: usize>(p: &Plan, cb: f32, sb: f32, src: &[f32], dst: &mut [f32]) {
        let x = load::<N>(src);
        // SAFETY: AVX-512F is enabled here.
        let y = unsafe {
            let u = apply_columns::<N>(&p.x_plus, &x);
            let v = rot_z::<N>(cb, sb, &u);
            apply_columns::<N>(&p.x_minus, &v)
        };
        store::<N>(&y, dst);
    }

    #[target_feature(enable = "avx512f")]
    fn zyz_n<const N: usize>(
        p: &Plan,
        (ca, sa): (f32, f32),
        (cb, sb): (f32, f32),
        (cg, sg): (f32, f32),
        src: &[f32],
        dst: &mut [f32],
    ) {
        let x = load::<N>(src);
        // SAFETY: AVX-512F is enabled here.
        let y = unsafe {
            let a = rot_z::<N>(cg, sg, &x);
            let b = apply_columns::<N>(&p.x_plus, &a);
            let c = rot_z::<N>(cb, sb, &b);
            let d = apply_columns::<N>(&p.x_minus, &c);
            rot_z::<N>(ca, sa, &d)
        };
        store::<N>(&y, dst);
    }

    /// `dst = R_z(α) src` (Appendix C).
    ///
    /// # Safety
    /// The CPU must support AVX-512F ([`super::available`]).
    #[inline]
    pub(crate) unsafe fn rotate_z(order: usize, c: f32, s: f32, src: &[f32], dst: &mut [f32]) {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { by_order!(order, rotate_z_n, c, s, src, dst) }
    }

    /// In-place [`rotate_z`].
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline]
    pub(crate) unsafe fn rotate_z_in_place(order: usize, c: f32, s: f32, v: &mut [f32]) {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { by_order!(order, rotate_z_in_place_n, c, s, v) }
    }

    /// The Taylor Y step alone.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline]
    pub(crate) unsafe fn taylor_y_only(
        p: &Plan,
        kind: TaylorKind,
        beta: f32,
        src: &[f32],
        dst: &mut [f32],
    ) {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { by_order!(p.n, taylor_y_n, p, kind, beta, src, dst) }
    }

    /// `R_z(α) R̃_y(β) R_z(γ)` with the Taylor-expanded Y step in three steps;
    /// `angles = [cos α, sin α, β, cos γ, sin γ]`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    pub(crate) unsafe fn taylor_rotation3(
        p: &Plan,
        kind: TaylorKind,
        angles: [f32; 5],
        src: &[f32],
        dst: &mut [f32],
    ) {
        // SAFETY: the caller guarantees AVX-512F.
        // Scalars, not the array, cross the call: an array goes through memory
        // and its 8-byte reloads miss store-to-load forwarding.
        let [ca, sa, beta, cg, sg] = angles;
        unsafe {
            by_order!(
                p.n,
                taylor_rotation3_n,
                p,
                kind,
                (ca, sa),
                beta,
                (cg, sg),
                src,
                dst
            )
        }
    }

    /// The fused 1st/1.5th-order rotation `R_z(σ) · [R_z(−γ) R̃_y(β) R_z(γ)]`
    /// from `(cos σ, sin σ)` and `(β, cos γ, sin γ)`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    pub(crate) unsafe fn taylor_fused(
        p: &Plan,
        kind: TaylorKind,
        sigma: (f32, f32),
        y: (f32, f32, f32),
        src: &[f32],
        dst: &mut [f32],
    ) {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { by_order!(p.n, taylor_fused_n, p, kind, sigma, y, src, dst) }
    }

    /// [`taylor_fused`] with its scalars read off the rotation matrix `m`
    /// (row-major); `false` (nothing written) when the small-angle formulas do
    /// not apply or `β² > lim2`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    pub(crate) unsafe fn taylor_fused_matrix(
        p: &Plan,
        kind: TaylorKind,
        m: &[f32],
        lim2: f32,
        src: &[f32],
        dst: &mut [f32],
    ) -> bool {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { by_order!(p.n, taylor_fused_matrix_n, p, kind, m, lim2, src, dst) }
    }

    /// [`taylor_rotation3`] from a row-major rotation matrix; `false`
    /// (nothing written) when `β > lim`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    pub(crate) unsafe fn taylor3_matrix(
        p: &Plan,
        kind: TaylorKind,
        m: &[f32],
        lim: f32,
        src: &[f32],
        dst: &mut [f32],
    ) -> bool {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { by_order!(p.n, taylor3_matrix_n, p, kind, m, lim, src, dst) }
    }

    /// `R_x(−90°) R_z(β) R_x(90°)` (the exact Y rotation of the ZYZ method).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline]
    pub(crate) unsafe fn zyz_y(p: &Plan, cb: f32, sb: f32, src: &[f32], dst: &mut [f32]) {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { by_order!(p.n, zyz_y_n, p, cb, sb, src, dst) }
    }

    /// `R_z(α) R_x(−90°) R_z(β) R_x(90°) R_z(γ)` (ZYZ / "ZXZXZ");
    /// `angles = [cos α, sin α, cos β, sin β, cos γ, sin γ]`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    pub(crate) unsafe fn zyz(p: &Plan, angles: [f32; 6], src: &[f32], dst: &mut [f32]) {
        // SAFETY: the caller guarantees AVX-512F.
        let [ca, sa, cb, sb, cg, sg] = angles;
        unsafe { by_order!(p.n, zyz_n, p, (ca, sa), (cb, sb), (cg, sg), src, dst) }
    }
}

#[cfg(test)]
mod tests {
    //! The vectorised kernels against the portable code (f32) and against the
    //! exact Ivanic–Ruedenberg matrices in f64, at every order 1…10.
    use super::*;
    use crate::rotation::tests::{rand_rot, rand_vec};
    use crate::rotation::{
        ZyzRotation, rotate_z, rotate_z_in_place, rotate_z_in_place_portable, rotate_z_portable,
    };
    use crate::taylor::{TaylorOrder, TaylorRotation, TaylorY};

    /// `max |a − b| / max(1, ‖a‖₂)`: rounding differences relative to the vector's size.
    fn max_diff32(a: &[f32], b: &[f32]) -> f32 {
        let norm = a.iter().map(|x| x * x).sum::<f32>().sqrt().max(1.0);
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max)
            / norm
    }

    fn to32(v: &[f64]) -> Vec<f32> {
        v.iter().map(|&x| x as f32).collect()
    }

    /// Public entry points (vectorised where available) = portable code, f32.
    #[test]
    fn kernels_match_portable_f32() {
        // Without AVX-512 the entry points are the portable code itself.
        if !crate::fast::tests::avx512_or_skip() {
            return;
        }
        for order in 1..=SIMD_MAX_ORDER {
            let nn = order * order;
            let zyz = ZyzRotation::<f32>::new(order).unwrap();
            let ty = TaylorY::<f32>::new(order).unwrap();
            let mut scratch = vec![0.0f32; nn];
            for seed in 0..8u64 {
                let src = to32(&rand_vec(seed + 100, nn));
                let r = rand_rot(seed + 40).to_f32();
                let e = r.euler_zyz();
                let (mut a, mut b) = (vec![0.0f32; nn], vec![0.0f32; nn]);
                // Z rotation, out of place and in place.
                rotate_z(order, e.cos_alpha, e.sin_alpha, &src, &mut a);
                rotate_z_portable(order, e.cos_alpha, e.sin_alpha, &src, &mut b);
                assert!(
                    max_diff32(&a, &b) < 1e-6,
                    "z n={order} {}",
                    max_diff32(&a, &b)
                );
                let mut ip = src.clone();
                rotate_z_in_place(order, e.cos_alpha, e.sin_alpha, &mut ip);
                let mut ipp = src.clone();
                rotate_z_in_place_portable(order, e.cos_alpha, e.sin_alpha, &mut ipp);
                assert!(max_diff32(&ip, &ipp) < 1e-6, "z in place n={order}");
                assert!(
                    max_diff32(&ip, &a) < 1e-6,
                    "z in place vs out of place n={order}"
                );
                // ZYZ and its Y step.
                zyz.apply_euler(&e, &src, &mut a, &mut scratch);
                zyz.apply_euler_portable(&e, &src, &mut b, &mut scratch);
                assert!(
                    max_diff32(&a, &b) < 2e-6,
                    "zyz n={order} {}",
                    max_diff32(&a, &b)
                );
                zyz.apply_y(e.cos_beta, e.sin_beta, &src, &mut a, &mut scratch);
                zyz.apply_y_portable(e.cos_beta, e.sin_beta, &src, &mut b, &mut scratch);
                assert!(max_diff32(&a, &b) < 2e-6, "zyz y n={order}");
                // Taylor: the Y step alone and the full rotation.
                let beta = 0.05 + 0.05 * seed as f32;
                for kind in [
                    TaylorOrder::First,
                    TaylorOrder::OneAndHalf,
                    TaylorOrder::Second,
                ] {
                    ty.apply(kind, beta, &src, &mut a);
                    ty.apply_portable(kind, beta, &src, &mut b);
                    assert!(max_diff32(&a, &b) < 1e-6, "taylor y {kind:?} n={order}");
                    let tr = TaylorRotation::<f32>::new(order, kind, 10.0).unwrap();
                    let small = Rot3::from_euler_zyz(&crate::rotation::EulerZyz::from_angles(
                        0.3 + seed as f32,
                        beta,
                        -1.1 + 0.7 * seed as f32,
                    ));
                    let es = small.euler_zyz();
                    // From the matrix (direct angles where vectorised) = from Euler angles.
                    assert!(tr.apply(&small, &src, &mut a, &mut scratch));
                    assert!(tr.apply_euler(&es, &src, &mut b, &mut scratch));
                    assert!(
                        max_diff32(&a, &b) < 1e-6,
                        "taylor apply vs apply_euler {kind:?} n={order} {}",
                        max_diff32(&a, &b)
                    );
                    assert!(tr.apply_euler(&es, &src, &mut a, &mut scratch));
                    let b_beta = crate::taylor::taylor_beta(es.sin_beta, es.cos_beta);
                    let mut tmp = vec![0.0f32; nn];
                    rotate_z_portable(order, es.cos_gamma, es.sin_gamma, &src, &mut tmp);
                    ty.apply_portable(kind, b_beta, &tmp, &mut b);
                    rotate_z_in_place_portable(order, es.cos_alpha, es.sin_alpha, &mut b);
                    assert!(
                        max_diff32(&a, &b) < 1e-6,
                        "taylor rotation {kind:?} n={order} {}",
                        max_diff32(&a, &b)
                    );
                }
            }
        }
    }

    /// `TaylorRotation::apply` from a matrix agrees with `apply_euler` on every
    /// branch: Taylor path, β above β_lim (exact path), β > π/2 (Euler path).
    #[test]
    fn taylor_apply_from_matrix_all_branches() {
        for order in [2usize, 5, 6, 10] {
            let nn = order * order;
            let src = to32(&rand_vec(order as u64, nn));
            let (mut a, mut b, mut s) = (vec![0.0f32; nn], vec![0.0f32; nn], vec![0.0f32; nn]);
            for kind in [
                TaylorOrder::First,
                TaylorOrder::OneAndHalf,
                TaylorOrder::Second,
            ] {
                for (lim, beta, want_taylor) in
                    [(0.3f32, 0.2f32, true), (0.3, 0.9, false), (3.5, 2.5, true)]
                {
                    let tr = TaylorRotation::<f32>::new(order, kind, lim).unwrap();
                    let rot = Rot3::from_euler_zyz(&crate::rotation::EulerZyz::from_angles(
                        0.4, beta, -2.0,
                    ));
                    assert_eq!(tr.apply(&rot, &src, &mut a, &mut s), want_taylor);
                    assert_eq!(
                        tr.apply_euler(&rot.euler_zyz(), &src, &mut b, &mut s),
                        want_taylor
                    );
                    let d = max_diff32(&a, &b);
                    assert!(d < 2e-6, "{kind:?} n={order} β={beta}: {d}");
                }
            }
        }
    }

    /// Exact methods (vectorised f32 and portable f64) against the f64
    /// Ivanic–Ruedenberg matrix, orders 1…10, random rotations.
    #[test]
    fn exact_paths_match_ivanic_ruedenberg() {
        for order in 1..=SIMD_MAX_ORDER {
            let nn = order * order;
            let z64 = ZyzRotation::<f64>::new(order).unwrap();
            let z32 = ZyzRotation::<f32>::new(order).unwrap();
            for seed in 0..6u64 {
                let r = rand_rot(seed + 7);
                let src = rand_vec(seed + 3, nn);
                let mut want = vec![0.0; nn];
                ShRotation::from_rotation(order, &r)
                    .unwrap()
                    .apply(&src, &mut want);
                let mut got = vec![0.0; nn];
                let mut scratch = vec![0.0; nn];
                z64.apply(&r, &src, &mut got, &mut scratch);
                let e64 = got
                    .iter()
                    .zip(&want)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(e64 < 1e-12, "f64 zyz n={order}: {e64:e}");
                let src32 = to32(&src);
                let mut got32 = vec![0.0f32; nn];
                let mut s32 = vec![0.0f32; nn];
                z32.apply(&r.to_f32(), &src32, &mut got32, &mut s32);
                let e32 = got32
                    .iter()
                    .zip(&want)
                    .map(|(a, b)| (*a as f64 - b).abs())
                    .fold(0.0, f64::max);
                assert!(e32 < 1e-5, "f32 zyz n={order}: {e32:e}");
                // Z rotation alone, both precisions.
                let e = r.euler_zyz();
                let rz =
                    Rot3::from_axis_angle([0.0, 0.0, 1.0], e.sin_alpha.atan2(e.cos_alpha)).unwrap();
                ShRotation::from_rotation(order, &rz)
                    .unwrap()
                    .apply(&src, &mut want);
                rotate_z(order, e.cos_alpha, e.sin_alpha, &src, &mut got);
                let e64 = got
                    .iter()
                    .zip(&want)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(e64 < 1e-12, "f64 z n={order}: {e64:e}");
                rotate_z(
                    order,
                    e.cos_alpha as f32,
                    e.sin_alpha as f32,
                    &src32,
                    &mut got32,
                );
                let e32 = got32
                    .iter()
                    .zip(&want)
                    .map(|(a, b)| (*a as f64 - b).abs())
                    .fold(0.0, f64::max);
                assert!(e32 < 1e-5, "f32 z n={order}: {e32:e}");
            }
        }
    }

    /// The plans' tables: the band reversal is an involution and the X pieces
    /// hold every non-zero of the exact matrix.
    #[test]
    fn plan_tables_are_consistent() {
        for order in 1..=SIMD_MAX_ORDER {
            let p = plan(order);
            let t = z_tables(order);
            let nn = order * order;
            let nv = nn.div_ceil(LANES);
            let mut hit = vec![0usize; nn];
            for k in 0..nv {
                for (d, pc) in t.rev[k].iter().enumerate() {
                    for lane in 0..LANES {
                        if pc.mask & (1 << lane) != 0 {
                            hit[k * LANES + lane] += 1;
                            let from = (k + d - 1) * LANES + pc.idx.0[lane] as usize;
                            let (l, m) = crate::sh_lm(k * LANES + lane);
                            assert_eq!(from, crate::sh_index(l, -m));
                            let sel = t.sidx[k].0[lane];
                            assert_eq!(sel, if m > 0 { 16 + m as i32 } else { -m as i32 });
                            assert_eq!(t.cidx[k].0[lane], m.abs() as i32);
                        }
                    }
                }
            }
            assert!(hit.iter().all(|&h| h == 1), "order {order}: {hit:?}");
            let zyz = ZyzRotation::<f32>::new(order).unwrap();
            let nz: usize = p
                .x_plus
                .vals
                .iter()
                .map(|v| v.0.iter().filter(|x| **x != 0.0).count())
                .sum();
            assert_eq!(nz, zyz.x_nonzeros(), "order {order}");
            assert!(
                p.gx_residual < 1e-12,
                "order {order}: G_x residual {}",
                p.gx_residual
            );
        }
    }
}
