//! The ground-truth renderer (`--method reference`): Monte Carlo light
//! transport for the whole [`Scene`] — environment, point and area lights,
//! normal maps, spatially varying BRDFs, shadows and a homogeneous medium —
//! the judge of every method.
//!
//! # What is computed
//! Radiance arriving at the eye along each pixel's rays, box-filtered over
//! the pixel. The light paths are those of the techniques it judges:
//!
//! * **Surfaces reflect direct light only** (Kajiya 1986, restricted to one
//!   surface vertex). At the first surface seen,
//!   `L_o(x, ω_o) = ∫ f(x; ω_o, ω_i) L_i(x, ω_i) (n_s·ω_i)⁺ dω_i`
//!   over the hemisphere of the shading normal `n_s` (interpolated vertex
//!   normal, perturbed by the object's [`NormalMap`](crate::NormalMap)), with
//!   `f` the object's BRDF or its [`BrdfBlend`](crate::BrdfBlend)
//!   `(1 − w) f₁ + w f₂` at the hit's uv. `L_i` is the light arriving
//!   directly from the environment, the point lights and the area lights —
//!   attenuated by the medium and, with [`Scene::visibility`], shadowed by
//!   every object. Light reflected from surface to surface is not followed
//!   here (no technique judged by default models interreflection);
//!   [`render_gi_reference`] (`gi.rs`) follows it, with the direct and
//!   indirect images apart, for the radiance cache.
//! * **Environment.** Read through `env_from_world = world_from_envᵀ`. Shading
//!   reads it with [`ReferenceOptions::env_filter`] (default piecewise
//!   constant, [`EnvFilter::Nearest`]: consistent with its luminance sampler
//!   and with the texel integrals of the SH and wavelet projections); camera
//!   rays that miss every object read it bilinearly with
//!   [`Scene::env_radiance`], the background every method shares.
//! * **Point lights** (isotropic, radiant intensity `I`): irradiance
//!   `I cos / d²` times transmittance, with a shadow ray when visibility is on.
//!   They are not seen directly (a delta has no image).
//! * **Area lights** ([`AreaLight`](crate::AreaLight), one-sided textured
//!   rectangles): emit `radiance(uv, wi)` (a light field's view for the
//!   direction, [`crate::LightField`]) from their `+ẑ` side, nothing from
//!   the back. They are **luminaires only: they do not occlude** — shadow
//!   rays, camera rays and scattered rays pass through them, picking up
//!   their emission on the front side. The camera sees them (attenuated).
//! * **Visibility** ([`Scene::visibility`]): on, every object blocks every
//!   light (shadow rays through the [`SceneBvh`]); off, objects are seen by
//!   camera rays only and every later ray passes through them — the
//!   *unshadowed* integral the SH and wavelet techniques compute.
//! * **Medium** ([`Medium`]): a ball of radius `R` about the origin with
//!   extinction `β`, scattering `σ_s = albedo·β` and the isotropic phase
//!   function `1/(4π)`; vacuum outside it. The environment lies outside the
//!   ball, so distant light is attenuated by `e^{−β·chord}` along its way in
//!   and camera rays that leave the ball see the environment attenuated by
//!   the chord plus the light scattered into them. Two modes
//!   ([`MediumMode`]):
//!   - [`MediumMode::SingleScattering`]: exactly the path classes of the
//!     analytic fog model (sun-thesis-2008 §3.3): eye→medium→light (airlight,
//!     eq. 3.5), eye→surface→light (direct transmission, attenuated) and
//!     eye→surface→medium→light (airlight on the surface, eq. 3.22). The view
//!     ray is otherwise only attenuated (no eye→medium→surface paths).
//!   - [`MediumMode::MultipleScattering`]: any number of medium vertices and
//!     at most one surface vertex: analogue free-flight sampling
//!     (`t ~ β e^{−βt}`), next-event estimation to every light from every
//!     segment, Russian roulette, no cap on the scattering order.
//!
//! # Estimators
//! * **Pixel.** A camera ray through a uniformly jittered point of the pixel.
//! * **Direct light at a vertex** (surface or medium, [`surface`]): for the
//!   environment and for each area light, one light sample (luminance
//!   importance sampling [`EnvSampler`]; uniform by area on the rectangle)
//!   and one BSDF / phase sample, combined per light by multiple importance
//!   sampling with the power heuristic (Veach & Guibas 1995, §4); point lights
//!   by one deterministic connection each. With [`LightSampling::Wavelet`]
//!   each area light also gets, at surface vertices, one sample of its
//!   light × BRDF·cos product on the expanded top face
//!   ([`wavelet_sampling`], sun-thesis-2008 §4.6.1), the three weighted by
//!   the power heuristic. A blended BRDF samples one lobe
//!   chosen by weight and reports the mixture's density (an unbiased
//!   one-sample mixture).
//! * **Light scattered into a segment** ([`medium`]): per point light, one
//!   equiangular sample (Kulla & Fajardo, EGSR 2012), whose density cancels
//!   the light's `1/d²`; for the environment and the area lights, one
//!   distance sample `∝ e^{−βt}` on the segment's part inside the ball,
//!   with direct light by the phase function there.
//! * **Paths** (`integrator`): the in-scattered light of every segment is
//!   the contribution of paths whose last medium vertex lies on it; paths
//!   continue by free flight (medium vertex, weight = albedo, new direction
//!   from the phase function) or from the surface by BRDF sampling. Light
//!   reached by a continuation ray is *not* added again (the vertex's own
//!   direct-light estimate already holds it); only the camera ray adds the
//!   emission it sees.
//!
//! Every density is an exact solid-angle (or length) density, so the
//! renderer is unbiased for every feature.
//!
//! # Determinism, progress, error estimate
//! Sample `s` of pixel `p` draws all its random numbers from
//! [`Rng::for_sample`](crate::Rng::for_sample)`(seed, p, s)`, and per-pixel
//! sums are accumulated in sample order, so an image depends only on the seed
//! and sample count — never on the thread count, tile schedule, or how the
//! samples were split into passes (a progressive sequence of passes gives the
//! image of one render with the same total). Passes of
//! [`ReferenceOptions::pass_spp`] samples run in parallel over 16 × 16
//! tiles; [`Progress::check`](crate::Progress::check) before each tile
//! (cancellation returns [`ReferenceError::Cancelled`] and no image).
//! The renderer reports its own accuracy: per pixel the standard error of the
//! mean luminance, s/√N from the sample variance, and over the image
//! [`ReferenceImage::relative_std_error`] = mean standard error / mean luminance.

