//! [`ShMethod`]: SH environment-map shading behind the method interface
//! ([`relight_render::method::Relighter`], name `sh`).
//!
//! # What it renders
//! The unshadowed reflection integral of each object's isotropic BRDF under
//! the distant environment, band-limited to `order` SH bands (Kautz, Sloan &
//! Snyder 2002), with each object's own tangent-space normal map applied per
//! pixel by rotating the transfer vector from the perturbed to the
//! interpolated frame (Křivánek et al. 2006 §4.1; [`crate::relight`] has the
//! algorithm). Point and area lights, media, shadows and spatially varying
//! BRDFs are not rendered, and [`Relighter::supports`] says so. (The fog
//! method renders SH lighting in fog.)
//!
//! # What each call does
//! The per-frame path does only per-frame work:
//!
//! | call | work | cost |
//! |---|---|---|
//! | [`Relighter::prepare`] | BRDF tables (baked once per BRDF and kept in memory across `prepare`s), vertex data, the environment's SH projection, then `set_lighting` | seconds on the first bake, then ≈ a lighting change |
//! | [`Relighter::set_lighting`] | the projected lighting rotated by `world_from_env` exactly in the SH domain (one Ivanic–Ruedenberg matrix, so the map is never resampled), then into every vertex frame | O(vertices · n³) |
//! | [`Relighter::render`] | rasterization at `aa × aa` samples per pixel, per-pixel transfer lookup, rotation and dot product, box filter | O(pixels · aa² · n³) with the exact rotation |
//!
//! The environment is projected again only when its texels change (a 64-bit
//! fingerprint of the map is compared on every `set_lighting`).
//!
//! # Timings
//! `set_lighting` returns its milliseconds; the next frame also reports them
//! as [`FrameTimings::lighting_ms`] (then 0 until the next lighting change),
//! and [`FrameTimings::view_ms`] is the raster + shading time of the frame.
//!
//! [`FrameTimings::lighting_ms`]: relight_render::method::FrameTimings::lighting_ms
//! [`FrameTimings::view_ms`]: relight_render::method::FrameTimings::view_ms

use crate::bake::{BakeOptions, BrdfShTable};
use crate::filter::Filtered;
use crate::relight::{Background, check_meshes};
use crate::{LitScene, NormalMap, ShLightError, ShRenderer, ShRotationMethod};
use relight_ndf::NdfFilter;
use relight_render::method::{
    FrameRequest, FrameWork, MethodError, Relighter, Rendered, SceneFeature, Support, check_scene,
};
use relight_render::{Image, Numbered, Progress, Scene};
use relight_sh::rotation::ZyzRotation;
use relight_sh::window::{ChosenWindow, WindowChoice};
use std::borrow::Cow;
use std::sync::Arc;
use std::time::Instant;

/// Relative L2 change of a lobe by its window above which
/// [`ShMethod::warnings`] says the order cannot represent it.
pub const LOBE_CHANGE_WARNING: f64 = 0.25;

/// The method's name on the command line.
pub const SH_METHOD_NAME: &str = "sh";

/// Settings of [`ShMethod`]. `Default` holds the SH defaults (the one place
/// they live).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShOptions {
    /// SH bands n (1..=[`crate::MAX_SHADING_ORDER`]); n² coefficients per
    /// channel. Default 6.
    pub order: usize,
    /// Per-pixel rotation of the transfer vector into the vertex frame.
    /// Default [`ShOptions::DEFAULT_ROTATION`].
    pub rotation: ShRotationMethod,
    /// Resolution of the BRDF bake. Default [`BakeOptions::default`].
    pub bake: BakeOptions,
    /// Taylor rotations switch to exact ZYZ beyond this tilt, radians (≥ 0;
    /// Křivánek et al. §4.2). Default ∞ (pure Taylor).
    pub beta_lim: f32,
    /// Ringing window of each BRDF's transfer (`relight_sh::window`).
    /// Default [`WindowChoice::Auto`]: Sloan's deringing wherever a lobe
    /// would go negative at `order` bands, so no pixel is negative.
    pub window: WindowChoice,
    /// Normal-map filtering of normal-mapped Lambertian objects
    /// (`crate::filter`). Default [`NdfFilter::None`]: plain normal
    /// mapping.
    pub normal_filter: NdfFilter,
}

impl ShOptions {
    /// The default per-pixel rotation: exact, by the ZYZ decomposition
    /// (three Z rotations and two fixed sparse X matrices per pixel, no
    /// per-pixel matrix build).
    pub const DEFAULT_ROTATION: ShRotationMethod = ShRotationMethod::Zyz;
}

impl Default for ShOptions {
    fn default() -> Self {
        Self {
            order: 6,
            rotation: Self::DEFAULT_ROTATION,
            bake: BakeOptions::default(),
            beta_lim: f32::INFINITY,
            window: WindowChoice::Auto,
            normal_filter: NdfFilter::None,
        }
    }
}

