//! The special functions of the analytic single-scattering model, evaluated
//! exactly (adaptive Gauss–Kronrod in f64, relative tolerance 1e-10 per
//! integral, so every value is good to well below 1e-7 relative).
//!
//! # Definitions (Sun 2008, ch. 3)
//! * F(u, v) = ∫₀ᵛ exp(−u tan ξ) dξ, u ≥ 0, v ∈ [0, π/2] (eq. 3.15).
//! * Fᵏ(u, v) = ∫₀ᵛ cosᵏ(2ξ) exp(−u tan ξ) dξ (eq. 3.19); cos 2ξ = cos α is
//!   the cosine of the scattering angle at the scattering point.
//! * G_n(T, θ) (eq. 3.23), the surface-radiance integral of the airlight
//!   over the hemisphere, weighted by cosⁿθᵢ (n = 1 for the Lambertian G₀).
//!
//! # The scaled tail H̃ — why the tables store it instead of F
//! Airlight is always a *difference* F(u, v₂) − F(u, v₁) (eq. 3.16), which
//! cancels catastrophically when both values approach F(u, π/2) (thick
//! media, grazing angles). Writing the difference with the tail
//! ∫ᵥ^{π/2} e^{−u tan ξ} dξ = e^{−u tan v} H̃(u, v), where
//!
//!   H̃ᵏ(u, v) = ∫ᵥ^{π/2} cosᵏ(2ξ) exp(−u (tan ξ − tan v)) dξ,
//!
//! the exponential factors combine with A₀ of eq. 3.7 into e^{−T_sv} exactly
//! (because T cos γ + T sin γ tan(γ/2) = T), so the airlight to infinity is
//!
//!   L_a(γ, T_sv, ∞) = β I₀ e^{−T_sv} H̃(T_sv sin γ, γ/2) / (2π D_sv sin γ),
//!
//! and with a surface at optical depth T_vp (splitting the ray at the
//! surface point p, whose angle to the source is γ_p = 2 v₂ of eq. 3.16):
//!
//!   L_a = L_a(γ, T_sv, ∞) − e^{−T_vp} L_a(γ_p, T_sp, ∞).
//!
//! H̃ is bounded (≤ π/2 − v) and smooth; F itself is recovered as
//! F(u, v) = F(u, π/2) − e^{−u tan v} H̃(u, v). G_n similarly becomes
//! G_n(T, θ) = e^{−T} ∫₀^π H̃(T sin γ′, γ′/2) P_n(γ′, θ) dγ′, where the
//! azimuthal integral about the source direction P_n(γ′, θ) =
//! ∫₀^{2π} max(0, cos γ′ cos θ + sin γ′ sin θ cos φ)ⁿ dφ absorbs the solid
//! angle sin γ′ and the 1/sin γ′ of eq. 3.23.

use crate::quad::{integrate, integrate_pieces};
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::OnceLock;

fn gl32() -> (&'static [f64], &'static [f64]) {
    static GL: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    let g = GL.get_or_init(|| relight_sh::quadrature::gauss_legendre(32));
    (&g.0, &g.1)
}

/// Relative tolerance of every adaptive integral in this module.
pub const QUAD_REL: f64 = 1e-10;

/// F(u, v) = ∫₀ᵛ exp(−u tan ξ) dξ (Sun 2008, eq. 3.15).
///
/// `u` is clamped to ≥ 0 and `v` to [0, π/2]; F(u, π/2) is finite for u > 0
/// and equals π/2 at u = 0.
#[must_use]
pub fn f_special(u: f64, v: f64) -> f64 {
    fk_special(0, u, v)
}

/// Fᵏ(u, v) = ∫₀ᵛ cosᵏ(2ξ) exp(−u tan ξ) dξ (Sun 2008, eq. 3.19).
/// Same clamping as [`f_special`].
#[must_use]
pub fn fk_special(k: u32, u: f64, v: f64) -> f64 {
    let u = if u.is_nan() { 0.0 } else { u.max(0.0) };
    let v = if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, FRAC_PI_2)
    };
    if u.is_infinite() {
        return 0.0;
    }
    integrate(
        |xi| {
            let e = if xi >= FRAC_PI_2 {
                if u > 0.0 { 0.0 } else { 1.0 }
            } else {
                (-u * xi.tan()).exp()
            };
            if k == 0 {
                e
            } else {
                (2.0 * xi).cos().powi(k as i32) * e
            }
        },
        0.0,
        v,
        QUAD_REL,
        1e-300,
    )
}

/// The scaled tail H̃ᵏ(u, v) = ∫ᵥ^{π/2} cosᵏ(2ξ) exp(−u (tan ξ − tan v)) dξ
/// (see the module docs). u ≥ 0 (clamped; u = ∞ gives 0), v ∈ [0, π/2] (clamped).
#[must_use]
pub fn tail_scaled(k: u32, u: f64, v: f64) -> f64 {
    tail_scaled_tol(k, u, v, QUAD_REL)
}

