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

    /// The table seen from `eye` (world units): what every ray of a frame
    /// shares, found once.
    #[must_use]
    pub fn view(&self, eye: Vec3) -> ChordView<'_> {
        let x = eye * self.beta;
        ChordView {
            glow: self,
            x,
            xx: x.length_squared(),
            column_scale: (CHORD_TABLE_SIZE - 1) as f32 / self.t.max(1e-30),
        }
    }

    /// [`ChordView::weights`] of one ray.
    #[must_use]
    pub fn weights(&self, eye: Vec3, d: Vec3) -> [f32; 2] {
        self.view(eye).weights(d)
    }

    /// [`ChordView::segment_to`] of one surface point `eye + t_s·d`.
    #[must_use]
    pub fn segment(&self, eye: Vec3, d: Vec3, t_s: f32) -> [f32; 2] {
        self.view(eye).segment_to(d * t_s)
    }
}

/// A [`ChordGlow`] seen from one eye, in units β = 1.
#[derive(Clone, Copy, Debug)]
pub struct ChordView<'a> {
    glow: &'a ChordGlow,
    /// The eye, β·eye, and |β·eye|².
    x: Vec3,
    xx: f32,
    /// Table columns per unit of p.
    column_scale: f32,
}

/// The AVX2 + FMA copy of [`ChordView::segment_to`], eight samples per step
/// (the same arithmetic; `segments_match_one_at_a_time` compares them).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    #![allow(unsafe_op_in_unsafe_fn)]
    use super::{CHORD_TABLE_SIZE, ChordView};
    use crate::simd::exp;
    use std::arch::x86_64::*;

    /// Samples `0..8k` of [`ChordView::segments`]; returns 8k.
    ///
    /// # Safety
    /// The CPU has AVX2 and FMA; the slices hold at least `out.len()`
    /// samples; the table is built.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn segments(
        c: &ChordView,
        vx: &[f32],
        vy: &[f32],
        vz: &[f32],
        out: &mut [[f32; 2]],
    ) -> usize {
        let done = out.len() / 8 * 8;
        let table = &c.glow.table;
        let n = CHORD_TABLE_SIZE as f32;
        let s = _mm256_set1_ps;
        let (x0, x1, x2) = (s(c.x.x), s(c.x.y), s(c.x.z));
        let (xx, tt, beta) = (s(c.xx), s(c.glow.t * c.glow.t), s(c.glow.beta));
        let (last, below, zero, one) = (s(n - 1.0), s(n - 2.0), s(0.0), s(1.0));
        // Bilinear read of G / G_c at column (ix, ax) for coordinates u.
        let at = |ixf: __m256, ax: __m256, u: __m256, h: __m256, scale: __m256| {
            // max(x, 0) first: a NaN coordinate reads texel 0.
            let fy = _mm256_min_ps(
                _mm256_max_ps(_mm256_mul_ps(_mm256_add_ps(u, h), scale), zero),
                last,
            );
            let iyf = _mm256_min_ps(_mm256_floor_ps(fy), below);
            let ay = _mm256_sub_ps(fy, iyf);
            let i = _mm256_cvttps_epi32(_mm256_fmadd_ps(iyf, s(n), ixf));
            let g = |off: i32| {
                _mm256_i32gather_ps::<4>(
                    table.as_ptr(),
                    _mm256_add_epi32(i, _mm256_set1_epi32(off)),
                )
            };
            let (a, b) = (g(0), g(1));
            let (cc, d) = (g(CHORD_TABLE_SIZE as i32), g(CHORD_TABLE_SIZE as i32 + 1));
            let lo = _mm256_fmadd_ps(_mm256_sub_ps(b, a), ax, a);
            let hi = _mm256_fmadd_ps(_mm256_sub_ps(d, cc), ax, cc);
            _mm256_fmadd_ps(_mm256_sub_ps(hi, lo), ay, lo)
        };
        for k in (0..done).step_by(8) {
            let (ax_, ay_, az_) = (
                _mm256_loadu_ps(vx.as_ptr().add(k)),
                _mm256_loadu_ps(vy.as_ptr().add(k)),
                _mm256_loadu_ps(vz.as_ptr().add(k)),
            );
            let t2 = _mm256_fmadd_ps(ax_, ax_, _mm256_fmadd_ps(ay_, ay_, _mm256_mul_ps(az_, az_)));
            let t = _mm256_sqrt_ps(t2);
            let dot = _mm256_fmadd_ps(x0, ax_, _mm256_fmadd_ps(x1, ay_, _mm256_mul_ps(x2, az_)));
            let u_eye = _mm256_div_ps(dot, t);
            let p2 = _mm256_max_ps(_mm256_fnmadd_ps(u_eye, u_eye, xx), zero);
            let h = _mm256_sqrt_ps(_mm256_sub_ps(tt, p2));
            let u0 = _mm256_max_ps(u_eye, _mm256_sub_ps(zero, h));
            let u_s = _mm256_fmadd_ps(beta, t, u_eye);
            let ok = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(t, zero),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(p2, tt),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_LT_OQ>(u0, h),
                    _mm256_cmp_ps::<_CMP_GT_OQ>(u_s, u0),
                ),
            );
            let u_s = _mm256_min_ps(u_s, h);
            let f = exp(_mm256_sub_ps(u0, u_s));
            let fx = _mm256_min_ps(
                _mm256_max_ps(_mm256_mul_ps(_mm256_sqrt_ps(p2), s(c.column_scale)), zero),
                last,
            );
            let ixf = _mm256_min_ps(_mm256_floor_ps(fx), below);
            let ax = _mm256_sub_ps(fx, ixf);
            let scale = _mm256_div_ps(last, _mm256_max_ps(_mm256_add_ps(h, h), s(1e-30)));
            let g0 = at(ixf, ax, u0, h, scale);
            let gs = at(ixf, ax, u_s, h, scale);
            let share = _mm256_max_ps(_mm256_fnmadd_ps(f, gs, g0), zero);
            let f = _mm256_blendv_ps(one, f, ok);
            let share = _mm256_blendv_ps(zero, share, ok);
            let mut fs = [0.0f32; 8];
            let mut ss = [0.0f32; 8];
            _mm256_storeu_ps(fs.as_mut_ptr(), f);
            _mm256_storeu_ps(ss.as_mut_ptr(), share);
            for j in 0..8 {
                out[k + j] = [fs[j], ss[j]];
            }
        }
        done
    }
}

