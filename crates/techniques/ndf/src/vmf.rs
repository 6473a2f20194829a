//! The von Mises–Fisher lobe on S² (Banerjee, Dhillon, Ghosh & Sra 2005;
//! Han et al. 2007 §4): density, mean resultant length, its inverse, and the
//! SH attenuation factors `A_l(κ)` of the lobe.
//!
//! # Definitions
//! * Density `γ(n; μ, κ) = κ / (4π sinh κ) · exp(κ μ·n)`, sr⁻¹, κ ≥ 0
//!   (κ = 0: uniform). Written as `κ / (2π (1 − e^{−2κ})) · exp(κ (μ·n − 1))`
//!   so it never overflows.
//! * Mean resultant length `r = A(κ) = E[μ·n] = coth κ − 1/κ` ∈ [0, 1).
//! * SH of the lobe: `γ_lm = A_l(κ) y_lm(μ)` with `A_l(κ) = I_{l+½}(κ) / I_{½}(κ)`
//!   (Funk–Hecke; `A_0 = 1`, `A_1 = A(κ)`). The forward recurrence
//!   `A_{l+1} = A_{l−1} − (2l+1)/κ · A_l` loses every digit for κ ≪ l; the
//!   ratios `R_l = A_l / A_{l−1}` obey the continued fraction
//!   `R_l = 1 / ((2l+1)/κ + R_{l+1})`, which is evaluated *backward* from a
//!   start far above the wanted band (Miller's algorithm), stable for every κ.

/// Largest concentration stored: a lobe at the clamp is a delta
/// (`1/κ` is treated as 0 by the effective BRDFs), so level 0 of a pyramid
/// shades exactly as plain normal mapping.
pub const KAPPA_MAX: f64 = 1.0e5;
/// Smallest concentration the fit produces (a lobe this wide is nearly uniform).
pub const KAPPA_MIN: f64 = 1.0e-3;

/// One normalized vMF lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vmf {
    /// Unit mean direction.
    pub mu: glam::DVec3,
    /// Concentration κ ∈ [[`KAPPA_MIN`], [`KAPPA_MAX`]].
    pub kappa: f64,
}

/// `log` of the normalization `κ / (2π (1 − e^{−2κ}))` of [`Vmf::density`]
/// (the factor in front of `exp(κ (μ·n − 1))`); `−log 4π` at κ → 0.
#[must_use]
pub fn log_norm(kappa: f64) -> f64 {
    if kappa < 1e-8 {
        return -(4.0 * std::f64::consts::PI).ln();
    }
    kappa.ln() - (2.0 * std::f64::consts::PI).ln() - (-(-2.0 * kappa).exp_m1()).ln()
}

/// The normalization itself, `κ / (2π (1 − e^{−2κ}))` (`1/4π` at κ → 0):
/// [`log_norm`] without its logarithms, for callers that take one `ln` of a
/// product. Past κ = 20, `e^{−2κ} < 5e-18` is below half an ulp of 1.
#[must_use]
pub fn norm(kappa: f64) -> f64 {
    if kappa < 1e-8 {
        return 1.0 / (4.0 * std::f64::consts::PI);
    }
    let tail = if kappa > 20.0 {
        1.0
    } else {
        -(-2.0 * kappa).exp_m1()
    };
    kappa / (2.0 * std::f64::consts::PI * tail)
}

impl Vmf {
    /// Density at unit `n`, sr⁻¹.
    #[must_use]
    pub fn density(&self, n: glam::DVec3) -> f64 {
        (log_norm(self.kappa) + self.kappa * (self.mu.dot(n) - 1.0)).exp()
    }
}

/// Mean resultant length `A(κ) = coth κ − 1/κ` (series below κ = 1e-3).
#[must_use]
pub fn mean_resultant(kappa: f64) -> f64 {
    if kappa < 1e-3 {
        return kappa / 3.0 - kappa.powi(3) / 45.0;
    }
    // coth κ = (1 + e^{−2κ}) / (1 − e^{−2κ}); beyond κ = 20, e^{−2κ} < 5e-18
    // leaves both sums at 1 in f64 (half an ulp is 5.5e-17): no `exp`.
    let e = if kappa > 20.0 {
        0.0
    } else {
        (-2.0 * kappa).exp()
    };
    (1.0 + e) / (1.0 - e) - 1.0 / kappa
}

