//! Křivánek et al.'s Taylor approximation of the SH Y rotation (2006).
//!
//! `R = R_z(α) R_y(β) R_z(γ)`; the Z rotations are exact and O(n²)
//! ([`crate::rotation::rotate_z`]); the Y rotation is replaced by its Taylor
//! expansion at β = 0 (paper §3):
//!
//! `R_y(β) ≈ I + β R_y'(0) + β²/2 R_y''(0)`.
//!
//! * **1st order**: `I + β R'`. `R'` is antisymmetric with non-zeros only on the
//!   sub- and super-diagonal of each band block (Figure 2), so only the
//!   sub-diagonal is stored.
//! * **1.5th order** (`shRotYdiff15`): adds only the *diagonal* of `β²/2 R''`.
//! * **2nd order**: the full `R''`, non-zero on the main diagonal and the
//!   diagonals two away from it.
//!
//! Cost `5n²` multiplications for the 1.5th order Y step (§3.1), O(n²) in total.
//! The derivative matrices are computed as in Appendix A: the Ivanic–Ruedenberg
//! recurrence carried out on truncated Taylor jets `(f, f', f'')` with the
//! product rule `(fg)'' = f''g + 2f'g' + fg''`, starting from band 1 of
//! `R_y(β)` (`cos β → (1, 0, −1)`, `sin β → (0, 1, 0)`). They are tested against
//! finite differences of the exact rotation.
//!
//! The approximation is only valid for small β; [`TaylorRotation`] switches to
//! the exact ZYZ rotation above `β_lim` (§4.2; the paper's radiance cache uses
//! `β_lim = 1.25 a` for its allowed error `a`).
//!
//! The vectors are stored flat over the whole coefficient vector (entries that
//! would couple different bands are zero), so the apply loops are single
//! contiguous sweeps that vectorise. For f32 at orders 2…10 on AVX-512F CPUs,
//! [`TaylorRotation`] runs `R_z(α) R̃_y(β) R_z(γ)` as one register-resident
//! kernel (see [`crate::rotation`], "Vectorised f32 path"). For the 1st and
//! 1.5th order it uses the algebraically identical form
//! `R_z(α+γ) · [R_z(−γ) R̃_y(β) R_z(γ)]`: the bracket is `I + β(cos γ R_y'(0) +
//! sin γ G_x) + β²·R_z(−γ) diag(½R'') R_z(γ)` with `G_x = R_z(−90°) R_y'(0)
//! R_z(90°)` the X-axis generator (it couples `(l, m)` with `(l, −m ± 1)`), and
//! the conjugated diagonal differs from `diag(½R'')` only on the pairs
//! `(l, ±1)` (terms in `cos 2γ, sin 2γ`) — one Z rotation fewer, same result
//! to rounding (tested against the three-step form).
//!
//! For RGB data (three coefficient vectors under one rotation, as in radiance
//! caching, §4.2) [`TaylorRotation::apply_rgb`] splits the rotation, finds β
//! and the multiple angles of α and γ once, and sweeps the three channels
//! through the three steps with the order a compile-time constant at the
//! paper's orders 6 and 10 (portable code, no allocation).

use crate::rotation::{EulerZyz, Rot3, ZyzRotation, rotate_z, rotate_z_in_place};
use crate::{MAX_ORDER, Real, ShError, check_order};

/// Which Taylor expansion to use for the Y rotation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum TaylorOrder {
    /// `I + β R'`.
    First,
    /// `I + β R' + β²/2 diag(R'')` — the paper's `shRotYdiff15`.
    OneAndHalf,
    /// `I + β R' + β²/2 R''`.
    Second,
}

/// `(f, f', f'')` at β = 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Jet([f64; 3]);