impl ChordView<'_> {
    /// `[direct, glow]` for the view ray along `d` (unit): `[1, 0]` for a
    /// ray that misses the ball (or no medium), `[e^{−T}, 1]` from the
    /// centre.
    #[must_use]
    pub fn weights(&self, d: Vec3) -> [f32; 2] {
        match self.chord(self.x.dot(d)) {
            Some((p, u0, h)) => {
                let at = self.glow_row(p, h);
                [crate::fast::exp(-(h - u0)), at(u0)]
            }
            None => [1.0, 0.0],
        }
    }

    /// `[e^{−βD}, s]` for the surface point at `v` from the eye (world
    /// units), D its view segment in the medium: its radiance L_s arrives
    /// as `e^{−βD} L_s + s · a L̄ G_c` (L̄ the environment's mean radiance, a
    /// the albedo, G_c [`ChordGlow::centre`]), s = (G(p, u₀) − e^{−βD}
    /// G(p, u_s)) / G_c the segment's share of a uniform sky's single
    /// scattering (exact for one; [`ChordGlow`]'s docs). `[1, 0]` where the
    /// segment has no medium.
    #[must_use]
    pub fn segment_to(&self, v: Vec3) -> [f32; 2] {
        let t = v.length();
        if t.is_nan() || t <= 0.0 {
            return [1.0, 0.0];
        }
        let u_eye = self.x.dot(v) / t;
        let Some((p, u0, h)) = self.chord(u_eye) else {
            return [1.0, 0.0];
        };
        let u_s = u_eye + self.glow.beta * t;
        if u_s <= u0 {
            return [1.0, 0.0];
        }
        let u_s = u_s.min(h);
        let f = crate::fast::exp(-(u_s - u0));
        let at = self.glow_row(p, h);
        [f, (at(u0) - f * at(u_s)).max(0.0)]
    }

    /// [`Self::segment_to`] of every sample `(vx[i], vy[i], vz[i])` into
    /// `out[i]` (`out.len()` samples): eight at a time where the CPU has
    /// AVX2 and FMA (the same values up to rounding), one by one otherwise.
    ///
    /// # Panics
    /// A slice of `vx`, `vy`, `vz` shorter than `out`.
    pub fn segments(&self, vx: &[f32], vy: &[f32], vz: &[f32], out: &mut [[f32; 2]]) {
        let n = out.len();
        assert!(
            vx.len() >= n && vy.len() >= n && vz.len() >= n,
            "segments: short input"
        );
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        if relight_isa::avx2() && !self.glow.table.is_empty() {
            // SAFETY: AVX2 and FMA are present, the inputs hold n samples,
            // and the table is built.
            done = unsafe { avx2::segments(self, vx, vy, vz, out) };
        }
        for i in done..n {
            out[i] = self.segment_to(Vec3::new(vx[i], vy[i], vz[i]));
        }
    }

    /// The ray's line from its coordinate `u_eye` = x·d at the eye: its
    /// distance p from the centre, the medium's start u₀ and the exit h
    /// along it; `None` without medium. p² = |x|² − u_eye² (no vector
    /// work per ray).
    fn chord(&self, u_eye: f32) -> Option<(f32, f32, f32)> {
        let t = self.glow.t;
        if self.glow.table.is_empty() {
            return None;
        }
        let p2 = (self.xx - u_eye * u_eye).max(0.0);
        if p2 >= t * t {
            return None;
        }
        let h = (t * t - p2).sqrt();
        let u0 = u_eye.max(-h);
        (u0 < h).then_some((p2.sqrt(), u0, h))
    }

    /// u ↦ G(p, u) / G_c on the chord of half-length `h` at distance `p`
    /// by bilinear lookup (u ∈ [−h, h]); the column and its weight, and
    /// the scale of u, are found once for the chord.
    fn glow_row(&self, p: f32, h: f32) -> impl Fn(f32) -> f32 + '_ {
        let n = CHORD_TABLE_SIZE;
        let last = (n - 1) as f32;
        let fx = (p * self.column_scale).clamp(0.0, last);
        let ix = (fx as usize).min(n - 2);
        let ax = fx - ix as f32;
        let scale = last / (2.0 * h).max(1e-30);
        let table = &self.glow.table;
        move |u: f32| {
            let fy = ((u + h) * scale).clamp(0.0, last);
            let iy = (fy as usize).min(n - 2);
            let ay = fy - iy as f32;
            let row = &table[iy * n + ix..iy * n + ix + n + 2];
            let lo = row[0] + (row[1] - row[0]) * ax;
            let hi = row[n] + (row[n + 1] - row[n]) * ax;
            lo + (hi - lo) * ay
        }
    }
}

