//! Procedural meshes for the embedded default scene and for tests: spheres,
//! a torus, a trefoil torus knot (the detailed shape) and ground planes.
//!
//! All shapes are centred at the origin in object space (+Y up), wound
//! counter-clockwise seen from outside, and come out of
//! [`Mesh::validate_and_repair`] (unit normals; tangents where there are
//! uvs). Seam vertices (the `u = 0` / `u = 1` column, pole fans) are exact
//! copies of their partners' positions, so position-welded topology is
//! closed: spheres have Euler characteristic 2, the torus and the knot 0.
//!
//! uv convention: `u` runs with the azimuth `φ ∈ [0, 2π)` (from +Z towards
//! +X), `v` from the top (+Y) down.

use crate::mesh::Mesh;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Grid of `(cols + 1) × (rows + 1)` vertices from `f(u, v) -> (position,
/// normal)` with `u, v ∈ [0, 1]`; the last column copies the first exactly
/// when `wrap_u`. Triangles of zero area (poles) are dropped by repair.
fn grid(cols: usize, rows: usize, wrap_u: bool, f: impl Fn(f32, f32) -> (Vec3, Vec3)) -> Mesh {
    let mut m = Mesh::default();
    for r in 0..=rows {
        for c in 0..=cols {
            let (u, v) = (c as f32 / cols as f32, r as f32 / rows as f32);
            let (p, n) = if wrap_u && c == cols {
                f(0.0, v)
            } else {
                f(u, v)
            };
            m.positions.push(p);
            m.normals.push(n);
            m.uvs.push(Vec2::new(u, v));
        }
    }
    let w = (cols + 1) as u32;
    for r in 0..rows as u32 {
        for c in 0..cols as u32 {
            let (i00, i10, i01, i11) = (
                r * w + c,
                r * w + c + 1,
                (r + 1) * w + c,
                (r + 1) * w + c + 1,
            );
            m.indices.push([i00, i01, i11]);
            m.indices.push([i00, i11, i10]);
        }
    }
    m.validate_and_repair();
    m
}

/// Point on the unit sphere at polar angle `θ = π v` from +Y and azimuth
/// `φ = 2π u` from +Z towards +X; poles are exact.
fn sphere_dir(u: f32, v: f32) -> Vec3 {
    if v <= 0.0 {
        return Vec3::Y;
    }
    if v >= 1.0 {
        return Vec3::NEG_Y;
    }
    let (st, ct) = (PI * v).sin_cos();
    let (sp, cp) = (TAU * u).sin_cos();
    Vec3::new(st * sp, ct, st * cp)
}

/// A latitude–longitude sphere: `segments` around (≥ 3), `rings` from pole
/// to pole (≥ 2); `(segments + 1)(rings + 1)` vertices, uvs as documented
/// in the module.
#[must_use]
pub fn uv_sphere(radius: f32, segments: usize, rings: usize) -> Mesh {
    let (segments, rings) = (segments.max(3), rings.max(2));
    grid(segments, rings, true, |u, v| {
        let d = sphere_dir(u, v);
        (d * radius, d)
    })
}

/// [`uv_sphere`] centred at `center` instead of the origin.
#[must_use]
pub fn uv_sphere_at(center: Vec3, radius: f32, segments: usize, rings: usize) -> Mesh {
    uv_sphere(radius, segments, rings).transformed(glam::Affine3A::from_translation(center))
}

/// A geodesic sphere: the icosahedron with each face split `4^level` times
/// (midpoints pushed to the sphere); `10·4^level + 2` shared vertices, no
/// uvs (no seams, so it is the watertight sphere for topology tests).
#[must_use]
pub fn icosphere(radius: f32, level: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut pos: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                pos.push((pos[a as usize] + pos[b as usize]).normalize());
                (pos.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for &[a, b, c] in &tris {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut pos),
                midpoint(b, c, &mut pos),
                midpoint(c, a, &mut pos),
            );
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let mut m = Mesh {
        normals: pos.clone(),
        positions: pos.iter().map(|&p| p * radius).collect(),
        uvs: Vec::new(),
        tangents: Vec::new(),
        indices: tris,
    };
    m.validate_and_repair();
    m
}

