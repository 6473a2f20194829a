//! The view mask of a Lambert NDF under one light, from the NDF's first two
//! moments; and under environment light, the part of the NDF that faces the
//! viewer ([`seen_sh9`], its model in its own docs).
//!
//! # The problem
//! A pixel shades `∫ γ(n) max(0, n·ω_i) H(n·ω_o) dn / π`: a normal turned
//! away from the viewer shades zero (the project's convention, which the
//! reference renderer shares). The mask `H(n·ω_o)` is not a function of
//! `n·ω_i`, so eq. 5.7's product per SH band does not hold it, and the
//! first form ([`crate::effective::lambert_sh_dir_seen`] before this
//! module) took the irradiance times the masked share of the NDF,
//! `E[max(0, n·ω_i)] · P(n·ω_o > 0)`. Where light and view are on the same
//! side (the screen scenes' light is behind the eye) the normals the
//! viewer loses are the ones the light misses too, and the product
//! undercounts. It was most of the SH Lambert error under a point light
//! (figures: `docs/ndf.md`, "The view mask").
//!
//! # The model
//! Bands 0–2 of an SH NDF hold its mean `m = E[n]` and second moment
//! `S = E[n nᵀ]` exactly ([`ShMoments`]). Taking `(X, Y) = (n·ω_i, n·ω_o)`
//! as bivariate normal with those moments (means `m·ω`, covariances
//! `ωᵀ(S − m mᵀ)ω′`), the share of the irradiance the viewer sees is
//!
//! `R = E[X⁺ 1(Y > 0)] / E[X⁺]`
//!
//! in closed form (Tallis 1961, with `h = μ/σ` and correlation ρ):
//! `E[X⁺]/σ_X = h_x Φ(h_x) + φ(h_x)` and
//! `E[X⁺ 1(Y>0)]/σ_X = h_x Φ₂(h_x, h_y; ρ) + φ(h_x) Φ((h_y − ρh_x)/√(1−ρ²))
//! + ρ φ(h_y) Φ((h_x − ρh_y)/√(1−ρ²))`. `R` depends on `(h_x, h_y, ρ)`
//! alone; [`mask_share`] reads it from a table built once from that form
//! ([`mask_share_exact`], `Φ₂` by Gauss–Legendre quadrature of
//! Drezner & Wesolowsky's integral over `asin ρ`). The shading is then the
//! irradiance of [`crate::effective::lambert_sh_dir`] (exact bands 0–2
//! plus the mean-normal tail) times `R`. A delta (level 0, σ = 0) gives
//! `R = H(n·ω_o)`, plain normal mapping's mask, exactly.
//!
//! Checked a second way: the closed form against direct quadrature of the
//! bivariate normal, the table against the closed form, and [`ShMoments`]
//! against sums over the normals an NDF was built from (tests in
//! `tests/it/mask.rs`).

use glam::Vec3;
use rayon::prelude::*;
use relight_sh::quadrature::{SphereQuadrature, gauss_legendre};
use std::f64::consts::{PI, SQRT_2};

/// The standard normal density.
fn phi(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * PI).sqrt()
}

