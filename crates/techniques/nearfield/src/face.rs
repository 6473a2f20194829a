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
//! keeps (Fig. 4.7E's green curve), and [`face_clipping`] what one light
//! loses at one vertex (the method's warning).

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

/// Light dropped past the face at a vertex, as a share of the light's
/// brightest vertex, that the method's warning starts at ([`face_clipping`]).
pub const FACE_CLIPPING_WARNING: f64 = 0.05;

/// `∫_0^x ∫_0^y (1 + u² + w²)⁻² dw du`, the projected solid angle of the
/// rectangle `[0, x] × [0, y]` of a plane at unit distance, seen from a
/// point whose normal faces the plane (the parallel-rectangle form factor
/// × π); odd in `x` and in `y`.
fn parallel_rect_corner(x: f64, y: f64) -> f64 {
    let (rx, ry) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    0.5 * (x / rx * (y / rx).atan() + y / ry * (x / ry).atan())
}

/// `parallel_rect_corner` over `[x0, x1] × [y0, y1]`.
#[must_use]
pub fn parallel_rect_integral(x: [f64; 2], y: [f64; 2]) -> f64 {
    parallel_rect_corner(x[1], y[1])
        - parallel_rect_corner(x[0], y[1])
        - parallel_rect_corner(x[1], y[0])
        + parallel_rect_corner(x[0], y[0])
}

/// A uniform light's projected solid angle at a vertex with affine map
/// `(s, o)` (eq. 4.34) whose normal faces the light's plane, whole and
/// inside the face of side `face` (the rest is dropped, §4.5.4): the light
/// covers `t ∈ [−o/s, (1 − o)/s]` per axis of the face `t ∈ [0, 1]²`, that
/// is `v = face (t − ½)`, each point weighted by `(1 + |v|²)⁻²`.
#[must_use]
pub fn face_clipping(s: [f64; 2], o: [f64; 2], face: f64) -> (f64, f64) {
    let h = 0.5 * face;
    let span = |k: usize| {
        [
            face * (-o[k] / s[k] - 0.5),
            face * ((1.0 - o[k]) / s[k] - 0.5),
        ]
    };
    let (x, y) = (span(0), span(1));
    let all = parallel_rect_integral(x, y).max(0.0);
    let clip = |r: [f64; 2]| [r[0].max(-h), r[1].min(h)];
    let (cx, cy) = (clip(x), clip(y));
    let kept = if cx[0] < cx[1] && cy[0] < cy[1] {
        parallel_rect_integral(cx, cy).clamp(0.0, all)
    } else {
        0.0
    };
    (all, kept)
}
