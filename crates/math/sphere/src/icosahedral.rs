//! Icosahedral geodesic triangle hierarchy (levels 0–7), as in
//! `spherical-wavelets-triple-product-2006.txt` §3.1.
//!
//! # Construction
//!
//! Level 0 is the 20 spherical triangles of the regular icosahedron inscribed
//! in the unit sphere (vertices `(0, ±1, ±ϕ)`, `(±1, ±ϕ, 0)`, `(±ϕ, 0, ±1)`
//! normalised, ϕ the golden ratio). Each subdivision step splits every
//! triangle `T_i^l = (a, b, c)` into four by the midpoints of its geodesic
//! edges, projected to the sphere (`m_ab = (a + b)/|a + b|`, the great-circle
//! midpoint), giving the children `T_{4i+k}^{l+1}` of Figure 3 of the paper:
//!
//! | child `4i + k` | vertices | |
//! |---|---|---|
//! | k = 0 | `(a, m_ab, m_ca)` | corner at `a` |
//! | k = 1 | `(m_ab, b, m_bc)` | corner at `b` |
//! | k = 2 | `(m_ca, m_bc, c)` | corner at `c` |
//! | k = 3 | `(m_bc, m_ca, m_ab)` | centre; vertex k is opposite the parent's vertex k |
//!
//! so the parent of triangle `i` is `i / 4` and its children are `4i .. 4i+4`.
//! Every triangle is counter-clockwise seen from outside (`a·(b×c) > 0`).
//!
//! | level l | triangles `20·4^l` | vertices `10·4^l + 2` | mean area (sr) |
//! |---|---|---|---|
//! | 0 | 20 | 12 | 0.628 |
//! | 3 | 1 280 | 642 | 9.8e-3 |
//! | 5 | 20 480 | 10 242 | 6.1e-4 |
//! | 7 | 327 680 | 163 842 | 3.8e-5 |
//!
//! Vertices are shared across levels: the vertices of level `l` are the first
//! `10·4^l + 2` entries of [`Icosahedral::vertices`] (each level appends its
//! edge midpoints), and triangle vertex indices refer to that one array.
//!
//! # Areas
//!
//! The paper normalises the area of a level-0 triangle to 1, so `A_l = 4^{−l}`;
//! the geodesic triangles of one level are in fact *not* equal (the centre
//! child is larger than the corner children). relight keeps the exact
//! spherical areas (steradians) by the Van Oosterom–Strackee formula for unit
//! vertices,
//!
//! ```text
//! tan(Ω/2) = |a·(b×c)| / (1 + a·b + b·c + c·a),
//! ```
//!
//! evaluated in f64 with `atan2`, so the areas of each level sum to 4π to
//! rounding.
//!
//! # Point location
//!
//! [`Icosahedral::locate`] descends the hierarchy. At level 0 it takes,
//! among the 20 faces, the one whose smallest signed edge distance `d·n̂_e`
//! is largest (`n̂_e = (a×b)/|a×b|`, the unit normal of the edge's great
//! circle, pointing inside; the 60 normals are precomputed). Below, the four
//! children tile their parent exactly, and corner child `k` is separated from
//! the centre child by the centre's edge opposite its vertex `k`; so one level
//! costs three signed distances: `d` goes to the corner whose separating edge
//! it lies furthest beyond, or to the centre when it is beyond none. Taking
//! the extreme margin rather than the first sign test that passes makes the
//! answer well defined on edges and vertices and immune to rounding (the
//! chosen triangle never excludes `d` by more than ~1e-16 in sine-distance).
//!
//! # References
//!
//! * [Ma, Hsiao, Lee, Chuang & Chen 2006, "Real-time triple product
//!   relighting using spherical local-frame parameterization", The Visual
//!   Computer 22(9–11) / `spherical-wavelets-triple-product-2006.txt` §3.1]
//!   geodesic subdivision and the `4i + k` child numbering; the basis on
//!   this hierarchy lives in `relight-triple` (`basis`).
//! * [Schröder & Sweldens 1995] "Spherical wavelets", SIGGRAPH 1995.
//! * [Van Oosterom & Strackee 1983] "The solid angle of a plane triangle".

use glam::DVec3;
use std::collections::HashMap;