/// SH environment shading as a [`Relighter`] (see the module docs).
pub struct ShMethod {
    options: ShOptions,
    /// Holds the in-memory cache of BRDF tables and the lighting rotation.
    renderer: ShRenderer,
    /// What `prepare` built for the scene.
    state: Option<LitScene>,
    /// The supersampled frame, reused across frames.
    image: Image,
    /// The last lighting change's ms, reported by the next frame.
    pending_lighting_ms: f64,
    /// The filtering mode, when [`ShOptions::normal_filter`] has objects
    /// to filter.
    filtered: Option<Filtered>,
    /// Normal-mapped objects the filter does not apply to, one line each.
    filter_warnings: Vec<String>,
}

impl std::fmt::Debug for ShMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShMethod")
            .field("options", &self.options)
            .field("prepared", &self.state.is_some())
            .finish_non_exhaustive()
    }
}

fn fail(e: ShLightError) -> MethodError {
    MethodError::failed(SH_METHOD_NAME, e)
}

fn stale(why: &str) -> MethodError {
    fail(ShLightError::InvalidParameter {
        what: "scene",
        why: why.to_string(),
    })
}

impl ShMethod {
    /// A method with `options`.
    ///
    /// # Errors
    /// [`MethodError::InvalidOption`] naming `order` or `beta_lim`.
    pub fn new(options: ShOptions) -> Result<Self, MethodError> {
        let invalid = |option, e: ShLightError| MethodError::InvalidOption {
            method: SH_METHOD_NAME,
            option,
            message: e.to_string(),
        };
        let renderer = ShRenderer::new(options.order, options.rotation)
            .map_err(|e| invalid("order", e))?
            .with_bake_options(options.bake)
            .with_window(options.window)
            .with_beta_lim(options.beta_lim)
            .map_err(|e| invalid("beta_lim", e))?;
        Ok(Self {
            options,
            renderer,
            state: None,
            image: Image::new(1, 1),
            pending_lighting_ms: 0.0,
            filtered: None,
            filter_warnings: Vec::new(),
        })
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &ShOptions {
        &self.options
    }

    /// The BRDF tables of the prepared scene, one per object (shared where
    /// objects share a BRDF); empty before `prepare`.
    #[must_use]
    pub fn tables(&self) -> &[Arc<BrdfShTable>] {
        self.state.as_ref().map_or(&[], LitScene::tables)
    }

    /// The window chosen for each object of the prepared scene at the
    /// method's order (empty before `prepare`): which one, how much it
    /// changed the lobe, and how negative the lobe was without it.
    #[must_use]
    pub fn windows(&self) -> &[ChosenWindow] {
        self.state.as_ref().map_or(&[], LitScene::windows)
    }

    /// One line per object whose lobe `order` bands cannot represent: its
    /// window changed it by more than [`LOBE_CHANGE_WARNING`] (relative L2),
    /// so its highlight is blurred; empty before `prepare`.
    #[must_use]
    pub fn lobe_warnings(&self) -> Vec<String> {
        self.windows()
            .iter()
            .enumerate()
            .filter(|(_, w)| w.change > LOBE_CHANGE_WARNING)
            .map(|(i, w)| {
                format!(
                    "sh: {}: order {} cannot represent this BRDF's lobe (it rings to {:.0} % of its peak below zero); the {} window changes it by {:.0} % — raise --order or use the wavelet method for sharp highlights",
                    Numbered::object(i),
                    self.options.order,
                    -100.0 * w.raw_min_ratio,
                    w.applied,
                    100.0 * w.change
                )
            })
            .collect()
    }

    fn check_same_meshes(state: &LitScene, scene: &Scene) -> Result<(), MethodError> {
        if state.is_built_for(scene) {
            Ok(())
        } else {
            Err(stale(
                "the objects changed since `prepare` (other meshes, or moved by an animation); call prepare again",
            ))
        }
    }
}

impl Relighter for ShMethod {
    fn name(&self) -> &'static str {
        SH_METHOD_NAME
    }

