//! The method interface: [`Relighter`], the one trait every rendering method
//! implements — the Monte Carlo reference and each paper technique — and the
//! only way the CLI, the viewer, `verify` and the Python package reach them.
//!
//! # The life of a method
//! 1. **Options.** Each method has its own options type (in its own crate),
//!    whose `Default` holds that method's defaults — the one place they live.
//! 2. **Check.** [`check_scene`] compares the scene's [`SceneFeature`]s with
//!    what the method [`supports`](Relighter::supports). A feature it cannot
//!    render is a [`MethodError::Unsupported`] naming the method and the
//!    feature; one it renders approximately is an error too unless the caller
//!    passes `approximate`, and then a warning.
//! 3. **Prepare.** [`Relighter::prepare`] bakes, or loads from the cache,
//!    whatever the scene needs (with progress and cancellation).
//! 4. **Per frame.** [`Relighter::set_lighting`] after the lighting changed
//!    (the environment's `world_from_env`, the lights); [`Relighter::render`]
//!    for a camera (a view change), returning the image and its timings.
//!    [`render_frame`] wraps `render` with what every method shares: the
//!    coverage and object-id channels and the one background.
//!
//! # Animation
//! A scene whose objects move ([`SceneFeature::Animation`]) is given to a
//! method in one of two ways, by [`posed_for`]: a method that supports it is
//! prepared once on the animated scene and renders each frame from the posed
//! scene [`Scene::at_time`] (its bake follows the motion: shexp moves its
//! blocker spheres); any other method is prepared on the posed scene itself,
//! so that a frame at time `t` is still the whole scene at `t`, and a caller
//! that changes `t` prepares it again (the viewer says so on screen instead of
//! playing).
//!
//! # One background
//! Every method shows the same pixels where no object is seen: the
//! environment read bilinearly ([`Scene::env_radiance`]) and averaged over the
//! pixel's four corners, the trapezoid rule of the box filter
//! ([`background_pixel`], about one lookup per pixel since neighbours share
//! corners). [`render_frame`] writes it into every pixel whose
//! coverage is zero, so that two methods differ only where they shade. In a
//! scene with a medium the background is the foggy sky (attenuated and
//! in-scattered environment), which is part of what a method computes: there
//! each method keeps its own.

pub use crate::object_raster::ObjectRaster;
use crate::raster::{CullMode, DrawCall, RasterOptions, Rasterizer};
use crate::{Camera, Cancelled, Image, Progress, Scene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use serde::Serialize;
use std::mem::MaybeUninit;
use std::sync::Arc;
use std::time::Instant;

/// A feature of a scene that a method may or may not render.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SceneFeature {
    /// Distant environment lighting (a non-black environment map).
    Environment,
    /// Isotropic point lights.
    PointLights,
    /// Textured rectangular area lights.
    AreaLights,
    /// Area lights whose radiance also varies with direction (light fields,
    /// [`crate::LightField`]).
    LightFields,
    /// A homogeneous participating medium.
    Medium,
    /// Binary visibility: shadows.
    Visibility,
    /// Tangent-space normal maps.
    NormalMaps,
    /// A spatially varying BRDF (two BRDFs blended by a texture).
    SpatiallyVaryingBrdf,
    /// Objects that move ([`Scene::is_animated`]). A method that supports it
    /// is prepared once on the animated scene and then renders each frame of
    /// the posed scene [`Scene::at_time`] without preparing again; a caller
    /// prepares a method that does not on the posed scene itself, again for
    /// every new time (module docs).
    Animation,
}

impl SceneFeature {
    /// Every feature, in a fixed order.
    pub const ALL: [SceneFeature; 9] = [
        Self::Environment,
        Self::PointLights,
        Self::AreaLights,
        Self::LightFields,
        Self::Medium,
        Self::Visibility,
        Self::NormalMaps,
        Self::SpatiallyVaryingBrdf,
        Self::Animation,
    ];

    /// Lower-case words, for messages.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Self::Environment => "environment lighting",
            Self::PointLights => "point lights",
            Self::AreaLights => "area lights",
            Self::LightFields => "area-light light fields (radiance varying with direction)",
            Self::Medium => "a participating medium",
            Self::Visibility => "visibility (shadows)",
            Self::NormalMaps => "normal maps",
            Self::SpatiallyVaryingBrdf => "spatially varying BRDFs",
            Self::Animation => "animation (moving objects)",
        }
    }

    /// The features `scene` uses.
    #[must_use]
    pub fn of_scene(scene: &Scene) -> Vec<SceneFeature> {
        Self::ALL
            .into_iter()
            .filter(|f| match f {
                Self::Environment => scene.has_environment(),
                Self::PointLights => !scene.point_lights.is_empty(),
                Self::AreaLights => !scene.area_lights.is_empty(),
                Self::LightFields => scene.area_lights.iter().any(|l| l.light_field.is_some()),
                Self::Medium => scene.medium.is_some_and(|m| m.beta > 0.0),
                Self::Visibility => scene.visibility,
                Self::NormalMaps => scene.objects.iter().any(|o| o.normal_map.is_some()),
                Self::SpatiallyVaryingBrdf => scene.objects.iter().any(|o| o.blend.is_some()),
                Self::Animation => scene.is_animated(),
            })
            .collect()
    }
}

impl std::fmt::Display for SceneFeature {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.describe())
    }
}

/// How a method renders one feature.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// Rendered as the reference renders it (up to the method's own error).
    Full,
    /// Rendered approximately; the text says how (shown as a warning, and only
    /// allowed with `approximate`).
    Approximate(&'static str),
    /// Not rendered.
    No,
}

