//! An object's BRDF read as the sum the `ltc` method integrates:
//! `f = k_d/π + GGX(α)` with Schlick Fresnel `F = a + b (1 − ω_o·ĥ)⁵`
//! (per channel `a`, `b`; a plain GGX has `a = F₀`, `b = 1 − F₀`, a
//! mixture `w·ggx` scales both by `w`).
//!
//! The scene holds BRDFs as `dyn Brdf`, so the terms are found by probing:
//! the BRDF is evaluated at fixed direction pairs (normal view with the light
//! at 0…80°, and mirror pairs at 30…80°); for each α on a log grid, refined
//! by golden-section search, `k_d/π`, `a·P` and `b·P·m` are a linear least
//! squares fit per channel (`P = D G₂ / (4 cos θ_o cos θ_i)` of the unit
//! Fresnel GGX). The fit is accepted only when it reproduces the BRDF at
//! other, off-plane probe pairs to within [`PROBE_TOLERANCE`]; any other
//! model (anisotropic, Phong, Ward, measured …) is refused.

use glam::Vec3;
use relight_brdf::Brdf;
use relight_brdf::microfacet::{MIN_ALPHA, ggx_d, smith_g2_height_correlated};

/// Largest relative difference (of the largest channel, against the
/// probe's value plus 10⁻³ of the largest probed value) between the BRDF
/// and the fitted terms at the check probes.
pub const PROBE_TOLERANCE: f32 = 2e-3;

/// The GGX term of [`Lobes`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Specular {
    /// Isotropic GGX roughness α.
    pub alpha: f32,
    /// Fresnel constant part per channel (`F₀` for a plain GGX).
    pub a: Vec3,
    /// Fresnel `(1 − ω_o·ĥ)⁵` part per channel (`1 − F₀`).
    pub b: Vec3,
}

/// A BRDF as diffuse + GGX (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobes {
    /// Diffuse albedo `k_d` (`f_d = k_d/π`).
    pub diffuse: Vec3,
    /// The GGX term, if any.
    pub specular: Option<Specular>,
}

impl Lobes {
    /// `f(ω_o, ω_i)` of these terms (local frame), without the cosine.
    #[must_use]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let mut f = self.diffuse / std::f32::consts::PI;
        if let Some(s) = self.specular {
            let (p, m) = unit_ggx(s.alpha, wo, wi);
            f += (s.a + s.b * m) * p;
        }
        f
    }
}

/// `(D G₂ / (4 cos θ_o cos θ_i), (1 − ω_o·ĥ)⁵)` of the unit-Fresnel GGX.
fn unit_ggx(alpha: f32, wo: Vec3, wi: Vec3) -> (f32, f32) {
    let h = (wo + wi).normalize_or_zero();
    if h == Vec3::ZERO || wo.z <= 0.0 || wi.z <= 0.0 {
        return (0.0, 0.0);
    }
    let d = ggx_d(h, alpha, alpha);
    let g = smith_g2_height_correlated(wo, wi, alpha, alpha);
    let m = (1.0 - wo.dot(h).clamp(0.0, 1.0)).powi(5);
    (d * g / (4.0 * wo.z * wi.z), m)
}

fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// The fitting probes: `(ω_o, ω_i)`.
fn fit_probes() -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::new();
    for t in [0.0, 1.0, 2.5, 5.0, 10.0, 20.0, 35.0, 50.0, 65.0, 80.0] {
        v.push((Vec3::Z, dir(t, 0.0)));
    }
    for t in [30.0, 50.0, 65.0, 75.0, 82.0] {
        v.push((dir(t, 0.0), dir(t, 180.0)));
    }
    v
}

/// The check probes: off-plane pairs the fit did not see.
fn check_probes() -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::new();
    for (to, ti, dphi) in [
        (20.0, 25.0, 150.0),
        (45.0, 40.0, 170.0),
        (60.0, 30.0, 90.0),
        (10.0, 70.0, 200.0),
        (70.0, 68.0, 178.0),
        (35.0, 3.0, 40.0),
        (5.0, 6.0, 180.0),
    ] {
        v.push((dir(to, 10.0), dir(ti, 10.0 + dphi)));
    }
    v
}

