//! Convolution with zonal (radially symmetric) kernels, and Ramamoorthi–Hanrahan
//! irradiance environment maps.
//!
//! For a kernel `k(ω·n)` symmetric about its axis, the spherical convolution
//! `(k ⋆ f)(n) = ∫ f(ω) k(ω·n) dω` is diagonal in SH (Funk–Hecke):
//! `(k ⋆ f)_{l,m} = Â_l f_{l,m}` with `Â_l = 2π ∫_{−1}^{1} k(t) P_l(t) dt`
//! (`= √(4π/(2l+1)) k_l` for the zonal coefficients `k_l` of the kernel; Sun's
//! thesis eq. 3.34–3.35, Ramamoorthi–Hanrahan 2001). This module gives `Â_l`
//! for:
//!
//! * the clamped cosine `max(t, 0)` — thesis eq. 2.21–2.25: `Â_0 = π`,
//!   `Â_1 = 2π/3`, odd `l > 1`: 0, even `l`:
//!   `2π (−1)^{l/2−1} / ((l+2)(l−1)) · l! / (2^l ((l/2)!)²)`;
//! * normalised power-cosine lobes `c_s max(t,0)^s` by the exact recurrence
//!   `I_l = (s−l+2)/(s+l+1) I_{l−2}`, `I_0 = 1/(s+1)`, `I_1 = 1/(s+2)` for
//!   `I_l = ∫_0^1 t^s P_l(t) dt` (any real `s > −1`): the normalised Phong lobe
//!   `(s+1)/(2π) t^s` (unit integral) and the normalised Blinn–Phong lobe
//!   `(s+2)/(2π) t^s` (unit projected integral `∫ D(h) (n·h) dω_h = 1`);
//! * any kernel `k(t)` by Gauss–Legendre quadrature on `[−1,0]` and `[0,1]`
//!   separately (exact for kernels polynomial on each half, such as clamped lobes).

use crate::project::ShRgb;
use crate::quadrature::gauss_legendre;
use crate::{MAX_ORDER, Real, ShError, check_order};
use glam::{Mat4, Vec3, Vec4};
use std::f64::consts::PI;

/// `Â_l` of the clamped cosine `max(cos θ, 0)` (thesis eq. 2.21–2.23).
#[must_use]
pub fn clamped_cosine_a_hat(l: usize) -> f64 {
    match l {
        0 => PI,
        1 => 2.0 * PI / 3.0,
        _ if l % 2 == 1 => 0.0,
        _ => {
            // l! / (2^l ((l/2)!)²) = C(l, l/2) / 2^l, computed as a running product.
            let h = l / 2;
            let mut binom_over_pow = 1.0f64;
            for k in 1..=h {
                // C(2k, k)/4^k = C(2k−2, k−1)/4^{k−1} · (2k−1)/(2k)
                binom_over_pow *= (2 * k - 1) as f64 / (2 * k) as f64;
            }
            let sign = if (h - 1).is_multiple_of(2) { 1.0 } else { -1.0 };
            2.0 * PI * sign / ((l as f64 + 2.0) * (l as f64 - 1.0)) * binom_over_pow
        }
    }
}

/// `Â_l`, `l < order`, of the clamped cosine.
#[must_use]
pub fn clamped_cosine(order: usize) -> Vec<f64> {
    (0..order).map(clamped_cosine_a_hat).collect()
}

/// `I_l = ∫_0^1 t^s P_l(t) dt` for `l < order` (exact recurrence, any `s > −1`).
fn power_moments(order: usize, s: f64) -> Vec<f64> {
    let mut i = vec![0.0; order];
    for l in 0..order {
        i[l] = match l {
            0 => 1.0 / (s + 1.0),
            1 => 1.0 / (s + 2.0),
            _ => (s - l as f64 + 2.0) / (s + l as f64 + 1.0) * i[l - 2],
        };
    }
    i
}

fn check_exponent(s: f64) -> Result<(), ShError> {
    if s.is_finite() && s >= 0.0 {
        Ok(())
    } else {
        Err(ShError::InvalidParameter {
            what: "exponent",
            why: format!("lobe exponent must be finite and ≥ 0, got {s}"),
        })
    }
}

/// `Â_l` of the normalised Phong lobe `(s+1)/(2π) max(cos θ, 0)^s` (integral 1).
pub fn phong(order: usize, s: f64) -> Result<Vec<f64>, ShError> {
    check_order("order", order, MAX_ORDER)?;
    check_exponent(s)?;
    Ok(power_moments(order, s)
        .into_iter()
        .map(|i| (s + 1.0) * i)
        .collect())
}

/// `Â_l` of the normalised Blinn–Phong lobe `(s+2)/(2π) max(cos θ, 0)^s`
/// (normalised so that `∫ D(h) cos θ_h dω_h = 1`), as a zonal kernel about its axis.
pub fn blinn_phong(order: usize, s: f64) -> Result<Vec<f64>, ShError> {
    check_order("order", order, MAX_ORDER)?;
    check_exponent(s)?;
    Ok(power_moments(order, s)
        .into_iter()
        .map(|i| (s + 2.0) * i)
        .collect())
}

