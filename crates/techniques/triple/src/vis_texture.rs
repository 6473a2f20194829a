//! Visibility textures (spherical-wavelets-triple-product-2006 §4.1, Fig. 6
//! and Table 3): an object's visibility stored per texel of a `res × res`
//! texture over its uvs instead of per vertex, so that a coarse mesh (the
//! paper's two-triangle floor) carries shadows as fine as the texture.
//!
//! Each texel centre is mapped to the surface through the triangle whose uv
//! triangle holds it (the first such triangle: charts must not overlap), its
//! position and normal interpolated barycentrically, and baked exactly as a
//! vertex ([`crate::visibility::bake_point_visibility`]: the same cells in
//! the same frame rule). Texels no triangle covers take the point of a
//! covered neighbour within [`DILATE`] texels, so that bilinear lookups at
//! chart borders read real visibility; farther ones are never read and hold
//! `V ≡ 1`. A pixel reads its four nearest texel centres bilinearly at its
//! interpolated uv (clamped to the texture, no wrap).
//!
//! # Meshes without uvs: a simple chart packer ([`Charts::pack`])
//! No parameterisation crate builds here (xatlas needs C++ bindings), so a
//! mesh without uvs gets one chart per triangle: the triangle laid flat
//! (its first edge along u, angles kept) and scaled to fit one cell of a
//! `k × k` grid, `k = ⌈√T⌉`, inside a one-texel gutter. Dilation stays
//! inside each cell, so a lookup never reads a neighbouring chart. The
//! texel density is per triangle (a small triangle gets as many texels as
//! a large one) and the cells need at least [`MIN_CELL`] texels a side:
//! `res ≥ MIN_CELL·⌈√T⌉`, else the object keeps per-vertex visibility
//! (the method warns). Per-vertex (Gouraud) shading reads each vertex at
//! its corner of the first triangle that uses it.

use glam::{Vec2, Vec3};
use relight_geom::Mesh;

/// Texels a covered texel's point is spread over, beyond the charts' edges.
pub const DILATE: usize = 2;

/// Largest texture side.
pub const MAX_RES: usize = 2048;

/// Smallest cell side of a packed chart, texels (a one-texel gutter each
/// side and at least two inside).
pub const MIN_CELL: usize = 4;

/// The uvs of the visibility texture: three per triangle.
#[derive(Clone, Debug, PartialEq)]
pub struct Charts {
    /// Corner uvs of every triangle, in `[0, 1]²`.
    pub corners: Vec<[Vec2; 3]>,
    /// Side of one packed cell in texels (dilation stays inside it); the
    /// texture side when the charts are the mesh's own uvs.
    pub cell: usize,
}

impl Charts {
    /// The mesh's own uvs (one per vertex), if it has them, else packed
    /// charts ([`Charts::pack`]); `None` when neither fits `res`.
    #[must_use]
    pub fn of(mesh: &Mesh, res: usize) -> Option<Self> {
        if res == 0 || mesh.normals.len() != mesh.positions.len() {
            return None;
        }
        if mesh.uvs.len() == mesh.positions.len() {
            return Some(Self {
                corners: mesh
                    .indices
                    .iter()
                    .map(|t| t.map(|i| mesh.uvs[i as usize]))
                    .collect(),
                cell: res,
            });
        }
        Self::pack(mesh, res)
    }

