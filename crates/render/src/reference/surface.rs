//! Direct light at one vertex of a path — a surface point or a point in the
//! medium — from every light, by multiple importance sampling.
//!
//! # The vertex
//! A `Scatter` is either a surface point with its BSDF in the local shading
//! frame (`f · cos θ_i`, cosine of the shading normal) or a medium point with
//! the isotropic phase function `1/(4π)` (no cosine). At a surface hit
//! (`surface_vertex`) the shading normal is the interpolated vertex normal,
//! perturbed by the object's normal map ([`NormalMap::perturb`] at the hit's
//! uv and tangent, the lookup every method shares), then both normals are
//! turned towards the viewer (surfaces are two-sided). Where an
//! interpolated shading normal (no normal map) still faces away from the
//! viewer, the BRDF sees the view at the horizon (`above_horizon`: no black
//! fringes at silhouettes). A normal map that turns the normal away keeps
//! the convention the SH method shares: the BRDF is zero there. The BSDF is the
//! object's BRDF, or with a [`BrdfBlend`] the mixture
//! `f = (1 − w) f₁ + w f₂`, `w` = the blend weight at the hit's uv, sampled by
//! picking lobe 2 with probability `w` and reporting the mixture density
//! `(1 − w) p₁ + w p₂` (one-sample MIS with the balance heuristic: unbiased
//! whatever the lobes' own samplers).
//!
//! # The estimate (`direct_light`)
//! `L = Σ_lights ∫ ρ(ω) L_ℓ(x, ω) T(x, ω) V(x, ω) dω`, with `ρ` = `f cos` or
//! the phase function, `T` the medium's transmittance and `V` visibility:
//! * environment and each area light: one light sample and the one shared
//!   BSDF/phase sample, each weighted by the power heuristic against the
//!   other's density for that light (Veach 1997, §9.2.4); the weights of the
//!   two strategies sum to one per light, so the sum is unbiased;
//! * with [`LightSampling::Wavelet`] at a surface vertex, each area light
//!   also gets one sample of its light × BRDF·cos product on the expanded
//!   top face ([`super::wavelet_sampling`]); its light, BSDF and wavelet
//!   samples are weighted by the three-strategy power heuristic, and the
//!   wavelet density is 0 outside the face, where the other two carry the
//!   light;
//! * each point light: one connection (a delta: no MIS);
//! * the BSDF/phase sample collects every area light it crosses (front side)
//!   before the first occluder, and the environment when nothing occludes.
//!
//! Shadow rays leave a surface from [`offset_ray_origin`] on the side of the
//! geometric normal that the ray goes to.

use super::LightSampling;
use super::integrator::Tracer;
use super::lights::{Lights, area_light_pdf, area_light_sample, point_light_sample};
use super::wavelet_sampling::{FaceProduct, FaceSet, power3};
use crate::bvh::{Hit, SceneBvh, ShadingPoint, offset_ray_origin};
use crate::sampling::{Rng, sample_uniform_sphere, uniform_sphere_pdf};
use crate::{BrdfBlend, Object};
use glam::{Mat3, Vec2, Vec3};
use relight_brdf::{Brdf, BrdfSample};
use relight_sphere::Frame;
use std::cell::RefCell;

#[cfg(doc)]
use crate::NormalMap;

use super::lights::EnvLight;

#[cfg(test)]
mod horizon_tests {
    use super::{MIN_COS_VIEW, above_horizon};
    use glam::Vec3;

    /// Views above the horizon are untouched; others end at the bound,
    /// unit length, with their azimuth.
    #[test]
    fn raises_only_views_below_the_horizon() {
        let ok = Vec3::new(0.6, 0.0, 0.8);
        assert_eq!(above_horizon(ok), ok);
        for wo in [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.6, 0.0, -0.8),
            Vec3::new(0.3, -0.4, -1.0),
        ] {
            let wo = wo.normalize();
            let w = above_horizon(wo);
            assert!((w.length() - 1.0).abs() < 1e-5, "{w}");
            assert!((w.z - MIN_COS_VIEW).abs() < 1e-6, "{w}");
            assert!(
                (w.y.atan2(w.x) - wo.y.atan2(wo.x)).abs() < 1e-5,
                "{wo} → {w}"
            );
        }
        assert!((above_horizon(-Vec3::Z).z - MIN_COS_VIEW).abs() < 1e-6);
    }
}

/// The BSDF at one surface point: a BRDF, or two blended by a weight.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SurfaceBsdf<'a> {
    base: &'a dyn Brdf,
    /// The second lobe and its weight `w ∈ [0, 1]`.
    second: Option<(&'a dyn Brdf, f32)>,
}

