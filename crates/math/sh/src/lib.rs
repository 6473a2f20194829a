//! relight-sh: a real spherical-harmonics toolkit.
//!
//! # Convention
//! Real, orthonormal spherical harmonics with the **Condon–Shortley phase**,
//! the convention of DirectXMath (`XMSHEvalDirection`), google/spherical-harmonics
//! and pbrt, so coefficient vectors interchange with theirs:
//!
//! * `y_{l,m}(θ,φ) = √2 K_l^m cos(mφ) P_l^m(cos θ)` for m > 0,
//!   `√2 K_l^{|m|} sin(|m|φ) P_l^{|m|}(cos θ)` for m < 0, `K_l^0 P_l^0(cos θ)` for m = 0,
//!   `K_l^m = √((2l+1)/(4π) · (l−m)!/(l+m)!)`, and `P_l^m` carries the factor `(−1)^m`.
//! * Coefficient `(l, m)` is stored at index **`i = l(l+1) + m`** ([`sh_index`]).
//! * Spherical coordinates are taken about the **+Z axis**: `z = cos θ`,
//!   `x = sin θ cos φ`, `y = sin θ sin φ`. So `y_{1,-1} = −√(3/4π) y`,
//!   `y_{1,0} = √(3/4π) z`, `y_{1,1} = −√(3/4π) x`. Directions are unit vectors
//!   in whatever frame the coefficients live in (relight's world frame is +Y up;
//!   the SH polar axis stays +Z regardless — the axes are never permuted).
//! * **Order** `n` (the word used throughout this crate, in `--order` and in the
//!   benchmarks) is the number of **bands**: bands `l = 0 … n−1`, `n²` coefficients.
//!   Valid orders are `1 ..=` [`MAX_ORDER`].
//! * **Rotation direction:** rotating a coefficient vector by a rotation `R`
//!   produces the coefficients of `g(ω) = f(R⁻¹ ω)`, i.e. the function is carried
//!   along by `R`. In particular, rotating the vector `y(d)` gives `y(R d)`.
//!   Rotation matrices act on column vectors (`glam::Mat3 * v`), angles are in
//!   radians and right-handed (counter-clockwise looking down the axis).
//!   Euler angles are ZYZ: `R = R_z(α) R_y(β) R_z(γ)`.
//!
//! # Contents
//! * [`basis`]: evaluation of all `n²` functions at a direction by the
//!   associated-Legendre recurrence (no per-function trigonometry), any order up
//!   to [`MAX_ORDER`], f32 and f64; a generated straight-line fast path for
//!   `n ≤ 8` (L ≤ 7) in [`generated`].
//! * [`quadrature`]: Gauss–Legendre × uniform-φ product rules that integrate
//!   band-limited functions exactly.
//! * [`project`]: projection of sampled functions and environment maps with exact
//!   texel solid angles, a lat-long fast path (Fourier along rows, Legendre down
//!   columns), reconstruction, and ringing windows.
//! * [`rotation`]: Z rotation (O(n²)), Ivanic–Ruedenberg exact matrices,
//!   ZYZ with fixed ±90° X rotations ("ZXZXZ"), zonal rotation.
//! * [`taylor`]: Křivánek et al.'s Taylor-expanded Y rotation (1st, 1.5th, 2nd order).
//! * [`convolve`]: zonal kernels (clamped cosine, Phong, Blinn–Phong, any
//!   radially symmetric function) and Ramamoorthi–Hanrahan irradiance.
//! * [`product`]: triple-product tensor Γ, products, SH exponential and logarithm.
//! * [`window`]: ringing windows chosen for a set of lobes (Hann, Lanczos
//!   σ-factors, Sloan's deringing that keeps them non-negative).
//! * [`mod@bench`]: `bench_sh` timings.
//!
//! # API map (for techniques and the CLI)
//! * evaluate: [`eval_sh_into`] (allocation-free, f32/f64), [`eval_sh`], [`try_eval_sh`];
//! * project: [`project::project_env`]`(&EnvMap, order, Window) -> ShRgb`,
//!   [`project::project_samples`], [`project::project_fn`], [`project::LatLongProjector`];
//!   reconstruct: [`project::reconstruct`]`(&ShRgb, Param) -> EnvMap`;
//! * rotate: [`rotation::Rot3`] (from `Quat`/`Mat3`, checked),
//!   [`rotation::IvanicRuedenberg`] + [`rotation::ShRotation`] (exact, build once),
//!   [`rotation::ZyzRotation`] (exact, no matrix), [`taylor::TaylorRotation`]
//!   (`TaylorOrder::{First, OneAndHalf, Second}`, β_lim switch), [`rotation::rotate_z`],
//!   [`rotation::rotate_zonal`]. All take caller-provided buffers;
//! * convolve: [`convolve::clamped_cosine`], [`convolve::phong`],
//!   [`convolve::blinn_phong`], [`convolve::zonal_kernel`], [`convolve::convolve_rgb`];
//!   irradiance: [`convolve::irradiance`], [`convolve::IrradianceQuadratic`];
//! * products: [`product::TripleProduct`], [`product::ShExp`] (`ExpMethod`),
//!   [`product::log_sh`];
//! * [`bench_sh`] → `Vec<ShBenchRow>`; [`CONVENTION`] for tool output.
//!
//! # References
//! * J. Křivánek, J. Konttinen, S. Pattanaik, K. Bouatouch, *Fast Approximation to
//!   Spherical Harmonic Rotation*, 2006 (`sh-rotation-taylor-2006.txt`).
//! * B. Sun, *Frequency domain analysis of light transport*, thesis 2008
//!   (`sun-thesis-2008.txt`), §2.2, §2.4, §3.6, §5.2.
//! * J. Ivanic, K. Ruedenberg, *Rotation matrices for real spherical harmonics*,
//!   J. Phys. Chem. 1996 (+ errata 1998).
//! * R. Ramamoorthi, P. Hanrahan, *An efficient representation for irradiance
//!   environment maps*, SIGGRAPH 2001.
//! * P.-P. Sloan, *Stupid spherical harmonics tricks*, GDC 2008; *Deringing
//!   spherical harmonics*, SIGGRAPH Asia 2017.

