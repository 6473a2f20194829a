//! Effective BRDFs of a filtered normal distribution (thesis §5.1.2,
//! eqs. 5.3–5.7; Han et al. 2007 §5) and the baselines they replace.
//!
//! Every function here returns `f·cos θ_i` per unit irradiance-normal light
//! — the radiance a unit directional light along `wi` reflects toward `wo`
//! (both unit, in the *tangent frame* of the surface, +Z the geometric
//! normal) — without the BRDF's colour, which the caller multiplies.
//!
//! # Which BRDFs (eq. 5.3)
//! The convolution form needs `ρ(ω_i, ω_o; n) = f(n · ω(ω_i, ω_o))` with one
//! direction ω that does not depend on n:
//! * **Lambert**, `ω = ω_i`: `f(t) = max(t, 0)/π`. SH: `Λ_l` = π, 2π/3, π/4
//!   (the clamped cosine's Funk–Hecke factors); `Σ_lm Λ_l γ_lm L_lm / π`.
//! * **Half-angle models**, `ω = ĥ`: Blinn–Phong `cos^s θ_h ≈ exp(s(μ·ĥ − 1))`
//!   is a vMF of κ = s, and two vMFs convolve to one of
//!   `κ' = κ s /(κ + s)`: `s' = κ s / (κ + s)`, amplitude `s'/s`. GGX and
//!   Beckmann: a vMF of κ has slope variance ≈ `1/κ` per axis, adding to
//!   the microfacet variance `α²/2`: `α'² = α² + 2/κ`.
//! * **Phong about the mirror direction is excluded:** its lobe depends on
//!   `reflect(ω_o, n)`, a direction that turns *twice* as fast as n, so the
//!   BRDF is not `f(n·ω)` for a fixed ω and eq. 5.3 does not hold. It is not
//!   offered here (no faked approximation).
//!
//! The cosine `max(0, n·ω_i)` of a half-angle model (and the view mask
//! `n·ω_o > 0`) is taken at the lobe axis μ for GGX and Beckmann, as Han et
//! al. do; for Blinn–Phong at the axis of the product lobe (`blinn_lobe`),
//! which a wide NDF lobe moves from μ toward ĥ.
//!
//! # Lambert under a directional light, per vMF lobe
//! `∫ max(0, n·l) γ(n; μ, κ) dn` has no closed form. Its bands `l ≤ 2` are
//! exact (`Σ c_l A_l(κ) P_l(μ·l)`, `c = (1/4, 1/2, 5/16)`); the remainder of
//! the clamped cosine beyond them (`max(0,t) − Σ_{l≤2} c_l P_l(t)`, bands
//! 4, 6, …) is attenuated by `A_4(κ)`, so a delta (κ at the clamp) is exact
//! and κ → 0 gives the uniform answer 1/4 · … (tested against quadrature).

use crate::pyramid::ShadeLobe;
use glam::Vec3;
use rayon::prelude::*;
use relight_brdf::microfacet::{
    beckmann_d, beckmann_lambda, fresnel_schlick, ggx_d, smith_g2_height_correlated,
};
use relight_brdf::phong::blinn_phong_normalization;
use std::f32::consts::PI;

/// A BRDF the effective forms know (colour / albedo applied by the caller).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum NdfBrdf {
    /// `1/π`.
    Lambert,
    /// Normalized Blinn–Phong of exponent `s` (relight-brdf's `BlinnPhong`).
    Blinn { s: f32 },
    /// GGX, height-correlated Smith, Schlick F₀ = 1 (relight-brdf's `Ggx`).
    Ggx { alpha: f32 },
    /// Beckmann with Smith-Beckmann masking (Walter 2007), F₀ = 1.
    Beckmann { alpha: f32 },
}

impl NdfBrdf {
    /// Parses `lambert`, `blinn:S`, `ggx:A`, `beckmann:A`.
    ///
    /// # Errors
    /// A one-line message naming the problem.
    pub fn parse(s: &str) -> Result<Self, String> {
        let (name, arg) = s.split_once(':').unwrap_or((s, ""));
        let num = |what: &str, lo: f32, hi: f32| -> Result<f32, String> {
            let v: f32 = arg
                .parse()
                .map_err(|_| format!("`{s}`: {what} must be a number (e.g. {name}:0.3)"))?;
            if !(lo..=hi).contains(&v) {
                return Err(format!("`{s}`: {what} must be in [{lo}, {hi}]"));
            }
            Ok(v)
        };
        match name {
            "lambert" if arg.is_empty() => Ok(Self::Lambert),
            "blinn" => Ok(Self::Blinn {
                s: num("the exponent", 1.0, 1e5)?,
            }),
            "ggx" => Ok(Self::Ggx {
                alpha: num("α", 1e-3, 1.0)?,
            }),
            "beckmann" => Ok(Self::Beckmann {
                alpha: num("α", 1e-3, 1.0)?,
            }),
            _ => Err(format!(
                "`{s}`: unknown NDF BRDF (known: lambert, blinn:S, ggx:A, beckmann:A; phong is excluded by eq. 5.3)"
            )),
        }
    }

    /// Short name for tables.
    #[must_use]
    pub fn label(&self) -> String {
        match self {
            Self::Lambert => "lambert".into(),
            Self::Blinn { s } => format!("blinn:{s}"),
            Self::Ggx { alpha } => format!("ggx:{alpha}"),
            Self::Beckmann { alpha } => format!("beckmann:{alpha}"),
        }
    }
}

/// The share of a vMF lobe's normals that face the viewer, `P(n·ω_o > 0)`
/// for `n ~ vMF(μ, κ)` with `t = μ·ω_o`: `n·ω_o` has mean `A t` and
/// variance `A/κ + (1 − 3A/κ) t² − A² t²` (`E[n nᵀ] = (A/κ) I + (1 − 3A/κ)
/// μμᵀ`, `A = A(κ)`; `(1 − t²)/κ` for large κ), taken as Gaussian:
/// `Φ(A t / σ)` (within 0.03 of Monte Carlo for κ ≥ 3, tested). A delta
/// (`1/κ = 0`) gives the step
/// `t > 0`, the view mask of plain normal mapping (a normal turned away
/// from the viewer shades zero: the project's convention, which the
/// reference renderer shares); κ → 0 gives ½.
#[inline(always)]
#[must_use]
pub fn visible_fraction(t: f32, inv_kappa: f32) -> f32 {
    if inv_kappa <= 0.0 {
        return if t > 0.0 { 1.0 } else { 0.0 };
    }
    let a = crate::vmf::attenuation_012(inv_kappa)[1];
    let var = a * inv_kappa + (1.0 - 3.0 * a * inv_kappa) * t * t - a * a * t * t;
    // Beyond 6σ (`(a t)² > 36 var`) `normal_cdf` is the step: decided
    // without the square root and the division (to its rounding at 6σ,
    // where Φ is within 1e-9 of the step; tested).
    let at = a * t;
    if at * at > 36.0 * var {
        return if t > 0.0 { 1.0 } else { 0.0 };
    }
    let sd = var.max(0.0).sqrt();
    if sd <= 0.0 {
        return if t > 0.0 { 1.0 } else { 0.0 };
    }
    normal_cdf(a * t / sd)
}