impl<'a> SurfaceBsdf<'a> {
    /// `base` alone, or blended with `second = (f₂, w)`.
    pub fn new(base: &'a dyn Brdf, second: Option<(&'a dyn Brdf, f32)>) -> Self {
        // A weight of exactly 0 or 1 is a single lobe (no wasted evaluations).
        match second {
            Some((_, w)) if w <= 0.0 => Self { base, second: None },
            Some((b, w)) if w >= 1.0 => Self {
                base: b,
                second: None,
            },
            s => Self { base, second: s },
        }
    }

    /// The material of `object` at texture coordinates `uv`.
    pub fn of_object(object: &'a Object, uv: Vec2) -> Self {
        Self::new(
            object.brdf.as_ref(),
            object
                .blend
                .as_ref()
                .map(|b: &'a BrdfBlend| (b.second.as_ref(), b.weight_at(uv))),
        )
    }

    /// The lobes: base BRDF and, blended, the second with its weight.
    #[inline]
    pub fn lobes(&self) -> (&'a dyn Brdf, Option<(&'a dyn Brdf, f32)>) {
        (self.base, self.second)
    }

    /// `f(wo, wi)` (local frame, no cosine).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self.second {
            None => self.base.eval(wo, wi),
            Some((b, w)) => self.base.eval(wo, wi) * (1.0 - w) + b.eval(wo, wi) * w,
        }
    }

    /// Solid-angle density of [`SurfaceBsdf::sample`].
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self.second {
            None => self.base.pdf(wo, wi),
            Some((b, w)) => self.base.pdf(wo, wi) * (1.0 - w) + b.pdf(wo, wi) * w,
        }
    }

    /// Draws `wi`: one lobe by weight (reusing `u.x`), then the mixture's `f`
    /// and density at the drawn direction.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        let Some((b, w)) = self.second else {
            return self.base.sample(wo, u);
        };
        let (lobe, ux) = if u.x < w {
            (b, u.x / w)
        } else {
            (self.base, (u.x - w) / (1.0 - w))
        };
        let s = lobe.sample(wo, Vec2::new(ux.min(1.0 - f32::EPSILON), u.y))?;
        let pdf = self.pdf(wo, s.wi);
        (pdf > 0.0).then(|| BrdfSample {
            wi: s.wi,
            f: self.eval(wo, s.wi),
            pdf,
        })
    }
}

/// A path vertex that scatters light (module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Scatter<'a> {
    Surface {
        /// Hit position.
        p: Vec3,
        /// Unit geometric normal, on the viewer's side.
        ng: Vec3,
        /// Shading frame (`z` = shading normal on the viewer's side).
        frame: Frame,
        /// Local direction towards the viewer.
        wo: Vec3,
        bsdf: SurfaceBsdf<'a>,
    },
    /// A point in the medium (isotropic phase function).
    Medium { x: Vec3 },
}

impl Scatter<'_> {
    /// The vertex position.
    #[inline]
    pub fn position(&self) -> Vec3 {
        match *self {
            Self::Surface { p, .. } => p,
            Self::Medium { x } => x,
        }
    }

    /// Origin of a ray leaving the vertex along `wi`.
    #[inline]
    pub fn origin_towards(&self, wi: Vec3) -> Vec3 {
        match *self {
            Self::Surface { p, ng, .. } => {
                offset_ray_origin(p, if wi.dot(ng) >= 0.0 { ng } else { -ng })
            }
            Self::Medium { x } => x,
        }
    }

    /// `ρ(wi)` (`f · cos` or the phase function) and the density with which
    /// [`Scatter::sample`] draws world direction `wi`.
    #[inline]
    pub fn eval(&self, wi: Vec3) -> (Vec3, f32) {
        match self {
            Self::Surface {
                frame, wo, bsdf, ..
            } => {
                let l = frame.to_local(wi);
                if l.z <= 0.0 {
                    return (Vec3::ZERO, 0.0);
                }
                (bsdf.eval(*wo, l) * l.z, bsdf.pdf(*wo, l))
            }
            Self::Medium { .. } => (Vec3::splat(uniform_sphere_pdf()), uniform_sphere_pdf()),
        }
    }

    /// Draws a world direction: `(wi, ρ(wi), pdf)`.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        match self {
            Self::Surface {
                frame, wo, bsdf, ..
            } => {
                let BrdfSample { wi, f, pdf } = bsdf.sample(*wo, u)?;
                if !(pdf > 0.0 && wi.z > 0.0) || f == Vec3::ZERO {
                    return None;
                }
                Some((frame.from_local(wi), f * wi.z, pdf))
            }
            Self::Medium { .. } => Some((
                sample_uniform_sphere(u),
                Vec3::splat(uniform_sphere_pdf()),
                uniform_sphere_pdf(),
            )),
        }
    }
}

