//! [`Scene`]: everything any method consumes — meshes with materials, a
//! distant environment, point and area lights, a homogeneous medium, per-object
//! animation — seen by a camera.
//!
//! This is the one scene model of relight. Scene files (`relight-scene`,
//! `docs/scene-format.md`) load into it; every method takes it through the
//! method interface ([`crate::method`]) and says which of its
//! [`SceneFeature`](crate::method::SceneFeature)s it renders; the reference
//! renderer renders all of them.
//!
//! # Frames and units
//! * World space: right-handed, +Y up, in scene units (metres by convention).
//! * The environment map `env` lives in its own frame; radiance arriving from
//!   world direction `ω` is `env(env_from_world · ω)` with
//!   `env_from_world = world_from_envᵀ`.
//! * Radiance is linear RGB (the environment's units); a point light's
//!   intensity is radiant intensity I (radiance × area ÷ distance² arrives as
//!   `I / d²` irradiance at normal incidence); an area light's radiance is
//!   `texture(uv) × intensity`.

use crate::Camera;
use crate::light_field::LightField;
use crate::texture::{NormalMap, Texture};
use glam::{Affine3A, Mat3, Quat, Vec2, Vec3};
use relight_brdf::Brdf;
use relight_geom::Mesh;
use relight_sphere::EnvMap;
use std::sync::Arc;

/// A spatially varying BRDF: `f(uv) = (1 − w(uv)) · f_object + w(uv) · second`
/// with `w` the red channel of `weight`, clamped to [0, 1].
#[derive(Clone, Debug)]
pub struct BrdfBlend {
    /// The BRDF blended in where the weight is 1.
    pub second: Arc<dyn Brdf>,
    /// Blend weight over the mesh's uvs (red channel, clamped to [0, 1]).
    pub weight: Arc<Texture>,
}

impl BrdfBlend {
    /// The weight of [`BrdfBlend::second`] at `uv`, in [0, 1].
    #[inline]
    #[must_use]
    pub fn weight_at(&self, uv: Vec2) -> f32 {
        self.weight.sample(uv).x.clamp(0.0, 1.0)
    }
}

/// One key of an [`Animation`]: the object's motion at `time` seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Seconds.
    pub time: f32,
    pub translate: Vec3,
    pub rotation: Quat,
    /// Uniform scale (> 0).
    pub scale: f32,
}

impl Keyframe {
    /// The affine map of this key.
    #[must_use]
    pub fn transform(&self) -> Affine3A {
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(self.scale),
            self.rotation,
            self.translate,
        )
    }
}

/// Keyframed rigid motion of an object, applied on top of its placement:
/// `world_from_placed(t)` interpolates translation and scale linearly and the
/// rotation by slerp between the two keys around `t`, and holds the first
/// (last) key before (after) the keys.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// Keys in increasing time (at least one).
    keys: Vec<Keyframe>,
}

impl Animation {
    /// From keys (sorted here by time).
    ///
    /// # Errors
    /// No keys, non-finite values, or a scale ≤ 0.
    pub fn try_new(mut keys: Vec<Keyframe>) -> Result<Self, String> {
        if keys.is_empty() {
            return Err("an animation needs at least one key".into());
        }
        for k in &keys {
            if !(k.time.is_finite()
                && k.translate.is_finite()
                && k.rotation.is_finite()
                && k.scale.is_finite()
                && k.scale > 0.0)
            {
                return Err(format!(
                    "key at time {}: values must be finite and the scale > 0",
                    k.time
                ));
            }
        }
        keys.sort_by(|a, b| a.time.total_cmp(&b.time));
        for k in &mut keys {
            k.rotation = k.rotation.normalize();
        }
        Ok(Self { keys })
    }

    /// The keys, in increasing time.
    #[must_use]
    pub fn keys(&self) -> &[Keyframe] {
        &self.keys
    }