/// The standard normal cdf, `erfc` by Numerical Recipes' Chebyshev form
/// (relative error < 1.2e-7 everywhere).
fn cdf(x: f64) -> f64 {
    let z = x.abs() / SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    if x >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

/// `Φ₂(a, b; ρ) = P(U < a, V < b)` for standard normals of correlation
/// `ρ ∈ (−1, 1)`: `Φ(a)Φ(b) + (1/2π) ∫_0^{asin ρ} exp(−(a² + b² − 2ab sin θ)
/// / (2 cos² θ)) dθ` (Drezner & Wesolowsky 1990), by 64-point
/// Gauss–Legendre quadrature.
#[must_use]
pub fn bivariate_normal_cdf(a: f64, b: f64, rho: f64) -> f64 {
    static NODES: std::sync::OnceLock<(Vec<f64>, Vec<f64>)> = std::sync::OnceLock::new();
    let (xs, ws) = NODES.get_or_init(|| gauss_legendre(64));
    let top = rho.clamp(-1.0, 1.0).asin();
    let half = 0.5 * top;
    let mut s = 0.0;
    for (&x, &w) in xs.iter().zip(ws) {
        let th = half * (1.0 + x);
        let c2 = th.cos().powi(2);
        if c2 > 0.0 {
            s += w * (-(a * a + b * b - 2.0 * a * b * th.sin()) / (2.0 * c2)).exp();
        }
    }
    cdf(a) * cdf(b) + s * half / (2.0 * PI)
}

/// `R(h_x, h_y, ρ) = E[X⁺ 1(Y>0)] / E[X⁺]` for bivariate normal `(X, Y)`
/// with `h = μ/σ` and correlation `ρ` (module docs), in closed form;
/// `h = ±∞` are the limits. `ρ` is clamped to `±(1 − 1e-9)`.
#[must_use]
pub fn mask_share_exact(hx: f64, hy: f64, rho: f64) -> f64 {
    if hy == f64::INFINITY {
        return 1.0;
    }
    if hy == f64::NEG_INFINITY {
        return 0.0;
    }
    if hx == f64::INFINITY {
        return cdf(hy);
    }
    let rho = rho.clamp(-1.0 + 1e-9, 1.0 - 1e-9);
    let q = (1.0 - rho * rho).sqrt();
    let hx = hx.max(-30.0);
    let den = hx * cdf(hx) + phi(hx);
    let num = hx * bivariate_normal_cdf(hx, hy, rho)
        + phi(hx) * cdf((hy - rho * hx) / q)
        + rho * phi(hy) * cdf((hx - rho * hy) / q);
    if den <= 1e-300 {
        // X > 0 only in a vanishing tail: the limit at X = 0⁺, where Y | X
        // has mean μ_Y + ρ σ_Y (−h_x) in units of σ_Y.
        return cdf((hy - rho * hx) / q);
    }
    (num / den).clamp(0.0, 1.0)
}

/// Nodes per axis of [`mask_share`]'s table over the compressed
/// coordinates `s = h/(1 + |h|) ∈ [−1, 1]` (both ends are `h = ±∞`). In
/// `s` the approach to `h_x = ∞`, `R ≈ Φ(h_y) + ρ φ(h_y)/h_x`, is linear,
/// which linear interpolation follows (with `h/√(1 + h²)` it was a square
/// root, off by 0.02 next to the end).
const H_NODES: usize = 65;
/// Nodes over `ρ ∈ [−1, 1]`.
const RHO_NODES: usize = 33;

/// [`mask_share_exact`] at compressed coordinates `s_x, s_y ∈ [−1, 1]`
/// (`h = s/(1 − |s|)`) and `ρ ∈ [−1, 1]`, by trilinear interpolation in
/// a table built once (`65 × 65 × 33` f32, 560 KB). Callers pass
/// `s = μ/(|μ| + σ)`, finite where σ = 0 (a delta: `s = ±1`, where the
/// table holds the exact step `R ∈ {0, 1}` along `s_y`).
#[inline]
#[must_use]
pub fn mask_share(sx: f32, sy: f32, rho: f32) -> f32 {
    let t = table();
    let cell = |v: f32, n: usize| {
        let x = ((v.clamp(-1.0, 1.0) + 1.0) * 0.5 * (n - 1) as f32).min((n - 1) as f32);
        let i = (x as usize).min(n - 2);
        (i, x - i as f32)
    };
    let (i, fx) = cell(sx, H_NODES);
    let (j, fy) = cell(sy, H_NODES);
    let (k, fz) = cell(if rho.is_nan() { 0.0 } else { rho }, RHO_NODES);
    let at = |i: usize, j: usize, k: usize| t[(k * H_NODES + j) * H_NODES + i];
    let bilerp = |k: usize| {
        let a = at(i, j, k) + fx * (at(i + 1, j, k) - at(i, j, k));
        let b = at(i, j + 1, k) + fx * (at(i + 1, j + 1, k) - at(i, j + 1, k));
        a + fy * (b - a)
    };
    let (lo, hi) = (bilerp(k), bilerp(k + 1));
    lo + fz * (hi - lo)
}

/// Builds [`mask_share`]'s table now if it is not built yet (about 9·10⁶
/// exponentials, in parallel): for a caller that would rather not pay it
/// inside its first frame.
pub fn warm() {
    let _ = table();
}

/// [`mask_share`]'s table, `[ρ][s_y][s_x]`, built once.
fn table() -> &'static [f32] {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let h = |i: usize| {
            let s = -1.0 + 2.0 * i as f64 / (H_NODES - 1) as f64;
            if s >= 1.0 {
                f64::INFINITY
            } else if s <= -1.0 {
                f64::NEG_INFINITY
            } else {
                s / (1.0 - s.abs())
            }
        };
        (0..RHO_NODES * H_NODES * H_NODES)
            .into_par_iter()
            .map(|idx| {
                let (i, j, k) = (
                    idx % H_NODES,
                    (idx / H_NODES) % H_NODES,
                    idx / (H_NODES * H_NODES),
                );
                let rho = -1.0 + 2.0 * k as f64 / (RHO_NODES - 1) as f64;
                mask_share_exact(h(i), h(j), rho) as f32
            })
            .collect()
    })
}