/// The κ with `A(κ) = r`: Banerjee et al.'s estimate `r (3 − r²)/(1 − r²)`
/// refined by Newton steps on `A(κ) − r` (`A'(κ) = 1 − A² − 2A/κ`), clamped
/// to [[`KAPPA_MIN`], [`KAPPA_MAX`]]. `r` outside [0, 1) clamps.
#[must_use]
pub fn kappa_from_resultant(r: f64) -> f64 {
    let r_max = mean_resultant(KAPPA_MAX);
    if r.is_nan() || r <= 0.0 {
        return KAPPA_MIN;
    }
    if r >= r_max {
        return KAPPA_MAX;
    }
    let mut k = r * (3.0 - r * r) / (1.0 - r * r);
    for _ in 0..3 {
        let a = mean_resultant(k);
        let d = 1.0 - a * a - 2.0 * a / k;
        if d <= 0.0 {
            break;
        }
        let next = k - (a - r) / d;
        if !(next.is_finite() && next > 0.0) {
            break;
        }
        k = next;
    }
    k.clamp(KAPPA_MIN, KAPPA_MAX)
}

/// The fast estimate `r (3 − r²)/(1 − r²)` alone (Banerjee et al. 2005 eq. 4.4),
/// clamped as [`kappa_from_resultant`]: what the shader uses per pixel.
#[inline]
#[must_use]
pub fn kappa_estimate(r: f32) -> f32 {
    if r.is_nan() || r <= 0.0 {
        return KAPPA_MIN as f32;
    }
    let r = r.min(1.0 - 1.0 / KAPPA_MAX as f32);
    (r * (3.0 - r * r) / (1.0 - r * r)).clamp(KAPPA_MIN as f32, KAPPA_MAX as f32)
}

/// Writes `A_l(κ)` for `l = 0..out.len()` (module docs), without allocating.
/// For `κ ≥ 4n² + 16` (`n = out.len()`) the forward recurrence from
/// `A_0 = 1`, `A_1 = A(κ)` is used: every step's factor `(2l+1)/κ` is below
/// `1/(2n)`, so rounding errors do not grow. Otherwise the ratios' continued
/// fraction is run backward from `n + 40 + 8√κ` bands up, where the ratio is
/// negligible. κ ≥ 0; κ = 0 gives `[1, 0, 0, …]`.
pub fn sh_attenuation(kappa: f64, out: &mut [f64]) {
    if out.is_empty() {
        return;
    }
    out.fill(0.0);
    out[0] = 1.0;
    if kappa <= 0.0 {
        return;
    }
    let n = out.len();
    if kappa >= (4 * n * n + 16) as f64 {
        if n > 1 {
            out[1] = mean_resultant(kappa);
        }
        for l in 1..n.saturating_sub(1) {
            out[l + 1] = out[l - 1] - (2 * l + 1) as f64 / kappa * out[l];
        }
        return;
    }
    // R_l decays like κ/(2l+1) once 2l+1 ≫ κ; start well beyond both.
    let start = n + 40 + (kappa.sqrt() * 8.0) as usize;
    let mut ratio = 0.0f64; // R_{start+1}
    // `out[l]` holds R_l first, then the running product.
    for l in (1..=start).rev() {
        ratio = 1.0 / ((2 * l + 1) as f64 / kappa + ratio);
        if l < n {
            out[l] = ratio;
        }
    }
    for l in 1..n {
        out[l] *= out[l - 1];
    }
}

/// `A_l(κ)` for `l = 0..out.len()` by the forward recurrence alone, each
/// step clamped to `[0, A_{l−1}]` (the `A_l` fall with `l`): the per-pixel
/// form (no start far above the band). Exact where [`sh_attenuation`] takes
/// the same steps (`κ ≥ 4n² + 16`); below, the steps amplify rounding by
/// `Π (2l+1)/κ` (≈ 3e-9 at κ = 1, n = 9, in f64), and where that exceeds
/// the values (κ ≲ 0.3) the clamps keep them under `A_{l−1}`, itself tiny
/// there (`A_l ≈ κ^l/(2l+1)!!`). Within 1e-6 of [`sh_attenuation`] for
/// `n ≤ 16` (tested).
pub fn sh_attenuation_forward(kappa: f64, out: &mut [f64]) {
    if out.is_empty() {
        return;
    }
    out.fill(0.0);
    out[0] = 1.0;
    if kappa <= 0.0 || out.len() < 2 {
        return;
    }
    out[1] = mean_resultant(kappa);
    let inv = 1.0 / kappa;
    for l in 1..out.len() - 1 {
        let next = out[l - 1] - (2 * l + 1) as f64 * inv * out[l];
        out[l + 1] = next.clamp(0.0, out[l]);
    }
}

