//! Loop subdivision (Loop 1987, "Smooth subdivision surfaces based on
//! triangles", M.S. thesis, University of Utah), used to grow small meshes
//! into large ones for benchmarks (the bunny to ~120 K vertices in three
//! steps).
//!
//! # Rules
//! One step splits every triangle into four. With the mesh **welded by
//! position** for topology (so uv seams, where vertices are split, move
//! together and open no cracks):
//!
//! * **edge point** of an interior edge `(a, b)` with opposite vertices
//!   `c, d`: `3/8 (a + b) + 1/8 (c + d)`; of a boundary or non-manifold edge:
//!   the midpoint `(a + b)/2`.
//! * **vertex point** of an interior vertex of valence `n` with neighbours
//!   `q_i`: `(1 − nβ) v + β Σ q_i`, `β = (5/8 − (3/8 + ¼ cos(2π/n))²)/n`
//!   (Loop's original weights); of a boundary vertex with boundary
//!   neighbours `q₀, q₁`: `3/4 v + 1/8 (q₀ + q₁)`; a vertex on a
//!   non-manifold edge or with other than two boundary neighbours stays put.
//!
//! uvs are interpolated linearly (edge midpoints, vertices kept), so texture
//! seams stay seams. Normals are recomputed (smooth) and tangents recomputed
//! when uvs exist. Vertex count: `V' = V + E` (≈ 4 V for a closed mesh),
//! triangles `F' = 4 F`; the Euler characteristic is preserved.

use crate::mesh::Mesh;
use glam::{Vec2, Vec3};
use std::collections::{HashMap, HashSet};

/// Loop's vertex weight β for valence `n`.
#[must_use]
pub fn loop_beta(n: usize) -> f32 {
    let n = n as f64;
    let c = 3.0 / 8.0 + 0.25 * (std::f64::consts::TAU / n).cos();
    ((5.0 / 8.0 - c * c) / n) as f32
}