/// Why a method did not render.
#[derive(Debug, thiserror::Error)]
pub enum MethodError {
    /// The scene uses a feature the method cannot render.
    #[error("method {method} cannot render {feature}{}", approx_hint(*.approximate))]
    Unsupported {
        method: &'static str,
        feature: SceneFeature,
        /// `Some(how)` when `--approximate` would render it approximately.
        approximate: Option<&'static str>,
    },
    /// An option is out of range or does not apply.
    #[error("method {method}: {option}: {message}")]
    InvalidOption {
        method: &'static str,
        option: &'static str,
        message: String,
    },
    /// The user asked to stop; nothing was produced.
    #[error("cancelled")]
    Cancelled,
    /// The method's own failure (bad data, bake IO, …).
    #[error("method {method}: {source}")]
    Failed {
        method: &'static str,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

fn approx_hint(approximate: Option<&'static str>) -> String {
    match approximate {
        Some(how) => format!(" exactly (pass --approximate to accept: {how})"),
        None => String::new(),
    }
}

impl From<Cancelled> for MethodError {
    fn from(_: Cancelled) -> Self {
        Self::Cancelled
    }
}

impl MethodError {
    /// Wraps a method's own error, keeping cancellation as [`MethodError::Cancelled`].
    pub fn failed<E>(method: &'static str, e: E) -> Self
    where
        E: std::error::Error + Send + Sync + 'static,
    {
        let boxed: Box<dyn std::error::Error + Send + Sync> = Box::new(e);
        if is_cancelled(boxed.as_ref()) {
            Self::Cancelled
        } else {
            Self::Failed {
                method,
                source: boxed,
            }
        }
    }
}

/// True when `e`, or any error in its source chain, is a cancellation: a
/// [`Cancelled`], a [`MethodError::Cancelled`], or an error whose message is
/// exactly "cancelled" or ends in " cancelled" (how each crate's error
/// displays its own `Cancelled` variant).
#[must_use]
pub fn is_cancelled(e: &(dyn std::error::Error + 'static)) -> bool {
    let mut cur: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(err) = cur {
        if err.is::<Cancelled>() || matches!(err.downcast_ref(), Some(MethodError::Cancelled)) {
            return true;
        }
        let text = err.to_string();
        if text == "cancelled" || text.ends_with(" cancelled") {
            return true;
        }
        cur = err.source();
    }
    false
}

/// What one frame is asked for.
#[derive(Clone, Debug)]
pub struct FrameRequest {
    /// The camera (its size is the output image's).
    pub camera: Camera,
    /// Antialiasing: `aa × aa` samples per pixel, box-filtered like the
    /// reference's pixels (1…[`MAX_AA`]). Monte Carlo methods integrate each
    /// pixel themselves and ignore it.
    pub aa: usize,
    /// Progressive methods: when nothing changed since the last frame, add to
    /// the running estimate instead of starting again.
    pub progressive: bool,
}

/// Largest `aa` a [`FrameRequest`] may ask for.
pub const MAX_AA: usize = 8;

impl FrameRequest {
    /// One sample per pixel, not progressive.
    #[must_use]
    pub fn new(camera: Camera) -> Self {
        Self {
            camera,
            aa: 1,
            progressive: false,
        }
    }

    /// The same request with `aa × aa` samples per pixel.
    #[must_use]
    pub fn with_aa(mut self, aa: usize) -> Self {
        self.aa = aa;
        self
    }

    /// Checks the size and `aa`.
    ///
    /// # Errors
    /// An empty image or `aa` outside 1…[`MAX_AA`].
    pub fn validate(&self, method: &'static str) -> Result<(), MethodError> {
        if !(1..=MAX_AA).contains(&self.aa) {
            return Err(MethodError::InvalidOption {
                method,
                option: "aa",
                message: format!(
                    "must be 1…{MAX_AA} samples per pixel side (got {})",
                    self.aa
                ),
            });
        }
        if self.camera.width == 0 || self.camera.height == 0 {
            return Err(MethodError::InvalidOption {
                method,
                option: "size",
                message: format!(
                    "image size must be at least 1×1 (got {}×{})",
                    self.camera.width, self.camera.height
                ),
            });
        }
        Ok(())
    }
}

/// Where the time of a frame went, milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FrameTimings {
    /// The lighting change folded into this frame (0 when the lighting was
    /// already set).
    pub lighting_ms: f64,
    /// The view-dependent work: shading and rasterization.
    pub view_ms: f64,
}

/// Per-pixel coverage and object id of an image.
#[derive(Clone, Debug, PartialEq)]
pub struct Coverage {
    pub width: usize,
    pub height: usize,
    /// Fraction of the pixel covered by objects, in [0, 1].
    pub coverage: Vec<f32>,
    /// 1 + index of the object covering most of the pixel; 0 = none.
    pub object_id: Vec<u32>,
}

impl Coverage {
    /// Pixels fully covered by objects (the default region of `compare`).
    #[must_use]
    pub fn object_mask(&self) -> Vec<bool> {
        self.coverage.iter().map(|&c| c >= 1.0).collect()
    }

    /// Pixels no object touches.
    #[must_use]
    pub fn background_mask(&self) -> Vec<bool> {
        self.coverage.iter().map(|&c| c <= 0.0).collect()
    }
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// Linear RGB radiance per pixel.
    pub image: Image,
    /// Coverage and object ids, when the method knows them (else
    /// [`render_frame`] rasterizes them); shared, so that a method that
    /// keeps them for a still camera ([`CoverageCache`]) hands them out
    /// without a copy.
    pub coverage: Option<Arc<Coverage>>,
    pub timings: FrameTimings,
    /// Monte Carlo methods: samples per pixel so far and the image's
    /// relative standard error (mean per-pixel standard error ÷ mean
    /// luminance). `None` for deterministic methods.
    pub noise: Option<Noise>,
}

impl Rendered {
    /// The frame of a method that rasterized its own visibility buffer:
    /// `samples` (the frame at `k × k` samples per pixel, as `raster` last
    /// drew it) box-filtered to the request's size, the coverage of `raster`,
    /// `lighting_ms` of the lighting change this frame is the first after (0
    /// otherwise) and the view time since `view_start`.
    #[must_use]
    pub fn from_samples(
        samples: std::borrow::Cow<'_, Image>,
        raster: &Rasterizer,
        k: usize,
        lighting_ms: f64,
        view_start: Instant,
    ) -> Self {
        let (w, h) = (samples.width / k, samples.height / k);
        let coverage = Arc::new(coverage_of_raster(raster, w, h, k));
        Self::from_samples_with(samples, coverage, k, lighting_ms, view_start)
    }

    /// [`Rendered::from_samples`] with the coverage taken from `cache`: a
    /// frame whose rasterizer still holds the visibility buffer the cache
    /// last reduced (a lighting change under a still camera) copies it
    /// instead of reducing the buffer again.
    #[must_use]
    pub fn from_samples_cached(
        samples: std::borrow::Cow<'_, Image>,
        raster: &Rasterizer,
        k: usize,
        cache: &mut CoverageCache,
        lighting_ms: f64,
        view_start: Instant,
    ) -> Self {
        let (w, h) = (samples.width / k, samples.height / k);
        let coverage = cache.get(raster, w, h, k);
        Self::from_samples_with(samples, coverage, k, lighting_ms, view_start)
    }

    fn from_samples_with(
        samples: std::borrow::Cow<'_, Image>,
        coverage: Arc<Coverage>,
        k: usize,
        lighting_ms: f64,
        view_start: Instant,
    ) -> Self {
        let image = match (k, samples) {
            (1, std::borrow::Cow::Owned(image)) => image,
            (1, std::borrow::Cow::Borrowed(image)) => Image {
                width: image.width,
                height: image.height,
                pixels: par_copy(&image.pixels),
            },
            (_, samples) => samples.box_downsample(k),
        };
        Self {
            image,
            coverage: Some(coverage),
            timings: FrameTimings {
                lighting_ms,
                view_ms: view_start.elapsed().as_secs_f64() * 1e3,
            },
            noise: None,
        }
    }
}

/// A Monte Carlo image's own error estimate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Noise {
    pub spp: u32,
    /// Mean per-pixel standard error ÷ mean luminance.
    pub relative_std_error: f64,
    /// √(Σ se²) / √(Σ L²): the relative RMS error the noise alone gives,
    /// the σ_MC a relative RMS error is read against.
    pub rms_relative_std_error: f64,
    /// The same over the pixels objects fully cover
    /// ([`Coverage::object_mask`]): the σ_MC of an error measured there, as
    /// `relight compare` and `verify` measure (0 when no object is seen).
    pub object_rms_relative_std_error: f64,
}

/// A rendering method (see the module docs).
pub trait Relighter: Send {
    /// Name, as on the command line (`reference`, `sh`, `wavelet`, `fog`, …).
    fn name(&self) -> &'static str;

    /// How this method renders `feature`.
    fn supports(&self, feature: SceneFeature) -> Support;

    /// What [`Relighter::prepare`] would refuse in `scene` beyond its
    /// features (e.g. an object's BRDF the method's options do not model),
    /// found without baking, so that `relight info` can say it before any
    /// work. `Ok` by default; `prepare` refuses the same objects.
    ///
    /// # Errors
    /// The first object the method cannot render, named.
    fn check_objects(&self, scene: &Scene) -> Result<(), MethodError> {
        let _ = scene;
        Ok(())
    }

    /// Bakes or loads what `scene` needs, then sets its lighting. Call again
    /// when the objects or materials change.
    ///
    /// # Errors
    /// Bad options or data, or [`MethodError::Cancelled`].
    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError>;

    /// A lighting change: `scene`'s environment rotation or lights moved.
    /// Returns the milliseconds it took.
    ///
    /// # Errors
    /// As [`Relighter::prepare`].
    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError>;

    /// Whether [`Relighter::set_lighting`] with `scene` would bake again
    /// (seconds) rather than update (milliseconds): an interactive caller
    /// defers such a change until the input that makes it is over (the
    /// viewer, while a drag lasts). False by default; a method that bakes
    /// per light (nearfield: a light whose plane tilts) says when.
    fn lighting_rebakes(&self, scene: &Scene) -> bool {
        let _ = scene;
        false
    }

    /// Renders `scene` (as last prepared and lit) for `request`.
    ///
    /// # Errors
    /// Bad sizes, or [`MethodError::Cancelled`].
    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError>;

    /// What the prepared method renders differently from the scene it was
    /// given (e.g. a lobe its band limit cannot hold, so it is windowed),
    /// one line each naming the method; the CLI prints them and the viewer
    /// shows them on screen. Empty by default and before `prepare`.
    fn warnings(&self) -> Vec<String> {
        Vec::new()
    }

    /// Bytes of precomputed data the method holds (0 when none).
    fn data_bytes(&self) -> u64 {
        0
    }

    /// The arithmetic of one frame of `request` on `scene` (as prepared),
    /// counted by the method from its own loops, for `relight bench frames`
    /// to read against the machine's rate; `None` when the method does not
    /// count it.
    fn frame_work(&self, scene: &Scene, request: &FrameRequest) -> Option<FrameWork> {
        let _ = (scene, request);
        None
    }
}

/// The f32 fused multiply-adds (an add or multiply alone counts as one) of
/// one frame, by the method's own count of its inner loops.
///
/// A view change costs `view_fma`; a lighting change costs
/// [`FrameWork::lighting_change_fma`], `set_lighting`'s own work and then
/// the frame `render` draws after it (an upper bound where that frame
/// reuses work of the view's, as the fog's vertex transfers).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FrameWork {
    /// A view change: everything [`Relighter::render`] computes.
    pub view_fma: f64,
    /// What [`Relighter::set_lighting`] itself computes (0 where a new
    /// lighting only changes what `render` reads).
    pub lighting_fma: f64,
}

impl FrameWork {
    /// A lighting change: `set_lighting`, then the frame after it.
    #[must_use]
    pub fn lighting_change_fma(&self) -> f64 {
        self.lighting_fma + self.view_fma
    }
}

/// Checks that `method` renders every feature of `scene`: `Ok(warnings)`
/// (the scene's own, [`Scene::lighting_warnings`], then one per
/// approximated feature, only with `approximate`), or the first feature it
/// cannot render, then [`Relighter::check_objects`].
///
/// # Errors
/// [`MethodError::Unsupported`], or the objects' error.
pub fn check_scene(
    method: &dyn Relighter,
    scene: &Scene,
    approximate: bool,
) -> Result<Vec<String>, MethodError> {
    let mut warnings = scene.lighting_warnings();
    for feature in SceneFeature::of_scene(scene) {
        match method.supports(feature) {
            Support::Full => {}
            Support::Approximate(how) if approximate => warnings.push(format!(
                "method {} renders {feature} approximately: {how}",
                method.name()
            )),
            Support::Approximate(how) => {
                return Err(MethodError::Unsupported {
                    method: method.name(),
                    feature,
                    approximate: Some(how),
                });
            }
            Support::No => {
                return Err(MethodError::Unsupported {
                    method: method.name(),
                    feature,
                    approximate: None,
                });
            }
        }
    }
    method.check_objects(scene)?;
    Ok(warnings)
}

/// True when `prepared` (a method's meshes, one per object, as it prepared
/// them) are exactly `scene`'s objects' meshes, by identity: the test a
/// method's `render` makes before using what it baked.
pub fn same_meshes<'a>(
    prepared: impl ExactSizeIterator<Item = &'a std::sync::Arc<relight_geom::Mesh>>,
    scene: &Scene,
) -> bool {
    same_mesh_list(prepared, scene.objects.iter().map(|o| &o.mesh))
}

