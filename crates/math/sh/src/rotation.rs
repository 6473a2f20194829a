//! Rotation of SH coefficient vectors.
//!
//! A rotation `R` acts on a band-limited function by `g(ω) = f(R⁻¹ω)`; on the
//! coefficients this is a block-diagonal orthogonal matrix with one
//! `(2l+1)²` block per band (bands never mix). Rotating `y(d)` gives `y(R d)`.
//!
//! Methods, each separately callable (all f32 and f64, allocation-free once built):
//!
//! * [`rotate_z`] — about +Z by α in O(n²): `(c_m, c_{−m})` pairs turn by `mα`,
//!   with `cos mα, sin mα` from the multiple-angle recurrence (Křivánek et al.
//!   2006, Appendix C);
//! * [`ShRotation`] built by [`IvanicRuedenberg`] — the exact matrices by the
//!   Ivanic–Ruedenberg recurrence (1996, errata 1998): band `l` from band `l−1`
//!   and band 1 through the `u, v, w` coefficients and `U, V, W, P` functions.
//!   Build once, apply many. Storage: blocks back to back, block `l` row-major
//!   at offset `l(4l²−1)/3` ([`block_offset`]);
//! * [`ZyzRotation`] — `R = R_z(α) R_y(β) R_z(γ)` with the Y rotation written as
//!   `R_x(−90°) R_z(β) R_x(+90°)`: two fixed, sparse X matrices (about a quarter
//!   non-zero) precomputed per order plus three O(n²) Z rotations — the "ZXZXZ"
//!   decomposition of Kautz et al. 2002 (Křivánek et al. §2.2, §3.1);
//! * [`rotate_zonal`] — a function symmetric about +Z (coefficients `z_l` of
//!   `y_{l,0}`) turned to point along `d`: `f_{l,m} = √(4π/(2l+1)) z_l y_{l,m}(d)`.
//!
//! The Taylor approximation of the Y rotation lives in [`crate::taylor`].
//!
//! **Vectorised f32 path.** For f32 vectors on CPUs with AVX-512F (detected at
//! run time), [`rotate_z`] and [`rotate_z_in_place`] at orders 4…10,
//! [`ZyzRotation`] at 3…10 and the Taylor rotations at 2…10 run kernels that keep the whole
//! coefficient vector in 16-lane registers: the Z rotation becomes
//! `C ∘ x + S ∘ x̄` (`x̄` = each band reversed, per-coefficient `cos |m|α`,
//! `−sin mα` gathered by lane permutes), the fixed X matrices are applied in
//! column form. Elsewhere (f64, larger orders, other CPUs) the portable code
//! below runs; both compute the same products and are tested against each
//! other (f32 results agree to rounding, ≲ 1e-6 relative).
//!
//! Rotation inputs are [`Rot3`]: a row-major 3×3 matrix acting on column
//! vectors. [`Rot3::try_new`] rejects non-orthonormal matrices (typed error);
//! quaternions are normalised (documented normalisation).

use crate::{MAX_ORDER, Real, ShError, ShFloatExt, check_order};

/// Offset of band `l`'s block in the block-diagonal storage: `Σ_{k<l} (2k+1)² = l(4l²−1)/3`.
#[inline]
#[must_use]
pub const fn block_offset(l: usize) -> usize {
    (4 * l * l * l - l) / 3
}

/// Number of stored entries for `order` bands: `n(4n²−1)/3`.
#[inline]
#[must_use]
pub const fn block_len(order: usize) -> usize {
    block_offset(order)
}

/// A 3D rotation, row-major (`m[i][j] = R_ij`), acting on column vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rot3<T> {
    pub m: [[T; 3]; 3],
}

/// ZYZ Euler angles as cosines and sines: `R = R_z(α) R_y(β) R_z(γ)`, `β ∈ [0, π]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EulerZyz<T> {
    pub cos_alpha: T,
    pub sin_alpha: T,
    pub cos_beta: T,
    pub sin_beta: T,
    pub cos_gamma: T,
    pub sin_gamma: T,
}

impl<T: Real> EulerZyz<T> {
    /// From angles in radians.
    #[must_use]
    pub fn from_angles(alpha: T, beta: T, gamma: T) -> Self {
        let (sa, ca) = alpha.sin_cos();
        let (sb, cb) = beta.sin_cos();
        let (sg, cg) = gamma.sin_cos();
        Self {
            cos_alpha: ca,
            sin_alpha: sa,
            cos_beta: cb,
            sin_beta: sb,
            cos_gamma: cg,
            sin_gamma: sg,
        }
    }
    /// β in radians, `[0, π]` when produced by [`Rot3::euler_zyz`].
    #[must_use]
    pub fn beta(&self) -> T {
        self.sin_beta.atan2(self.cos_beta)
    }
}

#[inline]
pub(crate) fn normalize2<T: Real>(c: T, s: T) -> (T, T) {
    let n2 = c * c + s * s;
    if n2.to_f64() > 0.0 {
        let inv = T::ONE / n2.sqrt();
        (c * inv, s * inv)
    } else {
        (T::ONE, T::ZERO)
    }
}

/// [`Rot3::euler_zyz`] with one square root and one division where
/// `sin β ≥ 0.1`: from `R = R_z(α) R_y(β) R_z(γ)`, the third column is
/// `sin β (cos α, sin α, ·)` and the third row `sin β (−cos γ, sin γ, ·)`, so
/// one `1 / sin β` normalises both (relative error ≈ ε / sin β ≤ 10 ε). Nearer
/// the poles it is [`Rot3::euler_zyz`] (α ± γ from the upper 2×2 block). This
/// is the decomposition [`ZyzRotation::apply`] uses: three dependent
/// square-root/division pairs were the longest chain of a low-order rotation.
#[inline]
pub(crate) fn euler_zyz_direct<T: Real>(rot: &Rot3<T>) -> EulerZyz<T> {
    euler_zyz_off_pole(rot).unwrap_or_else(|| rot.euler_zyz())
}

/// The one-division part of [`euler_zyz_direct`]: `None` where
/// `sin² β < 0.01`. Callers that keep the angles in registers branch on this
/// around their whole kernel (a join after the two decompositions sent the
/// angles through the stack, and the vector reload of four scalar stores
/// missed store-to-load forwarding).
#[inline]
pub(crate) fn euler_zyz_off_pole<T: Real>(rot: &Rot3<T>) -> Option<EulerZyz<T>> {
    let m = &rot.m;
    let sb2 = m[0][2] * m[0][2] + m[1][2] * m[1][2];
    if sb2.to_f64() < 0.01 {
        return None;
    }
    // 1/sin β as sin β · (1/sin² β): the square root and the division
    // run side by side instead of one after the other.
    let sb = sb2.sqrt();
    let inv = sb * (T::ONE / sb2);
    Some(EulerZyz {
        cos_alpha: m[0][2] * inv,
        sin_alpha: m[1][2] * inv,
        cos_beta: m[2][2],
        sin_beta: sb,
        cos_gamma: -(m[2][0] * inv),
        sin_gamma: m[2][1] * inv,
    })
}

impl<T: Real> Rot3<T> {
    /// The identity.
    #[must_use]
    pub fn identity() -> Self {
        let (o, z) = (T::ONE, T::ZERO);
        Self {
            m: [[o, z, z], [z, o, z], [z, z, o]],
        }
    }