/// Why an [`Icosahedral`] hierarchy or query is invalid.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IcosahedralError {
    /// The requested level exceeds what was built (or [`Icosahedral::MAX_LEVEL`]).
    LevelTooDeep {
        /// The level asked for.
        level: usize,
        /// The deepest level available.
        max: usize,
    },
}

impl std::fmt::Display for IcosahedralError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::LevelTooDeep { level, max } => write!(
                f,
                "icosahedral level {level} is too deep: the hierarchy has levels 0..={max}"
            ),
        }
    }
}

impl std::error::Error for IcosahedralError {}

/// Exact area (solid angle, sr) of the spherical triangle with unit vertices
/// `a, b, c` (Van Oosterom–Strackee, f64). Orientation-independent.
#[inline]
#[must_use]
pub fn spherical_triangle_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let triple = a.dot(b.cross(c)).abs();
    let denom = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * triple.atan2(denom)
}

/// The icosahedral geodesic hierarchy, levels `0..=max_level` (at most 7).
#[derive(Clone, Debug)]
pub struct Icosahedral {
    vertices: Vec<DVec3>,
    /// `levels[l]` holds the `20·4^l` triangles of level `l` (CCW vertex indices).
    levels: Vec<Vec<[u32; 3]>>,
    /// The 20 level-0 faces, for the first step of a descent.
    base: BaseFaces,
}

impl Icosahedral {
    /// Deepest level supported (`20·4^7 = 327 680` triangles).
    pub const MAX_LEVEL: usize = 7;

    /// Builds levels `0..=max_level`.
    ///
    /// # Errors
    /// [`IcosahedralError::LevelTooDeep`] when `max_level > 7`.
    pub fn new(max_level: usize) -> Result<Self, IcosahedralError> {
        if max_level > Self::MAX_LEVEL {
            return Err(IcosahedralError::LevelTooDeep {
                level: max_level,
                max: Self::MAX_LEVEL,
            });
        }
        let (mut vertices, base) = icosahedron();
        vertices.reserve(Self::vertex_count(max_level) - vertices.len());
        let mut levels = Vec::with_capacity(max_level + 1);
        levels.push(base);
        for l in 0..max_level {
            let parent = &levels[l];
            let mut midpoints: HashMap<(u32, u32), u32> =
                HashMap::with_capacity(parent.len() * 3 / 2);
            let mut mid = |a: u32, b: u32, vertices: &mut Vec<DVec3>| -> u32 {
                let key = (a.min(b), a.max(b));
                *midpoints.entry(key).or_insert_with(|| {
                    let m = (vertices[a as usize] + vertices[b as usize]).normalize();
                    vertices.push(m);
                    (vertices.len() - 1) as u32
                })
            };
            let mut children = Vec::with_capacity(parent.len() * 4);
            for &[a, b, c] in parent {
                let mab = mid(a, b, &mut vertices);
                let mbc = mid(b, c, &mut vertices);
                let mca = mid(c, a, &mut vertices);
                children.push([a, mab, mca]);
                children.push([mab, b, mbc]);
                children.push([mca, mbc, c]);
                children.push([mbc, mca, mab]);
            }
            levels.push(children);
        }
        let mut base = BaseFaces {
            edge_normals: [[DVec3::ZERO; 3]; 20],
            centres: [DVec3::ZERO; 20],
        };
        for (i, t) in levels[0].iter().enumerate() {
            let [a, b, c] = t.map(|v| vertices[v as usize]);
            base.edge_normals[i] = [
                a.cross(b).normalize(),
                b.cross(c).normalize(),
                c.cross(a).normalize(),
            ];
            base.centres[i] = (a + b + c).normalize();
        }
        Ok(Self {
            vertices,
            levels,
            base,
        })
    }

    /// Deepest level built.
    #[must_use]
    pub fn max_level(&self) -> usize {
        self.levels.len() - 1
    }

    /// Number of triangles at `level`: `20·4^level`.
    #[must_use]
    pub const fn triangle_count(level: usize) -> usize {
        20 << (2 * level)
    }

    /// Number of vertices of `level`: `10·4^level + 2`.
    #[must_use]
    pub const fn vertex_count(level: usize) -> usize {
        (10 << (2 * level)) + 2
    }

    /// All vertices (unit length); level `l` uses the first `vertex_count(l)`.
    #[must_use]
    pub fn vertices(&self) -> &[DVec3] {
        &self.vertices
    }