    /// The motion at `time` seconds.
    #[must_use]
    pub fn world_from_placed(&self, time: f32) -> Affine3A {
        let k = &self.keys;
        let i = k.partition_point(|key| key.time <= time);
        if i == 0 {
            return k[0].transform();
        }
        if i == k.len() {
            return k[k.len() - 1].transform();
        }
        let (a, b) = (&k[i - 1], &k[i]);
        let t = ((time - a.time) / (b.time - a.time).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
        Keyframe {
            time,
            translate: a.translate.lerp(b.translate, t),
            rotation: a.rotation.slerp(b.rotation, t),
            scale: a.scale + (b.scale - a.scale) * t,
        }
        .transform()
    }
}

/// A mesh (already placed in world space) with its material.
#[derive(Clone, Debug)]
pub struct Object {
    pub mesh: Arc<Mesh>,
    /// The BRDF (local shading frame, normal on +Z, cosine not included).
    pub brdf: Arc<dyn Brdf>,
    /// Optional tangent-space normal map over the mesh's uvs.
    pub normal_map: Option<Arc<NormalMap>>,
    /// Optional spatially varying BRDF: a second BRDF blended in by a texture.
    pub blend: Option<BrdfBlend>,
    /// Optional keyframed motion (see [`Scene::at_time`]).
    pub animation: Option<Arc<Animation>>,
}

impl Object {
    /// A plain object: `brdf` everywhere, no normal map, no motion.
    #[must_use]
    pub fn new(mesh: Arc<Mesh>, brdf: Arc<dyn Brdf>) -> Self {
        Self {
            mesh,
            brdf,
            normal_map: None,
            blend: None,
            animation: None,
        }
    }
}

/// An isotropic point light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    /// World-space position.
    pub position: Vec3,
    /// Radiant intensity I per RGB channel (≥ 0).
    pub intensity: Vec3,
}

impl PointLight {
    #[must_use]
    pub fn new(position: Vec3, intensity: Vec3) -> Self {
        Self {
            position,
            intensity,
        }
    }
}

/// A one-sided, textured rectangular area light.
///
/// The rectangle spans `center ± ½ size.x · x̂ ± ½ size.y · ŷ`, where
/// `(x̂, ŷ, ẑ)` are the columns of `world_from_light`; it emits from its `+ẑ`
/// side only, with radiance `texture(uv) × intensity` (or `intensity` with no
/// texture). Texture uv: `u = ½ + x/size.x` along `+x̂`, `v = ½ − y/size.y`
/// (v runs down the image, so the image appears upright seen from `+ẑ` with
/// `ŷ` up).
#[derive(Clone, Debug)]
pub struct AreaLight {
    pub center: Vec3,
    /// Full side lengths along `x̂` and `ŷ` (> 0).
    pub size: Vec2,
    /// Rotation whose columns are the light's `x̂`, `ŷ` and emitting normal `ẑ`.
    pub world_from_light: Mat3,
    /// Radiance scale per channel (≥ 0).
    pub intensity: Vec3,
    /// Optional radiance texture (linear RGB), multiplied by `intensity`.
    pub texture: Option<Arc<Texture>>,
    /// Optional radiance by point *and* emitted direction (a light field,
    /// sun-thesis §4.5.3), multiplied by `intensity`; it replaces `texture`
    /// (scene files refuse both, [`Self::radiance`] ignores `texture` then).
    pub light_field: Option<Arc<LightField>>,
}

impl AreaLight {
    /// The emitting side's unit normal `ẑ`.
    #[must_use]
    pub fn normal(&self) -> Vec3 {
        self.world_from_light.z_axis
    }

    /// Area of the rectangle.
    #[must_use]
    pub fn area(&self) -> f32 {
        self.size.x * self.size.y
    }

    /// The world point at texture coordinates `uv ∈ [0, 1]²`.
    #[must_use]
    pub fn point_at(&self, uv: Vec2) -> Vec3 {
        self.center
            + self.world_from_light.x_axis * ((uv.x - 0.5) * self.size.x)
            + self.world_from_light.y_axis * ((0.5 - uv.y) * self.size.y)
    }

    /// The texture coordinates of world point `p` (on the light's plane).
    #[must_use]
    pub fn uv_of(&self, p: Vec3) -> Vec2 {
        let d = p - self.center;
        Vec2::new(
            0.5 + d.dot(self.world_from_light.x_axis) / self.size.x,
            0.5 - d.dot(self.world_from_light.y_axis) / self.size.y,
        )
    }

    /// Emitted radiance at `uv` towards the `+ẑ` side, whatever the
    /// direction: exact for a light without a light field; with one, its
    /// views' mean at `uv` (uniform over the slope square), which only
    /// consumers that refuse
    /// [`SceneFeature::LightFields`](crate::method::SceneFeature) or need a
    /// direction-free proposal (importance sampling) may use.
    #[must_use]
    pub fn radiance_at(&self, uv: Vec2) -> Vec3 {
        if let Some(lf) = &self.light_field {
            let views = lf.views() * lf.views();
            let sum: Vec3 = (0..views)
                .map(|i| lf.view(i % lf.views(), i / lf.views()).sample(uv))
                .sum();
            return sum / views as f32 * self.intensity;
        }
        match &self.texture {
            Some(t) => t.sample(uv) * self.intensity,
            None => self.intensity,
        }
    }