#![allow(clippy::needless_range_loop)] // index-heavy numerical kernels read better with explicit indices

pub mod basis;
pub mod bench;
pub mod convolve;
pub mod fast;
#[rustfmt::skip]
pub mod generated;
/// The vector instruction set in use ([`relight_isa`], shared with every
/// crate that has run-time-selected kernels).
pub use relight_isa as isa;
#[rustfmt::skip]
pub(crate) mod kernels;
pub mod kernels_gen;
mod lane_tables;
mod lanes;
pub mod product;
mod product_high;
pub mod project;
pub mod quadrature;
pub mod real;
pub mod rotation;
mod simd;
mod simd_avx2;
mod simd_bands;
mod simd_eval;
mod simd_product;
pub mod taylor;
pub mod window;

pub use basis::{
    ShFloat as ShFloatExt, eval_sh, eval_sh_array, eval_sh_array_into, eval_sh_f64, eval_sh_into,
    try_eval_sh, try_eval_sh_into,
};
pub use bench::{ShBenchRow, bench_sh};
pub use real::Real;
pub use relight_isa::{Isa, detected_isa, isa, set_isa_limit};

/// One-paragraph statement of the coefficient convention, for tool output
/// (`relight sh --help`, JSON headers).
pub const CONVENTION: &str = "real orthonormal spherical harmonics with the Condon-Shortley phase \
(as DirectXMath, google/spherical-harmonics, pbrt); coefficient (l,m) at index l(l+1)+m; \
order n = number of bands (n^2 coefficients); polar axis +Z: z = cos(theta), x = sin(theta)cos(phi), \
y = sin(theta)sin(phi); y_1,-1 = -sqrt(3/4pi) y, y_1,0 = sqrt(3/4pi) z, y_1,1 = -sqrt(3/4pi) x; \
rotating coefficients by R gives the coefficients of f(R^-1 w), so y(d) rotates to y(R d)";