/// The standard normal cdf `Φ(x) = (1 + erf(x/√2))/2`, erf by Abramowitz &
/// Stegun 7.1.26 (|error| ≤ 1.5e-7).
#[inline(always)]
fn normal_cdf(x: f32) -> f32 {
    normal_cdf_pdf(x).0
}

/// `e^{−t}` for `t ∈ [0, 87]` (larger `t` is clamped there: below 1.7e-38)
/// in f32 from `+`, `×` and exponent bits alone, so that a loop over lanes
/// vectorizes (a libm `expf` call per lane does not) and every copy of it
/// rounds alike: `e^{−t} = 2^{−n} e^{−r}` with `n = round(t/ln 2)`, `r = t −
/// n ln 2` (ln 2 split in two, Cody–Waite) in `[−ln 2/2, ln 2/2]`, and
/// `e^{−r}` by Cephes' `expf` polynomial. Relative error ≤ 2.5e-7 (tested
/// against f64).
#[inline(always)]
#[must_use]
pub fn exp_neg(t: f32) -> f32 {
    let t = t.clamp(0.0, 87.0);
    // `t ≥ 0`: truncation is the floor, so this rounds to nearest.
    let n = (t * std::f32::consts::LOG2_E + 0.5) as i32;
    let nf = n as f32;
    let x = (nf * 0.693_359_4 - t) + nf * -2.121_944_4e-4;
    let p = ((((1.987_569_1e-4 * x + 1.398_2e-3) * x + 8.333_452e-3) * x + 4.166_579_6e-2) * x
        + 1.666_666_5e-1)
        * x
        + 0.5;
    let e = p * (x * x) + x + 1.0;
    // `2^{−n}` for `n ∈ [0, 126]`.
    e * f32::from_bits(((127 - n) as u32) << 23)
}

/// `(Φ(x), φ(x))` in f32 with one `exp`: A&S 7.1.26's `erf(x/√2)` carries
/// the factor `e^{−x²/2}`, which is also `√(2π) φ(x)`. Beyond 6σ, `(1, 0)`
/// or `(0, 0)` (the tail is below 1e-8).
#[inline(always)]
pub(crate) fn normal_cdf_pdf(x: f32) -> (f32, f32) {
    if x.abs() > 6.0 {
        return (if x > 0.0 { 1.0 } else { 0.0 }, 0.0);
    }
    normal_cdf_pdf_within_6(x)
}

/// [`normal_cdf_pdf`] for `|x| ≤ 6`, without the branch: a loop over lanes
/// that calls it vectorizes (`crate::seen_lanes`).
#[inline(always)]
pub(crate) fn normal_cdf_pdf_within_6(x: f32) -> (f32, f32) {
    let z = x.abs() * std::f32::consts::FRAC_1_SQRT_2;
    let k = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = k
        * (0.254_829_6
            + k * (-0.284_496_74 + k * (1.421_413_7 + k * (-1.453_152_1 + k * 1.061_405_4))));
    let e = exp_neg(z * z);
    let erf = 1.0 - poly * e;
    let cdf = if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    };
    (
        cdf,
        e * (0.5 * std::f32::consts::FRAC_2_SQRT_PI * std::f32::consts::FRAC_1_SQRT_2),
    )
}

/// `max(0,t)` minus its bands `l ≤ 2` (`1/4 + t/2 + 5/16 P_2(t)`).
#[inline]
fn clamped_cos_remainder(t: f32) -> f32 {
    t.max(0.0) - clamped_cos_low(t)
}

#[inline]
fn clamped_cos_low(t: f32) -> f32 {
    0.25 + 0.5 * t + 0.3125 * 0.5 * (3.0 * t * t - 1.0)
}

/// `∫ max(0, n·l) γ(n; μ, κ) dn` approximated as in the module docs (`t = μ·l`).
#[inline]
#[must_use]
pub fn lambert_lobe(t: f32, inv_kappa: f32) -> f32 {
    if inv_kappa <= 0.0 {
        return t.max(0.0);
    }
    let [_, a1, a2] = crate::vmf::attenuation_012(inv_kappa);
    // A_4 by forward steps, clamped at 0 (tiny and inaccurate only where κ is
    // small, where it does not matter).
    let a4 = attenuation_4(inv_kappa);
    0.25 + 0.5 * a1 * t + 0.3125 * a2 * 0.5 * (3.0 * t * t - 1.0) + a4 * clamped_cos_remainder(t)
}

/// `f·cos θ_i` of `brdf` with one lobe of axis `n` (unit) and `1/κ`
/// (`0` = the plain BRDF at normal `n`): the single-normal shading every
/// baseline and level 0 use, and the ground truth per fine normal.
#[inline]
#[must_use]
pub fn shade_lobe(brdf: NdfBrdf, n: Vec3, inv_kappa: f32, wo: Vec3, wi: Vec3) -> f32 {
    let (co, ci) = (n.dot(wo), n.dot(wi));
    match brdf {
        NdfBrdf::Lambert => {
            lambert_lobe(ci, inv_kappa) * crate::mask::lobe_seen_share(n, inv_kappa, wo, wi) / PI
        }
        NdfBrdf::Blinn { s } => {
            let Some(h) = (wo + wi).try_normalize() else {
                return 0.0;
            };
            blinn_phong_normalization(s) * blinn_lobe(s, n, inv_kappa, h, wo, wi)
        }
        _ if co <= 0.0 || ci <= 0.0 => 0.0,
        NdfBrdf::Ggx { alpha } => {
            let a = (alpha * alpha + 2.0 * inv_kappa).sqrt();
            microfacet(
                n,
                wo,
                wi,
                |h| ggx_d(h, a, a),
                |o, i| smith_g2_height_correlated(o, i, a, a),
            )
        }
        NdfBrdf::Beckmann { alpha } => {
            let a = (alpha * alpha + 2.0 * inv_kappa).sqrt();
            microfacet(
                n,
                wo,
                wi,
                |h| beckmann_d(h, a),
                |o, i| 1.0 / (1.0 + beckmann_lambda(o, a) + beckmann_lambda(i, a)),
            )
        }
    }
}

