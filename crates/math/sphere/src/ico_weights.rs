//! Located directions with their barycentric weights, for lookups per
//! pixel: [`IcoWeights`].
//!
//! A per-pixel lookup on the icosahedral hierarchy (the triple-product
//! method's lighting table, indexed by the shading normal) needs the
//! triangle of one level that holds a direction and the direction's
//! barycentric weights in it. Neighbouring pixels mostly share that
//! triangle (a floor's normal is constant; a sphere's turns slowly), so the
//! last pixel's triangle is tried first.
//!
//! Weights come from three rows per triangle `(a, b, c)`, tabulated:
//! `w = (d·(b×c), d·(c×a), d·(a×b))`, normalised to sum 1 — Cramer's rule
//! of [`Icosahedral::barycentric`] with the determinant dropped (it is
//! positive for a CCW triangle and cancels in the normalisation). All
//! three are ≥ 0 exactly where `d` lies in the triangle's cone, so the
//! weights are also the containment test: a hint is taken when no weight
//! falls below −[`HINT_MARGIN`] of their sum, else [`IcoLocator::locate`]
//! answers. Inside a triangle the answer is `locate`'s; on an edge (or a
//! vertex), where `locate` picks one of the triangles that meet there, the
//! hint may be another of them: the weights of the shared corners agree
//! and the others are 0, to the margin (test `hinted_lookups_are_locates`).
//! That matters where a normal sits on an edge everywhere: a floor's +Y
//! lies on an edge of the base icosahedron.

use crate::icosahedral::{IcoLocator, Icosahedral, IcosahedralError};
use glam::DVec3;

/// How far below 0 a weight may fall, as a fraction of the weights' sum,
/// for a hint to be taken: far above the rows' rounding (~10⁻¹⁶), far
/// below any weight that matters.
pub const HINT_MARGIN: f64 = 1e-9;

/// [`IcoLocator`] at one level with every triangle's barycentric rows
/// (module docs): 72 bytes per triangle (92 KB at level 3).
#[derive(Clone, Debug)]
pub struct IcoWeights {
    locator: IcoLocator,
    /// Per triangle `(a, b, c)`: `[b×c, c×a, a×b]`.
    rows: Vec<[DVec3; 3]>,
}

impl Icosahedral {
    /// The weighted locator of `level` ([`IcoWeights`]).
    ///
    /// # Errors
    /// [`IcosahedralError::LevelTooDeep`].
    pub fn weights(&self, level: usize) -> Result<IcoWeights, IcosahedralError> {
        let locator = self.locator(level)?;
        let rows = (0..Self::triangle_count(level))
            .map(|i| {
                let [a, b, c] = self.triangle(level, i);
                [b.cross(c), c.cross(a), a.cross(b)]
            })
            .collect();
        Ok(IcoWeights { locator, rows })
    }
}

impl IcoWeights {
    /// The level it locates at.
    #[must_use]
    pub fn level(&self) -> usize {
        self.locator.level()
    }

    /// A triangle holding `d` (non-zero, need not be normalised) and `d`'s
    /// barycentric weights in it (sum 1, each ≥ −[`HINT_MARGIN`]): `hint`
    /// if it holds `d`, else [`IcoLocator::locate`]'s, left in `hint` for
    /// the next call (module docs). Any `hint` is valid; one out of range is
    /// ignored.
    #[inline]
    #[must_use]
    pub fn locate(&self, d: DVec3, hint: &mut usize) -> (usize, DVec3) {
        if let Some(w) = self.rows.get(*hint).map(|r| weigh(r, d)) {
            let sum = w.x + w.y + w.z;
            if w.min_element() >= -HINT_MARGIN * sum {
                return (*hint, w / sum);
            }
        }
        let i = self.locator.locate(d);
        *hint = i;
        let w = weigh(&self.rows[i], d);
        (i, w / (w.x + w.y + w.z))
    }
}

/// The unnormalised weights of `d` from a triangle's rows.
#[inline(always)]
fn weigh(rows: &[DVec3; 3], d: DVec3) -> DVec3 {
    DVec3::new(rows[0].dot(d), rows[1].dot(d), rows[2].dot(d))
}
