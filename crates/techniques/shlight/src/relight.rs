//! Per frame: SH lighting, per-vertex rotation, per-pixel rotation and dot
//! product (Kautz et al. 2002 with Křivánek et al. 2006 §4.1 normal mapping).
//!
//! # Algorithm (one frame)
//! 1. **Lighting**: `L` = the environment projected onto `n` bands (world
//!    frame, RGB; `relight_sh::project::project_env`, no window).
//! 2. **Per vertex** (parallel): a local frame `F_v` (z = vertex normal,
//!    x = the vertex tangent made orthogonal to it) and the lighting in that
//!    frame, `L_v = R(F_vᵀ) L` (exact, by the ZYZ decomposition of `F_vᵀ`:
//!    three Z rotations and two fixed sparse X matrices per channel; no
//!    per-vertex matrix is built). Meshes **without tangents** get one frame per triangle corner
//!    instead (vertices are unshared), with x = the triangle's first edge made
//!    orthogonal to the corner normal: the three frames of a triangle then
//!    differ only by the small tilt between its normals, so linearly
//!    interpolating their coefficient vectors is meaningful (frames with
//!    unrelated tangent azimuths would not be).
//! 3. **Per pixel** (`crate::shade`, over the rasterizer's visibility
//!    buffer with its perspective-correct barycentrics): the interpolated vertex frame `F_v` (from the
//!    interpolated normal and tangent, Gram–Schmidt) carries the interpolated
//!    lighting `L_v`; the *perturbed* frame `F_p` has z = the normal-mapped
//!    normal ([`NormalMap::perturb`]) and x = the same tangent. With the view
//!    direction `ω_o` in `F_p` at polar angle θ_o and azimuth φ_o, the
//!    transfer vector is `B_p = R_z(φ_o) B(θ_o)` ([`BrdfShTable::lookup`]); it is
//!    rotated into `F_v` by `T = F_vᵀ F_p R_z(φ_o)` with the chosen
//!    [`ShRotationMethod`] and the pixel is `L_o = ⟨L_v, T H B(θ_o)⟩` per
//!    channel, `H` the BRDF's ringing window ([`ShRenderer::with_window`]).
//!    Where the table is rank-1 (`B_c = ρ_c B̂`, every single-lobe BRDF with a
//!    colour) one vector is rotated instead of three.
//!    The Y angle β of `T`'s ZYZ decomposition is exactly the tilt between
//!    the perturbed and the interpolated normal, so Taylor rotation is
//!    accurate where normal maps are gentle.
//!
//! Surfaces are two-sided like the reference renderer's: a pixel seen from
//! the back of its triangle shades with both frames flipped, `(x, y, z) →
//! (x, −y, −z)` (a rotation by π about x, applied to `L_v` as the sign
//! `(−1)^{l+m}` (m ≥ 0) / `−(−1)^{l+|m|}` (m < 0)).
//!
//! # `--rotation none`: simplified normal mapping
//! Křivánek et al. §4.1, last paragraph before "Results": "ignore the
//! per-pixel rotation (step 4) and use the normal map only to modulate the
//! local frame for the BRDF look-up". Here: `B_p = R_z(φ_o) B(θ_o)` with θ_o,
//! φ_o measured in the perturbed frame `F_p`, dotted directly with `L_v`
//! (which lives in `F_v`). The normal map thus only changes the view angle of
//! the BRDF lookup; a Lambertian surface shows no bumps at all.
//! Without a normal map `F_p = F_v` and every method gives the same image.
//!
//! # Anti-aliasing and coverage
//! [`ShRenderer::with_supersampling`] renders `k × k` sub-pixel samples per
//! pixel (pixel centres of a `kW × kH` image) and box-filters them, like the
//! reference renderer's uniformly jittered box filter. [`ShImage::mask`]
//! marks pixels whose every sub-sample hit an object; `verify` compares
//! errors over that mask (silhouette pixels, which mix object and background,
//! are left out).

use crate::bake::{BakeOptions, BrdfShTable};
use crate::shade::{Bg, Pass, triangle_offsets};
use crate::{MAX_SHADING_ORDER, NormalMap, ShLightError, check_shading_order};
use glam::{Mat3, Vec2, Vec3, Vec4};
use rayon::prelude::*;
use relight_brdf::Brdf;
use relight_render::cull::{closed_bounds, cull_for_closed};
use relight_render::raster::{DrawCall, NO_TRIANGLE, RasterError, RasterOptions, Rasterizer};
use relight_render::{Camera, Image, Progress, Scene};
use relight_sh::fast::ROTATE_BATCH_MAX_ORDER;
use relight_sh::project::{ShRgb, Window, project_env};
use relight_sh::rotation::{IvanicRuedenberg, Rot3, ShRotation, ZyzRotation};
use relight_sh::taylor::{TaylorOrder, TaylorRotation};
use relight_sh::window::{ChosenWindow, LobeSet, WindowChoice};
use relight_sphere::Frame;
use std::str::FromStr;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

/// Which empty samples of a frame get the environment
/// ([`crate::LitScene::render_into`]; `crate::shade`'s docs), in the
/// lighting's frame and through the lighting filter where there is one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Background {
    /// None: black.
    Black,
    /// Every empty sample.
    All,
    /// Only the empty samples of `k × k` blocks an object partly covers.
    Partial(usize),
}

/// The window for `table` at `order` bands (Sloan's deringing, Hann,
/// Lanczos or none; `relight_sh::window`), from its transfer lobes.
///
/// # Errors
/// An order above the table's.
pub(crate) fn choose_window(
    table: &BrdfShTable,
    order: usize,
    choice: WindowChoice,
) -> Result<ChosenWindow, ShLightError> {
    check_shading_order(order)?;
    if order > table.order() {
        return Err(ShLightError::InvalidParameter {
            what: "order",
            why: format!("{order} exceeds the baked order {}", table.order()),
        });
    }
    let lobes = table.lobes(order);
    let refs: Vec<&[f32]> = lobes.iter().map(Vec::as_slice).collect();
    Ok(LobeSet::new(order, &refs)?.choose(choice))
}

/// How the per-pixel transfer vector is rotated from the normal-mapped frame
/// to the interpolated vertex frame (`--rotation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShRotationMethod {
    /// Exact Ivanic–Ruedenberg matrix, built per pixel.
    Exact,
    /// Exact ZYZ ("ZXZXZ") decomposition with two fixed ±90° X rotations.
    Zyz,
    /// Křivánek's 1st-order Taylor Y rotation (exact Z rotations around it).
    Taylor1,
    /// The "1.5th order" Taylor Y rotation (`shRotYdiff15`).
    Taylor15,
    /// The 2nd-order Taylor Y rotation.
    Taylor2,
    /// No per-pixel rotation: the paper's "simplified normal mapping".
    None,
}

impl ShRotationMethod {
    /// All methods, in `verify` order.
    pub const ALL: [ShRotationMethod; 6] = [
        Self::Exact,
        Self::Zyz,
        Self::Taylor1,
        Self::Taylor15,
        Self::Taylor2,
        Self::None,
    ];

    /// The CLI name (`exact`, `zyz`, `taylor1`, `taylor15`, `taylor2`, `none`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Exact => "exact",
            Self::Zyz => "zyz",
            Self::Taylor1 => "taylor1",
            Self::Taylor15 => "taylor15",
            Self::Taylor2 => "taylor2",
            Self::None => "none",
        }
    }

    fn taylor(self) -> Option<TaylorOrder> {
        match self {
            Self::Taylor1 => Some(TaylorOrder::First),
            Self::Taylor15 => Some(TaylorOrder::OneAndHalf),
            Self::Taylor2 => Some(TaylorOrder::Second),
            _ => None,
        }
    }
}

