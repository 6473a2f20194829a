//! [`NearfieldMethod`]: near-field area-light relighting behind the method
//! interface ([`Relighter`], name `nearfield`).
//!
//! # What it renders
//! Textured rectangular area lights ([`relight_render::AreaLight`], one or
//! more) on any BRDF, with or without shadows, per vertex (Gouraud). A Lambertian
//! object (or a blend of two Lambertian BRDFs) is baked as `cos V` and
//! shaded with its albedo; every other BRDF — glossy, coloured, measured,
//! a blend by a texture — gets the thesis' fixed-view transport
//! ([`crate::specular`]): the BRDF at the view from the scene camera's eye
//! to the vertex folded into the transport (Fig. 4.9, "specular materials
//! with precomputation done per vertex"), RGB where the BRDF's colour
//! changes with direction. Environment, point lights, media and normal
//! maps are refused; a lobe narrower than a face cell is shaded at the
//! cell's width, with a warning.
//!
//! # Several lights
//! The transport lives on a face aligned with a light's plane (eq. 4.34),
//! and its shadow rays end at that plane, so lights in one plane share one
//! transport per object, and each plane gets its own bake (and cache
//! file). Two lights share a plane when their normals agree
//! ([`crate::rotate::AXIS_TOLERANCE`]) and so do their offsets along it;
//! the plane's first light sets its axes and the others are turned in it
//! (their bounding rectangles, below). Each light is propagated on its
//! own — its own source terms (the fraction is per light), affine map and
//! target mask — and the vertex sums the lights' dot products, so the work
//! per frame is the one-light work times the number of lights, and the
//! result is exactly the sum of the lights' (`tests/it/lights.rs`).
//! Editing a light keeps every bake unless the number of lights changes or
//! a light's normal leaves its plane's (then all planes are baked again,
//! from the cache where they match).
//!
//! # The fixed view and the camera
//! The fixed-view transport is for the eye it was baked with (the scene's
//! camera at `prepare`; the cache key holds it). A later `set_lighting` or
//! `prepare` with the scene's camera at another eye re-bakes the fixed-view
//! objects only (the Lambertian transports are kept) and reports the
//! cost in [`Relighter::warnings`]. A frame rendered from another camera
//! (the viewer's orbit: `render` with `request.camera`) keeps the bake and
//! shows the baked view's highlights; the warnings say so from `prepare`
//! on (the viewer shows them on screen), and [`NearfieldMethod::view_is_baked`]
//! tells whether the last frame's eye was the baked one.
//!
//! | call | work |
//! |---|---|
//! | [`Relighter::prepare`] | the per-vertex transport on each light plane's face ([`crate::transport`]), shadows ray-cast when the scene has visibility, or loaded from the disk cache ([`crate::cache`], with [`NearfieldOptions::cache_dir`]); then `set_lighting` |
//! | [`Relighter::set_lighting`] | per light, moved, scaled or turned in its plane (or moved to another height): the light frame the vertices are mapped through; always: the light's coefficients (a turned light re-rasterised into its bounding rectangle, [`crate::rotate`]), source compression, and for all lights the fused propagation per vertex (affine map, ACC rows, target mask and dot product, [`crate::propagate`]: a move costs what a texture edit costs). A light whose normal changed, or another number of lights, re-bakes the transports. |
//! | [`Relighter::render`] | rasterize and interpolate the vertex colours |
//!
//! Moving along the normal keeps the baked shadows, cast towards the old
//! plane. A turn in the plane (thesis §4.5.6) is not affine in Haar
//! (§4.4): the light is re-rasterised into the rectangle along the baked
//! axes that bounds it, zero outside the turned rectangle, and shaded as
//! that unturned light; a turn of exactly 0° is the unturned path.

use crate::cache::{BakeKey, CacheError};
use crate::face::{FACE_CLIPPING_WARNING, LightFrame, face_clipping};
use crate::light::{LightCoeffs, Ranking, SourceTerms, compress, count_of};
use crate::light_field::{FieldScratch, FieldSource, shade_vertex_field};
use crate::propagate::{
    Kernel, Primitives, VertexMap, VertexScratch, prefetch, prefetches_mask, shade_fma,
    shade_rgb_fma, shade_vertex,
};
use crate::rotate::InPlane;
use crate::specular::{
    ObjectBrdf, ObjectKind, SpecularMesh, bake_specular, blend_weights, object_kind,
};
use crate::transport::{Transport, bake_transport};
use glam::Vec3;
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_render::method::{
    FrameRequest, FrameWork, MethodError, ObjectRaster, Relighter, Rendered, SceneFeature, Support,
    check_scene,
};
use relight_render::raster::Background;
use relight_render::{AreaLight, Image, Numbered, Progress, Scene, SceneBvh};
use relight_wavelet::CacheUse;
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// The method's name on the command line.
pub const NEARFIELD_METHOD_NAME: &str = "nearfield";