/// `Â_l = 2π ∫_{−1}^{1} k(t) P_l(t) dt` of any radially symmetric kernel `k(cos θ)`,
/// by `nodes`-point Gauss–Legendre on each of `[−1, 0]` and `[0, 1]`.
pub fn zonal_kernel(
    order: usize,
    nodes: usize,
    k: impl Fn(f64) -> f64,
) -> Result<Vec<f64>, ShError> {
    check_order("order", order, MAX_ORDER)?;
    let (x, w) = gauss_legendre(nodes.max(1));
    let mut out = vec![0.0; order];
    for half in [-1.0, 1.0] {
        for (xi, wi) in x.iter().zip(&w) {
            let t = half * 0.5 * (xi + 1.0);
            let kv = k(t) * 0.5 * wi;
            let (mut p0, mut p1) = (1.0, t);
            for (l, o) in out.iter_mut().enumerate() {
                let p = match l {
                    0 => 1.0,
                    1 => t,
                    _ => {
                        let lf = l as f64;
                        let p2 = ((2.0 * lf - 1.0) * t * p1 - (lf - 1.0) * p0) / lf;
                        p0 = p1;
                        p1 = p2;
                        p2
                    }
                };
                *o += 2.0 * PI * kv * p;
            }
        }
    }
    Ok(out)
}

/// The zonal coefficients `k_l = Â_l √((2l+1)/(4π))` (coefficients of `y_{l,0}`),
/// e.g. for [`crate::rotation::rotate_zonal`].
#[must_use]
pub fn zonal_from_a_hat(a_hat: &[f64]) -> Vec<f64> {
    a_hat
        .iter()
        .enumerate()
        .map(|(l, a)| a * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt())
        .collect()
}

/// `c_{l,m} *= Â_l` in place (convolution of the function with the kernel).
///
/// # Panics
/// If `a_hat.len() < order` or `c.len() < order²`.
pub fn convolve<T: Real>(order: usize, a_hat: &[f64], c: &mut [T]) {
    for l in 0..order {
        let a = T::from_f64(a_hat[l]);
        for v in &mut c[l * l..(l + 1) * (l + 1)] {
            *v *= a;
        }
    }
}

/// Convolves all channels of `c` (bands beyond `a_hat.len()` are zeroed).
#[must_use]
pub fn convolve_rgb(c: &ShRgb, a_hat: &[f64]) -> ShRgb {
    let mut out = c.clone();
    let n = out.order;
    let mut a = a_hat.to_vec();
    a.resize(n, 0.0);
    for ch in &mut out.channels {
        convolve(n, &a, ch);
    }
    out
}

/// Irradiance coefficients `E_{l,m} = Â_l L_{l,m}` of the clamped cosine, order 3
/// (the 9-coefficient Ramamoorthi–Hanrahan irradiance environment map).
/// `E(n) = Σ E_{l,m} y_{l,m}(n)` is the irradiance (W·m⁻² if `L` is radiance)
/// at a surface with normal `n`. Divide by π for the outgoing radiance of a
/// white Lambertian surface.
pub fn irradiance(light: &ShRgb) -> Result<ShRgb, ShError> {
    let l3 = light.truncated(3)?;
    Ok(convolve_rgb(&l3, &clamped_cosine(3)))
}

/// The Ramamoorthi–Hanrahan quadratic form: `E(n) = (n,1)ᵀ M (n,1)` per
/// channel, a symmetric 4×4 matrix built from the first 9 coefficients of the
/// lighting (eq. 12 of R–H 2001, with signs adapted to the Condon–Shortley phase:
/// `L_{1,±1}`, `L_{2,±1}` enter negated relative to R–H's table).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradianceQuadratic {
    /// `[r, g, b]` matrices (glam, column-major; symmetric).
    pub m: [Mat4; 3],
}

impl IrradianceQuadratic {
    /// From lighting coefficients (order ≥ 3; the first 9 are used).
    pub fn new(light: &ShRgb) -> Result<Self, ShError> {
        check_order(
            "light.order (irradiance needs ≥ 3 bands)",
            light.order,
            MAX_ORDER,
        )?;
        if light.order < 3 {
            return Err(ShError::OrderOutOfRange {
                what: "light (irradiance needs ≥ 3 bands)",
                order: light.order,
                max: MAX_ORDER,
            });
        }
        const C1: f32 = 0.429_043;
        const C2: f32 = 0.511_664;
        const C3: f32 = 0.743_125;
        const C4: f32 = 0.886_227;
        const C5: f32 = 0.247_708;
        let m = light.channels.clone().map(|l| {
            // R–H names with CS-phase signs folded in.
            let (l00, l1m1, l10, l11) = (l[0], -l[1], l[2], -l[3]);
            let (l2m2, l2m1, l20, l21, l22) = (l[4], -l[5], l[6], -l[7], l[8]);
            Mat4::from_cols(
                Vec4::new(C1 * l22, C1 * l2m2, C1 * l21, C2 * l11),
                Vec4::new(C1 * l2m2, -C1 * l22, C1 * l2m1, C2 * l1m1),
                Vec4::new(C1 * l21, C1 * l2m1, C3 * l20, C2 * l10),
                Vec4::new(C2 * l11, C2 * l1m1, C2 * l10, C4 * l00 - C5 * l20),
            )
        });
        Ok(Self { m })
    }

