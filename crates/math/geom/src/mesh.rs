//! [`Mesh`]: an indexed triangle mesh with per-vertex attributes, its
//! validation and repair, smooth normals, tangents and rigid/affine edits.
//!
//! # Repair rules ([`Mesh::validate_and_repair`])
//! 1. Attribute arrays whose length differs from `positions.len()` are
//!    discarded (normals are then recomputed, uvs and tangents dropped).
//! 2. Triangles with an index `>= positions.len()` are dropped.
//! 3. Triangles with a non-finite corner are dropped (counted apart), then
//!    degenerate ones: a repeated index,
//!    or `|e₁ × e₂| ≤ DEGENERATE_REL · ℓ²_max`, where `ℓ_max` is the longest
//!    edge ([`DEGENERATE_REL`] = 1e-7, i.e. the triangle's height is below
//!    ~1e-7 of its longest edge, the resolution of f32 coordinates).
//! 4. Missing normals are computed as smooth, angle-weighted vertex normals
//!    (Thürmer & Wüthrich 1998, "Computing vertex normals from polygonal
//!    facets"): each incident face's unit normal weighted by the corner angle.
//!    Vertices at bit-identical positions (uv seams) share their normal.
//! 5. Present normals that are zero or non-finite are replaced by the
//!    computed smooth normal (counted in `repaired_normals`); non-unit ones
//!    are renormalised silently. Non-finite uvs are set to (0, 0) (counted in
//!    `repaired_uvs`).
//! 6. Tangents are computed when uvs exist and tangents are absent or
//!    invalid: per-triangle ∂p/∂u and ∂p/∂v accumulated per vertex (the
//!    per-vertex accumulation of MikkTSpace, Mikkelsen 2008, without its
//!    seam splitting), Gram–Schmidt orthogonalised against the normal, with
//!    the handedness sign(⟨n × t, ∂p/∂v⟩) in `w`.

use glam::{Affine3A, Mat3, Mat4, Vec2, Vec3, Vec4};
use std::collections::HashMap;
use std::fmt;

/// Relative area tolerance for degenerate triangles: a triangle is dropped
/// when `|e₁ × e₂| ≤ DEGENERATE_REL · ℓ²_max` (twice its area against its
/// longest edge squared).
pub const DEGENERATE_REL: f32 = 1e-7;

/// An indexed triangle mesh in object space (+Y up).
///
/// **Invariants** (established by [`Mesh::validate_and_repair`]): every index
/// is `< positions.len()`, no triangle is degenerate (zero area), `normals`
/// has one unit vector per vertex, `uvs`/`tangents` are empty or one per vertex
/// (uvs finite).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Unit vertex normals; empty until computed or loaded.
    pub normals: Vec<Vec3>,
    /// Texture coordinates, empty when the mesh has none.
    pub uvs: Vec<Vec2>,
    /// Tangents (xyz unit, w = handedness ±1), empty unless computed from uvs.
    pub tangents: Vec<Vec4>,
    pub indices: Vec<[u32; 3]>,
}

/// What [`Mesh::validate_and_repair`] changed, for the caller to report.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RepairReport {
    pub out_of_range_triangles: usize,
    /// Triangles dropped for a corner with a NaN or infinite coordinate.
    pub non_finite_triangles: usize,
    /// Triangles dropped for a repeated index or (near-)zero area.
    pub degenerate_triangles: usize,
    pub computed_normals: bool,
    pub repaired_normals: usize,
    /// Texture coordinates with a NaN or infinite component, set to (0, 0).
    pub repaired_uvs: usize,
    pub computed_tangents: bool,
    /// Attribute arrays discarded because their length did not match the
    /// vertex count (names: "normals", "uvs", "tangents").
    pub discarded_attributes: Vec<&'static str>,
}

impl RepairReport {
    /// True when nothing had to be fixed (computing absent normals/tangents
    /// is not a fix and does not count).
    #[must_use]
    pub fn is_clean(&self) -> bool {
        self.out_of_range_triangles == 0
            && self.non_finite_triangles == 0
            && self.degenerate_triangles == 0
            && self.repaired_normals == 0
            && self.repaired_uvs == 0
            && self.discarded_attributes.is_empty()
    }