impl std::fmt::Display for ShRotationMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ShRotationMethod {
    type Err = ShLightError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| ShLightError::InvalidParameter {
                what: "--rotation",
                why: format!(
                    "unknown method `{s}`; use one of exact, zyz, taylor1, taylor15, taylor2, none"
                ),
            })
    }
}

/// A rendered frame: the image and the pixels fully covered by objects.
#[derive(Clone, Debug)]
pub struct ShImage {
    pub image: Image,
    /// True where every sub-sample of the pixel hit an object (row-major).
    pub mask: Vec<bool>,
}

/// The SH environment-map renderer. Build once, render many frames; BRDF
/// bakes are cached in memory per (BRDF instance, order, bake options).
#[derive(Debug)]
pub struct ShRenderer {
    order: usize,
    rotation: ShRotationMethod,
    bake: BakeOptions,
    supersampling: usize,
    beta_lim: f32,
    env_background: bool,
    window: WindowChoice,
    pub(crate) filter: Option<LightingFilter>,
    /// `world_from_env` of the lighting, applied to its SH coefficients.
    pub(crate) lighting_rotation: Option<(Mat3, Rot3<f32>)>,
    cache: Mutex<Vec<CacheEntry>>,
}

/// A zonal (rotationally symmetric) filter of the lighting: shading uses
/// L′_lm = (`direct` + `bands[l]`) L_lm, and background pixels show
/// `direct` · L(d) + max(0, Σ_lm `bands[l]` L_lm Y_lm(d)). Bands past the end of
/// `bands` get 0. With `direct` = e^{−T_sv} and `bands` the PSF's
/// √(4π/(2l+1)) PSF_l (`relight_fog::psf::convolution_weights`) this is the
/// foggy environment of sun-thesis-2008 eq. 3.35–3.37: attenuated lighting
/// plus its convolution with the single-scattering point-spread function
/// (the fog method passes the fog ball's own kernel,
/// `relight_fog::psf::ball_convolution_weights`, the same way).
#[derive(Clone, Debug, PartialEq)]
pub struct LightingFilter {
    /// Weight of the unfiltered lighting (direct transmission), ≥ 0.
    pub direct: f32,
    /// Weight of band l of the filtered part (finite).
    pub bands: Vec<f32>,
}

impl LightingFilter {
    fn band(&self, l: usize) -> f32 {
        self.bands.get(l).copied().unwrap_or(0.0)
    }
}

#[derive(Debug)]
struct CacheEntry {
    /// Kept alive so its address is never reused while cached.
    brdf: Arc<dyn Brdf>,
    order: usize,
    bake: BakeOptions,
    table: Arc<BrdfShTable>,
    /// Windows chosen for this table: (order, choice, window).
    windows: Vec<(usize, WindowChoice, ChosenWindow)>,
}

/// The camera-independent state at `order_max` bands: the BRDF tables, the
/// geometry with its vertex frames ([`ShRenderer::build`]) and, once lit
/// ([`ShRenderer::light`]), the lighting in every vertex frame. Shaded for a
/// camera by [`Lit::shade_into`] after [`Lit::rasterize`].
pub(crate) struct Lit {
    pub(crate) order_max: usize,
    draws: Vec<DrawData>,
    pub(crate) tables: Vec<Arc<BrdfShTable>>,
    /// The window asked for, and per object the one chosen at `order_max`.
    pub(crate) window: WindowChoice,
    pub(crate) windows: Vec<ChosenWindow>,
    /// With a [`LightingFilter`]: its `direct` weight and the filtered
    /// lighting's SH (order_max², RGB), added to the background.
    filtered_background: Option<(f32, [Vec<f32>; 3])>,
    /// Inverse of the lighting rotation, for background lookups.
    env_from_world: Mat3,
    /// The lighting of the last [`ShRenderer::light`] (world frame, rotated
    /// and filtered), `order_max²` per channel, that vertices are lit from
    /// when they are first seen ([`Lit::shade_into`]); `None` before.
    world_light: Option<[Vec<f32>; 3]>,
    /// Stamp of `world_light`: a vertex whose stamp
    /// ([`DrawData::stamp`]) equals it holds `L_v` of that lighting.
    epoch: u32,
    /// The ZYZ plan of the per-vertex rotation at `order_max`.
    vertex_zyz: ZyzRotation<f32>,
    /// The rotation machinery of the last frame's (order, method, β limit).
    rotator: Mutex<Option<Arc<Rotator>>>,
    /// Vertices lit by the last [`Lit::shade_into`] (for the work count).
    pub(crate) last_relit: usize,
}

/// A [`DrawData::stamp`] of a vertex that the visible-vertex scan of a
/// frame found stale ([`Lit::relight_visible`]).
const STAMP_NEEDED: u32 = u32::MAX;

/// [`Lit`] rasterized for one camera at `k × k` samples per pixel; shaded
/// by [`Prepared::shade`].
pub(crate) struct Prepared {
    lit: Lit,
    raster: Rasterizer,
    camera: Camera,
    k: usize,
}

/// Marked vertices per batch rotation of [`Lit::relight_needed`] (three
/// times as many vectors).
const RELIGHT_RUN: usize = 64;

/// Vertices per parallel task of [`Lit::relight_needed`]: after a view
/// change a few in a thousand are marked, and each batch should still be
/// full (a batch of 64 vertices with two marked cost as much as a full one).
const RELIGHT_SPAN: usize = 1024;

/// One thread's buffers for a run of [`Lit::relight_needed`]: per marked
/// vertex its index in the span, its rotation, and its three channel
/// vectors (`order²` each) after the batch rotation (`dst` doubles as the
/// scratch of the one-by-one path). The sources are the world lighting's
/// channels themselves, shared by every vertex
/// ([`relight_sh::fast::rotate_shared_batch`]).
struct RelightRun {
    index: [usize; RELIGHT_RUN],
    rots: Vec<Rot3<f32>>,
    dst: Vec<f32>,
}