/// The surface vertex of `hit` seen along `d` (unit, from the viewer): the
/// object's normal map and blend applied, normals turned to the viewer.
pub(crate) fn surface_vertex<'s>(
    objects: &'s [Object],
    bvh: &SceneBvh,
    hit: &Hit,
    d: Vec3,
) -> (ShadingPoint, Scatter<'s>) {
    let sp = bvh.shading_point(hit);
    let object = &objects[hit.object as usize];
    let mut ng = sp.geometric_normal;
    let mut ns = match &object.normal_map {
        Some(m) => m.perturb(sp.shading_normal, sp.tangent, sp.uv),
        None => sp.shading_normal,
    };
    if d.dot(ng) > 0.0 {
        ng = -ng;
        ns = -ns;
    }
    let frame = sp.frame(ns);
    let wo = frame.to_local(-d);
    let sc = Scatter::Surface {
        p: sp.position,
        ng,
        frame,
        // Normal-mapped surfaces keep the shared convention of the methods
        // (zero where the map turns the normal away from the viewer).
        wo: if object.normal_map.is_some() {
            wo
        } else {
            above_horizon(wo)
        },
        bsdf: SurfaceBsdf::of_object(object, sp.uv),
    };
    (sp, sc)
}

/// Least `cos θ_o` of the view direction in the shading frame
/// ([`above_horizon`]): about 87°.
pub const MIN_COS_VIEW: f32 = 0.05;

/// The local view direction `wo` (unit), raised to at least
/// [`MIN_COS_VIEW`] above the shading horizon, keeping its azimuth.
///
/// An interpolated vertex normal (or a normal map) can face away from the
/// viewer where the geometric normal does not: at silhouettes of coarse
/// meshes, e.g. the thin ears of the Stanford bunny. There `ω_o` lies below
/// the BRDF's hemisphere, every BRDF is zero, and the silhouette gets a
/// black fringe that no real surface has. Evaluating the BRDF for the
/// grazing view at the horizon instead keeps the shading continuous up to
/// the silhouette; the shading normal itself is kept, so a Lambert surface
/// shows the irradiance about its shading normal, as the SH and wavelet
/// methods (which shade by the normal) do. Views above the horizon (almost
/// every pixel) are unchanged.
#[must_use]
pub fn above_horizon(wo: Vec3) -> Vec3 {
    if wo.z >= MIN_COS_VIEW {
        return wo;
    }
    let xy = Vec2::new(wo.x, wo.y);
    let len = xy.length();
    let s = (1.0 - MIN_COS_VIEW * MIN_COS_VIEW).sqrt();
    if len < 1e-6 {
        // Straight from below: any azimuth will do.
        return Vec3::new(s, 0.0, MIN_COS_VIEW);
    }
    let h = xy * (s / len);
    Vec3::new(h.x, h.y, MIN_COS_VIEW)
}

thread_local! {
    /// Per-thread face products of [`LightSampling::Wavelet`], rebuilt at
    /// each surface vertex (no allocation after a thread's first).
    static FACES: RefCell<FaceSet> = RefCell::new(FaceSet::default());
}

/// Direct light at `sc` from every light (point lights only when
/// `with_points`; the medium's segment estimator samples those itself).
/// Adds the rays traced to `rays`. With [`LightSampling::Wavelet`] at a
/// surface vertex, builds each area light's face product first
/// ([`super::wavelet_sampling`]).
pub(crate) fn direct_light(
    tr: &Tracer,
    sc: &Scatter,
    with_points: bool,
    rng: &mut Rng,
    rays: &mut u64,
) -> Vec3 {
    if tr.light_sampling == LightSampling::Wavelet
        && let Some(wl) = tr.wavelet
        && let Scatter::Surface {
            p, frame, wo, bsdf, ..
        } = sc
        && !tr.lights.areas.is_empty()
    {
        let (frame, wo, bsdf) = (*frame, *wo, *bsdf);
        let rho = move |d: Vec3| {
            let l = frame.to_local(d);
            if l.z <= 0.0 {
                Vec3::ZERO
            } else {
                bsdf.eval(wo, l) * l.z
            }
        };
        return FACES.with_borrow_mut(|set| {
            set.build(wl, tr.lights.areas, *p, rho);
            direct_light_with(tr, sc, with_points, rng, rays, Some(&set.faces))
        });
    }
    direct_light_with(tr, sc, with_points, rng, rays, None)
}

