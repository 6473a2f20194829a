//! [`NearfieldMethod`]: near-field area-light relighting behind the method
//! interface ([`Relighter`], name `nearfield`).
//!
//! # What it renders
//! One textured rectangular area light ([`relight_render::AreaLight`]) on
//! any BRDF, with or without shadows, per vertex (Gouraud). A Lambertian
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
//! | [`Relighter::prepare`] | the per-vertex transport on the light's face ([`crate::transport`]), shadows ray-cast when the scene has visibility, or loaded from the disk cache ([`crate::cache`], with [`NearfieldOptions::cache_dir`]); then `set_lighting` |
//! | [`Relighter::set_lighting`] | light moved, scaled or turned in its plane (or moved to another height): the light frame the vertices are mapped through; always: the light's coefficients (a turned light re-rasterised into its bounding rectangle, [`crate::rotate`]), source compression, the fused propagation per vertex (affine map, ACC rows, target mask and dot product, [`crate::propagate`]: a move costs what a texture edit costs). A light whose normal changed re-bakes the transport. |
//! | [`Relighter::render`] | rasterize and interpolate the vertex colours |
//!
//! Moving along the normal keeps the baked shadows, cast towards the old
//! plane. A turn in the plane (thesis §4.5.6) is not affine in Haar
//! (§4.4): the light is re-rasterised into the rectangle along the baked
//! axes that bounds it, zero outside the turned rectangle, and shaded as
//! that unturned light; a turn of exactly 0° is the unturned path.

use crate::cache::{BakeKey, CacheError};
use crate::face::LightFrame;
use crate::light::{LightCoeffs, Ranking, SourceTerms, compress, count_of};
use crate::propagate::{
    Kernel, Primitives, VertexMap, VertexScratch, prefetch, shade_fma, shade_rgb_fma, shade_vertex,
};
use crate::rotate::InPlane;
use crate::specular::{
    ObjectBrdf, ObjectKind, SpecularMesh, bake_specular, blend_weights, object_kind,
};
use crate::transport::{Transport, bake_transport};
use glam::Vec3;
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_render::cull::ClosedMeshes;
use relight_render::method::{
    FrameRequest, FrameWork, MethodError, Relighter, Rendered, SceneFeature, Support, check_scene,
    rasterize_objects,
};
use relight_render::raster::{Background, Rasterizer};
use relight_render::{AreaLight, Image, Progress, Scene, SceneBvh};
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
        }
    }
}

/// One object's baked and per-light data.
struct Prepared {
    mesh: Arc<Mesh>,
    /// How it is shaded ([`crate::specular::object_kind`]).
    kind: ObjectKind,
    /// The factor × π of the transport dot product: the albedo (Lambertian;
    /// a blend's first albedo), π · tint (one-channel fixed view) or π (RGB).
    albedo: Vec3,
    /// Per vertex, a Lambertian blend's albedo (else empty).
    albedos: Vec<Vec3>,
    transport: Transport,
}