/// One vMF lobe `(μ, 1/κ)` ⊗ Blinn–Phong `s`, without the normalization:
/// `(s'/s) (μ·ĥ)^{s'} · max(0, n*·ω_i) · V(n*·ω_o)`, with
/// `s' = κs/(κ+s)` (module docs). The cosine and the view mask are taken at
/// `n* = (κμ + s ĥ)/|κμ + s ĥ|`, the axis of the product of the NDF lobe
/// and the BRDF's lobe about ĥ — the normals that make the highlight at ĥ
/// (its mean direction, Banerjee et al. 2005: vMFs multiply to a vMF of
/// resultant `κμ + sĥ`), and `V` that lobe's [`visible_fraction`]. A delta
/// (`1/κ = 0`) has `n* = μ` and `V` the step `n·ω_o > 0`: plain shading.
#[inline(always)]
fn blinn_lobe(s: f32, mu: Vec3, inv_kappa: f32, h: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    let (factor, x, p) = blinn_lobe_parts(s, mu, inv_kappa, h, wo, wi);
    factor * pow_unit(x, p)
}

/// [`blinn_lobe`] as `factor · x^p`, the power left to the caller, so that
/// [`shade_mixture_blinn`] takes all its lobes' powers in one
/// vectorizable pass. A delta's power is taken here (`x = p = 1`).
#[inline(always)]
fn blinn_lobe_parts(
    s: f32,
    mu: Vec3,
    inv_kappa: f32,
    h: Vec3,
    wo: Vec3,
    wi: Vec3,
) -> (f32, f32, f32) {
    const NONE: (f32, f32, f32) = (0.0, 1.0, 1.0);
    if inv_kappa <= 0.0 {
        let ci = mu.dot(wi);
        if mu.dot(wo) <= 0.0 || ci <= 0.0 {
            return NONE;
        }
        return (pow_exponent(mu.dot(h).max(0.0), s) * ci, 1.0, 1.0);
    }
    let sp = s / (1.0 + s * inv_kappa);
    let mh = mu.dot(h);
    // `(μ·ĥ)^{s'} ≤ e^{−s'(1 − μ·ĥ)}` (ln x ≤ x − 1): below e⁻³⁰ of the
    // lobe's peak, the lobe adds nothing an f32 sum would keep.
    if sp * (1.0 - mh) > NEGLIGIBLE_EXPONENT {
        return NONE;
    }
    let p = mu + (s * inv_kappa) * h;
    let len = p.length();
    let n = if len > 0.0 { p / len } else { mu };
    let ci = n.dot(wi);
    if ci <= 0.0 {
        return NONE;
    }
    // The product lobe's resultant is κ·|μ + (s/κ) ĥ|.
    let vis = visible_fraction(n.dot(wo), inv_kappa / len.max(1e-6));
    ((sp / s) * ci * vis, mh.max(0.0), sp)
}

/// [`blinn_lobe`] skips a lobe whose `(μ·ĥ)^{s'}` is bounded below
/// `e^{−NEGLIGIBLE_EXPONENT}` (≈ 1e-13) of its peak.
const NEGLIGIBLE_EXPONENT: f32 = 30.0;

/// `x^p` for `x ∈ [0, 1]` (larger x is taken as 1, `x ≤ 0` or NaN gives 0)
/// and `p > 0` (the product lobe's exponent `s' = κs/(κ+s)`, not a whole
/// number), as `2^{p log₂ x}` with both factors by polynomials and no
/// branch: no libm call, and a loop over lobes vectorizes.
/// `log₂ x = e + ln(m)/ln 2` with `x = 2^e m`, `m ∈ [√½, √2)`, and
/// `ln m = 2 atanh z`, `z = (m−1)/(m+1)`, by its series to `z⁹`
/// (`|z| ≤ 0.172`: truncation below 1e-8 of `ln m`); `2^y = 2^k 2^f`,
/// `k` rounded by the `1.5·2²³` shifter, `|f| ≤ ½`, `2^f` by its Taylor
/// series to the 7th power (truncation below 2e-8). Relative error within
/// 2e-5 of `powf` wherever the result is above 1e-30 (`p ≤ 2048`, tested;
/// the error of `log₂ x` is multiplied by `p ln 2`); below 2⁻¹²⁶ it
/// returns 0.
#[inline(always)]
#[must_use]
pub fn pow_unit(x: f32, p: f32) -> f32 {
    let zero = x.is_nan() || x <= 0.0;
    let x = if zero { 1.0 } else { x.min(1.0) };
    // Subnormal x: scaled into the normal range first.
    let sub = x < f32::MIN_POSITIVE;
    let x = if sub { x * 8_388_608.0 } else { x };
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 as f32 - if sub { 150.0 } else { 127.0 };
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let big = m > std::f32::consts::SQRT_2;
    let (m, e) = if big { (m * 0.5, e + 1.0) } else { (m, e) };
    let z = (m - 1.0) / (m + 1.0);
    let z2 = z * z;
    let series = 1.0 + z2 * (1.0 / 3.0 + z2 * (1.0 / 5.0 + z2 * (1.0 / 7.0 + z2 * (1.0 / 9.0))));
    let log2x = e + (2.0 * std::f32::consts::LOG2_E) * z * series;
    let y = p * log2x;
    let under = y < -126.0;
    let y = if under { -126.0 } else { y };
    const SHIFTER: f32 = 12_582_912.0; // 1.5 · 2²³
    let t = y + SHIFTER;
    let kf = t - SHIFTER;
    let k = (t.to_bits() as i32).wrapping_sub(SHIFTER.to_bits() as i32);
    let g = (y - kf) * std::f32::consts::LN_2;
    let ef = 1.0
        + g * (1.0
            + g * (1.0 / 2.0
                + g * (1.0 / 6.0
                    + g * (1.0 / 24.0
                        + g * (1.0 / 120.0 + g * (1.0 / 720.0 + g * (1.0 / 5040.0)))))));
    // y ∈ [−126, 0]: k + 127 ∈ [1, 127], a normal power of two.
    let v = ef * f32::from_bits(((k + 127) as u32) << 23);
    if zero || under { 0.0 } else { v }
}

/// `x^s` for `x ≥ 0`: by repeated squaring (`powi`, no libm call) when
/// `s` is a whole number up to 1024 — the usual Blinn–Phong exponents, and
/// every delta lobe (level 0) shades with the BRDF's own `s` — within a
/// relative `s · 2⁻²³` of the exact power (each squaring doubles the
/// relative error; tested), `powf` otherwise.
#[inline]
fn pow_exponent(x: f32, s: f32) -> f32 {
    if s.fract() == 0.0 && (0.0..=1024.0).contains(&s) {
        x.powi(s as i32)
    } else {
        x.powf(s)
    }
}

