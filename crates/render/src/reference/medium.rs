//! The homogeneous medium: transmittance through the fog ball and the light
//! scattered into a ray segment.
//!
//! # Model
//! The [`Medium`] fills the ball `|x| ≤ R` with extinction `β = σ_t`,
//! scattering `σ_s = a·β` (albedo `a`) and the isotropic phase function
//! `k = 1/(4π)` (sun-thesis-2008 §3.2); outside the ball is vacuum. The
//! transmittance between two points is `T = e^{−β ℓ}`, `ℓ` = the length of
//! the segment inside the ball ([`transmittance`]).
//!
//! # Light scattered into a segment (`inscatter`)
//! For the segment `o + t d`, `t ∈ [0, t_end)`, the single-scattered radiance
//! arriving at `o` is
//!
//! `L_s = ∫ T(o, x_t) σ_s ∫ k · L_d(x_t, ω) dω dt`,
//!
//! `L_d` the direct light at `x_t` (attenuated, shadowed). The integral runs
//! over `[a, b]`, the part of the segment inside the ball. It is estimated
//! per light type:
//! * **point light** `I` at `c`: equiangular sampling (Kulla & Fajardo,
//!   "Importance Sampling Techniques for Path Tracing in Participating
//!   Media", EGSR 2012). With `Δ = (c − o)·d` and `D` the light's distance
//!   from the ray's line, `t = Δ + D tan θ`, `θ` uniform in
//!   `[θ_a, θ_b] = [atan((a − Δ)/D), atan((b − Δ)/D)]`, density
//!   `D / ((θ_b − θ_a)(D² + (t − Δ)²))`. The light's `1/r²` (`r² = D² + (t −
//!   Δ)²`) cancels: the estimate is
//!   `σ_s k I T(o, x) T(x, c) V(x, c) (θ_b − θ_a) / D` — the discretisation of
//!   eq. 3.5 of sun-thesis-2008 (there with `a = 1`, `o` the viewer);
//! * **environment and area lights**: one distance `t ∈ [a, b]` drawn with
//!   density `β e^{−β(t − a)} / (1 − e^{−β(b − a)})`, so that
//!   `T σ_s / pdf = a (1 − e^{−β(b − a)})`, then `direct_light` with the
//!   phase function at `x_t`.

use super::integrator::Tracer;
use super::surface::{Scatter, direct_light};
use crate::Medium;
use crate::sampling::Rng;
use glam::Vec3;

/// Length of the part of `o + t d` (d unit), `0 ≤ t < len`, inside the ball,
/// and where it starts: `(t_in, t_out)` with `t_out > t_in`, or `None`.
#[inline]
#[must_use]
pub fn ball_segment(m: &Medium, o: Vec3, d: Vec3, len: f32) -> Option<(f32, f32)> {
    let (a, b) = m.ball_span(o, d)?;
    let b = b.min(len);
    (b > a).then_some((a, b))
}

/// Transmittance `e^{−β ℓ}` of the segment `o + t d` (d unit), `0 ≤ t < len`
/// (`len` may be infinite), `ℓ` its length inside the ball.
#[inline]
#[must_use]
pub fn transmittance(m: &Medium, o: Vec3, d: Vec3, len: f32) -> f32 {
    match ball_segment(m, o, d, len) {
        Some((a, b)) => (-m.beta * (b - a)).exp(),
        None => 1.0,
    }
}

/// Draws a distance in `[a, b]` with density `∝ β e^{−β(t − a)}` from `u`:
/// `(t, 1 − e^{−β(b − a)})` (the second value is the probability that free
/// flight from `a` scatters before `b`).
#[inline]
#[must_use]
pub fn sample_truncated_exponential(beta: f32, a: f32, b: f32, u: f32) -> (f32, f32) {
    let p_scatter = -(-beta * (b - a)).exp_m1();
    let t = a - (-u * p_scatter).ln_1p() / beta;
    (t.clamp(a, b), p_scatter)
}

/// Equiangular sample on `[a, b]` of the line `o + t d` about `c`: `(t, D,
/// θ_b − θ_a)` (see the module docs); `None` for an empty range.
#[inline]
#[must_use]
pub fn sample_equiangular(
    o: Vec3,
    d: Vec3,
    c: Vec3,
    a: f32,
    b: f32,
    u: f32,
) -> Option<(f32, f32, f32)> {
    let oc = c - o;
    let delta = oc.dot(d);
    let dist = (oc - delta * d).length().max(1e-7 * (1.0 + oc.length()));
    let th_a = (a - delta).atan2(dist);
    let th_b = (b - delta).atan2(dist);
    let span = th_b - th_a;
    if span.is_nan() || span <= 0.0 {
        return None;
    }
    let th = th_a + u * span;
    let t = (delta + dist * th.tan()).clamp(a, b);
    Some((t, dist, span))
}

/// Radiance scattered once into the segment `o + t d`, `0 ≤ t < t_end`,
/// towards `o`: the estimate of the module docs. Zero without a medium.
pub(crate) fn inscatter(
    tr: &Tracer,
    o: Vec3,
    d: Vec3,
    t_end: f32,
    rng: &mut Rng,
    rays: &mut u64,
) -> Vec3 {
    let Some(m) = tr.medium else {
        return Vec3::ZERO;
    };
    let Some((a, b)) = ball_segment(&m, o, d, t_end) else {
        return Vec3::ZERO;
    };
    let sigma_s = m.albedo * m.beta;
    if sigma_s <= 0.0 {
        return Vec3::ZERO;
    }
    let k = crate::sampling::uniform_sphere_pdf();
    let mut l = Vec3::ZERO;
    for p in tr.lights.points {
        let u = rng.next_f32();
        let Some((t, dist, span)) = sample_equiangular(o, d, p.position, a, b, u) else {
            continue;
        };
        let x = o + t * d;
        let v = p.position - x;
        let r = v.length();
        if r.is_nan() || r <= 0.0 || p.intensity == Vec3::ZERO {
            continue;
        }
        let wl = v / r;
        if tr.unoccluded(x, wl, r * (1.0 - 1e-4), rays) {
            let t_cam = (-m.beta * (t - a)).exp();
            let t_light = transmittance(&m, x, wl, r);
            l += p.intensity * (sigma_s * k * t_cam * t_light * span / dist);
        }
    }
    if tr.lights.has_env() || !tr.lights.areas.is_empty() {
        let u = rng.next_f32();
        let (t, p_scatter) = sample_truncated_exponential(m.beta, a, b, u);
        let x = o + t * d;
        let ld = direct_light(tr, &Scatter::Medium { x }, false, rng, rays);
        l += ld * (m.albedo * p_scatter);
    }
    if l.is_finite() { l } else { Vec3::ZERO }
}
