//! Product quadrature rules of the sphere: Gauss–Legendre in `z = cos θ` ×
//! uniform in `φ`. With `N` Legendre nodes and `M` azimuth samples the rule
//! integrates every spherical polynomial of degree `≤ min(2N−1, M−1)` exactly
//! (up to rounding), so it is the oracle for orthonormality, for projecting
//! analytic functions and for the triple-product tensor.

use glam::DVec3;
use std::f64::consts::PI;

/// Nodes `x_k ∈ (−1, 1)` (ascending) and weights `w_k` (summing to 2) of the
/// `n`-point Gauss–Legendre rule, by Newton iteration on `P_n` (f64, error ~1e-15).
#[must_use]
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // Tricomi's initial guess, then Newton.
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let kf = k as f64;
                let p2 = ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
            }
            if n == 1 {
                p0 = 1.0;
                p1 = z;
            }
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        if n == 1 {
            z = 0.0;
            dp = 1.0;
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    if n == 1 {
        w[0] = 2.0;
    }
    (x, w)
}

/// A product rule on the whole sphere: `n_theta` Gauss–Legendre rows ×
/// `n_phi` uniform azimuths, with directions (about +Z) and weights in
/// steradians summing to 4π.
#[derive(Clone, Debug)]
pub struct SphereQuadrature {
    pub n_theta: usize,
    pub n_phi: usize,
    /// `z` nodes of the rows.
    pub z: Vec<f64>,
    /// Unit directions, row-major (`row * n_phi + col`).
    pub dirs: Vec<DVec3>,
    /// Weights (sr), same order.
    pub weights: Vec<f64>,
}

impl SphereQuadrature {
    /// `n_theta × n_phi` product rule; azimuths `φ_j = 2π (j + ½) / n_phi`.
    #[must_use]
    pub fn new(n_theta: usize, n_phi: usize) -> Self {
        let (z, wz) = gauss_legendre(n_theta);
        let mut dirs = Vec::with_capacity(n_theta * n_phi);
        let mut weights = Vec::with_capacity(n_theta * n_phi);
        for (zi, wi) in z.iter().zip(&wz) {
            let s = (1.0 - zi * zi).max(0.0).sqrt();
            for j in 0..n_phi {
                let phi = 2.0 * PI * (j as f64 + 0.5) / n_phi as f64;
                dirs.push(DVec3::new(s * phi.cos(), s * phi.sin(), *zi));
                weights.push(wi * 2.0 * PI / n_phi as f64);
            }
        }
        Self {
            n_theta,
            n_phi,
            z,
            dirs,
            weights,
        }
    }

    /// The smallest rule exact for spherical polynomials of total degree `degree`.
    #[must_use]
    pub fn for_degree(degree: usize) -> Self {
        Self::new(degree / 2 + 1, degree + 1)
    }

    /// Number of nodes.
    #[must_use]
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// Whether the rule has no nodes.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// `∫ f dω` by the rule.
    pub fn integrate(&self, f: impl Fn(DVec3) -> f64) -> f64 {
        self.dirs
            .iter()
            .zip(&self.weights)
            .map(|(d, w)| f(*d) * w)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        for n in 1..12 {
            let (x, w) = gauss_legendre(n);
            for p in 0..2 * n {
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(p as i32)).sum();
                let want = if p % 2 == 1 {
                    0.0
                } else {
                    2.0 / (p as f64 + 1.0)
                };
                assert!((got - want).abs() < 1e-13, "n={n} p={p}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn sphere_rule_area_and_moments() {
        let q = SphereQuadrature::for_degree(6);
        assert!((q.weights.iter().sum::<f64>() - 4.0 * PI).abs() < 1e-12);
        // ∫ x² y² z² dω = 4π/105.
        let got = q.integrate(|d| d.x * d.x * d.y * d.y * d.z * d.z);
        assert!((got - 4.0 * PI / 105.0).abs() < 1e-13, "{got}");
    }
}