mod bench;
mod gi;
mod integrator;
mod lights;
pub mod medium;
mod rays;
mod relighter;
mod render;
pub mod surface;
pub mod wavelet_sampling;
pub mod wavelet_verify;

#[cfg(test)]
pub(crate) use bench::floor_quad;
pub use bench::{ReferenceBenchRow, bench_reference, sun_sky};
pub use gi::{CameraHit, GiImage, GiOptions, GiTracer, GiVertex, render_gi_reference};
pub use lights::EnvLight;
pub use rays::{RaySampler, with_ray_sampler};
pub use relighter::ReferenceRenderer;
pub use render::{ReferenceImage, render_reference, render_reference_with};
pub use surface::{RadianceEstimate, reference_radiance_at, reference_radiance_in_frame};
pub use wavelet_sampling::{WaveletLights, WaveletSamplingOptions};
pub use wavelet_verify::{WaveletVerifyOptions, verify_wavelet_sampling};

use crate::sampling::EnvFilter;
use crate::{Cancelled, Scene};

#[cfg(doc)]
use crate::{Medium, SceneBvh, sampling::EnvSampler};

/// Why a reference render did not produce an image.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
pub enum ReferenceError {
    /// The user asked to stop (Ctrl-C); nothing was produced.
    #[error("reference render cancelled")]
    Cancelled,
    /// `spp` must be at least 1.
    #[error("--spp must be at least 1 (got {0})")]
    ZeroSamples(u32),
    /// The camera has a zero width or height.
    #[error("image size must be at least 1×1 (got {width}×{height})")]
    EmptyImage { width: usize, height: usize },
    /// A scene value the renderer cannot integrate (named, with the problem).
    #[error("scene {parameter}: {problem}")]
    InvalidScene { parameter: String, problem: String },
    /// A renderer option out of range (named, with the problem).
    #[error("reference option {parameter}: {problem}")]
    InvalidOption {
        parameter: &'static str,
        problem: String,
    },
}