/// `D·G·F/(4 cos θ_o cos θ_i) · cos θ_i` in the frame of `n`, F₀ = 1.
#[inline]
pub(crate) fn microfacet(
    n: Vec3,
    wo: Vec3,
    wi: Vec3,
    d: impl Fn(Vec3) -> f32,
    g: impl Fn(Vec3, Vec3) -> f32,
) -> f32 {
    let f = relight_sphere::Frame::from_z(n);
    let (o, i) = (f.to_local(wo), f.to_local(wi));
    if o.z <= 0.0 || i.z <= 0.0 {
        return 0.0;
    }
    let Some(h) = (o + i).try_normalize() else {
        return 0.0;
    };
    let fr = fresnel_schlick(Vec3::ONE, o.dot(h)).x;
    fr * d(h) * g(o, i) / (4.0 * o.z)
}

/// [`shade_mixture`] for Blinn–Phong `s` with its normalization `norm`
/// ([`blinn_phong_normalization`]`(s)`, an f64 `exp2`) computed by the
/// caller once: the renderer's per-pixel form, [`shade_mixture`]'s value
/// (tested). (A form with fewer divisions per lobe measured slower: the
/// divisions overlap, the longer code did not inline.)
#[inline(always)]
#[must_use]
pub fn shade_mixture_blinn(s: f32, norm: f32, lobes: &[ShadeLobe], wo: Vec3, wi: Vec3) -> f32 {
    let Some(h) = (wo + wi).try_normalize() else {
        return 0.0;
    };
    // Each lobe's factor and power base and exponent first, then the
    // powers of eight lobes at once ([`pow_unit`] is branch-free: one pass
    // of 8-lane arithmetic in the AVX2 copy of the pixel loop), then the sum
    // in lobe order. Plain loops: an iterator's generic `fold` was not
    // inlined into that copy.
    const LANES: usize = 8;
    let mut sum = 0.0;
    for chunk in lobes.chunks(LANES) {
        let (mut f, mut x, mut p) = ([0.0f32; LANES], [1.0f32; LANES], [1.0f32; LANES]);
        for (j, l) in chunk.iter().enumerate() {
            let (fj, xj, pj) = blinn_lobe_parts(s, l.mu, l.inv_kappa, h, wo, wi);
            (f[j], x[j], p[j]) = (l.alpha * norm * fj, xj, pj);
        }
        let mut pw = [0.0f32; LANES];
        for j in 0..LANES {
            pw[j] = pow_unit(x[j], p[j]);
        }
        for j in 0..chunk.len() {
            sum += f[j] * pw[j];
        }
    }
    sum
}

/// `f·cos θ_i` of a vMF mixture: `Σ_j α_j` [`shade_lobe`]`(μ_j, 1/κ_j)`.
#[inline]
#[must_use]
pub fn shade_mixture(brdf: NdfBrdf, lobes: &[ShadeLobe], wo: Vec3, wi: Vec3) -> f32 {
    if let NdfBrdf::Blinn { s } = brdf {
        // `shade_lobe` per lobe, with the half vector and the normalization
        // (an f64 `exp2`) hoisted out of the lobe loop.
        return shade_mixture_blinn(s, blinn_phong_normalization(s), lobes, wo, wi);
    }
    lobes
        .iter()
        .map(|l| l.alpha * shade_lobe(brdf, l.mu, l.inv_kappa, wo, wi))
        .sum()
}

/// Lambert `f·cos` of an SH NDF `gamma` (≥ 9 coefficients) under a unit
/// directional light along `wi`. Bands `l ≤ 2` are exact,
/// `Σ Λ_l γ_lm y_lm(wi) / π`; three bands alone would turn the clamped
/// cosine into `1/4 + t/2 + 5/16 P_2(t)` (0.094 instead of 0 at the
/// terminator, +50 % at grazing light), so the remainder of the clamped
/// cosine (bands 4, 6, …) is added as for a vMF lobe ([`lambert_lobe`]) of
/// the NDF's mean normal `m` (read from band 1: `m·a = (4π/3) Σ_m γ_1m
/// y_1m(a)`), κ = A⁻¹(|m|). A delta (level 0) is then exact.
#[inline]
#[must_use]
pub fn lambert_sh_dir(gamma: &[f32], wi: Vec3) -> f32 {
    lambert_sh_dir_of_mean(gamma, mean_normal_of_sh(gamma), wi)
}

/// [`lambert_sh_dir`] with the NDF's mean normal `m` given (a caller that
/// has it already: [`crate::mask::ShMoments::mean`]).
#[inline]
fn lambert_sh_dir_of_mean(gamma: &[f32], m: Vec3, wi: Vec3) -> f32 {
    let mut y = [0.0f32; 9];
    relight_sh::eval_sh_into(3, wi.to_array(), &mut y);
    let low = lambert_sh_env(gamma, &y);
    let r = m.length();
    if r <= 0.0 {
        return low;
    }
    let inv_kappa = if r >= 1.0 - 1.5 / crate::vmf::KAPPA_MAX as f32 {
        0.0
    } else {
        1.0 / crate::vmf::kappa_estimate(r)
    };
    let a4 = attenuation_4(inv_kappa);
    low + a4 * clamped_cos_remainder((m / r).dot(wi)) / PI
}

/// [`lambert_sh_dir`] seen from `wo`: times the share of that irradiance
/// falling on normals that face the viewer, from the NDF's mean and
/// covariance ([`crate::mask`]; at level 0, a delta, the mask of plain
/// normal mapping). The first form took the NDF's visible share,
/// `P(n·ω_o > 0)` of the mean-normal lobe, independent of `ω_i`
/// (`docs/ndf.md`, "The view mask").
#[inline]
#[must_use]
pub fn lambert_sh_dir_seen(gamma: &[f32], wo: Vec3, wi: Vec3) -> f32 {
    lambert_sh_dir_seen_with(gamma, &crate::mask::ShMoments::of_sh(gamma), wo, wi)
}

/// [`lambert_sh_dir_seen`] with the NDF's moments given
/// ([`crate::mask::ShMoments::of_sh`]`(gamma)`): a pixel's moments serve
/// all its lights, and their mean is the mean normal the tail needs. The
/// same value, bit for bit.
#[inline]
#[must_use]
pub fn lambert_sh_dir_seen_with(
    gamma: &[f32],
    moments: &crate::mask::ShMoments,
    wo: Vec3,
    wi: Vec3,
) -> f32 {
    lambert_sh_dir_of_mean(gamma, moments.mean, wi) * moments.seen_share(wo, wi)
}

/// The mean normal of an SH NDF from its band 1 (convention-free: three
/// evaluations of band 1 at the axes).
#[inline]
#[must_use]
pub fn mean_normal_of_sh(gamma: &[f32]) -> Vec3 {
    let axes = band1_axes();
    let k = 4.0 * PI / 3.0;
    let [(ix, jx), (iy, jy), (iz, jz)] = AXIS_TERMS;
    Vec3::new(
        gamma[ix] * axes[0][jx] * k,
        gamma[iy] * axes[1][jy] * k,
        gamma[iz] * axes[2][jz] * k,
    )
}