/// [`direct_light`] with the area lights' face products (`faces[i]` for
/// light `i`) when the wavelet strategy runs at this vertex.
fn direct_light_with(
    tr: &Tracer,
    sc: &Scatter,
    with_points: bool,
    rng: &mut Rng,
    rays: &mut u64,
    faces: Option<&[FaceProduct]>,
) -> Vec3 {
    let x = sc.position();
    let lights = &tr.lights;
    let mut l = Vec3::ZERO;
    let has_env = lights.has_env();
    let strategy = tr.light_sampling;
    let light_samples = strategy != LightSampling::BsdfOnly;
    // Environment: light sample.
    if has_env && light_samples {
        let u_texel = rng.next_f64();
        let u_pos = rng.next_2d();
        if let Some(s) = lights.sample_env(u_texel, u_pos) {
            let (rho, pdf_sc) = sc.eval(s.wi);
            if rho != Vec3::ZERO && s.value != Vec3::ZERO {
                let o = sc.origin_towards(s.wi);
                if tr.unoccluded(o, s.wi, f32::INFINITY, rays) {
                    let t = tr.transmittance(o, s.wi, f32::INFINITY);
                    l += rho * s.value * (t * strategy.light_weight(s.pdf, pdf_sc) / s.pdf);
                }
            }
        }
    }
    // Area lights: one light sample each.
    for (i, a) in lights.areas.iter().enumerate().filter(|_| light_samples) {
        let u = rng.next_2d();
        if let Some(s) = area_light_sample(a, x, u) {
            let (rho, pdf_sc) = sc.eval(s.wi);
            if rho != Vec3::ZERO && s.value != Vec3::ZERO {
                let o = sc.origin_towards(s.wi);
                let len = (a.point_at(u) - o).length();
                if tr.unoccluded(o, s.wi, len * (1.0 - 1e-4), rays) {
                    let t = tr.transmittance(o, s.wi, len);
                    let w = match faces {
                        Some(f) => power3(s.pdf, pdf_sc, f[i].pdf(s.wi)),
                        None => strategy.light_weight(s.pdf, pdf_sc),
                    };
                    l += rho * s.value * (t * w / s.pdf);
                }
            }
        }
    }
    // Area lights, wavelet strategy: one product sample each.
    for (a, f) in lights.areas.iter().zip(faces.unwrap_or_default()) {
        let u = rng.next_2d();
        let Some((wi, pdf_w)) = f.sample(u) else {
            continue;
        };
        let (rho, pdf_sc) = sc.eval(wi);
        if rho == Vec3::ZERO {
            continue;
        }
        let o = sc.origin_towards(wi);
        // A sample in a cell the light only partly covers may miss it.
        if let Some((t, uv)) = a.intersect(o, wi, 0.0) {
            let pdf_l = area_light_pdf(a, wi, t);
            let le = a.radiance(uv, wi);
            if pdf_l > 0.0 && le != Vec3::ZERO && tr.unoccluded(o, wi, t * (1.0 - 1e-4), rays) {
                l += rho * le * (tr.transmittance(o, wi, t) * power3(pdf_w, pdf_l, pdf_sc) / pdf_w);
            }
        }
    }
    // Point lights: one connection each.
    if with_points {
        for p in lights.points {
            if let Some(s) = point_light_sample(p, x) {
                let (rho, _) = sc.eval(s.wi);
                if rho != Vec3::ZERO && s.value != Vec3::ZERO {
                    let o = sc.origin_towards(s.wi);
                    let len = (p.position - o).length();
                    if tr.unoccluded(o, s.wi, len * (1.0 - 1e-4), rays) {
                        l += rho * s.value * tr.transmittance(o, s.wi, len);
                    }
                }
            }
        }
    }
    // BSDF / phase sample: the area lights it crosses and the environment.
    if (has_env || !lights.areas.is_empty()) && strategy != LightSampling::LightOnly {
        let u = rng.next_2d();
        if let Some((wi, rho, pdf)) = sc.sample(u) {
            let o = sc.origin_towards(wi);
            if lights.areas.is_empty() {
                // Environment only: an any-hit shadow ray, and only when it
                // would carry light.
                let (le, pdf_env) = lights.env_radiance_and_pdf(wi);
                if le != Vec3::ZERO && tr.unoccluded(o, wi, f32::INFINITY, rays) {
                    l += rho
                        * le
                        * (tr.transmittance(o, wi, f32::INFINITY)
                            * strategy.bsdf_weight(pdf, pdf_env)
                            / pdf);
                }
                return if l.is_finite() { l } else { Vec3::ZERO };
            }
            let t_occ = tr.secondary_hit(o, wi, rays).map_or(f32::INFINITY, |h| h.t);
            for (i, a) in lights.areas.iter().enumerate() {
                if let Some((t, uv)) = a.intersect(o, wi, 0.0)
                    && t < t_occ
                {
                    let pdf_l = area_light_pdf(a, wi, t);
                    if pdf_l > 0.0 {
                        let le = a.radiance(uv, wi);
                        let w = match faces {
                            Some(f) => power3(pdf, pdf_l, f[i].pdf(wi)),
                            None => strategy.bsdf_weight(pdf, pdf_l),
                        };
                        l += rho * le * (tr.transmittance(o, wi, t) * w / pdf);
                    }
                }
            }
            if has_env && t_occ == f32::INFINITY {
                let (le, pdf_env) = lights.env_radiance_and_pdf(wi);
                if le != Vec3::ZERO {
                    l += rho
                        * le
                        * (tr.transmittance(o, wi, f32::INFINITY)
                            * strategy.bsdf_weight(pdf, pdf_env)
                            / pdf);
                }
            }
        }
    }
    if l.is_finite() { l } else { Vec3::ZERO }
}

