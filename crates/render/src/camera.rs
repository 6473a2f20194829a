//! [`Camera`]: a pinhole perspective camera.

use glam::{Mat4, Vec2, Vec3, Vec4};

/// A pinhole camera looking from `eye` at `target`, `up` roughly up,
/// vertical field of view `vfov_deg` (degrees, (0, 180)), image `width × height` pixels.
///
/// `image_offset` shifts the image plane within itself (an off-axis shear,
/// not a turn of the camera): the point seen at image position `(px, py)` is
/// the one the unshifted camera sees at `(px + ox·width, py + oy·height)`.
/// It is a fraction of the image size, so a method that renders the camera
/// at `k ×` its size shifts by the same fraction of a pixel of the original
/// image. Progressive antialiasing renders one pass per sub-pixel offset
/// ([`Camera::with_pixel_offset`]); `Vec2::ZERO` is the plain camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub vfov_deg: f32,
    pub width: usize,
    pub height: usize,
    /// Offset of the image plane, fractions of `width` and `height` (see above).
    pub image_offset: Vec2,
}

impl Camera {
    /// The same camera with its image shifted by `(dx, dy)` pixels of its
    /// own size (see [`Camera::image_offset`]).
    #[must_use]
    pub fn with_pixel_offset(mut self, dx: f32, dy: f32) -> Self {
        self.image_offset = Vec2::new(
            dx / self.width.max(1) as f32,
            dy / self.height.max(1) as f32,
        );
        self
    }

    /// `view_from_world` (right-handed, looking down −Z).
    #[must_use]
    pub fn view_from_world(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// `clip_from_world` with near/far planes `near`, `far` (NDC z in [0, 1], y up).
    #[must_use]
    pub fn clip_from_world(&self, near: f32, far: f32) -> Mat4 {
        let aspect = self.width as f32 / self.height as f32;
        let proj = glam::camera::rh::proj::directx::perspective(
            self.vfov_deg.to_radians(),
            aspect,
            near,
            far,
        );
        // The image offset as a shear in clip space: NDC x − 2·ox, y + 2·oy.
        let o = self.image_offset;
        let shift = if o == Vec2::ZERO {
            Mat4::IDENTITY
        } else {
            Mat4::from_cols(
                Vec4::X,
                Vec4::Y,
                Vec4::Z,
                Vec4::new(-2.0 * o.x, 2.0 * o.y, 0.0, 1.0),
            )
        };
        shift * proj * self.view_from_world()
    }

    /// World-space ray (origin, unit direction) through the image point
    /// (`px`, `py`) in pixels (pixel centres at +0.5, row 0 at the top).
    /// For many rays, build the frame once with [`Camera::ray_frame`].
    #[must_use]
    pub fn ray(&self, px: f32, py: f32) -> (Vec3, Vec3) {
        (self.eye, self.ray_frame().dir(px, py))
    }

    /// The camera's ray frame, computed once for many [`CameraRays::dir`] calls.
    #[must_use]
    pub fn ray_frame(&self) -> CameraRays {
        // A degenerate camera (eye = target, up ∥ view) gets a fixed frame, not NaNs.
        let fwd = (self.target - self.eye).normalize_or(Vec3::NEG_Z);
        let right = fwd.cross(self.up).normalize_or(Vec3::X);
        let up = right.cross(fwd);
        let tan = (0.5 * self.vfov_deg.to_radians()).tan();
        let aspect = self.width as f32 / self.height as f32;
        CameraRays {
            eye: self.eye,
            fwd,
            right: right * (tan * aspect),
            up: up * tan,
            inv_width: 1.0 / self.width as f32,
            inv_height: 1.0 / self.height as f32,
            offset: self.image_offset,
        }
    }
}

/// Precomputed ray frame of a [`Camera`]: forward axis and the right / up
/// axes scaled by the half-extent of the image plane at unit distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraRays {
    eye: Vec3,
    fwd: Vec3,
    right: Vec3,
    up: Vec3,
    inv_width: f32,
    inv_height: f32,
    offset: Vec2,
}

impl CameraRays {
    /// The rays' common origin, the camera's eye.
    #[inline]
    #[must_use]
    pub fn origin(&self) -> Vec3 {
        self.eye
    }