/// Mean and covariance of an NDF, read from its SH bands 0–2 (module
/// docs): `m = E[n]`, `C = E[n nᵀ] − m mᵀ` (symmetric, stored as
/// `xx, yy, zz, xy, xz, yz`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShMoments {
    /// `E[n]` (length ≤ 1).
    pub mean: Vec3,
    /// `Cov[n]` as `[xx, yy, zz, xy, xz, yz]`.
    pub cov: [f32; 6],
}

impl ShMoments {
    /// The moments of the NDF whose first 9 SH coefficients are `gamma`:
    /// `E[p(n)] = Σ_i γ_i ∫ p y_i` for the quadratic monomials `p`, whose
    /// projections onto bands 0–2 are computed once (convention-free, as
    /// [`crate::effective::mean_normal_of_sh`]'s band-1 axes).
    #[inline(always)]
    #[must_use]
    pub fn of_sh(gamma: &[f32]) -> Self {
        let p = monomial_projections();
        let mean = crate::effective::mean_normal_of_sh(gamma);
        // Bands 0 and 2 only (band 1 of an even monomial is zero), and of
        // those the entries of `PROJ_TERMS`, written out (the lanes of
        // `crate::seen_lanes` compute the same f32 operations).
        let g = gamma;
        let second = [
            g[0] * p[0][0] + g[6] * p[0][6] + g[8] * p[0][8],
            g[0] * p[1][0] + g[6] * p[1][6] + g[8] * p[1][8],
            g[0] * p[2][0] + g[6] * p[2][6],
            g[4] * p[3][4],
            g[7] * p[4][7],
            g[5] * p[5][5],
        ];
        let m = mean;
        Self {
            mean,
            cov: [
                second[0] - m.x * m.x,
                second[1] - m.y * m.y,
                second[2] - m.z * m.z,
                second[3] - m.x * m.y,
                second[4] - m.x * m.z,
                second[5] - m.y * m.z,
            ],
        }
    }

    /// `aᵀ C b`.
    #[inline]
    #[must_use]
    pub fn cov_form(&self, a: Vec3, b: Vec3) -> f32 {
        let c = &self.cov;
        a.x * (c[0] * b.x + c[3] * b.y + c[4] * b.z)
            + a.y * (c[3] * b.x + c[1] * b.y + c[5] * b.z)
            + a.z * (c[4] * b.x + c[5] * b.y + c[2] * b.z)
    }

    /// `R` of the module docs for light `wi` and view `wo`: the share of
    /// the irradiance from `wi` that falls on normals facing `wo`.
    #[inline]
    #[must_use]
    pub fn seen_share(&self, wo: Vec3, wi: Vec3) -> f32 {
        seen_share_of(
            self.mean.dot(wi),
            self.mean.dot(wo),
            self.cov_form(wi, wi),
            self.cov_form(wo, wo),
            self.cov_form(wi, wo),
        )
    }
}

/// `R` for one vMF lobe of axis `mu` and `1/κ` (`0`: a delta, the step
/// `μ·ω_o > 0`), from its moments `E[n] = Aμ`, `Cov[n] = (A/κ) I +
/// (1 − 3A/κ − A²) μμᵀ` (`A = A(κ)`): the mask
/// [`crate::effective::shade_lobe`] gives Lambert, where the lobe's
/// visible share `P(n·ω_o > 0)` alone
/// ([`crate::effective::visible_fraction`], `R` at ρ = 0) took the mask
/// and the light as independent.
#[inline]
#[must_use]
pub fn lobe_seen_share(mu: Vec3, inv_kappa: f32, wo: Vec3, wi: Vec3) -> f32 {
    let (ti, to) = (mu.dot(wi), mu.dot(wo));
    if inv_kappa <= 0.0 {
        return if to > 0.0 { 1.0 } else { 0.0 };
    }
    let a = crate::vmf::attenuation_012(inv_kappa)[1];
    let iso = a * inv_kappa;
    let along = 1.0 - 3.0 * iso - a * a;
    seen_share_of(
        a * ti,
        a * to,
        iso + along * ti * ti,
        iso + along * to * to,
        iso * wi.dot(wo) + along * ti * to,
    )
}