    fn warnings(&self) -> Vec<String> {
        let mut w = self.lobe_warnings();
        w.extend(self.filter_warnings.iter().cloned());
        w
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            SceneFeature::Environment | SceneFeature::NormalMaps => Support::Full,
            SceneFeature::PointLights
            | SceneFeature::AreaLights
            | SceneFeature::LightFields
            | SceneFeature::Medium
            | SceneFeature::Visibility
            | SceneFeature::SpatiallyVaryingBrdf
            | SceneFeature::Animation => Support::No,
        }
    }

    /// Meshes without normals (or uvs and tangents under a normal map) and
    /// anisotropic BRDFs ([`crate::check_objects`]).
    fn check_objects(&self, scene: &Scene) -> Result<(), MethodError> {
        crate::check_objects(scene, &|i| scene.objects[i].normal_map.is_some()).map_err(fail)
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        // A feature it cannot render is never silently dropped.
        check_scene(self, scene, true)?;
        let needs_uvs = |i: usize| scene.objects[i].normal_map.is_some();
        let previous = self.state.take();
        self.state = Some(
            LitScene::build(&self.renderer, scene, &needs_uvs, previous, progress).map_err(fail)?,
        );
        (self.filtered, self.filter_warnings) = match self.options.normal_filter {
            NdfFilter::None => (None, Vec::new()),
            f => Filtered::prepare(f, scene, progress)?,
        };
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let t = Instant::now();
        let state = self
            .state
            .as_mut()
            .ok_or_else(|| stale("call prepare before set_lighting"))?;
        Self::check_same_meshes(state, scene)?;
        self.renderer
            .set_lighting_rotation(scene.world_from_env)
            .map_err(|e| MethodError::InvalidOption {
                method: SH_METHOD_NAME,
                option: "world_from_env",
                message: e.to_string(),
            })?;
        state.light(&self.renderer, scene, progress).map_err(fail)?;
        if let Some(f) = self.filtered.as_mut() {
            f.set_lighting(scene, progress)?;
        }
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.pending_lighting_ms = ms;
        Ok(ms)
    }

    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError> {
        request.validate(SH_METHOD_NAME)?;
        let t = Instant::now();
        let state = self
            .state
            .as_mut()
            .ok_or_else(|| stale("call prepare before render"))?;
        Self::check_same_meshes(state, scene)?;
        check_meshes(scene, &|i| scene.objects[i].normal_map.is_some()).map_err(fail)?;
        let k = request.aa;
        let mut camera = request.camera;
        camera.width *= k;
        camera.height *= k;
        let maps: Vec<Option<&NormalMap>> = scene
            .objects
            .iter()
            .map(|o| o.normal_map.as_deref())
            .collect();
        // `render_frame` paints every pixel no object touches; only the empty
        // samples of partly covered pixels need the environment here.
        let background = if k == 1 {
            Background::Black
        } else {
            Background::Partial(k)
        };
        state
            .render_into(
                scene,
                &camera,
                self.options.order,
                self.options.rotation,
                &maps,
                self.options.beta_lim,
                background,
                &mut self.image,
            )
            .map_err(fail)?;
        progress.check()?;
        let mut frame = Rendered::from_samples(
            Cow::Borrowed(&self.image),
            state.raster(),
            k,
            std::mem::take(&mut self.pending_lighting_ms),
            t,
        );
        if let Some(f) = self.filtered.as_mut() {
            f.composite(request, &mut frame, progress)?;
        }
        Ok(frame)
    }

    /// The last frame's covered samples at `crate::shade`'s count per
    /// sample (by object: its rotation, normal map and channels), read from
    /// the last raster (the view of `request` once it was rendered), plus
    /// the vertices that frame lit by ZYZ (step 2 is lazy: a frame lights
    /// the vertices it shows whose lighting is stale — all of them after a
    /// lighting change, the newly seen ones after a view change).
    /// `set_lighting` itself only rotates the projected lighting once
    /// (`lighting_fma` 0: a few thousand operations).
    fn frame_work(&self, scene: &Scene, request: &FrameRequest) -> Option<FrameWork> {
        let _ = request;
        let state = self.state.as_ref()?;
        let order = self.options.order;
        let x_nnz = ZyzRotation::<f32>::new(order).ok()?.x_nonzeros();
        let raster = state.raster();
        let tables = state.tables();
        let mut samples = vec![0u64; tables.len()];
        for &id in &raster.gbuffer().triangle {
            if let Some((d, _)) = raster.locate(id)
                && let Some(c) = samples.get_mut(d)
            {
                *c += 1;
            }
        }
        let view_fma: f64 = samples
            .iter()
            .enumerate()
            .map(|(d, &n)| {
                let channels = if tables[d].mono_colour().is_some() {
                    1
                } else {
                    3
                };
                let mapped = scene.objects.get(d).is_some_and(|o| o.normal_map.is_some());
                n as f64
                    * crate::shade::sample_fma(
                        order,
                        self.options.rotation,
                        mapped,
                        channels,
                        x_nnz,
                    )
            })
            .sum();
        let relit = state.last_relit() as f64 * crate::relight::vertex_fma(order, x_nnz);
        Some(FrameWork {
            view_fma: view_fma + relit,
            lighting_fma: 0.0,
        })
    }

    /// Bytes of the distinct BRDF tables of the prepared scene.
    fn data_bytes(&self) -> u64 {
        let tables = self.tables();
        tables
            .iter()
            .enumerate()
            .filter(|(i, t)| !tables[..*i].iter().any(|u| Arc::ptr_eq(t, u)))
            .map(|(_, t)| std::mem::size_of_val(t.coeffs()) as u64)
            .sum()
    }
}