/// Settings of [`NearfieldMethod`]; `Default` holds the defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct NearfieldOptions {
    /// Wavelet order `n` per axis of the face (the transport) and of the
    /// light's coefficients (a power of two, 4…64). Default 32 (the
    /// thesis' order).
    pub order: usize,
    /// Order the light is box-averaged at, when coarser than `order`
    /// (`None`: `order`). A light at order `n_L < n` is exact in the
    /// order-`n` basis (its finer details are zero), so this runs the
    /// transport at `n` for a light of order `n_L`: it shrinks the
    /// discretisation error `∫ (L − P L)(T − P T)` at the cost of the
    /// order-`n` transport (`docs/nearfield.md`). Default `None`.
    pub light_order: Option<usize>,
    /// Side of the expanded top face at unit distance (2 = a cube map's top
    /// face; the thesis uses 3–4). Default 4.
    pub face: f64,
    /// Fraction of the light's `n²` coefficients kept (source level). Default 0.01.
    pub source_terms: f64,
    /// How the source terms are ranked ([`crate::light`]'s module docs).
    /// Default [`Ranking::AreaWeighted`].
    pub source_ranking: Ranking,
    /// Fraction of each vertex's `n²` target coefficients kept by the
    /// constant-light heuristic (eq. 4.38). Default 0.20.
    pub target_terms: f64,
    /// Folder to keep transport bakes in and load them from on a match
    /// ([`crate::cache`]; `None`: no disk cache). Default `None` (the
    /// library touches no disk unless asked; the CLI sets `--cache`, else
    /// [`crate::cache::default_cache_dir`], `$RELIGHT_CACHE/nearfield`, …).
    pub cache_dir: Option<PathBuf>,
    /// Shade objects too coarse for per-vertex shading (a ground quad) on
    /// a refined copy ([`Scene::with_coarse_objects_refined`], with a
    /// warning); off: warn only. Default on.
    pub refine_coarse: bool,
}

impl Default for NearfieldOptions {
    fn default() -> Self {
        Self {
            order: 32,
            light_order: None,
            face: 4.0,
            source_terms: 0.01,
            source_ranking: Ranking::AreaWeighted,
            target_terms: 0.20,
            cache_dir: None,
            refine_coarse: true,
        }
    }
}

/// One object's data, the same for every light.
struct Prepared {
    /// The mesh shaded: the scene's, or a coarse object's refined copy
    /// ([`Scene::with_coarse_objects_refined`]).
    mesh: Arc<Mesh>,
    /// The scene's mesh, which later calls must still have.
    source: Arc<Mesh>,
    /// How it is shaded ([`crate::specular::object_kind`]).
    kind: ObjectKind,
    /// The factor × π of the transport dot product: the albedo (Lambertian;
    /// a blend's first albedo), π · tint (one-channel fixed view) or π (RGB).
    albedo: Vec3,
    /// Per vertex, a Lambertian blend's albedo (else empty).
    albedos: Vec<Vec3>,
}

/// The transports baked for one plane of lights (module docs, "Several
/// lights"): the face and the shadow rays are the plane's, so every light
/// in it shares them.
struct PlaneBake {
    /// The frame the transports were baked for: the plane's first light's.
    frame: LightFrame,
    /// The bake's cache key.
    key: BakeKey,
    /// One per object.
    transports: Vec<Transport>,
}

/// One scene light as the propagation sees it.
#[derive(Clone, Debug, Default)]
struct LitLight {
    /// Index of its plane in `NearfieldMethod::planes`.
    plane: usize,
    /// The frame vertices are mapped through (the light's own, or a
    /// turned light's bounding rectangle); `None`: not set yet (black).
    frame: Option<LightFrame>,
    source: SourceTerms,
    /// A light field's coefficients (eq. 4.37, [`crate::light_field`]),
    /// which replace `source` for this light.
    field: Option<FieldSource>,
}

/// Offset along the normal (scene units, relative to `1 + |c|`) within
/// which two lights of one normal lie in one plane.
const PLANE_TOLERANCE: f32 = 1e-5;

/// For each of `lights`, the index of its plane (in order of first
/// appearance). Two lights share a plane when the second is the first
/// turned in the first's plane ([`InPlane::of`]: the same normal) and
/// their centres' offsets along it agree within [`PLANE_TOLERANCE`].
fn planes_of(lights: &[AreaLight]) -> Vec<usize> {
    let mut leaders: Vec<usize> = Vec::new();
    let mut out = Vec::with_capacity(lights.len());
    for (i, l) in lights.iter().enumerate() {
        let same = |j: usize| {
            let a = &lights[j];
            let n = a.normal();
            let scale = 1.0 + a.center.length().max(l.center.length());
            (a.world_from_light == l.world_from_light
                || InPlane::of(&a.world_from_light, l).is_some())
                && (l.center - a.center).dot(n).abs() <= PLANE_TOLERANCE * scale
        };
        match leaders.iter().position(|&j| same(j)) {
            Some(p) => out.push(p),
            None => {
                out.push(leaders.len());
                leaders.push(i);
            }
        }
    }
    out
}

/// Near-field relighting as a [`Relighter`] (module docs).
pub struct NearfieldMethod {
    options: NearfieldOptions,
    objects: Vec<Prepared>,
    /// The transports per plane of lights (empty: nothing baked).
    planes: Vec<PlaneBake>,
    /// Whether the planes were baked with visibility.
    baked_visibility: bool,
    /// Per scene light (at least one entry: the single-light calls
    /// [`Self::set_light_frame`], [`Self::update_source`] and
    /// [`Self::source`] address the first).
    lights: Vec<LitLight>,
    colors: Vec<Vec<Vec3>>,
    /// The bake's warnings.
    warnings: Vec<String>,
    /// The lighting's warnings ([`face_clipping_warnings`]), worked out
    /// when first asked for after each lighting change, so that a change
    /// (a light drag, a bench's move) costs only the propagation.
    lighting_warnings: std::sync::OnceLock<Vec<String>>,
    /// The visibility buffer, kept while the camera and meshes are (a
    /// lighting change shades it again).
    view: ObjectRaster,
    pending_lighting_ms: f64,
    /// Times of the last lighting change: coefficients, propagation (ms).
    pub last_times: [f64; 2],
    bakes: usize,
    loads: usize,
    /// The camera's eye the fixed-view transports were baked for (`None`:
    /// no fixed-view object).
    baked_eye: Option<Vec3>,
    /// The last frame's eye was the baked one (or nothing is fixed-view).
    view_is_baked: bool,
    /// Seconds of the last fixed-view bake (0 when loaded or none).
    pub specular_bake_s: f64,
}

