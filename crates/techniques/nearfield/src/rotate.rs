//! In-plane rotation of the light without a re-bake (thesis §4.5.6: the
//! light may be moved, scaled "and horizontally rotated" interactively).
//!
//! The Haar ACC/ATC of eqs. 4.31–4.32 are products of 1D ones: they
//! express scales and translations, "but not rotations or shears" (§4.4),
//! so a light turned about its normal is not an affine transform of the
//! baked face. Instead the turned light is **re-rasterised** into the
//! rectangle, aligned with the axes the transport was baked for, that
//! bounds it: that rectangle's radiance is the light's texture where the
//! turned rectangle covers it and zero elsewhere, and the method proceeds
//! as for an unturned light of the bounding rectangle's size (the same
//! affine map, eq. 4.34; the same ACC rows and masks, eq. 4.38).
//! For a square light this is the bounding square.
//!
//! With the light's `x̂ = c x̂_b + s ŷ_b` in the baked axes `(x̂_b, ŷ_b)`
//! and sides `w × h`, the bounding rectangle has sides
//! `W = w|c| + h|s|`, `H = w|s| + h|c|` and the light's centre; its point
//! at offsets `(X, Y)` along `(x̂_b, ŷ_b)` is at `(X c + Y s, −X s + Y c)`
//! in the light's own axes. The box average over each of the `n × n`
//! cells takes [`TURNED_SUBSAMPLES`]² reads (the turned rectangle's edges
//! cross cells, so coverage is resolved to 1/64 of a cell).

use crate::face::LightFrame;
use glam::{Mat3, Vec2, Vec3};
use relight_render::AreaLight;

/// Reads per cell side when re-rasterising a turned light.
pub const TURNED_SUBSAMPLES: usize = 8;

/// Largest difference of the light's axes from the baked ones (per
/// component of the unit vectors) still taken as the same normal, or as
/// an exact in-plane rotation: ≈ 0.006°.
pub const AXIS_TOLERANCE: f32 = 1e-4;

/// A light turned in its plane relative to the baked axes: its bounding
/// rectangle (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InPlane {
    /// Cosine and sine of the turn: the light's `x̂` is `c x̂_b + s ŷ_b`.
    pub cos: f32,
    pub sin: f32,
    /// The bounding rectangle: the light's centre, the baked axes, sides `(W, H)`.
    pub frame: LightFrame,
}

impl InPlane {
    /// `light` as turned in the plane of `baked` axes, or `None` when its
    /// normal differs from `baked`'s `ẑ` (or its axes are mirrored): a
    /// turn out of the plane needs a new transport.
    #[must_use]
    pub fn of(baked: &Mat3, light: &AreaLight) -> Option<Self> {
        let a = &light.world_from_light;
        let close = |u: Vec3, v: Vec3| (u - v).abs().max_element() <= AXIS_TOLERANCE;
        if !close(a.z_axis, baked.z_axis) {
            return None;
        }
        let (c, s) = (a.x_axis.dot(baked.x_axis), a.x_axis.dot(baked.y_axis));
        // ŷ must be x̂ turned by +90° in the same plane (a proper rotation).
        if (a.y_axis.dot(baked.x_axis) + s).abs() > AXIS_TOLERANCE
            || (a.y_axis.dot(baked.y_axis) - c).abs() > AXIS_TOLERANCE
        {
            return None;
        }
        let (w, h) = (light.size.x, light.size.y);
        let size = [w * c.abs() + h * s.abs(), w * s.abs() + h * c.abs()];
        Some(Self {
            cos: c,
            sin: s,
            frame: LightFrame {
                center: light.center,
                axes: *baked,
                size,
            },
        })
    }

    /// Radiance of the bounding rectangle at its texture coordinates `uv`
    /// (same convention as [`AreaLight::uv_of`]): `light`'s radiance where
    /// the turned rectangle covers the point, zero elsewhere.
    #[must_use]
    pub fn radiance(&self, light: &AreaLight, uv: Vec2) -> Vec3 {
        let [bw, bh] = self.frame.size;
        let (x, y) = ((uv.x - 0.5) * bw, (0.5 - uv.y) * bh);
        let (c, s) = (self.cos, self.sin);
        let (xl, yl) = (x * c + y * s, -x * s + y * c);
        let u = Vec2::new(0.5 + xl / light.size.x, 0.5 - yl / light.size.y);
        if (0.0..=1.0).contains(&u.x) && (0.0..=1.0).contains(&u.y) {
            light.radiance_at(u)
        } else {
            Vec3::ZERO
        }
    }

    /// The bounding rectangle's radiance box-averaged on an `n × n` grid.
    #[must_use]
    pub fn cells(&self, light: &AreaLight, n: usize) -> [Vec<f64>; 3] {
        crate::light::cells_of(n, TURNED_SUBSAMPLES, &|uv| self.radiance(light, uv))
    }
}