/// [`tail_scaled`] to relative tolerance `rel`.
#[must_use]
pub fn tail_scaled_tol(k: u32, u: f64, v: f64, rel: f64) -> f64 {
    let u = if u.is_nan() { 0.0 } else { u.max(0.0) };
    let v = if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, FRAC_PI_2)
    };
    if u.is_infinite() || v >= FRAC_PI_2 {
        return 0.0;
    }
    // cos v is constant; cos 2ξ is only needed for k > 0.
    let cos_v = v.cos();
    integrate(
        |xi| {
            let c = if k == 0 {
                1.0
            } else {
                (2.0 * xi).cos().powi(k as i32)
            };
            if u == 0.0 {
                c
            } else if xi >= FRAC_PI_2 {
                0.0
            } else {
                // tan ξ − tan v = sin(ξ − v) / (cos ξ cos v), without cancellation.
                c * (-u * (xi - v).sin() / (xi.cos() * cos_v)).exp()
            }
        },
        v,
        FRAC_PI_2,
        rel,
        1e-300,
    )
}

/// The normaliser N(u, v) = cos²v / (cos v + u) that captures the behaviour
/// of H̃ at u → ∞ (≈ cos²v/u), at v → π/2 (≈ cos v) and at u = v = 0 (up
/// to π/2), so that the tabulated ratio R = H̃ / N stays within [0.8, π/2].
#[inline]
#[must_use]
pub fn tail_normaliser(u: f64, v: f64) -> f64 {
    let c = v.cos().max(0.0);
    c * c / (c + u)
}

/// Corner factor q(c) = (1 + c) E(c), E(c) = ∫₀^∞ e^{−c r}/(1 + r)² dr,
/// c = u tan v: the limit of H̃/N at the corner u → 0, v → π/2 along
/// u tan v = c (light nearly behind the viewer). q(0) = q(∞) = 1, min ≈ 0.8.
/// The tables divide by N·q so that the tabulated ratio is continuous there.
#[must_use]
pub fn corner_factor(c: f64) -> f64 {
    if c.is_nan() || c <= 0.0 {
        return 1.0;
    }
    if c > 100.0 {
        // Asymptotic series E(c) ≈ 1/c − 2/c² + 6/c³ − 24/c⁴.
        return 1.0 - 1.0 / c + 4.0 / (c * c) - 18.0 / (c * c * c);
    }
    // r = s/(1−s).
    let e = integrate(
        |s: f64| {
            if s >= 1.0 {
                return 0.0;
            }
            let r = s / (1.0 - s);
            (-c * r).exp() / ((1.0 + r) * (1.0 + r)) / ((1.0 - s) * (1.0 - s))
        },
        0.0,
        1.0,
        1e-10,
        1e-300,
    );
    (1.0 + c) * e
}

/// The tabulated ratio Rᵏ(u, v) = H̃ᵏ(u, v) / (N(u, v) q(u tan v)), with its limits:
/// Rᵏ → cosᵏ(2v) as u → ∞ and Rᵏ → (−1)ᵏ as v → π/2.
#[must_use]
pub fn tail_ratio(k: u32, u: f64, v: f64) -> f64 {
    let v = if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, FRAC_PI_2)
    };
    let sign = if k % 2 == 1 { -1.0 } else { 1.0 };
    if u.is_infinite() {
        return (2.0 * v).cos().powi(k as i32);
    }
    let c = v.cos();
    if c < 1e-9 {
        return sign;
    }
    let u = u.max(0.0);
    let den = tail_normaliser(u, v) * corner_factor(u * v.tan());
    if !(den > 0.0 && den.is_finite()) {
        return sign;
    }
    tail_scaled(k, u, v) / den
}