impl Mesh {
    /// One step of Loop subdivision (module docs). Expects valid indices
    /// (run [`Mesh::validate_and_repair`] first); returns the new mesh with
    /// smooth normals (and tangents when uvs exist).
    #[must_use]
    pub fn subdivide(&self) -> Mesh {
        let nv = self.positions.len();
        // Weld by exact position for topology.
        let mut group_of_pos: HashMap<[u32; 3], u32> = HashMap::with_capacity(nv);
        let mut weld = Vec::with_capacity(nv);
        let mut group_pos: Vec<Vec3> = Vec::new();
        for p in &self.positions {
            let key = p.to_array().map(|x| if x == 0.0 { 0 } else { x.to_bits() });
            let next = group_pos.len() as u32;
            let g = *group_of_pos.entry(key).or_insert_with(|| {
                group_pos.push(*p);
                next
            });
            weld.push(g);
        }
        let ng = group_pos.len();

        // Welded edges: opposite vertices (first two) and use count.
        #[derive(Clone, Copy)]
        struct EdgeInfo {
            opp: [u32; 2],
            count: u32,
        }
        let mut wedges: HashMap<(u32, u32), EdgeInfo> =
            HashMap::with_capacity(self.indices.len() * 2);
        for tri in &self.indices {
            let w = tri.map(|i| weld[i as usize]);
            for k in 0..3 {
                let (a, b, c) = (w[k], w[(k + 1) % 3], w[(k + 2) % 3]);
                let e = wedges.entry((a.min(b), a.max(b))).or_insert(EdgeInfo {
                    opp: [u32::MAX; 2],
                    count: 0,
                });
                if (e.count as usize) < 2 {
                    e.opp[e.count as usize] = c;
                }
                e.count += 1;
            }
        }

        // Vertex points per welded group.
        let mut nb_sum = vec![Vec3::ZERO; ng];
        let mut valence = vec![0u32; ng];
        let mut bnd_sum = vec![Vec3::ZERO; ng];
        let mut bnd_count = vec![0u32; ng];
        let mut nonmanifold = vec![false; ng];
        for (&(a, b), e) in &wedges {
            let (ua, ub) = (a as usize, b as usize);
            nb_sum[ua] += group_pos[ub];
            nb_sum[ub] += group_pos[ua];
            valence[ua] += 1;
            valence[ub] += 1;
            match e.count {
                1 => {
                    bnd_sum[ua] += group_pos[ub];
                    bnd_sum[ub] += group_pos[ua];
                    bnd_count[ua] += 1;
                    bnd_count[ub] += 1;
                }
                2 => {}
                _ => {
                    nonmanifold[ua] = true;
                    nonmanifold[ub] = true;
                }
            }
        }
        let new_group_pos: Vec<Vec3> = (0..ng)
            .map(|g| {
                let v = group_pos[g];
                if nonmanifold[g] {
                    v
                } else if bnd_count[g] > 0 {
                    if bnd_count[g] == 2 {
                        0.75 * v + 0.125 * bnd_sum[g]
                    } else {
                        v
                    }
                } else if valence[g] >= 3 {
                    let n = valence[g] as usize;
                    let beta = loop_beta(n);
                    (1.0 - n as f32 * beta) * v + beta * nb_sum[g]
                } else {
                    v
                }
            })
            .collect();

        let has_uv = self.uvs.len() == nv;
        let mut out = Mesh {
            positions: weld.iter().map(|&g| new_group_pos[g as usize]).collect(),
            normals: Vec::new(),
            uvs: if has_uv { self.uvs.clone() } else { Vec::new() },
            tangents: Vec::new(),
            indices: Vec::with_capacity(self.indices.len() * 4),
        };
        // Edge points per unwelded edge (shared by the triangles that share
        // the vertex pair); their position comes from the welded edge.
        let mut edge_vertex: HashMap<(u32, u32), u32> =
            HashMap::with_capacity(self.indices.len() * 2);
        let mut edge_point = |a: u32, b: u32, out: &mut Mesh| -> u32 {
            let key = (a.min(b), a.max(b));
            *edge_vertex.entry(key).or_insert_with(|| {
                let (wa, wb) = (weld[a as usize], weld[b as usize]);
                let e = wedges[&(wa.min(wb), wa.max(wb))];
                let (pa, pb) = (group_pos[wa as usize], group_pos[wb as usize]);
                let p = if e.count == 2 {
                    0.375 * (pa + pb)
                        + 0.125 * (group_pos[e.opp[0] as usize] + group_pos[e.opp[1] as usize])
                } else {
                    0.5 * (pa + pb)
                };
                out.positions.push(p);
                if has_uv {
                    let uv: Vec2 = 0.5 * (self.uvs[a as usize] + self.uvs[b as usize]);
                    out.uvs.push(uv);
                }
                (out.positions.len() - 1) as u32
            })
        };
        for &[a, b, c] in &self.indices {
            let ab = edge_point(a, b, &mut out);
            let bc = edge_point(b, c, &mut out);
            let ca = edge_point(c, a, &mut out);
            out.indices
                .extend_from_slice(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        out.validate_and_repair();
        out
    }

    /// Subdivides `levels` times.
    #[must_use]
    pub fn subdivided(&self, levels: u32) -> Mesh {
        let mut m = self.clone();
        for _ in 0..levels {
            m = m.subdivide();
        }
        m
    }

    /// Subdivides until the mesh has at least `target` vertices (at most
    /// `max_levels` steps); returns the mesh and the number of steps taken.
    /// Each step multiplies the vertex count by about four, so the result
    /// has between `target` and ~4 `target` vertices.
    #[must_use]
    pub fn subdivide_to_vertices(&self, target: usize, max_levels: u32) -> (Mesh, u32) {
        let mut m = self.clone();
        let mut levels = 0;
        while m.vertex_count() < target && levels < max_levels && !m.indices.is_empty() {
            m = m.subdivide();
            levels += 1;
        }
        (m, levels)
    }

    /// One step of midpoint subdivision: every triangle split into four at its
    /// edge midpoints, the new vertex normal the renormalized mean of the edge's
    /// two normals, its uv the mean of theirs, its tangent the renormalized
    /// mean of theirs with the first end's handedness. The surface is
    /// unchanged, and the shading-normal field (barycentric blend of vertex
    /// normals, normalized — what the reference renderer shades with) is
    /// unchanged up to the renormalization of the new normals (second order
    /// in the angle between neighbouring normals); uvs, affine over each
    /// triangle, are exact. A mesh without one normal (uv, tangent) per
    /// vertex gets none.
    #[must_use]
    pub fn subdivide_midpoint(&self) -> Mesh {
        let mesh = self;
        let every = |len: usize| len == mesh.positions.len();
        let (has_n, has_uv, has_t) = (
            every(mesh.normals.len()),
            every(mesh.uvs.len()),
            every(mesh.tangents.len()),
        );
        let mut out = Mesh {
            positions: mesh.positions.clone(),
            normals: if has_n {
                mesh.normals.clone()
            } else {
                Vec::new()
            },
            uvs: if has_uv { mesh.uvs.clone() } else { Vec::new() },
            tangents: if has_t {
                mesh.tangents.clone()
            } else {
                Vec::new()
            },
            indices: Vec::with_capacity(mesh.indices.len() * 4),
        };
        let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.indices.len() * 2);
        let mut edge = |a: u32, b: u32, out: &mut Mesh| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (a, b) = (a as usize, b as usize);
                out.positions
                    .push(0.5 * (mesh.positions[a] + mesh.positions[b]));
                if has_n {
                    let (na, nb) = (mesh.normals[a], mesh.normals[b]);
                    out.normals.push((na + nb).normalize_or(na));
                }
                if has_uv {
                    out.uvs.push(0.5 * (mesh.uvs[a] + mesh.uvs[b]));
                }
                if has_t {
                    let (ta, tb) = (mesh.tangents[a], mesh.tangents[b]);
                    let xyz = (ta.truncate() + tb.truncate()).normalize_or(ta.truncate());
                    out.tangents.push(xyz.extend(ta.w));
                }
                (out.positions.len() - 1) as u32
            })
        };
        for &[a, b, c] in &mesh.indices {
            let ab = edge(a, b, &mut out);
            let bc = edge(b, c, &mut out);
            let ca = edge(c, a, &mut out);
            out.indices
                .extend_from_slice(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        out
    }

    /// Vertex count after one [`Mesh::subdivide`] step: one new vertex per
    /// distinct index edge.
    #[must_use]
    pub fn loop_vertex_count(&self) -> usize {
        let mut edges: HashSet<(u32, u32)> = HashSet::with_capacity(self.indices.len() * 2);
        for tri in &self.indices {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                edges.insert((a.min(b), a.max(b)));
            }
        }
        self.positions.len() + edges.len()
    }

    /// A mesh of exactly `target` vertices (when `target` ≥ the current count,
    /// else a clone): Loop subdivision while a whole step stays within
    /// `target`, then [`Mesh::bisect_longest_edges_to`] for the rest. Used to
    /// give benchmarks the vertex counts they name (the bunny at 30 K, 50 K,
    /// 100 K, 120 K vertices), which whole Loop steps (×≈4) cannot hit.
    #[must_use]
    pub fn refine_to_vertices(&self, target: usize) -> Mesh {
        let mut m = self.clone();
        while !m.indices.is_empty() && m.loop_vertex_count() <= target {
            m = m.subdivide();
        }
        m.bisect_longest_edges_to(target);
        m
    }

    /// Adds vertices up to `target` by splitting the longest edges at their
    /// midpoints (each split turns the one or two triangles on the edge into
    /// two or four; normals are the normalized mean of the endpoints', uvs the
    /// mean; tangents are recomputed). Edges are matched by position, so an
    /// edge on a uv seam splits on both sides and opens no crack; such an edge
    /// adds one vertex per side. Stops early only when no edge is left to
    /// split without passing `target`. Triangles with one edge split per pass,
    /// longest first, so the result stays a conforming triangulation.
    pub fn bisect_longest_edges_to(&mut self, target: usize) {
        type PosKey = [u32; 3];
        // Squared length and the (triangle, local edge) pairs on the edge.
        type EdgeUses = (f32, Vec<(u32, u8)>);
        let key =
            |p: Vec3| -> PosKey { p.to_array().map(|x| if x == 0.0 { 0 } else { x.to_bits() }) };
        let has_normals = self.normals.len() == self.positions.len();
        let has_uvs = self.uvs.len() == self.positions.len();
        while self.positions.len() < target {
            // Geometric edges: squared length and the (triangle, local edge) uses.
            let mut edges: HashMap<(PosKey, PosKey), EdgeUses> =
                HashMap::with_capacity(self.indices.len() * 2);
            for (t, tri) in self.indices.iter().enumerate() {
                for k in 0..3u8 {
                    let (a, b) = (tri[k as usize], tri[(k as usize + 1) % 3]);
                    let (pa, pb) = (self.positions[a as usize], self.positions[b as usize]);
                    let (ka, kb) = (key(pa), key(pb));
                    let e = edges
                        .entry(if ka < kb { (ka, kb) } else { (kb, ka) })
                        .or_insert_with(|| (pa.distance_squared(pb), Vec::new()));
                    e.1.push((t as u32, k));
                }
            }
            let mut list: Vec<EdgeUses> = edges.into_values().collect();
            list.sort_by(|a, b| b.0.total_cmp(&a.0));
            let mut used = vec![false; self.indices.len()];
            let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
            let mut splits: Vec<(u32, u8, u32)> = Vec::new();
            for (len2, uses) in list {
                if self.positions.len() >= target {
                    break;
                }
                if len2 <= 0.0 || uses.iter().any(|&(t, _)| used[t as usize]) {
                    continue;
                }
                let pair = |&(t, k): &(u32, u8)| {
                    let tri = self.indices[t as usize];
                    let (a, b) = (tri[k as usize], tri[(k as usize + 1) % 3]);
                    (a.min(b), a.max(b))
                };
                let mut pairs: Vec<(u32, u32)> = uses.iter().map(pair).collect();
                pairs.sort_unstable();
                pairs.dedup();
                if self.positions.len() + pairs.len() > target {
                    continue;
                }
                for u in &uses {
                    used[u.0 as usize] = true;
                    let (a, b) = pair(u);
                    let m = *midpoint.entry((a, b)).or_insert_with(|| {
                        let (ia, ib) = (a as usize, b as usize);
                        self.positions
                            .push(0.5 * (self.positions[ia] + self.positions[ib]));
                        if has_normals {
                            let n = self.normals[ia] + self.normals[ib];
                            self.normals
                                .push(n.try_normalize().unwrap_or(self.normals[ia]));
                        }
                        if has_uvs {
                            self.uvs.push(0.5 * (self.uvs[ia] + self.uvs[ib]));
                        }
                        (self.positions.len() - 1) as u32
                    });
                    splits.push((u.0, u.1, m));
                }
            }
            if splits.is_empty() {
                break;
            }
            for (t, k, m) in splits {
                let tri = self.indices[t as usize];
                let k = k as usize;
                let (v0, v1, v2) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
                self.indices[t as usize] = [v0, m, v2];
                self.indices.push([m, v1, v2]);
            }
        }
        if !self.tangents.is_empty() {
            self.tangents = self.compute_tangents();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    #[test]
    fn counts_and_euler_characteristic_are_preserved() {
        for (name, m, chi) in [
            ("icosphere", shapes::icosphere(1.0, 1), 2),
            ("uv_sphere", shapes::uv_sphere(1.0, 16, 8), 2),
            ("torus", shapes::torus(1.0, 0.3, 16, 8), 0),
            ("plane", shapes::plane(2.0, 3), 1),
        ] {
            assert_eq!(m.euler_characteristic(), chi, "{name} before");
            let (e, boundary) = m.edge_counts();
            let s = m.subdivide();
            assert_eq!(s.triangle_count(), 4 * m.triangle_count(), "{name}");
            assert_eq!(s.euler_characteristic(), chi, "{name} after");
            let (_, b2) = s.edge_counts();
            assert_eq!(b2, 2 * boundary, "{name}: each boundary edge splits in two");
            assert!(s.try_validate().is_ok(), "{name}");
            if name == "icosphere" {
                assert_eq!(s.vertex_count(), m.vertex_count() + e);
            }
        }
    }

    #[test]
    fn icosahedron_vertex_rule_matches_closed_form() {
        // For the unit icosahedron every vertex has valence 5 and its
        // neighbours sum to √5 v (they lie at angle acos(1/√5) around v),
        // so the vertex point is (1 − 5β + √5 β) v.
        let ico = shapes::icosphere(1.0, 0);
        let s = ico.subdivide();
        let beta = loop_beta(5);
        let want = 1.0 - 5.0 * beta + 5f32.sqrt() * beta;
        for i in 0..ico.vertex_count() {
            let r = s.positions[i].length();
            assert!(
                (r - want).abs() < 1e-5,
                "vertex {i}: radius {r} vs closed form {want}"
            );
            assert!(
                s.positions[i]
                    .normalize()
                    .abs_diff_eq(ico.positions[i], 1e-5)
            );
        }
        // Edge points: 3/8(a+b) + 1/8(c+d); for the icosahedron the radius
        // follows from the geometry too — check against a direct evaluation.
        let [a, b, c] = ico.indices[0].map(|i| ico.positions[i as usize]);
        let d = ico
            .indices
            .iter()
            .find_map(|t| {
                let has = |v: Vec3| t.iter().any(|&i| ico.positions[i as usize] == v);
                (has(a) && has(b) && !has(c)).then(|| {
                    t.iter()
                        .map(|&i| ico.positions[i as usize])
                        .find(|&p| p != a && p != b)
                        .unwrap()
                })
            })
            .unwrap();
        let want = 0.375 * (a + b) + 0.125 * (c + d);
        assert!(
            s.positions.iter().any(|p| p.abs_diff_eq(want, 1e-6)),
            "edge point {want} missing"
        );
    }

    #[test]
    fn affine_invariance_keeps_a_flat_grid_flat() {
        let mut m = shapes::plane(2.0, 4);
        let xf = glam::Affine3A::from_rotation_x(0.4)
            * glam::Affine3A::from_translation(Vec3::new(0.1, 2.0, -3.0));
        m.transform(xf);
        let n = m.normals[0];
        let p0 = m.positions[0];
        let s = m.subdivided(2);
        for p in &s.positions {
            assert!((p - p0).dot(n).abs() < 1e-5, "point {p} left the plane");
        }
        assert!(s.normals.iter().all(|x| x.abs_diff_eq(n, 1e-5)));
        assert_eq!(s.tangents.len(), s.vertex_count());
    }

    #[test]
    fn midpoint_subdivision_carries_uvs_and_tangents() {
        // A tilted, curved-normal patch: uvs are affine in the grid, so the
        // midpoints' uvs are the exact uvs of their positions.
        let mut m = shapes::plane(2.0, 3);
        m.transform(glam::Affine3A::from_rotation_z(0.3));
        let (p0, n0) = (m.positions[0], m.normals[0]);
        let uv_at = |p: Vec3, m: &Mesh| {
            // Solve for the affine map from the first triangle.
            let [a, b, c] = m.indices[0].map(|i| i as usize);
            let (e1, e2) = (
                m.positions[b] - m.positions[a],
                m.positions[c] - m.positions[a],
            );
            let d = p - m.positions[a];
            let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let det = d11 * d22 - d12 * d12;
            let (x, y) = (
                (d22 * d.dot(e1) - d12 * d.dot(e2)) / det,
                (d11 * d.dot(e2) - d12 * d.dot(e1)) / det,
            );
            m.uvs[a] + x * (m.uvs[b] - m.uvs[a]) + y * (m.uvs[c] - m.uvs[a])
        };
        let s = m.subdivide_midpoint().subdivide_midpoint();
        assert_eq!(s.vertex_count(), 13 * 13);
        assert_eq!(
            (s.uvs.len(), s.tangents.len()),
            (s.vertex_count(), s.vertex_count())
        );
        for (i, p) in s.positions.iter().enumerate() {
            assert!((*p - p0).dot(n0).abs() < 1e-5, "{p}");
            assert!(
                s.uvs[i].abs_diff_eq(uv_at(*p, &m), 1e-5),
                "{i}: {}",
                s.uvs[i]
            );
            assert!(s.tangents[i].abs_diff_eq(m.tangents[0], 1e-5), "{i}");
        }
        // Without uvs and tangents the result has none.
        let mut bare = m.clone();
        bare.uvs.clear();
        bare.tangents.clear();
        let s = bare.subdivide_midpoint();
        assert!(s.uvs.is_empty() && s.tangents.is_empty());
        assert_eq!(s.normals.len(), s.vertex_count());
    }

    #[test]
    fn seams_do_not_open_cracks() {
        // The uv sphere has a seam column and split pole vertices; after two
        // steps the welded mesh must still be closed.
        let s = shapes::uv_sphere(1.0, 12, 6).subdivided(2);
        assert_eq!(s.edge_counts().1, 0);
        assert_eq!(s.euler_characteristic(), 2);
        for p in &s.positions {
            assert!(p.length() > 0.85 && p.length() <= 1.0 + 1e-5, "{p}");
        }
    }

    #[test]
    fn subdivide_to_vertices_reaches_target() {
        let ico = shapes::icosphere(1.0, 0);
        let (m, levels) = ico.subdivide_to_vertices(1000, 8);
        assert_eq!(levels, 4);
        assert_eq!(m.vertex_count(), 10 * 4usize.pow(4) + 2);
        let (m, levels) = ico.subdivide_to_vertices(5, 8);
        assert_eq!((levels, m.vertex_count()), (0, 12));
    }

    #[test]
    fn loop_vertex_count_predicts_subdivide() {
        for m in [
            shapes::icosphere(1.0, 1),
            shapes::uv_sphere(1.0, 12, 6),
            shapes::plane(2.0, 3),
        ] {
            assert_eq!(m.subdivide().vertex_count(), m.loop_vertex_count());
        }
    }

    #[test]
    fn refine_to_vertices_hits_the_count_and_keeps_the_surface() {
        // A uv sphere has a seam (split vertices) and pole fans.
        let s = shapes::uv_sphere(1.0, 24, 12);
        let area = s.area();
        for target in [s.vertex_count(), 1000, 3001, 12_345] {
            let r = s.refine_to_vertices(target);
            assert_eq!(r.vertex_count(), target, "target {target}");
            r.try_validate().unwrap();
            assert_eq!(r.normals.len(), target);
            assert_eq!(r.uvs.len(), target);
            // Closed and crack-free: welded by position, every edge has two triangles.
            let (welded_boundary, chi) = {
                let mut w = r.clone();
                let mut first: HashMap<[u32; 3], u32> = HashMap::new();
                let remap: Vec<u32> = w
                    .positions
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        *first
                            .entry(p.to_array().map(f32::to_bits))
                            .or_insert(i as u32)
                    })
                    .collect();
                for tri in &mut w.indices {
                    *tri = tri.map(|i| remap[i as usize]);
                }
                (w.edge_counts().1, w.euler_characteristic())
            };
            assert_eq!(welded_boundary, 0, "target {target}: cracks");
            assert_eq!(chi, 2, "target {target}: welded Euler characteristic");
            // Loop steps shrink the sphere a little, bisection keeps the surface.
            for p in &r.positions {
                assert!(p.length() <= 1.0 + 1e-5 && p.length() > 0.9, "{p}");
            }
            let ratio = r.area() / area;
            assert!((0.85..=1.0 + 1e-5).contains(&ratio), "area ratio {ratio}");
        }
        // Below the current count: unchanged.
        assert_eq!(s.refine_to_vertices(10).vertex_count(), s.vertex_count());
    }
}