    /// Triangles of `level` as vertex indices into [`Icosahedral::vertices`].
    ///
    /// # Panics
    /// When `level > max_level()` (see [`Icosahedral::try_triangles`]).
    #[must_use]
    pub fn triangles(&self, level: usize) -> &[[u32; 3]] {
        &self.levels[level]
    }

    /// Triangles of `level`, or an error when the level was not built.
    ///
    /// # Errors
    /// [`IcosahedralError::LevelTooDeep`].
    pub fn try_triangles(&self, level: usize) -> Result<&[[u32; 3]], IcosahedralError> {
        self.check_level(level)?;
        Ok(&self.levels[level])
    }

    fn check_level(&self, level: usize) -> Result<(), IcosahedralError> {
        if level > self.max_level() {
            Err(IcosahedralError::LevelTooDeep {
                level,
                max: self.max_level(),
            })
        } else {
            Ok(())
        }
    }

    /// The three unit vertices of triangle `i` at `level` (CCW from outside).
    #[inline]
    #[must_use]
    pub fn triangle(&self, level: usize, i: usize) -> [DVec3; 3] {
        self.levels[level][i].map(|v| self.vertices[v as usize])
    }

    /// Parent (at `level − 1`) of triangle `i`: `i / 4`.
    #[inline]
    #[must_use]
    pub const fn parent(i: usize) -> usize {
        i / 4
    }

    /// Children (at `level + 1`) of triangle `i`: `4i .. 4i + 4` (see the table).
    #[inline]
    #[must_use]
    pub const fn children(i: usize) -> [usize; 4] {
        [4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3]
    }

    /// Exact spherical area (sr) of triangle `i` at `level`.
    #[must_use]
    pub fn area(&self, level: usize, i: usize) -> f64 {
        let [a, b, c] = self.triangle(level, i);
        spherical_triangle_area(a, b, c)
    }

    /// Areas of all triangles of `level`, in triangle order.
    #[must_use]
    pub fn areas(&self, level: usize) -> Vec<f64> {
        (0..self.levels[level].len())
            .map(|i| self.area(level, i))
            .collect()
    }

    /// Unit direction through the centroid of the planar triangle `i`.
    #[must_use]
    pub fn centroid(&self, level: usize, i: usize) -> DVec3 {
        let [a, b, c] = self.triangle(level, i);
        (a + b + c).normalize()
    }

    /// Smallest signed sine-distance of `d` (unit) to the three edge great
    /// circles of a CCW triangle: ≥ 0 inside, < 0 outside.
    #[inline]
    fn edge_margin(t: [DVec3; 3], d: DVec3) -> f64 {
        let e = |p: DVec3, q: DVec3| d.dot(p.cross(q).normalize());
        e(t[0], t[1]).min(e(t[1], t[2])).min(e(t[2], t[0]))
    }

    /// Barycentric coordinates of the point where the ray along `d` meets the
    /// plane of triangle `i` (all ≥ 0 iff `d` lies in the spherical triangle).
    #[must_use]
    pub fn barycentric(&self, level: usize, i: usize, d: DVec3) -> DVec3 {
        let [a, b, c] = self.triangle(level, i);
        // d = α a + β b + γ c  ⇒  Cramer's rule with triple products.
        let det = a.dot(b.cross(c));
        let w = DVec3::new(d.dot(b.cross(c)), a.dot(d.cross(c)), a.dot(b.cross(d))) / det;
        w / (w.x + w.y + w.z)
    }

    /// True when `d` lies in the spherical triangle `i` of `level` (edges
    /// included, with tolerance `tol` in sine-distance, e.g. 1e-12).
    #[must_use]
    pub fn contains(&self, level: usize, i: usize, d: DVec3, tol: f64) -> bool {
        Self::edge_margin(self.triangle(level, i), d.normalize()) >= -tol
    }

    /// Triangle of `level` containing direction `d` (non-zero, need not be
    /// normalised), found by descending the hierarchy from level 0.
    ///
    /// # Panics
    /// When `level > max_level()` (see [`Icosahedral::try_locate`]).
    #[must_use]
    pub fn locate(&self, d: DVec3, level: usize) -> usize {
        let mut path = [0usize; Self::MAX_LEVEL + 1];
        self.locate_path(d, level, &mut path);
        path[level]
    }