    /// Irradiance at unit normal `n`, per channel.
    #[must_use]
    pub fn eval(&self, n: Vec3) -> Vec3 {
        let v = n.extend(1.0);
        Vec3::new(
            v.dot(self.m[0] * v),
            v.dot(self.m[1] * v),
            v.dot(self.m[2] * v),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::project::{Window, project_fn};
    use crate::quadrature::SphereQuadrature;
    use glam::DVec3;

    #[test]
    #[allow(clippy::approx_constant)] // the thesis' printed values (eq. 2.24–2.25)
    fn clamped_cosine_matches_thesis_and_quadrature() {
        let want = [3.141593, 2.094395, 0.785398, 0.0, -0.130900, 0.0, 0.049087];
        for (l, w) in want.iter().enumerate() {
            assert!(
                (clamped_cosine_a_hat(l) - w).abs() < 1e-6,
                "Â_{l} = {} vs {w}",
                clamped_cosine_a_hat(l)
            );
        }
        let q = zonal_kernel(12, 16, |t| t.max(0.0)).unwrap();
        for (l, v) in q.iter().enumerate() {
            assert!(
                (v - clamped_cosine_a_hat(l)).abs() < 1e-13,
                "l {l}: quad {v} vs formula {}",
                clamped_cosine_a_hat(l)
            );
        }
    }

    #[test]
    fn lobes_match_quadrature_and_normalisation() {
        for s in [0.0, 1.0, 7.0, 32.0, 2.5] {
            let p = phong(10, s).unwrap();
            let pq = zonal_kernel(10, 60, |t| {
                if t > 0.0 {
                    (s + 1.0) / (2.0 * PI) * t.powf(s)
                } else {
                    0.0
                }
            })
            .unwrap();
            let b = blinn_phong(10, s).unwrap();
            for l in 0..10 {
                assert!(
                    (p[l] - pq[l]).abs() < 1e-10,
                    "phong s={s} l={l}: {} vs {}",
                    p[l],
                    pq[l]
                );
                assert!((b[l] - pq[l] * (s + 2.0) / (s + 1.0)).abs() < 1e-10);
            }
            assert!((p[0] - 1.0).abs() < 1e-14, "Phong lobe integrates to 1");
            assert!(
                (b[1] - 1.0).abs() < 1e-14,
                "Blinn–Phong projected integral is 1"
            );
        }
        assert!(phong(3, -1.0).is_err());
        assert!(phong(0, 1.0).is_err());
    }

    #[test]
    fn irradiance_matches_direct_integration() {
        // Band-limited lighting (order 3) so that E is exact: compare the SH
        // irradiance and the quadratic form with brute-force quadrature of
        // ∫ L(ω) max(n·ω, 0) dω.
        let light = |d: DVec3| {
            1.0 + 0.6 * d.x - 0.3 * d.y + 0.8 * d.z + 0.5 * d.x * d.y - 0.4 * (d.z * d.z)
                + 0.2 * d.y * d.z
        };
        let qh = SphereQuadrature::for_degree(6);
        let c = project_fn(3, &qh, light);
        let cf: Vec<f32> = c.iter().map(|&v| v as f32).collect();
        let sh = ShRgb::try_from_channels(3, [cf.clone(), cf.clone(), cf]).unwrap();
        let e = irradiance(&sh).unwrap();
        let quad = IrradianceQuadratic::new(&sh).unwrap();
        let fine = SphereQuadrature::new(400, 800);
        for n in [
            DVec3::Z,
            DVec3::new(0.3, -0.7, 0.2).normalize(),
            DVec3::new(-1.0, 0.2, -0.4).normalize(),
        ] {
            let want = fine.integrate(|w| light(w) * w.dot(n).max(0.0));
            let got = e.eval(n.as_vec3()).x as f64;
            let got_q = quad.eval(n.as_vec3()).y as f64;
            assert!(
                (got - want).abs() < 2e-3 * want.abs().max(1.0),
                "n={n}: SH {got} vs quadrature {want}"
            );
            assert!(
                (got_q - got).abs() < 1e-4 * got.abs().max(1.0),
                "n={n}: quadratic form {got_q} vs SH {got}"
            );
        }
        assert_eq!(e.window, Window::None);
    }
}
