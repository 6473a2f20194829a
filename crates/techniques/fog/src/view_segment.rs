//! The view ray's segment inside the fog ball, from an eye anywhere.
//!
//! The analytic model (Sun 2008, eq. 3.29) assumes the medium fills the
//! space between the eye and the point it sees. The scene's medium
//! ([`relight_render::Medium`]) is a ball of radius R about the origin with
//! vacuum outside, and the lights and surfaces lie inside it. Along a view
//! ray `eye + t·d` the medium is the span `[t_in, t_out]`
//! ([`relight_render::Medium::ball_span`]): `t_in = 0` with the eye inside,
//! the entry distance with the eye outside.
//!
//! # Point lights: the model from the ball's edge
//! Write M(t) = e^{−βt} L_p + A(t) for the model to a surface at distance t
//! in an unbounded medium (eq. 3.29) and A(t) = ∫₀ᵗ β e^{−βs} L_in(s) ds for
//! its airlight alone (a black surface at t). With vacuum on `[0, t_in)`
//! the pixel is
//!
//!   L = e^{−β(t_s − t_in)} L_p + ∫_{t_in}^{t_s} β e^{−β(s − t_in)} L_in(s) ds
//!     = e^{β t_in} (M(t_s) − A(t_in)),
//!
//! exact because the in-scattered radiance L_in(s) at a point of the
//! segment is the same in both media: the light and the point are inside
//! the convex ball, so the light's way to it is too. Both terms are the
//! model the renderer already evaluates from the real eye (the same
//! per-light tables, the same lanes), so the eye outside costs one more
//! airlight evaluation per covered sample and nothing with the eye inside.
//! The two terms share the eye's tail L∞(eye) bit for bit (one γ, one
//! table read), so it cancels exactly; what is left, e^{−β t_in} L∞(p_in) −
//! e^{−β t_s} L∞(p), is what a per-pixel eye at the entry point would give.
//! An empty pixel's ray is the same with a black surface at `t_out`, and a
//! ray that misses the ball sees no medium: black.
//!
//! # The environment: the chord's thickness
//! An empty pixel shows the environment through the optical thickness
//! T_d = β (t_out − t_in) of its ray's chord, not the centre's T = βR: the
//! direct part is e^{−T_d} L(d) and the single-scattered glow is the
//! centre's, rescaled by how much of a uniform sky the chord scatters
//! against the centre's view ([`ChordGlow`]).
//! A covered pixel's view segment runs from `t_in` to the surface, and
//! what it scatters is read from the same table ([`ChordGlow::segment`]).

use crate::FogError;
use glam::Vec3;
use relight_render::Medium;

/// The farthest the eye may be from the ball, in mean free paths
/// β (|eye| − R): the model's terms carry e^{−β t_in} and the pixel
/// e^{β t_in}, and beyond about 87 they leave f32's range. At 40 the ball
/// of the scene's medium is a speck (with β R = 1, under 3° across).
pub const MAX_EYE_DEPTH: f32 = 40.0;

/// Refuses an eye farther than [`MAX_EYE_DEPTH`] mean free paths from a
/// fog ball of `radius` and extinction `beta`.
///
/// # Errors
/// [`FogError::EyeFarOutsideBall`].
pub fn check_eye(eye: Vec3, beta: f32, radius: f32) -> Result<(), FogError> {
    let depth = beta * (eye.length() - radius);
    if depth > MAX_EYE_DEPTH {
        return Err(FogError::EyeFarOutsideBall { eye, radius, depth });
    }
    Ok(())
}

/// Where the medium starts along the view ray `eye + t·d` (d unit), clamped
/// to `[0, t_surface]`: 0 with the eye inside the ball, the ball's entry
/// with it outside, `t_surface` where the ray reaches the surface first or
/// misses the ball.
#[must_use]
pub fn medium_start(medium: &Medium, eye: Vec3, d: Vec3, t_surface: f32) -> f32 {
    medium
        .ball_span(eye, d)
        .map_or(t_surface, |(t_in, _)| t_in.min(t_surface))
        .max(0.0)
}

/// Radii of [`ChordGlow`]'s in-scatter profile J(r), r ∈ [0, R].
pub const CHORD_PROFILE_SAMPLES: usize = 257;
/// Side of [`ChordGlow`]'s chord table (impact parameter × start; odd,
/// so the centre's own chord, σ = ½, is a grid row).
pub const CHORD_TABLE_SIZE: usize = 65;
/// Gauss–Legendre nodes of the integrals behind [`ChordGlow`].
const CHORD_NODES: usize = 32;