/// True when `a` and `b` hold the same meshes, by identity, in the same
/// order ([`same_meshes`] against a scene; drawn meshes against the ones a
/// buffer was rasterized for).
pub fn same_mesh_list<'a, 'b>(
    a: impl ExactSizeIterator<Item = &'a std::sync::Arc<relight_geom::Mesh>>,
    b: impl ExactSizeIterator<Item = &'b std::sync::Arc<relight_geom::Mesh>>,
) -> bool {
    a.len() == b.len() && a.zip(b).all(|(x, y)| std::sync::Arc::ptr_eq(x, y))
}

/// True when `method` supports [`SceneFeature::Animation`]: prepared once on
/// a moving scene, it renders every pose (module docs, *Animation*).
#[must_use]
pub fn follows_animation(method: &dyn Relighter) -> bool {
    method.supports(SceneFeature::Animation) == Support::Full
}

/// The scene to [`Relighter::prepare`] `method` on for frames at `time`
/// seconds (module docs, *Animation*): `scene` itself when it moves and the
/// method supports [`SceneFeature::Animation`], else the posed scene
/// [`Scene::at_time`] (a static scene is returned as it is, borrowed).
#[must_use]
pub fn posed_for<'a>(
    method: &dyn Relighter,
    scene: &'a Scene,
    time: f32,
) -> std::borrow::Cow<'a, Scene> {
    if !scene.is_animated() || follows_animation(method) {
        std::borrow::Cow::Borrowed(scene)
    } else {
        std::borrow::Cow::Owned(scene.at_time(time))
    }
}