/// Which band-1 coefficient each axis of [`mean_normal_of_sh`] reads:
/// `(index in γ, index in its row of band1_axes)` for x, y, z. Band 1 is
/// `y`, `z`, `x` (relight-sh's order), so each axis meets one non-zero
/// entry; the others are exactly zero (tested), and their products added
/// nothing.
pub(crate) const AXIS_TERMS: [(usize, usize); 3] = [(3, 2), (1, 0), (2, 1)];

/// Band 1 at the three axes, evaluated once (the same products as three
/// evaluations per call).
pub(crate) fn band1_axes() -> &'static [[f32; 3]; 3] {
    static AXES: std::sync::OnceLock<[[f32; 3]; 3]> = std::sync::OnceLock::new();
    AXES.get_or_init(|| {
        [Vec3::X, Vec3::Y, Vec3::Z].map(|a| {
            let mut y = [0.0f32; 4];
            relight_sh::eval_sh_into(2, a.to_array(), &mut y);
            [y[1], y[2], y[3]]
        })
    })
}

/// [`mean_normal_of_sh`] as a matrix on `(γ_1, γ_2, γ_3)` (to f32
/// rounding), for a caller that composes it with a rotation.
#[must_use]
pub fn mean_normal_matrix() -> glam::Mat3 {
    let a = band1_axes();
    let k = 4.0 * PI / 3.0;
    glam::Mat3::from_cols(
        Vec3::new(a[0][0], a[1][0], a[2][0]) * k,
        Vec3::new(a[0][1], a[1][1], a[2][1]) * k,
        Vec3::new(a[0][2], a[1][2], a[2][2]) * k,
    )
}

/// `A_4(κ)` by forward steps from `A_1, A_2` (clamped at 0; 1 for a delta).
#[inline]
fn attenuation_4(inv_kappa: f32) -> f32 {
    if inv_kappa <= 0.0 {
        return 1.0;
    }
    let [_, a1, a2] = crate::vmf::attenuation_012(inv_kappa);
    let a3 = (a1 - 5.0 * a2 * inv_kappa).max(0.0);
    (a2 - 7.0 * a3 * inv_kappa).max(0.0)
}

/// Lambert radiance of an SH NDF `gamma` under SH lighting `light` (both in
/// the tangent frame, ≥ 9 coefficients): the 9-term dot product
/// `Σ Λ_l γ_lm L_lm / π` (eq. 5.7 with `ρ̂_l = Λ_l/π`).
#[inline]
#[must_use]
pub fn lambert_sh_env(gamma: &[f32], light: &[f32]) -> f32 {
    let mut s = 0.0;
    for i in 0..9 {
        s += LAMBDA[i] * gamma[i] * light[i];
    }
    s
}

/// [`lambert_sh_env`]'s factors `Λ_l/π` per coefficient (bands 0–2).
const LAMBDA: [f32; 9] = [
    1.0,
    2.0 / 3.0,
    2.0 / 3.0,
    2.0 / 3.0,
    0.25,
    0.25,
    0.25,
    0.25,
    0.25,
];

/// SH lighting (9 coefficients) with [`lambert_sh_env`]'s `Λ_l/π` folded
/// in: `Σ_i γ_i lit_i` is `lambert_sh_env(γ, light)` up to rounding (one
/// product per term instead of two).
#[inline]
#[must_use]
pub fn lambert_lit9(light: &[f32]) -> [f32; 9] {
    let mut out = [0.0f32; 9];
    for (o, (l, f)) in out.iter_mut().zip(light[..9].iter().zip(LAMBDA)) {
        *o = f * l;
    }
    out
}

/// `Λ_l`, the clamped cosine's Funk–Hecke factor (`2π ∫_0^1 t P_l(t) dt`):
/// π, 2π/3, 0 for odd `l > 1`, and for even `l ≥ 2`
/// `2π (−1)^{l/2+1} / ((l+2)(l−1)) · C(l, l/2)/2^l` (Ramamoorthi & Hanrahan
/// 2001, eq. 8): π/4, −π/24, π/64, …
#[must_use]
pub fn clamped_cosine_factor(l: usize) -> f64 {
    use std::f64::consts::PI;
    match l {
        0 => PI,
        1 => 2.0 * PI / 3.0,
        _ if l % 2 == 1 => 0.0,
        _ => {
            // C(l, l/2)/2^l = Π_{k=1}^{l/2} (2k − 1)/(2k).
            let c: f64 = (1..=l / 2)
                .map(|k| (2 * k - 1) as f64 / (2 * k) as f64)
                .product();
            let sign = if (l / 2) % 2 == 1 { 1.0 } else { -1.0 };
            2.0 * PI * sign * c / ((l + 2) * (l - 1)) as f64
        }
    }
}

/// SH bands of the lighting the env Lambert tail ([`lambert_tail_env`])
/// reads at run time: bands 4, 6 and 8 (`Λ_l` of the bands beyond are below
/// 1 % of Λ_0; under a sun-like light the irradiance they leave out is
/// ~1.5 % RMS, against ~8 % for the 9-term form alone).
pub const LAMBERT_TAIL_ORDER: usize = 9;

/// The bands `4 ≤ l < n` of Lambert under SH lighting `light` (`n²`
/// coefficients, `n ≤ 16`, in the frame of `m`) for an NDF taken beyond its
/// band 2 as one vMF lobe at its mean normal `m` (`|m| ≤ 1`, κ from `|m|`
/// by [`crate::vmf::kappa_estimate`], `A_l` by
/// [`crate::vmf::sh_attenuation_forward`];
/// `|m|` at the clamp's resultant or beyond is a delta):
/// `Σ_{even l ≥ 4} Λ_l A_l(κ) Σ_m y_lm(m̂) L_lm / π`. It completes
/// [`lambert_sh_env`] as [`lambert_sh_dir`]'s remainder does for one
/// direction: at level 0 (a delta) the sum of the two is the irradiance of
/// `light`'s `n` bands exactly. `y` is scratch of `≥ n²` floats.
///
/// # Panics
/// If `light` has more than 256 coefficients or `y` is shorter than `light`.
#[must_use]
pub fn lambert_tail_env(m: Vec3, light: &[f32], y: &mut [f32]) -> f32 {
    lambert_tail_channels(m, [light], y)[0]
}