/// `[A_0, A_1, A_2](κ)` in f32 for the per-pixel Lambert path: `A_1` as
/// [`mean_resultant`], `A_2 = 1 − 3 A_1/κ` (the first step of the forward
/// recurrence, well conditioned for κ ≥ 0.5), the series `κ²/15 − 2κ⁴/315`
/// below. `1/κ = 0` (`inv_kappa = 0`) is the delta: `[1, 1, 1]`.
#[inline]
#[must_use]
pub fn attenuation_012(inv_kappa: f32) -> [f32; 3] {
    if inv_kappa <= 0.0 {
        return [1.0, 1.0, 1.0];
    }
    let k = 1.0 / inv_kappa;
    if k < 0.5 {
        let k2 = k * k;
        return [
            1.0,
            k / 3.0 - k * k2 / 45.0,
            k2 / 15.0 - 2.0 * k2 * k2 / 315.0,
        ];
    }
    // e^{−2κ} < 5e-18 beyond κ = 20: coth κ is 1 in f32, no `exp` needed.
    let e = if k > 20.0 { 0.0 } else { (-2.0 * k).exp() };
    let a1 = (1.0 + e) / (1.0 - e) - inv_kappa;
    [1.0, a1, 1.0 - 3.0 * a1 * inv_kappa]
}

/// `A_l(κ)` a second way, for tests and `verify`: composite Simpson in
/// `u = κ(1 − μ·n)` of `∫_0^{2κ} e^{−u} P_l(1 − u/κ) du / (1 − e^{−2κ})`
/// (the lobe's Legendre moment), `steps` even.
#[must_use]
pub fn sh_attenuation_quadrature(kappa: f64, l: usize, steps: usize) -> f64 {
    let umax = (2.0 * kappa).min(60.0);
    let n = steps.max(2) / 2 * 2;
    let h = umax / n as f64;
    let f = |u: f64| (-u).exp() * legendre(l, 1.0 - u / kappa);
    let mut s = f(0.0) + f(umax);
    for i in 1..n {
        s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0 / (-(-2.0 * kappa).exp_m1())
}

/// The Legendre polynomial `P_l(t)` (three-term recurrence).
#[must_use]
pub fn legendre(l: usize, t: f64) -> f64 {
    if l == 0 {
        return 1.0;
    }
    let (mut p0, mut p1) = (1.0, t);
    for k in 1..l {
        let p2 = ((2 * k + 1) as f64 * t * p1 - k as f64 * p0) / (k + 1) as f64;
        p0 = p1;
        p1 = p2;
    }
    p1
}

/// A seeded xorshift generator for the Monte Carlo checks.
#[derive(Clone, Debug)]
pub struct Xorshift(pub u64);

impl Xorshift {
    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// One sample of the lobe (Wood 1994: the exact inverse cdf of `w = μ·n`,
/// `w = 1 + ln(u + (1 − u) e^{−2κ})/κ`, uniform azimuth).
#[must_use]
pub fn sample(rng: &mut Xorshift, v: &Vmf) -> glam::DVec3 {
    let u = rng.next_f64();
    let w = (1.0 + (u + (1.0 - u) * (-2.0 * v.kappa).exp()).ln() / v.kappa).clamp(-1.0, 1.0);
    let phi = 2.0 * std::f64::consts::PI * rng.next_f64();
    let s = (1.0 - w * w).max(0.0).sqrt();
    let f = relight_sphere::Frame::from_z(v.mu.as_vec3());
    (f.x.as_dvec3() * (s * phi.cos()) + f.y.as_dvec3() * (s * phi.sin()) + v.mu * w).normalize()
}