/// Sample points per pixel side of the shared background
/// ([`background_pixel`]): the pixel's corners, 2 × 2, shared with its
/// neighbours.
pub const BACKGROUND_SUBSAMPLES: usize = 2;

/// The radiance the camera sees where no object is, along `d` from `o`: the
/// environment ([`Scene::env_radiance`], bilinear) plus the front of any area
/// light in the way.
#[inline]
fn background_radiance(scene: &Scene, o: Vec3, d: Vec3) -> Vec3 {
    scene.env_radiance(d) + area_lights_seen(scene, o, d)
}

/// The background of pixel `(x, y)`: the trapezoid rule of the box-filtered
/// pixel the reference integrates — the mean of the `background_radiance`
/// at the pixel's four corners. The corners are shared with the neighbouring
/// pixels, so a frame costs one environment lookup per pixel
/// ([`fill_background`]), where a midpoint grid of the same order costs four;
/// both are exact for radiance affine across the pixel, which a bilinear
/// environment is wherever its texels are larger than a pixel.
#[must_use]
pub fn background_pixel(scene: &Scene, rays: &crate::CameraRays, x: usize, y: usize) -> Vec3 {
    let o = rays.origin();
    let (x, y) = (x as f32, y as f32);
    let c = |i: f32, j: f32| background_radiance(scene, o, rays.dir(x + i, y + j));
    0.25 * (c(0.0, 0.0) + c(1.0, 0.0) + c(0.0, 1.0) + c(1.0, 1.0))
}

/// Radiance the camera sees directly from area lights along `d` from `o`: the
/// front side of every rectangle the ray crosses (area lights are transparent
/// emitters, `relight_render::reference`), so the background shows them too.
fn area_lights_seen(scene: &Scene, o: Vec3, d: Vec3) -> Vec3 {
    scene
        .area_lights
        .iter()
        .filter(|l| d.dot(l.normal()) < 0.0)
        .filter_map(|l| l.intersect(o, d, 0.0).map(|(_, uv)| l.radiance(uv, d)))
        .sum()
}