/// [`lambert_tail_env`] for `C` channels of lighting of one order at once
/// (one SH evaluation and one `A_l(κ)`).
///
/// # Panics
/// As [`lambert_tail_env`], or if the channels' lengths differ.
#[must_use]
pub fn lambert_tail_channels<const C: usize>(
    m: Vec3,
    light: [&[f32]; C],
    y: &mut [f32],
) -> [f32; C] {
    let len = light[0].len();
    assert!(
        light.iter().all(|l| l.len() == len),
        "channels of one order"
    );
    let n = (len as f64).sqrt() as usize;
    assert!(n <= 16, "lambert_tail_env: at most 16 bands");
    let r = m.length();
    let mut out = [0.0f32; C];
    if n <= 4 || r <= 0.0 {
        return out;
    }
    let mut a = [1.0f64; 16];
    if r < 1.0 - 1.5 / crate::vmf::KAPPA_MAX as f32 {
        // Per pixel: Banerjee's κ estimate (as `unpack`) and forward steps.
        crate::vmf::sh_attenuation_forward(f64::from(crate::vmf::kappa_estimate(r)), &mut a[..n]);
    }
    let y = &mut y[..n * n];
    relight_sh::eval_sh_into(n, (m / r).to_array(), y);
    for (o, lc) in out.iter_mut().zip(light) {
        let mut s = 0.0f64;
        for l in (4..n).step_by(2) {
            let band: f32 = (l * l..(l + 1) * (l + 1)).map(|i| y[i] * lc[i]).sum();
            s += clamped_cosine_factor(l) * a[l] * f64::from(band);
        }
        *o = (s / std::f64::consts::PI) as f32;
    }
    out
}

/// [`lambert_tail_channels`] for the three colour channels of one
/// [`LAMBERT_TAIL_ORDER`]-band lighting, prepared once per lighting change:
/// `Λ_l/π · L_lm` is folded into the coefficients of the even bands 4, 6, 8
/// (the odd ones have `Λ_l = 0` and are dropped), and the band sums
/// `T_l(d) = Λ_l/π Σ_m y_lm(d) L_lm` (`l` = 4, 6, 8, per channel) are baked
/// at the nodes of an octahedral grid of directions (`(TAIL_GRID + 1)²`
/// nodes spanning `[−1, 1]²`: nodes lie on the map's folded outer edges,
/// where glued points have one direction and so one value, which makes the
/// bilinear lookup continuous over the seams, and on its axes, where the
/// map creases, which keeps the error second order). A pixel then
/// costs one bilinear lookup of 9 values at `m̂`, `A_l(κ)` for `l ≤ 8`, and
/// 9 products ([`Self::eval`]); [`Self::eval_exact`] evaluates the SH
/// directly (`3 × 39` products summed in f32; the portable form sums in
/// f64; the two agree within 1e-6 at a tail scale of ~0.1, tested; the
/// lookup's interpolation error is tested too).
#[derive(Clone, Debug)]
pub struct LambertTail {
    /// `Λ_l/π · L_lm` of bands 4, 6, 8, packed band after band, per channel.
    w: [[f32; TAIL_PACKED]; 3],
    /// `T_l(d)` per node of the octahedral grid (row-major,
    /// `(TAIL_GRID + 1)²`), as `[c * 3 + (l − 4)/2]`; empty without lighting.
    table: Vec<[f32; 9]>,
    /// Whether there is lighting at all (an empty input gives 0).
    on: bool,
}

/// Cells per side of [`LambertTail`]'s octahedral table. At 128 the
/// bilinear error is ~0.5 % of the tail's scale even with band 8 as strong
/// as band 4 (tested; it falls as the cell size squared: 0.1 % at 256).
pub const TAIL_GRID: usize = 128;

/// Cells of [`LambertTail::attenuation_468`]'s table over `[31/32, 1]`
/// (its table below 31/32 has four times as many).
pub const ATTENUATION_NODES: usize = 1024;

/// Coefficients of bands 4, 6 and 8: 9 + 13 + 17.
const TAIL_PACKED: usize = 39;

impl Default for LambertTail {
    /// No lighting: every tail is 0.
    fn default() -> Self {
        Self {
            w: [[0.0; TAIL_PACKED]; 3],
            table: Vec::new(),
            on: false,
        }
    }
}

impl LambertTail {
    /// Folds `Λ_l/π` into `light` (three channels of
    /// `LAMBERT_TAIL_ORDER²` coefficients each, or all empty: no lighting).
    ///
    /// # Panics
    /// If a channel has another length than `LAMBERT_TAIL_ORDER²` (and is
    /// not empty).
    #[must_use]
    pub fn new(light: [&[f32]; 3]) -> Self {
        if light.iter().all(|l| l.is_empty()) {
            return Self::default();
        }
        let nn = LAMBERT_TAIL_ORDER * LAMBERT_TAIL_ORDER;
        assert!(
            light.iter().all(|l| l.len() == nn),
            "LambertTail: {nn} coefficients per channel"
        );
        let mut w = [[0.0f32; TAIL_PACKED]; 3];
        for (wc, lc) in w.iter_mut().zip(light) {
            let mut k = 0;
            for l in (4..LAMBERT_TAIL_ORDER).step_by(2) {
                let f = clamped_cosine_factor(l) / std::f64::consts::PI;
                for v in &lc[l * l..(l + 1) * (l + 1)] {
                    wc[k] = (f * f64::from(*v)) as f32;
                    k += 1;
                }
            }
        }
        let side = TAIL_GRID + 1;
        let h = 2.0 / TAIL_GRID as f64;
        let table = (0..side * side)
            .into_par_iter()
            .map(|t| {
                let (i, j) = (t % side, t / side);
                let q = glam::DVec2::new(-1.0 + i as f64 * h, -1.0 + j as f64 * h);
                let d = relight_sphere::param::octahedron_from_octahedral(q).normalize();
                let mut y = [0.0f32; LAMBERT_TAIL_ORDER * LAMBERT_TAIL_ORDER];
                relight_sh::eval_sh_into(LAMBERT_TAIL_ORDER, d.as_vec3().to_array(), &mut y);
                let mut v = [0.0f32; 9];
                for (c, wc) in w.iter().enumerate() {
                    let mut k = 0;
                    for (b, l) in (4..LAMBERT_TAIL_ORDER).step_by(2).enumerate() {
                        let yl = &y[l * l..(l + 1) * (l + 1)];
                        v[c * 3 + b] = yl
                            .iter()
                            .zip(&wc[k..k + yl.len()])
                            .map(|(y, w)| y * w)
                            .sum();
                        k += yl.len();
                    }
                }
                v
            })
            .collect();
        Self { w, table, on: true }
    }

    /// `A_l(κ)` of bands 4, 6, 8 for a mean normal of length `r`
    /// (1 at the clamp's resultant or beyond: a delta), computed: κ by
    /// [`crate::vmf::kappa_estimate`], [`crate::vmf::sh_attenuation_forward`]
    /// in f64. What [`Self::attenuation_468`] tabulates.
    #[must_use]
    pub fn attenuation_468_exact(r: f32) -> [f32; 3] {
        let mut a = [1.0f64; LAMBERT_TAIL_ORDER];
        if r < 1.0 - 1.5 / crate::vmf::KAPPA_MAX as f32 {
            crate::vmf::sh_attenuation_forward(f64::from(crate::vmf::kappa_estimate(r)), &mut a);
        }
        [a[4] as f32, a[6] as f32, a[8] as f32]
    }

