//! The texel layouts of the sphere: lat-long, cube map, octahedral and
//! hemi-octahedral maps.
//!
//! A [`Param`] is a rectangular grid of texels plus a bijection between the
//! continuous grid coordinate `uv ∈ [0,1]²` and the unit sphere (or, for the
//! hemi-octahedral map, the upper hemisphere). Every variant provides the same
//! family of maps:
//!
//! | map | f64 (exact) | f32 (convenience) |
//! |---|---|---|
//! | grid → sphere | [`Param::dir_from_uv`], [`Param::dir_from_texel_f64`] | [`Param::dir_from_texel`] |
//! | sphere → grid | [`Param::uv_from_dir`], [`Param::texel_from_dir_f64`] | [`Param::texel_from_dir`] |
//! | measure | [`Param::texel_solid_angle`], [`Param::uv_rect_solid_angle`], [`Param::solid_angles_f64`] | [`Param::solid_angles`] |
//! | filtering | [`Param::bilinear_f64`] | [`Param::bilinear`] |
//!
//! Texels are numbered row-major, `index = row · width + col`; texel `(col,
//! row)` covers `uv ∈ [col/width, (col+1)/width] × [row/height, (row+1)/height]`
//! and its centre is at `((col + ½)/width, (row + ½)/height)`.
//!
//! # Solid angles are exact
//!
//! [`Param::texel_solid_angle`] integrates `dω` over the texel analytically, so
//! `Σ L_i Ω_i` is a quadrature of the sphere with no small-texel (Jacobian at
//! the centre) error, and `Σ Ω_i = 4π` (2π for the hemisphere) to rounding:
//!
//! * **lat-long**: a texel is a latitude–longitude patch,
//!   `Ω = Δφ (cos θ₀ − cos θ₁)`.
//! * **cube**: a texel is the central projection of a rectangle
//!   `[a₀,a₁]×[b₀,b₁]` of the plane at distance 1, so
//!   `Ω = F(a₁,b₁) − F(a₀,b₁) − F(a₁,b₀) + F(a₀,b₀)` with the corner function
//!   `F(a,b) = atan2(ab, √(a²+b²+1))` (the solid angle of `[0,a]×[0,b]`).
//! * **octahedral / hemi-octahedral**: the map from the square to the
//!   octahedron `|x|+|y|+|z| = 1` is piecewise *linear* (eight triangles for
//!   the sphere, four for the hemisphere), so a texel is a planar polygon on the
//!   octahedron, cut into at most eight convex pieces by the fold lines
//!   (`x = 0`, `y = 0`, `|x|+|y| = 1`). The sphere direction is the central
//!   projection of the octahedron point, so the solid angle of each piece is the
//!   exact sum of the solid angles of a fan of planar triangles seen from the
//!   origin, each given by the Van Oosterom–Strackee formula
//!   `tan(Ω/2) = |a·(b×c)| / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|)`.
//!   Any size `n ≥ 1` works (odd `n` simply puts fold lines through texel
//!   interiors).
//!
//! # Layouts
//!
//! ## Lat-long (equirectangular), `width × height`
//!
//! World **+Y up**. Polar angle θ ∈ [0, π] from +Y, azimuth φ ∈ [0, 2π):
//!
//! ```text
//! θ = π v,  φ = 2π u,   d = (−sin θ sin φ,  cos θ,  sin θ cos φ)
//! ```
//!
//! | u (column) | 0 | ¼ | ½ | ¾ |
//! |---|---|---|---|---|
//! | direction at the equator | +Z | −X | −Z | +X |
//!
//! Row 0 is the +Y pole (top of the image), the last row the −Y pole. The
//! image centre looks down −Z (the default glTF camera direction) and +X is to
//! its right, so a viewer inside the sphere sees the image unmirrored. Azimuth
//! increases with the column, from +Z through −X (φ = atan2(−x, z)).
//!
//! Bilinear lookup wraps in azimuth and reflects across the poles: the row
//! above row 0 is row 0 rotated by half a turn (column + width/2; needs an even
//! width — with an odd width the pole rows are clamped). The value at a pole
//! then depends on the approach azimuth only by `O(Δθ²)` for smooth data.
//!
//! ## Cube map, six `n × n` faces stacked vertically
//!
//! `width = n`, `height = 6n`, faces in the order +X, −X, +Y, −Y, +Z, −Z (face
//! `f` occupies rows `f n .. (f+1) n`). Within a face, with face coordinates
//! `a = 2s − 1`, `b = 2t − 1` (`s` across the columns, `t` down the rows),
//! `d ∝ N + a U + b V` — the OpenGL / Direct3D cube-map convention:
//!
//! | face | N | U (a, columns) | V (b, rows) |
//! |---|---|---|---|
//! | 0: +X | +X | −Z | −Y |
//! | 1: −X | −X | +Z | −Y |
//! | 2: +Y | +Y | +X | +Z |
//! | 3: −Y | −Y | +X | −Z |
//! | 4: +Z | +Z | +X | −Y |
//! | 5: −Z | −Z | −X | −Y |
//!
//! In whole-grid coordinates `uv = ((a+1)/2, (f + (b+1)/2) / 6)`. Bilinear
//! lookup crosses face edges to the texel adjacent on the sphere; at a cube
//! corner (where only three texels meet) the missing fourth weight is shared
//! equally by the three, which keeps the lookup continuous there too.
//!
//! ## Octahedral map of the sphere, `n × n` (Praun & Hoppe 2003)
//!
//! Map coordinates `p = 2 uv − 1 ∈ [−1,1]²` (`p.x` across the columns, `p.y`
//! down the rows). The square is folded onto the octahedron:
//!
//! ```text
//! z = 1 − |p.x| − |p.y|
//! o = (p.x, p.y, z)                                   if z ≥ 0  (inner diamond: upper hemisphere)
//! o = ((1 − |p.y|) sgn p.x, (1 − |p.x|) sgn p.y, z)   if z < 0  (corner triangles: lower hemisphere)
//! d = o / |o|
//! ```
//!
//! | map point | centre | edge midpoints | corners |
//! |---|---|---|---|
//! | direction | +Z | ±X, ±Y (on the equator diamond) | −Z |
//!
//! Inverse: `o = d / (|d.x|+|d.y|+|d.z|)`, unfolded when `d.z < 0`. The outer
//! edges are seams: the point `(1, y)` is the point `(1, −y)`, and all four
//! corners are −Z. Bilinear lookup follows these folds (the texel beyond the
//! right edge at row `r` is the edge texel at row `n−1−r`), so it is continuous
//! everywhere on the sphere.
//!
//! ## Hemi-octahedral map of the upper hemisphere z ≥ 0, `n × n`
//!
//! The inner diamond of the octahedral map (the four upper faces of the
//! octahedron) rotated by 45° and scaled to fill the square, as in
//! Wang et al. 2006 §3 (Figure 3b). With `q = 2 uv − 1 ∈ [−1,1]²`:
//!
//! ```text
//! x = (q.x + q.y) / 2,   y = (q.y − q.x) / 2,   d ∝ (x, y, 1 − |x| − |y|)
//! ```
//!
//! | map point | centre | corners (1,1) (−1,1) (−1,−1) (1,−1) | edges |
//! |---|---|---|---|
//! | direction | +Z | +X, +Y, −X, −Y | equator |
//!
//! The fold lines `x = 0`, `y = 0` are the square's diagonals. Directions with
//! `z < 0` (where the map stores nothing) are mirrored to `(x, y, −z)`;
//! bilinear lookup clamps at the square's edges (the horizon).
//!
//! # References
//!
//! * [Praun & Hoppe 2003] E. Praun, H. Hoppe, "Spherical parametrization and
//!   remeshing", SIGGRAPH 2003 — octahedral maps.
//! * [Wang et al. 2006] R. Wang, R. Ng, D. Luebke, G. Humphreys, "Efficient
//!   wavelet rotation for environment map rendering", EGSR 2006, §3
//!   (`wavelet-rotation-2006.txt`) — octahedral and hemi-octahedral maps.
//! * [Van Oosterom & Strackee 1983] "The solid angle of a plane triangle",
//!   IEEE Trans. Biomed. Eng. 30(2).

