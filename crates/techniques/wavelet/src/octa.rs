//! Octahedral and hemi-octahedral maps (Praun & Hoppe 2003, as used by
//! wavelet-rotation-2006 §3 "Parametrization of Spherical Functions"), the
//! normal tessellation and the local-frame rule of the wavelet technique.
//!
//! # Maps
//! Map coordinates `(u, v)` ∈ \[0,1\]², `u` along columns, `v` along rows;
//! texel `(col, row)` covers `[col/n, (col+1)/n) × [row/n, (row+1)/n)` and has
//! index `row * n + col` (the layout of `relight_sphere::Param::Octahedral`:
//! +Z at the centre of the square).
//!
//! * **Octahedral** (whole sphere, source lighting, world frame):
//!   `(x, y) = (2u − 1, 2v − 1)`; for `|x| + |y| ≤ 1` the point on the unit
//!   L1 octahedron is `P = (x, y, 1 − |x| − |y|)` (upper hemisphere), outside it
//!   the triangle is folded: `P = (sgn x (1 − |y|), sgn y (1 − |x|), |x| + |y| − 1)`.
//!   Direction `ω = P / |P|`.
//! * **Hemi-octahedral** (upper hemisphere z ≥ 0 of a local frame, target
//!   lighting and BRDF slices): the inner diamond turned by 45° and stretched to
//!   the square: `(a, b) = (2u − 1, 2v − 1)`, `x = (a + b)/2`, `y = (b − a)/2`,
//!   `P = (x, y, 1 − |x| − |y|)`.
//!
//! The formulas live in `relight_sphere::param` (`Param::Octahedral`,
//! `Param::HemiOctahedral`, `Param::uv_density`); the functions here are the
//! technique's `(u, v)`-tuple front end to them.
//!
//! # Exact area element
//! On an octahedron face `dω = (P·n̂) / |P|³ dA` with `P·n̂ = 1/√3` and
//! `dA = √3 dx dy`, so `dω = dx dy / |P|³`. Hence the densities
//! `dω / (du dv) = 4 / |P|³` (octahedral) and `2 / |P|³` (hemi-octahedral);
//! the bakes weight every sub-texel sample by them.
//!
//! # Local frames
//! The rotation matrices are indexed by the normal only (paper §2), so the
//! tangent must be a function of the normal. [`shading_frame`] uses the
//! *minimal rotation* taking world +Y to the normal `n`, applied to the base
//! frame (x = +X, y = −Z, z = +Y). It is smooth everywhere except at the single
//! point `n = −Y` (normals facing straight down, the least visible ones),
//! unlike `Frame::from_z` (Duff et al. 2017), which jumps across the half-plane
//! z < 0, y = 0 — a visible meridian when local lighting is interpolated
//! between sampled normals.

use glam::{DVec2, DVec3, Vec3};
use relight_sphere::param::{
    hemi_octahedral_from_dir, hemi_octahedral_from_dir_f32, octahedral_from_dir,
    octahedral_from_dir_f32, octahedron_from_hemi_octahedral, octahedron_from_octahedral,
};
use relight_sphere::{Frame, Param};

/// Direction (unit) through the octahedral map point `(u, v)`.
#[inline]
#[must_use]
pub fn oct_dir_from_uv(u: f64, v: f64) -> DVec3 {
    oct_point(u, v).normalize()
}

/// Point on the L1 unit octahedron for the octahedral map point `(u, v)`.
#[inline]
#[must_use]
pub fn oct_point(u: f64, v: f64) -> DVec3 {
    octahedron_from_octahedral(DVec2::new(2.0 * u - 1.0, 2.0 * v - 1.0))
}

/// Octahedral map point of a (non-zero) direction; inverse of [`oct_dir_from_uv`].
#[inline]
#[must_use]
pub fn oct_uv_from_dir(d: DVec3) -> (f64, f64) {
    let p = octahedral_from_dir(d) * 0.5 + 0.5;
    (p.x, p.y)
}

/// `dω / (du dv)` of the octahedral map at `(u, v)` (sr per unit map area).
#[inline]
#[must_use]
pub fn oct_density(u: f64, v: f64) -> f64 {
    Param::Octahedral { n: 1 }.uv_density(DVec2::new(u, v))
}

/// Point on the L1 octahedron (z ≥ 0) for the hemi-octahedral map point `(u, v)`.
#[inline]
#[must_use]
pub fn hemi_point(u: f64, v: f64) -> DVec3 {
    octahedron_from_hemi_octahedral(DVec2::new(2.0 * u - 1.0, 2.0 * v - 1.0))
}

/// Local direction (unit, z ≥ 0) through the hemi-octahedral map point `(u, v)`.
#[inline]
#[must_use]
pub fn hemi_dir_from_uv(u: f64, v: f64) -> DVec3 {
    hemi_point(u, v).normalize()
}

/// Hemi-octahedral map point of a local direction; directions below the
/// horizon are projected onto it (z clamped to 0).
#[inline]
#[must_use]
pub fn hemi_uv_from_dir(d: DVec3) -> (f64, f64) {
    let d = DVec3::new(d.x, d.y, d.z.max(0.0));
    if d.x.abs() + d.y.abs() + d.z < 1e-300 {
        return (0.5, 0.5);
    }
    let q = hemi_octahedral_from_dir(d) * 0.5 + 0.5;
    (q.x, q.y)
}