/// Pixel corners `x0..=x1` × `y0..=y1` ([`CameraRays::dir`]'s coordinates,
/// whole numbers) outside which no ray crosses an area light.
#[derive(Clone, Copy, Debug, PartialEq)]
struct CornerBox {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

/// The corners of [`fill_background`] that can see an area light of
/// `scene`: the bounding box of the lights' projected rectangles (a
/// rectangle wholly in front of the eye projects to the quadrilateral of its
/// projected corners), widened by one corner against rounding; `None` (test
/// every corner) where a light reaches to or behind the eye's plane. Corners
/// outside it see no light, so skipping their ray tests changes no bit; on
/// the near-field scenes, whose ceiling lights fill a small part of the view
/// or none of it, the tests were a tenth of a frame.
fn area_lights_corner_box(scene: &Scene, rays: &crate::CameraRays) -> Option<CornerBox> {
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    for l in &scene.area_lights {
        for uv in [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE] {
            let p = rays.pixel_of(l.point_at(uv))?;
            if !p.is_finite() {
                return None;
            }
            (lo, hi) = (lo.min(p), hi.max(p));
        }
    }
    if lo.x > hi.x {
        // No light: an empty box.
        return Some(CornerBox {
            x0: 1,
            x1: 0,
            y0: 1,
            y1: 0,
        });
    }
    // Corner coordinates clamped to `usize`; one corner of margin.
    let corner = |v: f32, round_up: bool| -> usize {
        let v = if round_up {
            v.ceil() + 1.0
        } else {
            v.floor() - 1.0
        };
        v.clamp(0.0, u32::MAX as f32) as usize
    };
    Some(CornerBox {
        x0: corner(lo.x, false),
        x1: corner(hi.x, true),
        y0: corner(lo.y, false),
        y1: corner(hi.y, true),
    })
}

/// Whether a pixel of this coverage gets the background: no object covers
/// any of it.
#[inline]
fn empty_coverage(c: f32) -> bool {
    c <= 0.0 || c.is_nan()
}

/// Rows per task of [`fill_background`]: a band of `B` pixel rows evaluates
/// `B + 1` rows of corners.
const BACKGROUND_BAND: usize = 8;

/// Writes the shared background ([`background_pixel`]) into every pixel of
/// `image` whose coverage is zero. Bands of rows run in parallel; a band
/// evaluates each pixel corner its empty pixels need once and shares it
/// with the (up to four) pixels that meet there: about `1 + 1/8` lookups
/// per empty pixel, against sixteen for a 4 × 4 grid. The environment
/// lookups of a row of corners are made together
/// ([`relight_sphere::EnvMap::eval_many`], the same bits as one at a time).
pub fn fill_background(scene: &Scene, camera: &Camera, coverage: &Coverage, image: &mut Image) {
    let rays = camera.ray_frame();
    let o = rays.origin();
    let w = image.width;
    if w == 0 {
        return;
    }
    let env_from_world = scene.world_from_env.transpose();
    // A black environment's lookups are exactly zero: skip them, and with
    // no area light in the scene every empty pixel is zero.
    let black = scene.env.is_black();
    if black && scene.area_lights.is_empty() {
        for (p, &c) in image.pixels.iter_mut().zip(&coverage.coverage) {
            if empty_coverage(c) {
                *p = Vec3::ZERO;
            }
        }
        return;
    }
    let lights_box = area_lights_corner_box(scene, &rays);
    /// A band's buffers: which corners of a row of corners are needed,
    /// their x, directions and radiance, and two rows of corner values by x.
    #[derive(Default)]
    struct Scratch {
        needed: Vec<bool>,
        xs: Vec<usize>,
        dirs: Vec<Vec3>,
        radiance: Vec<Vec3>,
        top: Vec<Vec3>,
        bottom: Vec<Vec3>,
    }
    // Row `yy` of corners: those an empty pixel of the band's rows `yy − 1`
    // or `yy` needs (`covs` holds the band's rows from `y0`), into `top` or
    // `bottom`.
    let corners = |s: &mut Scratch, covs: &[f32], y0: usize, yy: usize, top: bool| {
        s.needed.clear();
        s.needed.resize(w + 1, false);
        let rows = covs.len() / w;
        for y in [yy.checked_sub(1), Some(yy)].into_iter().flatten() {
            let Some(r) = y.checked_sub(y0).filter(|&r| r < rows) else {
                continue;
            };
            for (x, &c) in covs[r * w..(r + 1) * w].iter().enumerate() {
                if empty_coverage(c) {
                    s.needed[x] = true;
                    s.needed[x + 1] = true;
                }
            }
        }
        s.xs.clear();
        s.xs.extend((0..=w).filter(|&x| s.needed[x]));
        let row_in_box = lights_box.is_none_or(|b| (b.y0..=b.y1).contains(&yy));
        let in_box = |x: usize| row_in_box && lights_box.is_none_or(|b| (b.x0..=b.x1).contains(&x));
        let line = if top { &mut s.top } else { &mut s.bottom };
        line.resize(w + 1, Vec3::ZERO);
        if black {
            // Only the area lights: no direction outside their box.
            for &x in &s.xs {
                line[x] = if in_box(x) {
                    area_lights_seen(scene, o, rays.dir(x as f32, yy as f32))
                } else {
                    Vec3::ZERO
                };
            }
            return;
        }
        s.dirs.clear();
        s.dirs
            .extend(s.xs.iter().map(|&x| rays.dir(x as f32, yy as f32)));
        s.radiance.clear();
        s.radiance.resize(s.dirs.len(), Vec3::ZERO);
        scene
            .env
            .eval_many(env_from_world, &s.dirs, &mut s.radiance);
        for ((&x, &d), &l) in s.xs.iter().zip(&s.dirs).zip(&s.radiance) {
            line[x] = l + if in_box(x) {
                area_lights_seen(scene, o, d)
            } else {
                Vec3::ZERO
            };
        }
    };
    image
        .pixels
        .par_chunks_mut(w * BACKGROUND_BAND)
        .zip(coverage.coverage.par_chunks(w * BACKGROUND_BAND))
        .enumerate()
        .for_each_init(Scratch::default, |s, (band, (rows, covs))| {
            if !covs.iter().any(|&c| empty_coverage(c)) {
                return;
            }
            let y0 = band * BACKGROUND_BAND;
            let y1 = y0 + covs.len() / w;
            if black && lights_box.is_some_and(|b| y1 < b.y0 || y0 > b.y1) {
                // Every corner of the band is black.
                for (p, &c) in rows.iter_mut().zip(covs) {
                    if empty_coverage(c) {
                        *p = Vec3::ZERO;
                    }
                }
                return;
            }
            corners(s, covs, y0, y0, true);
            for (r, (row, cov)) in rows.chunks_mut(w).zip(covs.chunks(w)).enumerate() {
                let y = y0 + r;
                corners(s, covs, y0, y + 1, false);
                for (x, (p, &c)) in row.iter_mut().zip(cov).enumerate() {
                    if !empty_coverage(c) {
                        continue;
                    }
                    let (t, b) = (&s.top, &s.bottom);
                    *p = 0.25 * (((t[x] + t[x + 1]) + b[x]) + b[x + 1]);
                }
                std::mem::swap(&mut s.top, &mut s.bottom);
            }
        });
}

/// Coverage and object ids of `scene`'s objects seen by `camera`, from a
/// visibility buffer at `samples × samples` points per pixel (both sides of
/// every triangle drawn).
///
/// # Errors
/// A bad image size or mesh (as the rasterizer reports it).
pub fn rasterize_coverage(
    scene: &Scene,
    camera: &Camera,
    samples: usize,
) -> Result<Coverage, crate::RasterError> {
    let k = samples.max(1);
    let mut big = *camera;
    big.width *= k;
    big.height *= k;
    let draws: Vec<DrawCall> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| DrawCall::new(&o.mesh.positions, &o.mesh.indices).with_object_id(i as u32))
        .collect();
    let mut r = Rasterizer::new();
    let opts = RasterOptions {
        cull: CullMode::None,
        ..RasterOptions::default()
    }
    .fit_depth(&big, &draws);
    r.rasterize(&big, &draws, &opts)?;
    Ok(coverage_of_raster(&r, camera.width, camera.height, k))
}

