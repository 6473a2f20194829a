//! Direction warps shared by the models, in the pbrt family style
//! `sample_x(u) → direction`, `x_pdf(…) → solid-angle density`.
//!
//! All warps take `u ∈ [0,1)²` and return unit vectors in the local frame
//! (+Z is the warp's axis). Densities are per steradian.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// Shirley–Chiu concentric map of the unit square onto the unit disk
/// (area-preserving, low distortion).
#[inline]
#[must_use]
pub fn sample_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Inverse of [`sample_uniform_disk_concentric`]: the `u` ∈ \[0,1\]² that maps
/// to the disk point `p` (|p| ≤ 1).
#[inline]
#[must_use]
pub fn invert_uniform_disk_concentric_sample(p: Vec2) -> Vec2 {
    let r = p.length();
    if r == 0.0 {
        return Vec2::splat(0.5);
    }
    let o = if p.x.abs() >= p.y.abs() {
        // Left/right wedge: o_x = ±r, θ = π/4 · o_y/o_x ∈ [−π/4, π/4].
        let s = p.x.signum();
        let theta = (p.y * s).atan2(p.x * s);
        let ox = s * r;
        Vec2::new(ox, ox * theta / FRAC_PI_4)
    } else {
        // Top/bottom wedge: o_y = ±r, θ = π/2 − π/4 · o_x/o_y ∈ [π/4, 3π/4].
        let s = p.y.signum();
        let theta = (p.y * s).atan2(p.x * s);
        let oy = s * r;
        Vec2::new(oy * (FRAC_PI_2 - theta) / FRAC_PI_4, oy)
    };
    ((o + Vec2::ONE) * 0.5).clamp(Vec2::ZERO, Vec2::ONE)
}

/// Cosine-weighted hemisphere about +Z (Malley's method): density cos θ / π.
#[inline]
#[must_use]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_uniform_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`sample_cosine_hemisphere`]: max(cos θ, 0) / π.
#[inline]
#[must_use]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Inverse of [`sample_cosine_hemisphere`] for a unit `w` with z ≥ 0.
#[inline]
#[must_use]
pub fn invert_cosine_hemisphere_sample(w: Vec3) -> Vec2 {
    invert_uniform_disk_concentric_sample(Vec2::new(w.x, w.y))
}

/// Power-cosine lobe about +Z: density (n+1)/(2π) · cosⁿ θ on the
/// hemisphere, `exponent` n ≥ 0. cos θ = (1−u_x)^{1/(n+1)}, φ = 2π u_y.
#[inline]
#[must_use]
pub fn sample_power_cosine(u: Vec2, exponent: f32) -> Vec3 {
    let cos_theta = (1.0 - u.x).powf(1.0 / (exponent + 1.0));
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// Density of [`sample_power_cosine`]: (n+1)/(2π) · max(cos θ, 0)ⁿ.
#[inline]
#[must_use]
pub fn power_cosine_pdf(cos_theta: f32, exponent: f32) -> f32 {
    if cos_theta <= 0.0 {
        return 0.0;
    }
    (exponent + 1.0) / (2.0 * PI) * cos_theta.powf(exponent)
}

/// Inverse of [`sample_power_cosine`] for a unit `w` with z > 0:
/// u = (1 − cos^{n+1} θ, φ/2π).
#[inline]
#[must_use]
pub fn invert_power_cosine_sample(w: Vec3, exponent: f32) -> Vec2 {
    let phi = w.y.atan2(w.x).rem_euclid(2.0 * PI);
    Vec2::new(
        1.0 - w.z.clamp(0.0, 1.0).powf(exponent + 1.0),
        phi / (2.0 * PI),
    )
}

/// Mirror reflection of `w` about the unit vector `n`: 2(w·n)n − w.
#[inline]
#[must_use]
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    2.0 * w.dot(n) * n - w
}

/// Mirror direction of `wo` about the shading normal +Z.
#[inline]
#[must_use]
pub fn mirror(wo: Vec3) -> Vec3 {
    Vec3::new(-wo.x, -wo.y, wo.z)
}

/// `world_from_axis`: maps a vector given in a frame whose +Z is the unit
/// `axis` back to the frame `axis` is expressed in.
#[inline]
#[must_use]
pub fn from_axis_frame(axis: Vec3, v: Vec3) -> Vec3 {
    let (t, b) = axis.any_orthonormal_pair();
    t * v.x + b * v.y + axis * v.z
}

/// Both directions strictly above the surface (z > 0)?
#[inline]
#[must_use]
pub fn both_above(wo: Vec3, wi: Vec3) -> bool {
    wo.z > 0.0 && wi.z > 0.0
}

/// Unit half vector ĥ = (wo + wi)/|wo + wi|, or `None` when they are opposite.
#[inline]
#[must_use]
pub fn half_vector(wo: Vec3, wi: Vec3) -> Option<Vec3> {
    (wo + wi).try_normalize()
}

/// Mean of the RGB channels (used for lobe-selection probabilities).
#[inline]
#[must_use]
pub(crate) fn mean(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// The Jacobian step of half-vector sampling: the solid-angle density of
/// `wi = reflect(wo, h)` given the density `pdf_h` of `h` is
/// `pdf_h / (4 wo·h)` (Walter et al. 2007, eq. 14).
#[inline]
#[must_use]
pub fn half_to_incident_pdf(pdf_h: f32, wo_dot_h: f32) -> f32 {
    if wo_dot_h <= 0.0 {
        0.0
    } else {
        pdf_h / (4.0 * wo_dot_h)
    }
}

/// Reflects `wo` about a sampled half vector `h`; `None` when `wo·h ≤ 0`
/// or the result is at or below the horizon.
#[inline]
#[must_use]
pub fn reflect_about_half(wo: Vec3, h: Vec3) -> Option<Vec3> {
    if wo.dot(h) <= 0.0 {
        return None;
    }
    let wi = reflect(wo, h).normalize();
    (wi.z > 0.0).then_some(wi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::verify::Pcg32;

    #[test]
    fn warps_round_trip_through_their_inverses() {
        let mut rng = Pcg32::new(11);
        for _ in 0..20_000 {
            let u = rng.next_vec2();
            let back = invert_cosine_hemisphere_sample(sample_cosine_hemisphere(u));
            assert!(
                (back - u).abs().max_element() < 2e-4,
                "cosine: {u} → {back}"
            );
            for n in [0.0, 3.0, 50.0] {
                let w = sample_power_cosine(u, n);
                let back = invert_power_cosine_sample(w, n);
                // Near the pole φ is ill-conditioned; compare directions instead.
                let again = sample_power_cosine(back, n);
                assert!(
                    (again - w).length() < 1e-3,
                    "power {n}: {u} → {w} → {back} → {again}"
                );
            }
        }
    }
}