    /// [`Self::attenuation_468_exact`] by linear interpolation in `r` in two
    /// tables, `4 ×` [`ATTENUATION_NODES`] cells over `[0, 31/32]` (the
    /// steepest part, κ ≈ 20–40, is just below 31/32) and
    /// [`ATTENUATION_NODES`] over `[31/32, 1]` (built once, 61 KB; near 1, `A_l ≈ 1 − l(l+1)/2 ε + O(ε²)`
    /// in `ε = 1/κ ≈ 1 − r` curves fast for `l = 8`), the delta branch (`r`
    /// at the clamp's resultant) kept exact. In `r` the `A_l` are smooth at
    /// both ends (`κ ≈ 3r` near 0), so the error is second order: ≤ 5e-6
    /// (tested), where the computed form cost an f64 `exp` and eight
    /// recurrence steps per pixel.
    #[inline(always)]
    #[must_use]
    pub fn attenuation_468(r: f32) -> [f32; 3] {
        if r >= 1.0 - 1.5 / crate::vmf::KAPPA_MAX as f32 {
            return [1.0; 3];
        }
        const SPLIT: f32 = 31.0 / 32.0;
        const N: usize = 4 * ATTENUATION_NODES;
        const M: usize = ATTENUATION_NODES;
        static TABLE: std::sync::OnceLock<Vec<[f32; 3]>> = std::sync::OnceLock::new();
        let t = TABLE.get_or_init(|| {
            let lo = (0..=N).map(|i| SPLIT * i as f32 / N as f32);
            let hi = (0..=M).map(|i| SPLIT + (1.0 - SPLIT) * i as f32 / M as f32);
            lo.chain(hi).map(Self::attenuation_468_exact).collect()
        });
        let (x, base, cells) = if r < SPLIT {
            (r.max(0.0) * (N as f32 / SPLIT), 0, N)
        } else {
            ((r - SPLIT) * (M as f32 / (1.0 - SPLIT)), N + 1, M)
        };
        let i = (x as usize).min(cells - 1);
        let f = x - i as f32;
        let (a, b) = (t[base + i], t[base + i + 1]);
        // Written out: `[0, 1, 2].map(..)` was a call per pixel (`try_map`
        // not inlined).
        [
            a[0] + f * (b[0] - a[0]),
            a[1] + f * (b[1] - a[1]),
            a[2] + f * (b[2] - a[2]),
        ]
    }

    /// The tail at mean normal `m` (`|m| ≤ 1`, in the lighting's frame),
    /// per channel, from the baked table: [`lambert_tail_channels`]`(m,
    /// light)` up to the bilinear interpolation of `T_l` at `m̂`.
    #[inline(always)]
    #[must_use]
    pub fn eval(&self, m: Vec3) -> Vec3 {
        let r = m.length();
        if !self.on || r <= 0.0 {
            return Vec3::ZERO;
        }
        let a = Self::attenuation_468(r);
        // `relight_sphere::param::octahedral_from_dir_f32(m̂)` with one
        // division: the map divides by the L1 norm, so `m` needs no
        // normalizing, and `x/l1, y/l1` are products with `1/l1` (to rounding).
        let p = {
            let inv = 1.0 / (m.x.abs() + m.y.abs() + m.z.abs());
            let (x, y) = (m.x * inv, m.y * inv);
            if m.z < 0.0 {
                let sx = if x >= 0.0 { 1.0 } else { -1.0 };
                let sy = if y >= 0.0 { 1.0 } else { -1.0 };
                glam::Vec2::new((1.0 - y.abs()) * sx, (1.0 - x.abs()) * sy)
            } else {
                glam::Vec2::new(x, y)
            }
        };
        // Node i is at −1 + 2i/TAIL_GRID.
        let g = TAIL_GRID as f32;
        let x = ((p.x + 1.0) * 0.5 * g).clamp(0.0, g);
        let y = ((p.y + 1.0) * 0.5 * g).clamp(0.0, g);
        let (x0, y0) = (
            (x as usize).min(TAIL_GRID - 1),
            (y as usize).min(TAIL_GRID - 1),
        );
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let side = TAIL_GRID + 1;
        let t = &self.table;
        let at = |i: usize, j: usize| &t[j * side + i];
        let (t00, t10, t01, t11) = (
            at(x0, y0),
            at(x0 + 1, y0),
            at(x0, y0 + 1),
            at(x0 + 1, y0 + 1),
        );
        let (w00, w10, w01, w11) = (
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        );
        // The nine blends first (a fixed-size loop the compiler vectorizes),
        // then per channel `Σ_b A_b T_b` in the same order as before.
        let mut v = [0.0f32; 9];
        for k in 0..9 {
            v[k] = w00 * t00[k] + w10 * t10[k] + w01 * t01[k] + w11 * t11[k];
        }
        let mut out = Vec3::ZERO;
        for c in 0..3 {
            out[c] = 0.0 + a[0] * v[c * 3] + a[1] * v[c * 3 + 1] + a[2] * v[c * 3 + 2];
        }
        out
    }

    /// The tail at mean normal `m` (`|m| ≤ 1`, in the lighting's frame),
    /// per channel, by direct SH evaluation: [`lambert_tail_channels`]`(m,
    /// light)`.
    #[inline]
    #[must_use]
    pub fn eval_exact(&self, m: Vec3) -> Vec3 {
        let r = m.length();
        if !self.on || r <= 0.0 {
            return Vec3::ZERO;
        }
        let mut a = [1.0f64; LAMBERT_TAIL_ORDER];
        if r < 1.0 - 1.5 / crate::vmf::KAPPA_MAX as f32 {
            crate::vmf::sh_attenuation_forward(f64::from(crate::vmf::kappa_estimate(r)), &mut a);
        }
        let mut y = [0.0f32; LAMBERT_TAIL_ORDER * LAMBERT_TAIL_ORDER];
        relight_sh::eval_sh_into(LAMBERT_TAIL_ORDER, (m / r).to_array(), &mut y);
        let mut out = Vec3::ZERO;
        let mut k = 0;
        for l in (4..LAMBERT_TAIL_ORDER).step_by(2) {
            let yl = &y[l * l..(l + 1) * (l + 1)];
            let al = a[l] as f32;
            for c in 0..3 {
                let wl = &self.w[c][k..k + yl.len()];
                let band: f32 = yl.iter().zip(wl).map(|(y, w)| y * w).sum();
                out[c] += al * band;
            }
            k += yl.len();
        }
        out
    }
}

/// Lambert radiance of a vMF mixture under SH lighting `light` (9
/// coefficients, tangent frame): `Σ_j α_j Σ_l Λ_l A_l(κ_j) y_lm(μ_j) L_lm / π`.
#[inline]
#[must_use]
pub fn lambert_mixture_env(lobes: &[ShadeLobe], light: &[f32]) -> f32 {
    lambert_sh_env(&mixture_sh9(lobes), light)
}