/// `n` directions spread evenly over the sphere (a Fibonacci lattice): the
/// tests' quadrature of integrals taken point by point.
#[cfg(test)]
pub(crate) fn fibonacci_sphere(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).sqrt();
            let a = std::f32::consts::PI * (1.0 + 5f32.sqrt()) * (i as f32 + 0.5);
            Vec3::new(r * a.cos(), r * a.sin(), z)
        })
        .collect()
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
        let dirs = fibonacci_sphere(4000);
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

    /// The batch (AVX2 where present) gives each sample what
    /// `segment_to` gives it alone: eyes inside and outside, surfaces
    /// before, inside and past the ball, rays that miss it, the eye's own
    /// point, and a count that is not a multiple of eight; to 5e-5 (FMA
    /// rounding, which p² = |x|² − u² amplifies for an eye far out).
    #[test]
    fn segments_match_one_at_a_time() {
        let chords = ChordGlow::new(&ball(0.15, 6.0));
        for eye in [Vec3::new(0.5, 1.0, 2.0), Vec3::new(1.0, 2.0, 15.0)] {
            let view = chords.view(eye);
            let mut v = [Vec::new(), Vec::new(), Vec::new()];
            for i in 0..203 {
                let a = i as f32 * 0.61;
                let spread = Vec3::new(
                    a.sin() * (1.7 * a).cos(),
                    a.cos(),
                    a.sin() * (1.7 * a).sin(),
                );
                // From outside, rays about the ball's direction.
                let d = if eye.length() > 6.0 {
                    (0.5 * spread - eye.normalize()).normalize()
                } else {
                    spread
                };
                let t = if i == 7 { 0.0 } else { 0.2 + (i % 23) as f32 };
                for (k, c) in v.iter_mut().enumerate() {
                    c.push((d * t)[k]);
                }
            }
            let mut out = vec![[0.0f32; 2]; 203];
            view.segments(&v[0], &v[1], &v[2], &mut out);
            let mut inside = 0;
            for (i, got) in out.iter().enumerate() {
                let want = view.segment_to(Vec3::new(v[0][i], v[1][i], v[2][i]));
                inside += usize::from(want[1] > 0.0);
                for k in 0..2 {
                    assert!(
                        (got[k] - want[k]).abs() <= 5e-5 * want[k].abs().max(1.0),
                        "eye {eye}, sample {i}: batch {got:?} vs one {want:?}"
                    );
                }
            }
            // Inside, all but the eye's own point; outside, some miss.
            let outside = eye.length() > 6.0;
            assert!(
                inside > 30 && (inside < 180) == outside,
                "{inside} samples in the medium"
            );
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