impl RelightRun {
    fn new(nn: usize) -> Self {
        Self {
            index: [0; RELIGHT_RUN],
            rots: vec![
                Rot3::new_unchecked([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
                RELIGHT_RUN
            ],
            dst: vec![0.0; 3 * RELIGHT_RUN * nn],
        }
    }
}

/// One object's geometry and vertex data (SoA by kind).
pub(crate) struct DrawData {
    pub(crate) positions: Vec<Vec3>,
    pub(crate) triangles: Vec<[u32; 3]>,
    /// Per vertex: normal (3), tangent (4, w = handedness), uv (2).
    pub(crate) verts: Vec<[f32; 9]>,
    /// Per vertex the lighting in its frame, `L_v`: 3 channels × `order_max²`
    /// (`light[v · 3n² + c · n² + i]`), valid where [`DrawData::stamp`]
    /// equals [`Lit`]'s epoch.
    pub(crate) light: Vec<f32>,
    /// Per vertex: the epoch of the lighting `light` holds (0: never lit), or
    /// [`STAMP_NEEDED`] during a frame's visible-vertex scan.
    stamp: Vec<AtomicU32>,
    /// The bounds of a closed, outward-oriented mesh, whose back faces the
    /// raster culls from outside them
    /// ([`relight_render::cull`]); `None` for an open mesh.
    closed: Option<relight_geom::Aabb>,
}

impl ShRenderer {
    /// A renderer for `order` bands (`1..=`[`MAX_SHADING_ORDER`]) with the
    /// given per-pixel rotation. Defaults: [`BakeOptions::default`], no
    /// supersampling, pure Taylor rotation (no β limit).
    ///
    /// # Errors
    /// Order out of range.
    pub fn new(order: usize, rotation: ShRotationMethod) -> Result<Self, ShLightError> {
        check_shading_order(order)?;
        Ok(Self {
            order,
            rotation,
            bake: BakeOptions::default(),
            supersampling: 1,
            beta_lim: f32::INFINITY,
            env_background: true,
            window: WindowChoice::default(),
            filter: None,
            lighting_rotation: None,
            cache: Mutex::new(Vec::new()),
        })
    }

    /// The ringing window of the transfer ([`WindowChoice`], default
    /// [`WindowChoice::Auto`]: Sloan's deringing where a lobe would go
    /// negative).
    #[must_use]
    pub fn with_window(mut self, window: WindowChoice) -> Self {
        self.window = window;
        self
    }

    /// Bake resolution.
    #[must_use]
    pub fn with_bake_options(mut self, bake: BakeOptions) -> Self {
        self.bake = bake;
        self
    }

    /// `k × k` sub-pixel samples per pixel (box filter), `k` clamped to 1..=8.
    #[must_use]
    pub fn with_supersampling(mut self, k: usize) -> Self {
        self.supersampling = k.clamp(1, 8);
        self
    }

    /// Taylor methods switch to the exact ZYZ rotation when the tilt β exceeds
    /// `beta_lim` radians (Křivánek et al. §4.2). Default: never (∞).
    ///
    /// # Errors
    /// NaN or negative limit.
    pub fn with_beta_lim(mut self, beta_lim: f32) -> Result<Self, ShLightError> {
        if beta_lim.is_nan() || beta_lim < 0.0 {
            return Err(ShLightError::InvalidParameter {
                what: "beta_lim",
                why: format!("{beta_lim} must be ≥ 0 radians"),
            });
        }
        self.beta_lim = beta_lim;
        Ok(self)
    }

    /// Whether pixels that show no object show the environment (default,
    /// like the reference renderer; `EnvMap::eval` per background pixel) or black.
    #[must_use]
    pub fn with_env_background(mut self, on: bool) -> Self {
        self.env_background = on;
        self
    }

    /// Filters the lighting ([`LightingFilter`]), e.g. into a foggy
    /// environment.
    ///
    /// # Errors
    /// A negative or non-finite `direct`, or a non-finite band weight.
    pub fn with_lighting_filter(mut self, filter: LightingFilter) -> Result<Self, ShLightError> {
        self.set_lighting_filter(Some(filter))?;
        Ok(self)
    }

    /// Sets (or, with `None`, removes) the lighting filter of
    /// [`ShRenderer::with_lighting_filter`]; it takes effect at the next
    /// lighting change ([`crate::LitScene::light`]).
    ///
    /// # Errors
    /// As [`ShRenderer::with_lighting_filter`]; the filter is then unchanged.
    pub fn set_lighting_filter(
        &mut self,
        filter: Option<LightingFilter>,
    ) -> Result<(), ShLightError> {
        if let Some(filter) = &filter
            && (!(filter.direct.is_finite() && filter.direct >= 0.0)
                || filter.bands.iter().any(|w| !w.is_finite()))
        {
            return Err(ShLightError::InvalidParameter {
                what: "lighting filter",
                why: format!(
                    "direct weight {} must be finite and ≥ 0 and every band weight finite ({:?})",
                    filter.direct, filter.bands
                ),
            });
        }
        self.filter = filter;
        Ok(())
    }

    /// Rotates the lighting by `world_from_env` (`L_world(d) =
    /// env(world_from_envᵀ d)`) in the SH domain: the projected
    /// coefficients are rotated exactly (Ivanic–Ruedenberg), so the map is
    /// never resampled; background pixels look the map up rotated.
    ///
    /// # Errors
    /// A matrix that is not a rotation (tolerance 1e-4).
    pub fn with_lighting_rotation(mut self, world_from_env: Mat3) -> Result<Self, ShLightError> {
        self.set_lighting_rotation(world_from_env)?;
        Ok(self)
    }

    /// [`ShRenderer::with_lighting_rotation`] in place (for a renderer kept
    /// across frames, whose BRDF bakes stay cached).
    ///
    /// # Errors
    /// A matrix that is not a rotation (tolerance 1e-4); the rotation is then
    /// unchanged.
    pub fn set_lighting_rotation(&mut self, world_from_env: Mat3) -> Result<(), ShLightError> {
        let r = Rot3::try_from_mat3(world_from_env)?;
        self.lighting_rotation = (world_from_env != Mat3::IDENTITY).then_some((world_from_env, r));
        Ok(())
    }

    /// Bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// The per-pixel rotation method.
    #[must_use]
    pub fn rotation(&self) -> ShRotationMethod {
        self.rotation
    }

    /// The (cached) bake of `brdf` at `order` bands.
    ///
    /// # Errors
    /// See [`BrdfShTable::bake`].
    pub fn table(
        &self,
        brdf: &Arc<dyn Brdf>,
        order: usize,
        object: usize,
        progress: &dyn Progress,
    ) -> Result<Arc<BrdfShTable>, ShLightError> {
        {
            let cache = self
                .cache
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            if let Some(e) = cache
                .iter()
                .find(|e| Arc::ptr_eq(&e.brdf, brdf) && e.order >= order && e.bake == self.bake)
            {
                return Ok(e.table.clone());
            }
        }
        let table = Arc::new(BrdfShTable::bake(
            brdf.as_ref(),
            order,
            &self.bake,
            object,
            progress,
        )?);
        let mut cache = self
            .cache
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        cache.push(CacheEntry {
            brdf: brdf.clone(),
            order,
            bake: self.bake,
            table: table.clone(),
            windows: Vec::new(),
        });
        Ok(table)
    }

    /// The window of [`ShRenderer::with_window`] for `table` (one of this
    /// renderer's bakes) at `order` bands, chosen once and cached.
    ///
    /// # Errors
    /// An order above the table's.
    pub fn window_of(
        &self,
        table: &Arc<BrdfShTable>,
        order: usize,
    ) -> Result<ChosenWindow, ShLightError> {
        let find = |cache: &Vec<CacheEntry>| {
            cache
                .iter()
                .filter(|e| Arc::ptr_eq(&e.table, table))
                .flat_map(|e| &e.windows)
                .find(|(o, c, _)| *o == order && *c == self.window)
                .map(|(_, _, w)| w.clone())
        };
        let lock = || {
            self.cache
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
        };
        if let Some(w) = find(&lock()) {
            return Ok(w);
        }
        let w = choose_window(table, order, self.window)?;
        if let Some(e) = lock().iter_mut().find(|e| Arc::ptr_eq(&e.table, table)) {
            e.windows.push((order, self.window, w.clone()));
        }
        Ok(w)
    }

    /// Renders `scene` (environment lighting, no shadows), with an optional
    /// tangent-space normal map applied to every object through its uvs.
    ///
    /// # Errors
    /// A normal map on a mesh without uvs/tangents, a mesh without normals, an
    /// anisotropic BRDF, rasterizer errors (image size, camera), NaN lighting,
    /// or cancellation.
    pub fn render(
        &self,
        scene: &Scene,
        normal_map: Option<&NormalMap>,
        progress: &dyn Progress,
    ) -> Result<ShImage, ShLightError> {
        let prepared = self.prepare(scene, normal_map, self.order, progress)?;
        progress.check()?;
        prepared.shade(
            scene,
            self.order,
            self.rotation,
            normal_map,
            self.beta_lim,
            self.env_background,
        )
    }

    /// Steps 1–2 and rasterization at `order_max` bands: [`ShRenderer::build`]
    /// (with `normal_map` on every object), the environment projected and
    /// [`ShRenderer::light`]ed, then rasterized for the scene camera.
    pub(crate) fn prepare(
        &self,
        scene: &Scene,
        normal_map: Option<&NormalMap>,
        order_max: usize,
        progress: &dyn Progress,
    ) -> Result<Prepared, ShLightError> {
        let mut lit = self.build(scene, order_max, &|_| normal_map.is_some(), progress)?;
        progress.check()?;
        let light = project_env(&scene.env, order_max, Window::None)?;
        self.light(&mut lit, &light, progress)?;
        lit.relight_all();
        let k = self.supersampling;
        let mut camera = scene.camera;
        camera.width *= k;
        camera.height *= k;
        let mut raster = Rasterizer::new();
        lit.rasterize(&camera, &mut raster)?;
        Ok(Prepared {
            lit,
            raster,
            camera,
            k,
        })
    }

    /// The lighting- and camera-independent part of a frame: every mesh
    /// checked (normals; uvs and tangents where `needs_uvs(object)`, i.e.
    /// where a normal map will be applied), the BRDF tables (baked once per
    /// BRDF, then from the in-memory cache) and the vertex data of every
    /// object (normal, tangent, uv; meshes without tangents get one vertex per
    /// triangle corner, see the module docs). The per-vertex lighting is left
    /// zero until [`ShRenderer::light`].
    ///
    /// # Errors
    /// Order out of range, a mesh without normals, a normal-mapped mesh
    /// without uvs or tangents, an anisotropic BRDF, cancellation.
    pub(crate) fn build(
        &self,
        scene: &Scene,
        order_max: usize,
        needs_uvs: &dyn Fn(usize) -> bool,
        progress: &dyn Progress,
    ) -> Result<Lit, ShLightError> {
        check_shading_order(order_max)?;
        check_meshes(scene, needs_uvs)?;
        let tables = scene
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| self.table(&o.brdf, order_max, i, progress))
            .collect::<Result<Vec<_>, _>>()?;
        progress.check()?;
        let windows = tables
            .iter()
            .map(|t| self.window_of(t, order_max))
            .collect::<Result<Vec<_>, _>>()?;
        let nn = order_max * order_max;
        let closed: Vec<Option<relight_geom::Aabb>> = scene
            .objects
            .par_iter()
            .map(|o| closed_bounds(&o.mesh))
            .collect();
        progress.check()?;
        let mut draws = Vec::with_capacity(scene.objects.len());
        for (o, closed) in scene.objects.iter().zip(closed) {
            progress.check()?;
            let m = &o.mesh;
            let has_tangents = m.tangents.len() == m.positions.len() && !m.positions.is_empty();
            let (positions, normals, tangents, uvs, triangles) = if has_tangents {
                let uvs = if m.uvs.len() == m.positions.len() {
                    m.uvs.clone()
                } else {
                    vec![Vec2::ZERO; m.positions.len()]
                };
                (
                    m.positions.clone(),
                    m.normals.clone(),
                    m.tangents.clone(),
                    uvs,
                    m.indices.clone(),
                )
            } else {
                unshare_corners(m)
            };
            let verts = (0..positions.len())
                .map(|v| {
                    let (n, t, uv) = (normals[v], tangents[v], uvs[v]);
                    [n.x, n.y, n.z, t.x, t.y, t.z, t.w, uv.x, uv.y]
                })
                .collect();
            draws.push(DrawData {
                light: vec![0.0f32; positions.len() * 3 * nn],
                stamp: (0..positions.len()).map(|_| AtomicU32::new(0)).collect(),
                positions,
                triangles,
                verts,
                closed,
            });
        }
        Ok(Lit {
            order_max,
            draws,
            tables,
            window: self.window,
            windows,
            filtered_background: None,
            env_from_world: Mat3::IDENTITY,
            world_light: None,
            epoch: 0,
            vertex_zyz: ZyzRotation::new(order_max)?,
            rotator: Mutex::new(None),
            last_relit: 0,
        })
    }

    /// Steps 1–2 for `lit`: `light` (the environment projected onto
    /// `lit.order_max` bands in its own frame) rotated exactly by the
    /// lighting rotation ([`ShRenderer::with_lighting_rotation`]) and
    /// filtered ([`ShRenderer::with_lighting_filter`]); each vertex frame
    /// gets it (exact ZYZ per vertex, in parallel) when a frame first sees
    /// the vertex ([`Lit::shade_into`]), or all at once by
    /// [`Lit::relight_all`].
    ///
    /// # Errors
    /// `light` of another order than `lit`, cancellation.
    pub(crate) fn light(
        &self,
        lit: &mut Lit,
        light: &ShRgb,
        progress: &dyn Progress,
    ) -> Result<(), ShLightError> {
        let order_max = lit.order_max;
        if light.order != order_max {
            return Err(ShLightError::InvalidParameter {
                what: "lighting order",
                why: format!(
                    "the projected lighting has {} bands, the prepared geometry {order_max}",
                    light.order
                ),
            });
        }
        let plan = IvanicRuedenberg::<f32>::new(order_max)?;
        let mut light = light.clone();
        let mut env_from_world = Mat3::IDENTITY;
        if let Some((world_from_env, r)) = &self.lighting_rotation {
            let mut rot = ShRotation::<f32>::identity(order_max)?;
            plan.build(r, &mut rot);
            light = light.rotated(&rot);
            env_from_world = world_from_env.transpose();
        }
        // The filtered part alone, for the background (with a filter).
        let mut filtered_background = None;
        if let Some(f) = &self.filter {
            let mut filtered = light.clone();
            for (lit, only) in light.channels.iter_mut().zip(&mut filtered.channels) {
                for (i, (a, b)) in lit.iter_mut().zip(only.iter_mut()).enumerate() {
                    let w = f.band((i as f64).sqrt() as usize);
                    *b *= w;
                    *a *= f.direct + w;
                }
            }
            filtered_background = Some((f.direct, filtered.channels));
        }
        // Step 2 is lazy: a vertex is rotated into its frame when a frame
        // first sees it after this change (`Lit::relight_visible`), so a
        // lighting change costs the visible vertices only.
        progress.check()?;
        lit.world_light = Some(light.channels);
        lit.epoch = match lit.epoch.wrapping_add(1) {
            0 | STAMP_NEEDED => 1,
            e => e,
        };
        lit.filtered_background = filtered_background;
        lit.env_from_world = env_from_world;
        Ok(())
    }
}

/// What the SH pipeline refuses in `scene`'s objects, found without
/// baking: `check_meshes` and an anisotropic BRDF
/// ([`crate::bake::check_isotropic`]). The SH and fog methods'
/// `Relighter::check_objects`.
///
/// # Errors
/// The first object refused, named.
pub fn check_objects(scene: &Scene, needs_uvs: &dyn Fn(usize) -> bool) -> Result<(), ShLightError> {
    check_meshes(scene, needs_uvs)?;
    for (i, o) in scene.objects.iter().enumerate() {
        crate::bake::check_isotropic(o.brdf.as_ref(), i)?;
    }
    Ok(())
}

/// Every object has one normal per vertex, and uvs and tangents where
/// `needs_uvs(object)`.
///
/// # Errors
/// [`ShLightError::MissingNormals`], [`ShLightError::MissingUvs`].
pub(crate) fn check_meshes(
    scene: &Scene,
    needs_uvs: &dyn Fn(usize) -> bool,
) -> Result<(), ShLightError> {
    for (i, o) in scene.objects.iter().enumerate() {
        let m = &o.mesh;
        let nv = m.positions.len();
        if m.normals.len() != nv {
            return Err(ShLightError::MissingNormals {
                object: i,
                normals: m.normals.len(),
                vertices: nv,
            });
        }
        if needs_uvs(i) && (m.uvs.len() != nv || m.tangents.len() != nv) {
            return Err(ShLightError::MissingUvs {
                object: i,
                uvs: m.uvs.len(),
                tangents: m.tangents.len(),
                vertices: nv,
            });
        }
    }
    Ok(())
}

/// The draws for a camera at `eye`: closed meshes seen from outside cull
/// their back faces (the same visibility buffer, about half the triangles).
fn draw_calls(draws: &[DrawData], eye: Vec3) -> Vec<DrawCall<'_>> {
    draws
        .iter()
        .enumerate()
        .map(|(i, d)| {
            DrawCall::new(&d.positions, &d.triangles)
                .with_object_id(i as u32)
                .with_cull(cull_for_closed(d.closed.as_ref(), eye))
        })
        .collect()
}

