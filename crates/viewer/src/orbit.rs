//! An orbit camera: the eye moves on a sphere about a target point.
//!
//! Angles are in degrees. Yaw turns about world +Y (0 looks down −Z, as the
//! default scene's camera does from +Z), pitch raises the eye above the
//! target's horizontal plane and is kept inside (−89°, 89°) so the up vector
//! never lines up with the view direction.

use glam::Vec3;
use relight_render::Camera;

/// Largest |pitch| in degrees.
pub const MAX_PITCH_DEG: f32 = 89.0;

/// Eye position = target + distance · (cos p sin y, sin p, cos p cos y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The point looked at (world units).
    pub target: Vec3,
    /// About world +Y, degrees.
    pub yaw_deg: f32,
    /// Above the horizontal plane, degrees, in (−89, 89).
    pub pitch_deg: f32,
    /// Eye–target distance (world units, > 0).
    pub distance: f32,
    /// Vertical field of view, degrees.
    pub vfov_deg: f32,
}

impl Orbit {
    /// The orbit that reproduces `camera`'s eye, target and field of view.
    #[must_use]
    pub fn from_camera(camera: &Camera) -> Self {
        let d = camera.eye - camera.target;
        let distance = d.length().max(1e-3);
        let dir = d / distance;
        Self {
            target: camera.target,
            yaw_deg: dir.x.atan2(dir.z).to_degrees(),
            pitch_deg: dir.y.clamp(-1.0, 1.0).asin().to_degrees(),
            distance,
            vfov_deg: camera.vfov_deg,
        }
    }

    /// The eye position.
    #[must_use]
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw_deg.to_radians().sin_cos();
        let (sp, cp) = self.pitch_deg.to_radians().sin_cos();
        self.target + self.distance * Vec3::new(cp * sy, sp, cp * cy)
    }

    /// A camera of `width × height` pixels on this orbit, +Y up.
    #[must_use]
    pub fn camera(&self, width: usize, height: usize) -> Camera {
        Camera {
            eye: self.eye(),
            target: self.target,
            up: Vec3::Y,
            vfov_deg: self.vfov_deg,
            width,
            height,
            image_offset: glam::Vec2::ZERO,
        }
    }

    /// Turns the eye by `d_yaw` and `d_pitch` degrees (pitch clamped).
    pub fn rotate(&mut self, d_yaw: f32, d_pitch: f32) {
        self.yaw_deg = (self.yaw_deg + d_yaw).rem_euclid(360.0);
        self.pitch_deg = (self.pitch_deg + d_pitch).clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG);
    }

    /// Moves the eye toward (`steps` > 0) or away from the target, 10 % of
    /// the distance per step, never closer than 1 % of the starting radius.
    pub fn zoom(&mut self, steps: f32, min_distance: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).max(min_distance);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_the_default_camera_and_keeps_the_distance() {
        let cam = relight_scene::default_camera(64, 36);
        let o = Orbit::from_camera(&cam);
        assert!(
            (o.eye() - cam.eye).length() < 1e-4,
            "{} vs {}",
            o.eye(),
            cam.eye
        );
        let mut o2 = o;
        o2.rotate(123.0, 200.0);
        assert!(((o2.eye() - o2.target).length() - o.distance).abs() < 1e-4);
        assert_eq!(o2.pitch_deg, MAX_PITCH_DEG);
        let c = o2.camera(64, 36);
        assert!(c.eye.is_finite() && (c.target - c.eye).normalize().y < -0.99);
        o2.zoom(100.0, 0.5);
        assert_eq!(o2.distance, 0.5);
    }
}