/// Least squares of `y ≈ x · basis` (≤ 3 columns) by the normal equations;
/// returns the coefficients and the weighted squared residual.
fn least_squares(rows: &[([f64; 3], f64, f64)], cols: usize) -> ([f64; 3], f64) {
    // rows: (basis, y, weight)
    let mut ata = [[0.0f64; 3]; 3];
    let mut aty = [0.0f64; 3];
    for (b, y, w) in rows {
        for r in 0..cols {
            aty[r] += w * b[r] * y;
            for c in 0..cols {
                ata[r][c] += w * b[r] * b[c];
            }
        }
    }
    // Gaussian elimination with partial pivoting (tiny system).
    let mut a = ata;
    let mut x = aty;
    for k in 0..cols {
        let piv = (k..cols)
            .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
            .unwrap_or(k);
        a.swap(k, piv);
        x.swap(k, piv);
        if a[k][k].abs() < 1e-300 {
            continue;
        }
        for i in k + 1..cols {
            let f = a[i][k] / a[k][k];
            let pivot_row = a[k];
            for (v, p) in a[i][k..cols].iter_mut().zip(&pivot_row[k..cols]) {
                *v -= f * p;
            }
            x[i] -= f * x[k];
        }
    }
    let mut sol = [0.0f64; 3];
    for k in (0..cols).rev() {
        let mut s = x[k];
        for c in k + 1..cols {
            s -= a[k][c] * sol[c];
        }
        sol[k] = if a[k][k].abs() < 1e-300 {
            0.0
        } else {
            s / a[k][k]
        };
    }
    let res = rows
        .iter()
        .map(|(b, y, w)| {
            let p: f64 = (0..cols).map(|c| b[c] * sol[c]).sum();
            w * (p - y).powi(2)
        })
        .sum();
    (sol, res)
}

/// Fits Lambert + GGX terms at roughness `alpha` to `values` at the fit
/// probes; returns the terms and the summed relative residual.
fn fit_at(alpha: f32, probes: &[(Vec3, Vec3)], values: &[Vec3]) -> (Lobes, f64) {
    let mut total = 0.0;
    let mut kd = Vec3::ZERO;
    let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
    for ch in 0..3 {
        let rows: Vec<([f64; 3], f64, f64)> = probes
            .iter()
            .zip(values)
            .map(|((wo, wi), v)| {
                let (p, m) = unit_ggx(alpha, *wo, *wi);
                let y = f64::from(v[ch]);
                let w = 1.0 / (y.abs() + 1e-6).powi(2);
                ([1.0, f64::from(p), f64::from(p * m)], y, w)
            })
            .collect();
        let (sol, res) = least_squares(&rows, 3);
        total += res;
        kd[ch] = (sol[0] * std::f64::consts::PI) as f32;
        a[ch] = sol[1] as f32;
        b[ch] = sol[2] as f32;
    }
    (
        Lobes {
            diffuse: kd,
            specular: Some(Specular { alpha, a, b }),
        },
        total,
    )
}