/// A copy of `src` made by the pool's threads (blocks of 64 KB): a frame's
/// image or coverage copied into a [`Rendered`] is 4–13 MB, which one
/// thread copies at its own load/store rate.
fn par_copy<T: Copy + Send + Sync>(src: &[T]) -> Vec<T> {
    const BLOCK_BYTES: usize = 1 << 16;
    let block = (BLOCK_BYTES / std::mem::size_of::<T>().max(1)).max(1);
    let mut out = Vec::with_capacity(src.len());
    // Block by block with `memcpy`: an element-wise collect moved each
    // 12-byte pixel as two scalar stores (a 1200 × 900 near-field frame on
    // one thread, copy included: 4.3 → 4.0 ms).
    out.spare_capacity_mut()[..src.len()]
        .par_chunks_mut(block)
        .zip(src.par_chunks(block))
        .for_each(|(dst, s)| {
            // SAFETY: `MaybeUninit<T>` has `T`'s layout, and every `T` is a
            // valid, initialised `MaybeUninit<T>`.
            let s: &[MaybeUninit<T>] =
                unsafe { std::slice::from_raw_parts(s.as_ptr().cast(), s.len()) };
            dst.copy_from_slice(s);
        });
    // SAFETY: the loop above initialised every element below `src.len()`.
    unsafe { out.set_len(src.len()) };
    out
}

/// What a [`CoverageCache`] entry was reduced from:
/// `(Rasterizer::generation, width, height, k)`.
type CoverageKey = (u64, usize, usize, usize);

/// The last [`coverage_of_raster`] a method computed, with the
/// [`Rasterizer::generation`] and sizes it was computed for
/// ([`Rendered::from_samples_cached`]).
#[derive(Debug, Default)]
pub struct CoverageCache {
    /// `(generation, width, height, k)` and the coverage.
    last: Option<(CoverageKey, Arc<Coverage>)>,
}

impl CoverageCache {
    /// [`coverage_of_raster`], from the cache when `r` holds the same
    /// rasterization (generations are unique across the process, and 0 is
    /// never cached) at the same sizes.
    pub fn get(&mut self, r: &Rasterizer, width: usize, height: usize, k: usize) -> Arc<Coverage> {
        let key = (r.generation(), width, height, k);
        match &self.last {
            // Shared, not copied: 8 bytes a pixel.
            Some((held, c)) if *held == key && key.0 != 0 => c.clone(),
            _ => {
                let c = Arc::new(coverage_of_raster(r, width, height, k));
                self.last = Some((key, c.clone()));
                c
            }
        }
    }
}

/// [`Coverage`] at `width × height` of a rasterizer's last visibility buffer,
/// drawn at `k × k` samples per pixel with draw call `i` = object `i` (the
/// layout every raster method uses).
#[must_use]
pub fn coverage_of_raster(r: &Rasterizer, width: usize, height: usize, k: usize) -> Coverage {
    let g = r.gbuffer();
    coverage_from_ids(width, height, k, |x, y| {
        r.locate(g.triangle[y * g.width + x]).map(|(d, _)| d as u32)
    })
}