/// Near-field relighting as a [`Relighter`] (module docs).
pub struct NearfieldMethod {
    options: NearfieldOptions,
    objects: Vec<Prepared>,
    /// The light frame the transport was baked for, and with visibility.
    baked: Option<(LightFrame, bool)>,
    /// The light frame the propagation maps vertices through (the light's
    /// own, or a turned light's bounding rectangle).
    light_frame: Option<LightFrame>,
    source: SourceTerms,
    colors: Vec<Vec<Vec3>>,
    warnings: Vec<String>,
    raster: Rasterizer,
    /// Which meshes are closed (their back faces culled from outside).
    closed: ClosedMeshes,
    frame: Image,
    pending_lighting_ms: f64,
    /// Times of the last lighting change: coefficients, propagation (ms).
    pub last_times: [f64; 2],
    bakes: usize,
    /// The key of the current bake.
    key: Option<BakeKey>,
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

/// The one area light of `scene`.
fn the_light(scene: &Scene) -> Result<&AreaLight, MethodError> {
    match scene.area_lights.as_slice() {
        [l] => Ok(l),
        [] => Err(invalid("scene", "needs one [[area_light]] (it has none)")),
        ls => Err(invalid(
            "scene",
            format!("renders one area light (the scene has {})", ls.len()),
        )),
    }
}

impl NearfieldMethod {
    /// Whether the transport must be baked again for `light` (its plane
    /// changed, or the objects or visibility did), and else the in-plane
    /// turn from the baked axes, if any: a light turned in the baked plane
    /// keeps the bake (module docs).
    fn lighting_plan(
        &self,
        scene: &Scene,
        light: &AreaLight,
        own: &LightFrame,
    ) -> (bool, Option<InPlane>) {
        let same_objects =
            relight_render::method::same_meshes(self.objects.iter().map(|p| &p.mesh), scene);
        match self.baked {
            Some((b, vis)) if same_objects && vis == scene.visibility => {
                if b.axes == own.axes {
                    (false, None)
                } else {
                    let turn = InPlane::of(&b.axes, light);
                    (turn.is_none(), turn)
                }
            }
            _ => (true, None),
        }
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
            baked: None,
            light_frame: None,
            source: SourceTerms::default(),
            colors: Vec::new(),
            warnings: Vec::new(),
            raster: Rasterizer::new(),
            closed: ClosedMeshes::default(),
            frame: Image::new(0, 0),
            pending_lighting_ms: 0.0,
            last_times: [0.0; 2],
            bakes: 0,
            key: None,
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

    /// The key of the current bake (after `prepare` or [`Self::bake_scene`]).
    #[must_use]
    pub fn bake_key(&self) -> Option<&BakeKey> {
        self.key.as_ref()
    }

    /// The cache file of the current bake, when caching.
    #[must_use]
    pub fn cache_path(&self) -> Option<PathBuf> {
        Some(
            self.options
                .cache_dir
                .as_ref()?
                .join(self.key.as_ref()?.file_name()),
        )
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

    /// Writes the current bake to `path` (the cache's format, [`crate::cache`]).
    ///
    /// # Errors
    /// [`CacheError`] when nothing is baked or the file cannot be written.
    pub fn save_bake(&self, path: &Path) -> Result<(), CacheError> {
        let key = self.key.as_ref().ok_or_else(|| CacheError::Mismatch {
            path: path.to_path_buf(),
            why: "nothing baked yet".into(),
        })?;
        let t: Vec<&Transport> = self.objects.iter().map(|p| &p.transport).collect();
        crate::cache::save(path, key, &t)
    }

    /// Each object's baked transport.
    #[must_use]
    pub fn transports(&self) -> Vec<&Transport> {
        self.objects.iter().map(|p| &p.transport).collect()
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

    /// The per-vertex colours of the last lighting change.
    #[must_use]
    pub fn vertex_colors(&self) -> &[Vec<Vec3>] {
        &self.colors
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

    /// The source terms of the last lighting change.
    #[must_use]
    pub fn source(&self) -> &SourceTerms {
        &self.source
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

    /// The bake of `scene`; `keep_lambertian`: the objects (the same meshes
    /// and light plane) keep their Lambertian transports and only the
    /// fixed-view ones are baked again (a camera change).
    fn bake_with(
        &mut self,
        scene: &Scene,
        progress: &dyn Progress,
        keep_lambertian: bool,
    ) -> Result<(), MethodError> {
        let light = the_light(scene)?;
        let frame = LightFrame::of(light);
        let meshes: Vec<&Mesh> = scene.objects.iter().map(|o| o.mesh.as_ref()).collect();
        let (n, face) = (self.options.order, self.options.face);
        self.warnings.clear();
        for (i, o) in scene.objects.iter().enumerate() {
            let m = &o.mesh;
            if m.normals.len() != m.positions.len() {
                return Err(invalid(
                    "scene",
                    format!("object {i} has no vertex normals (one per vertex is needed)"),
                ));
            }
            if o.blend.is_some() && m.uvs.len() != m.positions.len() {
                return Err(invalid(
                    "scene",
                    format!("object {i} blends two BRDFs by a texture but has no uvs"),
                ));
            }
        }
        let kinds: Vec<ObjectKind> = scene.objects.iter().map(object_kind).collect();
        let specular = kinds.iter().any(ObjectKind::is_specular);
        let bvh = scene.visibility.then(|| SceneBvh::build(&meshes));
        let key = BakeKey::of_kinds(scene, &frame, n, face, &kinds);
        let path = self
            .options
            .cache_dir
            .as_ref()
            .map(|d| d.join(key.file_name()));
        let mut cached = None;
        if let Some(p) = path.as_deref().filter(|p| p.exists()) {
            match crate::cache::load(p, &key, face) {
                Ok(t) => cached = Some(t),
                Err(e) => self.warnings.push(format!(
                    "method nearfield: cached transport unusable ({e}); re-baked"
                )),
            }
        }
        let loaded = cached.is_some();
        let mut kept: Vec<Option<Transport>> = if keep_lambertian {
            std::mem::take(&mut self.objects)
                .into_iter()
                .map(|p| (!p.kind.is_specular()).then_some(p.transport))
                .collect()
        } else {
            Vec::new()
        };
        kept.resize_with(meshes.len(), || None);
        let mut spec_s = 0.0;
        let transports = match cached {
            Some(t) => t,
            None => {
                let total: u64 = meshes
                    .iter()
                    .zip(&kinds)
                    .zip(&kept)
                    .filter(|((_, k), kt)| k.is_specular() || kt.is_none())
                    .map(|((m, _), _)| m.positions.len() as u64)
                    .sum();
                progress.start("nearfield transport", total);
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
                                &frame,
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
                            &frame,
                            &m.positions,
                            &m.normals,
                            n,
                            face,
                            bvh.as_ref(),
                            progress,
                        )?),
                    }
                }
                progress.finish();
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
        let mut objects = Vec::with_capacity(meshes.len());
        for ((o, kind), transport) in scene.objects.iter().zip(&kinds).zip(transports) {
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
                kind: *kind,
                albedo,
                albedos,
                transport,
            });
        }
        self.objects = objects;
        self.baked = Some((frame, scene.visibility));
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
                    "method nearfield: object {i}'s BRDF lobe (half width {narrowest:.1}° at 30° incidence) is narrower than a face cell ({cell:.1}° at order {n}, face {face}): its fixed-view highlights are blurred to the cell's size (raise --order)"
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
        self.key = Some(key);
        if loaded {
            self.loads += 1;
        } else {
            self.bakes += 1;
        }
        Ok(())
    }

    /// Maps the vertices through `frame` from the next [`Self::propagate`]
    /// on (a light move or scale: the ACC rows and masks are the kernel's,
    /// [`crate::propagate`]).
    pub fn set_light_frame(&mut self, frame: &LightFrame) {
        self.light_frame = Some(*frame);
    }

    /// The light's coefficients and source compression. Returns ms.
    pub fn update_source(&mut self, light: &AreaLight) -> f64 {
        self.update_source_turned(light, None)
    }

    /// [`Self::update_source`] for `light` turned in the baked plane by
    /// `turn` (its bounding rectangle re-rasterised, [`crate::rotate`]).
    /// Returns ms.
    pub fn update_source_turned(&mut self, light: &AreaLight, turn: Option<&InPlane>) -> f64 {
        let t = Instant::now();
        let o = &self.options;
        let (n, coarse) = (o.order, o.light_order.unwrap_or(o.order).min(o.order));
        let coeffs = match turn {
            None => LightCoeffs::of_at(light, n, coarse),
            Some(turn) => LightCoeffs::of_cells(&turn.cells(light, coarse), n, coarse),
        };
        self.source = compress(&coeffs, o.source_terms, o.source_ranking);
        t.elapsed().as_secs_f64() * 1e3
    }

    /// The fused propagation of every vertex (the per-frame relighting
    /// work: affine maps, ACC rows, masks and the kernel,
    /// [`crate::propagate`]). Vertices are black before a light frame is
    /// set. Returns ms.
    pub fn propagate(&mut self) -> f64 {
        let t = Instant::now();
        let (n, face) = (self.options.order, self.options.face);
        let m = self.target_count();
        let nn = n * n;
        let prims = Primitives::new(n);
        let kernel = Kernel {
            primitives: &prims,
            source: &self.source,
            targets: m,
        };
        let frame = self.light_frame;
        self.colors = self
            .objects
            .iter()
            .map(|p| {
                let verts = p.mesh.positions.len();
                let channels = p.transport.channels;
                (0..verts)
                    .into_par_iter()
                    .with_min_len(256)
                    .map_init(VertexScratch::default, |sc, v| {
                        let Some((s, o)) =
                            frame.and_then(|f| f.affine(f.local(p.mesh.positions[v]), face))
                        else {
                            return Vec3::ZERO;
                        };
                        let per = channels * nn;
                        let t = &p.transport.values[v * per..(v + 1) * per];
                        if let Some(next) = p.transport.values.get((v + 1) * per..(v + 2) * per) {
                            prefetch(next);
                        }
                        let vertex = VertexMap { s, o, transport: t };
                        let b = Vec3::from(shade_vertex(&kernel, &vertex, sc)).max(Vec3::ZERO);
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

    /// FMAs of one [`Self::propagate`].
    #[must_use]
    pub fn propagate_fma(&self) -> f64 {
        let m = self.target_count();
        self.objects
            .iter()
            .map(|p| {
                let per = if p.transport.channels == 3 {
                    shade_rgb_fma(&self.source, m)
                } else {
                    shade_fma(&self.source, m)
                };
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
        the_light(scene)?;
        self.bake(scene, progress)?;
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let t = Instant::now();
        let light = the_light(scene)?;
        let own = LightFrame::of(light);
        let (rebake, mut turn) = self.lighting_plan(scene, light, &own);
        if rebake {
            self.bake(scene, progress)?;
            turn = None;
        } else if self.baked_eye.is_some_and(|e| e != scene.camera.eye) {
            // The fixed view moved with the scene's camera (module docs):
            // the Lambertian transports are kept when the light is where
            // they were baked for, else everything is baked for it anew.
            let keep = turn.is_none() && self.baked.is_some_and(|(b, _)| b == own);
            self.bake_with(scene, progress, keep)?;
            turn = None;
        }
        let frame = turn.map_or(own, |t| t.frame);
        progress.check()?;
        self.set_light_frame(&frame);
        let c = self.update_source_turned(light, turn.as_ref());
        let p = self.propagate();
        self.last_times = [c, p];
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.pending_lighting_ms = ms;
        Ok(ms)
    }

    fn lighting_rebakes(&self, scene: &Scene) -> bool {
        let Ok(light) = the_light(scene) else {
            return false;
        };
        let own = LightFrame::of(light);
        // What `set_lighting` bakes: the transport for a light whose plane
        // changed, or the fixed-view transports for a camera that moved.
        self.lighting_plan(scene, light, &own).0
            || self.baked_eye.is_some_and(|e| e != scene.camera.eye)
    }

    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError> {
        request.validate(NEARFIELD_METHOD_NAME)?;
        let t0 = Instant::now();
        let same = relight_render::method::same_meshes(self.objects.iter().map(|p| &p.mesh), scene);
        if !same || self.colors.len() != self.objects.len() {
            return Err(invalid(
                "scene",
                "the objects changed since `prepare` (or it was not called); call prepare again",
            ));
        }
        progress.check()?;
        self.view_is_baked = self.baked_eye.is_none_or(|e| e == request.camera.eye);
        let k = request.aa;
        let (_, draws) = rasterize_objects(&mut self.raster, &mut self.closed, scene, request)
            .map_err(|e| invalid("raster", e))?;
        let refs: Vec<&[Vec3]> = self.colors.iter().map(|c| &c[..]).collect();
        self.raster
            .shade_gouraud(
                &draws,
                &refs,
                Background::Color(Vec3::ZERO),
                &mut self.frame,
            )
            .map_err(|e| invalid("raster", e))?;
        Ok(Rendered::from_samples(
            Cow::Borrowed(&self.frame),
            &self.raster,
            k,
            std::mem::take(&mut self.pending_lighting_ms),
            t0,
        ))
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    fn frame_work(&self, _scene: &Scene, _request: &FrameRequest) -> Option<FrameWork> {
        Some(FrameWork {
            view_fma: 0.0,
            lighting_fma: self.propagate_fma(),
        })
    }

    fn data_bytes(&self) -> u64 {
        self.objects
            .iter()
            .map(|p| 4 * p.transport.values.len() as u64)
            .sum()
    }
}