    /// One human-readable line per repair that dropped or replaced data.
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.out_of_range_triangles > 0 {
            w.push(format!(
                "dropped {} triangle(s) with out-of-range vertex indices",
                self.out_of_range_triangles
            ));
        }
        if self.non_finite_triangles > 0 {
            w.push(format!(
                "dropped {} triangle(s) with a NaN or infinite vertex position",
                self.non_finite_triangles
            ));
        }
        if self.degenerate_triangles > 0 {
            w.push(format!(
                "dropped {} degenerate (zero-area) triangle(s)",
                self.degenerate_triangles
            ));
        }
        if self.repaired_normals > 0 {
            w.push(format!(
                "replaced {} zero/NaN normal(s) with smooth normals",
                self.repaired_normals
            ));
        }
        if self.repaired_uvs > 0 {
            w.push(format!(
                "set {} NaN/infinite texture coordinate(s) to (0, 0)",
                self.repaired_uvs
            ));
        }
        for a in &self.discarded_attributes {
            w.push(format!(
                "discarded {a}: length does not match the vertex count"
            ));
        }
        w
    }
}

impl fmt::Display for RepairReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = self.warnings();
        if self.computed_normals {
            parts.push("computed smooth normals".into());
        }
        if self.computed_tangents {
            parts.push("computed tangents".into());
        }
        if parts.is_empty() {
            write!(f, "no repairs")
        } else {
            write!(f, "{}", parts.join("; "))
        }
    }
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    /// Centre point.
    #[must_use]
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
    /// Edge lengths.
    #[must_use]
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
    /// Whether `p` lies in the box (boundary included).
    #[must_use]
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
}

/// Error of [`Mesh::try_validate`]: the first invalid item found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MeshError {
    /// Triangle `triangle` references vertex `index` ≥ `vertex_count`.
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertex_count: usize,
    },
    /// Triangle `triangle` has a corner with a NaN or infinite coordinate.
    NonFinite { triangle: usize },
    /// Triangle `triangle` has a repeated index or (near-)zero area.
    Degenerate { triangle: usize },
    /// An attribute array has the wrong length.
    AttributeLength {
        attribute: &'static str,
        len: usize,
        vertex_count: usize,
    },
    /// Normal `vertex` is zero, non-finite or not unit length.
    BadNormal { vertex: usize },
    /// The texture coordinates of `vertex` are not finite.
    BadUv { vertex: usize },
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::IndexOutOfRange {
                triangle,
                index,
                vertex_count,
            } => write!(
                f,
                "triangle {triangle} references vertex {index} but the mesh has {vertex_count} vertices"
            ),
            Self::NonFinite { triangle } => {
                write!(
                    f,
                    "triangle {triangle} has a NaN or infinite vertex position"
                )
            }
            Self::Degenerate { triangle } => {
                write!(f, "triangle {triangle} is degenerate (zero area)")
            }
            Self::AttributeLength {
                attribute,
                len,
                vertex_count,
            } => {
                write!(
                    f,
                    "{attribute} has {len} entries for {vertex_count} vertices"
                )
            }
            Self::BadNormal { vertex } => {
                write!(f, "normal {vertex} is zero, NaN or not unit length")
            }
            Self::BadUv { vertex } => {
                write!(
                    f,
                    "the texture coordinates of vertex {vertex} are NaN or infinite"
                )
            }
        }
    }
}

impl std::error::Error for MeshError {}

/// True when triangle `(a, b, c)` is degenerate by the rule of [`DEGENERATE_REL`].
#[must_use]
pub fn is_degenerate(a: Vec3, b: Vec3, c: Vec3) -> bool {
    let (e0, e1, e2) = (b - a, c - a, c - b);
    let lmax2 = e0
        .length_squared()
        .max(e1.length_squared())
        .max(e2.length_squared());
    let twice_area = e0.cross(e1).length();
    !(twice_area.is_finite() && lmax2.is_finite()) || twice_area <= DEGENERATE_REL * lmax2
}