    /// [`Icosahedral::locate`] with a typed error for a level that was not built.
    ///
    /// # Errors
    /// [`IcosahedralError::LevelTooDeep`].
    pub fn try_locate(&self, d: DVec3, level: usize) -> Result<usize, IcosahedralError> {
        self.check_level(level)?;
        Ok(self.locate(d, level))
    }

    /// Writes the containing triangle of every level `0..=level` into
    /// `path[0..=level]` (ancestors of the leaf: `path[l] = path[l+1] / 4`).
    ///
    /// # Panics
    /// When `level > max_level()` or `path` is shorter than `level + 1`.
    pub fn locate_path(&self, d: DVec3, level: usize, path: &mut [usize]) {
        assert!(
            level <= self.max_level(),
            "icosahedral level {level} > {}",
            self.max_level()
        );
        let d = d.normalize();
        let mut i = self.base.face_of(d);
        path[0] = i;
        for (l, slot) in path.iter_mut().enumerate().take(level + 1).skip(1) {
            i = 4 * i + child_beyond(d, &self.centre_edge_normals(l, i));
            *slot = i;
        }
    }

    /// The unit edge normals `(m_b×m_c, m_c×m_a, m_a×m_b)/|·|` of the centre
    /// child (`4i + 3`, vertices `(m_a, m_b, m_c)`) of triangle `i` of level
    /// `l − 1`: the edge opposite vertex `k` separates it from corner child `k`.
    fn centre_edge_normals(&self, l: usize, i: usize) -> [DVec3; 3] {
        let [ma, mb, mc] = self.triangle(l, 4 * i + 3);
        [
            mb.cross(mc).normalize(),
            mc.cross(ma).normalize(),
            ma.cross(mb).normalize(),
        ]
    }

    /// A [`IcoLocator`] for `level`: [`Icosahedral::locate`] with every edge
    /// normal it needs computed once.
    ///
    /// # Errors
    /// [`IcosahedralError::LevelTooDeep`] when `level` was not built.
    pub fn locator(&self, level: usize) -> Result<IcoLocator, IcosahedralError> {
        self.check_level(level)?;
        let centre = (1..=level)
            .map(|l| {
                (0..self.levels[l - 1].len())
                    .map(|i| self.centre_edge_normals(l, i))
                    .collect()
            })
            .collect();
        Ok(IcoLocator {
            base: self.base,
            centre,
        })
    }
}

/// The 20 level-0 faces: unit inward edge normals `(a×b, b×c, c×a)/|·|` and
/// unit centres `(a+b+c)/|·|`.
#[derive(Clone, Copy, Debug)]
struct BaseFaces {
    edge_normals: [[DVec3; 3]; 20],
    centres: [DVec3; 20],
}

/// How far (in `d·centre`) a face's centre may lie below the nearest one
/// and still be tested by the edge rule: far above rounding (~10⁻¹⁶), far
/// below any gap between a face and one it does not touch.
const BASE_CENTRE_BAND: f64 = 1e-9;

impl BaseFaces {
    /// The face of `d` (unit): the one with the largest smallest edge
    /// margin, the lowest index on a tie (an edge or a vertex). Only faces
    /// whose centre is within [`BASE_CENTRE_BAND`] of the nearest centre
    /// are tested: a face's spherical triangle is its centre's Voronoi cell
    /// (the plane of an edge mirrors the two faces on it, so it bisects
    /// their centres), so the face holding `d`, and every face that ties
    /// with it, has a centre that near; the rest have a negative margin.
    #[inline]
    fn face_of(&self, d: DVec3) -> usize {
        let dots = self.centres.map(|c| d.dot(c));
        let nearest = dots.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut best = (f64::NEG_INFINITY, 0);
        for (i, n) in self.edge_normals.iter().enumerate() {
            if dots[i] < nearest - BASE_CENTRE_BAND {
                continue;
            }
            let m = d.dot(n[0]).min(d.dot(n[1])).min(d.dot(n[2]));
            if m > best.0 {
                best = (m, i);
            }
        }
        best.1
    }
}

/// Which child of a triangle `d` (unit) lies in, from the centre child's
/// edge normals: the corner `k` whose separating edge `d` is furthest
/// beyond, else the centre (3).
#[inline]
fn child_beyond(d: DVec3, centre: &[DVec3; 3]) -> usize {
    let mut k = 3;
    let mut worst = 0.0;
    for (j, n) in centre.iter().enumerate() {
        let m = d.dot(*n);
        if m < worst {
            worst = m;
            k = j;
        }
    }
    k
}