use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};

/// A parameterization of the sphere (or, for [`Param::HemiOctahedral`], of the
/// upper hemisphere z ≥ 0 of a local frame) by a grid of texels.
///
/// Texels are numbered row-major: `index = row * width + col`; a cube map
/// stacks its six faces vertically (`width = n`, `height = 6 n`, faces in the
/// order +X, −X, +Y, −Y, +Z, −Z).
///
/// All sizes must be ≥ 1 ([`Param::validate`]); the methods assume a valid
/// parameterization.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Param {
    /// Equirectangular, `width × height` (usually width = 2 height); world
    /// +Y up, row 0 at the top (+Y).
    LatLong {
        /// Columns (azimuth samples).
        width: usize,
        /// Rows (polar-angle samples).
        height: usize,
    },
    /// Six `n × n` faces.
    Cube {
        /// Face side in texels.
        n: usize,
    },
    /// Praun–Hoppe octahedral map of the whole sphere, `n × n`, poles on ±Z
    /// (+Z at the centre of the square).
    Octahedral {
        /// Side of the square in texels (any n ≥ 1).
        n: usize,
    },
    /// Octahedral map of the upper hemisphere z ≥ 0, `n × n` (the inner
    /// diamond of the octahedral map stretched to the square).
    HemiOctahedral {
        /// Side of the square in texels (any n ≥ 1).
        n: usize,
    },
}

/// Four texels and bilinear weights that sum to 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bilinear {
    /// Texel indices (may repeat).
    pub texels: [u32; 4],
    /// Non-negative weights, summing to 1.
    pub weights: [f32; 4],
}

/// Four texels and bilinear weights (f64) that sum to 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BilinearF64 {
    /// Texel indices (may repeat).
    pub texels: [usize; 4],
    /// Non-negative weights, summing to 1.
    pub weights: [f64; 4],
}