/// P_n(γ, θ) = ∫₀^{2π} max(0, cos γ cos θ + sin γ sin θ cos φ)ⁿ dφ — the
/// azimuthal integral of a clamped cosine lobe (exponent `n` ≥ 1) about the
/// source direction; `mu` = cos θ.
#[must_use]
pub fn lobe_azimuthal(n: u32, gamma: f64, mu: f64) -> f64 {
    let mu = mu.clamp(-1.0, 1.0);
    let a = gamma.cos() * mu;
    let b = gamma.sin().abs() * (1.0 - mu * mu).max(0.0).sqrt();
    if a <= -b {
        return 0.0;
    }
    if a >= b {
        // No clamping: binomial expansion of ∫(a + b cos φ)ⁿ dφ; only even
        // powers of cos survive, ∫cos^{2j} = 2π (2j−1)!!/(2j)!!.
        let mut sum = 0.0;
        let mut binom = 1.0; // C(n, j)
        let mut dfr = 1.0; // (j−1)!!/j!! for even j
        for j in 0..=n {
            if j > 0 {
                binom *= f64::from(n - j + 1) / f64::from(j);
            }
            if j % 2 == 0 {
                if j > 0 {
                    dfr *= f64::from(j - 1) / f64::from(j);
                }
                sum += binom * a.powi((n - j) as i32) * b.powi(j as i32) * dfr;
            }
        }
        return 2.0 * PI * sum;
    }
    let phi0 = (-a / b).clamp(-1.0, 1.0).acos();
    // The clamped integrand is a smooth polynomial in cos φ on [0, φ0] that
    // vanishes at φ0: a fixed 32-point Gauss–Legendre rule is exact to ~1e-12.
    let (x, w) = gl32();
    let h = 0.5 * phi0;
    let s: f64 = x
        .iter()
        .zip(w)
        .map(|(xi, wi)| wi * (a + b * (h + h * xi).cos()).max(0.0).powi(n as i32))
        .sum();
    2.0 * h * s
}

/// e^{T} G_n(T, θ) = ∫₀^π H̃(T sin γ′, γ′/2) P_n(γ′, θ) dγ′ (eq. 3.23 after
/// the change of variables in the module docs). `n` = 1 is the Lambertian
/// G₀ of the paper (weight cos θᵢ); `n` ≥ 1 the reparameterised Phong lobe.
/// `t` ≥ 0 (clamped), `mu` = cos θ ∈ [−1, 1] (clamped).
#[must_use]
pub fn g_scaled(n: u32, t: f64, mu: f64) -> f64 {
    let t = if t.is_nan() { 0.0 } else { t.max(0.0) };
    let mu = mu.clamp(-1.0, 1.0);
    let theta = mu.acos();
    let breaks = {
        let mut b = [FRAC_PI_2 - theta, theta - FRAC_PI_2, theta + FRAC_PI_2];
        b.sort_by(f64::total_cmp);
        b
    };
    integrate_pieces(
        |g| {
            let p = lobe_azimuthal(n, g, mu);
            if p == 0.0 {
                0.0
            } else {
                tail_scaled_tol(0, t * g.sin(), 0.5 * g, 1e-8) * p
            }
        },
        0.0,
        PI,
        &breaks,
        1e-7,
        1e-300,
    )
}

/// G_n(T, θ) of eq. 3.23 (`n` = 1: Lambertian G₀), `mu` = cos θ.
#[must_use]
pub fn g_special(n: u32, t: f64, mu: f64) -> f64 {
    (-t.max(0.0)).exp() * g_scaled(n, t, mu)
}

/// Exact isotropic airlight to infinity divided by the source intensity and
/// β/(2π D_sv): e^{−T} H̃(T sin γ, γ/2) / sin γ, i.e.
/// L_a(γ, T, ∞) = β I₀ / (2π D_sv) · `airlight_inf_kernel(T, γ)`.
#[must_use]
pub fn airlight_inf_kernel(t: f64, gamma: f64) -> f64 {
    let s = gamma.sin().max(1e-300);
    (-t).exp() * tail_scaled(0, t * gamma.sin(), 0.5 * gamma) / s
}