/// An empty pixel's environment weights along its chord through the fog
/// ball: `direct · L(d) + glow · G(d)` with G the centre's single-scattered
/// glow (the ball kernel's, [`crate::psf::ball_convolution_weights`]).
///
/// # The model
/// In units β = 1 (ball radius T = βR), a point at radius r receives the
/// fraction
///
///   J(r) = ½ ∫₋₁¹ e^{−(√(T² − r²(1 − μ²)) − rμ)} dμ
///
/// of a uniform sky's radiance after its way in from the edge, so a view
/// ray's chord from u₀ to its exit h (coordinates along the ray's line,
/// from its closest point to the centre at distance p; h = √(T² − p²))
/// scatters
///
///   G(p, u₀) = ∫_{u₀}^{h} e^{−(u − u₀)} J(√(p² + u²)) du
///
/// of it into the eye, against G_c = ∫₀^T e^{−s} J(s) ds from the centre
/// (which equals the ball kernel's w₀). The glow weight is G / G_c: exact
/// for a uniform sky from any eye, inside or outside the ball; the
/// environment's directional structure is the centre's. The direct
/// weight is e^{−(h − u₀)}. G is tabulated over p/T and the start's place
/// on the chord ([`CHORD_TABLE_SIZE`]², bilinear), built when the medium
/// changes.
#[derive(Clone, Debug, PartialEq)]
pub struct ChordGlow {
    beta: f32,
    /// T = βR.
    t: f32,
    /// G_c.
    centre: f32,
    /// G / G_c at (a = p/T, σ = (u₀ + h)/(2h)), row-major in σ.
    table: Vec<f32>,
}

impl ChordGlow {
    /// The chord glow of `medium` (β > 0 and a finite radius > 0; else every
    /// ray gets `[1, 0]`).
    #[must_use]
    pub fn new(medium: &Medium) -> Self {
        let t = f64::from(medium.env_thickness());
        if !(t > 0.0 && t.is_finite()) {
            return Self {
                beta: 0.0,
                t: 0.0,
                centre: 0.0,
                table: Vec::new(),
            };
        }
        let (x, w) = relight_sh::quadrature::gauss_legendre(CHORD_NODES);
        let last = (CHORD_PROFILE_SAMPLES - 1) as f64;
        let profile: Vec<f64> = (0..CHORD_PROFILE_SAMPLES)
            .map(|i| {
                let r = t * i as f64 / last;
                x.iter()
                    .zip(&w)
                    .map(|(&mu, &wm)| {
                        let edge = (t * t - r * r * (1.0 - mu * mu)).max(0.0).sqrt() - r * mu;
                        0.5 * wm * (-edge).exp()
                    })
                    .sum()
            })
            .collect();
        let j = |r: f64| {
            let f = (r / t * last).clamp(0.0, last);
            let i = (f as usize).min(CHORD_PROFILE_SAMPLES - 2);
            let a = f - i as f64;
            profile[i] * (1.0 - a) + profile[i + 1] * a
        };
        // ∫_{u0}^{h} e^{−(u − u0)} J(√(p² + u²)) du.
        let g = |p: f64, u0: f64, h: f64| -> f64 {
            let half = 0.5 * (h - u0);
            x.iter()
                .zip(&w)
                .map(|(&xs, &ws)| {
                    let u = u0 + half * (xs + 1.0);
                    half * ws * (-(u - u0)).exp() * j((p * p + u * u).sqrt())
                })
                .sum()
        };
        let centre = g(0.0, 0.0, t);
        let n = CHORD_TABLE_SIZE;
        let mut table = Vec::with_capacity(n * n);
        for iy in 0..n {
            let sigma = iy as f64 / (n - 1) as f64;
            for ix in 0..n {
                let p = t * ix as f64 / (n - 1) as f64;
                let h = (t * t - p * p).max(0.0).sqrt();
                let u0 = -h + 2.0 * h * sigma;
                table.push((g(p, u0, h) / centre) as f32);
            }
        }
        Self {
            beta: medium.beta,
            t: t as f32,
            centre: centre as f32,
            table,
        }
    }

    /// G_c: what the centre's view scatters of a uniform sky of radiance 1
    /// (albedo 1), the ball kernel's w₀; 0 without a medium.
    #[must_use]
    pub fn centre(&self) -> f32 {
        self.centre
    }