impl From<Cancelled> for ReferenceError {
    fn from(_: Cancelled) -> Self {
        Self::Cancelled
    }
}

/// Which light paths through the medium are integrated (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MediumMode {
    /// The analytic fog model's classes: at most one medium vertex, and none
    /// before a surface (sun-thesis-2008 §3.3).
    SingleScattering,
    /// Any number of medium vertices (free flight, Russian roulette, no cap),
    /// at most one surface vertex.
    #[default]
    MultipleScattering,
}

impl MediumMode {
    /// The name used on the command line (`single` / `multiple`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::SingleScattering => "single",
            Self::MultipleScattering => "multiple",
        }
    }
}

impl std::str::FromStr for MediumMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "single" => Ok(Self::SingleScattering),
            "multiple" => Ok(Self::MultipleScattering),
            _ => Err(format!(
                "unknown medium mode {s:?} (expected single or multiple)"
            )),
        }
    }
}

/// Which strategies estimate the light of the environment and the area
/// lights at a vertex. [`LightSampling::Mis`] is the renderer; the two
/// single strategies exist to check it (each alone is unbiased too, with
/// more variance); [`LightSampling::Wavelet`] adds product sampling of the
/// area lights (sun-thesis-2008 §4.6.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightSampling {
    /// Light and BSDF/phase samples combined by the power heuristic.
    #[default]
    Mis,
    /// Light samples only (weight 1); BSDF samples find no light.
    LightOnly,
    /// BSDF/phase samples only (weight 1); no light samples.
    BsdfOnly,
    /// [`LightSampling::Mis`], plus at surface vertices one wavelet
    /// importance sample per area light (light × BRDF·cos on the expanded
    /// top face, [`wavelet_sampling`]), the three strategies combined per
    /// area light by the power heuristic. Medium vertices and the GI
    /// reference's tracer ([`render_gi_reference`]) use plain MIS.
    Wavelet,
}

impl LightSampling {
    /// Every strategy, in the order of [`LightSampling::name`]'s list.
    pub const ALL: [Self; 4] = [Self::Mis, Self::LightOnly, Self::BsdfOnly, Self::Wavelet];

    /// The name used on the command line (`mis`, `light`, `bsdf`,
    /// `wavelet`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Mis => "mis",
            Self::LightOnly => "light",
            Self::BsdfOnly => "bsdf",
            Self::Wavelet => "wavelet",
        }
    }
}

impl std::str::FromStr for LightSampling {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                format!("unknown light sampling {s:?} (expected mis, light, bsdf or wavelet)")
            })
    }
}

impl LightSampling {
    /// The weight of a light sample of density `pdf_light` that the
    /// BSDF/phase sampler would draw with density `pdf_bsdf`.
    #[inline]
    #[must_use]
    pub fn light_weight(self, pdf_light: f32, pdf_bsdf: f32) -> f32 {
        match self {
            Self::Mis | Self::Wavelet => crate::sampling::power_heuristic(pdf_light, pdf_bsdf),
            Self::LightOnly => 1.0,
            Self::BsdfOnly => 0.0,
        }
    }

    /// The weight of a BSDF/phase sample (density `pdf_bsdf`) that reaches a
    /// light whose sampler has density `pdf_light` there.
    #[inline]
    #[must_use]
    pub fn bsdf_weight(self, pdf_bsdf: f32, pdf_light: f32) -> f32 {
        match self {
            Self::Mis | Self::Wavelet => crate::sampling::power_heuristic(pdf_bsdf, pdf_light),
            Self::LightOnly => 0.0,
            Self::BsdfOnly => 1.0,
        }
    }
}

