//! The exact clamped-cosine integral of a spherical polygon (Heitz et al.
//! 2016, *Real-Time Polygonal-Light Shading with Linearly Transformed
//! Cosines*, §4 and eq. 11; the edge form goes back to Lambert's formula,
//! Arvo 1995).
//!
//! For a polygon `P` with vertices `p_i` (relative to the shading point, in
//! the local frame with the normal on +Z), clipped to the upper hemisphere,
//!
//! `E(P) = ∫_P max(0, ω_z)/π dω = (1/2π) Σ_i θ_i · (p̂_i × p̂_{i+1})_z / |p̂_i × p̂_{i+1}|`,
//!
//! `θ_i = acos(p̂_i · p̂_{i+1})` the arc of edge `i`. The sign follows the
//! winding (counter-clockwise seen from the origin is positive); callers that
//! know the light faces them take the absolute value. Checked against
//! midpoint quadrature over the polygon's area in the tests.

use glam::DVec3;

/// Most vertices a polygon may have here: a quadrilateral clipped by two
/// planes (each cut of a convex polygon adds at most one vertex).
pub const MAX_VERTICES: usize = 6;

/// Clips the convex polygon `poly` (≤ [`MAX_VERTICES`] − 1 vertices) to
/// `z ≥ 0` (Sutherland–Hodgman against one plane) into `out`; returns the
/// vertex count (0 when nothing is above the horizon). No allocation.
#[must_use]
pub fn clip_to_horizon(poly: &[DVec3], out: &mut [DVec3; MAX_VERTICES]) -> usize {
    let n = poly.len();
    let mut k = 0;
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        let (ia, ib) = (a.z >= 0.0, b.z >= 0.0);
        if ia && k < out.len() {
            out[k] = a;
            k += 1;
        }
        if ia != ib && k < out.len() {
            // The crossing point of edge a→b with z = 0.
            let t = a.z / (a.z - b.z);
            let mut c = a + (b - a) * t;
            c.z = 0.0;
            out[k] = c;
            k += 1;
        }
    }
    k
}

/// The signed contribution `θ · (â × b̂)_z / |â × b̂|` of one edge between
/// unit vectors `a`, `b` (eq. 11 of Heitz et al. 2016, before the `1/2π`).
/// `θ / sin θ` is evaluated by a series near θ = 0, where `acos` loses
/// precision.
#[inline]
#[must_use]
pub fn edge_integral(a: DVec3, b: DVec3) -> f64 {
    let c = a.cross(b);
    let s = c.length();
    if s <= 0.0 {
        return 0.0;
    }
    let cos = a.dot(b).clamp(-1.0, 1.0);
    let theta = s.atan2(cos);
    c.z * (theta / s)
}

/// `E(P) = ∫_P max(0, ω_z)/π dω` of the convex polygon `poly` (≤ 5 vertices,
/// relative to the shading point, local frame: normal +Z), signed by the
/// winding (module docs). Clipped at the horizon; 0 when it lies below.
#[must_use]
pub fn clamped_cosine_integral(poly: &[DVec3]) -> f64 {
    let mut clipped = [DVec3::ZERO; MAX_VERTICES];
    let k = clip_to_horizon(poly, &mut clipped);
    if k < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..k {
        let a = clipped[i].normalize_or_zero();
        let b = clipped[(i + 1) % k].normalize_or_zero();
        sum += edge_integral(a, b);
    }
    sum / (2.0 * std::f64::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Midpoint quadrature of `∫ cos_θ/π · cos_l / r² dA` over the
    /// parallelogram `c + s·u + t·v`, `s, t ∈ [0, 1]` (the light faces −n̂).
    fn quadrature(c: DVec3, u: DVec3, v: DVec3, n: usize) -> f64 {
        let nl = u.cross(v).normalize();
        let da = u.cross(v).length() / (n * n) as f64;
        let mut sum = 0.0;
        for j in 0..n {
            for i in 0..n {
                let p = c + u * ((i as f64 + 0.5) / n as f64) + v * ((j as f64 + 0.5) / n as f64);
                let r2 = p.length_squared();
                let w = p / r2.sqrt();
                sum += w.z.max(0.0) / std::f64::consts::PI * w.dot(nl).abs() / r2;
            }
        }
        sum * da
    }

    #[test]
    fn matches_area_quadrature_with_and_without_the_horizon() {
        let cases = [
            // Above, tilted, straddling the horizon, below.
            (
                DVec3::new(-0.5, -0.4, 1.0),
                DVec3::new(1.0, 0.0, 0.2),
                DVec3::new(0.0, 0.8, 0.1),
            ),
            (
                DVec3::new(0.3, -1.0, 0.5),
                DVec3::new(0.0, 2.0, 0.0),
                DVec3::new(0.4, 0.0, 0.9),
            ),
            (
                DVec3::new(1.0, -0.5, -0.6),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(0.0, 0.0, 1.2),
            ),
            (
                DVec3::new(-0.5, -0.5, -1.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
            ),
        ];
        for (c, u, v) in cases {
            let poly = [c, c + u, c + u + v, c + v];
            let e = clamped_cosine_integral(&poly).abs();
            let q = quadrature(c, u, v, 1200);
            assert!(
                (e - q).abs() <= 2e-5 * q.max(1e-3),
                "{e} vs {q} for {c} {u} {v}"
            );
            // Reversing the winding flips the sign only.
            let rev = [poly[3], poly[2], poly[1], poly[0]];
            assert!((clamped_cosine_integral(&rev) + clamped_cosine_integral(&poly)).abs() < 1e-12);
        }
    }

    #[test]
    fn a_huge_square_above_covers_the_whole_hemisphere() {
        let s = 1e5;
        let poly = [
            DVec3::new(-s, -s, 1.0),
            DVec3::new(s, -s, 1.0),
            DVec3::new(s, s, 1.0),
            DVec3::new(-s, s, 1.0),
        ];
        let e = clamped_cosine_integral(&poly);
        assert!((e - 1.0).abs() < 1e-4, "{e}");
    }
}