/// Box-reduces per-sample object ids (`None` = empty) of a `k`× supersampled
/// buffer to [`Coverage`] at `width × height` (rows in parallel, no
/// allocation per pixel; ties go to the lower object id).
#[must_use]
pub fn coverage_from_ids(
    width: usize,
    height: usize,
    k: usize,
    id_at: impl Fn(usize, usize) -> Option<u32> + Sync,
) -> Coverage {
    let n = width * height;
    let k = k.max(1);
    let mut coverage = vec![0.0f32; n];
    let mut object_id = vec![0u32; n];
    if width == 0 {
        return Coverage {
            width,
            height,
            coverage,
            object_id,
        };
    }
    let inv = 1.0 / (k * k) as f32;
    coverage
        .par_chunks_mut(width)
        .zip(object_id.par_chunks_mut(width))
        .enumerate()
        .for_each(|(py, (cov, ids))| {
            // (object id, samples) of the objects seen in one pixel, at most k².
            let mut counts = [(0u32, 0u32); MAX_AA * MAX_AA];
            for (px, (c, o)) in cov.iter_mut().zip(ids.iter_mut()).enumerate() {
                if k == 1 {
                    let id = id_at(px, py);
                    *c = if id.is_some() { 1.0 } else { 0.0 };
                    *o = id.map_or(0, |i| i + 1);
                    continue;
                }
                let mut used = 0usize;
                let mut hit = 0u32;
                for sy in 0..k {
                    for sx in 0..k {
                        if let Some(id) = id_at(px * k + sx, py * k + sy) {
                            hit += 1;
                            if let Some(e) = counts[..used].iter_mut().find(|(o, _)| *o == id) {
                                e.1 += 1;
                            } else if used < MAX_AA * MAX_AA {
                                counts[used] = (id, 1);
                                used += 1;
                            }
                        }
                    }
                }
                *o = counts[..used]
                    .iter()
                    .max_by_key(|(o, c)| (*c, std::cmp::Reverse(*o)))
                    .map_or(0, |(o, _)| o + 1);
                *c = hit as f32 * inv;
            }
        });
    Coverage {
        width,
        height,
        coverage,
        object_id,
    }
}

/// Sub-pixel samples per side of the coverage [`render_frame`] rasterizes
/// when a method does not report its own.
pub const COVERAGE_SUBSAMPLES: usize = 4;

/// Whether [`render_frame`] paints the shared background into every pixel
/// of `scene`'s frames that no object covers (coverage 0): every scene
/// without a participating medium. A method may then leave the samples of
/// such pixels unshaded; methods that render a medium keep their own
/// background (the foggy sky is part of their image).
#[must_use]
pub fn frame_paints_background(scene: &Scene) -> bool {
    !scene.medium.is_some_and(|m| m.beta > 0.0)
}