    /// Radiance arriving along `wi` (unit, from the receiver towards the
    /// light) from the light's point at `uv`: [`Self::radiance_at`] without
    /// a light field, else the field's view for the emitted direction `−wi`
    /// ([`LightField::radiance`]). Zero from behind the emitting side.
    #[must_use]
    pub fn radiance(&self, uv: Vec2, wi: Vec3) -> Vec3 {
        let m = self.world_from_light;
        let cos = -wi.dot(m.z_axis);
        if cos <= 0.0 {
            return Vec3::ZERO;
        }
        let Some(lf) = &self.light_field else {
            return self.radiance_at(uv);
        };
        let slope = Vec2::new(-wi.dot(m.x_axis), -wi.dot(m.y_axis)) / cos;
        lf.radiance(uv, slope) * self.intensity
    }

    /// Ray–rectangle intersection: the distance `t > t_min` along `d` (unit)
    /// from `o` and the uv there, whichever side is hit.
    #[must_use]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32) -> Option<(f32, Vec2)> {
        let n = self.normal();
        let denom = d.dot(n);
        if denom.abs() < 1e-12 {
            return None;
        }
        let t = (self.center - o).dot(n) / denom;
        if !(t > t_min && t.is_finite()) {
            return None;
        }
        let uv = self.uv_of(o + d * t);
        ((0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y)).then_some((t, uv))
    }

    /// Total emitted power Φ = ∫∫ L cos θ dω dA per channel: π ∫ L dA for
    /// the Lambertian emitter, with a light field each view's mean times its
    /// projected solid angle ([`LightField::projected_solid_angle`]).
    #[must_use]
    pub fn power(&self) -> Vec3 {
        if let Some(lf) = &self.light_field {
            let a = lf.views();
            let sum: Vec3 = (0..a * a)
                .map(|i| lf.view(i % a, i / a).mean() * lf.projected_solid_angle(i % a, i / a))
                .sum();
            return sum * self.intensity * self.area();
        }
        let mean = self.texture.as_ref().map_or(Vec3::ONE, |t| t.mean());
        mean * self.intensity * (std::f32::consts::PI * self.area())
    }
}

/// A homogeneous participating medium with the isotropic phase function
/// 1/(4π) (sun-thesis-2008 §3.2), filling the ball of `radius` about the world
/// origin. The environment lies outside the ball: its sources are at distance
/// `radius` from the scene centre (sun-thesis §3.6.4, where `T_sv = β·radius`),
/// so distant light crossing the ball is attenuated by `e^{−β·chord}` and
/// in-scattered along the way. Point and area lights sit inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    /// Extinction coefficient β = σ_t (1 / scene unit, ≥ 0).
    pub beta: f32,
    /// Single-scattering albedo σ_s / σ_t in [0, 1].
    pub albedo: f32,
    /// Radius of the fog ball about the origin (scene units, > 0).
    pub radius: f32,
}

impl Medium {
    /// Optical thickness from the centre to the environment, `T = β·radius`.
    #[must_use]
    pub fn env_thickness(&self) -> f32 {
        self.beta * self.radius
    }

    /// The distance `(t_in, t_out)` along a ray `o + t d` (d unit) inside the
    /// ball, clipped to `t ≥ 0`; `None` when the ray misses it.
    #[must_use]
    pub fn ball_span(&self, o: Vec3, d: Vec3) -> Option<(f32, f32)> {
        let b = o.dot(d);
        let c = o.length_squared() - self.radius * self.radius;
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        let (t0, t1) = (-b - s, -b + s);
        (t1 > 0.0).then_some((t0.max(0.0), t1))
    }
}

/// Everything a method may render, seen by `camera`.
#[derive(Clone, Debug)]
pub struct Scene {
    pub objects: Vec<Object>,
    /// Distant lighting, in the environment's own frame.
    pub env: EnvMap,
    /// Rotation taking environment directions to world directions.
    pub world_from_env: Mat3,
    pub point_lights: Vec<PointLight>,
    pub area_lights: Vec<AreaLight>,
    /// Optional homogeneous medium between every two points.
    pub medium: Option<Medium>,
    /// Binary visibility: objects shadow light (environment, point and area
    /// lights) from each other and themselves. Off: the unshadowed
    /// reflection integral that SH and wavelet environment shading compute.
    pub visibility: bool,
    pub camera: Camera,
}