/// Why a [`Param`] is unusable.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ParamError {
    /// A size parameter (`width`, `height` or `n`) is zero.
    ZeroSize {
        /// The offending parameterization.
        param: Param,
    },
    /// The texel count overflows `u32` (bilinear footprints store `u32` indices).
    TooLarge {
        /// The offending parameterization.
        param: Param,
    },
}

impl std::fmt::Display for ParamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::ZeroSize { param } => {
                write!(
                    f,
                    "invalid spherical parameterization {param:?}: sizes must be at least 1"
                )
            }
            Self::TooLarge { param } => write!(
                f,
                "invalid spherical parameterization {param:?}: more than 2^32 texels; use a smaller size"
            ),
        }
    }
}

impl std::error::Error for ParamError {}

/// Cube faces `(N, U, V)`: `d ∝ N + a U + b V` (see the module table).
const CUBE_FACES: [[DVec3; 3]; 6] = [
    [DVec3::X, DVec3::NEG_Z, DVec3::NEG_Y],
    [DVec3::NEG_X, DVec3::Z, DVec3::NEG_Y],
    [DVec3::Y, DVec3::X, DVec3::Z],
    [DVec3::NEG_Y, DVec3::X, DVec3::NEG_Z],
    [DVec3::Z, DVec3::X, DVec3::NEG_Y],
    [DVec3::NEG_Z, DVec3::NEG_X, DVec3::NEG_Y],
];

/// `+1` for `x ≥ 0` (including −0), else `−1`: the octahedral fold sign.
#[inline]
fn sgn(x: f64) -> f64 {
    if x >= 0.0 { 1.0 } else { -1.0 }
}

/// Octahedron point (not normalised) of octahedral map coordinate `p ∈ [−1,1]²`.
#[inline]
#[must_use]
pub fn octahedron_from_octahedral(p: DVec2) -> DVec3 {
    let z = 1.0 - p.x.abs() - p.y.abs();
    if z >= 0.0 {
        DVec3::new(p.x, p.y, z)
    } else {
        DVec3::new(
            (1.0 - p.y.abs()) * sgn(p.x),
            (1.0 - p.x.abs()) * sgn(p.y),
            z,
        )
    }
}

/// Octahedral map coordinate `p ∈ [−1,1]²` of a non-zero direction.
#[inline]
#[must_use]
pub fn octahedral_from_dir(d: DVec3) -> DVec2 {
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let p = DVec2::new(d.x / l1, d.y / l1);
    if d.z < 0.0 {
        DVec2::new((1.0 - p.y.abs()) * sgn(p.x), (1.0 - p.x.abs()) * sgn(p.y))
    } else {
        p
    }
}

/// Diamond (octahedron-plane) coordinates of hemi-octahedral map coordinate `q`.
#[inline]
fn diamond_from_hemi(q: DVec2) -> DVec2 {
    DVec2::new(0.5 * (q.x + q.y), 0.5 * (q.y - q.x))
}

/// Hemi-octahedral map coordinate `q ∈ [−1,1]²` of a direction (z mirrored to ≥ 0).
#[inline]
#[must_use]
pub fn hemi_octahedral_from_dir(d: DVec3) -> DVec2 {
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let (x, y) = (d.x / l1, d.y / l1);
    DVec2::new((x - y).clamp(-1.0, 1.0), (x + y).clamp(-1.0, 1.0))
}

/// Octahedron point (not normalised) of hemi-octahedral map coordinate `q ∈ [−1,1]²`.
#[inline]
#[must_use]
pub fn octahedron_from_hemi_octahedral(q: DVec2) -> DVec3 {
    let p = diamond_from_hemi(q);
    DVec3::new(p.x, p.y, (1.0 - p.x.abs() - p.y.abs()).max(0.0))
}

/// [`octahedral_from_dir`] in f32 (hot paths: per-vertex normal lookups).
#[inline]
#[must_use]
pub fn octahedral_from_dir_f32(d: Vec3) -> glam::Vec2 {
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let (x, y) = (d.x / l1, d.y / l1);
    if d.z < 0.0 {
        let sx = if x >= 0.0 { 1.0 } else { -1.0 };
        let sy = if y >= 0.0 { 1.0 } else { -1.0 };
        glam::Vec2::new((1.0 - y.abs()) * sx, (1.0 - x.abs()) * sy)
    } else {
        glam::Vec2::new(x, y)
    }
}

/// [`hemi_octahedral_from_dir`] in f32 (z mirrored to ≥ 0; `d` non-zero).
#[inline]
#[must_use]
pub fn hemi_octahedral_from_dir_f32(d: Vec3) -> glam::Vec2 {
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let (x, y) = (d.x / l1, d.y / l1);
    glam::Vec2::new((x - y).clamp(-1.0, 1.0), (x + y).clamp(-1.0, 1.0))
}