/// One frame through the interface: [`Relighter::render`], then the coverage
/// (the method's own, or rasterized at [`COVERAGE_SUBSAMPLES`]²) and the one
/// background in every pixel no object covers. Methods that render a medium
/// keep their own background (the foggy sky is part of their image).
///
/// # Errors
/// As [`Relighter::render`].
pub fn render_frame(
    method: &mut dyn Relighter,
    scene: &Scene,
    request: &FrameRequest,
    progress: &dyn Progress,
) -> Result<Rendered, MethodError> {
    request.validate(method.name())?;
    let mut out = method.render(scene, request, progress)?;
    let t = Instant::now();
    let coverage = match out.coverage.take() {
        Some(c) => c,
        None => Arc::new(
            rasterize_coverage(scene, &request.camera, COVERAGE_SUBSAMPLES)
                .map_err(|e| MethodError::failed(method.name(), e))?,
        ),
    };
    if frame_paints_background(scene) {
        fill_background(scene, &request.camera, &coverage, &mut out.image);
    }
    out.coverage = Some(coverage);
    out.timings.view_ms += t.elapsed().as_secs_f64() * 1e3;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AreaLight, Camera};
    use glam::{Mat3, Vec2, Vec3};
    use relight_sphere::{EnvMap, Param};

    /// [`fill_background`] writes [`background_pixel`] into every empty
    /// pixel, bit for bit (environment lookups made row by row, an area
    /// light in view), and leaves every covered pixel alone: odd sizes, so
    /// that bands end early, and holes of every shape in the coverage.
    #[test]
    fn fill_background_is_the_shared_background_pixel() {
        let param = Param::LatLong {
            width: 40,
            height: 20,
        };
        let texels = (0..param.len())
            .map(|i| Vec3::new(1.0 + (i as f32 * 0.37).sin(), 0.2 * (i % 5) as f32, 0.7))
            .collect();
        let (w, h) = (23, 19);
        let camera = Camera {
            eye: Vec3::new(0.3, 0.4, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 70.0,
            width: w,
            height: h,
            image_offset: Vec2::new(0.01, -0.02),
        };
        let mut scene = Scene::new(Vec::new(), EnvMap { param, texels }, camera);
        scene.world_from_env = Mat3::from_euler(glam::EulerRot::YXZ, 0.6, -0.2, 0.1);
        scene.area_lights.push(AreaLight {
            center: Vec3::new(0.0, 0.5, 0.0),
            size: Vec2::new(1.0, 0.6),
            world_from_light: Mat3::IDENTITY,
            intensity: Vec3::splat(5.0),
            texture: None,
            light_field: None,
        });
        let coverage = Coverage {
            width: w,
            height: h,
            coverage: (0..w * h)
                .map(|i| match (i * 7 + i / w) % 5 {
                    0 => 1.0,
                    1 => 0.5,
                    _ => 0.0,
                })
                .collect(),
            object_id: vec![0; w * h],
        };
        let check = |scene: &Scene| {
            let marker = Vec3::new(-1.0, -2.0, -3.0);
            let mut image = Image::new(w, h);
            image.pixels.fill(marker);
            fill_background(scene, &camera, &coverage, &mut image);
            let rays = camera.ray_frame();
            let mut lit = 0;
            for y in 0..h {
                for x in 0..w {
                    let (i, got) = (y * w + x, image.pixels[y * w + x]);
                    if coverage.coverage[i] > 0.0 {
                        assert_eq!(got, marker, "covered pixel ({x}, {y}) written");
                        continue;
                    }
                    let want = background_pixel(scene, &rays, x, y);
                    assert_eq!(
                        got.to_array().map(f32::to_bits),
                        want.to_array().map(f32::to_bits),
                        "pixel ({x}, {y})"
                    );
                    lit += usize::from(
                        area_lights_seen(scene, rays.origin(), rays.dir(x as f32, y as f32))
                            != Vec3::ZERO,
                    );
                }
            }
            assert_eq!(
                lit > 0,
                !scene.area_lights.is_empty(),
                "the area light in view"
            );
        };
        check(&scene);
        // A black environment skips its lookups (`EnvMap::is_black`), with
        // the area light and without it: the same bits.
        scene.env = EnvMap::black();
        check(&scene);
        // Corners outside the lights' projected box skip their ray tests
        // (`area_lights_corner_box`): a second light across the image's
        // left edge, then one reaching behind the eye (every corner tested).
        let mut wide = scene.clone();
        wide.area_lights.push(AreaLight {
            center: Vec3::new(-1.6, -0.2, 0.5),
            size: Vec2::new(0.8, 0.5),
            world_from_light: Mat3::from_rotation_y(0.7),
            ..wide.area_lights[0].clone()
        });
        check(&wide);
        let mut behind = scene.clone();
        behind.area_lights[0].center = Vec3::new(0.0, 1.5, 3.0);
        behind.area_lights[0].size = Vec2::new(3.0, 4.0);
        behind.area_lights[0].world_from_light = Mat3::from_rotation_x(1.2);
        assert!(area_lights_corner_box(&behind, &camera.ray_frame()).is_none());
        check(&behind);
        scene.area_lights.clear();
        check(&scene);
    }

    /// [`area_lights_corner_box`] holds every corner whose ray meets a
    /// light, and is smaller than the image when the light is.
    #[test]
    fn area_lights_corner_box_holds_the_lit_corners() {
        let (w, h) = (64, 48);
        let camera = Camera {
            eye: Vec3::new(0.2, 0.5, 4.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 60.0,
            width: w,
            height: h,
            image_offset: Vec2::new(0.02, 0.01),
        };
        let mut scene = Scene::new(Vec::new(), EnvMap::black(), camera);
        scene.area_lights.push(AreaLight {
            center: Vec3::new(0.4, 0.8, 0.0),
            size: Vec2::new(0.7, 0.4),
            world_from_light: Mat3::from_rotation_x(0.4) * Mat3::from_rotation_z(0.3),
            intensity: Vec3::ONE,
            texture: None,
            light_field: None,
        });
        let rays = camera.ray_frame();
        let b = area_lights_corner_box(&scene, &rays).expect("in front of the eye");
        let mut lit = 0;
        for y in 0..=h {
            for x in 0..=w {
                let d = rays.dir(x as f32, y as f32);
                if area_lights_seen(&scene, rays.origin(), d) != Vec3::ZERO {
                    lit += 1;
                    assert!(
                        (b.x0..=b.x1).contains(&x) && (b.y0..=b.y1).contains(&y),
                        "lit corner ({x}, {y}) outside {b:?}"
                    );
                }
            }
        }
        assert!(lit > 20, "{lit} lit corners");
        assert!((b.x1 - b.x0) * (b.y1 - b.y0) < w * h / 4, "{b:?}");
    }

    /// [`CoverageCache`] gives [`coverage_of_raster`]'s coverage: again for
    /// the same rasterization, and anew after another rasterization or at
    /// other sizes.
    #[test]
    fn coverage_cache_follows_the_rasterization() {
        use crate::raster::{DrawCall, RasterOptions, Rasterizer};
        let positions = [
            Vec3::new(-0.5, -0.5, 0.0),
            Vec3::new(0.6, -0.4, 0.0),
            Vec3::new(0.0, 0.7, 0.0),
        ];
        let indices = [[0u32, 1, 2]];
        let draws = [DrawCall::new(&positions, &indices)];
        let camera = |eye: Vec3| Camera {
            eye,
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 60.0,
            width: 24,
            height: 16,
            image_offset: Vec2::ZERO,
        };
        let mut r = Rasterizer::new();
        let mut cache = CoverageCache::default();
        let draw = |r: &mut Rasterizer, eye: Vec3| {
            let cam = camera(eye);
            let opts = RasterOptions::default().fit_depth(&cam, &draws);
            r.rasterize(&cam, &draws, &opts).unwrap();
        };
        draw(&mut r, Vec3::new(0.0, 0.0, 2.0));
        let first = cache.get(&r, 24, 16, 1);
        assert_eq!(*first, coverage_of_raster(&r, 24, 16, 1));
        assert!(first.coverage.iter().any(|&c| c > 0.0));
        let again = cache.get(&r, 24, 16, 1);
        assert_eq!(again, first, "same rasterization");
        assert!(Arc::ptr_eq(&again, &first), "shared, not copied");
        assert_eq!(*cache.get(&r, 12, 8, 2), coverage_of_raster(&r, 12, 8, 2));
        draw(&mut r, Vec3::new(0.8, 0.3, 1.5));
        let moved = cache.get(&r, 24, 16, 1);
        assert_eq!(*moved, coverage_of_raster(&r, 24, 16, 1));
        assert_ne!(moved, first, "a new rasterization is reduced again");
    }
}