/// The largest supported order (number of bands). Evaluation and rotation work
/// (and are tested) far beyond the L = 30 the issue asks for.
pub const MAX_ORDER: usize = 64;

/// Index of coefficient `(l, m)`: `l(l+1) + m`, for `|m| ≤ l`.
#[inline]
#[must_use]
pub const fn sh_index(l: usize, m: isize) -> usize {
    ((l * (l + 1)) as isize + m) as usize
}

/// The `(l, m)` of coefficient index `i` (inverse of [`sh_index`]).
#[inline]
#[must_use]
pub fn sh_lm(i: usize) -> (usize, isize) {
    let l = (i as f64).sqrt() as usize;
    let l = if (l + 1) * (l + 1) <= i {
        l + 1
    } else if l * l > i {
        l - 1
    } else {
        l
    };
    (l, i as isize - (l * (l + 1)) as isize)
}

/// Errors of the SH toolkit. Every message names the parameter and says how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShError {
    /// Order (number of bands) 0 or above the maximum.
    #[error(
        "SH order {order} for `{what}` is out of range: use 1..={max} bands (n bands = n² coefficients)"
    )]
    OrderOutOfRange {
        what: &'static str,
        order: usize,
        max: usize,
    },
    /// A coefficient vector of the wrong length.
    #[error("`{what}` has {got} coefficients, but order {order} needs {expected} (= order²)")]
    LengthMismatch {
        what: &'static str,
        order: usize,
        expected: usize,
        got: usize,
    },
    /// A NaN or infinite coefficient / input value.
    #[error("`{what}`[{index}] is not finite ({value}); clean the input (NaN/inf) before using it")]
    NonFinite {
        what: &'static str,
        index: usize,
        value: f64,
    },
    /// A matrix that is not a proper rotation (orthonormal, det +1).
    #[error(
        "`{what}` is not a rotation: max |RᵀR − I| = {deviation:.3e}, det = {det:.6}; orthonormalise it (or pass a unit quaternion)"
    )]
    NotARotation {
        what: &'static str,
        deviation: f64,
        det: f64,
    },
    /// A direction or axis that is zero or not finite.
    #[error("`{what}` must be a non-zero finite direction, got length {length}")]
    BadDirection { what: &'static str, length: f64 },
    /// Other invalid parameter (window width, kernel exponent, …).
    #[error("invalid parameter `{what}`: {why}")]
    InvalidParameter { what: &'static str, why: String },
}

/// Check `1 ≤ order ≤ max`.
pub fn check_order(what: &'static str, order: usize, max: usize) -> Result<(), ShError> {
    if order == 0 || order > max {
        Err(ShError::OrderOutOfRange { what, order, max })
    } else {
        Ok(())
    }
}

/// Check a coefficient vector: length `order²` and all values finite.
pub fn check_coeffs<T: Real>(what: &'static str, order: usize, c: &[T]) -> Result<(), ShError> {
    check_order(what, order, MAX_ORDER)?;
    if c.len() != order * order {
        return Err(ShError::LengthMismatch {
            what,
            order,
            expected: order * order,
            got: c.len(),
        });
    }
    check_finite(what, c)
}

/// Check that all values are finite.
pub fn check_finite<T: Real>(what: &'static str, c: &[T]) -> Result<(), ShError> {
    match c.iter().position(|v| !v.to_f64().is_finite()) {
        Some(index) => Err(ShError::NonFinite {
            what,
            index,
            value: c[index].to_f64(),
        }),
        None => Ok(()),
    }
}

/// The order `n` with `n² = len`, if `len` is a perfect square ≥ 1.
#[must_use]
pub fn order_of_len(len: usize) -> Option<usize> {
    let n = (len as f64).sqrt().round() as usize;
    (n >= 1 && n * n == len).then_some(n)
}