/// A torus around the Y axis: ring radius `major`, tube radius `minor`,
/// `segments` around the ring, `sides` around the tube.
#[must_use]
pub fn torus(major: f32, minor: f32, segments: usize, sides: usize) -> Mesh {
    let (segments, sides) = (segments.max(3), sides.max(3));
    let mut m = grid(segments, sides, true, |u, v| {
        let (sp, cp) = (TAU * u).sin_cos();
        let (st, ct) = if v >= 1.0 {
            (0.0, 1.0)
        } else {
            (TAU * v).sin_cos()
        };
        let ring = Vec3::new(sp, 0.0, cp);
        let n = ring * ct + Vec3::Y * st;
        (ring * major + n * minor, n)
    });
    // The grid's tube direction runs outward-then-up, which winds the
    // triangles inward: flip them to face out.
    for t in &mut m.indices {
        t.swap(1, 2);
    }
    m.tangents = m.compute_tangents();
    m
}

/// The default scene's detailed shape (the `knot` built-in):
/// [`detailed_shape_with`] at bounding radius 1 and resolution 512
/// (513 × 257 = 131 841 vertices). That many because per-vertex (Gouraud)
/// methods must sample its glossy highlights (wavelet-rotation-2006 §3
/// shades models of 30–120 K vertices).
#[must_use]
pub fn detailed_shape() -> Mesh {
    detailed_shape_with(1.0, 512)
}

/// Winding numbers of the detailed shape's trefoil: the curve goes
/// `KNOT_P` times around the knot's axis and `KNOT_Q` times through its hole.
pub const KNOT_P: u32 = 2;
/// See [`KNOT_P`].
pub const KNOT_Q: u32 = 3;

/// Tube radius of the detailed shape, as a fraction of its bounding radius.
/// The (2, 3) centreline (scaled to fit) has a minimum radius of curvature
/// of about 0.39 and strands at least 0.45 apart, so a tube of 0.18 neither
/// folds nor touches itself.
pub const KNOT_TUBE: f32 = 0.18;

/// The centreline `c(t)` of the (p, q) = (2, 3) torus knot and its first
/// two derivatives, unscaled: `r = 2 + cos qt`,
/// `c = (r cos pt, r sin pt, sin qt)`, `t ∈ [0, 2π)`. The knot's axis is
/// +Z (it faces a camera on the +Z axis); `|c| ≤ 3`.
fn knot_curve(t: f32) -> [Vec3; 3] {
    let (p, q) = (KNOT_P as f32, KNOT_Q as f32);
    let (sq, cq) = (q * t).sin_cos();
    let (sp, cp) = (p * t).sin_cos();
    let (r, r1, r2) = (2.0 + cq, -q * sq, -q * q * cq);
    [
        Vec3::new(r * cp, r * sp, sq),
        Vec3::new(r1 * cp - p * r * sp, r1 * sp + p * r * cp, q * cq),
        Vec3::new(
            r2 * cp - 2.0 * p * r1 * sp - p * p * r * cp,
            r2 * sp + 2.0 * p * r1 * cp - p * p * r * sp,
            -q * q * sq,
        ),
    ]
}

/// The "detailed shape" of the default scene: a trefoil (2, 3) torus knot,
/// a tube of radius [`KNOT_TUBE`]` × radius` around the scaled centreline
/// of `knot_curve`, fitting in a sphere of radius `radius` about the
/// origin. It shadows and occludes itself from every side (all-frequency
/// visibility for the shadowing and ambient-occlusion tests).
///
/// The tube is swept along the centreline's Frenet frame (T, N, B), which
/// is periodic, so the seam closes exactly (Euler characteristic 0, like a
/// torus); normals are the analytic tube normals `cos θ N + sin θ B`.
/// `resolution` segments along the curve (≥ 8) and `resolution / 2` around
/// the tube; uvs run with the curve (u) and around the tube (v).
#[must_use]
pub fn detailed_shape_with(radius: f32, resolution: usize) -> Mesh {
    let segments = resolution.max(8);
    let sides = (segments / 2).max(4);
    let tube = KNOT_TUBE * radius;
    let scale = (radius - tube) / 3.0;
    let mut m = grid(segments, sides, true, |u, v| {
        let [c, d1, d2] = knot_curve(TAU * u);
        let t = d1.normalize();
        let b = d1.cross(d2).normalize();
        let n = b.cross(t);
        let (st, ct) = if v >= 1.0 {
            (0.0, 1.0)
        } else {
            (TAU * v).sin_cos()
        };
        let normal = n * ct + b * st;
        (c * scale + normal * tube, normal)
    });
    // θ runs from N towards B = T × N, so the grid's (u, v) order winds
    // the triangles outward as they are (unlike the torus').
    m.tangents = m.compute_tangents();
    m
}