/// Cube face index and face coordinates `(a, b) ∈ [−1,1]²` of a non-zero direction.
#[inline]
#[must_use]
pub fn cube_face_from_dir(d: DVec3) -> (usize, DVec2) {
    let a = d.abs();
    let face = if a.x >= a.y && a.x >= a.z {
        usize::from(d.x < 0.0)
    } else if a.y >= a.z {
        2 + usize::from(d.y < 0.0)
    } else {
        4 + usize::from(d.z < 0.0)
    };
    let [n, u, v] = CUBE_FACES[face];
    let m = d.dot(n);
    let ab = DVec2::new(d.dot(u) / m, d.dot(v) / m).clamp(DVec2::NEG_ONE, DVec2::ONE);
    (face, ab)
}

/// Unit direction of cube face `face` at face coordinates `ab`.
#[inline]
#[must_use]
pub fn dir_from_cube_face(face: usize, ab: DVec2) -> DVec3 {
    let [n, u, v] = CUBE_FACES[face];
    (n + u * ab.x + v * ab.y).normalize()
}

/// Solid angle of the planar triangle `abc` seen from the origin (Van
/// Oosterom & Strackee 1983); the vertices need not be unit length.
/// Valid when the triangle does not contain the origin.
#[inline]
#[must_use]
pub fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let triple = a.dot(b.cross(c)).abs();
    let denom = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * triple.atan2(denom)
}

/// Small fixed-capacity convex polygon (no allocation in the solid-angle loops).
#[derive(Clone, Copy)]
struct Poly {
    v: [DVec2; 12],
    len: usize,
}

impl Poly {
    fn from_slice(pts: &[DVec2]) -> Self {
        let mut v = [DVec2::ZERO; 12];
        v[..pts.len()].copy_from_slice(pts);
        Self { v, len: pts.len() }
    }

    /// Sutherland–Hodgman clip to the half-plane `n·p ≤ c`.
    fn clip(&self, n: DVec2, c: f64) -> Self {
        let mut out = Self {
            v: [DVec2::ZERO; 12],
            len: 0,
        };
        if self.len == 0 {
            return out;
        }
        for i in 0..self.len {
            let p = self.v[i];
            let q = self.v[(i + 1) % self.len];
            let (dp, dq) = (n.dot(p) - c, n.dot(q) - c);
            if dp <= 0.0 {
                out.push(p);
            }
            if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                let t = dp / (dp - dq);
                out.push(p + (q - p) * t);
            }
        }
        out
    }

    fn push(&mut self, p: DVec2) {
        if self.len < self.v.len() {
            self.v[self.len] = p;
            self.len += 1;
        }
    }
}

/// Octahedron lift of a point known to lie in quadrant `(sx, sy)`, inner or outer region.
#[inline]
fn lift(p: DVec2, sx: f64, sy: f64, outer: bool) -> DVec3 {
    let z = 1.0 - p.x.abs() - p.y.abs();
    if outer {
        DVec3::new((1.0 - p.y.abs()) * sx, (1.0 - p.x.abs()) * sy, z)
    } else {
        DVec3::new(p.x, p.y, z)
    }
}

/// Solid angle of a convex polygon lifted onto one octahedron face (fan of triangles).
fn lifted_fan_solid_angle(poly: &Poly, sx: f64, sy: f64, outer: bool) -> f64 {
    if poly.len < 3 {
        return 0.0;
    }
    let a = lift(poly.v[0], sx, sy, outer);
    let mut sum = 0.0;
    let mut b = lift(poly.v[1], sx, sy, outer);
    for k in 2..poly.len {
        let c = lift(poly.v[k], sx, sy, outer);
        sum += triangle_solid_angle(a, b, c);
        b = c;
    }
    sum
}

/// Exact solid angle subtended by the octahedral lift of a convex polygon
/// given in octahedral map coordinates (`[−1,1]²`).
fn octahedral_polygon_solid_angle(poly: &Poly) -> f64 {
    let pts = &poly.v[..poly.len];
    // Fast path: the whole polygon lies in one of the eight linear pieces.
    let all = |f: &dyn Fn(DVec2) -> bool| pts.iter().all(|&p| f(p));
    for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
        if all(&|p| p.x * sx >= 0.0 && p.y * sy >= 0.0) {
            if all(&|p| p.x.abs() + p.y.abs() <= 1.0) {
                return lifted_fan_solid_angle(poly, sx, sy, false);
            }
            if all(&|p| p.x.abs() + p.y.abs() >= 1.0) {
                return lifted_fan_solid_angle(poly, sx, sy, true);
            }
        }
    }
    let mut sum = 0.0;
    for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
        // Quadrant: sx·x ≥ 0 and sy·y ≥ 0.
        let q = poly
            .clip(DVec2::new(-sx, 0.0), 0.0)
            .clip(DVec2::new(0.0, -sy), 0.0);
        if q.len < 3 {
            continue;
        }
        let diag = DVec2::new(sx, sy);
        let inner = q.clip(diag, 1.0);
        let outer = q.clip(-diag, -1.0);
        sum += lifted_fan_solid_angle(&inner, sx, sy, false);
        sum += lifted_fan_solid_angle(&outer, sx, sy, true);
    }
    sum
}

/// Solid angle of the rectangle `[a0,a1]×[b0,b1]` of a cube face (gnomonic).
#[inline]
fn cube_rect_solid_angle(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    let f = |a: f64, b: f64| (a * b).atan2((a * a + b * b + 1.0).sqrt());
    f(a1, b1) - f(a0, b1) - f(a1, b0) + f(a0, b0)
}