    /// One chart per triangle on a `⌈√T⌉²` grid of `res × res` texels
    /// (module docs); `None` when a cell would be under [`MIN_CELL`] texels.
    #[must_use]
    pub fn pack(mesh: &Mesh, res: usize) -> Option<Self> {
        let t = mesh.indices.len();
        let k = (t as f64).sqrt().ceil().max(1.0) as usize;
        let cell = res / k;
        if cell < MIN_CELL {
            return None;
        }
        let inner = (cell - 2) as f32;
        let r = res as f32;
        let corners = mesh
            .indices
            .iter()
            .enumerate()
            .map(|(i, tri)| {
                let [a, b, c] = tri.map(|j| mesh.positions[j as usize]);
                let e = b - a;
                let len = e.length();
                let u = if len > 0.0 { e / len } else { Vec3::X };
                let w = c - a;
                let xc = w.dot(u);
                let yc = (w - u * xc).length();
                let flat = [Vec2::ZERO, Vec2::new(len, 0.0), Vec2::new(xc, yc)];
                let lo = flat[0].min(flat[1]).min(flat[2]);
                let hi = flat[0].max(flat[1]).max(flat[2]);
                let size = (hi - lo).max_element();
                let scale = if size > 0.0 { inner / size } else { 0.0 };
                let origin = Vec2::new(((i % k) * cell + 1) as f32, ((i / k) * cell + 1) as f32);
                flat.map(|p| (origin + (p - lo) * scale) / r)
            })
            .collect();
        Some(Self { corners, cell })
    }

    /// The uv of barycentrics `l` on triangle `tri`.
    #[inline]
    #[must_use]
    pub fn uv(&self, tri: usize, l: Vec3) -> Vec2 {
        let [a, b, c] = self.corners[tri];
        a * l.x + b * l.y + c * l.z
    }

    /// One uv per vertex of `mesh`: its corner of the first triangle that
    /// uses it (vertices no triangle uses get `(0, 0)`).
    #[must_use]
    pub fn vertex_uvs(&self, mesh: &Mesh) -> Vec<Vec2> {
        let mut out = vec![None; mesh.positions.len()];
        for (t, tri) in mesh.indices.iter().enumerate() {
            for (k, &v) in tri.iter().enumerate() {
                out[v as usize].get_or_insert(self.corners[t][k]);
            }
        }
        out.into_iter().map(Option::unwrap_or_default).collect()
    }

    /// The corner uvs as bytes (for bake cache keys).
    #[must_use]
    pub fn key_bytes(&self) -> Vec<u8> {
        let mut v: Vec<u8> = self
            .corners
            .iter()
            .flat_map(|c| c.iter().flat_map(|p| p.to_array()))
            .flat_map(f32::to_le_bytes)
            .collect();
        v.extend((self.cell as u64).to_le_bytes());
        v
    }
}

/// The surface point `(position, unit normal)` of every texel centre of a
/// `res × res` texture over `charts` (module docs), row-major from
/// `uv = (0, 0)`; `None` for texels far from every chart.
///
/// Packed charts (one triangle per cell) fill their whole cell: a triangle
/// whose chart holds no texel centre seeds the texel under its centroid,
/// and dilation runs until the cell is full, so that a lookup at a sharp
/// corner (up to a texel beyond any covered centre) reads the triangle.
#[must_use]
pub fn texel_points(mesh: &Mesh, charts: &Charts, res: usize) -> Vec<Option<(Vec3, Vec3)>> {
    let mut out: Vec<Option<(Vec3, Vec3)>> = vec![None; res * res];
    let r = res as f32;
    let packed = charts.cell < res;
    for (t, tri) in mesh.indices.iter().enumerate() {
        let [a, b, c] = tri.map(|i| i as usize);
        let [ua, ub, uc] = charts.corners[t].map(|u| u * r);
        let det = (ub - ua).perp_dot(uc - ua);
        if det.abs() < 1e-12 {
            continue;
        }
        if packed {
            let m = (ua + ub + uc) / 3.0;
            let (x, y) = (m.x as usize, m.y as usize);
            if x < res && y < res {
                let p = (mesh.positions[a] + mesh.positions[b] + mesh.positions[c]) / 3.0;
                let nrm = (mesh.normals[a] + mesh.normals[b] + mesh.normals[c])
                    .normalize_or(mesh.normals[a]);
                out[y * res + x] = Some((p, nrm));
            }
        }
        let lo = ua.min(ub).min(uc);
        let hi = ua.max(ub).max(uc);
        let (x0, y0) = (
            (lo.x - 0.5).ceil().max(0.0) as usize,
            (lo.y - 0.5).ceil().max(0.0) as usize,
        );
        let (x1, y1) = (
            ((hi.x - 0.5).floor().min(r - 1.0)).max(-1.0),
            ((hi.y - 0.5).floor().min(r - 1.0)).max(-1.0),
        );
        if x1 < 0.0 || y1 < 0.0 {
            continue;
        }
        for y in y0..=y1 as usize {
            for x in x0..=x1 as usize {
                let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let l1 = (q - ua).perp_dot(uc - ua) / det;
                let l2 = (ub - ua).perp_dot(q - ua) / det;
                let l0 = 1.0 - l1 - l2;
                let eps = -1e-5;
                let seeded = packed && out[y * res + x].is_some();
                if l0 < eps || l1 < eps || l2 < eps || (out[y * res + x].is_some() && !seeded) {
                    continue;
                }
                let p = mesh.positions[a] * l0 + mesh.positions[b] * l1 + mesh.positions[c] * l2;
                let nrm = (mesh.normals[a] * l0 + mesh.normals[b] * l1 + mesh.normals[c] * l2)
                    .normalize_or(mesh.normals[a]);
                out[y * res + x] = Some((p, nrm));
            }
        }
    }
    let passes = if packed { 2 * charts.cell } else { DILATE };
    for _ in 0..passes {
        let prev = out.clone();
        for y in 0..res {
            for x in 0..res {
                if prev[y * res + x].is_some() {
                    continue;
                }
                let cell = charts.cell as i64;
                let same_cell = |nx: i64, ny: i64| {
                    nx.div_euclid(cell) == x as i64 / cell && ny.div_euclid(cell) == y as i64 / cell
                };
                let near = [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)]
                    .iter()
                    .filter_map(|(dx, dy)| {
                        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                        ((0..res as i64).contains(&nx)
                            && (0..res as i64).contains(&ny)
                            && same_cell(nx, ny))
                        .then(|| prev[ny as usize * res + nx as usize])
                        .flatten()
                    })
                    .next();
                out[y * res + x] = near;
            }
        }
    }
    out
}

