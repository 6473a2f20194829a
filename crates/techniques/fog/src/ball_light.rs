//! How much the environment lights a surface point in the fog ball,
//! against the ball's centre.
//!
//! The thesis' environment model (§3.6.4) lights every surface point as the
//! centre of the medium is: through optical thickness T = βR, plus the
//! light scattered on that way. A point x of the ball at radius r sees the
//! edge nearer on its outward side and farther on its inward side, so a
//! surface facing outward off centre receives more: for a uniform sky at
//! T = 1 and albedo 1, 12 % more at r = 0.3 R, 28 % at 0.6 R, 50 % at
//! 0.9 R (and 7 % less facing inward at 0.3 R).
//!
//! [`BallIrradiance::factor`] is that ratio for a uniform sky: the
//! irradiance at x through a surface of normal n,
//!
//!   E(x, n) = ∫_{H(n)} (e^{−T_d(x, ω)} + a·G_c·g(x, ω)) cos θ dω,
//!
//! against the centre's E_c = π (e^{−T} + a·G_c), with T_d and g the
//! chord weights of the ray from x along ω ([`ChordGlow`]). By the ball's
//! symmetry it depends on r and n·x̂ only, and is tabulated over both
//! ([`FACTOR_TABLE_SIZE`]², bilinear) when the medium changes. Scaling a
//! surface's radiance by it is exact for a Lambertian surface under a
//! uniform sky and keeps the centre's directional structure otherwise
//! (test `factor_matches_the_scattering_integral`).

use crate::view_segment::ChordGlow;
use glam::Vec3;
use relight_render::Medium;

/// Samples of [`BallIrradiance`]'s table per axis (r/R and n·x̂).
pub const FACTOR_TABLE_SIZE: usize = 33;
/// Gauss–Legendre nodes in cos θ, and azimuths, of the hemisphere integral.
const COS_NODES: usize = 16;
const AZIMUTHS: usize = 32;

/// A uniform sky's irradiance at a point of the fog ball against the
/// centre's (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct BallIrradiance {
    radius: f32,
    /// E(x, n) / E_c at (r / R, n·x̂), row-major in n·x̂.
    table: Vec<f32>,
}