impl Param {
    /// Grid width in texels.
    #[must_use]
    pub fn width(&self) -> usize {
        match *self {
            Self::LatLong { width, .. } => width,
            Self::Cube { n } | Self::Octahedral { n } | Self::HemiOctahedral { n } => n,
        }
    }
    /// Grid height in texels (6 n for a cube map).
    #[must_use]
    pub fn height(&self) -> usize {
        match *self {
            Self::LatLong { height, .. } => height,
            Self::Cube { n } => 6 * n,
            Self::Octahedral { n } | Self::HemiOctahedral { n } => n,
        }
    }
    /// Number of texels.
    #[must_use]
    pub fn len(&self) -> usize {
        self.width() * self.height()
    }
    /// True when the grid has no texels (an invalid parameterization).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Checks that every size is ≥ 1 and the texel count fits in `u32`.
    ///
    /// # Errors
    /// [`ParamError::ZeroSize`] or [`ParamError::TooLarge`].
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.width() == 0 || self.height() == 0 {
            return Err(ParamError::ZeroSize { param: *self });
        }
        if self
            .width()
            .checked_mul(self.height())
            .is_none_or(|l| l > u32::MAX as usize)
        {
            return Err(ParamError::TooLarge { param: *self });
        }
        Ok(())
    }
    /// True for the hemi-octahedral map (covers z ≥ 0 only).
    #[must_use]
    pub fn is_hemisphere(&self) -> bool {
        matches!(self, Self::HemiOctahedral { .. })
    }
    /// Total solid angle covered: 4π, or 2π for the hemisphere.
    #[must_use]
    pub fn total_solid_angle(&self) -> f64 {
        if self.is_hemisphere() { TAU } else { 2.0 * TAU }
    }
    /// Direction through the continuous map coordinate `uv ∈ [0,1]²` of the
    /// whole grid (texel centres at `(col + 0.5) / width`). Unit length.
    #[must_use]
    pub fn dir_from_uv(&self, uv: DVec2) -> DVec3 {
        match *self {
            Self::LatLong { .. } => {
                let (st, ct) = (PI * uv.y).sin_cos();
                let (sp, cp) = (TAU * uv.x).sin_cos();
                DVec3::new(-st * sp, ct, st * cp)
            }
            Self::Cube { .. } => {
                let fy = uv.y * 6.0;
                let face = (fy.floor().max(0.0) as usize).min(5);
                let t = fy - face as f64;
                dir_from_cube_face(face, DVec2::new(2.0 * uv.x - 1.0, 2.0 * t - 1.0))
            }
            Self::Octahedral { .. } => octahedron_from_octahedral(uv * 2.0 - 1.0).normalize(),
            Self::HemiOctahedral { .. } => {
                octahedron_from_hemi_octahedral(uv * 2.0 - 1.0).normalize()
            }
        }
    }
    /// Continuous map coordinate of a direction (inverse of `dir_from_uv`).
    /// `d` need not be normalised but must be non-zero. For the hemi-octahedral
    /// map, directions with z < 0 are mirrored to z > 0.
    #[must_use]
    pub fn uv_from_dir(&self, d: DVec3) -> DVec2 {
        match *self {
            Self::LatLong { .. } => {
                let theta = (d.x.hypot(d.z)).atan2(d.y);
                let mut phi = (-d.x).atan2(d.z);
                if phi < 0.0 {
                    phi += TAU;
                }
                let u = phi / TAU;
                DVec2::new(if u >= 1.0 { 0.0 } else { u }, theta / PI)
            }
            Self::Cube { .. } => {
                let (face, ab) = cube_face_from_dir(d);
                DVec2::new(0.5 * (ab.x + 1.0), (face as f64 + 0.5 * (ab.y + 1.0)) / 6.0)
            }
            Self::Octahedral { .. } => {
                (octahedral_from_dir(d) * 0.5 + 0.5).clamp(DVec2::ZERO, DVec2::ONE)
            }
            Self::HemiOctahedral { .. } => {
                (hemi_octahedral_from_dir(d) * 0.5 + 0.5).clamp(DVec2::ZERO, DVec2::ONE)
            }
        }
    }
    /// `(col, row)` of texel `i`.
    #[inline]
    #[must_use]
    pub fn col_row(&self, i: usize) -> (usize, usize) {
        let w = self.width();
        (i % w, i / w)
    }
    /// The uv rectangle `(min, max)` covered by texel `i`.
    #[must_use]
    pub fn texel_uv_rect(&self, i: usize) -> (DVec2, DVec2) {
        let (c, r) = self.col_row(i);
        let (w, h) = (self.width() as f64, self.height() as f64);
        (
            DVec2::new(c as f64 / w, r as f64 / h),
            DVec2::new((c + 1) as f64 / w, (r + 1) as f64 / h),
        )
    }
    /// uv of the centre of texel `i`.
    #[must_use]
    pub fn texel_center_uv(&self, i: usize) -> DVec2 {
        let (c, r) = self.col_row(i);
        DVec2::new(
            (c as f64 + 0.5) / self.width() as f64,
            (r as f64 + 0.5) / self.height() as f64,
        )
    }
    /// Directions of the four corners of texel `i` (uv order: min, (max.x,
    /// min.y), max, (min.x, max.y)).
    #[must_use]
    pub fn texel_corners(&self, i: usize) -> [DVec3; 4] {
        let (a, b) = self.texel_uv_rect(i);
        // Nudge inside the texel so a cube corner stays on its own face.
        let e = DVec2::splat(1e-12);
        let (a, b) = (a + e, b - e);
        [
            self.dir_from_uv(a),
            self.dir_from_uv(DVec2::new(b.x, a.y)),
            self.dir_from_uv(b),
            self.dir_from_uv(DVec2::new(a.x, b.y)),
        ]
    }
    /// Direction through the centre of texel `i` (unit length, f64).
    #[must_use]
    pub fn dir_from_texel_f64(&self, i: usize) -> DVec3 {
        self.dir_from_uv(self.texel_center_uv(i))
    }
    /// Direction through the centre of texel `i` (unit length).
    #[must_use]
    pub fn dir_from_texel(&self, i: usize) -> Vec3 {
        self.dir_from_texel_f64(i).as_vec3()
    }
    /// Texel containing the continuous map coordinate `uv` (clamped to the grid).
    #[must_use]
    pub fn texel_from_uv(&self, uv: DVec2) -> usize {
        let (w, h) = (self.width(), self.height());
        let c = ((uv.x * w as f64).floor().max(0.0) as usize).min(w - 1);
        let r = ((uv.y * h as f64).floor().max(0.0) as usize).min(h - 1);
        r * w + c
    }
    /// Texel containing direction `d` (need not be normalised; must be non-zero).
    #[must_use]
    pub fn texel_from_dir_f64(&self, d: DVec3) -> usize {
        match *self {
            Self::Cube { n } => {
                let (face, ab) = cube_face_from_dir(d);
                let c = ((0.5 * (ab.x + 1.0) * n as f64).floor() as usize).min(n - 1);
                let r = ((0.5 * (ab.y + 1.0) * n as f64).floor() as usize).min(n - 1);
                (face * n + r) * n + c
            }
            _ => self.texel_from_uv(self.uv_from_dir(d)),
        }
    }
    /// Texel containing direction `d` (need not be normalised; must be non-zero).
    #[must_use]
    pub fn texel_from_dir(&self, d: Vec3) -> usize {
        self.texel_from_dir_f64(d.as_dvec3())
    }
    /// Exact solid angle (steradians) of the region `[min, max]` of the uv
    /// square. For a cube map the rectangle must lie within one face.
    #[must_use]
    pub fn uv_rect_solid_angle(&self, min: DVec2, max: DVec2) -> f64 {
        match *self {
            Self::LatLong { .. } => {
                (max.x - min.x) * TAU * ((PI * min.y).cos() - (PI * max.y).cos())
            }
            Self::Cube { .. } => {
                let face = (((min.y + max.y) * 3.0).floor().max(0.0) as usize).min(5);
                let f = face as f64;
                let b0 = 2.0 * (min.y * 6.0 - f) - 1.0;
                let b1 = 2.0 * (max.y * 6.0 - f) - 1.0;
                cube_rect_solid_angle(2.0 * min.x - 1.0, 2.0 * max.x - 1.0, b0, b1)
            }
            Self::Octahedral { .. } => {
                let (a, b) = (min * 2.0 - 1.0, max * 2.0 - 1.0);
                let poly = Poly::from_slice(&[a, DVec2::new(b.x, a.y), b, DVec2::new(a.x, b.y)]);
                octahedral_polygon_solid_angle(&poly)
            }
            Self::HemiOctahedral { .. } => {
                let (a, b) = (min * 2.0 - 1.0, max * 2.0 - 1.0);
                let poly = Poly::from_slice(&[
                    diamond_from_hemi(a),
                    diamond_from_hemi(DVec2::new(b.x, a.y)),
                    diamond_from_hemi(b),
                    diamond_from_hemi(DVec2::new(a.x, b.y)),
                ]);
                octahedral_polygon_solid_angle(&poly)
            }
        }
    }
    /// Area element `dω / (du dv)` at the map coordinate `uv` (steradians per
    /// unit uv area; the Jacobian whose integral over a texel is
    /// [`Param::texel_solid_angle`]). Used to weight sub-texel samples.
    ///
    /// * lat-long: `2π² sin(πv)`;
    /// * cube: `24 / (1 + a² + b²)^{3/2}` with the face coordinates `(a, b)`;
    /// * octahedral: `4 / |o|³` and hemi-octahedral: `2 / |o|³`, with `o` the
    ///   octahedron point (on a face `dω = (o·n̂)/|o|³ dA`, `o·n̂ = 1/√3`,
    ///   `dA = √3 dx dy`, and `dx dy = 4 du dv`, resp. `2 du dv` for the
    ///   45°-rotated hemi-octahedral square).
    #[must_use]
    pub fn uv_density(&self, uv: DVec2) -> f64 {
        match *self {
            Self::LatLong { .. } => 2.0 * PI * PI * (PI * uv.y).sin(),
            Self::Cube { .. } => {
                let fy = uv.y * 6.0;
                let face = fy.floor().clamp(0.0, 5.0);
                let (a, b) = (2.0 * uv.x - 1.0, 2.0 * (fy - face) - 1.0);
                24.0 / (1.0 + a * a + b * b).powf(1.5)
            }
            Self::Octahedral { .. } => {
                4.0 / octahedron_from_octahedral(uv * 2.0 - 1.0).length().powi(3)
            }
            Self::HemiOctahedral { .. } => {
                2.0 / octahedron_from_hemi_octahedral(uv * 2.0 - 1.0)
                    .length()
                    .powi(3)
            }
        }
    }
    /// Exact solid angle of texel `i` in steradians (analytic, f64).
    #[must_use]
    pub fn texel_solid_angle(&self, i: usize) -> f64 {
        match *self {
            Self::Cube { n } => {
                let (c, r) = self.col_row(i);
                let r = r % n;
                let s = 2.0 / n as f64;
                cube_rect_solid_angle(
                    -1.0 + c as f64 * s,
                    -1.0 + (c + 1) as f64 * s,
                    -1.0 + r as f64 * s,
                    -1.0 + (r + 1) as f64 * s,
                )
            }
            _ => {
                let (a, b) = self.texel_uv_rect(i);
                self.uv_rect_solid_angle(a, b)
            }
        }
    }
    /// All texel solid angles, f32, in texel order (handy for quadrature).
    #[must_use]
    pub fn solid_angles(&self) -> Vec<f32> {
        (0..self.len())
            .map(|i| self.texel_solid_angle(i) as f32)
            .collect()
    }
    /// All texel solid angles, f64, in texel order.
    #[must_use]
    pub fn solid_angles_f64(&self) -> Vec<f64> {
        (0..self.len())
            .into_par_iter()
            .map(|i| self.texel_solid_angle(i))
            .collect()
    }
    /// All texel centre directions in texel order.
    #[must_use]
    pub fn directions(&self) -> Vec<Vec3> {
        (0..self.len()).map(|i| self.dir_from_texel(i)).collect()
    }
    /// Bilinear footprint of `d`, continuous across seams and poles (neighbours
    /// across a seam are the texels adjacent on the sphere).
    #[must_use]
    ///
    /// Lat-long maps take an f32 path ([`crate::atan::atan2_f32`], no f64
    /// transcendental: it was most of a frame's background fill); it agrees
    /// with [`Param::bilinear_f64`] to about 10⁻⁴ of a texel in position (test
    /// `latlong_bilinear_f32_matches_f64`).
    pub fn bilinear(&self, d: Vec3) -> Bilinear {
        if let Self::LatLong { width, height } = *self {
            return latlong_bilinear_f32(width, height, d);
        }
        let b = self.bilinear_f64(d.as_dvec3());
        Bilinear {
            texels: b.texels.map(|t| t as u32),
            weights: b.weights.map(|w| w as f32),
        }
    }
    /// Bilinear footprint of `d` in f64 (see [`Param::bilinear`]).
    #[must_use]
    pub fn bilinear_f64(&self, d: DVec3) -> BilinearF64 {
        if let Self::Cube { n } = *self {
            return cube_bilinear(n, d);
        }
        let (w, h) = (self.width() as i64, self.height() as i64);
        let uv = self.uv_from_dir(d);
        let x = uv.x * w as f64 - 0.5;
        let y = uv.y * h as f64 - 0.5;
        let (c0, r0) = (x.floor(), y.floor());
        let (fx, fy) = (x - c0, y - r0);
        let (c0, r0) = (c0 as i64, r0 as i64);
        let slots = [(c0, r0), (c0 + 1, r0), (c0, r0 + 1), (c0 + 1, r0 + 1)];
        let weights = [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ];
        let texels = slots.map(|(c, r)| {
            let (c, r) = match *self {
                Self::LatLong { .. } => {
                    let half = if w % 2 == 0 { w / 2 } else { 0 };
                    let (c, r) = if r < 0 {
                        (c + half, -1 - r)
                    } else if r >= h {
                        (c + half, 2 * h - 1 - r)
                    } else {
                        (c, r)
                    };
                    (c.rem_euclid(w), r.clamp(0, h - 1))
                }
                Self::Octahedral { .. } => {
                    let n = w;
                    let (c, r) = if c < 0 {
                        (0, n - 1 - r)
                    } else if c >= n {
                        (n - 1, n - 1 - r)
                    } else {
                        (c, r)
                    };
                    if r < 0 {
                        (n - 1 - c, 0)
                    } else if r >= n {
                        (n - 1 - c, n - 1)
                    } else {
                        (c, r)
                    }
                }
                _ => (c.clamp(0, w - 1), r.clamp(0, h - 1)),
            };
            (r * w + c) as usize
        });
        BilinearF64 { texels, weights }
    }
}

