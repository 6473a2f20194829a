//! Adaptive Gauss–Kronrod (7, 15) quadrature in f64: the oracle behind every
//! tabulated special function of this crate.
//!
//! The interval is bisected until the Kronrod/Gauss difference of every
//! piece is below its share of `max(rel · |I|, abs)`; pieces stop splitting
//! at depth 50, at round-off level, or after 2000 pieces (the estimate is
//! then kept as is).
//!
//! Fixed Gauss–Legendre rules come from the one table of the workspace,
//! [`relight_sh::quadrature::gauss_legendre`].

const XGK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const WGK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_2,
    0.140_653_259_715_525_9,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_8,
];
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// One G7K15 step on [a, b]: (Kronrod estimate, |Kronrod − Gauss|).
#[inline]
fn gk15(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let fc = f(c);
    let mut k = WGK[7] * fc;
    let mut g = WG[3] * fc;
    for j in 0..7 {
        let x = h * XGK[j];
        let s = f(c - x) + f(c + x);
        k += WGK[j] * s;
        if j % 2 == 1 {
            g += WG[j / 2] * s;
        }
    }
    (k * h, ((k - g) * h).abs())
}

/// ∫ₐᵇ f(x) dx to relative tolerance `rel` (absolute floor `abs`).
///
/// Returns 0 for an empty interval (`a == b`); `b < a` gives the negated integral.
pub fn integrate(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, rel: f64, abs: f64) -> f64 {
    if a == b {
        return 0.0;
    }
    let (whole, err) = gk15(&mut f, a, b);
    let tol = (rel * whole.abs()).max(abs);
    if err <= tol {
        return whole;
    }
    let len = (b - a).abs();
    // Explicit stack of (a, b, depth) to avoid recursion limits.
    let mut stack: Vec<(f64, f64, u32)> = vec![(a, b, 0)];
    let mut total = 0.0;
    let mut budget = 2000u32;
    while let Some((lo, hi, depth)) = stack.pop() {
        let (est, e) = gk15(&mut f, lo, hi);
        let share = tol * ((hi - lo).abs() / len);
        // Stop at the tolerance, at round-off level, at depth 50, or when the
        // piece budget is spent (then the remaining estimates are kept).
        budget = budget.saturating_sub(1);
        if e <= share || e <= 1e-15 * est.abs() || depth >= 50 || budget == 0 {
            total += est;
        } else {
            let mid = 0.5 * (lo + hi);
            stack.push((lo, mid, depth + 1));
            stack.push((mid, hi, depth + 1));
        }
    }
    total
}

/// [`integrate`] over consecutive pieces split at `breaks` (interior points,
/// ascending), so that kinks of the integrand fall on piece boundaries.
pub fn integrate_pieces(
    mut f: impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    breaks: &[f64],
    rel: f64,
    abs: f64,
) -> f64 {
    let mut lo = a;
    let mut sum = 0.0;
    for &x in breaks.iter().chain(std::iter::once(&b)) {
        let x = x.clamp(a, b);
        if x > lo {
            sum += integrate(&mut f, lo, x, rel, abs);
            lo = x;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gk_integrates_known_integrals() {
        let v = integrate(f64::sin, 0.0, std::f64::consts::PI, 1e-12, 0.0);
        assert!((v - 2.0).abs() < 1e-12, "∫sin = {v}, want 2");
        let v = integrate(|x| 1.0 / x.sqrt(), 1e-12, 1.0, 1e-10, 0.0);
        assert!((v - 2.0).abs() < 1e-5, "∫x^-1/2 = {v}, want ≈2");
    }
}