/// `R` from the means and (co)variances of `X = n·ω_i`, `Y = n·ω_o`.
#[inline]
fn seen_share_of(mx: f32, my: f32, vx: f32, vy: f32, c: f32) -> f32 {
    let (vx, vy) = (vx.max(0.0), vy.max(0.0));
    // `s = μ/(|μ| + σ)`: ±1 for a delta.
    let compress = |m: f32, v: f32| {
        let d = m.abs() + v.sqrt();
        if d > 0.0 { m / d } else { 0.0 }
    };
    let vv = vx * vy;
    let rho = if vv > 0.0 { c / vv.sqrt() } else { 0.0 };
    mask_share(compress(mx, vx), compress(my, vy), rho)
}

/// Bands 0–2 of the part of an NDF that faces the viewer, `γ'_i = ∫ y_i(n)
/// γ(n) H(n·ω_o) dn`, and that part's share `P(n·ω_o > 0)`: the environment
/// light's view mask. Under environment light a pixel shades
/// `Σ_i γ'_i lit_i` (eq. 5.7 with the seen NDF), the mask of plain normal
/// mapping carried to a footprint.
///
/// # The model
/// `y_i(n) = b_i·n + nᵀ A_i n` on the unit sphere (bands 0–2 are quadratic;
/// the constant folded in as `c |n|²`), so `γ'_i = b_i·E[n H] + tr(A_i E[n nᵀ
/// H])`. With `n` normal of the NDF's mean `m` and covariance `C`
/// ([`ShMoments`]), `t = n·ω_o ~ N(μ, s²)`, `α = μ/s`, `g = C ω_o / s`:
/// `E[H] = Φ(α)`, `E[n H] = m Φ + g φ`, `E[n nᵀ H] = (C + m mᵀ) Φ + (m gᵀ +
/// g mᵀ) φ − g gᵀ α φ` (the truncated normal's moments: `n = m + g u + r`,
/// `u` standard normal, `r` independent of `u`). Where every normal faces
/// the viewer (`Φ = 1, φ = 0`) this is `γ` itself (to rounding); a delta
/// (`s → 0`) gives `γ·H(m·ω_o)`, plain normal mapping's mask. Tested against
/// sums over normals in `tests/it/mask.rs`.
#[inline(always)]
#[must_use]
pub fn seen_sh9(gamma: &[f32], wo: Vec3) -> ([f32; 9], f32) {
    seen_sh9_with(&ShMoments::of_sh(gamma), wo)
}

/// [`seen_sh9`] with the NDF's moments already taken
/// (`ShMoments::of_sh(gamma)`): [`seen_moments`], then
/// [`sh9_of_seen_moments`].
#[inline(always)]
#[must_use]
pub fn seen_sh9_with(mom: &ShMoments, wo: Vec3) -> ([f32; 9], f32) {
    let (e, share) = seen_moments(mom, wo);
    (sh9_of_seen_moments(&e), share)
}

