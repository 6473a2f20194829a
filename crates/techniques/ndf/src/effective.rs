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
//! The cosine `max(0, n·ω_i)` of a half-angle model is taken at the lobe
//! axis μ (and `μ·ω_o > 0` is required), as Han et al. do.
//!
//! # Lambert under a directional light, per vMF lobe
//! `∫ max(0, n·l) γ(n; μ, κ) dn` has no closed form. Its bands `l ≤ 2` are
//! exact (`Σ c_l A_l(κ) P_l(μ·l)`, `c = (1/4, 1/2, 5/16)`); the remainder of
//! the clamped cosine beyond them (`max(0,t) − Σ_{l≤2} c_l P_l(t)`, bands
//! 4, 6, …) is attenuated by `A_4(κ)`, so a delta (κ at the clamp) is exact
//! and κ → 0 gives the uniform answer 1/4 · … (tested against quadrature).

use crate::pyramid::ShadeLobe;
use glam::Vec3;
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
            if co <= 0.0 {
                return 0.0;
            }
            lambert_lobe(ci, inv_kappa) / PI
        }
        _ if co <= 0.0 || ci <= 0.0 => 0.0,
        NdfBrdf::Blinn { s } => {
            let Some(h) = (wo + wi).try_normalize() else {
                return 0.0;
            };
            let sp = s / (1.0 + s * inv_kappa);
            blinn_phong_normalization(s) * (sp / s) * n.dot(h).max(0.0).powf(sp) * ci
        }
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

/// `f·cos θ_i` of a vMF mixture: `Σ_j α_j` [`shade_lobe`]`(μ_j, 1/κ_j)`.
#[inline]
#[must_use]
pub fn shade_mixture(brdf: NdfBrdf, lobes: &[ShadeLobe], wo: Vec3, wi: Vec3) -> f32 {
    if let NdfBrdf::Blinn { s } = brdf {
        // `shade_lobe` per lobe, with the half vector and the normalization
        // (an f64 `exp2`) hoisted out of the lobe loop.
        let Some(h) = (wo + wi).try_normalize() else {
            return 0.0;
        };
        let c = blinn_phong_normalization(s);
        return lobes
            .iter()
            .map(|l| {
                let ci = l.mu.dot(wi);
                if l.mu.dot(wo) <= 0.0 || ci <= 0.0 {
                    return 0.0;
                }
                let sp = s / (1.0 + s * l.inv_kappa);
                l.alpha * c * (sp / s) * l.mu.dot(h).max(0.0).powf(sp) * ci
            })
            .sum();
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
    let mut y = [0.0f32; 9];
    relight_sh::eval_sh_into(3, wi.to_array(), &mut y);
    let low = lambert_sh_env(gamma, &y);
    let m = mean_normal_of_sh(gamma);
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

/// The mean normal of an SH NDF from its band 1 (convention-free: three
/// evaluations of band 1 at the axes).
#[inline]
#[must_use]
pub fn mean_normal_of_sh(gamma: &[f32]) -> Vec3 {
    let mut y = [0.0f32; 4];
    let mut axis = |a: Vec3| {
        relight_sh::eval_sh_into(2, a.to_array(), &mut y);
        (gamma[1] * y[1] + gamma[2] * y[2] + gamma[3] * y[3]) * (4.0 * PI / 3.0)
    };
    Vec3::new(axis(Vec3::X), axis(Vec3::Y), axis(Vec3::Z))
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
    let mut s = 0.0;
    for i in 0..9 {
        s += LAMBDA[i] * gamma[i] * light[i];
    }
    s
}

/// Lambert radiance of a vMF mixture under SH lighting `light` (9
/// coefficients, tangent frame): `Σ_j α_j Σ_l Λ_l A_l(κ_j) y_lm(μ_j) L_lm / π`.
#[inline]
#[must_use]
pub fn lambert_mixture_env(lobes: &[ShadeLobe], light: &[f32]) -> f32 {
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
    lambert_sh_env(&gamma, light)
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