/// Direct numerical integration of the airlight single-scattering integral
/// (eq. 3.5) for an isotropic phase function, in radiance units:
/// L_a = β I₀/(4π) ∫₀^{D_vp} e^{−β d(x)} e^{−β x} / d(x)² dx, with d from
/// the cosine rule (eq. 3.4). `d_vp` may be infinite. This is the oracle of
/// `verify_fog`; it shares no code with the tables.
#[must_use]
pub fn airlight_eq35(beta: f64, i0: f64, d_sv: f64, d_vp: f64, gamma: f64) -> f64 {
    let cg = gamma.cos();
    let integrand = |x: f64| {
        let d2 = (d_sv * d_sv + x * x - 2.0 * x * d_sv * cg).max(1e-300);
        (-beta * (d2.sqrt() + x)).exp() / d2
    };
    // Split at the closest approach (the peak) and map an infinite tail.
    let x0 = (d_sv * cg).max(0.0);
    let mut sum = 0.0;
    let end = if d_vp.is_finite() {
        d_vp
    } else {
        f64::INFINITY
    };
    let peak = x0.min(end);
    let w = d_sv * gamma.sin().abs() + 1e-12;
    let mut breaks = vec![(peak - w).max(0.0), peak, (peak + w).min(end)];
    breaks.dedup();
    if end.is_finite() {
        sum += integrate_pieces(integrand, 0.0, end, &breaks, 1e-11, 1e-300);
    } else {
        let cut = peak + w + 10.0 / beta.max(1e-12) + 10.0 * d_sv;
        sum += integrate_pieces(integrand, 0.0, cut, &breaks, 1e-11, 1e-300);
        // x = cut + s/(1−s)
        sum += integrate(
            |s: f64| {
                if s >= 1.0 {
                    return 0.0;
                }
                let x = cut + s / (1.0 - s);
                integrand(x) / ((1.0 - s) * (1.0 - s))
            },
            0.0,
            1.0,
            1e-11,
            1e-300,
        );
    }
    beta * i0 / (4.0 * PI) * sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_sh::quadrature::gauss_legendre;

    /// Independent check: composite Gauss–Legendre (not GK) on the
    /// s = tan ξ form F(u, v) = ∫₀^{tan v} e^{−us}/(1+s²) ds.
    fn f_indep(u: f64, v: f64) -> f64 {
        let (x, w) = gauss_legendre(40);
        let b = v.tan();
        let m = 200;
        let mut s = 0.0;
        for i in 0..m {
            let (lo, hi) = (b * i as f64 / m as f64, b * (i + 1) as f64 / m as f64);
            for (xi, wi) in x.iter().zip(&w) {
                let t = 0.5 * (lo + hi) + 0.5 * (hi - lo) * xi;
                s += 0.5 * (hi - lo) * wi * (-u * t).exp() / (1.0 + t * t);
            }
        }
        s
    }

    #[test]
    fn f_matches_independent_quadrature() {
        for &(u, v) in &[
            (0.0, 1.0),
            (0.3, 0.2),
            (1.0, 1.0),
            (5.0, 1.4),
            (10.0, 0.7),
            (0.01, 1.5),
        ] {
            let a = f_special(u, v);
            let b = f_indep(u, v);
            assert!(
                ((a - b) / b).abs() < 1e-7,
                "F({u},{v}) = {a} vs independent {b}"
            );
        }
        // F(0, v) = v exactly.
        assert!((f_special(0.0, 0.9) - 0.9).abs() < 1e-12);
    }

    #[test]
    fn tail_identity_with_f() {
        for &(u, v) in &[(0.5, 0.3), (2.0, 1.0), (0.1, 1.2), (7.0, 0.05)] {
            let lhs = f_special(u, FRAC_PI_2) - f_special(u, v);
            let rhs = (-u * v.tan()).exp() * tail_scaled(0, u, v);
            assert!(
                ((lhs - rhs) / rhs).abs() < 1e-7,
                "tail({u},{v}): F-diff {lhs} vs e^-u tan v H {rhs}"
            );
        }
        for k in 1..4 {
            let (u, v) = (0.8, 0.4);
            let lhs = fk_special(k, u, FRAC_PI_2) - fk_special(k, u, v);
            let rhs = (-u * v.tan()).exp() * tail_scaled(k, u, v);
            assert!(
                (lhs - rhs).abs() < 1e-8 * lhs.abs().max(1e-3),
                "k={k}: {lhs} vs {rhs}"
            );
        }
    }

    #[test]
    fn airlight_kernel_matches_eq35() {
        for &(beta, dsv, gamma) in &[
            (0.04, 20.0, 0.3),
            (0.5, 3.0, 2.0),
            (1.0, 1.0, 1.0),
            (0.1, 50.0, 3.0),
        ] {
            let a = beta / (2.0 * PI * dsv) * airlight_inf_kernel(beta * dsv, gamma);
            let b = airlight_eq35(beta, 1.0, dsv, f64::INFINITY, gamma);
            assert!(
                ((a - b) / b).abs() < 1e-6,
                "β={beta} D={dsv} γ={gamma}: model {a} vs eq.3.5 {b}"
            );
        }
    }

    #[test]
    fn lobe_azimuthal_matches_quadrature() {
        for &(n, g, mu) in &[
            (1u32, 0.3, 0.9),
            (1, 1.2, 0.2),
            (10, 0.5, 0.7),
            (20, 0.2, 0.99),
            (3, 2.0, -0.5),
        ] {
            let a = lobe_azimuthal(n, g, mu);
            let st = (1.0 - mu * mu).sqrt();
            let m = 20000;
            let b: f64 = (0..m)
                .map(|i| {
                    let phi = 2.0 * PI * (i as f64 + 0.5) / m as f64;
                    (g.cos() * mu + g.sin() * st * phi.cos())
                        .max(0.0)
                        .powi(n as i32)
                })
                .sum::<f64>()
                * 2.0
                * PI
                / m as f64;
            assert!(
                (a - b).abs() < 1e-6 * b.max(1e-3),
                "P_{n}({g},{mu}) = {a} vs midpoint {b}"
            );
        }
    }
}