    /// `[direct, glow]` for the view ray `eye + t·d` (world units, d unit):
    /// `[1, 0]` for a ray that misses the ball (or no medium), `[e^{−T}, 1]`
    /// from the centre.
    #[must_use]
    pub fn weights(&self, eye: Vec3, d: Vec3) -> [f32; 2] {
        match self.chord(eye, d) {
            Some((p, u0, h)) => [crate::fast::exp(-(h - u0)), self.glow(p, u0, h)],
            None => [1.0, 0.0],
        }
    }

    /// `[e^{−βD}, s]` for a surface at distance `t_s` along the view ray
    /// `eye + t·d`, D its view segment in the medium: its radiance L_s
    /// arrives as `e^{−βD} L_s + s · a L̄ G_c` (L̄ the environment's mean
    /// radiance, a the albedo, G_c [`Self::centre`]), s = (G(p, u₀) −
    /// e^{−βD} G(p, u_s)) / G_c the segment's share of a uniform sky's
    /// single scattering (exact for one; type docs). `[1, 0]` where the
    /// segment has no medium.
    #[must_use]
    pub fn segment(&self, eye: Vec3, d: Vec3, t_s: f32) -> [f32; 2] {
        let Some((p, u0, h)) = self.chord(eye, d) else {
            return [1.0, 0.0];
        };
        let u_s = (eye * self.beta).dot(d) + self.beta * t_s;
        if u_s <= u0 {
            return [1.0, 0.0];
        }
        let u_s = u_s.min(h);
        let f = crate::fast::exp(-(u_s - u0));
        let s = self.glow(p, u0, h) - f * self.glow(p, u_s, h);
        [f, s.max(0.0)]
    }

    /// The ray's line in units β = 1: its distance p from the centre, the
    /// medium's start u₀ and the exit h along it; `None` without medium.
    fn chord(&self, eye: Vec3, d: Vec3) -> Option<(f32, f32, f32)> {
        if self.table.is_empty() {
            return None;
        }
        let x = eye * self.beta;
        let u_eye = x.dot(d);
        let p = (x - u_eye * d).length();
        if p >= self.t {
            return None;
        }
        let h = (self.t * self.t - p * p).sqrt();
        let u0 = u_eye.max(-h);
        (u0 < h).then_some((p, u0, h))
    }