    /// Wraps a matrix without checking it (the caller guarantees orthonormality).
    #[must_use]
    pub const fn new_unchecked(m: [[T; 3]; 3]) -> Self {
        Self { m }
    }

    /// Checks `max |RᵀR − I| ≤ tol` and `det > 0`; errors with
    /// [`ShError::NotARotation`] otherwise. Use `tol ≈ 1e-4` for f32 data.
    pub fn try_new(m: [[T; 3]; 3], tol: f64) -> Result<Self, ShError> {
        let mf = m.map(|r| r.map(|v| v.to_f64()));
        let mut dev: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let d: f64 = (0..3).map(|k| mf[k][i] * mf[k][j]).sum();
                dev = dev.max((d - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        let det = mf[0][0] * (mf[1][1] * mf[2][2] - mf[1][2] * mf[2][1])
            - mf[0][1] * (mf[1][0] * mf[2][2] - mf[1][2] * mf[2][0])
            + mf[0][2] * (mf[1][0] * mf[2][1] - mf[1][1] * mf[2][0]);
        if dev.is_nan() || dev > tol || det.is_nan() || det <= 0.0 {
            return Err(ShError::NotARotation {
                what: "rotation",
                deviation: dev,
                det,
            });
        }
        Ok(Self { m })
    }

    /// Rotation by `angle` radians about `axis` (normalised; error if zero / non-finite).
    pub fn from_axis_angle(axis: [T; 3], angle: T) -> Result<Self, ShError> {
        let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        if !(len.to_f64() > 0.0 && len.to_f64().is_finite()) {
            return Err(ShError::BadDirection {
                what: "axis",
                length: len.to_f64(),
            });
        }
        let [x, y, z] = axis.map(|v| v / len);
        let (s, c) = angle.sin_cos();
        let t = T::ONE - c;
        Ok(Self {
            m: [
                [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
            ],
        })
    }

    /// `R_z(α) R_y(β) R_z(γ)`.
    #[must_use]
    pub fn from_euler_zyz(e: &EulerZyz<T>) -> Self {
        let rz = |c: T, s: T| Self {
            m: [
                [c, -s, T::ZERO],
                [s, c, T::ZERO],
                [T::ZERO, T::ZERO, T::ONE],
            ],
        };
        let ry = Self {
            m: [
                [e.cos_beta, T::ZERO, e.sin_beta],
                [T::ZERO, T::ONE, T::ZERO],
                [-e.sin_beta, T::ZERO, e.cos_beta],
            ],
        };
        rz(e.cos_alpha, e.sin_alpha)
            .mul(&ry)
            .mul(&rz(e.cos_gamma, e.sin_gamma))
    }

    /// Matrix product `self · other`.
    #[must_use]
    pub fn mul(&self, o: &Self) -> Self {
        let mut m = [[T::ZERO; 3]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.m[i][0] * o.m[0][j] + self.m[i][1] * o.m[1][j] + self.m[i][2] * o.m[2][j];
            }
        }
        Self { m }
    }

    /// The inverse (transpose).
    #[must_use]
    pub fn transpose(&self) -> Self {
        let m = self.m;
        Self {
            m: [
                [m[0][0], m[1][0], m[2][0]],
                [m[0][1], m[1][1], m[2][1]],
                [m[0][2], m[1][2], m[2][2]],
            ],
        }
    }

    /// `R v`.
    #[must_use]
    pub fn apply(&self, v: [T; 3]) -> [T; 3] {
        let m = self.m;
        [
            m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
            m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
        ]
    }

    /// ZYZ Euler decomposition without inverse trigonometry, robust at the
    /// poles: `α` from the third column, `α ± γ` from the upper 2×2 block (whichever
    /// of `1 ± cos β` is larger), so `R_z(α)R_y(β)R_z(γ)` reproduces `R` to rounding
    /// even when `β ≈ 0` or `β ≈ π` (where α, γ alone are ill-defined).
    #[must_use]
    pub fn euler_zyz(&self) -> EulerZyz<T> {
        let m = self.m;
        let cb = m[2][2];
        let sb = (m[0][2] * m[0][2] + m[1][2] * m[1][2]).sqrt();
        let (ca, sa) = normalize2(m[0][2], m[1][2]);
        let (cg, sg) = if cb >= T::ZERO {
            // σ = α + γ from (R00 + R11, R10 − R01) = (1 + cos β)(cos σ, sin σ).
            let (cs, ss) = normalize2(m[0][0] + m[1][1], m[1][0] - m[0][1]);
            (cs * ca + ss * sa, ss * ca - cs * sa)
        } else {
            // δ = α − γ from (R11 − R00, −(R10 + R01)) = (1 − cos β)(cos δ, sin δ).
            let (cd, sd) = normalize2(m[1][1] - m[0][0], -(m[1][0] + m[0][1]));
            (ca * cd + sa * sd, sa * cd - ca * sd)
        };
        let cb = if cb > T::ONE {
            T::ONE
        } else if cb < -T::ONE {
            -T::ONE
        } else {
            cb
        };
        EulerZyz {
            cos_alpha: ca,
            sin_alpha: sa,
            cos_beta: cb,
            sin_beta: sb,
            cos_gamma: cg,
            sin_gamma: sg,
        }
    }
}

impl Rot3<f32> {
    /// From a quaternion (normalised first: documented normalisation; a zero or
    /// non-finite quaternion is an error).
    pub fn from_quat(q: glam::Quat) -> Result<Self, ShError> {
        let len = q.length();
        if !(len > 0.0 && len.is_finite()) {
            return Err(ShError::BadDirection {
                what: "quaternion",
                length: len as f64,
            });
        }
        Ok(Self::from_mat3_unchecked(glam::Mat3::from_quat(q / len)))
    }
    /// From a glam matrix (column-major storage), checked with tolerance 1e-4.
    pub fn try_from_mat3(m: glam::Mat3) -> Result<Self, ShError> {
        Self::try_new(Self::from_mat3_unchecked(m).m, 1e-4)
    }
    /// From a glam matrix without checking.
    #[must_use]
    pub fn from_mat3_unchecked(m: glam::Mat3) -> Self {
        let c = m.to_cols_array_2d();
        Self {
            m: [
                [c[0][0], c[1][0], c[2][0]],
                [c[0][1], c[1][1], c[2][1]],
                [c[0][2], c[1][2], c[2][2]],
            ],
        }
    }
}

impl Rot3<f64> {
    /// From a quaternion (normalised first; zero / non-finite is an error).
    pub fn from_dquat(q: glam::DQuat) -> Result<Self, ShError> {
        let len = q.length();
        if !(len > 0.0 && len.is_finite()) {
            return Err(ShError::BadDirection {
                what: "quaternion",
                length: len,
            });
        }
        Ok(Self::from_dmat3_unchecked(glam::DMat3::from_quat(q / len)))
    }
    /// From a glam matrix, checked with tolerance 1e-9.
    pub fn try_from_dmat3(m: glam::DMat3) -> Result<Self, ShError> {
        Self::try_new(Self::from_dmat3_unchecked(m).m, 1e-9)
    }
    /// From a glam matrix without checking.
    #[must_use]
    pub fn from_dmat3_unchecked(m: glam::DMat3) -> Self {
        let c = m.to_cols_array_2d();
        Self {
            m: [
                [c[0][0], c[1][0], c[2][0]],
                [c[0][1], c[1][1], c[2][1]],
                [c[0][2], c[1][2], c[2][2]],
            ],
        }
    }
    /// The f32 copy.
    #[must_use]
    pub fn to_f32(&self) -> Rot3<f32> {
        Rot3 {
            m: self.m.map(|r| r.map(|v| v as f32)),
        }
    }
}

// ---------------------------------------------------------------------------
// Z rotation
// ---------------------------------------------------------------------------

/// `cos mα, sin mα` for `m = 0 … order−1` by the multiple-angle recurrence
/// `cos mα = 2 cos α cos((m−1)α) − cos((m−2)α)` (same for sin).
#[inline(always)]
fn multiple_angles<T: Real>(order: usize, cos_a: T, sin_a: T, c: &mut [T], s: &mut [T]) {
    c[0] = T::ONE;
    s[0] = T::ZERO;
    if order > 1 {
        c[1] = cos_a;
        s[1] = sin_a;
    }
    let two_c = cos_a + cos_a;
    for m in 2..order {
        c[m] = two_c * c[m - 1] - c[m - 2];
        s[m] = two_c * s[m - 1] - s[m - 2];
    }
}

/// The Z rotation for a fixed order (`N` constant: fully unrolled for small N).
#[inline(always)]
fn rotate_z_fixed<T: Real, const N: usize>(cos_a: T, sin_a: T, src: &[T], dst: &mut [T]) {
    let (src, dst) = (&src[..N * N], &mut dst[..N * N]);
    let mut c = [T::ZERO; N];
    let mut s = [T::ZERO; N];
    multiple_angles(N, cos_a, sin_a, &mut c, &mut s);
    for l in 0..N {
        let b = l * (l + 1);
        dst[b] = src[b];
        for m in 1..=l {
            let (x, y) = (src[b + m], src[b - m]);
            dst[b + m] = x * c[m] - y * s[m];
            dst[b - m] = y * c[m] + x * s[m];
        }
    }
}

fn rotate_z_dyn<T: Real>(order: usize, cos_a: T, sin_a: T, src: &[T], dst: &mut [T]) {
    let (src, dst) = (&src[..order * order], &mut dst[..order * order]);
    let mut c = [T::ZERO; MAX_ORDER];
    let mut s = [T::ZERO; MAX_ORDER];
    multiple_angles(order, cos_a, sin_a, &mut c, &mut s);
    for l in 0..order {
        let b = l * (l + 1);
        dst[b] = src[b];
        for m in 1..=l {
            let (x, y) = (src[b + m], src[b - m]);
            dst[b + m] = x * c[m] - y * s[m];
            dst[b - m] = y * c[m] + x * s[m];
        }
    }
}

/// Rotates `src` about +Z by the angle whose cosine and sine are given, into
/// `dst` (`order²` entries each). O(n²): the pair `(c_{l,m}, c_{l,−m})` turns by
/// `mα`; `cos mα, sin mα` come from `cos(mα) = 2cos α cos((m−1)α) − cos((m−2)α)`
/// (Křivánek et al. 2006, Appendix C). Orders ≤ 8 run fully unrolled code;
/// f32 at orders 4…10 uses the vectorised kernel when the CPU has AVX-512F
/// (the multiple angles then come from binary powers of `e^{iα}`).
///
/// # Panics
/// If `src` or `dst` is shorter than `order²`, or `order > MAX_ORDER`.
#[inline]
pub fn rotate_z<T: Real>(order: usize, cos_a: T, sin_a: T, src: &[T], dst: &mut [T]) {
    if crate::simd::try_rotate_z(order, cos_a, sin_a, src, dst) {
        return;
    }
    rotate_z_portable(order, cos_a, sin_a, src, dst);
}

/// [`rotate_z`] without the vectorised f32 kernel.
#[inline]
pub(crate) fn rotate_z_portable<T: Real>(
    order: usize,
    cos_a: T,
    sin_a: T,
    src: &[T],
    dst: &mut [T],
) {
    match order {
        1 => rotate_z_fixed::<T, 1>(cos_a, sin_a, src, dst),
        2 => rotate_z_fixed::<T, 2>(cos_a, sin_a, src, dst),
        3 => rotate_z_fixed::<T, 3>(cos_a, sin_a, src, dst),
        4 => rotate_z_fixed::<T, 4>(cos_a, sin_a, src, dst),
        5 => rotate_z_fixed::<T, 5>(cos_a, sin_a, src, dst),
        6 => rotate_z_fixed::<T, 6>(cos_a, sin_a, src, dst),
        7 => rotate_z_fixed::<T, 7>(cos_a, sin_a, src, dst),
        8 => rotate_z_fixed::<T, 8>(cos_a, sin_a, src, dst),
        _ => rotate_z_dyn(order, cos_a, sin_a, src, dst),
    }
}

/// In-place [`rotate_z`] (via a stack copy of the vector).
///
/// # Panics
/// If `v` is shorter than `order²`, or `order > MAX_ORDER`.
#[inline]
pub fn rotate_z_in_place<T: Real>(order: usize, cos_a: T, sin_a: T, v: &mut [T]) {
    if crate::simd::try_rotate_z_in_place(order, cos_a, sin_a, v) {
        return;
    }
    rotate_z_in_place_portable(order, cos_a, sin_a, v);
}

/// [`rotate_z_in_place`] without the vectorised f32 kernel.
#[inline]
pub(crate) fn rotate_z_in_place_portable<T: Real>(order: usize, cos_a: T, sin_a: T, v: &mut [T]) {
    let nn = order * order;
    if order <= 8 {
        let mut tmp = [T::ZERO; 64];
        tmp[..nn].copy_from_slice(&v[..nn]);
        rotate_z_portable(order, cos_a, sin_a, &tmp, v);
    } else {
        let mut c = [T::ZERO; MAX_ORDER];
        let mut s = [T::ZERO; MAX_ORDER];
        multiple_angles(order, cos_a, sin_a, &mut c, &mut s);
        let v = &mut v[..nn];
        for l in 1..order {
            let b = l * (l + 1);
            for m in 1..=l {
                let (x, y) = (v[b + m], v[b - m]);
                v[b + m] = x * c[m] - y * s[m];
                v[b - m] = y * c[m] + x * s[m];
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Exact matrices: Ivanic–Ruedenberg
// ---------------------------------------------------------------------------

/// `Σ row_j x_j` with four partial sums (independent chains the compiler can
/// keep in one vector register) instead of one serial chain.
#[inline(always)]
fn dot4<T: Real>(row: &[T], x: &[T]) -> T {
    let mut acc = [T::ZERO; 4];
    let (rc, xc) = (row.chunks_exact(4), x.chunks_exact(4));
    let (rr, xr) = (rc.remainder(), xc.remainder());
    for (r, v) in rc.zip(xc) {
        for k in 0..4 {
            acc[k] += r[k] * v[k];
        }
    }
    let mut tail = T::ZERO;
    for (r, v) in rr.iter().zip(xr) {
        tail += *r * *v;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// A block-diagonal SH rotation matrix for `order` bands (exact), built by
/// [`IvanicRuedenberg::build`] or [`ShRotation::from_rotation`].
#[derive(Clone, Debug, PartialEq)]
pub struct ShRotation<T> {
    order: usize,
    /// Blocks back to back; block `l` row-major `(2l+1)²` at [`block_offset`]`(l)`,
    /// element `(m₁, m₂)` at `(m₁+l)(2l+1) + (m₂+l)`: `dst_{l,m₁} = Σ_{m₂} B_{m₁m₂} src_{l,m₂}`.
    blocks: Vec<T>,
}

impl<T: Real> ShRotation<T> {
    /// The identity for `order` bands.
    pub fn identity(order: usize) -> Result<Self, ShError> {
        check_order("order", order, MAX_ORDER)?;
        let mut blocks = vec![T::ZERO; block_len(order)];
        for l in 0..order {
            let w = 2 * l + 1;
            for i in 0..w {
                blocks[block_offset(l) + i * w + i] = T::ONE;
            }
        }
        Ok(Self { order, blocks })
    }

    /// Builds the exact matrix of `rot` (allocates a plan; for many rotations
    /// keep an [`IvanicRuedenberg`] and call [`IvanicRuedenberg::build`]).
    pub fn from_rotation(order: usize, rot: &Rot3<T>) -> Result<Self, ShError> {
        let plan = IvanicRuedenberg::new(order)?;
        let mut out = Self::identity(order)?;
        plan.build(rot, &mut out);
        Ok(out)
    }

    /// Number of bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Block of band `l`, row-major `(2l+1)²`.
    #[must_use]
    pub fn block(&self, l: usize) -> &[T] {
        &self.blocks[block_offset(l)..block_offset(l + 1)]
    }

    /// All blocks, contiguous.
    #[must_use]
    pub fn blocks(&self) -> &[T] {
        &self.blocks
    }

    /// Element `(l, m₁, m₂)`.
    #[must_use]
    pub fn get(&self, l: usize, m1: isize, m2: isize) -> T {
        let w = 2 * l + 1;
        self.blocks[block_offset(l) + (m1 + l as isize) as usize * w + (m2 + l as isize) as usize]
    }

    /// `dst = M src` for the first `self.order()²` coefficients. `src` may be
    /// of a higher order; only the leading bands are read.
    ///
    /// # Panics
    /// If `src` or `dst` is shorter than `order²`.
    #[inline]
    pub fn apply(&self, src: &[T], dst: &mut [T]) {
        let n = self.order;
        let (src, dst) = (&src[..n * n], &mut dst[..n * n]);
        dst[0] = src[0];
        let mut off = 1;
        for l in 1..n {
            let w = 2 * l + 1;
            let base = l * l;
            let s = &src[base..base + w];
            let blk = &self.blocks[off..off + w * w];
            for (i, row) in blk.chunks_exact(w).enumerate() {
                dst[base + i] = dot4(row, s);
            }
            off += w * w;
        }
    }

    /// Checked [`apply`](Self::apply): lengths and finiteness.
    pub fn try_apply(&self, src: &[T], dst: &mut [T]) -> Result<(), ShError> {
        crate::check_coeffs("src", self.order, src)?;
        if dst.len() != src.len() {
            return Err(ShError::LengthMismatch {
                what: "dst",
                order: self.order,
                expected: src.len(),
                got: dst.len(),
            });
        }
        self.apply(src, dst);
        Ok(())
    }

    /// Applies to three channels (RGB) at once: each matrix row is read once
    /// for the three dot products.
    ///
    /// # Panics
    /// If a slice is shorter than `order²`.
    pub fn apply_rgb(&self, src: [&[T]; 3], dst: [&mut [T]; 3]) {
        let n = self.order;
        let nn = n * n;
        let s = src.map(|s| &s[..nn]);
        let [d0, d1, d2] = dst;
        let (d0, d1, d2) = (&mut d0[..nn], &mut d1[..nn], &mut d2[..nn]);
        d0[0] = s[0][0];
        d1[0] = s[1][0];
        d2[0] = s[2][0];
        let mut off = 1;
        for l in 1..n {
            let w = 2 * l + 1;
            let base = l * l;
            let (a, b, c) = (
                &s[0][base..base + w],
                &s[1][base..base + w],
                &s[2][base..base + w],
            );
            let blk = &self.blocks[off..off + w * w];
            for (i, row) in blk.chunks_exact(w).enumerate() {
                d0[base + i] = dot4(row, a);
                d1[base + i] = dot4(row, b);
                d2[base + i] = dot4(row, c);
            }
            off += w * w;
        }
    }

    /// The product `self · other` (rotate by `other`, then by `self`).
    ///
    /// # Panics
    /// If the orders differ.
    #[must_use]
    pub fn compose(&self, other: &Self) -> Self {
        assert_eq!(self.order, other.order, "compose: orders differ");
        let mut out = self.clone();
        for l in 0..self.order {
            let w = 2 * l + 1;
            let o = block_offset(l);
            for i in 0..w {
                for j in 0..w {
                    out.blocks[o + i * w + j] = (0..w)
                        .map(|k| self.blocks[o + i * w + k] * other.blocks[o + k * w + j])
                        .sum();
                }
            }
        }
        out
    }

    /// The inverse rotation (each block transposed).
    #[must_use]
    pub fn inverse(&self) -> Self {
        let mut out = self.clone();
        for l in 0..self.order {
            let w = 2 * l + 1;
            let o = block_offset(l);
            for i in 0..w {
                for j in 0..w {
                    out.blocks[o + i * w + j] = self.blocks[o + j * w + i];
                }
            }
        }
        out
    }
}

/// The Ivanic–Ruedenberg `[u, v, w]` coefficients of every element of bands
/// `2 … order−1` in block-diagonal layout (f64), as in the original paper.
#[must_use]
pub fn ivanic_ruedenberg_uvw(order: usize) -> Vec<[f64; 3]> {
    let mut uvw = vec![[0.0; 3]; block_len(order)];
    for l in 2..order {
        let li = l as isize;
        let w = 2 * l + 1;
        for m in -li..=li {
            for n in -li..=li {
                let d = if m == 0 { 1.0 } else { 0.0 };
                let lf = l as f64;
                let (mf, nf) = (m as f64, n as f64);
                let denom = if n.abs() == li {
                    2.0 * lf * (2.0 * lf - 1.0)
                } else {
                    (lf + nf) * (lf - nf)
                };
                let am = mf.abs();
                let u = ((lf + mf) * (lf - mf) / denom).sqrt();
                let v = 0.5
                    * ((1.0 + d) * (lf + am - 1.0) * (lf + am) / denom).sqrt()
                    * (1.0 - 2.0 * d);
                let ww = -0.5 * ((lf - am - 1.0).max(0.0) * (lf - am) / denom).sqrt() * (1.0 - d);
                uvw[block_offset(l) + (m + li) as usize * w + (n + li) as usize] = [u, v, ww];
            }
        }
    }
    uvw
}

/// The exact-rotation plan: the Ivanic–Ruedenberg recurrence (1996/1998)
/// refactored for speed (depends only on the order; f32 or f64).
///
/// The recurrence writes element `(m, c)` of band `l` as
/// `u U + v V + w W`, where `U, V, W` combine the functions
/// `P_i(a, c)` (`i ∈ {−1, 0, 1}`, `|a| < l`) of band `l−1` and band 1, and
/// `u, v, w = û_m, v̂_m, ŵ_m / √denom(c)`. So per column `c` the plan first
/// forms the three vectors `Q_i(a) = P_i(a, c)/√denom(c)` (3(2l−1) products),
/// then every row `m` is a fixed combination of at most five `Q` entries with
/// precomputed weights — no branches in the inner loops.
#[derive(Clone, Debug)]
pub struct IvanicRuedenberg<T> {
    order: usize,
    /// Per band (from 2), per row m: five `(weight, index into Q)` terms.
    terms: Vec<[(T, u16); 5]>,
    /// Offsets of each band's rows in `terms`.
    term_off: Vec<usize>,
    /// Per band, per column c: `1/√denom(c)`.
    col_scale: Vec<T>,
}

impl<T: Real> IvanicRuedenberg<T> {
    /// The plan for `order` bands.
    pub fn new(order: usize) -> Result<Self, ShError> {
        check_order("order", order, MAX_ORDER)?;
        let mut terms = Vec::new();
        let mut term_off = vec![0; order.max(2) + 1];
        let mut col_scale = Vec::new();
        for l in 2..order {
            term_off[l] = terms.len();
            let li = l as isize;
            let lf = l as f64;
            let wp = 2 * l - 1;
            // Index of Q_i(a) in the per-column buffer.
            let qi = |i: isize, a: isize| ((i + 1) as usize * wp + (a + li - 1) as usize) as u16;
            for m in -li..=li {
                let am = m.abs();
                let amf = am as f64;
                let d = if m == 0 { 1.0 } else { 0.0 };
                let u = ((lf + m as f64) * (lf - m as f64)).sqrt();
                let v = 0.5 * ((1.0 + d) * (lf + amf - 1.0) * (lf + amf)).sqrt() * (1.0 - 2.0 * d);
                let w = -0.5 * ((lf - amf - 1.0).max(0.0) * (lf - amf)).sqrt() * (1.0 - d);
                let mut t: Vec<(f64, u16)> = Vec::new();
                if am < li {
                    t.push((u, qi(0, m)));
                }
                let s2 = std::f64::consts::SQRT_2;
                match m {
                    0 => {
                        t.push((v, qi(1, 1)));
                        t.push((v, qi(-1, -1)));
                    }
                    1 => t.push((v * s2, qi(1, 0))),
                    -1 => t.push((v * s2, qi(-1, 0))),
                    _ if m > 0 => {
                        t.push((v, qi(1, m - 1)));
                        t.push((-v, qi(-1, -m + 1)));
                    }
                    _ => {
                        t.push((v, qi(1, m + 1)));
                        t.push((v, qi(-1, -m - 1)));
                    }
                }
                if m != 0 && am < li - 1 {
                    if m > 0 {
                        t.push((w, qi(1, m + 1)));
                        t.push((w, qi(-1, -m - 1)));
                    } else {
                        t.push((w, qi(1, m - 1)));
                        t.push((-w, qi(-1, -m + 1)));
                    }
                }
                let mut arr = [(T::ZERO, 0u16); 5];
                for (k, (c, i)) in t.into_iter().enumerate() {
                    arr[k] = (T::from_f64(c), i);
                }
                terms.push(arr);
            }
            for c in -li..=li {
                let cf = c as f64;
                let denom = if c.abs() == li {
                    2.0 * lf * (2.0 * lf - 1.0)
                } else {
                    (lf + cf) * (lf - cf)
                };
                col_scale.push(T::from_f64(1.0 / denom.sqrt()));
            }
        }
        Ok(Self {
            order,
            terms,
            term_off,
            col_scale,
        })
    }

    /// Number of bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Fills `out` (which must have this plan's order) with the exact SH
    /// rotation matrix of `rot`. Allocation-free.
    ///
    /// Vectorised over the columns of each block: for a tile of
    /// `IR_TILE` columns the plan forms the `3(2l−1)` rows
    /// `Q_i(a, c) = P_i(a, c)/√denom(c)` once, then every row `m` of band `l`
    /// is at most five scaled `Q` rows added — contiguous, branch-free lanes.
    /// With AVX2+FMA (detected at run time) the same code is compiled for
    /// 256-bit registers; elsewhere it runs on the baseline ISA.
    ///
    /// # Panics
    /// If `out.order() != self.order()`.
    pub fn build(&self, rot: &Rot3<T>, out: &mut ShRotation<T>) {
        assert_eq!(
            out.order, self.order,
            "IvanicRuedenberg::build: order mismatch"
        );
        #[cfg(target_arch = "x86_64")]
        if crate::isa::isa() >= crate::isa::Isa::Avx2 {
            // SAFETY: the CPU has AVX2 and FMA (`isa` never exceeds the CPU's).
            unsafe { self.build_avx2(rot, out) };
            return;
        }
        self.build_portable(rot, out);
    }

    /// [`build`](Self::build) compiled for AVX2+FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn build_avx2(&self, rot: &Rot3<T>, out: &mut ShRotation<T>) {
        self.build_body(rot, out);
    }

    /// [`build`](Self::build) on the baseline ISA (also what the tests
    /// compare the AVX2 build against).
    pub(crate) fn build_portable(&self, rot: &Rot3<T>, out: &mut ShRotation<T>) {
        self.build_body(rot, out);
    }

    /// Picks the Q buffer's size for the order (zeroing it is part of the cost).
    #[inline(always)]
    fn build_body(&self, rot: &Rot3<T>, out: &mut ShRotation<T>) {
        match self.order {
            0..=8 => self.build_with::<{ 3 * 15 }>(rot, out),
            9..=16 => self.build_with::<{ 3 * 31 }>(rot, out),
            _ => self.build_with::<{ 3 * (2 * MAX_ORDER - 1) }>(rot, out),
        }
    }

    /// The build with room for `Q_ROWS = 3(2l−1)` tile rows of the top band.
    #[inline(always)]
    fn build_with<const Q_ROWS: usize>(&self, rot: &Rot3<T>, out: &mut ShRotation<T>) {
        let n = self.order;
        debug_assert!(n < 2 || 3 * (2 * n - 3) <= Q_ROWS);
        let b = &mut out.blocks[..block_len(n)];
        b[0] = T::ONE;
        if n == 1 {
            return;
        }
        // Band 1 in the (y, z, x) order without the Condon–Shortley signs; the
        // signs (−1)^{m₁+m₂} are applied to every block at the end.
        let r = rot.m;
        let r1 = [
            [r[1][1], r[1][2], r[1][0]],
            [r[2][1], r[2][2], r[2][0]],
            [r[0][1], r[0][2], r[0][0]],
        ];
        for i in 0..3 {
            for j in 0..3 {
                b[1 + i * 3 + j] = r1[i][j];
            }
        }
        // Q rows of one tile: row (i+1)(2l−1) + a, IR_TILE lanes each.
        let mut q = [[T::ZERO; IR_TILE]; Q_ROWS];
        let mut cs_off = 0;
        for l in 2..n {
            let wp = 2 * l - 1;
            let w = 2 * l + 1;
            let (head, tail) = b.split_at_mut(block_offset(l));
            let prev = &head[block_offset(l - 1)..block_offset(l)];
            let cur = &mut tail[..w * w];
            let terms = &self.terms[self.term_off[l]..self.term_off[l] + w];
            let scales = &self.col_scale[cs_off..cs_off + w];
            cs_off += w;
            for c0 in (0..w).step_by(IR_TILE) {
                let tw = IR_TILE.min(w - c0);
                // Column scales of the tile; interior columns c take
                // prev(a, c−1), the two end columns c = ∓l combinations of
                // prev's first and last columns.
                let mut sc = [T::ZERO; IR_TILE];
                sc[..tw].copy_from_slice(&scales[c0..c0 + tw]);
                for a in 0..wp {
                    let p = &prev[a * wp..(a + 1) * wp];
                    let mut shifted = [T::ZERO; IR_TILE];
                    for (c, s) in shifted.iter_mut().enumerate().take(tw) {
                        let g = c0 + c;
                        if g >= 1 && g + 1 < w {
                            *s = p[g - 1];
                        }
                    }
                    for i in 0..3 {
                        let row = &mut q[i * wp + a];
                        let e1 = r1[i][1];
                        for c in 0..IR_TILE {
                            row[c] = e1 * sc[c] * shifted[c];
                        }
                        let (a1, a0) = (r1[i][2], r1[i][0]);
                        if c0 == 0 {
                            row[0] = sc[0] * (a1 * p[0] + a0 * p[wp - 1]);
                        }
                        if w - 1 - c0 < IR_TILE {
                            let k = w - 1 - c0;
                            row[k] = sc[k] * (a1 * p[wp - 1] - a0 * p[0]);
                        }
                    }
                }
                for (m, t) in terms.iter().enumerate() {
                    let (r0, r1_, r2, r3, r4) = (
                        &q[t[0].1 as usize],
                        &q[t[1].1 as usize],
                        &q[t[2].1 as usize],
                        &q[t[3].1 as usize],
                        &q[t[4].1 as usize],
                    );
                    let mut v = [T::ZERO; IR_TILE];
                    for c in 0..IR_TILE {
                        v[c] = t[0].0 * r0[c]
                            + t[1].0 * r1_[c]
                            + t[2].0 * r2[c]
                            + t[3].0 * r3[c]
                            + t[4].0 * r4[c];
                    }
                    cur[m * w + c0..m * w + c0 + tw].copy_from_slice(&v[..tw]);
                }
            }
        }
        // Condon–Shortley signs (−1)^{m₁+m₂}: odd positions of even rows and
        // even positions of odd rows.
        let mut alt = [T::ZERO; 2 * MAX_ORDER + 2];
        for (j, a) in alt.iter_mut().enumerate() {
            *a = if j % 2 == 0 { T::ONE } else { -T::ONE };
        }
        for l in 1..n {
            let w = 2 * l + 1;
            let o = block_offset(l);
            for (i, row) in b[o..o + w * w].chunks_exact_mut(w).enumerate() {
                let sign = &alt[i % 2..i % 2 + w];
                for (x, s) in row.iter_mut().zip(sign) {
                    *x *= *s;
                }
            }
        }
    }
}

/// Columns per tile of [`IvanicRuedenberg::build`] (one 256-bit f32 register).
const IR_TILE: usize = 8;

// ---------------------------------------------------------------------------
// ZYZ with fixed X rotations ("ZXZXZ")
// ---------------------------------------------------------------------------

/// Sparse matrix in CSR form over the whole coefficient vector (used for the
/// fixed ±90° X rotations).
#[derive(Clone, Debug)]
struct Csr<T> {
    row_start: Vec<u32>,
    cols: Vec<u16>,
    vals: Vec<T>,
}

impl<T: Real> Csr<T> {
    fn from_rotation(r: &ShRotation<f64>) -> Self {
        let n = r.order();
        let mut row_start = vec![0u32];
        let (mut cols, mut vals) = (Vec::new(), Vec::new());
        for l in 0..n {
            let w = 2 * l + 1;
            for i in 0..w {
                for j in 0..w {
                    let v = r.block(l)[i * w + j];
                    if v.abs() > 1e-12 {
                        cols.push((l * l + j) as u16);
                        vals.push(T::from_f64(v));
                    }
                }
                row_start.push(cols.len() as u32);
            }
        }
        Self {
            row_start,
            cols,
            vals,
        }
    }

    #[inline]
    fn apply(&self, src: &[T], dst: &mut [T]) {
        let rows = self.row_start.len() - 1;
        let src = &src[..rows];
        let (mut cols, mut vals) = (&self.cols[..], &self.vals[..]);
        for (d, w) in dst[..rows].iter_mut().zip(self.row_start.windows(2)) {
            let len = (w[1] - w[0]) as usize;
            let (c, rest_c) = cols.split_at(len);
            let (v, rest_v) = vals.split_at(len);
            let mut acc = T::ZERO;
            for (cv, vv) in c.iter().zip(v) {
                // SAFETY: every column index was produced by `from_rotation` as
                // `l² + j < order² = rows = src.len()`.
                acc += *vv * unsafe { *src.get_unchecked(*cv as usize) };
            }
            *d = acc;
            cols = rest_c;
            vals = rest_v;
        }
    }

    fn nnz(&self) -> usize {
        self.vals.len()
    }
}

/// The ZYZ ("ZXZXZ") rotation plan for one order: the two fixed sparse
/// matrices `R_x(±90°)`. Apply with Euler angles from [`Rot3::euler_zyz`].
#[derive(Clone, Debug)]
pub struct ZyzRotation<T> {
    order: usize,
    x_plus: Csr<T>,
    x_minus: Csr<T>,
}

impl<T: Real> ZyzRotation<T> {
    /// The plan for `order` bands (computes the fixed X matrices exactly in f64).
    pub fn new(order: usize) -> Result<Self, ShError> {
        check_order("order", order, MAX_ORDER)?;
        let h = std::f64::consts::FRAC_PI_2;
        let xp =
            ShRotation::<f64>::from_rotation(order, &Rot3::from_axis_angle([1.0, 0.0, 0.0], h)?)?;
        let xm = xp.inverse();
        Ok(Self {
            order,
            x_plus: Csr::from_rotation(&xp),
            x_minus: Csr::from_rotation(&xm),
        })
    }

    /// Number of bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Non-zeros of one fixed X matrix (for the cost model).
    #[must_use]
    pub fn x_nonzeros(&self) -> usize {
        self.x_plus.nnz()
    }

    /// `dst = R_z(α) R_x(−90°) R_z(β) R_x(90°) R_z(γ) src`; `scratch` needs `order²` entries.
    ///
    /// # Panics
    /// If a buffer is shorter than `order²`.
    #[inline]
    pub fn apply_euler(&self, e: &EulerZyz<T>, src: &[T], dst: &mut [T], scratch: &mut [T]) {
        if crate::simd::try_zyz(self.order, e, src, dst)
            || crate::simd_avx2::try_zyz(self.order, e, src, dst)
        {
            return;
        }
        if let (Some(s32), Some(d32)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst)) {
            let e32 = EulerZyz {
                cos_alpha: e.cos_alpha.to_f64() as f32,
                sin_alpha: e.sin_alpha.to_f64() as f32,
                cos_beta: e.cos_beta.to_f64() as f32,
                sin_beta: e.sin_beta.to_f64() as f32,
                cos_gamma: e.cos_gamma.to_f64() as f32,
                sin_gamma: e.sin_gamma.to_f64() as f32,
            };
            if crate::fast::rotate_euler_one(self.order, &e32, s32, d32) {
                return;
            }
        }
        self.apply_euler_portable(e, src, dst, scratch);
    }

    /// [`apply_euler`](Self::apply_euler) without the vectorised f32 kernel.
    #[inline]
    pub(crate) fn apply_euler_portable(
        &self,
        e: &EulerZyz<T>,
        src: &[T],
        dst: &mut [T],
        scratch: &mut [T],
    ) {
        let n = self.order;
        let nn = n * n;
        let (dst, tmp) = (&mut dst[..nn], &mut scratch[..nn]);
        rotate_z_portable(n, e.cos_gamma, e.sin_gamma, src, dst);
        self.x_plus.apply(dst, tmp);
        rotate_z_in_place_portable(n, e.cos_beta, e.sin_beta, tmp);
        self.x_minus.apply(tmp, dst);
        rotate_z_in_place_portable(n, e.cos_alpha, e.sin_alpha, dst);
    }

    /// Only the Y rotation by β (cosine, sine given): `R_x(−90°) R_z(β) R_x(90°)`.
    #[inline]
    pub fn apply_y(&self, cos_b: T, sin_b: T, src: &[T], dst: &mut [T], scratch: &mut [T]) {
        if crate::simd::try_zyz_y(self.order, cos_b, sin_b, src, dst) {
            return;
        }
        self.apply_y_portable(cos_b, sin_b, src, dst, scratch);
    }

    /// [`apply_y`](Self::apply_y) without the vectorised f32 kernel.
    #[inline]
    pub(crate) fn apply_y_portable(
        &self,
        cos_b: T,
        sin_b: T,
        src: &[T],
        dst: &mut [T],
        scratch: &mut [T],
    ) {
        let nn = self.order * self.order;
        let tmp = &mut scratch[..nn];
        self.x_plus.apply(src, tmp);
        rotate_z_in_place_portable(self.order, cos_b, sin_b, tmp);
        self.x_minus.apply(tmp, dst);
    }

    /// Applies `rot`. For f32 up to [`crate::fast::KERNEL_ROTATE_MAX_ORDER`]
    /// this is the generated kernel of [`crate::fast`] (bands 1 and 2 straight
    /// from the matrix, bands ≥ 3 by ZYZ, the same products as
    /// [`apply_euler`](Self::apply_euler) to rounding); otherwise it decomposes
    /// `rot` (`euler_zyz_direct`) and applies the angles.
    #[inline]
    pub fn apply(&self, rot: &Rot3<T>, src: &[T], dst: &mut [T], scratch: &mut [T]) {
        if let (Some(s32), Some(d32)) = (T::as_f32_slice(src), T::as_f32_slice_mut(dst)) {
            // `T` is f32 here: the matrix is reinterpreted, not converted.
            if let Some(m) = T::as_f32_slice(rot.m.as_flattened())
                && let Ok(m) = <&[f32; 9]>::try_from(m)
            {
                // SAFETY: `[f32; 9]` and `[[f32; 3]; 3]` have the same layout.
                let m = unsafe { &*std::ptr::from_ref(m).cast::<[[f32; 3]; 3]>() };
                if crate::fast::rotate_one(self.order, m, s32, d32) {
                    return;
                }
            }
        }
        self.apply_euler(&euler_zyz_direct(rot), src, dst, scratch);
    }
}

// ---------------------------------------------------------------------------
// Zonal rotation
// ---------------------------------------------------------------------------

/// Turns a zonal function (symmetric about +Z, coefficients `zonal[l]` of
/// `y_{l,0}`, `l < order`) to point along the unit direction `dir`:
/// `out_{l,m} = √(4π/(2l+1)) zonal[l] y_{l,m}(dir)`. O(n²), allocation-free.
///
/// # Panics
/// If `zonal.len() < order` or `out.len() < order²`.
pub fn rotate_zonal<T: ShFloatExt>(order: usize, zonal: &[T], dir: [T; 3], out: &mut [T]) {
    crate::basis::eval_sh_into(order, dir, out);
    for l in 0..order {
        let s = T::from_f64((4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt()) * zonal[l];
        for v in &mut out[l * l..(l + 1) * (l + 1)] {
            *v *= s;
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::basis::eval_sh_into;
    use crate::quadrature::SphereQuadrature;

    pub fn rand_rot(seed: u64) -> Rot3<f64> {
        let mut s = seed.wrapping_mul(0x9E3779B97F4A7C15).wrapping_add(1);
        let mut r = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let q = glam::DQuat::from_xyzw(r() - 0.5, r() - 0.5, r() - 0.5, r() - 0.5);
        Rot3::from_dquat(q).unwrap()
    }

    pub fn rand_vec(seed: u64, n: usize) -> Vec<f64> {
        let mut s = seed.wrapping_mul(0x2545F4914F6CDD1D).wrapping_add(7);
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect()
    }

    fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    /// The run-time-selected build (AVX2 where the CPU has it) equals the
    /// baseline build, in every Q-buffer size class; `apply_rgb` equals three
    /// single applications.
    #[test]
    fn ivanic_build_paths_and_rgb_apply_agree() {
        for order in [1, 2, 5, 8, 9, 16, 17, 24] {
            let plan = IvanicRuedenberg::<f64>::new(order).unwrap();
            let (mut a, mut b) = (
                ShRotation::identity(order).unwrap(),
                ShRotation::identity(order).unwrap(),
            );
            for seed in 0..3 {
                let r = rand_rot(seed + 40);
                plan.build(&r, &mut a);
                plan.build_portable(&r, &mut b);
                assert!(max_diff(a.blocks(), b.blocks()) < 1e-12, "order {order}");
                let nn = order * order;
                let src: Vec<Vec<f64>> = (0..3).map(|c| rand_vec(seed * 3 + c, nn)).collect();
                let mut one = vec![vec![0.0; nn]; 3];
                for c in 0..3 {
                    a.apply(&src[c], &mut one[c]);
                }
                let mut rgb = vec![vec![0.0; nn]; 3];
                let [r0, r1, r2] = &mut rgb[..] else {
                    unreachable!()
                };
                a.apply_rgb([&src[0], &src[1], &src[2]], [r0, r1, r2]);
                for c in 0..3 {
                    assert!(max_diff(&one[c], &rgb[c]) < 1e-13, "order {order}");
                }
            }
        }
    }

    #[test]
    fn ivanic_rotates_basis_vector() {
        for order in [2, 3, 6, 10, 20] {
            for seed in 0..4 {
                let r = rand_rot(seed);
                let m = ShRotation::from_rotation(order, &r).unwrap();
                let d = glam::DVec3::new(0.3, -0.4, 0.86).normalize().to_array();
                let mut yd = vec![0.0; order * order];
                let mut yrd = vec![0.0; order * order];
                eval_sh_into(order, d, &mut yd);
                eval_sh_into(order, r.apply(d), &mut yrd);
                let mut out = vec![0.0; order * order];
                m.apply(&yd, &mut out);
                let e = max_diff(&out, &yrd);
                assert!(
                    e < 1e-11,
                    "order {order} seed {seed}: |M y(d) − y(R d)| = {e:e}"
                );
            }
        }
    }

    #[test]
    fn z_rotation_matches_exact() {
        let order = 8;
        let a = 0.7f64;
        let r = Rot3::from_axis_angle([0.0, 0.0, 1.0], a).unwrap();
        let m = ShRotation::from_rotation(order, &r).unwrap();
        let src = rand_vec(3, order * order);
        let mut want = vec![0.0; order * order];
        m.apply(&src, &mut want);
        let mut got = vec![0.0; order * order];
        rotate_z(order, a.cos(), a.sin(), &src, &mut got);
        assert!(max_diff(&got, &want) < 1e-13, "{:e}", max_diff(&got, &want));
        let mut ip = src.clone();
        rotate_z_in_place(order, a.cos(), a.sin(), &mut ip);
        assert!(max_diff(&ip, &want) < 1e-13);
    }

    #[test]
    fn euler_round_trip_including_poles() {
        for seed in 0..50 {
            let r = rand_rot(seed);
            let back = Rot3::from_euler_zyz(&r.euler_zyz());
            for i in 0..3 {
                for j in 0..3 {
                    assert!((back.m[i][j] - r.m[i][j]).abs() < 1e-12, "seed {seed}");
                }
            }
        }
        for (a, b, g) in [
            (0.3, 0.0, 0.5),
            (0.3, 1e-9, -0.2),
            (1.0, std::f64::consts::PI, 0.4),
            (0.2, 3.0, 2.0),
        ] {
            let r = Rot3::from_euler_zyz(&EulerZyz::from_angles(a, b, g));
            let back = Rot3::from_euler_zyz(&r.euler_zyz());
            for i in 0..3 {
                for j in 0..3 {
                    assert!((back.m[i][j] - r.m[i][j]).abs() < 1e-12, "({a},{b},{g})");
                }
            }
        }
        // f32 near the pole.
        let r = Rot3::from_euler_zyz(&EulerZyz::from_angles(0.3f32, 1e-5, 0.9)).euler_zyz();
        let back = Rot3::from_euler_zyz(&r);
        let want = Rot3::from_euler_zyz(&EulerZyz::from_angles(0.3f32, 1e-5, 0.9));
        for i in 0..3 {
            for j in 0..3 {
                assert!((back.m[i][j] - want.m[i][j]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn exact_methods_agree_and_match_numeric_projection() {
        let order = 7;
        let r = rand_rot(11);
        let f = rand_vec(5, order * order);
        let m = ShRotation::from_rotation(order, &r).unwrap();
        let mut a = vec![0.0; order * order];
        m.apply(&f, &mut a);
        let zyz = ZyzRotation::<f64>::new(order).unwrap();
        let mut b = vec![0.0; order * order];
        let mut scratch = vec![0.0; order * order];
        zyz.apply(&r, &f, &mut b, &mut scratch);
        assert!(max_diff(&a, &b) < 1e-12, "IR vs ZYZ {:e}", max_diff(&a, &b));
        // Numeric: project g(ω) = f(R⁻¹ ω) by quadrature.
        let q = SphereQuadrature::for_degree(2 * order);
        let rt = r.transpose();
        let mut c = vec![0.0; order * order];
        let mut y = vec![0.0; order * order];
        let mut y2 = vec![0.0; order * order];
        for (d, w) in q.dirs.iter().zip(&q.weights) {
            eval_sh_into(order, rt.apply(d.to_array()), &mut y2);
            let g: f64 = f.iter().zip(&y2).map(|(a, b)| a * b).sum();
            eval_sh_into(order, d.to_array(), &mut y);
            for i in 0..order * order {
                c[i] += w * g * y[i];
            }
        }
        assert!(
            max_diff(&a, &c) < 1e-11,
            "IR vs quadrature {:e}",
            max_diff(&a, &c)
        );
        // f32 paths.
        let r32 = r.to_f32();
        let f32v: Vec<f32> = f.iter().map(|&v| v as f32).collect();
        let m32 = ShRotation::from_rotation(order, &r32).unwrap();
        let mut a32 = vec![0.0f32; order * order];
        m32.apply(&f32v, &mut a32);
        let z32 = ZyzRotation::<f32>::new(order).unwrap();
        let mut b32 = vec![0.0f32; order * order];
        let mut s32 = vec![0.0f32; order * order];
        z32.apply(&r32, &f32v, &mut b32, &mut s32);
        for i in 0..order * order {
            assert!((a32[i] as f64 - a[i]).abs() < 2e-5, "IR f32 {i}");
            assert!((b32[i] as f64 - a[i]).abs() < 2e-5, "ZYZ f32 {i}");
        }
    }

    #[test]
    fn norm_composition_inverse() {
        let order = 9;
        let (r1, r2) = (rand_rot(21), rand_rot(22));
        let m1 = ShRotation::from_rotation(order, &r1).unwrap();
        let m2 = ShRotation::from_rotation(order, &r2).unwrap();
        let m12 = ShRotation::from_rotation(order, &r1.mul(&r2)).unwrap();
        let f = rand_vec(9, order * order);
        let mut a = vec![0.0; order * order];
        let mut b = vec![0.0; order * order];
        m2.apply(&f, &mut a);
        m1.apply(&a, &mut b);
        let mut c = vec![0.0; order * order];
        m12.apply(&f, &mut c);
        assert!(
            max_diff(&b, &c) < 1e-12,
            "composition {:e}",
            max_diff(&b, &c)
        );
        let comp = m1.compose(&m2);
        m12.blocks()
            .iter()
            .zip(comp.blocks())
            .for_each(|(x, y)| assert!((x - y).abs() < 1e-12));
        let n0: f64 = f.iter().map(|v| v * v).sum();
        let n1: f64 = a.iter().map(|v| v * v).sum();
        assert!((n0 - n1).abs() < 1e-12 * n0, "L2 norm {n0} → {n1}");
        let inv = m2.inverse();
        inv.apply(&a, &mut c);
        assert!(max_diff(&c, &f) < 1e-12, "inverse");
        let minv = ShRotation::from_rotation(order, &r2.transpose()).unwrap();
        minv.blocks()
            .iter()
            .zip(inv.blocks())
            .for_each(|(x, y)| assert!((x - y).abs() < 1e-12));
    }

    #[test]
    fn zonal_rotation_matches_full() {
        let order = 8;
        let zonal = rand_vec(4, order);
        let mut f = vec![0.0; order * order];
        for l in 0..order {
            f[l * (l + 1)] = zonal[l];
        }
        let r = rand_rot(8);
        let m = ShRotation::from_rotation(order, &r).unwrap();
        let mut want = vec![0.0; order * order];
        m.apply(&f, &mut want);
        let mut got = vec![0.0; order * order];
        rotate_zonal(order, &zonal, r.apply([0.0, 0.0, 1.0]), &mut got);
        assert!(max_diff(&got, &want) < 1e-12, "{:e}", max_diff(&got, &want));
    }

    #[test]
    fn x90_is_sparse() {
        let z = ZyzRotation::<f32>::new(6).unwrap();
        // Křivánek et al. §3.1: N_x(n) = n(n²+2)/3 multiplications.
        let want = 6 * (36 + 2) / 3;
        assert!(
            z.x_nonzeros() <= want + 6,
            "nnz {} vs ~{want}",
            z.x_nonzeros()
        );
    }

    #[test]
    fn bad_rotations_are_errors() {
        assert!(matches!(
            Rot3::try_new([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]], 1e-6),
            Err(ShError::NotARotation { .. })
        ));
        assert!(matches!(
            Rot3::try_new([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], 1e-6),
            Err(ShError::NotARotation { .. })
        ));
        assert!(Rot3::<f32>::from_quat(glam::Quat::from_xyzw(0.0, 0.0, 0.0, 0.0)).is_err());
        assert!(Rot3::from_axis_angle([0.0f64, 0.0, 0.0], 1.0).is_err());
        assert!(ShRotation::<f32>::identity(0).is_err());
        assert!(ZyzRotation::<f32>::new(MAX_ORDER + 1).is_err());
        let m = ShRotation::<f64>::identity(3).unwrap();
        let mut d = vec![0.0; 9];
        let mut s = vec![0.0; 9];
        s[4] = f64::NAN;
        assert!(matches!(
            m.try_apply(&s, &mut d),
            Err(ShError::NonFinite { .. })
        ));
    }
}