/// Mean and standard error of a Monte Carlo radiance estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadianceEstimate {
    /// Estimated outgoing radiance, linear RGB.
    pub radiance: Vec3,
    /// Standard error of `radiance` per channel.
    pub std_error: Vec3,
}

/// Reference outgoing radiance at one surface point under an environment
/// (for per-vertex verification): `spp` MIS samples of the reflection
/// equation at `p` with unit shading normal `n` (also the geometric normal
/// for shadow rays), world view direction `wo` (unit, away from the
/// surface), `brdf`, environment `light` (its frame = the world), and shadow
/// rays through `visibility` when given. Deterministic in `seed`. The
/// shading frame is [`Frame::from_z`]`(n)`; use
/// [`reference_radiance_in_frame`] for anisotropic BRDFs.
#[allow(clippy::too_many_arguments)]
#[must_use]
pub fn reference_radiance_at(
    p: Vec3,
    n: Vec3,
    wo: Vec3,
    brdf: &dyn Brdf,
    light: &EnvLight,
    visibility: Option<&SceneBvh>,
    spp: u32,
    seed: u64,
) -> RadianceEstimate {
    reference_radiance_in_frame(p, &Frame::from_z(n), wo, brdf, light, visibility, spp, seed)
}

/// [`reference_radiance_at`] in an explicit shading frame (`frame.z` = normal).
#[allow(clippy::too_many_arguments)]
#[must_use]
pub fn reference_radiance_in_frame(
    p: Vec3,
    frame: &Frame,
    wo: Vec3,
    brdf: &dyn Brdf,
    light: &EnvLight,
    visibility: Option<&SceneBvh>,
    spp: u32,
    seed: u64,
) -> RadianceEstimate {
    let empty = SceneBvh::build(&[]);
    let tr = Tracer {
        objects: &[],
        bvh: visibility.unwrap_or(&empty),
        occlude: visibility.is_some(),
        lights: Lights {
            env: light,
            world_from_env: Mat3::IDENTITY,
            env_from_world: Mat3::IDENTITY,
            points: &[],
            areas: &[],
        },
        medium: None,
        mode: super::MediumMode::default(),
        light_sampling: LightSampling::Mis,
        wavelet: None,
    };
    let sc = Scatter::Surface {
        p,
        ng: frame.z,
        frame: *frame,
        wo: frame.to_local(wo),
        bsdf: SurfaceBsdf::new(brdf, None),
    };
    let (mut sum, mut sum_sq) = ([0.0f64; 3], [0.0f64; 3]);
    let mut rays = 0;
    let n = spp.max(1);
    for s in 0..n {
        let mut rng = Rng::for_sample(seed, 0, u64::from(s));
        let v = direct_light(&tr, &sc, true, &mut rng, &mut rays);
        for (k, x) in v.to_array().into_iter().enumerate() {
            sum[k] += f64::from(x);
            sum_sq[k] += f64::from(x) * f64::from(x);
        }
    }
    let nf = f64::from(n);
    let mean = sum.map(|s| s / nf);
    let se: [f64; 3] = std::array::from_fn(|k| {
        if n < 2 {
            0.0
        } else {
            ((sum_sq[k] / nf - mean[k] * mean[k]).max(0.0) / (nf - 1.0)).sqrt()
        }
    });
    RadianceEstimate {
        radiance: Vec3::new(mean[0] as f32, mean[1] as f32, mean[2] as f32),
        std_error: Vec3::new(se[0] as f32, se[1] as f32, se[2] as f32),
    }
}