type Corners = (Vec<Vec3>, Vec<Vec3>, Vec<Vec4>, Vec<Vec2>, Vec<[u32; 3]>);

/// One vertex per triangle corner, tangent = the triangle's first edge.
fn unshare_corners(m: &relight_geom::Mesh) -> Corners {
    let nt = m.indices.len();
    let (mut p, mut n, mut t, mut uv) = (
        Vec::with_capacity(3 * nt),
        Vec::with_capacity(3 * nt),
        Vec::with_capacity(3 * nt),
        Vec::with_capacity(3 * nt),
    );
    let has_uv = m.uvs.len() == m.positions.len();
    for tri in &m.indices {
        let [a, b, c] = tri.map(|i| i as usize);
        let mut e = m.positions[b] - m.positions[a];
        if e.length_squared() == 0.0 {
            e = m.positions[c] - m.positions[a];
        }
        for v in [a, b, c] {
            p.push(m.positions[v]);
            n.push(m.normals[v]);
            t.push(
                e.normalize_or(m.normals[v].any_orthonormal_vector())
                    .extend(1.0),
            );
            uv.push(if has_uv { m.uvs[v] } else { Vec2::ZERO });
        }
    }
    let tris = (0..nt as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    (p, n, t, uv, tris)
}

/// Sign of `y_{l,m}` under `(x, y, z) → (x, −y, −z)` (rotation by π about x).
#[inline]
fn flip_sign(i: usize) -> f32 {
    let (l, m) = relight_sh::sh_lm(i);
    let e = (l as isize + m.abs()) & 1;
    let s = if e == 0 { 1.0 } else { -1.0 };
    if m < 0 { -s } else { s }
}

/// Fused multiply-adds of lighting one vertex at `order` bands
/// ([`Lit::relight_visible`]): its frame and Euler angles (≈ 40), then per
/// channel three Z rotations and the two fixed X matrices of the ZYZ plan
/// (`x_nonzeros` non-zeros each).
#[must_use]
pub(crate) fn vertex_fma(order: usize, x_nonzeros: usize) -> f64 {
    let n = order as f64;
    let z = 2.0 * n * n + 4.0 * n;
    40.0 + 3.0 * (3.0 * z + 2.0 * x_nonzeros as f64)
}

/// The rotation machinery of one (order, method).
pub(crate) struct Rotator {
    order: usize,
    method: ShRotationMethod,
    beta_lim: f32,
    exact: Option<IvanicRuedenberg<f32>>,
    zyz: Option<ZyzRotation<f32>>,
    taylor: Option<TaylorRotation<f32>>,
}

impl Rotator {
    fn new(order: usize, method: ShRotationMethod, beta_lim: f32) -> Result<Self, ShLightError> {
        Ok(Self {
            order,
            method,
            beta_lim,
            exact: (method == ShRotationMethod::Exact)
                .then(|| IvanicRuedenberg::new(order))
                .transpose()?,
            zyz: (method == ShRotationMethod::Zyz)
                .then(|| ZyzRotation::new(order))
                .transpose()?,
            taylor: method
                .taylor()
                .map(|k| TaylorRotation::new(order, k, beta_lim))
                .transpose()?,
        })
    }

    /// The Taylor plan of the Taylor methods.
    pub(crate) fn taylor(&self) -> Option<&TaylorRotation<f32>> {
        self.taylor.as_ref()
    }

    /// `dst_c = T src_c` for `channels` vectors (`order²` each, packed).
    #[inline]
    pub(crate) fn rotate(
        &self,
        t: Mat3,
        channels: usize,
        src: &[f32],
        dst: &mut [f32],
        scratch: &mut [f32],
        exact: &mut Option<ShRotation<f32>>,
    ) {
        let k = self.order * self.order;
        let rot = Rot3::from_mat3_unchecked(t);
        match self.method {
            ShRotationMethod::Exact => {
                let plan = self.exact.as_ref().expect("exact plan");
                if exact.as_ref().is_none_or(|r| r.order() != self.order) {
                    *exact = Some(ShRotation::identity(self.order).expect("order checked"));
                }
                let m = exact.as_mut().expect("set above");
                plan.build(&rot, m);
                for c in 0..channels {
                    m.apply(&src[c * k..(c + 1) * k], &mut dst[c * k..(c + 1) * k]);
                }
            }
            ShRotationMethod::Zyz => {
                let z = self.zyz.as_ref().expect("zyz plan");
                let e = rot.euler_zyz();
                for c in 0..channels {
                    z.apply_euler(
                        &e,
                        &src[c * k..(c + 1) * k],
                        &mut dst[c * k..(c + 1) * k],
                        scratch,
                    );
                }
            }
            ShRotationMethod::Taylor1 | ShRotationMethod::Taylor15 | ShRotationMethod::Taylor2 => {
                let tr = self.taylor.as_ref().expect("taylor plan");
                let e = rot.euler_zyz();
                for c in 0..channels {
                    tr.apply_euler(
                        &e,
                        &src[c * k..(c + 1) * k],
                        &mut dst[c * k..(c + 1) * k],
                        scratch,
                    );
                }
            }
            ShRotationMethod::None => dst[..channels * k].copy_from_slice(&src[..channels * k]),
        }
    }
}

impl Prepared {
    /// Step 3 at `order ≤ order_max` bands with `method`, `normal_map` on
    /// every object; box-filters the supersampled image down to the scene
    /// camera's size.
    pub(crate) fn shade(
        &self,
        scene: &Scene,
        order: usize,
        method: ShRotationMethod,
        normal_map: Option<&NormalMap>,
        beta_lim: f32,
        env_background: bool,
    ) -> Result<ShImage, ShLightError> {
        self.shade_with(
            scene,
            order,
            method,
            normal_map,
            beta_lim,
            env_background,
            false,
        )
    }

    /// [`Prepared::shade`]; `portable` forces the portable copy of the
    /// per-pixel pass (tests compare it with the AVX2 + FMA copy).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade_with(
        &self,
        scene: &Scene,
        order: usize,
        method: ShRotationMethod,
        normal_map: Option<&NormalMap>,
        beta_lim: f32,
        env_background: bool,
        portable: bool,
    ) -> Result<ShImage, ShLightError> {
        let maps = vec![normal_map; self.lit.draws.len()];
        let mut hi = Image::new(self.camera.width, self.camera.height);
        self.lit.shade_lit(
            &self.raster,
            &self.camera,
            scene,
            order,
            method,
            &maps,
            beta_lim,
            if env_background {
                Background::All
            } else {
                Background::Black
            },
            &mut hi,
            portable,
        )?;
        if self.k == 1 {
            let mask = self.raster.gbuffer().coverage_mask();
            return Ok(ShImage { image: hi, mask });
        }
        Ok(self.downsample(&hi))
    }

    fn downsample(&self, hi: &Image) -> ShImage {
        let k = self.k;
        let (w, h) = (hi.width / k, hi.height / k);
        let g = self.raster.gbuffer();
        let mut mask = vec![false; w * h];
        for y in 0..h {
            for x in 0..w {
                mask[y * w + x] =
                    (0..k * k).all(|s| g.is_covered((y * k + s / k) * hi.width + x * k + s % k));
            }
        }
        ShImage {
            image: hi.box_downsample(k),
            mask,
        }
    }
}