/// Settings of the reference renderer; `Default` holds every default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceOptions {
    /// Total samples per pixel (≥ 1); each sample is one camera path.
    pub spp: u32,
    /// Samples per pixel per progressive pass (≥ 1; clamped to `spp`). Also
    /// the samples each progressive frame of [`ReferenceRenderer`] adds.
    pub pass_spp: u32,
    /// Global seed: same seed and `spp` → bit-identical image.
    pub seed: u64,
    /// Which medium paths are integrated (ignored without a medium).
    pub medium_mode: MediumMode,
    /// How shading reads the environment (see [`EnvFilter`]); camera rays
    /// that miss always read it bilinearly ([`Scene::env_radiance`]).
    pub env_filter: EnvFilter,
    /// Strategies for the environment and area lights.
    pub light_sampling: LightSampling,
    /// Settings of [`LightSampling::Wavelet`] (ignored by the others).
    pub wavelet: WaveletSamplingOptions,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self {
            spp: 64,
            pass_spp: 8,
            seed: 0,
            medium_mode: MediumMode::MultipleScattering,
            env_filter: EnvFilter::Nearest,
            light_sampling: LightSampling::Mis,
            wavelet: WaveletSamplingOptions::default(),
        }
    }
}

/// The range [`validate_scene`] takes a light's intensity in, per channel.
fn emission_range() -> String {
    format!(
        "must be finite, ≥ 0 and ≤ {:e} (MAX_RADIANCE) in every channel",
        relight_sphere::MAX_RADIANCE
    )
}

/// A light intensity [`validate_scene`] accepts: every channel in
/// `0 ≤ v ≤` [`relight_sphere::MAX_RADIANCE`] (larger ones overflow f32).
fn emission_ok(v: glam::Vec3) -> bool {
    v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= relight_sphere::MAX_RADIANCE
}

/// Checks the scene values the estimators divide by or exponentiate: the
/// medium, the point and area lights.
///
/// # Errors
/// [`ReferenceError::InvalidScene`] naming the value.
pub fn validate_scene(scene: &Scene) -> Result<(), ReferenceError> {
    let bad = |parameter: String, problem: &str| {
        Err(ReferenceError::InvalidScene {
            parameter,
            problem: problem.into(),
        })
    };
    if let Some(m) = &scene.medium {
        if !(m.beta.is_finite() && m.beta >= 0.0) {
            return bad(
                "medium.beta".into(),
                &format!("must be finite and ≥ 0 (got {})", m.beta),
            );
        }
        if !(0.0..=1.0).contains(&m.albedo) {
            return bad(
                "medium.albedo".into(),
                &format!("must be in [0, 1] (got {})", m.albedo),
            );
        }
        if !(m.radius.is_finite() && m.radius > 0.0) {
            return bad(
                "medium.radius".into(),
                &format!("must be finite and > 0 (got {})", m.radius),
            );
        }
    }
    for (i, l) in scene.point_lights.iter().enumerate() {
        if !l.position.is_finite() {
            return bad(format!("point_lights[{i}].position"), "must be finite");
        }
        if !emission_ok(l.intensity) {
            return bad(format!("point_lights[{i}].intensity"), &emission_range());
        }
    }
    for (i, l) in scene.area_lights.iter().enumerate() {
        if !(l.size.is_finite() && l.size.min_element() > 0.0) {
            return bad(
                format!("area_lights[{i}].size"),
                "both sides must be finite and > 0",
            );
        }
        if !(l.center.is_finite() && l.world_from_light.is_finite()) {
            return bad(
                format!("area_lights[{i}].center/orientation"),
                "must be finite",
            );
        }
        if (l.normal().length() - 1.0).abs() > 1e-3 {
            return bad(
                format!("area_lights[{i}].orientation"),
                "must be a rotation (unit axes)",
            );
        }
        if !emission_ok(l.intensity) {
            return bad(format!("area_lights[{i}].intensity"), &emission_range());
        }
    }
    if !scene.world_from_env.is_finite() {
        return bad("world_from_env".into(), "must be finite");
    }
    Ok(())
}