impl BallIrradiance {
    /// The factors of `medium` with its chord table `chords` (built for the
    /// same medium). Without a medium (β = 0), every factor is 1.
    #[must_use]
    pub fn new(medium: &Medium, chords: &ChordGlow) -> Self {
        let t = medium.env_thickness();
        if !(t > 0.0 && t.is_finite()) {
            return Self {
                radius: medium.radius,
                table: Vec::new(),
            };
        }
        let a = medium.albedo;
        let scatter = a * chords.centre();
        let centre = std::f32::consts::PI * ((-t).exp() + scatter);
        let (x, w) = relight_sh::quadrature::gauss_legendre(COS_NODES);
        // (cos θ, weight) on [0, 1] and the azimuths' sines and cosines.
        let cos: Vec<(f32, f32)> = x
            .iter()
            .zip(&w)
            .map(|(&x, &w)| ((0.5 * (x + 1.0)) as f32, (0.5 * w) as f32))
            .collect();
        let phi: Vec<(f32, f32)> = (0..AZIMUTHS)
            .map(|k| (std::f32::consts::TAU * (k as f32 + 0.5) / AZIMUTHS as f32).sin_cos())
            .collect();
        let dphi = std::f32::consts::TAU / AZIMUTHS as f32;
        let n = FACTOR_TABLE_SIZE;
        let last = (n - 1) as f32;
        let mut table = Vec::with_capacity(n * n);
        for iy in 0..n {
            let c = -1.0 + 2.0 * iy as f32 / last;
            let normal = Vec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c);
            let (tu, tv) = normal.any_orthonormal_pair();
            for ix in 0..n {
                // Just inside the edge at the last sample.
                let r = medium.radius * (ix as f32 / last).min(1.0 - 1e-4);
                let view = chords.view(Vec3::new(0.0, 0.0, r));
                let mut e = 0.0;
                for &(ct, wt) in &cos {
                    let st = (1.0 - ct * ct).max(0.0).sqrt();
                    for &(sp, cp) in &phi {
                        let dir = normal * ct + (tu * cp + tv * sp) * st;
                        let [direct, glow] = view.weights(dir);
                        e += (direct + scatter * glow) * ct * wt * dphi;
                    }
                }
                table.push(e / centre);
            }
        }
        Self {
            radius: medium.radius,
            table,
        }
    }

    /// E(x, n) / E_c for a surface at `x` (world units) with unit normal
    /// `n`; points outside the ball read its edge. 1 without a medium.
    #[must_use]
    pub fn factor(&self, x: Vec3, n: Vec3) -> f32 {
        self.factor_at(Self::coordinates(x, n))
    }

    /// The table's coordinates of a surface at `x` with unit normal `n`:
    /// `[r, n·x̂]` (r in world units; n·x̂ = 0 at the centre).
    #[must_use]
    pub fn coordinates(x: Vec3, n: Vec3) -> [f32; 2] {
        let r = x.length();
        [r, if r > 0.0 { n.dot(x) / r } else { 0.0 }]
    }

    /// [`Self::factor`] at [`Self::coordinates`] `[r, c]`.
    #[must_use]
    pub fn factor_at(&self, [r, c]: [f32; 2]) -> f32 {
        if self.table.is_empty() {
            return 1.0;
        }
        let size = FACTOR_TABLE_SIZE;
        let last = (size - 1) as f32;
        // max(·, 0) first: NaN reads the first sample.
        let fx = ((r / self.radius) * last).max(0.0).min(last);
        let fy = ((c + 1.0) * 0.5 * last).max(0.0).min(last);
        let (ix, iy) = ((fx as usize).min(size - 2), (fy as usize).min(size - 2));
        let (ax, ay) = (fx - ix as f32, fy - iy as f32);
        let at = |i: usize, k: usize| self.table[k * size + i];
        let lo = at(ix, iy) + (at(ix + 1, iy) - at(ix, iy)) * ax;
        let hi = at(ix, iy + 1) + (at(ix + 1, iy + 1) - at(ix, iy + 1)) * ax;
        lo + (hi - lo) * ay
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table against the irradiance integral taken point by point: the
    /// light arriving at x along each of a Fibonacci sphere's directions
    /// (through the chord, plus what scatters into it on the way, from a
    /// point-by-point in-scatter), cosine-weighted over the hemisphere;
    /// within 2 % at five points, and 1 at the centre.
    #[test]
    fn factor_matches_the_scattering_integral() {
        let medium = Medium {
            beta: 0.1,
            albedo: 1.0,
            radius: 10.0,
        };
        let chords = ChordGlow::new(&medium);
        let factors = BallIrradiance::new(&medium, &chords);
        let dirs = crate::view_segment::fibonacci_sphere(600);
        let edge = |x: Vec3, w: Vec3| {
            let b = x.dot(w);
            -b + (b * b - (x.length_squared() - 100.0)).max(0.0).sqrt()
        };
        let inscatter = |x: Vec3| {
            dirs.iter().map(|&w| (-0.1 * edge(x, w)).exp()).sum::<f32>() / dirs.len() as f32
        };
        let incoming = |x: Vec3, w: Vec3| {
            let te = edge(x, w);
            let steps = 24;
            let h = te / steps as f32;
            let scattered: f32 = (0..steps)
                .map(|j| {
                    let s = (j as f32 + 0.5) * h;
                    0.1 * (-0.1 * s).exp() * inscatter(x + s * w) * h
                })
                .sum();
            (-0.1 * te).exp() + scattered
        };
        let irradiance = |x: Vec3, n: Vec3| {
            dirs.iter()
                .step_by(2)
                .filter(|w| w.dot(n) > 0.0)
                .map(|&w| incoming(x, w) * w.dot(n))
                .sum::<f32>()
                * 4.0
                * std::f32::consts::PI
                / 300.0
        };
        let centre = irradiance(Vec3::ZERO, Vec3::Y);
        assert!((factors.factor(Vec3::ZERO, Vec3::Y) - 1.0).abs() < 2e-3);
        for (x, n) in [
            (Vec3::new(0.0, 0.0, 3.0), Vec3::Z),
            (Vec3::new(0.0, 0.0, 3.0), Vec3::NEG_Z),
            (Vec3::new(0.0, 6.0, 0.0), Vec3::X),
            (
                Vec3::new(4.0, 4.0, 4.0),
                Vec3::new(1.0, 1.0, 1.0).normalize(),
            ),
            (Vec3::new(0.0, -8.5, 0.0), Vec3::new(0.0, -0.6, 0.8)),
        ] {
            let want = irradiance(x, n) / centre;
            let got = factors.factor(x, n);
            assert!(
                (got - want).abs() < 0.02 * want,
                "x {x}, n {n}: table {got} vs point by point {want}"
            );
        }
    }
}