impl Jet {
    const ZERO: Jet = Jet([0.0; 3]);
    fn c(v: f64) -> Self {
        Jet([v, 0.0, 0.0])
    }
    fn mul(self, o: Jet) -> Jet {
        let (a, b) = (self.0, o.0);
        Jet([
            a[0] * b[0],
            a[1] * b[0] + a[0] * b[1],
            a[2] * b[0] + 2.0 * a[1] * b[1] + a[0] * b[2],
        ])
    }
    fn add(self, o: Jet) -> Jet {
        Jet([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
    }
    fn sub(self, o: Jet) -> Jet {
        Jet([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
    }
    fn scale(self, s: f64) -> Jet {
        Jet([self.0[0] * s, self.0[1] * s, self.0[2] * s])
    }
}

/// The Y-rotation derivative matrices `R_y'(0)`, `R_y''(0)` in block-diagonal
/// storage ([`crate::rotation::block_offset`]), f64, by the jet recurrence.
/// Returns `(first, second)`.
#[must_use]
pub fn y_rotation_derivatives(order: usize) -> (Vec<f64>, Vec<f64>) {
    use crate::rotation::{block_len, block_offset};
    let n = order;
    let mut b = vec![Jet::ZERO; block_len(n)];
    b[0] = Jet::c(1.0);
    if n > 1 {
        // Band 1 of R_y(β) in (y, z, x) order without CS signs:
        // R = [[c,0,s],[0,1,0],[−s,0,c]] → r1[i][j] = R[p(i)][p(j)], p = (1, 2, 0).
        let (c, s) = (Jet([1.0, 0.0, -1.0]), Jet([0.0, 1.0, 0.0]));
        let r = [
            [c, Jet::ZERO, s],
            [Jet::ZERO, Jet::c(1.0), Jet::ZERO],
            [s.scale(-1.0), Jet::ZERO, c],
        ];
        let p = [1usize, 2, 0];
        for i in 0..3 {
            for j in 0..3 {
                b[1 + i * 3 + j] = r[p[i]][p[j]];
            }
        }
    }
    let uvw = crate::rotation::ivanic_ruedenberg_uvw(n);
    let r1: [Jet; 9] = if n > 1 {
        b[1..10].try_into().unwrap()
    } else {
        [Jet::ZERO; 9]
    };
    let r1 = |i: isize, j: isize| r1[((i + 1) * 3 + (j + 1)) as usize];
    for l in 2..n {
        let li = l as isize;
        let (head, tail) = b.split_at_mut(block_offset(l));
        let prev = &head[block_offset(l - 1)..];
        let lp = li - 1;
        let wp = (2 * l - 1) as isize;
        let pv = |a: isize, c: isize| prev[((a + lp) * wp + (c + lp)) as usize];
        let p = |i: isize, a: isize, c: isize| -> Jet {
            if c == li {
                r1(i, 1).mul(pv(a, lp)).sub(r1(i, -1).mul(pv(a, -lp)))
            } else if c == -li {
                r1(i, 1).mul(pv(a, -lp)).add(r1(i, -1).mul(pv(a, lp)))
            } else {
                r1(i, 0).mul(pv(a, c))
            }
        };
        let w = 2 * l + 1;
        for m in -li..=li {
            for nn in -li..=li {
                let k = (m + li) as usize * w + (nn + li) as usize;
                let [u, v, ww] = uvw[block_offset(l) + k];
                let mut acc = Jet::ZERO;
                if m.abs() < li {
                    acc = acc.add(p(0, m, nn).scale(u));
                }
                let vv = if m == 0 {
                    p(1, 1, nn).add(p(-1, -1, nn))
                } else if m == 1 {
                    p(1, 0, nn).scale(std::f64::consts::SQRT_2)
                } else if m == -1 {
                    p(-1, 0, nn).scale(std::f64::consts::SQRT_2)
                } else if m > 0 {
                    p(1, m - 1, nn).sub(p(-1, -m + 1, nn))
                } else {
                    p(1, m + 1, nn).add(p(-1, -m - 1, nn))
                };
                acc = acc.add(vv.scale(v));
                if m != 0 && m.abs() < li - 1 {
                    let wv = if m > 0 {
                        p(1, m + 1, nn).add(p(-1, -m - 1, nn))
                    } else {
                        p(1, m - 1, nn).sub(p(-1, -m + 1, nn))
                    };
                    acc = acc.add(wv.scale(ww));
                }
                tail[k] = acc;
            }
        }
    }
    // Condon–Shortley signs (−1)^{m₁+m₂}.
    for l in 1..n {
        let w = 2 * l + 1;
        let o = block_offset(l);
        for i in 0..w {
            for j in ((i + 1) % 2..w).step_by(2) {
                b[o + i * w + j] = b[o + i * w + j].scale(-1.0);
            }
        }
    }
    (
        b.iter().map(|j| j.0[1]).collect(),
        b.iter().map(|j| j.0[2]).collect(),
    )
}

/// The Taylor-expanded Y rotation for one order: the stored diagonals of
/// `R_y'(0)` and `R_y''(0)` over the flat coefficient vector.
#[derive(Clone, Debug)]
pub struct TaylorY<T> {
    order: usize,
    /// `sub[i] = R'[i][i−1]` (0 at band starts), length `n² + 1` (last = 0).
    sub: Vec<T>,
    /// `½ R''[i][i]`.
    half_diag2: Vec<T>,
    /// `½ R''[i][i−2]` (0 across bands), length `n²`.
    half_sub2: Vec<T>,
    /// `½ R''[i][i+2]`, length `n²`.
    half_sup2: Vec<T>,
}

impl<T: Real> TaylorY<T> {
    /// Derivative matrices for `order` bands.
    pub fn new(order: usize) -> Result<Self, ShError> {
        check_order("order", order, MAX_ORDER)?;
        let (d1, d2) = y_rotation_derivatives(order);
        let nn = order * order;
        let mut sub = vec![T::ZERO; nn + 1];
        let mut half_diag2 = vec![T::ZERO; nn];
        let mut half_sub2 = vec![T::ZERO; nn];
        let mut half_sup2 = vec![T::ZERO; nn];
        for l in 0..order {
            let w = 2 * l + 1;
            let o = crate::rotation::block_offset(l);
            for i in 0..w {
                let g = l * l + i;
                if i >= 1 {
                    sub[g] = T::from_f64(d1[o + i * w + i - 1]);
                }
                half_diag2[g] = T::from_f64(0.5 * d2[o + i * w + i]);
                if i >= 2 {
                    half_sub2[g] = T::from_f64(0.5 * d2[o + i * w + i - 2]);
                }
                if i + 2 < w {
                    half_sup2[g] = T::from_f64(0.5 * d2[o + i * w + i + 2]);
                }
            }
        }
        Ok(Self {
            order,
            sub,
            half_diag2,
            half_sub2,
            half_sup2,
        })
    }

    /// Number of bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// `(R'[i][i−1] (length n²+1), ½R''[i][i], ½R''[i][i−2], ½R''[i][i+2])`.
    pub(crate) fn tables(&self) -> (&[T], &[T], &[T], &[T]) {
        (
            &self.sub,
            &self.half_diag2,
            &self.half_sub2,
            &self.half_sup2,
        )
    }

    /// `dst ≈ R_y(β) src` with the chosen expansion (β in radians). Orders ≤ 8
    /// run fully unrolled code; f32 at orders 2…10 runs the vectorised kernel
    /// (whole vector in registers, `R'` and `R''` terms as lane shifts) when
    /// the CPU has AVX-512F.
    ///
    /// # Panics
    /// If `src` or `dst` is shorter than `order²`.
    #[inline]
    pub fn apply(&self, kind: TaylorOrder, beta: T, src: &[T], dst: &mut [T]) {
        if crate::simd::try_taylor_y(self.order, kind.into(), beta, src, dst) {
            return;
        }
        self.apply_portable(kind, beta, src, dst);
    }

    /// [`apply`](Self::apply) without the vectorised f32 kernel.
    #[inline]
    pub(crate) fn apply_portable(&self, kind: TaylorOrder, beta: T, src: &[T], dst: &mut [T]) {
        match self.order {
            1 => dst[0] = src[0],
            2 => self.apply_fixed::<4>(kind, beta, src, dst),
            3 => self.apply_fixed::<9>(kind, beta, src, dst),
            4 => self.apply_fixed::<16>(kind, beta, src, dst),
            5 => self.apply_fixed::<25>(kind, beta, src, dst),
            6 => self.apply_fixed::<36>(kind, beta, src, dst),
            7 => self.apply_fixed::<49>(kind, beta, src, dst),
            8 => self.apply_fixed::<64>(kind, beta, src, dst),
            n => self.apply_dyn(n * n, kind, beta, src, dst),
        }
    }

    #[inline(always)]
    fn apply_fixed<const NN: usize>(&self, kind: TaylorOrder, beta: T, src: &[T], dst: &mut [T]) {
        self.apply_dyn(NN, kind, beta, src, dst);
    }

    #[inline(always)]
    fn apply_dyn(&self, nn: usize, kind: TaylorOrder, beta: T, src: &[T], dst: &mut [T]) {
        let (src, dst) = (&src[..nn], &mut dst[..nn]);
        let sub = &self.sub[..nn + 1];
        let bb = beta * beta;
        match kind {
            TaylorOrder::First => {
                dst[0] = src[0];
                for i in 1..nn - 1 {
                    dst[i] = src[i] + beta * (sub[i] * src[i - 1] - sub[i + 1] * src[i + 1]);
                }
                dst[nn - 1] = src[nn - 1] + beta * sub[nn - 1] * src[nn - 2];
            }
            TaylorOrder::OneAndHalf => {
                let d2 = &self.half_diag2[..nn];
                dst[0] = src[0];
                for i in 1..nn - 1 {
                    dst[i] = src[i] * (T::ONE + bb * d2[i])
                        + beta * (sub[i] * src[i - 1] - sub[i + 1] * src[i + 1]);
                }
                dst[nn - 1] =
                    src[nn - 1] * (T::ONE + bb * d2[nn - 1]) + beta * sub[nn - 1] * src[nn - 2];
            }
            TaylorOrder::Second => {
                let (d2, s2, p2) = (
                    &self.half_diag2[..nn],
                    &self.half_sub2[..nn],
                    &self.half_sup2[..nn],
                );
                dst[0] =
                    src[0] * (T::ONE + bb * d2[0]) - beta * sub[1] * src[1] + bb * p2[0] * src[2];
                dst[1] = src[1] * (T::ONE + bb * d2[1])
                    + beta * (sub[1] * src[0] - sub[2] * src[2])
                    + bb * p2[1] * src[3];
                for i in 2..nn - 2 {
                    dst[i] = src[i] * (T::ONE + bb * d2[i])
                        + beta * (sub[i] * src[i - 1] - sub[i + 1] * src[i + 1])
                        + bb * (s2[i] * src[i - 2] + p2[i] * src[i + 2]);
                }
                for i in (nn - 2).max(2)..nn {
                    let mut v = src[i] * (T::ONE + bb * d2[i])
                        + beta * sub[i] * src[i - 1]
                        + bb * s2[i] * src[i - 2];
                    if i + 1 < nn {
                        v -= beta * sub[i + 1] * src[i + 1];
                    }
                    dst[i] = v;
                }
            }
        }
    }
}

/// `atan2(y, x)` for `y ≥ 0` (β from its sine and cosine) by a degree-11
/// minimax polynomial: absolute error < 2e-6 rad.
#[inline]
#[must_use]
pub fn fast_atan2_upper<T: Real>(y: T, x: T) -> T {
    let ax = x.abs();
    let (num, den, swap) = if y > ax {
        (ax, y, true)
    } else {
        (y, ax, false)
    };
    let t = if den > T::ZERO { num / den } else { T::ZERO };
    let t2 = t * t;
    let c = |v: f64| T::from_f64(v);
    // Estrin's scheme (shorter dependency chain than Horner; same polynomial).
    let t4 = t2 * t2;
    let lo = c(0.999_866_0) + t2 * c(-0.330_299_5);
    let mid = c(0.180_141_0) + t2 * c(-0.085_133_0);
    let p = t * (lo + t4 * (mid + t4 * c(0.020_835_1)));
    let a = if swap {
        c(std::f64::consts::FRAC_PI_2) - p
    } else {
        p
    };
    if x < T::ZERO {
        c(std::f64::consts::PI) - a
    } else {
        a
    }
}

/// Largest β (radians) for which [`taylor_beta`] and the matrix fast path of
/// [`TaylorRotation::apply`] use the division-free small-angle formulas.
pub const SMALL_BETA_MAX: f64 = 0.75;
/// `sin²(SMALL_BETA_MAX)`.
pub(crate) const SMALL_SIN2_MAX: f64 = 0.464_631_399_166_148_5;

/// `β / sin β = asin(s)/s` as a polynomial in `s² = sin²β`, for
/// `0 ≤ s² ≤ sin²(0.75)` (β ≤ [`SMALL_BETA_MAX`]): a degree-6 minimax fit,
/// relative error < 6e-8 (tested). No division, square root or `atan2`, and no
/// singularity at β = 0 (the value there is 1).
#[inline(always)]
#[must_use]
pub fn beta_over_sin<T: Real>(s2: T) -> T {
    let c = |i: usize| T::from_f64(BETA_OVER_SIN[i]);
    // Estrin's scheme.
    let s4 = s2 * s2;
    let a = c(0) + s2 * c(1);
    let b = c(2) + s2 * c(3);
    let d = c(4) + s2 * c(5);
    let e = d + s4 * c(6);
    a + s4 * (b + s4 * e)
}

/// Coefficients of [`beta_over_sin`] (powers of `s²`, ascending).
pub(crate) const BETA_OVER_SIN: [f64; 7] = [
    1.000_000_05,
    0.166_656_434,
    0.075_331_923_4,
    0.040_658_442_3,
    0.052_583_439_9,
    -0.037_858_343_4,
    0.087_827_221_7,
];

/// Coefficients of [`inv_one_plus_cos`] (powers of `u`, ascending).
pub(crate) const INV_ONE_PLUS_COS: [f64; 6] = [
    0.499_999_998,
    0.250_000_583,
    0.124_974_902,
    0.062_891_181,
    0.028_543_757_5,
    0.023_885_076_8,
];

/// `1 / (1 + cos β)` as a polynomial in `u = 1 − cos β`, for
/// `0 ≤ u ≤ 1 − cos 0.75` (β ≤ [`SMALL_BETA_MAX`]): a degree-5 minimax fit,
/// relative error < 1e-8 (tested).
#[inline(always)]
#[must_use]
pub fn inv_one_plus_cos<T: Real>(u: T) -> T {
    let c = |i: usize| T::from_f64(INV_ONE_PLUS_COS[i]);
    let u2 = u * u;
    let a = c(0) + u * c(1);
    let b = c(2) + u * c(3);
    let d = c(4) + u * c(5);
    a + u2 * (b + u2 * d)
}

/// β in `[0, π]` from `sin β ≥ 0` and `cos β`, as the Taylor rotations use it:
/// for `cos β ≥ 0` and `sin²β ≤ sin²(0.75)` (β ≤ [`SMALL_BETA_MAX`]) it is
/// `sin β · β/sin β` with [`beta_over_sin`] (relative error < 1e-7, exact
/// behaviour at β → 0), otherwise [`fast_atan2_upper`]. The matrix fast path
/// of [`TaylorRotation::apply`] uses the same polynomial, so both entry points
/// agree to rounding.
#[inline]
#[must_use]
pub fn taylor_beta<T: Real>(sin_beta: T, cos_beta: T) -> T {
    let s2 = sin_beta * sin_beta;
    if cos_beta >= T::ZERO && s2 <= T::from_f64(SMALL_SIN2_MAX) {
        sin_beta * beta_over_sin(s2)
    } else {
        fast_atan2_upper(sin_beta, cos_beta)
    }
}

/// A full rotation with the Taylor-expanded Y step: `R_z(α) R̃_y(β) R_z(γ)`,
/// switching to the exact ZYZ rotation when `β > beta_lim` (§4.2).
#[derive(Clone, Debug)]
pub struct TaylorRotation<T> {
    pub kind: TaylorOrder,
    /// Largest β (radians) handled by the Taylor expansion.
    pub beta_lim: T,
    taylor: TaylorY<T>,
    exact: ZyzRotation<T>,
}

impl<T: Real> TaylorRotation<T> {
    /// Plan for `order` bands. `beta_lim` in radians (use `T::from_f64(f64::INFINITY)`
    /// to never switch).
    pub fn new(order: usize, kind: TaylorOrder, beta_lim: T) -> Result<Self, ShError> {
        if beta_lim.to_f64().is_nan() || beta_lim < T::ZERO {
            return Err(ShError::InvalidParameter {
                what: "beta_lim",
                why: "must be ≥ 0 radians".into(),
            });
        }
        Ok(Self {
            kind,
            beta_lim,
            taylor: TaylorY::new(order)?,
            exact: ZyzRotation::new(order)?,
        })
    }

    /// The underlying Y step.
    #[must_use]
    pub fn taylor_y(&self) -> &TaylorY<T> {
        &self.taylor
    }

    /// Applies the rotation given by Euler angles; `scratch` needs `order²` entries.
    /// Returns `true` when the Taylor path was used, `false` when β exceeded the limit.
    #[inline]
    pub fn apply_euler(
        &self,
        e: &EulerZyz<T>,
        src: &[T],
        dst: &mut [T],
        scratch: &mut [T],
    ) -> bool {
        let beta = taylor_beta(e.sin_beta, e.cos_beta);
        if beta > self.beta_lim {
            self.exact.apply_euler(e, src, dst, scratch);
            return false;
        }
        let n = self.taylor.order;
        if crate::simd::try_taylor_rotation(n, self.kind.into(), e, beta, src, dst) {
            return true;
        }
        rotate_z(n, e.cos_gamma, e.sin_gamma, src, scratch);
        self.taylor.apply(self.kind, beta, scratch, dst);
        rotate_z_in_place(n, e.cos_alpha, e.sin_alpha, dst);
        true
    }

    /// Decomposes `rot` (ZYZ) and applies it; see [`apply_euler`](Self::apply_euler).
    ///
    /// Where the vectorised 1st/1.5th-order kernel runs (f32, orders 2…10,
    /// AVX-512F) and `β ≤ min(β_lim, 0.75)`, no angle is extracted: the kernel
    /// needs only `β cos γ`, `β sin γ`, `β²`, `β² cos 2γ`, `β² sin 2γ` and
    /// `(cos, sin)(α+γ)`, and all of them are polynomials in the matrix entries.
    /// With `R₂₀ = −sin β cos γ`, `R₂₁ = sin β sin γ`, `s² = R₂₀² + R₂₁² = sin²β`
    /// and `k = β / sin β` ([`beta_over_sin`]`(s²)`):
    /// `β cos γ = −k R₂₀`, `β sin γ = k R₂₁`, `β² = k² s²`,
    /// `β² cos 2γ = k² (R₂₀² − R₂₁²)`, `β² sin 2γ = −2 k² R₂₀ R₂₁`; and
    /// `(R₀₀+R₁₁, R₁₀−R₀₁) = (1+cos β)(cos, sin)(α+γ)` with `1/(1+cos β)` from
    /// [`inv_one_plus_cos`]`(1 − R₂₂)`. No `atan2`, square root or division, no
    /// special case at β = 0 (where γ is undefined, `β cos γ = β sin γ = 0`
    /// follows from `R₂₀ = R₂₁ = 0`). The rotation applied is the same as
    /// through [`Rot3::euler_zyz`] and [`apply_euler`](Self::apply_euler)
    /// (tested on both sides of β_lim and near β = 0). The kernel applies the
    /// 1st-order term as `x + (β cos γ) G_y x + (β sin γ) G_x x` and the
    /// 1.5th-order term as `k² (s² d̄ ∘ x + c₂ δσ ∘ x + n₂ δ ∘ x̄)`
    /// (`c₂ = R₂₀² − R₂₁²`, `n₂ = 2R₂₀R₂₁`), so the 1.5th-order part waits
    /// for the polynomial `k` only in its last multiply-add.
    ///
    /// The 2nd order on the same CPUs computes [`Rot3::euler_zyz`] and
    /// [`taylor_beta`] inside the vectorised three-step kernel. Elsewhere
    /// (f64, other CPUs, larger β) this is `apply_euler(&rot.euler_zyz(), …)`.
    #[inline]
    pub fn apply(&self, rot: &Rot3<T>, src: &[T], dst: &mut [T], scratch: &mut [T]) -> bool {
        let (n, kind) = (self.taylor.order, self.kind.into());
        if self.kind == TaylorOrder::Second {
            if crate::simd::try_taylor3_matrix(n, kind, rot, self.beta_lim, src, dst) {
                return true;
            }
        } else if crate::simd::try_taylor_fused_matrix(n, kind, rot, self.beta_lim, src, dst) {
            return true;
        }
        self.apply_euler(&rot.euler_zyz(), src, dst, scratch)
    }
}

/// Whether the CPU has AVX2 and FMA (std caches the answer).
#[cfg(target_arch = "x86_64")]
#[inline]
fn avx2_fma() -> bool {
    crate::isa::isa() >= crate::isa::Isa::Avx2
}

/// `(cos mθ, sin mθ)` for `m = 0 … order−1` by the Chebyshev recurrence
/// (paper Appendix C).
#[inline(always)]
fn multiple_angles<T: Real>(order: usize, c1: T, s1: T, c: &mut [T], s: &mut [T]) {
    c[0] = T::ONE;
    s[0] = T::ZERO;
    if order > 1 {
        c[1] = c1;
        s[1] = s1;
    }
    let two_c = c1 + c1;
    for m in 2..order {
        c[m] = two_c * c[m - 1] - c[m - 2];
        s[m] = two_c * s[m - 1] - s[m - 2];
    }
}

impl<T: Real> TaylorRotation<T> {
    /// Rotates three coefficient vectors (RGB, channel-major: `src[c·n² + i]`,
    /// `3·n²` entries each for `src` and `dst`) by one rotation: the ZYZ split,
    /// β, and the multiple angles of α and γ are computed once and the three
    /// channels go through `R_z(α) R̃_y(β) R_z(γ)` side by side, band by band,
    /// with no allocation. `scratch` needs `3·n²` entries. Same rotation as
    /// [`apply_euler`](Self::apply_euler) on each channel (tested); returns
    /// `false` when β exceeded `β_lim` and the exact ZYZ rotation was used.
    ///
    /// # Panics
    /// If a buffer is shorter than `3·order²`.
    #[inline]
    pub fn apply_rgb(&self, rot: &Rot3<T>, src: &[T], dst: &mut [T], scratch: &mut [T]) -> bool {
        let n = self.taylor.order;
        let nn = n * n;
        let e = rot.euler_zyz();
        let beta = taylor_beta(e.sin_beta, e.cos_beta);
        let (src, dst, scratch) = (&src[..3 * nn], &mut dst[..3 * nn], &mut scratch[..3 * nn]);
        if beta > self.beta_lim {
            for c in 0..3 {
                let r = c * nn..(c + 1) * nn;
                self.exact
                    .apply_euler(&e, &src[r.clone()], &mut dst[r.clone()], &mut scratch[r]);
            }
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if n == 10 && avx2_fma() {
            // SAFETY: the CPU has AVX2 and FMA (checked at run time).
            unsafe { self.rgb_fixed_avx2::<10>(&e, beta, src, dst, scratch) };
            return true;
        }
        match n {
            6 => self.rgb_fixed::<6>(&e, beta, src, dst, scratch),
            10 => self.rgb_fixed::<10>(&e, beta, src, dst, scratch),
            _ => {
                let mut a = [[T::ZERO; MAX_ORDER]; 4];
                let [cg, sg, ca, sa] = &mut a;
                self.rgb_kernel(n, &e, beta, [cg, sg, ca, sa], src, dst, scratch);
            }
        }
        true
    }

    /// [`rgb_fixed`](Self::rgb_fixed) compiled for AVX2 + FMA (run-time
    /// dispatch; same arithmetic, no contraction, so the same results).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn rgb_fixed_avx2<const N: usize>(
        &self,
        e: &EulerZyz<T>,
        beta: T,
        src: &[T],
        dst: &mut [T],
        t: &mut [T],
    ) {
        self.rgb_fixed::<N>(e, beta, src, dst, t);
    }

    /// [`apply_rgb`](Self::apply_rgb)'s Taylor path with the order a
    /// constant, so the band loops unroll (the paper's Table 1 orders).
    #[inline(always)]
    fn rgb_fixed<const N: usize>(
        &self,
        e: &EulerZyz<T>,
        beta: T,
        src: &[T],
        dst: &mut [T],
        t: &mut [T],
    ) {
        let mut a = [[T::ZERO; N]; 4];
        let [cg, sg, ca, sa] = &mut a;
        self.rgb_kernel(N, e, beta, [cg, sg, ca, sa], src, dst, t);
    }

    /// The three steps for `n` bands over three channels: `t = R_z(γ) src`,
    /// `dst = R̃_y(β) t` (flat sweeps, [`TaylorY`]), `dst = R_z(α) dst` in
    /// place by `(l, ±m)` pairs; the multiple angles of α and γ once for all
    /// three channels (`angles` = `cos mγ, sin mγ, cos mα, sin mα`, `n`
    /// entries each).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn rgb_kernel(
        &self,
        n: usize,
        e: &EulerZyz<T>,
        beta: T,
        angles: [&mut [T]; 4],
        src: &[T],
        dst: &mut [T],
        t: &mut [T],
    ) {
        let nn = n * n;
        let [cg, sg, ca, sa] = angles;
        multiple_angles(n, e.cos_gamma, e.sin_gamma, cg, sg);
        multiple_angles(n, e.cos_alpha, e.sin_alpha, ca, sa);
        // Band by band through split slices: `(neg, c₀, pos)` with `neg`
        // reversed, so that the pair loops carry no index checks.
        for c in 0..3 {
            let (x, y) = (&src[c * nn..(c + 1) * nn], &mut t[c * nn..(c + 1) * nn]);
            for l in 0..n {
                let w = 2 * l + 1;
                let (xb, yb) = (&x[l * l..l * l + w], &mut y[l * l..l * l + w]);
                let (xn, xr) = xb.split_at(l);
                let (yn, yr) = yb.split_at_mut(l);
                yr[0] = xr[0];
                let pairs = xr[1..].iter().zip(xn.iter().rev());
                let outs = yr[1..].iter_mut().zip(yn.iter_mut().rev());
                let trig = cg[1..=l].iter().zip(&sg[1..=l]);
                for (((p, q), (yp, yq)), (cm, sm)) in pairs.zip(outs).zip(trig) {
                    *yp = *p * *cm - *q * *sm;
                    *yq = *q * *cm + *p * *sm;
                }
            }
        }
        for c in 0..3 {
            let r = c * nn..(c + 1) * nn;
            if nn == 1 {
                dst[c] = t[c];
            } else {
                self.taylor
                    .apply_dyn(nn, self.kind, beta, &t[r.clone()], &mut dst[r]);
            }
        }
        for c in 0..3 {
            let y = &mut dst[c * nn..(c + 1) * nn];
            for l in 1..n {
                let w = 2 * l + 1;
                let (yn, yr) = y[l * l..l * l + w].split_at_mut(l);
                let outs = yr[1..].iter_mut().zip(yn.iter_mut().rev());
                let trig = ca[1..=l].iter().zip(&sa[1..=l]);
                for ((yp, yq), (cm, sm)) in outs.zip(trig) {
                    let (p, q) = (*yp, *yq);
                    *yp = p * *cm - q * *sm;
                    *yq = q * *cm + p * *sm;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::tests::rand_vec;
    use crate::rotation::{ShRotation, block_offset};

    fn ry(order: usize, beta: f64) -> ShRotation<f64> {
        ShRotation::from_rotation(
            order,
            &Rot3::from_axis_angle([0.0, 1.0, 0.0], beta).unwrap(),
        )
        .unwrap()
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let order = 9;
        let (d1, d2) = y_rotation_derivatives(order);
        let h = 1e-4;
        let (p, m, z) = (ry(order, h), ry(order, -h), ry(order, 0.0));
        for k in 0..d1.len() {
            let fd1 = (p.blocks()[k] - m.blocks()[k]) / (2.0 * h);
            let fd2 = (p.blocks()[k] - 2.0 * z.blocks()[k] + m.blocks()[k]) / (h * h);
            assert!(
                (fd1 - d1[k]).abs() < 1e-6,
                "R' entry {k}: jet {} vs FD {fd1}",
                d1[k]
            );
            assert!(
                (fd2 - d2[k]).abs() < 1e-4,
                "R'' entry {k}: jet {} vs FD {fd2}",
                d2[k]
            );
        }
        // Sparsity of Figure 2: R' only on the ±1 diagonals, R'' on 0 and ±2.
        for l in 0..order {
            let w = 2 * l + 1;
            for i in 0..w {
                for j in 0..w {
                    let k = block_offset(l) + i * w + j;
                    let di = i as isize - j as isize;
                    if di.abs() != 1 {
                        assert!(d1[k].abs() < 1e-12, "R' ({l},{i},{j}) = {}", d1[k]);
                    }
                    if di != 0 && di.abs() != 2 {
                        assert!(d2[k].abs() < 1e-12, "R'' ({l},{i},{j}) = {}", d2[k]);
                    }
                }
                // antisymmetry of R'
                if i + 1 < w {
                    let (a, b) = (
                        d1[block_offset(l) + i * w + i + 1],
                        d1[block_offset(l) + (i + 1) * w + i],
                    );
                    assert!((a + b).abs() < 1e-12);
                }
            }
        }
    }

    /// Largest singular value of the error matrix `R_y(β) − R̃_y(β)` (Figure 3, top row).
    fn max_error(order: usize, kind: TaylorOrder, beta: f64) -> f64 {
        let t = TaylorY::<f64>::new(order).unwrap();
        let exact = ry(order, beta);
        let nn = order * order;
        let mut e = nalgebra::DMatrix::<f64>::zeros(nn, nn);
        let mut col = vec![0.0; nn];
        let mut out = vec![0.0; nn];
        let mut ex = vec![0.0; nn];
        for j in 0..nn {
            col.fill(0.0);
            col[j] = 1.0;
            t.apply(kind, beta, &col, &mut out);
            exact.apply(&col, &mut ex);
            for i in 0..nn {
                e[(i, j)] = ex[i] - out[i];
            }
        }
        e.singular_values().max()
    }

    #[test]
    fn taylor_error_shape_of_figure_3() {
        for order in [5, 8] {
            let b = 0.05;
            let e1 = [
                max_error(order, TaylorOrder::First, b),
                max_error(order, TaylorOrder::First, 2.0 * b),
            ];
            let e15 = [
                max_error(order, TaylorOrder::OneAndHalf, b),
                max_error(order, TaylorOrder::OneAndHalf, 2.0 * b),
            ];
            let e2 = [
                max_error(order, TaylorOrder::Second, b),
                max_error(order, TaylorOrder::Second, 2.0 * b),
            ];
            // Ordering: 2nd < 1.5th < 1st, errors grow with β.
            assert!(
                e2[0] < e15[0] && e15[0] < e1[0],
                "order {order}: e1 {e1:?} e15 {e15:?} e2 {e2:?}"
            );
            // Growth rates: 1st order error ∝ β², 2nd order ∝ β³.
            let r1 = e1[1] / e1[0];
            let r2 = e2[1] / e2[0];
            assert!(
                (r1 - 4.0).abs() < 0.4,
                "order {order}: 1st-order error ratio {r1} (expect ≈4)"
            );
            assert!(
                (r2 - 8.0).abs() < 0.8,
                "order {order}: 2nd-order error ratio {r2} (expect ≈8)"
            );
            // Higher SH order → larger error (Figure 3 left vs right).
            if order == 8 {
                assert!(
                    max_error(8, TaylorOrder::OneAndHalf, 0.2)
                        > max_error(5, TaylorOrder::OneAndHalf, 0.2)
                );
            }
        }
    }

    #[test]
    fn full_taylor_rotation_and_switch() {
        let order = 6;
        let f = rand_vec(1, order * order);
        let e = EulerZyz::from_angles(0.7f64, 0.05, -1.2);
        let rot = Rot3::from_euler_zyz(&e);
        let exact = ShRotation::from_rotation(order, &rot).unwrap();
        let mut want = vec![0.0; order * order];
        exact.apply(&f, &mut want);
        let norm = f.iter().map(|v| v * v).sum::<f64>().sqrt();
        let mut out = vec![0.0; order * order];
        let mut scratch = vec![0.0; order * order];
        for (kind, tol) in [
            (TaylorOrder::First, 0.05),
            (TaylorOrder::OneAndHalf, 0.02),
            (TaylorOrder::Second, 0.002),
        ] {
            let t = TaylorRotation::new(order, kind, 0.3).unwrap();
            assert!(t.apply(&rot, &f, &mut out, &mut scratch));
            let err = out
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt()
                / norm;
            assert!(err < tol, "{kind:?}: relative error {err}");
        }
        // Above β_lim the exact path is taken.
        let big = Rot3::from_euler_zyz(&EulerZyz::from_angles(0.7f64, 0.9, -1.2));
        let exact = ShRotation::from_rotation(order, &big).unwrap();
        exact.apply(&f, &mut want);
        let t = TaylorRotation::new(order, TaylorOrder::OneAndHalf, 0.3).unwrap();
        assert!(!t.apply(&big, &f, &mut out, &mut scratch));
        assert!(out.iter().zip(&want).all(|(a, b)| (a - b).abs() < 1e-12));
        assert!(TaylorRotation::<f32>::new(order, TaylorOrder::First, -1.0).is_err());
    }

    #[test]
    fn small_angle_polynomials_accuracy() {
        for k in 0..=3000 {
            let b = SMALL_BETA_MAX * k as f64 / 3000.0;
            let (sb, cb) = b.sin_cos();
            let want = if k == 0 { 1.0 } else { b / sb };
            let got = beta_over_sin(sb * sb);
            assert!(
                (got / want - 1.0).abs() < 1e-7,
                "β/sin β at β {b}: {got} vs {want}"
            );
            let inv = inv_one_plus_cos(1.0 - cb);
            assert!(
                (inv * (1.0 + cb) - 1.0).abs() < 2e-8,
                "1/(1+cos β) at β {b}: {inv}"
            );
            let tb = taylor_beta(sb, cb);
            assert!((tb - b).abs() <= 1e-7 * b, "taylor_beta at β {b}: {tb}");
        }
        // The small-angle branch ends at sin²β = sin²(0.75); past it (and for
        // cos β < 0) `taylor_beta` is `fast_atan2_upper`.
        assert!((SMALL_SIN2_MAX - SMALL_BETA_MAX.sin().powi(2)).abs() < 1e-15);
        for k in 0..=1000 {
            let b = std::f64::consts::PI * k as f64 / 1000.0;
            let got = taylor_beta(b.sin(), b.cos());
            assert!((got - b).abs() < 2e-5, "β {b}: {got}");
        }
        // Exactly 0 at β = 0, no division anywhere.
        assert_eq!(taylor_beta(0.0f32, 1.0), 0.0);
    }

    /// `TaylorRotation::<f32>::apply` from a matrix (on AVX-512F CPUs the
    /// angle-free kernel for the 1st/1.5th order, the in-kernel ZYZ split for
    /// the 2nd) against the three-step rotation built from the exact angles in
    /// f64: random α, γ; β = 0, tiny, below and above β_lim, around the end of
    /// the small-angle range and past π/2.
    #[test]
    fn apply_from_matrix_matches_exact_angles() {
        use crate::rotation::rotate_z_in_place;
        for order in [2usize, 3, 6, 10] {
            let nn = order * order;
            let src = rand_vec(order as u64 + 11, nn);
            let src32: Vec<f32> = src.iter().map(|&v| v as f32).collect();
            let ty = TaylorY::<f64>::new(order).unwrap();
            let (mut out, mut scr) = (vec![0.0f32; nn], vec![0.0f32; nn]);
            let (mut want, mut tmp) = (vec![0.0f64; nn], vec![0.0f64; nn]);
            for kind in [
                TaylorOrder::First,
                TaylorOrder::OneAndHalf,
                TaylorOrder::Second,
            ] {
                for lim in [0.3f64, f64::INFINITY] {
                    let tr = TaylorRotation::<f32>::new(order, kind, lim as f32).unwrap();
                    let betas = [0.0, 1e-7, 1e-4, 0.01, 0.29, 0.31, 0.7, 0.76, 1.5, 2.5];
                    for (i, &beta) in betas.iter().enumerate() {
                        for seed in 0..3 {
                            let a = 0.9 * seed as f64 + 0.37 * i as f64 - 2.0;
                            let g = -1.3 * seed as f64 + 0.53 * i as f64 + 0.7;
                            let rot = Rot3::from_euler_zyz(&EulerZyz::from_angles(a, beta, g));
                            let used = tr.apply(&rot.to_f32(), &src32, &mut out, &mut scr);
                            assert_eq!(used, beta <= lim, "{kind:?} n={order} β={beta}");
                            if used {
                                rotate_z(order, g.cos(), g.sin(), &src, &mut tmp);
                                ty.apply(kind, beta, &tmp, &mut want);
                                rotate_z_in_place(order, a.cos(), a.sin(), &mut want);
                            } else {
                                ShRotation::from_rotation(order, &rot)
                                    .unwrap()
                                    .apply(&src, &mut want);
                            }
                            let norm = want.iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0);
                            let err = out
                                .iter()
                                .zip(&want)
                                .map(|(&o, &w)| (o as f64 - w).abs())
                                .fold(0.0, f64::max)
                                / norm;
                            // f32 rounding; past the small-angle range β comes
                            // from `fast_atan2_upper` (≤ 2e-6 rad).
                            let tol = if beta <= SMALL_BETA_MAX { 1e-5 } else { 1e-4 };
                            assert!(err < tol, "{kind:?} n={order} β={beta} lim={lim}: {err:e}");
                        }
                    }
                }
            }
        }
    }

    /// The RGB entry point equals three single-channel rotations, on both
    /// sides of β_lim, for every expansion and a spread of orders.
    #[test]
    fn apply_rgb_matches_three_single_rotations() {
        for order in [1usize, 2, 3, 6, 7, 10] {
            let nn = order * order;
            let src = rand_vec(order as u64 + 3, 3 * nn);
            let (mut got, mut want) = (vec![0.0; 3 * nn], vec![0.0; 3 * nn]);
            let mut scr = vec![0.0; 3 * nn];
            for kind in [
                TaylorOrder::First,
                TaylorOrder::OneAndHalf,
                TaylorOrder::Second,
            ] {
                let tr = TaylorRotation::<f64>::new(order, kind, 0.3).unwrap();
                for (i, beta) in [0.0, 1e-3, 0.2, 0.29, 0.31, 1.2].into_iter().enumerate() {
                    let rot = Rot3::from_euler_zyz(&EulerZyz::from_angles(
                        0.4 - 0.7 * i as f64,
                        beta,
                        1.1 + 0.3 * i as f64,
                    ));
                    let used = tr.apply_rgb(&rot, &src, &mut got, &mut scr);
                    let mut used1 = true;
                    for c in 0..3 {
                        let r = c * nn..(c + 1) * nn;
                        used1 &= tr.apply_euler(
                            &rot.euler_zyz(),
                            &src[r.clone()],
                            &mut want[r],
                            &mut scr[..nn],
                        );
                    }
                    assert_eq!(used, used1, "{kind:?} n={order} β={beta}");
                    assert_eq!(used, beta <= 0.3);
                    let err = got
                        .iter()
                        .zip(&want)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0, f64::max);
                    assert!(err < 1e-12, "{kind:?} n={order} β={beta}: {err:e}");
                }
            }
        }
    }

    #[test]
    fn fast_atan2_accuracy() {
        for k in 0..=1000 {
            let b = std::f64::consts::PI * k as f64 / 1000.0;
            let got = fast_atan2_upper(b.sin(), b.cos());
            assert!((got - b).abs() < 2e-5, "β {b}: {got}");
        }
    }
}