impl std::fmt::Debug for NearfieldMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NearfieldMethod")
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

fn invalid(option: &'static str, message: impl ToString) -> MethodError {
    MethodError::InvalidOption {
        method: NEARFIELD_METHOD_NAME,
        option,
        message: message.to_string(),
    }
}

/// The area lights of `scene` (at least one).
fn the_lights(scene: &Scene) -> Result<&[AreaLight], MethodError> {
    match scene.area_lights.as_slice() {
        [] => Err(invalid("scene", "needs an [[area_light]] (it has none)")),
        ls => Ok(ls),
    }
}

/// Light `index` can be relit: a light field cannot be turned in its
/// baked plane (the turn would turn its directions too, which the
/// re-rasterised bounding rectangle of [`crate::rotate`] does not do). Its
/// view count is checked where its coefficients are made
/// ([`FieldSource::of`]).
fn check_light_field(index: usize, light: &AreaLight, turned: bool) -> Result<(), MethodError> {
    if light.light_field.is_none() {
        return Ok(());
    }
    if turned {
        return Err(invalid(
            "scene",
            format!(
                "{}: a light field turned in the plane whose transport it uses (against that plane's first light, or since the bake), which would turn its directions too; give it that light's orientation, or prepare again for it alone in its plane",
                Numbered::area_light(index)
            ),
        ));
    }
    Ok(())
}

/// One warning per light that drops, past the face of some vertex in front
/// of it, more than [`FACE_CLIPPING_WARNING`] of what its brightest vertex
/// gets ([`face_clipping`], untextured): the thesis' expanded top face
/// drops that light, and a larger face keeps it. Far, grazing vertices
/// that lose much of a little light do not count.
fn face_clipping_warnings(
    objects: &[Prepared],
    frames: impl Iterator<Item = Option<LightFrame>>,
    face: f64,
) -> Vec<String> {
    let mut out = Vec::new();
    for (i, frame) in frames.enumerate() {
        let Some(frame) = frame else {
            continue;
        };
        let per: Vec<(f64, f64)> = objects
            .iter()
            .flat_map(|o| {
                o.mesh
                    .positions
                    .par_iter()
                    .filter_map(|p| frame.affine(frame.local(*p), face))
                    .map(|(s, o)| face_clipping(s, o, face))
                    .collect::<Vec<_>>()
            })
            .collect();
        let peak = per.iter().map(|p| p.0).fold(0.0, f64::max);
        let dropped: Vec<f64> = per
            .iter()
            .map(|&(all, kept)| (all - kept) / peak)
            .filter(|&d| d > FACE_CLIPPING_WARNING)
            .collect();
        if let Some(worst) = dropped.iter().copied().reduce(f64::max) {
            out.push(format!(
                "method nearfield: {} falls past the face (side {face}) of {} of the {} vertices in front of it, dropping up to {:.0} % of the light its brightest vertex gets (§4.5.4); a larger --face keeps it, with coarser cells",
                Numbered::area_light(i),
                dropped.len(),
                per.len(),
                worst * 100.0
            ));
        }
    }
    out
}

/// The file [`NearfieldMethod::save_bakes`] writes for plane `index` (from
/// 0) of a bake with several planes: `.plane{index + 1}` before `path`'s
/// extension (`out.bake` → `out.plane2.bake`; `out` → `out.plane2`).
#[must_use]
pub fn plane_bake_path(path: &Path, index: usize) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(Default::default, |s| s.to_os_string());
    let mut name = stem;
    name.push(format!(".plane{}", index + 1));
    if let Some(ext) = path.extension() {
        name.push(".");
        name.push(ext);
    }
    path.with_file_name(name)
}

impl NearfieldMethod {
    /// How each of `scene`'s lights maps onto the baked planes: per light,
    /// its plane and its in-plane turn from the plane's axes, if any (a
    /// light turned in its baked plane, or moved in it or along its
    /// normal, keeps the bake: module docs). `None` when the transports
    /// must be baked again: nothing baked, other objects or visibility,
    /// another number of lights, or a light whose normal changed.
    fn lighting_plan(&self, scene: &Scene) -> Option<Vec<(usize, Option<InPlane>)>> {
        let same_objects =
            relight_render::method::same_meshes(self.objects.iter().map(|p| &p.source), scene);
        if self.planes.is_empty()
            || !same_objects
            || self.baked_visibility != scene.visibility
            || self.lights.len() != scene.area_lights.len()
        {
            return None;
        }
        scene
            .area_lights
            .iter()
            .zip(&self.lights)
            .map(|(light, lit)| {
                let axes = &self.planes[lit.plane].frame.axes;
                if *axes == light.world_from_light {
                    Some((lit.plane, None))
                } else {
                    InPlane::of(axes, light).map(|t| (lit.plane, Some(t)))
                }
            })
            .collect()
    }