/// `dω / (du dv)` of the hemi-octahedral map at `(u, v)`.
#[inline]
#[must_use]
pub fn hemi_density(u: f64, v: f64) -> f64 {
    Param::HemiOctahedral { n: 1 }.uv_density(DVec2::new(u, v))
}

/// Texel index of map point `(u, v)` on an `n × n` grid.
#[inline]
#[must_use]
pub fn texel_of(u: f64, v: f64, n: usize) -> usize {
    let c = ((u * n as f64) as usize).min(n - 1);
    let r = ((v * n as f64) as usize).min(n - 1);
    r * n + c
}

/// The local shading frame of the normal `n` (unit, world): see the module
/// docs. `frame.z == n`; `world_from_local = [x y z]`.
#[must_use]
pub fn shading_frame(n: Vec3) -> Frame {
    let f = shading_frame_f64(n.as_dvec3());
    Frame {
        x: f[0].as_vec3(),
        y: f[1].as_vec3(),
        z: n,
    }
}

/// [`shading_frame`] in f32 arithmetic (the per-vertex hot path).
#[inline]
#[must_use]
pub fn shading_frame_fast(n: Vec3) -> Frame {
    let k = 1.0 + n.y;
    if k < 1e-6 {
        return shading_frame(n);
    }
    let r = 1.0 / k;
    let x = Vec3::new(n.y + n.z * n.z * r, -n.x, -n.x * n.z * r);
    let y = Vec3::new(n.x * n.z * r, n.z, -n.y - n.x * n.x * r);
    Frame { x, y, z: n }
}

/// Octahedral map point of a direction in f32 (hot path of [`normal_bilinear`]).
#[inline]
#[must_use]
pub fn oct_uv_from_dir_f32(d: Vec3) -> (f32, f32) {
    let p = octahedral_from_dir_f32(d) * 0.5 + 0.5;
    (p.x, p.y)
}

/// Hemi-octahedral map point of a local direction in f32 (z clamped to ≥ 0).
#[inline]
#[must_use]
pub fn hemi_uv_from_dir_f32(d: Vec3) -> (f32, f32) {
    let d = Vec3::new(d.x, d.y, d.z.max(0.0));
    if d.x.abs() + d.y.abs() + d.z < 1e-30 {
        return (0.5, 0.5);
    }
    let q = hemi_octahedral_from_dir_f32(d) * 0.5 + 0.5;
    (q.x, q.y)
}

/// [`shading_frame`] in f64: `[x, y, z]` axes.
#[must_use]
pub fn shading_frame_f64(n: DVec3) -> [DVec3; 3] {
    let (bx, by, bz) = (n.x, n.y, n.z);
    let k = 1.0 + by;
    if k < 1e-9 {
        // n = −Y: limit chosen so that x × y = z.
        return [DVec3::X, DVec3::Z, n];
    }
    let x = DVec3::new(by + bz * bz / k, -bx, -bx * bz / k);
    let y = DVec3::new(bx * bz / k, bz, -by - bx * bx / k);
    [x, y, n]
}

/// Octahedral texel neighbour with the fold of the map's borders: an
/// out-of-range column/row (−1 or n) is reflected back and the other
/// coordinate mirrored, which is the texel adjacent on the sphere.
#[inline]
#[must_use]
pub fn oct_wrap(mut x: i64, mut y: i64, n: i64) -> (usize, usize) {
    if x < 0 {
        x = -1 - x;
        y = n - 1 - y;
    } else if x >= n {
        x = 2 * n - 1 - x;
        y = n - 1 - y;
    }
    if y < 0 {
        y = -1 - y;
        x = n - 1 - x;
    } else if y >= n {
        y = 2 * n - 1 - y;
        x = n - 1 - x;
    }
    (x.clamp(0, n - 1) as usize, y.clamp(0, n - 1) as usize)
}

/// The four sampled normals (texel centres of the `ntess × ntess` octahedral
/// grid) around direction `d` and their bilinear weights (sum 1), continuous
/// across the map's folds.
#[inline]
#[must_use]
pub fn normal_bilinear(d: Vec3, ntess: usize) -> ([u32; 4], [f32; 4]) {
    let (u, v) = oct_uv_from_dir_f32(d);
    let fx = u * ntess as f32 - 0.5;
    let fy = v * ntess as f32 - 0.5;
    let x0 = fx.floor();
    let y0 = fy.floor();
    let tx = fx - x0;
    let ty = fy - y0;
    let (x0, y0, n) = (x0 as i64, y0 as i64, ntess as i64);
    let idx = |x: i64, y: i64| {
        let (a, b) = oct_wrap(x, y, n);
        (b * ntess + a) as u32
    };
    (
        [
            idx(x0, y0),
            idx(x0 + 1, y0),
            idx(x0, y0 + 1),
            idx(x0 + 1, y0 + 1),
        ],
        [
            (1.0 - tx) * (1.0 - ty),
            tx * (1.0 - ty),
            (1.0 - tx) * ty,
            tx * ty,
        ],
    )
}