    /// G(p, u) / G_c by bilinear lookup (u ∈ [−h, h]).
    fn glow(&self, p: f32, u: f32, h: f32) -> f32 {
        let n = CHORD_TABLE_SIZE;
        let last = (n - 1) as f32;
        let fx = (p / self.t * last).clamp(0.0, last);
        let fy = ((u + h) / (2.0 * h).max(1e-30) * last).clamp(0.0, last);
        let (ix, iy) = ((fx as usize).min(n - 2), (fy as usize).min(n - 2));
        let (ax, ay) = (fx - ix as f32, fy - iy as f32);
        let at = |i: usize, k: usize| self.table[k * n + i];
        (at(ix, iy) * (1.0 - ax) + at(ix + 1, iy) * ax) * (1.0 - ay)
            + (at(ix, iy + 1) * (1.0 - ax) + at(ix + 1, iy + 1) * ax) * ay
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ball(beta: f32, radius: f32) -> Medium {
        Medium {
            beta,
            albedo: 1.0,
            radius,
        }
    }

    #[test]
    fn the_centre_sees_the_centres_weights() {
        let m = ball(0.2, 5.0);
        let glow = ChordGlow::new(&m);
        for d in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.6, 0.0, 0.8)] {
            let [direct, g] = glow.weights(Vec3::ZERO, d);
            assert!((direct - (-1.0f32).exp()).abs() < 1e-6, "{direct}");
            assert!((g - 1.0).abs() < 1e-5, "{g}");
        }
        // No medium: the environment as it is.
        assert_eq!(
            ChordGlow::new(&ball(0.0, 5.0)).weights(Vec3::ZERO, Vec3::X),
            [1.0, 0.0]
        );
    }

    /// A uniform sky's single scattering along chords from eyes inside and
    /// outside the ball, taken point by point (the in-scatter at each point
    /// of the chord from a Fibonacci sphere of incoming directions, each
    /// attenuated over its way in from the edge), against `glow × G_c`
    /// (G_c = the ball kernel's w₀): within 1 %.
    #[test]
    fn chord_glow_of_a_uniform_sky() {
        let (beta, radius) = (0.1f32, 10.0f32);
        let m = ball(beta, radius);
        let chords = ChordGlow::new(&m);
        let w0 = crate::psf::ball_convolution_weights(f64::from(beta * radius), 1)[0];
        let dirs: Vec<Vec3> = (0..4000)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / 4000.0;
                let r = (1.0 - z * z).sqrt();
                let a = std::f32::consts::PI * (1.0 + 5f32.sqrt()) * (i as f32 + 0.5);
                Vec3::new(r * a.cos(), r * a.sin(), z)
            })
            .collect();
        let inscatter = |x: Vec3| {
            let c = x.length_squared() - radius * radius;
            dirs.iter()
                .map(|w| {
                    let b = x.dot(*w);
                    (-beta * (-b + (b * b - c).max(0.0).sqrt())).exp()
                })
                .sum::<f32>()
                / dirs.len() as f32
        };
        for (eye, d) in [
            (Vec3::new(0.0, 0.0, 4.0), Vec3::NEG_Z),
            (Vec3::new(0.0, 0.0, 4.0), Vec3::Z),
            (Vec3::new(0.0, 0.0, 15.0), Vec3::NEG_Z),
            (
                Vec3::new(0.0, 0.0, 15.0),
                Vec3::new(0.0, 0.3, -0.954).normalize(),
            ),
            (Vec3::new(0.0, 0.0, 12.0), Vec3::new(0.0, 0.6, -0.8)),
            (Vec3::new(3.0, -2.0, 1.0), Vec3::new(0.48, 0.6, 0.64)),
        ] {
            let (t_in, t_out) = m.ball_span(eye, d).unwrap();
            let steps = 200;
            let h = (t_out - t_in) / steps as f32;
            let want: f32 = (0..steps)
                .map(|k| {
                    let s = t_in + (k as f32 + 0.5) * h;
                    beta * (-beta * (s - t_in)).exp() * inscatter(eye + s * d) * h
                })
                .sum();
            let [direct, glow] = chords.weights(eye, d);
            let got = glow * w0 as f32;
            assert!((chords.centre() - w0 as f32).abs() < 1e-4 * w0 as f32);
            assert!(
                (got - want).abs() < 0.01 * want,
                "eye {eye}, d {d}: chord glow {got} vs point by point {want}"
            );
            let t_d = beta * (t_out - t_in);
            assert!(
                (direct - (-t_d).exp()).abs() < 1e-5,
                "{direct} vs T_d {t_d}"
            );
            // A surface halfway along the chord: the segment's share.
            let t_s = 0.5 * (t_in + t_out);
            let half: f32 = (0..steps / 2)
                .map(|k| {
                    let s = t_in + (k as f32 + 0.5) * h;
                    beta * (-beta * (s - t_in)).exp() * inscatter(eye + s * d) * h
                })
                .sum();
            let [f, share] = chords.segment(eye, d, t_s);
            let got = share * chords.centre();
            assert!(
                (got - half).abs() < 0.01 * half,
                "eye {eye}, d {d}: segment {got} vs point by point {half}"
            );
            assert!((f - (-0.5 * t_d).exp()).abs() < 1e-5, "{f}");
        }
    }

    #[test]
    fn outside_the_ball_the_medium_starts_at_the_entry() {
        let m = ball(0.2, 5.0);
        let eye = Vec3::new(0.0, 0.0, 8.0);
        // Through the centre: the chord is the diameter.
        let [direct, _] = ChordGlow::new(&m).weights(eye, Vec3::NEG_Z);
        assert!((direct - (-2.0f32).exp()).abs() < 1e-6, "{direct}");
        assert!((medium_start(&m, eye, Vec3::NEG_Z, 10.0) - 3.0).abs() < 1e-5);
        let chords = ChordGlow::new(&m);
        let [f, _] = chords.segment(eye, Vec3::NEG_Z, 7.0);
        assert!((f - (-0.8f32).exp()).abs() < 1e-6, "{f}");
        // A surface before the ball: no medium on the way.
        assert_eq!(chords.segment(eye, Vec3::NEG_Z, 2.0), [1.0, 0.0]);
        // Away from the ball: nothing but the environment.
        assert_eq!(ChordGlow::new(&m).weights(eye, Vec3::Z), [1.0, 0.0]);
        assert_eq!(chords.segment(eye, Vec3::Z, 4.0), [1.0, 0.0]);
        // Inside: from the eye.
        let inside = Vec3::new(1.0, 0.0, 0.0);
        assert_eq!(medium_start(&m, inside, Vec3::Z, 3.0), 0.0);
    }
}