/// The moments of the part of an NDF (of moments `mom`) that faces `wo`
/// ([`seen_sh9`]'s model): `E[n H]` (x y z) then `E[n nᵀ H]` (xx, yy, zz,
/// xy, xz, yz), and the share `E[H]`. Linear in the seen part, so a
/// footprint's probes average them before [`sh9_of_seen_moments`]. Where
/// every normal faces the viewer (a delta in front, or `α > 6`) they are
/// the NDF's own `(m, C + m mᵀ)`, and zero where none does.
#[inline(always)]
#[must_use]
pub fn seen_moments(mom: &ShMoments, wo: Vec3) -> ([f32; 9], f32) {
    let m = mom.mean;
    let c = &mom.cov;
    let mu = m.dot(wo);
    // `C ω_o`, whose dot with ω_o is `cov_form(ω_o, ω_o)`.
    let cw = Vec3::new(
        c[0] * wo.x + c[3] * wo.y + c[4] * wo.z,
        c[3] * wo.x + c[1] * wo.y + c[5] * wo.z,
        c[4] * wo.x + c[5] * wo.y + c[2] * wo.z,
    );
    let s2 = wo.x * cw.x + wo.y * cw.y + wo.z * cw.z;
    let whole = |front: bool| {
        if front {
            (
                [
                    m.x,
                    m.y,
                    m.z,
                    c[0] + m.x * m.x,
                    c[1] + m.y * m.y,
                    c[2] + m.z * m.z,
                    c[3] + m.x * m.y,
                    c[4] + m.x * m.z,
                    c[5] + m.y * m.z,
                ],
                1.0,
            )
        } else {
            ([0.0; 9], 0.0)
        }
    };
    // A delta, or a spread too small for f32 moments to resolve.
    if s2 <= 1e-10 {
        return whole(mu > 0.0);
    }
    // One division: `1/s` scales `μ` and `C ω_o`.
    let inv_s = 1.0 / s2.sqrt();
    let alpha = mu * inv_s;
    // Beyond 6σ the share is 1 or 0 to 1e-9: the NDF itself, or nothing
    // (most pixels of a view that is not grazing).
    if alpha.abs() > 6.0 {
        return whole(alpha > 0.0);
    }
    let (cdf_a, pdf_a) = crate::effective::normal_cdf_pdf(alpha);
    let g = cw * inv_s;
    // E[n nᵀ H] as [xx, yy, zz, xy, xz, yz].
    let second = |i: usize, j: usize, cij: f32| {
        (cij + m[i] * m[j]) * cdf_a + (m[i] * g[j] + g[i] * m[j]) * pdf_a
            - g[i] * g[j] * alpha * pdf_a
    };
    (
        [
            m.x * cdf_a + g.x * pdf_a,
            m.y * cdf_a + g.y * pdf_a,
            m.z * cdf_a + g.z * pdf_a,
            second(0, 0, c[0]),
            second(1, 1, c[1]),
            second(2, 2, c[2]),
            second(0, 1, c[3]),
            second(0, 2, c[4]),
            second(1, 2, c[5]),
        ],
        cdf_a,
    )
}

/// Bands 0–2 of a seen part from its [`seen_moments`]: `γ'_i = b_i·E[n H] +
/// tr(A_i E[n nᵀ H])` ([`seen_sh9`]'s model).
#[inline(always)]
#[must_use]
pub fn sh9_of_seen_moments(e: &[f32; 9]) -> [f32; 9] {
    // The entries of `QUAD_TERMS`, written out.
    let q = quadratic_forms();
    [
        e[3] * q[0][3] + e[4] * q[0][4] + e[5] * q[0][5],
        e[1] * q[1][1],
        e[2] * q[2][2],
        e[0] * q[3][0],
        e[6] * q[4][6],
        e[8] * q[5][8],
        e[3] * q[6][3] + e[4] * q[6][4] + e[5] * q[6][5],
        e[7] * q[7][7],
        e[3] * q[8][3] + e[4] * q[8][4],
    ]
}

/// The entries of each row of [`monomial_projections`] (xx, yy, zz, xy,
/// xz, yz) that symmetry leaves non-zero: band 0 and `Y_20`, `Y_22` for the
/// squares (`zz` has no `Y_22`), one band-2 function for each product.
/// The others are zero but for quadrature noise below 1e-7 (the test that
/// reads this list), and [`ShMoments::of_sh`] and [`crate::seen_lanes`]
/// read only these, written out: about a fifth of the mask's operations
/// were multiplies by those zeros.
#[cfg(test)]
const PROJ_TERMS: [&[usize]; 6] = [&[0, 6, 8], &[0, 6, 8], &[0, 6], &[4], &[7], &[5]];

/// The entries of each row of [`quadratic_forms`] that are not zero
/// (below 1e-7 in the others, tested), in order: `y_0` from the trace,
/// band 1 from the mean, band 2 from the second moments; what
/// [`sh9_of_seen_moments`] and [`crate::seen_lanes`] read.
#[cfg(test)]
const QUAD_TERMS: [&[usize]; 9] = [
    &[3, 4, 5],
    &[1],
    &[2],
    &[0],
    &[6],
    &[8],
    &[3, 4, 5],
    &[7],
    &[3, 4],
];

