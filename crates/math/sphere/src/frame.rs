//! Local shading frames and spherical-coordinate helpers.

use glam::{EulerRot, Mat3, Vec3};

/// An orthonormal frame; `z` is the surface normal in shading frames.
///
/// `to_local` maps world directions into the frame (`local_from_world`),
/// `from_local` maps back (`world_from_local`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Tangent (local +X).
    pub x: Vec3,
    /// Bitangent (local +Y), `z × x`.
    pub y: Vec3,
    /// Normal (local +Z).
    pub z: Vec3,
}

impl Frame {
    /// Builds a frame around the unit normal `n` with the branch-free rule of
    /// Duff et al. 2017 ("Building an Orthonormal Basis, Revisited"): the
    /// tangent is a continuous function of `n` except on the half-plane z < 0, y = 0.
    #[inline]
    #[must_use]
    pub fn from_z(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { x, y, z: n }
    }

    /// Builds a frame from a normal and a (not necessarily orthogonal)
    /// tangent by Gram–Schmidt; falls back to [`Frame::from_z`] when the
    /// tangent is parallel to the normal.
    #[must_use]
    pub fn from_normal_tangent(n: Vec3, t: Vec3) -> Self {
        let x = (t - n * n.dot(t)).try_normalize();
        match x {
            Some(x) => Self {
                x,
                y: n.cross(x),
                z: n,
            },
            None => Self::from_z(n),
        }
    }

    /// `local_from_world`: components of the world vector `v` in this frame.
    #[inline]
    #[must_use]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    /// `world_from_local`: the world vector whose local components are `v`.
    #[inline]
    #[must_use]
    pub fn from_local(&self, v: Vec3) -> Vec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
}

/// Direction from polar angle `theta` (radians, [0, π], measured from +Z) and
/// azimuth `phi` (radians, measured from +X towards +Y). Z-up, as in the SH
/// literature; use [`Frame`] to place it in the world.
#[inline]
#[must_use]
pub fn spherical_direction(theta: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * cp, st * sp, ct)
}

/// `world_from_old` rotation for yaw (about +Y), pitch (about +X) and roll
/// (about +Z), in degrees, applied in that order (yaw outermost):
/// `R_y(yaw) · R_x(pitch) · R_z(roll)`. The `--light-rotate` convention.
#[must_use]
pub fn rotation_from_yaw_pitch_roll(deg: [f32; 3]) -> Mat3 {
    Mat3::from_euler(
        EulerRot::YXZ,
        deg[0].to_radians(),
        deg[1].to_radians(),
        deg[2].to_radians(),
    )
}