impl Scene {
    /// Objects under an environment, nothing else (no lights, medium or
    /// shadows; the environment unrotated).
    #[must_use]
    pub fn new(objects: Vec<Object>, env: EnvMap, camera: Camera) -> Self {
        Self {
            objects,
            env,
            world_from_env: Mat3::IDENTITY,
            point_lights: Vec::new(),
            area_lights: Vec::new(),
            medium: None,
            visibility: false,
            camera,
        }
    }

    /// Radiance of the environment arriving from world direction `d` (unit),
    /// read bilinearly (the lookup every method's background uses).
    #[inline]
    #[must_use]
    pub fn env_radiance(&self, d: Vec3) -> Vec3 {
        self.env.eval(self.world_from_env.transpose() * d)
    }

    /// True when the environment holds any light.
    #[must_use]
    pub fn has_environment(&self) -> bool {
        self.env.texels.iter().any(|t| t.max_element() > 0.0)
    }

    /// True when any object moves.
    #[must_use]
    pub fn is_animated(&self) -> bool {
        self.objects.iter().any(|o| o.animation.is_some())
    }

    /// The time of the last key of any animation (seconds; 0 for a static
    /// scene): the viewer's animation loops over `[0, animation_end]`.
    #[must_use]
    pub fn animation_end(&self) -> f32 {
        self.objects
            .iter()
            .filter_map(|o| o.animation.as_ref()?.keys().last().map(|k| k.time))
            .fold(0.0, f32::max)
    }

    /// The scene at `time` seconds: every animated object's mesh moved by
    /// its [`Animation`]; the rest shared.
    #[must_use]
    pub fn at_time(&self, time: f32) -> Scene {
        let mut s = self.clone();
        for o in &mut s.objects {
            if let Some(a) = &o.animation {
                o.mesh = Arc::new((*o.mesh).clone().transformed(a.world_from_placed(time)));
                o.animation = None;
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn animation_interpolates_and_holds() {
        let a = Animation::try_new(vec![
            Keyframe {
                time: 1.0,
                translate: Vec3::new(2.0, 0.0, 0.0),
                rotation: Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
                scale: 3.0,
            },
            Keyframe {
                time: 0.0,
                translate: Vec3::ZERO,
                rotation: Quat::IDENTITY,
                scale: 1.0,
            },
        ])
        .unwrap();
        let mid = a.world_from_placed(0.5);
        let p = mid.transform_point3(Vec3::ZERO);
        assert!((p - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-6, "{p}");
        let x = mid.transform_vector3(Vec3::X);
        let expect = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4) * Vec3::X * 2.0;
        assert!((x - expect).length() < 1e-5, "{x} vs {expect}");
        assert_eq!(a.world_from_placed(-5.0), a.keys()[0].transform());
        assert_eq!(a.world_from_placed(9.0), a.keys()[1].transform());
        assert!(Animation::try_new(vec![]).is_err());
        let mut bad = a.keys()[0];
        bad.scale = 0.0;
        assert!(Animation::try_new(vec![bad]).is_err());
    }

    #[test]
    fn area_light_uv_round_trip_and_intersection() {
        let l = AreaLight {
            center: Vec3::new(0.0, 2.0, 0.0),
            size: Vec2::new(2.0, 1.0),
            // Facing down: x̂ = +X, ŷ = +Z, ẑ = −Y.
            world_from_light: Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y),
            intensity: Vec3::ONE,
            texture: None,
            light_field: None,
        };
        for uv in [
            Vec2::new(0.1, 0.9),
            Vec2::new(0.5, 0.5),
            Vec2::new(1.0, 0.0),
        ] {
            let back = l.uv_of(l.point_at(uv));
            assert!((back - uv).length() < 1e-6, "{uv} → {back}");
        }
        let (t, uv) = l
            .intersect(Vec3::new(0.5, 0.0, 0.25), Vec3::Y, 0.0)
            .unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        assert!((uv - Vec2::new(0.75, 0.25)).length() < 1e-6, "{uv}");
        assert!(
            l.intersect(Vec3::new(3.0, 0.0, 0.0), Vec3::Y, 0.0)
                .is_none()
        );
        assert!((l.power() - Vec3::splat(2.0 * std::f32::consts::PI)).length() < 1e-5);
    }
}