/// [`Param::bilinear`] of a `width × height` lat-long map in f32: the uv of
/// [`Param::uv_from_dir`] and the seam and pole rules of
/// [`Param::bilinear_f64`].
#[inline]
fn latlong_bilinear_f32(width: usize, height: usize, d: Vec3) -> Bilinear {
    use std::f32::consts::{PI, TAU};
    let theta = crate::atan::atan2_f32((d.x * d.x + d.z * d.z).sqrt(), d.y);
    let mut phi = crate::atan::atan2_f32(-d.x, d.z);
    if phi < 0.0 {
        phi += TAU;
    }
    let u = phi / TAU;
    let u = if u >= 1.0 { 0.0 } else { u };
    let v = theta / PI;
    let (w, h) = (width as i32, height as i32);
    let x = u * w as f32 - 0.5;
    let y = v * h as f32 - 0.5;
    // `floor` by truncation (x, y ∈ [−0.5, w]): `f32::floor` is a libm call
    // on baseline x86-64 (no SSE4.1 `roundss`).
    let floor = |t: f32| {
        let i = t as i32;
        if i as f32 > t { i - 1 } else { i }
    };
    let (c0, r0) = (floor(x), floor(y));
    let (fx, fy) = (x - c0 as f32, y - r0 as f32);
    let texel = |c: i32, r: i32| latlong_texel(w, h, c, r);
    Bilinear {
        texels: [
            texel(c0, r0),
            texel(c0 + 1, r0),
            texel(c0, r0 + 1),
            texel(c0 + 1, r0 + 1),
        ],
        weights: [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ],
    }
}

