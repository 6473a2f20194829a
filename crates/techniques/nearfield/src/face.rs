//! The expanded top face (thesis §4.5.4) and the affine map from a vertex's
//! face to the light's texture (eq. 4.34).
//!
//! # Frames and units
//! The light ([`AreaLight`]) spans `c ± ½w x̂ ± ½h ŷ` and emits towards
//! `+ẑ`. A vertex `p` at depth `z = (p − c)·ẑ > 0` sees the light plane
//! through a square face of side `S` (the *face size*; the standard cube
//! map's top face is 2) at unit distance, parameterised by
//! `t ∈ [0, 1]²`: the face point `v = S (t − ½)` is the direction
//! `x̂ v₁ − ŷ v₂ − ẑ` (the face's second axis runs along `−ŷ` so that both
//! affine scales are positive). That ray meets the plane at texture
//! coordinates (uv of [`AreaLight::uv_of`])
//!
//! ```text
//!   u₁ = s₁ t₁ + o₁,  s₁ = zS/w,  o₁ = ½ + p_x/w − zS/(2w)
//!   u₂ = s₂ t₂ + o₂,  s₂ = zS/h,  o₂ = ½ − p_y/h − zS/(2h)
//! ```
//!
//! with `p_x = (p − c)·x̂`, `p_y = (p − c)·ŷ`: the incident radiance on the
//! face is `F(s t + o)`, an affine transform of the light's texture `F`,
//! exact (not a linearisation). Depth and in-plane offsets are in scene
//! units; `s`, `o` are dimensionless.
//!
//! Light outside the face (grazing directions, `|v_i| > S/2`) is dropped;
//! [`lobe_fraction`] gives the share of a centred Lambertian lobe the face
//! keeps (Fig. 4.7E's green curve).

use glam::{Mat3, Vec3};
use relight_render::AreaLight;

/// The light's plane and extent, what the affine map needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightFrame {
    pub center: Vec3,
    /// Columns x̂, ŷ, ẑ (ẑ the emitting normal).
    pub axes: Mat3,
    /// Side lengths (w, h) along x̂, ŷ (scene units, > 0).
    pub size: [f32; 2],
}

impl LightFrame {
    /// The frame of `light`.
    #[must_use]
    pub fn of(light: &AreaLight) -> Self {
        Self {
            center: light.center,
            axes: light.world_from_light,
            size: [light.size.x, light.size.y],
        }
    }

    /// `(p_x, p_y, z)`: the in-plane offsets and the depth of `p`.
    #[must_use]
    pub fn local(&self, p: Vec3) -> Vec3 {
        let d = p - self.center;
        Vec3::new(
            d.dot(self.axes.x_axis),
            d.dot(self.axes.y_axis),
            d.dot(self.axes.z_axis),
        )
    }

    /// The per-axis affine map `(s, o)` of a vertex at `local` (from
    /// [`Self::local`]) for face size `face`, or `None` on or behind the
    /// light's plane (`z ≤ 0`: unlit by the one-sided light).
    #[must_use]
    pub fn affine(&self, local: Vec3, face: f64) -> Option<([f64; 2], [f64; 2])> {
        let z = f64::from(local.z);
        if z <= 1e-6 {
            return None;
        }
        let (w, h) = (f64::from(self.size[0]), f64::from(self.size[1]));
        let (s1, s2) = (z * face / w, z * face / h);
        let o1 = 0.5 + f64::from(local.x) / w - 0.5 * s1;
        let o2 = 0.5 - f64::from(local.y) / h - 0.5 * s2;
        Some(([s1, s2], [o1, o2]))
    }

    /// The world direction (unnormalised, `|·| = √(1 + |v|²)`) of face point
    /// `v = (v₁, v₂)`.
    #[must_use]
    pub fn face_dir(&self, v1: f32, v2: f32) -> Vec3 {
        self.axes.x_axis * v1 - self.axes.y_axis * v2 - self.axes.z_axis
    }
}

/// Share of a centred Lambertian lobe `cos θ / π` inside a face of side
/// `face`: `(1/π) ∫∫ (1 + |v|²)⁻² dv` over `[−S/2, S/2]²` (midpoint rule,
/// `samples²` points).
#[must_use]
pub fn lobe_fraction(face: f64, samples: usize) -> f64 {
    let h = face / samples as f64;
    let mut sum = 0.0;
    for j in 0..samples {
        let y = -0.5 * face + (j as f64 + 0.5) * h;
        for i in 0..samples {
            let x = -0.5 * face + (i as f64 + 0.5) * h;
            let r = 1.0 + x * x + y * y;
            sum += 1.0 / (r * r);
        }
    }
    sum * h * h / std::f64::consts::PI
}

/// Share of the upper hemisphere's solid angle inside the face:
/// `(1/2π) ∫∫ (1 + |v|²)^{−3/2} dv` (Fig. 4.7E's blue curve).
#[must_use]
pub fn solid_angle_fraction(face: f64, samples: usize) -> f64 {
    let h = face / samples as f64;
    let mut sum = 0.0;
    for j in 0..samples {
        let y = -0.5 * face + (j as f64 + 0.5) * h;
        for i in 0..samples {
            let x = -0.5 * face + (i as f64 + 0.5) * h;
            let r = 1.0 + x * x + y * y;
            sum += 1.0 / (r * r.sqrt());
        }
    }
    sum * h * h / (2.0 * std::f64::consts::PI)
}
