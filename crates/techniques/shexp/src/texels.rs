//! The visibility texture of a large flat receiver (issue 15: "receivers are
//! the meshes' vertices, with a visibility texture option for large flat
//! receivers"; [`crate::method::ShExpOptions::visibility_texture`]).
//!
//! A flat object (a ground quad) has too few vertices to carry a soft shadow.
//! Instead of refining it, its plane is covered by a `res × res` grid of
//! texels over the bounding rectangle of its vertices, and every texel
//! centre is a receiver point: it is clustered, baked (`T_p`) and shaded per
//! frame exactly as a vertex is. The frame then looks the shaded texels up
//! bilinearly at each pixel's point on the plane (clamped at the border), so
//! the shadow's resolution is the texture's, whatever the mesh's
//! triangulation. Texels outside a non-rectangular mesh are shaded too (they
//! are points of the same plane) and only feed the filtering at its edges.
//!
//! Frame: the grid lives in the object's frame at `prepare`; a moving flat
//! receiver looks pixels up through the inverse of its motion since then.

use glam::{Affine3A, Vec3};
use relight_geom::Mesh;

/// A flat receiver's texel grid (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct TexelGrid {
    /// Corner of texel (0, 0)'s cell.
    origin: Vec3,
    /// The plane's axes scaled to the rectangle's sides.
    u: Vec3,
    v: Vec3,
    /// The plane's unit normal (the side the mesh's normals face).
    normal: Vec3,
    res: usize,
}

impl TexelGrid {
    /// The grid of `res × res` texels over `mesh`'s plane, or `None` for an
    /// empty or degenerate mesh (no area, `res` 0).
    #[must_use]
    pub fn new(mesh: &Mesh, res: usize) -> Option<Self> {
        if res == 0 || mesh.positions.is_empty() {
            return None;
        }
        // The side the mesh faces: its vertex normals, else its winding.
        let normals = if mesh.normals.len() == mesh.positions.len() {
            mesh.normals.clone()
        } else {
            mesh.smooth_normals()
        };
        let normal = normals.iter().copied().sum::<Vec3>().try_normalize()?;
        let centroid = mesh.positions.iter().copied().sum::<Vec3>() / mesh.positions.len() as f32;
        let frame = relight_sphere::Frame::from_z(normal);
        let (ax, ay) = (frame.x, frame.y);
        let (mut lo, mut hi) = (glam::Vec2::splat(f32::MAX), glam::Vec2::splat(f32::MIN));
        for p in &mesh.positions {
            let d = *p - centroid;
            let q = glam::Vec2::new(d.dot(ax), d.dot(ay));
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let size = hi - lo;
        if !(size.min_element() > 0.0 && size.is_finite()) {
            return None;
        }
        Some(Self {
            origin: centroid + ax * lo.x + ay * lo.y,
            u: ax * size.x,
            v: ay * size.y,
            normal,
            res,
        })
    }

    /// Texels per side.
    #[must_use]
    pub fn res(&self) -> usize {
        self.res
    }

    /// The texel centres as a receiver point set (positions and normals, no
    /// triangles), texel `(i, j)` at index `j·res + i`.
    #[must_use]
    pub fn receiver_points(&self) -> Mesh {
        let r = self.res;
        let positions: Vec<Vec3> = (0..r * r)
            .map(|k| {
                let (i, j) = (k % r, k / r);
                self.origin
                    + self.u * ((i as f32 + 0.5) / r as f32)
                    + self.v * ((j as f32 + 0.5) / r as f32)
            })
            .collect();
        Mesh {
            normals: vec![self.normal; positions.len()],
            positions,
            ..Mesh::default()
        }
    }

    /// The texture `texels` (one value per texel, as
    /// [`Self::receiver_points`]) at world point `p`, the grid moved by
    /// `now_from_prepare` (whose inverse is `prepare_from_now`): bilinear
    /// between texel centres, clamped at the border.
    #[inline]
    #[must_use]
    pub fn lookup(&self, texels: &[Vec3], prepare_from_now: &Affine3A, p: Vec3) -> Vec3 {
        let q = prepare_from_now.transform_point3(p) - self.origin;
        let r = self.res;
        let s = |axis: Vec3| {
            let t = q.dot(axis) / axis.length_squared() * r as f32 - 0.5;
            let t = t.clamp(0.0, (r - 1) as f32);
            let i = (t as usize).min(r.saturating_sub(2));
            (i, t - i as f32)
        };
        let ((i, fx), (j, fy)) = (s(self.u), s(self.v));
        let at = |i: usize, j: usize| texels[j.min(r - 1) * r + i.min(r - 1)];
        (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy)
            + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texel_centres_cover_the_plane_and_look_up_exactly() {
        let floor = relight_geom::shapes::plane(4.0, 3);
        let g = TexelGrid::new(&floor, 8).expect("a plane");
        assert!((g.normal - Vec3::Y).length() < 1e-6, "{}", g.normal);
        let pts = g.receiver_points();
        assert_eq!(pts.positions.len(), 64);
        for p in &pts.positions {
            assert!(
                p.y.abs() < 1e-6 && p.x.abs() < 2.0 && p.z.abs() < 2.0,
                "{p}"
            );
        }
        // A linear function of position is reproduced exactly inside the
        // centres' hull, and at every centre.
        let f = |p: Vec3| Vec3::new(1.0 + p.x, 2.0 - 0.5 * p.z, 0.25 * (p.x + p.z));
        let texels: Vec<Vec3> = pts.positions.iter().map(|&p| f(p)).collect();
        let id = Affine3A::IDENTITY;
        for p in pts.positions.iter().chain(&[Vec3::new(0.3, 0.0, -1.1)]) {
            assert!((g.lookup(&texels, &id, *p) - f(*p)).length() < 1e-5, "{p}");
        }
        // A moved grid looks up through the inverse motion.
        let m = Affine3A::from_rotation_translation(
            glam::Quat::from_rotation_y(0.7),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let p = Vec3::new(0.4, 0.0, 0.9);
        let got = g.lookup(&texels, &m.inverse(), m.transform_point3(p));
        assert!((got - f(p)).length() < 1e-5);
        // Degenerate input.
        assert!(TexelGrid::new(&floor, 0).is_none());
        assert!(TexelGrid::new(&Mesh::default(), 8).is_none());
    }
}