fn normal_ok(n: Vec3) -> bool {
    n.is_finite() && (n.length_squared() - 1.0).abs() < 1e-2
}

impl Mesh {
    /// Number of triangles.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Number of vertices.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// A mesh from positions and triangles with smooth normals computed,
    /// or the first invalid triangle as an error (the strict counterpart of
    /// building a mesh and calling [`Mesh::validate_and_repair`]).
    pub fn try_from_triangles(
        positions: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
    ) -> Result<Mesh, MeshError> {
        let mut m = Mesh {
            positions,
            indices,
            ..Default::default()
        };
        m.try_validate()?;
        m.normals = m.smooth_normals();
        Ok(m)
    }

    /// Checks the invariants without changing anything; the first violation
    /// is the error. [`Mesh::validate_and_repair`] fixes what this reports.
    pub fn try_validate(&self) -> Result<(), MeshError> {
        let n = self.positions.len();
        for (attribute, len) in [
            ("normals", self.normals.len()),
            ("uvs", self.uvs.len()),
            ("tangents", self.tangents.len()),
        ] {
            if len != 0 && len != n {
                return Err(MeshError::AttributeLength {
                    attribute,
                    len,
                    vertex_count: n,
                });
            }
        }
        for (t, tri) in self.indices.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(MeshError::IndexOutOfRange {
                    triangle: t,
                    index,
                    vertex_count: n,
                });
            }
            let [a, b, c] = tri.map(|i| self.positions[i as usize]);
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                return Err(MeshError::NonFinite { triangle: t });
            }
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || is_degenerate(a, b, c) {
                return Err(MeshError::Degenerate { triangle: t });
            }
        }
        if let Some(vertex) = self.normals.iter().position(|&v| !normal_ok(v)) {
            return Err(MeshError::BadNormal { vertex });
        }
        if let Some(vertex) = self.uvs.iter().position(|uv| !uv.is_finite()) {
            return Err(MeshError::BadUv { vertex });
        }
        Ok(())
    }

    /// Establishes the [`Mesh`] invariants (see the module docs for the
    /// rules) and reports what changed. Never fails; a mesh whose triangles
    /// are all invalid ends up with no triangles.
    pub fn validate_and_repair(&mut self) -> RepairReport {
        let mut report = RepairReport::default();
        let n = self.positions.len();
        if !self.normals.is_empty() && self.normals.len() != n {
            self.normals.clear();
            report.discarded_attributes.push("normals");
        }
        if !self.uvs.is_empty() && self.uvs.len() != n {
            self.uvs.clear();
            report.discarded_attributes.push("uvs");
        }
        if !self.tangents.is_empty() && (self.tangents.len() != n || self.uvs.is_empty()) {
            self.tangents.clear();
            report.discarded_attributes.push("tangents");
        }
        let positions = &self.positions;
        self.indices.retain(|tri| {
            if tri.iter().any(|&i| i as usize >= n) {
                report.out_of_range_triangles += 1;
                return false;
            }
            let [a, b, c] = tri.map(|i| positions[i as usize]);
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                report.non_finite_triangles += 1;
                return false;
            }
            let degenerate =
                tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || is_degenerate(a, b, c);
            report.degenerate_triangles += usize::from(degenerate);
            !degenerate
        });

        if self.normals.is_empty() {
            self.normals = self.smooth_normals();
            report.computed_normals = n > 0;
        } else if self
            .normals
            .iter()
            .any(|&v| !v.is_finite() || (v.length_squared() - 1.0).abs() > 1e-6)
        {
            let smooth = self.smooth_normals();
            for (v, s) in self.normals.iter_mut().zip(smooth) {
                if !v.is_finite() || v.length_squared() < 1e-24 {
                    *v = s;
                    report.repaired_normals += 1;
                } else {
                    *v = v.normalize();
                }
            }
        }

        for uv in &mut self.uvs {
            if !uv.is_finite() {
                *uv = Vec2::ZERO;
                report.repaired_uvs += 1;
            }
        }
        if !self.uvs.is_empty() {
            let bad = self.tangents.is_empty()
                || self
                    .tangents
                    .iter()
                    .any(|t| !t.is_finite() || !normal_ok(t.truncate()) || t.w.abs() != 1.0);
            if bad {
                self.tangents = self.compute_tangents();
                report.computed_tangents = true;
            }
        }
        report
    }

    /// Smooth angle-weighted vertex normals (rule 4 of the module docs).
    /// Vertices with bit-identical positions share their normal; a vertex
    /// used by no valid triangle gets +Y. Requires in-range indices.
    #[must_use]
    pub fn smooth_normals(&self) -> Vec<Vec3> {
        let (weld, groups) = self.weld_map();
        let mut acc = vec![Vec3::ZERO; groups];
        for tri in &self.indices {
            let p = tri.map(|i| self.positions[i as usize]);
            let face = (p[1] - p[0]).cross(p[2] - p[0]);
            let Some(face) = face.try_normalize() else {
                continue;
            };
            for k in 0..3 {
                let e1 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let e2 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
                acc[weld[tri[k] as usize] as usize] += face * angle;
            }
        }
        weld.iter()
            .map(|&g| acc[g as usize].try_normalize().unwrap_or(Vec3::Y))
            .collect()
    }

    /// Maps each vertex to a group of vertices at the bit-identical position.
    fn weld_map(&self) -> (Vec<u32>, usize) {
        let mut map: HashMap<[u32; 3], u32> = HashMap::with_capacity(self.positions.len());
        let weld = self
            .positions
            .iter()
            .map(|p| {
                let key = p.to_array().map(|x| if x == 0.0 { 0 } else { x.to_bits() });
                let next = map.len() as u32;
                *map.entry(key).or_insert(next)
            })
            .collect();
        (weld, map.len())
    }

    /// Per-vertex tangents from uvs (rule 6 of the module docs). Requires
    /// unit normals and uvs of the vertex count; returns empty otherwise.
    #[must_use]
    pub fn compute_tangents(&self) -> Vec<Vec4> {
        let n = self.positions.len();
        if self.uvs.len() != n || self.normals.len() != n {
            return Vec::new();
        }
        let mut tan = vec![Vec3::ZERO; n];
        let mut bit = vec![Vec3::ZERO; n];
        for tri in &self.indices {
            let [i0, i1, i2] = tri.map(|i| i as usize);
            let (e1, e2) = (
                self.positions[i1] - self.positions[i0],
                self.positions[i2] - self.positions[i0],
            );
            let (d1, d2) = (self.uvs[i1] - self.uvs[i0], self.uvs[i2] - self.uvs[i0]);
            let det = d1.x * d2.y - d2.x * d1.y;
            if det.abs() < 1e-20 || !det.is_finite() {
                continue;
            }
            // ∂p/∂u and ∂p/∂v of the triangle's affine uv map (Lengyel 2001).
            let dpdu = (e1 * d2.y - e2 * d1.y) / det;
            let dpdv = (e2 * d1.x - e1 * d2.x) / det;
            for i in [i0, i1, i2] {
                tan[i] += dpdu;
                bit[i] += dpdv;
            }
        }
        (0..n)
            .map(|i| {
                let nrm = self.normals[i];
                let t = tan[i] - nrm * nrm.dot(tan[i]);
                let t = t
                    .try_normalize()
                    .unwrap_or_else(|| nrm.any_orthonormal_vector());
                let w = if nrm.cross(t).dot(bit[i]) < 0.0 {
                    -1.0
                } else {
                    1.0
                };
                t.extend(w)
            })
            .collect()
    }

    /// Axis-aligned bounds of the vertex positions (`None` when empty).
    #[must_use]
    pub fn bounds(&self) -> Option<Aabb> {
        let first = *self.positions.first()?;
        let (min, max) = self
            .positions
            .iter()
            .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        Some(Aabb { min, max })
    }

    /// Applies `new_from_old` to the mesh: positions by the affine map,
    /// normals by the inverse transpose of its linear part, tangents by the
    /// linear part. A mirroring transform (negative determinant) also flips
    /// the triangle winding and tangent handedness so faces keep facing out.
    pub fn transform(&mut self, new_from_old: Affine3A) {
        let lin = Mat3::from(new_from_old.matrix3);
        let normal_mat = lin.inverse().transpose();
        for p in &mut self.positions {
            *p = new_from_old.transform_point3(*p);
        }
        for nrm in &mut self.normals {
            *nrm = (normal_mat * *nrm).try_normalize().unwrap_or(*nrm);
        }
        let mirror = lin.determinant() < 0.0;
        for t in &mut self.tangents {
            let v = (lin * t.truncate()).try_normalize().unwrap_or(t.truncate());
            *t = v.extend(if mirror { -t.w } else { t.w });
        }
        if mirror {
            for tri in &mut self.indices {
                tri.swap(1, 2);
            }
        }
    }

    /// [`Mesh::transform`] by a `Mat4` (its projective row is ignored).
    pub fn transform_mat4(&mut self, new_from_old: Mat4) {
        self.transform(Affine3A::from_mat4(new_from_old));
    }

    /// The mesh transformed by `new_from_old`.
    #[must_use]
    pub fn transformed(mut self, new_from_old: Affine3A) -> Self {
        self.transform(new_from_old);
        self
    }

    /// Uniformly scales and translates the mesh so its bounding box is
    /// centred at the origin with its longest side 2 (it fits in [-1, 1]³).
    /// Returns the applied `unit_from_old` transform (identity when empty or
    /// all points coincide).
    pub fn normalize_to_unit_box(&mut self) -> Affine3A {
        let Some(b) = self.bounds() else {
            return Affine3A::IDENTITY;
        };
        let longest = b.extent().max_element();
        if !(longest > 0.0 && longest.is_finite()) {
            return Affine3A::IDENTITY;
        }
        let s = 2.0 / longest;
        let xf = Affine3A::from_scale(Vec3::splat(s)) * Affine3A::from_translation(-b.center());
        self.transform(xf);
        xf
    }

    /// Appends `other`. Normals missing on either side are computed first;
    /// uvs and tangents are kept only when both meshes have them.
    pub fn merge(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        let keep_uvs = (!self.uvs.is_empty() || self.positions.is_empty()) && !other.uvs.is_empty();
        let keep_tangents = keep_uvs
            && (!self.tangents.is_empty() || self.positions.is_empty())
            && !other.tangents.is_empty();
        if self.normals.len() != self.positions.len() {
            self.normals = self.smooth_normals();
        }
        let other_normals = if other.normals.len() == other.positions.len() {
            other.normals.clone()
        } else {
            other.smooth_normals()
        };
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend(other_normals);
        if keep_uvs {
            self.uvs.extend_from_slice(&other.uvs);
        } else {
            self.uvs.clear();
        }
        if keep_tangents {
            self.tangents.extend_from_slice(&other.tangents);
        } else {
            self.tangents.clear();
        }
        self.indices
            .extend(other.indices.iter().map(|t| t.map(|i| i + base)));
    }

    /// Total surface area.
    #[must_use]
    pub fn area(&self) -> f64 {
        self.indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                0.5 * f64::from((b - a).cross(c - a).length())
            })
            .sum()
    }

    /// Number of undirected edges and of boundary edges (used by one
    /// triangle only). A closed (watertight) manifold has no boundary edges.
    /// Vertices are welded by position first, so uv seams do not count.
    #[must_use]
    pub fn edge_counts(&self) -> (usize, usize) {
        let (weld, _) = self.weld_map();
        let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.indices.len() * 2);
        for tri in &self.indices {
            for k in 0..3 {
                let (a, b) = (weld[tri[k] as usize], weld[tri[(k + 1) % 3] as usize]);
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        let boundary = edges.values().filter(|&&c| c == 1).count();
        (edges.len(), boundary)
    }

    /// Whether the position-welded mesh is closed and consistently oriented
    /// with outward normals: every directed edge `a → b` is used by exactly
    /// one triangle and its reverse `b → a` by exactly one other, and the
    /// signed volume `Σ p0 · (p1 × p2) / 6` (divergence theorem) is
    /// positive. Seen from outside, such a mesh hides each of its back faces
    /// behind one of its front faces, so a rasterizer may cull them.
    #[must_use]
    pub fn is_closed_outward(&self) -> bool {
        if self.indices.is_empty() {
            return false;
        }
        let (weld, _) = self.weld_map();
        // Directed edges `a → b` as `a·2³² + b`, and their reverses: the mesh
        // is closed and consistent iff no edge repeats, none is a loop, and
        // the sorted edges equal the sorted reverses (two sorts instead of a
        // hash map: several times faster on meshes of 10⁵–10⁶ triangles).
        let mut edges = Vec::with_capacity(self.indices.len() * 3);
        let mut reverses = Vec::with_capacity(self.indices.len() * 3);
        let mut volume = 0.0f64;
        for tri in &self.indices {
            let w = tri.map(|i| u64::from(weld[i as usize]));
            for k in 0..3 {
                let (a, b) = (w[k], w[(k + 1) % 3]);
                if a == b {
                    return false;
                }
                edges.push(a << 32 | b);
                reverses.push(b << 32 | a);
            }
            let [a, b, c] = tri.map(|i| self.positions[i as usize].as_dvec3());
            volume += a.dot(b.cross(c));
        }
        if volume <= 0.0 {
            return false;
        }
        edges.sort_unstable();
        reverses.sort_unstable();
        edges.windows(2).all(|w| w[0] != w[1]) && edges == reverses
    }

    /// Euler characteristic V − E + F of the position-welded mesh
    /// (2 for a closed genus-0 surface, 0 for a torus).
    #[must_use]
    pub fn euler_characteristic(&self) -> i64 {
        let (weld, _) = self.weld_map();
        let used: std::collections::HashSet<u32> = self
            .indices
            .iter()
            .flatten()
            .map(|&i| weld[i as usize])
            .collect();
        let (e, _) = self.edge_counts();
        used.len() as i64 - e as i64 + self.indices.len() as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> Mesh {
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            indices: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
            ..Default::default()
        }
    }

    #[test]
    fn repair_drops_bad_triangles_and_computes_normals() {
        let mut m = tetra();
        m.indices.push([0, 1, 9]); // out of range
        m.indices.push([0, 0, 1]); // repeated index
        m.positions.push(Vec3::new(2.0, 0.0, 0.0)); // collinear with 0 and 1
        m.indices.push([0, 1, 4]);
        m.positions.push(Vec3::new(f32::NAN, 0.0, 1.0)); // a NaN corner
        m.indices.push([0, 1, 5]);
        let mut nan_only = tetra();
        nan_only.positions[3].y = f32::INFINITY;
        assert_eq!(
            nan_only.try_validate(),
            Err(MeshError::NonFinite { triangle: 1 })
        );
        let r = m.validate_and_repair();
        assert_eq!(r.out_of_range_triangles, 1);
        assert_eq!(r.non_finite_triangles, 1);
        assert_eq!(r.degenerate_triangles, 2);
        assert!(r.warnings().iter().any(|w| w.contains("NaN or infinite")));
        assert!(r.computed_normals);
        assert_eq!(m.triangle_count(), 4);
        assert!(m.try_validate().is_ok());
        for n in &m.normals {
            assert!((n.length() - 1.0).abs() < 1e-5, "normal {n} not unit");
        }
        // Vertex 0 sits at the corner of the three axis faces: its normal
        // is the (angle-weighted) mean of -X, -Y, -Z, all angles π/2.
        let expect = Vec3::splat(-1.0).normalize();
        assert!(
            m.normals[0].abs_diff_eq(expect, 1e-5),
            "{} vs {expect}",
            m.normals[0]
        );
        assert!(!r.is_clean());
        assert_eq!(r.warnings().len(), 3);
    }

    #[test]
    fn near_degenerate_tolerance_is_relative() {
        // A sliver with height 1e-9 of its length is degenerate at any scale;
        // one with height 1e-4 is not.
        for scale in [1e-6f32, 1.0, 1e6] {
            let a = Vec3::ZERO;
            let b = Vec3::X * scale;
            assert!(is_degenerate(a, b, Vec3::new(0.5, 1e-9, 0.0) * scale));
            assert!(!is_degenerate(a, b, Vec3::new(0.5, 1e-4, 0.0) * scale));
        }
        assert!(is_degenerate(
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(f32::NAN, 1.0, 0.0)
        ));
    }

    #[test]
    fn repairs_bad_normals_and_wrong_length_attributes() {
        let mut m = tetra();
        m.normals = vec![
            Vec3::ZERO,
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::Y * 2.0,
            -Vec3::Z,
        ];
        m.uvs = vec![Vec2::ZERO; 3]; // wrong length
        let r = m.validate_and_repair();
        assert_eq!(r.repaired_normals, 2);
        assert_eq!(r.discarded_attributes, vec!["uvs"]);
        let mut m2 = tetra();
        m2.uvs = vec![Vec2::ZERO, Vec2::new(f32::NAN, 0.5), Vec2::X, Vec2::Y];
        let r2 = m2.validate_and_repair();
        assert_eq!(r2.repaired_uvs, 1);
        assert_eq!(m2.uvs[1], Vec2::ZERO);
        assert!(m2.try_validate().is_ok());
        m2.uvs[2].y = f32::INFINITY;
        assert_eq!(m2.try_validate(), Err(MeshError::BadUv { vertex: 2 }));
        assert!(m2.tangents.iter().all(|t| t.is_finite()));
        assert!(
            r2.warnings()
                .iter()
                .any(|w| w.contains("texture coordinate"))
        );
        assert!(m.normals[2].abs_diff_eq(Vec3::Y, 1e-6));
        assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
        assert!(m.uvs.is_empty() && m.tangents.is_empty());
    }

    #[test]
    fn tangents_follow_u_direction_and_handedness() {
        // A quad in the XZ plane facing +Y, u along +X, v along -Z.
        let mut m = Mesh {
            positions: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::new(1.0, 0.0, -1.0),
                Vec3::new(0.0, 0.0, -1.0),
            ],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        };
        let r = m.validate_and_repair();
        assert!(r.computed_tangents && r.computed_normals);
        for (n, t) in m.normals.iter().zip(&m.tangents) {
            assert!(n.abs_diff_eq(Vec3::Y, 1e-6), "{n}");
            assert!(t.truncate().abs_diff_eq(Vec3::X, 1e-6), "{t}");
            // n × t = Y × X = -Z = dp/dv, so right-handed: w = +1.
            assert_eq!(t.w, 1.0);
        }
        // Mirror u: handedness flips.
        for uv in &mut m.uvs {
            uv.x = 1.0 - uv.x;
        }
        let t = m.compute_tangents();
        assert!(
            t.iter()
                .all(|t| t.truncate().abs_diff_eq(-Vec3::X, 1e-6) && t.w == -1.0)
        );
    }

    #[test]
    fn transform_keeps_normals_perpendicular_under_nonuniform_scale() {
        let mut m = tetra();
        m.validate_and_repair();
        let xf = Affine3A::from_scale(Vec3::new(3.0, 0.5, 1.0)) * Affine3A::from_rotation_y(0.7);
        let mut t = m.clone();
        t.transform(xf);
        let fresh = {
            let mut f = t.clone();
            f.normals.clear();
            f.validate_and_repair();
            f
        };
        // Face normals transform by the inverse transpose: check a face.
        let tri = t.indices[3];
        let p = tri.map(|i| t.positions[i as usize]);
        let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let m_face = {
            let q = tri.map(|i| m.positions[i as usize]);
            (q[1] - q[0]).cross(q[2] - q[0]).normalize()
        };
        let via_it = (Mat3::from(xf.matrix3).inverse().transpose() * m_face).normalize();
        assert!(face.abs_diff_eq(via_it, 1e-5), "{face} vs {via_it}");
        assert_eq!(fresh.indices, t.indices);
        // A mirror keeps outward faces outward.
        let mut mirrored = m.clone();
        mirrored.transform(Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        let mut rec = mirrored.clone();
        rec.normals.clear();
        rec.validate_and_repair();
        for (a, b) in mirrored.normals.iter().zip(&rec.normals) {
            assert!(a.abs_diff_eq(*b, 1e-5), "{a} vs {b}");
        }
    }

    #[test]
    fn bounds_normalize_merge() {
        let mut m = tetra();
        m.transform(Affine3A::from_scale_rotation_translation(
            Vec3::splat(5.0),
            Default::default(),
            Vec3::ONE,
        ));
        let b = m.bounds().unwrap();
        assert_eq!(b.min, Vec3::ONE);
        assert_eq!(b.max, Vec3::splat(6.0));
        m.normalize_to_unit_box();
        let b = m.bounds().unwrap();
        assert!(b.min.abs_diff_eq(Vec3::splat(-1.0), 1e-6) && b.max.abs_diff_eq(Vec3::ONE, 1e-6));
        let mut a = tetra();
        a.merge(&m);
        assert_eq!(a.vertex_count(), 8);
        assert_eq!(a.triangle_count(), 8);
        assert_eq!(a.normals.len(), 8);
        assert!(a.try_validate().is_ok());
        assert_eq!(a.euler_characteristic(), 4); // two spheres
        assert_eq!(Mesh::default().bounds(), None);
    }

    #[test]
    fn strict_constructor_reports_the_first_bad_triangle() {
        let t = tetra();
        let m = Mesh::try_from_triangles(t.positions.clone(), t.indices.clone()).unwrap();
        assert_eq!(m.normals.len(), 4);
        let mut bad = t.indices.clone();
        bad.push([0, 1, 1]);
        assert_eq!(
            Mesh::try_from_triangles(t.positions.clone(), bad),
            Err(MeshError::Degenerate { triangle: 4 })
        );
        let e = Mesh::try_from_triangles(t.positions, vec![[0, 1, 4]]).unwrap_err();
        assert_eq!(
            e,
            MeshError::IndexOutOfRange {
                triangle: 0,
                index: 4,
                vertex_count: 4
            }
        );
        assert!(e.to_string().contains("vertex 4"));
    }

    #[test]
    fn tetra_is_closed_genus_zero() {
        let m = tetra();
        assert_eq!(m.edge_counts(), (6, 0));
        assert_eq!(m.euler_characteristic(), 2);
    }

    #[test]
    fn closed_outward_needs_every_edge_paired_and_a_positive_volume() {
        assert!(tetra().is_closed_outward());
        let mut inverted = tetra();
        for t in &mut inverted.indices {
            t.swap(1, 2);
        }
        assert!(!inverted.is_closed_outward(), "inside-out");
        let mut flipped = tetra();
        flipped.indices[3].swap(1, 2);
        assert!(!flipped.is_closed_outward(), "one face flipped");
        let mut open = tetra();
        open.indices.pop();
        assert!(!open.is_closed_outward(), "a hole");
        assert!(!Mesh::default().is_closed_outward());
        assert!(!crate::shapes::plane(1.0, 4).is_closed_outward());
        // Two closed tetrahedra sharing the edge 0–1: each directed edge of
        // it is used twice (non-manifold), although every edge has a reverse.
        let mut glued = tetra();
        glued
            .positions
            .extend([Vec3::new(0.5, -1.0, -1.0), Vec3::new(0.4, -1.0, 1.0)]);
        glued
            .indices
            .extend([[0, 1, 4], [0, 5, 1], [0, 4, 5], [1, 5, 4]]);
        let mut second = Mesh {
            positions: glued.positions.clone(),
            indices: glued.indices[4..].to_vec(),
            ..Default::default()
        };
        second.positions.truncate(6);
        assert!(
            second.is_closed_outward(),
            "the second tetrahedron alone is closed"
        );
        assert!(!glued.is_closed_outward(), "two solids sharing an edge");
        // Two copies of a face.
        let mut doubled = tetra();
        doubled.indices.push(doubled.indices[0]);
        assert!(!doubled.is_closed_outward(), "a repeated face");
        // Seams welded by position: the builtin solids are closed.
        assert!(crate::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 24, 12).is_closed_outward());
        assert!(crate::shapes::torus(1.0, 0.3, 24, 12).is_closed_outward());
    }
}
