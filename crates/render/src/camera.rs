//! [`Camera`]: a pinhole perspective camera.

use glam::{Mat4, Vec3};

/// A pinhole camera looking from `eye` at `target`, `up` roughly up,
/// vertical field of view `vfov_deg` (degrees, (0, 180)), image `width × height` pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub vfov_deg: f32,
    pub width: usize,
    pub height: usize,
}

impl Camera {
    /// `view_from_world` (right-handed, looking down −Z).
    #[must_use]
    pub fn view_from_world(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// `clip_from_world` with near/far planes `near`, `far` (NDC z in [0, 1], y up).
    #[must_use]
    pub fn clip_from_world(&self, near: f32, far: f32) -> Mat4 {
        let aspect = self.width as f32 / self.height as f32;
        glam::camera::rh::proj::directx::perspective(self.vfov_deg.to_radians(), aspect, near, far)
            * self.view_from_world()
    }

    /// World-space ray (origin, unit direction) through the image point
    /// (`px`, `py`) in pixels (pixel centres at +0.5, row 0 at the top).
    #[must_use]
    pub fn ray(&self, px: f32, py: f32) -> (Vec3, Vec3) {
        let fwd = (self.target - self.eye).normalize();
        let right = fwd.cross(self.up).normalize();
        let up = right.cross(fwd);
        let tan = (0.5 * self.vfov_deg.to_radians()).tan();
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * px / self.width as f32 - 1.0) * tan * aspect;
        let sy = (1.0 - 2.0 * py / self.height as f32) * tan;
        (self.eye, (fwd + right * sx + up * sy).normalize())
    }
}