/// The four texels around `uv` on a `res × res` texture and their bilinear
/// weights (clamped to the texture: no wrap).
#[inline]
#[must_use]
pub fn taps(uv: Vec2, res: usize) -> ([usize; 4], [f32; 4]) {
    let r = res as f32;
    let fx = (uv.x * r - 0.5).clamp(0.0, r - 1.0);
    let fy = (uv.y * r - 0.5).clamp(0.0, r - 1.0);
    let (x0, y0) = (fx as usize, fy as usize);
    let (x1, y1) = ((x0 + 1).min(res - 1), (y0 + 1).min(res - 1));
    let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
    (
        [y0 * res + x0, y0 * res + x1, y1 * res + x0, y1 * res + x1],
        [
            (1.0 - tx) * (1.0 - ty),
            tx * (1.0 - ty),
            (1.0 - tx) * ty,
            tx * ty,
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plane_maps_every_texel_and_taps_reproduce_linear_functions() {
        let plane = relight_geom::shapes::plane(4.0, 1);
        assert_eq!(plane.uvs.len(), plane.positions.len());
        let charts = Charts::of(&plane, 16).expect("uvs");
        assert_eq!(charts.cell, 16);
        let pts = texel_points(&plane, &charts, 16);
        assert!(pts.iter().all(Option::is_some));
        // Texel centres are the uv map's points: a linear map of uv.
        let (p00, _) = pts[0].unwrap();
        let (p10, _) = pts[1].unwrap();
        let (p01, _) = pts[16].unwrap();
        for y in 0..16 {
            for x in 0..16 {
                let (p, n) = pts[y * 16 + x].unwrap();
                let want = p00 + (p10 - p00) * x as f32 + (p01 - p00) * y as f32;
                assert!((p - want).length() < 1e-4, "{x} {y}: {p} vs {want}");
                assert!((n - Vec3::Y).length() < 1e-5);
            }
        }
        // Bilinear taps: weights sum to 1 and reproduce x + 2y.
        let f = |i: usize| (i % 16) as f32 + 2.0 * (i / 16) as f32;
        for uv in [
            Vec2::new(0.3, 0.7),
            Vec2::new(0.51, 0.02),
            Vec2::new(1.0, 1.0),
        ] {
            let (t, w) = taps(uv, 16);
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            let got: f32 = t.iter().zip(&w).map(|(&i, &w)| w * f(i)).sum();
            let fx = (uv.x * 16.0 - 0.5).clamp(0.0, 15.0);
            let fy = (uv.y * 16.0 - 0.5).clamp(0.0, 15.0);
            assert!((got - (fx + 2.0 * fy)).abs() < 1e-4, "{uv}");
        }
    }

    /// Packed charts: inside their cells with a gutter, shapes kept, every
    /// covered texel's point on its own triangle, and a lookup anywhere on
    /// a triangle reads only points of that triangle.
    #[test]
    fn packed_charts_keep_shapes_and_never_read_a_neighbour() {
        let mut mesh = relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 8, 4);
        mesh.uvs.clear();
        let t = mesh.indices.len();
        let res = 128;
        assert!(
            Charts::pack(&mesh, MIN_CELL * 2).is_none(),
            "cells too small"
        );
        let charts = Charts::of(&mesh, res).expect("packed");
        let k = (t as f64).sqrt().ceil() as usize;
        assert_eq!(charts.cell, res / k);
        let pts = texel_points(&mesh, &charts, res);
        let on_triangle = |tri: usize, p: Vec3| {
            let [a, b, c] = mesh.indices[tri].map(|i| mesh.positions[i as usize]);
            let n = (b - a).cross(c - a);
            // On the triangle's plane and within its edges (dilated texels
            // copy a covered texel's point, so they are on it too).
            (p - a).dot(n.normalize()).abs() < 1e-4
                && [(a, b), (b, c), (c, a)]
                    .iter()
                    .all(|&(u, v)| (v - u).cross(p - u).dot(n) > -1e-4 * n.length_squared())
        };
        for (tri, corners) in charts.corners.iter().enumerate() {
            let cell = charts.cell as f32 / res as f32;
            let (cx, cy) = ((tri % k) as f32 * cell, (tri / k) as f32 * cell);
            for c in corners {
                let g = 1.0 / res as f32 - 1e-6;
                assert!(c.x >= cx + g && c.x <= cx + cell - g, "{tri}: {c}");
                assert!(c.y >= cy + g && c.y <= cy + cell - g, "{tri}: {c}");
            }
            // Angles kept: uv edge ratios equal the 3D ones.
            let [a, b, c] = mesh.indices[tri].map(|i| mesh.positions[i as usize]);
            let ratio3 = (c - a).length() / (b - a).length();
            let ratio2 = (corners[2] - corners[0]).length() / (corners[1] - corners[0]).length();
            assert!((ratio3 - ratio2).abs() < 1e-3 * ratio3, "{tri}");
            // Every texel a lookup on this triangle reads holds a point of it
            // (degenerate triangles, the UV sphere's poles, cover nothing and
            // are never drawn).
            if (b - a).cross(c - a).length() < 1e-6 {
                continue;
            }
            for l in [
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::splat(1.0 / 3.0),
                Vec3::new(0.5, 0.5, 0.0),
            ] {
                let (texels, w) = taps(charts.uv(tri, l), res);
                for (&i, &w) in texels.iter().zip(&w) {
                    if w > 0.0 {
                        let (p, _) = pts[i].unwrap_or_else(|| panic!("{tri}: texel {i} empty"));
                        assert!(on_triangle(tri, p), "{tri}: texel {i} holds {p}");
                    }
                }
            }
        }
        // Per-vertex uvs: a corner of a triangle that uses the vertex.
        let vuv = charts.vertex_uvs(&mesh);
        for (v, uv) in vuv.iter().enumerate() {
            let corners: Vec<Vec2> = mesh
                .indices
                .iter()
                .enumerate()
                .flat_map(|(t, tri)| {
                    tri.iter()
                        .zip(charts.corners[t])
                        .filter(move |&(&i, _)| i as usize == v)
                        .map(|(_, c)| c)
                })
                .collect();
            assert!(
                corners.is_empty() && *uv == Vec2::ZERO || corners.contains(uv),
                "vertex {v}"
            );
        }
    }
}