/// Texel `(c, r)` of a `w × h` lat-long map, for a column `c ∈ [−1, w]` and
/// a row `r ∈ [−1, h]` one step outside at most: across a pole the row
/// reflects and the column turns half way round; across the seam the
/// column wraps (the rules of [`Param::bilinear_f64`]).
#[inline(always)]
pub(crate) fn latlong_texel(w: i32, h: i32, c: i32, r: i32) -> u32 {
    let half = if w % 2 == 0 { w / 2 } else { 0 };
    let (c, r) = if r < 0 {
        (c + half, -1 - r)
    } else if r >= h {
        (c + half, 2 * h - 1 - r)
    } else {
        (c, r)
    };
    // c ∈ [−1, w + w/2]: one wrap, not `rem_euclid` (an integer division).
    let c = if c < 0 {
        c + w
    } else if c >= w {
        c - w
    } else {
        c
    };
    (i64::from(r.clamp(0, h - 1)) * i64::from(w) + i64::from(c)) as u32
}

/// Cube-map bilinear footprint; crosses face edges, shares the missing weight
/// at cube corners equally among the three texels that meet there.
fn cube_bilinear(n: usize, d: DVec3) -> BilinearF64 {
    let (face, ab) = cube_face_from_dir(d);
    let ni = n as i64;
    let x = 0.5 * (ab.x + 1.0) * n as f64 - 0.5;
    let y = 0.5 * (ab.y + 1.0) * n as f64 - 0.5;
    let (c0, r0) = (x.floor(), y.floor());
    let (fx, fy) = (x - c0, y - r0);
    let (c0, r0) = (c0 as i64, r0 as i64);
    let slots = [(c0, r0), (c0 + 1, r0), (c0, r0 + 1), (c0 + 1, r0 + 1)];
    let mut weights = [
        (1.0 - fx) * (1.0 - fy),
        fx * (1.0 - fy),
        (1.0 - fx) * fy,
        fx * fy,
    ];
    let param = Param::Cube { n };
    let [nn, uu, vv] = CUBE_FACES[face];
    let delta = 1.0 / n as f64; // ghost centre lies δ beyond the edge (texel width 2/n)
    let centre = |k: i64| -1.0 + (k as f64 + 0.5) * 2.0 * delta;
    let mut texels = [0usize; 4];
    let mut corner_slot = None;
    for (k, &(c, r)) in slots.iter().enumerate() {
        let c_in = (0..ni).contains(&c);
        let r_in = (0..ni).contains(&r);
        texels[k] = match (c_in, r_in) {
            (true, true) => (face * n + r as usize) * n + c as usize,
            (false, true) => {
                let s = if c < 0 { -1.0 } else { 1.0 };
                param.texel_from_dir_f64(nn * (1.0 - delta) + uu * s + vv * centre(r))
            }
            (true, false) => {
                let s = if r < 0 { -1.0 } else { 1.0 };
                param.texel_from_dir_f64(nn * (1.0 - delta) + uu * centre(c) + vv * s)
            }
            (false, false) => {
                corner_slot = Some(k);
                (face * n + r.clamp(0, ni - 1) as usize) * n + c.clamp(0, ni - 1) as usize
            }
        };
    }
    if let Some(k) = corner_slot {
        let share = weights[k] / 3.0;
        weights[k] = 0.0;
        for (j, w) in weights.iter_mut().enumerate() {
            if j != k {
                *w += share;
            }
        }
    }
    BilinearF64 { texels, weights }
}