    /// A method with `options` (checked here).
    ///
    /// # Errors
    /// [`MethodError::InvalidOption`] naming the option.
    pub fn new(options: NearfieldOptions) -> Result<Self, MethodError> {
        let o = &options;
        if !(o.order.is_power_of_two() && (4..=64).contains(&o.order)) {
            return Err(invalid(
                "order",
                format!("must be a power of two in 4…64, got {}", o.order),
            ));
        }
        if let Some(l) = o.light_order
            && !(l.is_power_of_two() && (4..=o.order).contains(&l))
        {
            return Err(invalid(
                "light-order",
                format!("must be a power of two in 4…order ({}), got {l}", o.order),
            ));
        }
        if !(o.face.is_finite() && (0.5..=32.0).contains(&o.face)) {
            return Err(invalid("face", format!("must be 0.5…32, got {}", o.face)));
        }
        for (name, v) in [
            ("source-terms", o.source_terms),
            ("target-terms", o.target_terms),
        ] {
            if !(v > 0.0 && v <= 1.0) {
                return Err(invalid(
                    name,
                    format!("must be a fraction in (0, 1], got {v}"),
                ));
            }
        }
        Ok(Self {
            options,
            objects: Vec::new(),
            planes: Vec::new(),
            baked_visibility: false,
            lights: vec![LitLight::default()],
            colors: Vec::new(),
            warnings: Vec::new(),
            lighting_warnings: std::sync::OnceLock::new(),
            view: ObjectRaster::new(),
            pending_lighting_ms: 0.0,
            last_times: [0.0; 2],
            bakes: 0,
            loads: 0,
            baked_eye: None,
            view_is_baked: true,
            specular_bake_s: 0.0,
        })
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &NearfieldOptions {
        &self.options
    }

    /// Transport bakes computed so far (loads from the cache not counted).
    #[must_use]
    pub fn bakes(&self) -> usize {
        self.bakes
    }

    /// Transport bakes loaded from the disk cache so far.
    #[must_use]
    pub fn loads(&self) -> usize {
        self.loads
    }

    /// The folder transport bakes are cached in, if any.
    #[must_use]
    pub fn cache_dir(&self) -> Option<&Path> {
        self.options.cache_dir.as_deref()
    }

    /// The number of light planes baked (one transport per plane and
    /// object; module docs, "Several lights").
    #[must_use]
    pub fn planes(&self) -> usize {
        self.planes.len()
    }

    /// The key of the current bake of the first light's plane (after
    /// `prepare` or [`Self::bake_scene`]).
    #[must_use]
    pub fn bake_key(&self) -> Option<&BakeKey> {
        self.planes.first().map(|p| &p.key)
    }

    /// The cache file of the first light's plane's bake, when caching.
    #[must_use]
    pub fn cache_path(&self) -> Option<PathBuf> {
        self.cache_paths().into_iter().next()
    }

    /// The cache file of each plane's bake, when caching (else empty).
    #[must_use]
    pub fn cache_paths(&self) -> Vec<PathBuf> {
        let Some(dir) = self.options.cache_dir.as_ref() else {
            return Vec::new();
        };
        self.planes
            .iter()
            .map(|p| dir.join(p.key.file_name()))
            .collect()
    }

    /// Bakes (or loads from the cache) `scene`'s transport only: what
    /// `relight bake nearfield` runs.
    ///
    /// # Errors
    /// As [`Relighter::prepare`].
    pub fn bake_scene(
        &mut self,
        scene: &Scene,
        progress: &dyn Progress,
    ) -> Result<(), MethodError> {
        check_scene(self, scene, false)?;
        self.bake(scene, progress)
    }

    /// Writes the current bake in the cache's format ([`crate::cache`]),
    /// one file per light plane (a file holds one plane's transports):
    /// `path` itself for one plane; for several, [`plane_bake_path`] of
    /// each (`out.bake` → `out.plane1.bake`, `out.plane2.bake`, …, in the
    /// order of the planes' first lights). Returns the files written.
    ///
    /// # Errors
    /// [`CacheError`] when nothing is baked, or a file cannot be written.
    pub fn save_bakes(&self, path: &Path) -> Result<Vec<PathBuf>, CacheError> {
        if self.planes.is_empty() {
            return Err(CacheError::Mismatch {
                path: path.to_path_buf(),
                why: "nothing baked yet".into(),
            });
        }
        let several = self.planes.len() > 1;
        self.planes
            .iter()
            .enumerate()
            .map(|(i, plane)| {
                let out = if several {
                    plane_bake_path(path, i)
                } else {
                    path.to_path_buf()
                };
                let t: Vec<&Transport> = plane.transports.iter().collect();
                crate::cache::save(&out, &plane.key, &t).map(|()| out)
            })
            .collect()
    }

    /// Each object's baked transport for the first light's plane.
    #[must_use]
    pub fn transports(&self) -> Vec<&Transport> {
        self.planes
            .first()
            .map(|p| p.transports.iter().collect())
            .unwrap_or_default()
    }

    /// Each object's albedo as shaded: the colour is `B ⊙ albedo / π` for
    /// the transport dot product `B`. Lambertian objects: the albedo (a
    /// Lambertian blend: its first BRDF's; the blend is per vertex);
    /// fixed-view objects: π · tint (one channel) or π (RGB), the BRDF
    /// being in the transport.
    #[must_use]
    pub fn albedos(&self) -> Vec<Vec3> {
        self.objects.iter().map(|p| p.albedo).collect()
    }

    /// How each object is shaded.
    #[must_use]
    pub fn kinds(&self) -> Vec<ObjectKind> {
        self.objects.iter().map(|p| p.kind).collect()
    }

    /// The eye the fixed-view transports were baked for (`None`: no
    /// fixed-view object).
    #[must_use]
    pub fn baked_eye(&self) -> Option<Vec3> {
        self.baked_eye
    }

    /// Whether the last frame was rendered from the baked eye (always true
    /// without fixed-view objects): false means its highlights are the
    /// baked view's (module docs).
    #[must_use]
    pub fn view_is_baked(&self) -> bool {
        self.view_is_baked
    }

    /// The per-vertex colours of the last lighting change, per vertex of
    /// [`NearfieldMethod::shaded_meshes`].
    #[must_use]
    pub fn vertex_colors(&self) -> &[Vec<Vec3>] {
        &self.colors
    }

    /// The meshes shaded, one per object: the scene's, or a coarse
    /// object's refined copy ([`Scene::with_coarse_objects_refined`]).
    #[must_use]
    pub fn shaded_meshes(&self) -> Vec<&Arc<Mesh>> {
        self.objects.iter().map(|p| &p.mesh).collect()
    }

    /// Replaces the per-vertex colours the next `render` draws (verify
    /// renders quadrature colours through the same raster path); returns the
    /// old ones.
    pub fn replace_colors(&mut self, colors: Vec<Vec<Vec3>>) -> Vec<Vec<Vec3>> {
        std::mem::replace(&mut self.colors, colors)
    }

    /// Target terms per vertex.
    #[must_use]
    pub fn target_count(&self) -> usize {
        count_of(self.options.target_terms, self.options.order)
    }

    /// The first light's source terms of the last lighting change.
    #[must_use]
    pub fn source(&self) -> &SourceTerms {
        &self.lights[0].source
    }

    /// The angular slices light `index`'s field keeps (0 without a field,
    /// [`crate::light_field`]).
    #[must_use]
    pub fn field_slices(&self, index: usize) -> usize {
        self.lights
            .get(index)
            .and_then(|l| l.field.as_ref())
            .map_or(0, |f| f.terms.len())
    }

    /// Changes the compression (takes effect at the next `set_lighting`).
    pub fn set_compression(&mut self, source_terms: f64, target_terms: f64) {
        self.options.source_terms = source_terms;
        self.options.target_terms = target_terms;
    }

    /// Changes the source ranking (takes effect at the next `set_lighting`).
    pub fn set_source_ranking(&mut self, ranking: Ranking) {
        self.options.source_ranking = ranking;
    }

    fn bake(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        self.bake_with(scene, progress, false)
    }

    /// The bake of `scene`, one per plane of its lights;
    /// `keep_lambertian`: a plane baked before for the same light frame
    /// (the same meshes) keeps its Lambertian transports and only the
    /// fixed-view ones are baked again (a camera change).
    fn bake_with(
        &mut self,
        given: &Scene,
        progress: &dyn Progress,
        keep_lambertian: bool,
    ) -> Result<(), MethodError> {
        // Per-vertex (Gouraud) shading on a ground quad would show neither
        // the light's pool nor the shadows: such objects are shaded on a
        // refined copy, and said; one the vertex cap leaves coarse is warned
        // about as it is.
        let (refined_scene, refined, still) = if self.options.refine_coarse {
            given.with_coarse_objects_refined()
        } else {
            (Cow::Borrowed(given), Vec::new(), given.coarse_objects())
        };
        let scene = &refined_scene;
        let lights = the_lights(scene)?;
        let plane_of = planes_of(lights);
        let mut frames: Vec<LightFrame> = Vec::new();
        for (l, &p) in lights.iter().zip(&plane_of) {
            if p == frames.len() {
                frames.push(LightFrame::of(l));
            }
        }
        let meshes: Vec<&Mesh> = scene.objects.iter().map(|o| o.mesh.as_ref()).collect();
        let (n, face) = (self.options.order, self.options.face);
        self.warnings.clear();
        for r in &refined {
            self.warnings.push(format!(
                "method nearfield: shading is per vertex, and {}",
                r.describe()
            ));
        }
        for c in &still {
            self.warnings.push(format!(
                "method nearfield: shading is per vertex, and {}: the light and shadows between \
                 them are lost; give it a finer mesh (`builtin = \"ground-grid\"` for a floor)",
                c.describe()
            ));
        }
        for (i, o) in scene.objects.iter().enumerate() {
            let m = &o.mesh;
            if m.normals.len() != m.positions.len() {
                return Err(invalid(
                    "scene",
                    format!(
                        "{} has no vertex normals (one per vertex is needed)",
                        Numbered::object(i)
                    ),
                ));
            }
            if o.blend.is_some() && m.uvs.len() != m.positions.len() {
                return Err(invalid(
                    "scene",
                    format!(
                        "{} blends two BRDFs by a texture but has no uvs",
                        Numbered::object(i)
                    ),
                ));
            }
        }
        let kinds: Vec<ObjectKind> = scene.objects.iter().map(object_kind).collect();
        let specular = kinds.iter().any(ObjectKind::is_specular);
        let bvh = scene.visibility.then(|| SceneBvh::build(&meshes));
        // Per plane: its key, a cached bake if one loads, and the Lambertian
        // transports kept from an earlier bake of the same frame.
        let mut old_planes = std::mem::take(&mut self.planes);
        let mut plans = Vec::with_capacity(frames.len());
        for frame in &frames {
            let key = BakeKey::of_kinds(scene, frame, n, face, &kinds);
            let path = self
                .options
                .cache_dir
                .as_ref()
                .map(|d| d.join(key.file_name()));
            let mut cached = None;
            if let Some(p) = path.as_deref().filter(|p| p.exists()) {
                match crate::cache::load(p, &key, face) {
                    Ok(t) => cached = Some(t),
                    Err(e) => {
                        let used = match &e {
                            CacheError::File(w) => CacheUse::replaced(p, w),
                            CacheError::Mismatch { why, .. } => CacheUse::Replaced {
                                path: p.to_path_buf(),
                                why: why.clone(),
                            },
                        };
                        self.warnings
                            .extend(used.warning(&format!("method {NEARFIELD_METHOD_NAME}")));
                    }
                }
            }
            let mut kept: Vec<Option<Transport>> = match old_planes
                .iter()
                .position(|p| keep_lambertian && p.frame == *frame)
            {
                Some(i) => std::mem::take(&mut old_planes[i].transports)
                    .into_iter()
                    .zip(&kinds)
                    .map(|(t, k)| (!k.is_specular()).then_some(t))
                    .collect(),
                None => Vec::new(),
            };
            kept.resize_with(meshes.len(), || None);
            plans.push((key, path, cached, kept));
        }
        drop(old_planes);
        let total: u64 = plans
            .iter()
            .filter(|(_, _, cached, _)| cached.is_none())
            .flat_map(|(_, _, _, kept)| meshes.iter().zip(&kinds).zip(kept))
            .filter(|((_, k), kt)| k.is_specular() || kt.is_none())
            .map(|((m, _), _)| m.positions.len() as u64)
            .sum();
        let any_baked = plans.iter().any(|(_, _, cached, _)| cached.is_none());
        if any_baked {
            progress.start("nearfield transport", total);
        }
        let mut spec_s = 0.0;
        let mut planes = Vec::with_capacity(frames.len());
        for (frame, (key, path, cached, mut kept)) in frames.iter().zip(plans) {
            let loaded = cached.is_some();
            let transports = match cached {
                Some(t) => t,
                None => {
                    let mut out = Vec::with_capacity(meshes.len());
                    for (((m, o), kind), kt) in
                        meshes.iter().zip(&scene.objects).zip(&kinds).zip(&mut kept)
                    {
                        if let Some(t) = kt.take().filter(|_| !kind.is_specular()) {
                            out.push(t);
                            continue;
                        }
                        match kind {
                            ObjectKind::Specular { tint } => {
                                let t0 = Instant::now();
                                let weights = o
                                    .blend
                                    .as_ref()
                                    .map(|b| blend_weights(b, &m.uvs))
                                    .unwrap_or_default();
                                out.push(bake_specular(
                                    frame,
                                    SpecularMesh {
                                        positions: &m.positions,
                                        normals: &m.normals,
                                        tangents: &m.tangents,
                                    },
                                    ObjectBrdf {
                                        first: o.brdf.as_ref(),
                                        second: o
                                            .blend
                                            .as_ref()
                                            .map(|b| (b.second.as_ref(), &weights[..])),
                                        tint: *tint,
                                    },
                                    scene.camera.eye,
                                    n,
                                    face,
                                    bvh.as_ref(),
                                    progress,
                                )?);
                                spec_s += t0.elapsed().as_secs_f64();
                            }
                            _ => out.push(bake_transport(
                                frame,
                                &m.positions,
                                &m.normals,
                                n,
                                face,
                                bvh.as_ref(),
                                progress,
                            )?),
                        }
                    }
                    out
                }
            };
            if let (false, Some(p)) = (loaded, path.as_deref()) {
                let refs: Vec<&Transport> = transports.iter().collect();
                if let Err(e) = crate::cache::save(p, &key, &refs) {
                    self.warnings.push(format!(
                        "method nearfield: could not cache the transport ({e})"
                    ));
                }
            }
            planes.push(PlaneBake {
                frame: *frame,
                key,
                transports,
            });
        }
        if any_baked {
            progress.finish();
        }
        let loaded = !any_baked;
        let mut objects = Vec::with_capacity(meshes.len());
        for ((o, kind), source) in scene.objects.iter().zip(&kinds).zip(&given.objects) {
            let m = &o.mesh;
            let pi = std::f32::consts::PI;
            let (albedo, albedos) = match *kind {
                ObjectKind::Diffuse { albedo } => (albedo, Vec::new()),
                ObjectKind::DiffuseBlend { first, second } => {
                    let b = o.blend.as_ref().expect("a blend");
                    let per: Vec<Vec3> = m
                        .uvs
                        .iter()
                        .map(|&uv| {
                            let w = b.weight_at(uv);
                            first * (1.0 - w) + second * w
                        })
                        .collect();
                    (first, per)
                }
                ObjectKind::Specular { tint } => (tint.unwrap_or(Vec3::ONE) * pi, Vec::new()),
            };
            objects.push(Prepared {
                mesh: m.clone(),
                source: source.mesh.clone(),
                kind: *kind,
                albedo,
                albedos,
            });
        }
        self.objects = objects;
        self.planes = planes;
        self.baked_visibility = scene.visibility;
        self.lights = plane_of
            .iter()
            .map(|&plane| LitLight {
                plane,
                ..LitLight::default()
            })
            .collect();
        self.baked_eye = specular.then_some(scene.camera.eye);
        self.view_is_baked = true;
        self.specular_bake_s = spec_s;
        // A lobe narrower than a face cell is held at the cell's size.
        let cell = crate::specular::central_cell_deg(n, face);
        for (i, o) in scene.objects.iter().enumerate() {
            if !kinds[i].is_specular() {
                continue;
            }
            let brdfs =
                std::iter::once(o.brdf.as_ref()).chain(o.blend.as_ref().map(|b| b.second.as_ref()));
            let narrowest = brdfs
                .filter_map(crate::specular::lobe_half_width_deg)
                .fold(f32::MAX, f32::min);
            if 2.0 * narrowest < cell {
                self.warnings.push(format!(
                    "method nearfield: {}'s BRDF lobe (half width {narrowest:.1}° at 30° incidence) is narrower than a face cell ({cell:.1}° at order {n}, face {face}): its fixed-view highlights are blurred to the cell's size (raise --order)",
                    Numbered::object(i)
                ));
            }
        }
        if specular {
            let list: Vec<String> = kinds
                .iter()
                .enumerate()
                .filter(|(_, k)| k.is_specular())
                .map(|(i, k)| {
                    format!(
                        "{i} ({})",
                        if k.channels() == 3 {
                            "RGB"
                        } else {
                            "one channel"
                        }
                    )
                })
                .collect();
            let e = scene.camera.eye;
            self.warnings.push(format!(
                "method nearfield: objects {} have a fixed-view specular transport baked for the camera's eye at ({:.3}, {:.3}, {:.3}){}; other views show that view's highlights until the scene's camera moves (which re-bakes them)",
                list.join(", "),
                e.x,
                e.y,
                e.z,
                if loaded {
                    " (loaded from the cache)".to_string()
                } else {
                    format!(" in {spec_s:.2} s")
                }
            ));
        }
        if loaded {
            self.loads += 1;
        } else {
            self.bakes += 1;
        }
        Ok(())
    }

    /// Maps the vertices through `frame` for the first light from the next
    /// [`Self::propagate`] on (a light move or scale: the ACC rows and
    /// masks are the kernel's, [`crate::propagate`]).
    pub fn set_light_frame(&mut self, frame: &LightFrame) {
        self.lights[0].frame = Some(*frame);
    }

    /// The first light's coefficients and source compression: `light`
    /// as it is. Returns ms.
    ///
    /// # Errors
    /// A light field whose view count is not a power of two.
    pub fn update_source(&mut self, light: &AreaLight) -> Result<f64, MethodError> {
        self.update_source_of(0, light, None)
    }

    /// Light `index`'s coefficients and source compression: `light` as
    /// it is, or turned in its baked plane by `turn` (its bounding
    /// rectangle re-rasterised, [`crate::rotate`]). Returns ms.
    fn update_source_of(
        &mut self,
        index: usize,
        light: &AreaLight,
        turn: Option<&InPlane>,
    ) -> Result<f64, MethodError> {
        let t = Instant::now();
        let o = &self.options;
        let (n, coarse) = (o.order, o.light_order.unwrap_or(o.order).min(o.order));
        if let Some(lf) = &light.light_field {
            // `set_lighting` refuses a turned light field (`check_light_field`).
            let field = FieldSource::of(
                light,
                lf,
                [n, coarse],
                o.face,
                o.source_terms,
                o.source_ranking,
            )
            .map_err(|e| invalid("scene", format!("{}: {e}", Numbered::area_light(index))))?;
            self.lights[index].field = Some(field);
            self.lights[index].source = SourceTerms::default();
            return Ok(t.elapsed().as_secs_f64() * 1e3);
        }
        self.lights[index].field = None;
        let coeffs = match turn {
            None => LightCoeffs::of_at(light, n, coarse),
            Some(turn) => LightCoeffs::of_cells(&turn.cells(light, coarse), n, coarse),
        };
        self.lights[index].source = compress(&coeffs, o.source_terms, o.source_ranking);
        Ok(t.elapsed().as_secs_f64() * 1e3)
    }

    /// The fused propagation of every vertex, summed over the lights (the
    /// per-frame relighting work: affine maps, ACC rows, masks and the
    /// kernel, [`crate::propagate`]). A light whose frame is not set adds
    /// nothing. Returns ms.
    pub fn propagate(&mut self) -> f64 {
        let t = Instant::now();
        let (n, face) = (self.options.order, self.options.face);
        let m = self.target_count();
        let nn = n * n;
        let prims = Primitives::new(n);
        // Per light with a frame: its kernel, frame, plane and light field.
        let lit: Vec<(Kernel, LightFrame, &PlaneBake, Option<&FieldSource>)> = self
            .lights
            .iter()
            .filter_map(|l| {
                let kernel = Kernel {
                    primitives: &prims,
                    source: &l.source,
                    targets: m,
                };
                Some((
                    kernel,
                    l.frame?,
                    self.planes.get(l.plane)?,
                    l.field.as_ref(),
                ))
            })
            .collect();
        // Few targets: the kernel asks for its mask's own lines instead of
        // the next vertex's whole transport (`prefetches_mask`).
        let whole_ahead = !prefetches_mask(n, m);
        self.colors = self
            .objects
            .iter()
            .enumerate()
            .map(|(oi, p)| {
                let verts = p.mesh.positions.len();
                let Some(channels) = self.planes.first().map(|b| b.transports[oi].channels) else {
                    return vec![Vec3::ZERO; verts];
                };
                let per = channels * nn;
                (0..verts)
                    .into_par_iter()
                    .with_min_len(256)
                    .map_init(<(VertexScratch, FieldScratch)>::default, |(sc, fs), v| {
                        let mut b = Vec3::ZERO;
                        for (kernel, frame, plane, field) in &lit {
                            let ahead = field.is_some() || whole_ahead;
                            let Some((s, o)) = frame.affine(frame.local(p.mesh.positions[v]), face)
                            else {
                                continue;
                            };
                            let values = &plane.transports[oi].values;
                            let t = &values[v * per..(v + 1) * per];
                            if ahead && let Some(next) = values.get((v + 1) * per..(v + 2) * per) {
                                prefetch(next);
                            }
                            let vertex = VertexMap { s, o, transport: t };
                            let lit = match field {
                                None => shade_vertex(kernel, &vertex, sc),
                                Some(f) => {
                                    shade_vertex_field(&prims, f, m, &vertex, channels, sc, fs)
                                }
                            };
                            b += Vec3::from(lit).max(Vec3::ZERO);
                        }
                        if channels == 3 {
                            return b;
                        }
                        let albedo = p.albedos.get(v).unwrap_or(&p.albedo);
                        b * *albedo / std::f32::consts::PI
                    })
                    .collect()
            })
            .collect();
        t.elapsed().as_secs_f64() * 1e3
    }

    /// FMAs of one [`Self::propagate`] (every light's kernel).
    #[must_use]
    pub fn propagate_fma(&self) -> f64 {
        let m = self.target_count();
        let Some(plane) = self.planes.first() else {
            return 0.0;
        };
        self.objects
            .iter()
            .zip(&plane.transports)
            .map(|(p, t)| {
                let per: usize = self
                    .lights
                    .iter()
                    .map(|l| {
                        let shade = |s: &SourceTerms| {
                            if t.channels == 3 {
                                shade_rgb_fma(s, m)
                            } else {
                                shade_fma(s, m)
                            }
                        };
                        match &l.field {
                            None => shade(&l.source),
                            Some(f) => f.shade_fma(t.channels, shade),
                        }
                    })
                    .sum();
                (p.mesh.positions.len() * per) as f64
            })
            .sum()
    }
}

impl Relighter for NearfieldMethod {
    fn name(&self) -> &'static str {
        NEARFIELD_METHOD_NAME
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            SceneFeature::AreaLights
            | SceneFeature::LightFields
            | SceneFeature::Visibility
            | SceneFeature::SpatiallyVaryingBrdf => Support::Full,
            SceneFeature::Environment
            | SceneFeature::PointLights
            | SceneFeature::Medium
            | SceneFeature::NormalMaps
            | SceneFeature::Animation => Support::No,
        }
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        check_scene(self, scene, false)?;
        the_lights(scene)?;
        self.bake(scene, progress)?;
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let t = Instant::now();
        let lights = the_lights(scene)?;
        let mut plan = self.lighting_plan(scene);
        if plan.is_none() {
            self.bake(scene, progress)?;
        } else if self.baked_eye.is_some_and(|e| e != scene.camera.eye) {
            // The fixed view moved with the scene's camera (module docs):
            // a plane whose light is where it was baked for keeps its
            // Lambertian transports, the others are baked anew.
            self.bake_with(scene, progress, true)?;
            plan = None;
        }
        let plan = match plan {
            Some(p) => p,
            None => self.lighting_plan(scene).ok_or_else(|| {
                invalid("scene", "the lights do not match the bake made for them")
            })?,
        };
        for (i, (light, (_, turn))) in lights.iter().zip(&plan).enumerate() {
            check_light_field(i, light, turn.is_some())?;
        }
        let mut coeffs_ms = 0.0;
        for (i, (light, (_, turn))) in lights.iter().zip(&plan).enumerate() {
            progress.check()?;
            self.lights[i].frame = Some(turn.map_or_else(|| LightFrame::of(light), |t| t.frame));
            coeffs_ms += self.update_source_of(i, light, turn.as_ref())?;
        }
        let p = self.propagate();
        self.lighting_warnings = std::sync::OnceLock::new();
        self.last_times = [coeffs_ms, p];
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.pending_lighting_ms = ms;
        Ok(ms)
    }

    fn lighting_rebakes(&self, scene: &Scene) -> bool {
        if scene.area_lights.is_empty() {
            return false;
        }
        // What `set_lighting` bakes: the transports for lights whose plane
        // changed, or the fixed-view transports for a camera that moved.
        self.lighting_plan(scene).is_none() || self.baked_eye.is_some_and(|e| e != scene.camera.eye)
    }

    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError> {
        request.validate(NEARFIELD_METHOD_NAME)?;
        let t0 = Instant::now();
        let same =
            relight_render::method::same_meshes(self.objects.iter().map(|p| &p.source), scene);
        if !same || self.colors.len() != self.objects.len() {
            return Err(invalid(
                "scene",
                "the objects changed since `prepare` (or it was not called); call prepare again",
            ));
        }
        progress.check()?;
        self.view_is_baked = self.baked_eye.is_none_or(|e| e == request.camera.eye);
        let k = request.aa;
        // The shaded meshes: a coarse object's refined copy, not the scene's.
        let meshes: Vec<&Arc<Mesh>> = self.objects.iter().map(|p| &p.mesh).collect();
        let (_, draws) = self
            .view
            .draw_meshes(&meshes, request)
            .map_err(|e| invalid("raster", e))?;
        let refs: Vec<&[Vec3]> = self.colors.iter().map(|c| &c[..]).collect();
        // Shaded straight into the frame handed out (no copy: the pass
        // writes every pixel, so a new image costs no zero-fill).
        let mut frame = Image::new(0, 0);
        self.view
            .raster()
            .shade_gouraud(&draws, &refs, Background::Color(Vec3::ZERO), &mut frame)
            .map_err(|e| invalid("raster", e))?;
        Ok(self.view.rendered(
            Cow::Owned(frame),
            k,
            std::mem::take(&mut self.pending_lighting_ms),
            t0,
        ))
    }

    fn warnings(&self) -> Vec<String> {
        let mut w = self.warnings.clone();
        w.extend(
            self.lighting_warnings
                .get_or_init(|| {
                    face_clipping_warnings(
                        &self.objects,
                        self.lights.iter().map(|l| l.frame),
                        self.options.face,
                    )
                })
                .iter()
                .cloned(),
        );
        w
    }

    /// A view change draws the per-vertex colours by Gouraud interpolation
    /// (the last frame's covered samples); `set_lighting` propagates every
    /// light to every vertex ([`Self::propagate_fma`]). `None` before a
    /// frame.
    fn frame_work(&self, _scene: &Scene, _request: &FrameRequest) -> Option<FrameWork> {
        let samples = self.view.raster().gbuffer().covered_pixels();
        if samples == 0 && self.view.rasterizations() == 0 {
            return None;
        }
        Some(FrameWork {
            view_fma: samples as f64 * relight_render::raster::GOURAUD_FMA_PER_SAMPLE,
            lighting_fma: self.propagate_fma(),
        })
    }

    fn data_bytes(&self) -> u64 {
        self.planes
            .iter()
            .flat_map(|p| &p.transports)
            .map(|t| 4 * t.values.len() as u64)
            .sum()
    }
}