impl Lit {
    /// Pass 1 for `camera` (the raster's size, supersampling included).
    ///
    /// # Errors
    /// Rasterizer errors (image size, camera).
    pub(crate) fn rasterize(
        &self,
        camera: &Camera,
        raster: &mut Rasterizer,
    ) -> Result<(), ShLightError> {
        let calls = draw_calls(&self.draws, camera.eye);
        let opts = RasterOptions::default().fit_depth(camera, &calls);
        raster.rasterize(camera, &calls, &opts)?;
        Ok(())
    }

    /// Step 3 at `order ≤ order_max` bands with `method` into `out` (at the
    /// size `raster` was last rasterized at, for `camera`, from this
    /// geometry): object `i` shades with `normal_maps[i]` (`None`:
    /// unperturbed); empty samples get `background`.
    ///
    /// # Errors
    /// Order out of range, `normal_maps` not one per object, a raster of other
    /// geometry.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade_into(
        &mut self,
        raster: &Rasterizer,
        camera: &Camera,
        scene: &Scene,
        order: usize,
        method: ShRotationMethod,
        normal_maps: &[Option<&NormalMap>],
        beta_lim: f32,
        background: Background,
        out: &mut Image,
    ) -> Result<(), ShLightError> {
        self.check_raster(raster)?;
        self.last_relit = self.relight_visible(raster);
        self.shade_lit(
            raster,
            camera,
            scene,
            order,
            method,
            normal_maps,
            beta_lim,
            background,
            out,
            false,
        )
    }

    /// A raster of this geometry: every triangle id in range.
    fn check_raster(&self, raster: &Rasterizer) -> Result<(), ShLightError> {
        let g = raster.gbuffer();
        let ntri: usize = self.draws.iter().map(|d| d.triangles.len()).sum();
        if g.triangle
            .iter()
            .any(|&t| t != NO_TRIANGLE && t as usize >= ntri)
        {
            return Err(RasterError::DrawMismatch { draw: 0 }.into());
        }
        Ok(())
    }

    /// Lights every vertex from the last lighting (eager step 2).
    pub(crate) fn relight_all(&mut self) {
        for d in &self.draws {
            for s in &d.stamp {
                s.store(STAMP_NEEDED, Ordering::Relaxed);
            }
        }
        self.relight_needed();
    }

    /// Lights the vertices of every triangle the visibility buffer of
    /// `raster` shows whose lighting is stale (step 2, lazily); returns how
    /// many were lit. Rows are scanned in parallel, marking vertices
    /// [`STAMP_NEEDED`]; then the marked vertices are rotated in parallel.
    fn relight_visible(&mut self, raster: &Rasterizer) -> usize {
        if self.world_light.is_none() {
            return 0;
        }
        let g = raster.gbuffer();
        let offsets = triangle_offsets(&self.draws);
        let epoch = self.epoch;
        let draws = &self.draws;
        let w = g.width.max(1);
        g.triangle.par_chunks(w).for_each(|ids| {
            let mut last = NO_TRIANGLE;
            let mut d = 0usize;
            for &id in ids {
                if id == NO_TRIANGLE || id == last {
                    continue;
                }
                last = id;
                if !(id >= offsets[d] && id < offsets[d + 1]) {
                    d = offsets.partition_point(|&x| x <= id) - 1;
                }
                let draw = &draws[d];
                for v in draw.triangles[(id - offsets[d]) as usize] {
                    let st = &draw.stamp[v as usize];
                    if st.load(Ordering::Relaxed) != epoch {
                        st.store(STAMP_NEEDED, Ordering::Relaxed);
                    }
                }
            }
        });
        self.relight_needed()
    }

    /// Rotates the lighting into the frame of every vertex marked
    /// [`STAMP_NEEDED`] (exact ZYZ: three Z rotations and two fixed sparse X
    /// matrices per channel) and stamps it; returns how many. Vertices go
    /// in spans of [`RELIGHT_SPAN`] (the unit of the parallel split), whose
    /// marked ones are rotated [`RELIGHT_RUN`] at a time, three channel
    /// vectors each (full batches even where few are marked, as after a view
    /// change), by [`relight_sh::fast::rotate_shared_batch`] (eight vertices
    /// at a time, lanes across vertices, on a CPU with AVX2 and FMA: one set
    /// of angles per vertex for its three channels, the world lighting
    /// broadcast, not copied per vertex) up to its order, one by one by
    /// [`ZyzRotation::apply`] above it.
    fn relight_needed(&mut self) -> usize {
        let Some(light) = &self.world_light else {
            return 0;
        };
        let order = self.order_max;
        let nn = order * order;
        let zyz = &self.vertex_zyz;
        let epoch = self.epoch;
        let batched = order <= ROTATE_BATCH_MAX_ORDER;
        // The run's marked vertices, rotated together into `dst` (a span's
        // lighting) and stamped.
        let channels = [&light[0][..nn], &light[1][..nn], &light[2][..nn]];
        let flush = |run: &mut RelightRun, n: usize, dst: &mut [f32], stamps: &[AtomicU32]| {
            relight_sh::fast::rotate_shared_batch(
                order,
                &run.rots[..n],
                channels,
                &mut run.dst[..3 * n * nn],
            )
            .expect("order ≤ ROTATE_BATCH_MAX_ORDER and lengths sized by RelightRun");
            for (j, &i) in run.index[..n].iter().enumerate() {
                dst[i * 3 * nn..(i + 1) * 3 * nn]
                    .copy_from_slice(&run.dst[j * 3 * nn..(j + 1) * 3 * nn]);
                stamps[i].store(epoch, Ordering::Relaxed);
            }
        };
        let mut count = 0;
        for d in &mut self.draws {
            let (verts, stamp) = (&d.verts, &d.stamp);
            count += d
                .light
                .par_chunks_mut(3 * nn * RELIGHT_SPAN)
                .zip(
                    verts
                        .par_chunks(RELIGHT_SPAN)
                        .zip(stamp.par_chunks(RELIGHT_SPAN)),
                )
                .map_init(
                    || RelightRun::new(nn),
                    |run, (dst, (verts, stamps))| {
                        let (mut n, mut lit) = (0, 0);
                        for (i, (a, st)) in verts.iter().zip(stamps).enumerate() {
                            if st.load(Ordering::Relaxed) != STAMP_NEEDED {
                                continue;
                            }
                            lit += 1;
                            let f = Frame::from_normal_tangent(
                                Vec3::new(a[0], a[1], a[2]),
                                Vec3::new(a[3], a[4], a[5]),
                            );
                            // local_from_world: rows are the frame axes.
                            let rot = Rot3::new_unchecked([
                                f.x.to_array(),
                                f.y.to_array(),
                                f.z.to_array(),
                            ]);
                            if !batched {
                                let out = &mut dst[i * 3 * nn..(i + 1) * 3 * nn];
                                for (l, o) in light.iter().zip(out.chunks_exact_mut(nn)) {
                                    zyz.apply(&rot, l, o, &mut run.dst);
                                }
                                st.store(epoch, Ordering::Relaxed);
                                continue;
                            }
                            run.rots[n] = rot;
                            run.index[n] = i;
                            n += 1;
                            if n == RELIGHT_RUN {
                                flush(run, n, dst, stamps);
                                n = 0;
                            }
                        }
                        if n > 0 {
                            flush(run, n, dst, stamps);
                        }
                        lit
                    },
                )
                .sum::<usize>();
        }
        count
    }

    /// The rotation machinery of (order, method, β limit), kept from the
    /// last frame when it matches.
    fn rotator(
        &self,
        order: usize,
        method: ShRotationMethod,
        beta_lim: f32,
    ) -> Result<Arc<Rotator>, ShLightError> {
        let mut cached = self
            .rotator
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(r) = cached.as_ref()
            && r.order == order
            && r.method == method
            && r.beta_lim.to_bits() == beta_lim.to_bits()
        {
            return Ok(r.clone());
        }
        let r = Arc::new(Rotator::new(order, method, beta_lim)?);
        *cached = Some(r.clone());
        Ok(r)
    }

    /// [`Lit::shade_into`] of vertices already lit (every vertex the raster
    /// shows: after [`Lit::relight_all`] or [`Lit::relight_visible`]);
    /// `portable` forces the portable copy of the pass (tests).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade_lit(
        &self,
        raster: &Rasterizer,
        camera: &Camera,
        scene: &Scene,
        order: usize,
        method: ShRotationMethod,
        normal_maps: &[Option<&NormalMap>],
        beta_lim: f32,
        background: Background,
        out: &mut Image,
        portable: bool,
    ) -> Result<(), ShLightError> {
        if normal_maps.len() != self.draws.len() {
            return Err(ShLightError::InvalidParameter {
                what: "normal maps",
                why: format!(
                    "need one entry per object ({}), got {}",
                    self.draws.len(),
                    normal_maps.len()
                ),
            });
        }
        check_shading_order(order)?;
        if order > self.order_max {
            return Err(ShLightError::InvalidParameter {
                what: "order",
                why: format!("{order} exceeds the prepared order {}", self.order_max),
            });
        }
        let rotator = self.rotator(order, method, beta_lim)?;
        let k2 = order * order;
        let flip: Vec<f32> = (0..k2).map(flip_sign).collect();
        // Window factors per coefficient: the prepared ones at order_max, else
        // chosen for this order.
        let windows = self
            .tables
            .iter()
            .zip(&self.windows)
            .map(|(t, w)| {
                let h = if order == self.order_max {
                    w.factors.clone()
                } else {
                    choose_window(t, order, self.window)?.factors
                };
                Ok((0..k2)
                    .map(|i| h[relight_sh::sh_lm(i).0] as f32)
                    .collect::<Vec<f32>>())
            })
            .collect::<Result<Vec<_>, ShLightError>>()?;
        let pass = Pass {
            draws: &self.draws,
            tables: &self.tables,
            windows: &windows,
            normal_maps,
            order,
            nn_max: self.order_max * self.order_max,
            method,
            rotator: &rotator,
            flip: &flip,
        };
        let env = &scene.env;
        let bg = |d: Vec3| match &self.filtered_background {
            None => env.eval(self.env_from_world * d),
            Some((direct, sh)) => {
                let nn = self.order_max * self.order_max;
                let mut y = [0.0f32; MAX_SHADING_ORDER * MAX_SHADING_ORDER];
                relight_sh::basis::eval_sh_into(self.order_max, d.to_array(), &mut y[..nn]);
                let dot = |c: &[f32]| c.iter().zip(&y[..nn]).map(|(a, b)| a * b).sum::<f32>();
                // The band-limited filtered part may ring below zero.
                *direct * env.eval(self.env_from_world * d)
                    + Vec3::new(dot(&sh[0]), dot(&sh[1]), dot(&sh[2])).max(Vec3::ZERO)
            }
        };
        let bg_fn: &(dyn Fn(Vec3) -> Vec3 + Sync) = &bg;
        let bg = match background {
            Background::Black => Bg::Black,
            Background::All => Bg::All(bg_fn),
            Background::Partial(k) => Bg::Partial(k, bg_fn),
        };
        pass.run(raster, camera, bg, out, portable);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_brdf::{Ggx, Lambert};
    use relight_render::{NoProgress, Object};
    use relight_sphere::{EnvMap, Param};

    fn camera(eye: Vec3) -> Camera {
        Camera {
            eye,
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 45.0,
            width: 64,
            height: 48,
            image_offset: Vec2::ZERO,
        }
    }

    fn sky() -> EnvMap {
        let sun = Vec3::new(0.5, 0.7, 0.4).normalize();
        EnvMap::from_fn(
            Param::LatLong {
                width: 64,
                height: 32,
            },
            move |d| {
                let lobe = d.dot(sun).max(0.0).powi(8) * 6.0;
                Vec3::new(0.3 + lobe, 0.35 + 0.8 * lobe, 0.5 + 0.3 * d.y.max(0.0))
            },
        )
    }

    /// A bumpy GGX sphere and a plain Lambert one.
    fn scene() -> (Scene, NormalMap) {
        let nm = NormalMap::bumps(64, 6, 0.6);
        let a = Object::new(
            Arc::new(relight_geom::shapes::uv_sphere_at(
                Vec3::new(-0.6, 0.0, 0.0),
                0.55,
                32,
                16,
            )),
            Arc::new(Ggx::isotropic(0.3, Vec3::new(1.0, 0.8, 0.5)).unwrap()),
        );
        let b = Object::new(
            Arc::new(relight_geom::shapes::uv_sphere_at(
                Vec3::new(0.6, 0.0, 0.0),
                0.55,
                32,
                16,
            )),
            Arc::new(Lambert::new(Vec3::splat(0.7)).unwrap()),
        );
        (
            Scene::new(vec![a, b], sky(), camera(Vec3::new(0.0, 0.4, 3.2))),
            nm,
        )
    }

    /// The AVX2 + FMA copy of the per-pixel pass computes what the portable
    /// copy does (fused rounding only), for every rotation method.
    #[test]
    fn fma_pass_matches_the_portable_pass() {
        let (scene, nm) = scene();
        if !relight_isa::avx2() {
            // Under CI a portable-only CPU would compare the portable copy
            // with itself: fail rather than pass vacuously.
            assert!(
                std::env::var_os("CI").is_none(),
                "CI: no AVX2 + FMA on this CPU, so the fast copy is not tested"
            );
            eprintln!("no AVX2 + FMA on this CPU: both copies are the portable one");
        }
        // Orders 2, 3 and 6 end the dot product's 8-lane registers with 4,
        // 1 and 4 coefficients; the third object's table is not rank-1.
        let mut scene = scene;
        let mix = relight_brdf::Mix::new(vec![
            (
                0.5,
                Arc::new(Lambert::new(Vec3::new(0.2, 0.5, 0.9)).unwrap()) as _,
            ),
            (
                0.5,
                Arc::new(Ggx::isotropic(0.25, Vec3::new(0.9, 0.6, 0.3)).unwrap()) as _,
            ),
        ])
        .unwrap();
        let c = Object::new(
            Arc::new(relight_geom::shapes::uv_sphere_at(
                Vec3::new(0.0, -0.7, 0.0),
                0.4,
                24,
                12,
            )),
            Arc::new(mix),
        );
        scene.objects.push(c);
        for (order, method) in [2, 3, 6]
            .into_iter()
            .flat_map(|o| ShRotationMethod::ALL.map(|m| (o, m)))
        {
            let r = ShRenderer::new(order, method).unwrap();
            let p = r.prepare(&scene, Some(&nm), order, &NoProgress).unwrap();
            let shade = |portable| {
                p.shade_with(
                    &scene,
                    order,
                    method,
                    Some(&nm),
                    f32::INFINITY,
                    false,
                    portable,
                )
                .unwrap()
            };
            let (fast, slow) = (shade(false), shade(true));
            let mut lit = 0;
            for (i, (a, b)) in fast.image.pixels.iter().zip(&slow.image.pixels).enumerate() {
                let tol = 1e-4 * b.abs().max_element().max(1.0);
                assert!(
                    (*a - *b).abs().max_element() <= tol,
                    "order {order} {method}: pixel {i}: {a} vs {b}"
                );
                lit += usize::from(b.max_element() > 0.0);
            }
            assert!(lit > 500, "order {order} {method}: only {lit} lit pixels");
        }
    }

    /// Lighting only the vertices a frame sees, after a lighting change and
    /// a view change, gives the image of lighting every vertex (bit for bit:
    /// a stale vertex would hold the old lighting), and lights fewer.
    /// Every vertex's lighting from [`Lit::relight_all`] (batched up to
    /// [`ROTATE_BATCH_MAX_ORDER`], one by one above) equals the per-vertex
    /// ZYZ rotation through Euler angles, the path it replaced, to rounding.
    #[test]
    fn vertex_lighting_matches_the_per_vertex_rotation() {
        let (scene, _) = scene();
        for order in [3, ROTATE_BATCH_MAX_ORDER, ROTATE_BATCH_MAX_ORDER + 2] {
            let mut r = ShRenderer::new(order, ShRotationMethod::Zyz).unwrap();
            let mut lit = r.build(&scene, order, &|_| true, &NoProgress).unwrap();
            let light = project_env(&scene.env, order, Window::None).unwrap();
            r.set_lighting_rotation(Mat3::from_rotation_y(0.4)).unwrap();
            r.light(&mut lit, &light, &NoProgress).unwrap();
            lit.relight_all();
            let world = lit.world_light.clone().unwrap();
            let nn = order * order;
            let zyz = ZyzRotation::<f32>::new(order).unwrap();
            let (mut want, mut tmp) = (vec![0.0f32; nn], vec![0.0f32; nn]);
            let mut worst = 0.0f32;
            let mut checked = 0;
            for d in &lit.draws {
                for (v, a) in d.verts.iter().enumerate() {
                    let f = Frame::from_normal_tangent(
                        Vec3::new(a[0], a[1], a[2]),
                        Vec3::new(a[3], a[4], a[5]),
                    );
                    let e = Rot3::new_unchecked([f.x.to_array(), f.y.to_array(), f.z.to_array()])
                        .euler_zyz();
                    for (c, l) in world.iter().enumerate() {
                        zyz.apply_euler(&e, l, &mut want, &mut tmp);
                        let got = &d.light[v * 3 * nn + c * nn..v * 3 * nn + (c + 1) * nn];
                        let scale = want.iter().fold(1e-3f32, |m, x| m.max(x.abs()));
                        for (g, w) in got.iter().zip(&want) {
                            worst = worst.max((g - w).abs() / scale);
                        }
                    }
                    checked += 1;
                }
            }
            assert!(checked > 1000, "order {order}: {checked} vertices");
            assert!(
                worst < 2e-5,
                "order {order}: worst relative difference {worst:e}"
            );
        }
    }

    #[test]
    fn lazy_vertex_lighting_equals_eager() {
        let (scene, nm) = scene();
        let maps = [Some(&nm), None];
        let mut r = ShRenderer::new(6, ShRotationMethod::Zyz).unwrap();
        let mut lit = r.build(&scene, 6, &|_| true, &NoProgress).unwrap();
        let light = project_env(&scene.env, 6, Window::None).unwrap();
        r.light(&mut lit, &light, &NoProgress).unwrap();
        let mut raster = Rasterizer::new();
        let mut img = Image::new(1, 1);
        let cam_a = camera(Vec3::new(0.0, 0.4, 3.2));
        let shade = |lit: &mut Lit, raster: &mut Rasterizer, cam: &Camera, img: &mut Image| {
            lit.rasterize(cam, raster).unwrap();
            lit.shade_into(
                raster,
                cam,
                &scene,
                6,
                ShRotationMethod::Zyz,
                &maps,
                f32::INFINITY,
                Background::Black,
                img,
            )
            .unwrap();
        };
        shade(&mut lit, &mut raster, &cam_a, &mut img);
        let total: usize = lit.draws.iter().map(|d| d.positions.len()).sum();
        assert!(
            lit.last_relit > 0 && lit.last_relit < total,
            "{} of {total}",
            lit.last_relit
        );
        // A lighting change, then a view from the side (other vertices).
        r.set_lighting_rotation(Mat3::from_rotation_y(0.7)).unwrap();
        r.light(&mut lit, &light, &NoProgress).unwrap();
        let cam_b = camera(Vec3::new(2.4, 1.0, 2.0));
        shade(&mut lit, &mut raster, &cam_b, &mut img);
        assert!(lit.last_relit > 0 && lit.last_relit < total);
        // The same view again lights nothing.
        let lazy = img.clone();
        shade(&mut lit, &mut raster, &cam_b, &mut img);
        assert_eq!(lit.last_relit, 0);
        assert_eq!(img.pixels, lazy.pixels);
        lit.relight_all();
        let mut eager = Image::new(1, 1);
        lit.shade_lit(
            &raster,
            &cam_b,
            &scene,
            6,
            ShRotationMethod::Zyz,
            &maps,
            f32::INFINITY,
            Background::Black,
            &mut eager,
            false,
        )
        .unwrap();
        assert_eq!(lazy.pixels, eager.pixels);
    }

    /// The draws cull the back faces of the closed spheres from outside
    /// (fewer triangles binned) and give the visibility buffer of drawing
    /// both sides; from inside a sphere's bounds they cull nothing.
    #[test]
    fn closed_meshes_culled_from_outside_keep_the_visibility_buffer() {
        let (scene, nm) = scene();
        let r = ShRenderer::new(3, ShRotationMethod::Zyz).unwrap();
        let p = r.prepare(&scene, Some(&nm), 3, &NoProgress).unwrap();
        let draws = &p.lit.draws;
        assert!(
            draws.iter().all(|d| d.closed.is_some()),
            "both spheres are closed"
        );
        let inside = Vec3::new(-0.6, 0.0, 0.2);
        for eye in [Vec3::new(0.0, 0.4, 3.2), Vec3::new(2.5, -1.0, 0.5), inside] {
            let cam = Camera {
                width: 160,
                height: 120,
                ..camera(eye)
            };
            let culled = draw_calls(draws, eye);
            let both: Vec<DrawCall> = culled
                .iter()
                .map(|d| d.with_cull(relight_render::raster::CullMode::None))
                .collect();
            let opts = RasterOptions::default().fit_depth(&cam, &both);
            let (mut a, mut b) = (Rasterizer::new(), Rasterizer::new());
            let sa = a.rasterize(&cam, &culled, &opts).unwrap();
            let sb = b.rasterize(&cam, &both, &opts).unwrap();
            let cull = |d: &DrawCall| d.cull == Some(relight_render::raster::CullMode::Back);
            if eye == inside {
                // Inside the first sphere's bounds: its back faces are what shows.
                assert!(!cull(&culled[0]) && cull(&culled[1]));
            } else {
                assert!(culled.iter().all(cull));
                assert!(
                    sa.binned * 10 < sb.binned * 7,
                    "{} vs {}",
                    sa.binned,
                    sb.binned
                );
            }
            let (ga, gb) = (a.gbuffer(), b.gbuffer());
            assert!(gb.covered_pixels() > 2000, "{}", gb.covered_pixels());
            assert_eq!(ga.triangle, gb.triangle, "eye {eye}");
            assert_eq!(ga.barycentrics, gb.barycentrics, "eye {eye}");
        }
    }

    /// The per-vertex lighting rotation (ZYZ from the frame's Euler angles)
    /// equals the Ivanic–Ruedenberg matrix of the same frame.
    #[test]
    fn vertex_frame_rotation_zyz_equals_ivanic_ruedenberg() {
        let order = 6;
        let nn = order * order;
        let src: Vec<f32> = (0..nn).map(|i| ((i * 7 + 3) % 11) as f32 - 5.0).collect();
        let plan = IvanicRuedenberg::<f32>::new(order).unwrap();
        let zyz = ZyzRotation::<f32>::new(order).unwrap();
        let mut m = ShRotation::<f32>::identity(order).unwrap();
        let (mut a, mut b, mut tmp) = (vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]);
        for k in 0..50 {
            let t = k as f32 * 0.37;
            let n = Vec3::new(
                t.sin() * (2.0 * t).cos(),
                t.cos(),
                t.sin() * (2.0 * t).sin(),
            )
            .normalize();
            let f = Frame::from_normal_tangent(n, Vec3::new(1.0, 0.2 * t, -0.3));
            let r = Rot3::new_unchecked([f.x.to_array(), f.y.to_array(), f.z.to_array()]);
            plan.build(&r, &mut m);
            m.apply(&src, &mut a);
            zyz.apply_euler(&r.euler_zyz(), &src, &mut b, &mut tmp);
            for i in 0..nn {
                assert!(
                    (a[i] - b[i]).abs() < 1e-4,
                    "frame {k} coefficient {i}: {} vs {}",
                    a[i],
                    b[i]
                );
            }
        }
    }
}