/// The SH (bands 0–2) of a vMF mixture: `Σ_j α_j A_l(κ_j) y_lm(μ_j)`.
#[inline]
#[must_use]
pub fn mixture_sh9(lobes: &[ShadeLobe]) -> [f32; 9] {
    let mut gamma = [0.0f32; 9];
    let mut y = [0.0f32; 9];
    for l in lobes {
        relight_sh::eval_sh_into(3, l.mu.to_array(), &mut y);
        let a = crate::vmf::attenuation_012(l.inv_kappa);
        for i in 0..9 {
            let band = if i == 0 {
                0
            } else if i < 4 {
                1
            } else {
                2
            };
            gamma[i] += l.alpha * a[band] * y[i];
        }
    }
    gamma
}

/// [`lambert_mixture_env`] with each lobe's bands `4 ≤ l < n` of `light`
/// (`n²` coefficients, `n ≤ 16`) added as in [`lambert_tail_env`] (lobe `j`
/// at `A(κ_j) μ_j`); `y` is scratch of `≥ n²` floats.
#[must_use]
pub fn lambert_mixture_env_tail(lobes: &[ShadeLobe], light: &[f32], y: &mut [f32]) -> f32 {
    let low = lambert_mixture_env(lobes, &light[..9]);
    let tail: f32 = lobes
        .iter()
        .map(|l| l.alpha * lambert_tail_env(l.mean_normal(), light, y))
        .sum();
    low + tail
}

/// The baselines: one normal per texel from the mean normal `m` of the
/// footprint (`|m| ≤ 1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Baseline {
    /// The mean normal as it is, plugged into every `n·ω` (darkens).
    Unnormalized,
    /// The mean normal renormalized.
    Normalized,
    /// Toksvig 2005: renormalized, and the lobe widened by
    /// `1/κ = (1 − |m|)/|m|` (`s' = |m| s / (|m| + s(1 − |m|))`;
    /// `α'² = α² + 2(1 − |m|)/|m|`). Lambert as `Normalized`.
    Toksvig,
}

/// `f·cos θ_i` of a baseline for mean normal `m` (module docs).
#[inline]
#[must_use]
pub fn shade_baseline(brdf: NdfBrdf, b: Baseline, m: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    let r = m.length();
    if r <= 0.0 {
        return 0.0;
    }
    let n = m / r;
    match b {
        Baseline::Unnormalized => match brdf {
            NdfBrdf::Lambert if n.dot(wo) > 0.0 => m.dot(wi).max(0.0) / PI,
            NdfBrdf::Lambert => 0.0,
            NdfBrdf::Blinn { s } => r.powf(s + 1.0) * shade_lobe(brdf, n, 0.0, wo, wi),
            _ => r * shade_lobe(brdf, n, 0.0, wo, wi),
        },
        Baseline::Normalized => shade_lobe(brdf, n, 0.0, wo, wi),
        Baseline::Toksvig => match brdf {
            NdfBrdf::Lambert => shade_lobe(brdf, n, 0.0, wo, wi),
            _ => shade_lobe(brdf, n, ((1.0 - r) / r).max(0.0), wo, wi),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_matches_f64() {
        let mut worst = 0.0f64;
        for i in 0..=870_000 {
            let t = i as f32 * 1e-4;
            let want = (-f64::from(t)).exp();
            let rel = (f64::from(exp_neg(t)) - want).abs() / want;
            worst = worst.max(rel);
        }
        assert!(worst <= 2.5e-7, "worst relative error {worst:e}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert!(exp_neg(1e9) > 0.0 && exp_neg(1e9) < 2e-38);
        assert_eq!(exp_neg(-3.0), 1.0, "negative t clamps to 0");
    }

    #[test]
    fn normal_cdf_and_pdf_match_the_f64_forms() {
        // Φ by the midpoint rule on φ (independent of A&S).
        let phi = |x: f64| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
        for i in -160..=160 {
            let x = i as f32 / 20.0;
            let (c, p) = normal_cdf_pdf(x);
            let n = 20_000;
            let (lo, h) = (-12.0, (f64::from(x) + 12.0) / f64::from(n));
            let want: f64 = (0..n).map(|k| phi(lo + (f64::from(k) + 0.5) * h) * h).sum();
            assert!((f64::from(c) - want).abs() < 3e-7, "Φ({x}) = {c} vs {want}");
            let wp = if x.abs() > 6.0 {
                0.0
            } else {
                phi(f64::from(x))
            };
            assert!((f64::from(p) - wp).abs() < 1e-7, "φ({x}) = {p} vs {wp}");
            assert_eq!(normal_cdf(x), c);
        }
    }

    #[test]
    fn pow_unit_is_the_power_to_two_parts_in_1e5() {
        let mut xs: Vec<f32> = (0..=50_000).map(|i| i as f32 / 50_000.0).collect();
        xs.extend([
            1e-3,
            1e-20,
            1e-38,
            1e-40,
            1e-45,
            0.999_999_9,
            1.0,
            1.000_000_1,
        ]);
        for p in [1e-3f32, 0.5, 1.0, 7.3, 63.9, 255.5, 1000.7, 2048.0] {
            let mut worst = 0.0f64;
            for &x in &xs {
                let exact = f64::from(x.min(1.0)).powf(f64::from(p));
                let got = f64::from(pow_unit(x, p));
                assert!(got.is_finite() && got >= 0.0, "{x}^{p} = {got}");
                if exact > 1e-30 {
                    worst = worst.max((got - exact).abs() / exact);
                } else {
                    assert!(got <= 2e-30, "{x}^{p} = {got}");
                }
            }
            assert!(worst <= 2e-5, "p = {p}: relative {worst:e}");
        }
        assert_eq!(pow_unit(0.0, 3.5), 0.0);
        assert_eq!(pow_unit(1.0, 3.5), 1.0);
        assert_eq!(pow_unit(f32::NAN, 3.5), 0.0);
        assert_eq!(pow_unit(-0.5, 3.5), 0.0);
    }

    #[test]
    fn whole_exponents_by_squaring_are_the_power() {
        for s in [1.0f32, 2.0, 7.0, 64.0, 100.0, 1024.0, 63.5, 2000.0] {
            let mut worst = 0.0f64;
            for i in 0..=20_000 {
                let x = i as f32 / 20_000.0;
                let exact = f64::from(x).powf(f64::from(s));
                let got = f64::from(pow_exponent(x, s));
                if exact > 1e-30 {
                    worst = worst.max((got - exact).abs() / exact);
                } else {
                    assert!(got <= 1e-29, "{x}^{s} = {got}");
                }
            }
            let bound = f64::from(s.max(4.0)) * 2f64.powi(-23);
            assert!(worst <= bound, "s = {s}: relative {worst} > {bound}");
        }
    }
}