/// A square ground plane in XZ at y = 0, side `size`, facing +Y, split into
/// `n × n` quads; uv (0,0) at (−x, −z).
#[must_use]
pub fn plane(size: f32, n: usize) -> Mesh {
    let n = n.max(1);
    // Rows run towards +Z, columns towards +X: (i00, i01, i11) winds
    // counter-clockwise seen from +Y.
    grid(n, n, false, |u, v| {
        (Vec3::new((u - 0.5) * size, 0.0, (v - 0.5) * size), Vec3::Y)
    })
}

/// A single quad (two triangles): [`plane`] with one cell.
#[must_use]
pub fn quad(size: f32) -> Mesh {
    plane(size, 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_common(name: &str, m: &Mesh) {
        assert!(m.try_validate().is_ok(), "{name}: {:?}", m.try_validate());
        assert_eq!(m.normals.len(), m.vertex_count(), "{name}");
        for n in &m.normals {
            assert!((n.length() - 1.0).abs() < 1e-5, "{name}: normal {n}");
        }
        if !m.uvs.is_empty() {
            assert_eq!(m.tangents.len(), m.vertex_count(), "{name}");
            for (t, n) in m.tangents.iter().zip(&m.normals) {
                assert!(
                    (t.truncate().length() - 1.0).abs() < 1e-4 && t.truncate().dot(*n).abs() < 1e-4,
                    "{name}: {t}"
                );
                assert!(t.w == 1.0 || t.w == -1.0);
            }
        }
        // Faces point along their vertex normals (outward winding).
        let agree = m
            .indices
            .iter()
            .filter(|t| {
                let p = t.map(|i| m.positions[i as usize]);
                let f = (p[1] - p[0]).cross(p[2] - p[0]);
                f.dot(
                    m.normals[t[0] as usize] + m.normals[t[1] as usize] + m.normals[t[2] as usize],
                ) > 0.0
            })
            .count();
        assert!(
            agree as f32 >= 0.99 * m.triangle_count() as f32,
            "{name}: {agree}/{} faces outward",
            m.triangle_count()
        );
    }

    #[test]
    fn spheres_are_closed_with_correct_area() {
        let s = uv_sphere(2.0, 96, 48);
        check_common("uv_sphere", &s);
        assert_eq!(s.edge_counts().1, 0);
        assert_eq!(s.euler_characteristic(), 2);
        let want = 4.0 * std::f64::consts::PI * 4.0;
        assert!(
            (s.area() - want).abs() / want < 2e-3,
            "area {} vs {want}",
            s.area()
        );
        for (p, n) in s.positions.iter().zip(&s.normals) {
            assert!(n.abs_diff_eq(*p / 2.0, 1e-5), "{p} {n}");
        }
        for level in 0..4 {
            let ico = icosphere(1.5, level);
            check_common("icosphere", &ico);
            assert_eq!(ico.vertex_count(), 10 * 4usize.pow(level) + 2);
            assert_eq!(ico.triangle_count(), 20 * 4usize.pow(level));
            assert_eq!(ico.edge_counts(), (30 * 4usize.pow(level), 0));
            assert_eq!(ico.euler_characteristic(), 2);
            assert!(
                ico.positions
                    .iter()
                    .all(|p| (p.length() - 1.5).abs() < 1e-5)
            );
        }
    }

    #[test]
    fn torus_genus_one_and_area() {
        let t = torus(1.0, 0.25, 128, 64);
        check_common("torus", &t);
        assert_eq!(t.edge_counts().1, 0);
        assert_eq!(t.euler_characteristic(), 0);
        let want = 4.0 * std::f64::consts::PI.powi(2) * 0.25;
        assert!(
            (t.area() - want).abs() / want < 2e-3,
            "area {} vs {want}",
            t.area()
        );
        // Analytic normals agree with freshly computed smooth ones.
        let mut fresh = t.clone();
        fresh.normals.clear();
        fresh.validate_and_repair();
        for (a, b) in t.normals.iter().zip(&fresh.normals) {
            assert!(a.dot(*b) > 0.999, "{a} vs {b}");
        }
    }

    #[test]
    fn detailed_shape_is_a_closed_trefoil_knot() {
        let m = detailed_shape_with(1.0, 256);
        assert_eq!(detailed_shape().vertex_count(), 513 * 257);
        check_common("detailed_shape", &m);
        assert_eq!(m.euler_characteristic(), 0, "a knotted tube is a torus");
        assert_eq!(m.edge_counts().1, 0);
        // It fits the unit sphere and leaves the knot's hole empty.
        let (lo, hi) = m.positions.iter().fold((f32::MAX, 0f32), |(lo, hi), p| {
            (lo.min(p.length()), hi.max(p.length()))
        });
        assert!(hi <= 1.0 + 1e-5 && hi > 0.97, "bounding radius {hi}");
        assert!(lo > 0.05 && lo < 0.5, "nearest point to the centre {lo}");
        // Tube area 2π r L (Weyl's tube formula; the tube neither folds nor
        // meets itself), L the scaled centreline length by quadrature.
        let scale = (1.0 - KNOT_TUBE) / 3.0;
        let n = 20_000;
        let length: f64 = (0..n)
            .map(|i| f64::from(knot_curve(TAU * (i as f32 + 0.5) / n as f32)[1].length()))
            .sum::<f64>()
            * std::f64::consts::TAU
            / f64::from(n)
            * f64::from(scale);
        let want = std::f64::consts::TAU * f64::from(KNOT_TUBE) * length;
        assert!(
            (m.area() - want).abs() / want < 5e-3,
            "area {} vs 2πrL = {want}",
            m.area()
        );
        // Knotted as a (2, 3) torus knot: the centreline turns twice about
        // the axis and crosses the knot's mid-plane 2q = 6 times.
        let (mut turns, mut crossings) = (0.0f32, 0);
        let steps = 4096;
        for i in 0..steps {
            // Half-step offsets keep samples off the zeros of sin qt.
            let a = knot_curve(TAU * (i as f32 + 0.5) / steps as f32)[0];
            let b = knot_curve(TAU * (i as f32 + 1.5) / steps as f32)[0];
            let mut d = b.y.atan2(b.x) - a.y.atan2(a.x);
            if d > PI {
                d -= TAU;
            } else if d < -PI {
                d += TAU;
            }
            turns += d;
            crossings += usize::from((a.z > 0.0) != (b.z > 0.0));
        }
        assert!((turns / TAU - KNOT_P as f32).abs() < 1e-3, "{turns}");
        assert_eq!(crossings, 2 * KNOT_Q as usize);
        // Analytic normals agree with freshly computed smooth ones.
        let mut fresh = m.clone();
        fresh.normals.clear();
        fresh.validate_and_repair();
        let agree = m
            .normals
            .iter()
            .zip(&fresh.normals)
            .filter(|(a, b)| a.dot(**b) > 0.999)
            .count();
        assert!(agree as f32 > 0.99 * m.vertex_count() as f32, "{agree}");
    }

    #[test]
    fn plane_and_quad() {
        let p = plane(4.0, 8);
        check_common("plane", &p);
        assert!(p.normals.iter().all(|n| *n == Vec3::Y));
        assert_eq!(p.edge_counts().1, 4 * 8);
        assert_eq!(p.euler_characteristic(), 1);
        assert!((p.area() - 16.0).abs() < 1e-4);
        let q = quad(1.0);
        assert_eq!((q.vertex_count(), q.triangle_count()), (4, 2));
        assert!(
            q.tangents
                .iter()
                .all(|t| t.truncate().abs_diff_eq(Vec3::X, 1e-6))
        );
    }
}