/// Sampled normal `k` of the `ntess × ntess` grid (texel centre).
#[must_use]
pub fn grid_normal(k: usize, ntess: usize) -> DVec3 {
    let (c, r) = (k % ntess, k / ntess);
    oct_dir_from_uv(
        (c as f64 + 0.5) / ntess as f64,
        (r as f64 + 0.5) / ntess as f64,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        for i in 0..64 {
            for j in 0..64 {
                let (u, v) = ((i as f64 + 0.37) / 64.0, (j as f64 + 0.61) / 64.0);
                let d = oct_dir_from_uv(u, v);
                let (u2, v2) = oct_uv_from_dir(d);
                assert!(
                    (u - u2).abs() < 1e-9 && (v - v2).abs() < 1e-9,
                    "oct ({u},{v}) -> ({u2},{v2})"
                );
                let h = hemi_dir_from_uv(u, v);
                assert!(h.z >= 0.0);
                let (u3, v3) = hemi_uv_from_dir(h);
                assert!(
                    (u - u3).abs() < 1e-9 && (v - v3).abs() < 1e-9,
                    "hemi ({u},{v}) -> ({u3},{v3})"
                );
            }
        }
    }

    #[test]
    fn densities_integrate_to_the_sphere_and_hemisphere() {
        // Midpoint quadrature of the analytic Jacobians (second way: they are
        // derived from the octahedron's face geometry).
        let q = 1024;
        let (mut s, mut h) = (0.0, 0.0);
        for i in 0..q {
            for j in 0..q {
                let (u, v) = ((i as f64 + 0.5) / q as f64, (j as f64 + 0.5) / q as f64);
                s += oct_density(u, v) / (q * q) as f64;
                h += hemi_density(u, v) / (q * q) as f64;
            }
        }
        let pi = std::f64::consts::PI;
        assert!((s - 4.0 * pi).abs() < 1e-4, "octahedral: {s} vs 4π");
        assert!((h - 2.0 * pi).abs() < 1e-4, "hemi-octahedral: {h} vs 2π");
        // Finite-difference Jacobians agree with the formulas (points inside
        // the inner diamond and on a folded triangle).
        let e = 1e-6;
        for (u, v) in [(0.3, 0.6), (0.1, 0.95), (0.85, 0.2)] {
            let d0 = oct_dir_from_uv(u, v);
            let fd = ((oct_dir_from_uv(u + e, v) - d0) / e)
                .cross((oct_dir_from_uv(u, v + e) - d0) / e)
                .length();
            assert!(
                (fd - oct_density(u, v)).abs() < 1e-4 * fd,
                "oct ({u},{v}): {fd} vs {}",
                oct_density(u, v)
            );
            let h0 = hemi_dir_from_uv(u, v);
            let fh = ((hemi_dir_from_uv(u + e, v) - h0) / e)
                .cross((hemi_dir_from_uv(u, v + e) - h0) / e)
                .length();
            assert!(
                (fh - hemi_density(u, v)).abs() < 1e-4 * fh,
                "hemi ({u},{v}): {fh} vs {}",
                hemi_density(u, v)
            );
        }
    }

    #[test]
    fn shading_frame_is_orthonormal_right_handed_and_smooth() {
        for k in 0..1024 {
            let n = grid_normal(k, 32);
            let [x, y, z] = shading_frame_f64(n);
            assert!((x.length() - 1.0).abs() < 1e-9 && (y.length() - 1.0).abs() < 1e-9);
            assert!(x.dot(y).abs() < 1e-9 && x.dot(z).abs() < 1e-9 && y.dot(z).abs() < 1e-9);
            assert!((x.cross(y) - z).length() < 1e-9);
            // Smoothness away from −Y: a small change in n moves the tangent little.
            if n.y > -0.9 {
                let n2 = (n + DVec3::new(1e-4, -2e-4, 1e-4)).normalize();
                let x2 = shading_frame_f64(n2)[0];
                assert!((x - x2).length() < 1e-2, "frame jumps at {n}");
            }
        }
    }

    #[test]
    fn normal_bilinear_reproduces_grid_normals() {
        let t = 16;
        for k in 0..t * t {
            let n = grid_normal(k, t).as_vec3();
            let (idx, w) = normal_bilinear(n, t);
            let mut best = 0;
            for c in 1..4 {
                if w[c] > w[best] {
                    best = c;
                }
            }
            assert_eq!(idx[best] as usize, k);
            assert!((w[best] - 1.0).abs() < 1e-4);
        }
        // Near the folds the four neighbours are close on the sphere.
        for d in [
            Vec3::new(0.01, 0.02, -1.0),
            Vec3::new(1.0, 0.001, -0.3),
            Vec3::new(-0.5, -0.7, -0.01),
        ] {
            let d = d.normalize();
            let (idx, _) = normal_bilinear(d, t);
            for i in idx {
                let g = grid_normal(i as usize, t).as_vec3();
                assert!(g.dot(d) > 0.95, "neighbour {g} far from {d}");
            }
        }
    }
}