/// Reads `brdf` as Lambert + isotropic GGX (module docs); `Err(why)` when
/// it is not one, to within [`PROBE_TOLERANCE`].
///
/// # Errors
/// A one-line reason naming the largest mismatch.
pub fn identify(brdf: &dyn Brdf) -> Result<Lobes, String> {
    let probes = fit_probes();
    let values: Vec<Vec3> = probes.iter().map(|(o, i)| brdf.eval(*o, *i)).collect();
    let checks = check_probes();
    let check_values: Vec<Vec3> = checks.iter().map(|(o, i)| brdf.eval(*o, *i)).collect();
    let top = values
        .iter()
        .chain(&check_values)
        .map(|v| v.max_element())
        .fold(0.0f32, f32::max);
    let mismatch = |l: &Lobes| -> f32 {
        probes
            .iter()
            .zip(&values)
            .chain(checks.iter().zip(&check_values))
            .map(|((o, i), v)| {
                let d = (l.eval(*o, *i) - *v).abs().max_element();
                d / (v.max_element() + 1e-3 * top)
            })
            .fold(0.0f32, f32::max)
    };
    // Lambert alone.
    let lambert = Lobes {
        diffuse: values[0] * std::f32::consts::PI,
        specular: None,
    };
    if mismatch(&lambert) <= PROBE_TOLERANCE {
        return Ok(lambert);
    }
    // GGX over log α: a grid, then golden-section search in the best bracket.
    let (lo, hi) = (MIN_ALPHA.ln(), 0.0f32);
    let steps = 120;
    let at = |t: f32| fit_at(t.exp(), &probes, &values).1;
    let grid: Vec<f64> = (0..=steps)
        .map(|k| at(lo + (hi - lo) * k as f32 / steps as f32))
        .collect();
    let k = (0..=steps)
        .min_by(|&i, &j| grid[i].total_cmp(&grid[j]))
        .unwrap_or(0);
    let h = (hi - lo) / steps as f32;
    let (mut x0, mut x1) = (
        (lo + h * (k as f32 - 1.0)).max(lo),
        (lo + h * (k as f32 + 1.0)).min(hi),
    );
    let g = 0.618_034f32;
    for _ in 0..40 {
        let (c, d) = (x1 - g * (x1 - x0), x0 + g * (x1 - x0));
        if at(c) < at(d) {
            x1 = d;
        } else {
            x0 = c;
        }
    }
    let (mut fitted, _) = fit_at((0.5 * (x0 + x1)).exp(), &probes, &values);
    fitted.diffuse = fitted.diffuse.max(Vec3::ZERO);
    let worst = mismatch(&fitted);
    if worst <= PROBE_TOLERANCE {
        Ok(fitted)
    } else {
        Err(format!(
            "it is not Lambert + isotropic GGX (the best such fit, α = {:.4}, misses a probe by {:.1} %)",
            fitted.specular.map_or(0.0, |s| s.alpha),
            100.0 * worst
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_brdf::BrdfSpec;

    fn brdf(spec: &str) -> std::sync::Arc<dyn Brdf> {
        spec.parse::<BrdfSpec>().expect("valid spec").build()
    }

    #[test]
    fn reads_lambert_ggx_and_their_mixture() {
        let l = identify(brdf("lambert:0.7").as_ref()).unwrap();
        assert!(l.specular.is_none() && (l.diffuse - Vec3::splat(0.7)).abs().max_element() < 1e-5);
        for alpha in [0.02f32, 0.2, 0.6, 1.0] {
            let g = identify(brdf(&format!("ggx:{alpha}@1,0.78,0.34")).as_ref()).unwrap();
            let s = g.specular.unwrap();
            assert!(
                (s.alpha / alpha - 1.0).abs() < 1e-2,
                "{} vs {alpha}",
                s.alpha
            );
            assert!(
                (s.a - Vec3::new(1.0, 0.78, 0.34)).abs().max_element() < 1e-2,
                "{s:?}"
            );
            assert!(g.diffuse.max_element() < 1e-3, "{g:?}");
        }
        let m = identify(brdf("0.6*lambert:0.8+0.4*ggx:0.3@0.9,0.9,0.9").as_ref()).unwrap();
        let s = m.specular.unwrap();
        assert!(
            (m.diffuse - Vec3::splat(0.48)).abs().max_element() < 1e-2,
            "{m:?}"
        );
        assert!(
            (s.alpha - 0.3).abs() < 3e-3 && (s.a - Vec3::splat(0.36)).abs().max_element() < 1e-2,
            "{s:?}"
        );
    }

    #[test]
    fn refuses_other_models() {
        for spec in ["phong:40", "ward:0.2", "ggx:0.1,0.4"] {
            assert!(identify(brdf(spec).as_ref()).is_err(), "{spec}");
        }
    }
}
