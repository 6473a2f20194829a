//! `atan2` in f32 by a polynomial, for per-pixel lat-long lookups
//! ([`crate::Param::bilinear`]).
//!
//! `atan a = a · P(a²)` on `a ∈ [0, 1]` with `P` of degree 7: the
//! interpolant of `atan(√s)/√s` at the eight Chebyshev nodes of `s ∈ [0, 1]`
//! (near-minimax). Its error is below 6.4 × 10⁻⁸ rad in exact arithmetic
//! (measured on a 2 × 10⁴-point grid when the coefficients were derived) and
//! below 4 × 10⁻⁷ rad in f32, about one ulp of π (test `atan2_f32_matches_f64`); the octants
//! fold in with `atan a = π/2 − atan(1/a)` and the signs of `x` and `y`.
//! A 1024-texel-wide lat-long map turns 4 × 10⁻⁷ rad into 7 × 10⁻⁵ of a texel.

use std::f32::consts::{FRAC_PI_2, PI};

/// Coefficients of `P(s)`, lowest order first (module docs), as derived in
/// f64; the compiler rounds each to the nearest f32.
#[allow(clippy::excessive_precision)]
pub(crate) const P: [f32; 8] = [
    0.999_999_9,
    -0.333_318_13,
    0.199_669_62,
    -0.140_032_9,
    0.098_688_65,
    -0.058_829_753,
    0.023_780_519,
    -0.004_559_792,
];

/// `atan2(y, x)` in `[−π, π]`, with IEEE's signed-zero cases
/// (`atan2(±0, +0) = ±0`, `atan2(±0, −0) = ±π`) and no NaN for finite input (the branches are selects; no division by zero).
#[inline(always)]
#[must_use]
pub fn atan2_f32(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = if hi > 0.0 { lo / hi } else { 0.0 };
    let s = a * a;
    let mut p = P[7];
    for &c in P[..7].iter().rev() {
        // Multiply then add, not `mul_add`: the release build targets
        // baseline x86-64, where `f32::mul_add` is a call into libm's
        // software `fmaf` (it was 13 % of a lighting-table build in `perf`).
        p = p * s + c;
    }
    let mut r = a * p;
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    // Signs, not comparisons: IEEE's atan2(±0, −0) = ±π and atan2(−0, x) = −0
    // (the lat-long pole and seam pick their texels by them).
    if x.is_sign_negative() {
        r = PI - r;
    }
    if y.is_sign_negative() { -r } else { r }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_f32_matches_f64() {
        let mut worst = 0.0f64;
        let n = 20_000;
        for i in 0..n {
            let t = (i as f64 + 0.5) / n as f64 * std::f64::consts::TAU;
            for r in [1e-3f64, 1.0, 7.5e4] {
                let (y, x) = ((r * t.sin()) as f32, (r * t.cos()) as f32);
                let want = f64::from(y).atan2(f64::from(x));
                worst = worst.max((f64::from(atan2_f32(y, x)) - want).abs());
            }
        }
        assert!(worst < 4e-7, "worst error {worst:e} rad");
        // Axes and zeros.
        for (y, x, want) in [
            (0.0f32, 1.0f32, 0.0f32),
            (1.0, 0.0, FRAC_PI_2),
            (-1.0, 0.0, -FRAC_PI_2),
            (0.0, -1.0, PI),
            (0.0, 0.0, 0.0),
            (0.0, -0.0, PI),
            (-0.0, -0.0, -PI),
            (1.0, 1.0, std::f32::consts::FRAC_PI_4),
        ] {
            assert!((atan2_f32(y, x) - want).abs() < 4e-7, "atan2({y}, {x})");
        }
    }
}