/// `y_i(n) = b·n + nᵀ A n` on the unit sphere for `i < 9`, as
/// `[b_x, b_y, b_z, A_xx, A_yy, A_zz, 2A_xy, 2A_xz, 2A_yz]`: from `y_i` at
/// `±` the axes (`b_k = (y(e_k) − y(−e_k))/2`, `A_kk = (y(e_k) + y(−e_k))/2`)
/// and at `±(e_j + e_k)/√2` (whose even part is `(A_jj + A_kk)/2 + A_jk`),
/// so convention-free, computed once.
pub(crate) fn quadratic_forms() -> &'static [[f32; 9]; 9] {
    static Q: std::sync::OnceLock<[[f32; 9]; 9]> = std::sync::OnceLock::new();
    Q.get_or_init(|| {
        let y = |d: Vec3| {
            let mut v = [0.0f32; 9];
            relight_sh::eval_sh_into(3, d.normalize().to_array(), &mut v);
            v.map(f64::from)
        };
        let axes = [Vec3::X, Vec3::Y, Vec3::Z];
        let (plus, minus) = (axes.map(y), axes.map(|a| y(-a)));
        let pairs = [(0, 1), (0, 2), (1, 2)];
        let diag = pairs.map(|(j, k)| {
            let (p, q) = (y(axes[j] + axes[k]), y(-(axes[j] + axes[k])));
            std::array::from_fn::<f64, 9, _>(|i| 0.5 * (p[i] + q[i]))
        });
        std::array::from_fn(|i| {
            let b = [0, 1, 2].map(|k| 0.5 * (plus[k][i] - minus[k][i]));
            let a = [0, 1, 2].map(|k| 0.5 * (plus[k][i] + minus[k][i]));
            // Even part at (e_j + e_k)/√2: (A_jj + A_kk)/2 + A_jk.
            let off = [0, 1, 2].map(|p| {
                let (j, k) = pairs[p];
                2.0 * (diag[p][i] - 0.5 * (a[j] + a[k]))
            });
            [b[0], b[1], b[2], a[0], a[1], a[2], off[0], off[1], off[2]].map(|v| v as f32)
        })
    })
}

/// `∫ p_j(n) y_i(n) dn` for `p = xx, yy, zz, xy, xz, yz` and `i < 9`,
/// exact (a product rule exact to degree 4), computed once.
pub(crate) fn monomial_projections() -> &'static [[f32; 9]; 6] {
    static P: std::sync::OnceLock<[[f32; 9]; 6]> = std::sync::OnceLock::new();
    P.get_or_init(|| {
        let rule = SphereQuadrature::for_degree(4);
        let mut acc = [[0.0f64; 9]; 6];
        for (d, w) in rule.dirs.iter().zip(&rule.weights) {
            let mut y = [0.0f32; 9];
            relight_sh::eval_sh_into(3, d.as_vec3().to_array(), &mut y);
            let p = [
                d.x * d.x,
                d.y * d.y,
                d.z * d.z,
                d.x * d.y,
                d.x * d.z,
                d.y * d.z,
            ];
            for (a, pj) in acc.iter_mut().zip(p) {
                for (ai, yi) in a.iter_mut().zip(y) {
                    *ai += pj * f64::from(yi) * w;
                }
            }
        }
        acc.map(|row| row.map(|v| v as f32))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The entries the sparse products skip are zero: quadrature noise below
    /// 1e-7 in the two tables, exactly zero at the axes.
    #[test]
    fn skipped_table_entries_are_zero() {
        let skipped = |rows: &[[f32; 9]], terms: &[&[usize]]| {
            rows.iter()
                .zip(terms)
                .flat_map(|(r, t)| (0..9).filter(|i| !t.contains(i)).map(|i| r[i].abs()))
                .fold(0.0f32, f32::max)
        };
        assert!(skipped(monomial_projections(), &PROJ_TERMS) < 1e-7);
        assert!(skipped(quadratic_forms(), &QUAD_TERMS) < 1e-7);
        // And the kept ones are not (each carries a lobe of the result).
        for (rows, terms) in [
            (&monomial_projections()[..], &PROJ_TERMS[..]),
            (&quadratic_forms()[..], &QUAD_TERMS[..]),
        ] {
            for (r, t) in rows.iter().zip(terms) {
                assert!(t.iter().all(|&i| r[i].abs() > 0.1), "{r:?} {t:?}");
            }
        }
        let axes = crate::effective::band1_axes();
        for (row, (_, j)) in axes.iter().zip(crate::effective::AXIS_TERMS) {
            for (k, v) in row.iter().enumerate() {
                assert_eq!(*v == 0.0, k != j, "{axes:?}");
            }
        }
        // Band 1 is y, z, x: γ index 1 + the row entry.
        for (i, j) in crate::effective::AXIS_TERMS {
            assert_eq!(i, j + 1);
        }
    }
}