/// [`Icosahedral::locate`] at one level with the edge normals of every
/// triangle above it tabulated ([`Icosahedral::locator`]; 420 triangles,
/// 30 KB at level 3): the same triangle bit for bit, without the cross
/// products and square roots per level, for lookups per pixel.
#[derive(Clone, Debug)]
pub struct IcoLocator {
    base: BaseFaces,
    /// `centre[l − 1][i]`: the centre-child edge normals of triangle `i` of
    /// level `l − 1`, for the descent to level `l`.
    centre: Vec<Vec<[DVec3; 3]>>,
}

impl IcoLocator {
    /// The level it locates at.
    #[must_use]
    pub fn level(&self) -> usize {
        self.centre.len()
    }

    /// Triangle of [`IcoLocator::level`] containing `d` (non-zero, need not
    /// be normalised): [`Icosahedral::locate`]'s answer.
    #[must_use]
    pub fn locate(&self, d: DVec3) -> usize {
        let d = d.normalize();
        let mut i = self.base.face_of(d);
        for level in &self.centre {
            i = 4 * i + child_beyond(d, &level[i]);
        }
        i
    }
}

/// The regular icosahedron: 12 unit vertices and 20 CCW faces (sorted order).
fn icosahedron() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let phi = 0.5 * (1.0 + 5f64.sqrt());
    let mut v = Vec::with_capacity(12);
    for s1 in [-1.0, 1.0] {
        for s2 in [-1.0, 1.0] {
            v.push(DVec3::new(0.0, s1, s2 * phi));
            v.push(DVec3::new(s1, s2 * phi, 0.0));
            v.push(DVec3::new(s2 * phi, 0.0, s1));
        }
    }
    // Faces are the vertex triples at mutual (unnormalised) distance 2.
    let adjacent = |a: DVec3, b: DVec3| (a.distance(b) - 2.0).abs() < 1e-9;
    let mut faces = Vec::with_capacity(20);
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if adjacent(v[i], v[j]) && adjacent(v[j], v[k]) && adjacent(v[k], v[i]) {
                    let (i, j, k) = (i as u32, j as u32, k as u32);
                    let ccw = v[i as usize].dot(v[j as usize].cross(v[k as usize])) > 0.0;
                    faces.push(if ccw { [i, j, k] } else { [i, k, j] });
                }
            }
        }
    }
    debug_assert_eq!(faces.len(), 20);
    (v.into_iter().map(DVec3::normalize).collect(), faces)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The full rule: the largest smallest edge margin over all 20 faces.
    fn face_by_all_margins(b: &BaseFaces, d: DVec3) -> usize {
        let mut best = (f64::NEG_INFINITY, 0);
        for (i, n) in b.edge_normals.iter().enumerate() {
            let m = d.dot(n[0]).min(d.dot(n[1])).min(d.dot(n[2]));
            if m > best.0 {
                best = (m, i);
            }
        }
        best.1
    }

    /// Testing only the faces near the nearest centre gives the full rule's
    /// face everywhere: random directions, every vertex of level 6 (where
    /// five or six faces meet), points on level-6 edges and a hair off them,
    /// and the axes (which lie on base edges).
    #[test]
    fn the_centre_band_gives_the_full_rule() {
        let h = Icosahedral::new(6).unwrap();
        let mut probes: Vec<DVec3> = h.vertices().to_vec();
        probes.extend([
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            -DVec3::X,
            -DVec3::Y,
            -DVec3::Z,
        ]);
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20_000 {
            let z = 2.0 * next() - 1.0;
            let phi = std::f64::consts::TAU * next();
            let r = (1.0 - z * z).sqrt();
            probes.push(DVec3::new(r * phi.cos(), r * phi.sin(), z));
        }
        for t in h.triangles(6).iter().step_by(7) {
            let [a, b, _] = t.map(|v| h.vertices()[v as usize]);
            let e = (a + b).normalize();
            probes.push(e);
            probes.push((e + a.cross(b) * 1e-15).normalize());
            probes.push((e - a.cross(b) * 1e-15).normalize());
        }
        for d in probes {
            let d = d.normalize();
            assert_eq!(h.base.face_of(d), face_by_all_margins(&h.base, d), "{d}");
        }
    }
}