    /// Unit world direction through the image point (`px`, `py`) in pixels
    /// (pixel centres at +0.5, row 0 at the top).
    #[inline]
    #[must_use]
    pub fn dir(&self, px: f32, py: f32) -> Vec3 {
        let sx = 2.0 * (px * self.inv_width + self.offset.x) - 1.0;
        let sy = 1.0 - 2.0 * (py * self.inv_height + self.offset.y);
        (self.fwd + self.right * sx + self.up * sy).normalize()
    }

    /// The image point (pixels, as [`Self::dir`] takes them) that world
    /// point `p` projects to, the inverse of [`Self::dir`]; `None` for a
    /// point not in front of the eye (on or behind the plane through it
    /// perpendicular to the view axis), which no image point sees.
    #[must_use]
    pub fn pixel_of(&self, p: Vec3) -> Option<Vec2> {
        let v = p - self.eye;
        let z = v.dot(self.fwd);
        // NaN (a NaN point) fails too.
        if z.is_nan() || z <= 0.0 {
            return None;
        }
        // `v = z (fwd + right·sx + up·sy)` with `right ⟂ up ⟂ fwd`.
        let sx = v.dot(self.right) / (z * self.right.length_squared());
        let sy = v.dot(self.up) / (z * self.up.length_squared());
        Some(Vec2::new(
            (0.5 * (sx + 1.0) - self.offset.x) / self.inv_width,
            (0.5 * (1.0 - sy) - self.offset.y) / self.inv_height,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`CameraRays::pixel_of`] inverts [`CameraRays::dir`], and sees
    /// nothing behind the eye.
    #[test]
    fn pixel_of_inverts_dir() {
        let c = Camera {
            eye: Vec3::new(0.3, 1.0, 4.0),
            target: Vec3::new(-0.2, 0.1, 0.0),
            up: Vec3::Y,
            vfov_deg: 50.0,
            width: 320,
            height: 200,
            image_offset: Vec2::new(0.03, -0.05),
        };
        let rays = c.ray_frame();
        for (px, py, t) in [
            (0.0, 0.0, 1.0),
            (160.5, 99.5, 3.0),
            (319.0, 7.0, 0.2),
            (-40.0, 250.0, 9.0),
        ] {
            let p = rays.origin() + rays.dir(px, py) * t;
            let q = rays.pixel_of(p).expect("in front");
            assert!(
                (q - Vec2::new(px, py)).abs().max_element() < 1e-3,
                "{q} vs ({px}, {py})"
            );
        }
        let back = rays.origin() - rays.dir(160.0, 100.0);
        assert_eq!(rays.pixel_of(back), None);
        assert_eq!(rays.pixel_of(rays.origin()), None);
    }

    /// A shifted camera sees at `(px, py)` what the plain one sees at
    /// `(px + dx, py + dy)`, both through its rays and its projection.
    #[test]
    fn image_offset_shifts_rays_and_projection_alike() {
        let c = Camera {
            eye: Vec3::new(0.3, 1.0, 4.0),
            target: Vec3::new(0.0, 0.5, 0.0),
            up: Vec3::Y,
            vfov_deg: 40.0,
            width: 160,
            height: 90,
            image_offset: Vec2::ZERO,
        };
        let (dx, dy) = (0.25, -0.375);
        let s = c.with_pixel_offset(dx, dy);
        for (px, py) in [(0.5, 0.5), (80.0, 45.0), (159.5, 10.25)] {
            let a = s.ray_frame().dir(px, py);
            let b = c.ray_frame().dir(px + dx, py + dy);
            assert!((a - b).length() < 1e-6, "{a} vs {b}");
        }
        let pixel = |cam: &Camera, p: Vec3| {
            let q = cam.clip_from_world(0.1, 100.0) * p.extend(1.0);
            let n = q.truncate() / q.w;
            Vec2::new(
                (n.x + 1.0) * 0.5 * cam.width as f32,
                (1.0 - n.y) * 0.5 * cam.height as f32,
            )
        };
        let p = Vec3::new(0.4, 0.7, -0.2);
        let shift = pixel(&c, p) - pixel(&s, p);
        assert!((shift - Vec2::new(dx, dy)).length() < 1e-3, "{shift}");
        // A camera of k× the size shifts by the same fraction of the image.
        let mut big = s;
        big.width *= 2;
        big.height *= 2;
        let b = big.ray_frame().dir(2.0 * 40.0, 2.0 * 20.0);
        let want = c.ray_frame().dir(40.0 + dx, 20.0 + dy);
        assert!((b - want).length() < 1e-6);
    }
}
