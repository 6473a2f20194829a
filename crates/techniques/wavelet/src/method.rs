//! [`WaveletMethod`]: all-frequency wavelet environment shading behind the
//! method interface ([`relight_render::method::Relighter`], name `wavelet`).
//!
//! # What it renders
//! The unshadowed reflection integral of each object's BRDF under the
//! distant environment, per vertex, as the sparse dot product of a baked BRDF
//! slice with the lighting rotated into the vertex's local frame by
//! precomputed wavelet rotation matrices (wavelet-rotation-2006 §3, Eq. 7;
//! [`crate::render`] has the two steps), drawn with Gouraud shading. With
//! `ao > 0` every vertex colour is multiplied by its ambient occlusion
//! (§3 step 2), an approximation of shadowing that
//! [`Relighter::supports`] reports as such. Point and area lights, media,
//! normal maps and spatially varying BRDFs are not rendered.
//!
//! # What each call does
//! | call | work |
//! |---|---|
//! | [`Relighter::prepare`] | rotation matrices and one BRDF bake per distinct BRDF: from memory when already held, else [`bake_or_load_rotation`] / [`bake_or_load_brdf`] (the disk cache in [`WaveletOptions::cache_dir`], baked on a miss, with progress and cancellation); per-vertex AO when `ao > 0` (kept while the meshes are the same); then `set_lighting` |
//! | [`Relighter::set_lighting`] | step 1: the environment seen through `world_from_env` sampled onto the octahedral map, Haar transform, top `terms`; the products with the rotation matrices wait for a frame |
//! | [`Relighter::render`] | step 1's products for the sampled normals the frame's vertices blend and the lighting lacks, step 2 for the frame's eye (the vertices of visible triangles), Gouraud raster at `aa × aa` samples per pixel, box filter |
//!
//! # Timings
//! `set_lighting` returns its milliseconds; the next frame also reports them
//! as [`FrameTimings::lighting_ms`] (then 0 until the next lighting change);
//! [`FrameTimings::view_ms`] is step 2 + raster, and the products of step 1
//! that the frame formed.
//!
//! [`FrameTimings::lighting_ms`]: relight_render::method::FrameTimings::lighting_ms
//! [`FrameTimings::view_ms`]: relight_render::method::FrameTimings::view_ms

use crate::WaveletError;
use crate::brdf_bake::{BrdfBake, BrdfBakeParams};
use crate::render::{NormalInterp, VertexColors, WaveletRenderer};
use crate::rotation::{RotationMatrices, RotationParams};
use crate::study::{bake_or_load_brdf, bake_or_load_rotation, default_cache_dir};
use glam::Mat3;
use relight_geom::Mesh;
use relight_render::method::{
    CoverageCache, FrameRequest, MethodError, Relighter, Rendered, SceneFeature, Support,
    check_scene,
};
use relight_render::raster::Rasterizer;
use relight_render::{Image, Progress, Scene, SceneBvh};
use std::borrow::Cow;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// The method's name on the command line.
pub const WAVELET_METHOD_NAME: &str = "wavelet";

/// How [`WaveletMethod`] renders shadowing with `ao > 0`.
pub const AO_APPROXIMATION: &str =
    "per-vertex ambient occlusion × unshadowed radiance, wavelet-rotation-2006 §3 step 2";

/// Settings of [`WaveletMethod`]. `Default` holds the wavelet defaults (the
/// one place they live).
#[derive(Clone, Debug, PartialEq)]
pub struct WaveletOptions {
    /// Octahedral source side n (N = n² coefficients; power of two). Default 64.
    pub n: usize,
    /// Normal tessellation side (ntess² sampled normals). Default 32.
    pub ntess: usize,
    /// Quantized rotation-matrix entries with |q| < ntrunc are dropped (≥ 1). Default 1.
    pub ntrunc: u16,
    /// Lighting terms kept (1..=N). Default 256.
    pub terms: usize,
    /// Cosine-weighted AO rays per vertex against every object (0 = off).
    /// Default 0.
    pub ao: u32,
    /// Seed of the AO rays. Default 1.
    pub ao_seed: u64,
    /// View grid side of the BRDF bakes (views² slices). Default 64.
    pub brdf_views: usize,
    /// Wavelet terms kept per BRDF slice (capped at m²). Default 128.
    pub brdf_terms: usize,
    /// Blend of the four sampled normals around a vertex normal. Default
    /// [`NormalInterp::MirrorAligned`].
    pub normal_interp: NormalInterp,
    /// Where baked data is cached. Default [`default_cache_dir`].
    pub cache_dir: PathBuf,
    /// With `ao`, shade objects too coarse for per-vertex occlusion (a
    /// ground quad) on a refined copy
    /// ([`relight_render::Scene::with_coarse_objects_refined`], with a
    /// warning); off: warn only. Default on.
    pub refine_coarse: bool,
}

impl Default for WaveletOptions {
    fn default() -> Self {
        Self {
            n: 64,
            ntess: 32,
            ntrunc: 1,
            terms: 256,
            ao: 0,
            ao_seed: 1,
            brdf_views: 64,
            brdf_terms: 128,
            normal_interp: NormalInterp::default(),
            cache_dir: default_cache_dir(),
            refine_coarse: true,
        }
    }
}

impl WaveletOptions {
    /// The rotation-matrix parameters these options ask for.
    #[must_use]
    pub fn rotation_params(&self) -> RotationParams {
        RotationParams::new(self.n, self.ntess, self.ntrunc)
    }

    /// The BRDF-bake parameters for a BRDF identified by `key` (its model's
    /// `Debug` description, as [`crate::bake_or_load_scene_brdfs`] keys it).
    #[must_use]
    pub fn brdf_params(&self, key: &str) -> BrdfBakeParams {
        let m = self.rotation_params().m;
        BrdfBakeParams::new(key, m, self.brdf_views, self.brdf_terms.min(m * m))
    }
}

/// Per-vertex AO of one set of meshes.
struct AoCache {
    meshes: Vec<Arc<Mesh>>,
    rays: u32,
    seed: u64,
    values: Vec<Vec<f32>>,
}

/// Wavelet environment shading as a [`Relighter`] (see the module docs).
pub struct WaveletMethod {
    options: WaveletOptions,
    rotation: Option<Arc<RotationMatrices>>,
    renderer: Option<WaveletRenderer>,
    /// Every BRDF bake loaded so far, by its parameters (key included).
    bakes: Vec<Arc<BrdfBake>>,
    /// The prepared scene: its meshes and one bake per object.
    meshes: Vec<Arc<Mesh>>,
    /// The meshes shaded and drawn: `meshes`, or with `ao` a coarse
    /// object's refined copy; and whether they were refined.
    shaded: (Vec<Arc<Mesh>>, bool),
    object_bakes: Vec<Arc<BrdfBake>>,
    ao: Option<AoCache>,
    raster: Rasterizer,
    /// The coverage of `raster`'s last buffer (kept across lighting changes).
    coverage: CoverageCache,
    /// Step 2's vertex colours, kept for the same eye and lighting.
    colors: VertexColors,
    pending_lighting_ms: f64,
    /// Bakes and loads done by `prepare` so far (rotation + BRDF), for tests
    /// and the viewer's status line.
    loads: usize,
    /// What the last `prepare` renders differently ([`Relighter::warnings`]).
    warnings: Vec<String>,
    /// Cache files this `prepare` found unusable and replaced
    /// ([`crate::CacheUse::warning`]); they lead `warnings`.
    cache_warnings: Vec<String>,
}

impl std::fmt::Debug for WaveletMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WaveletMethod")
            .field("options", &self.options)
            .field("prepared", &self.renderer.is_some())
            .finish_non_exhaustive()
    }
}

fn fail(e: WaveletError) -> MethodError {
    MethodError::failed(WAVELET_METHOD_NAME, e)
}

fn invalid(option: &'static str, message: impl ToString) -> MethodError {
    MethodError::InvalidOption {
        method: WAVELET_METHOD_NAME,
        option,
        message: message.to_string(),
    }
}

fn stale(why: &str) -> MethodError {
    fail(WaveletError::BadParam {
        name: "scene",
        value: "(changed)".into(),
        why: why.into(),
    })
}

/// Bytes a BRDF bake holds in memory (indices and RGB values).
fn bake_bytes(b: &BrdfBake) -> u64 {
    (std::mem::size_of_val(&b.indices[..]) + std::mem::size_of_val(&b.values[..])) as u64
}

impl WaveletMethod {
    /// A method with `options` (checked here; nothing is loaded before
    /// `prepare`).
    ///
    /// # Errors
    /// [`MethodError::InvalidOption`] naming `n`/`ntess`/`ntrunc`, `terms`,
    /// or the BRDF bake sizes.
    pub fn new(options: WaveletOptions) -> Result<Self, MethodError> {
        options
            .rotation_params()
            .validate()
            .map_err(|e| invalid("n/ntess/ntrunc", e))?;
        let big_n = options.rotation_params().source_len();
        if !(1..=big_n).contains(&options.terms) {
            return Err(invalid(
                "terms",
                format!(
                    "must be in 1..=N = {big_n} (n = {}), got {}",
                    options.n, options.terms
                ),
            ));
        }
        options
            .brdf_params("validate")
            .validate()
            .map_err(|e| invalid("brdf_views/brdf_terms", e))?;
        Ok(Self {
            options,
            rotation: None,
            renderer: None,
            bakes: Vec::new(),
            meshes: Vec::new(),
            shaded: (Vec::new(), false),
            object_bakes: Vec::new(),
            ao: None,
            raster: Rasterizer::new(),
            coverage: CoverageCache::default(),
            colors: VertexColors::default(),
            pending_lighting_ms: 0.0,
            loads: 0,
            warnings: Vec::new(),
            cache_warnings: Vec::new(),
        })
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &WaveletOptions {
        &self.options
    }

    /// How many rotation-matrix and BRDF-bake loads (from the disk cache, or
    /// baked on a miss) `prepare` has done; data already in memory is not
    /// loaded again.
    #[must_use]
    pub fn loads(&self) -> usize {
        self.loads
    }

    /// The renderer, once prepared (for its lighting statistics).
    #[must_use]
    pub fn renderer(&self) -> Option<&WaveletRenderer> {
        self.renderer.as_ref()
    }

    fn check_same_meshes(&self, scene: &Scene) -> Result<(), MethodError> {
        if relight_render::method::same_meshes(self.meshes.iter(), scene) {
            Ok(())
        } else {
            Err(stale(
                "the objects changed since `prepare` (other meshes, or moved by an animation); call prepare again",
            ))
        }
    }

    fn brdf_bake(
        &mut self,
        object: &relight_render::Object,
        progress: &dyn Progress,
    ) -> Result<Arc<BrdfBake>, MethodError> {
        let key = object.brdf.label();
        let params = self.options.brdf_params(&key);
        if let Some(b) = self.bakes.iter().find(|b| b.params == params) {
            return Ok(b.clone());
        }
        let (mut b, used) = bake_or_load_brdf(
            &params,
            object.brdf.as_ref(),
            &self.options.cache_dir,
            progress,
        )
        .map_err(fail)?;
        self.loads += 1;
        self.cache_warnings
            .extend(used.warning(&format!("method {WAVELET_METHOD_NAME}")));
        // A loaded bake knows its key only as a hash; keep the full key so
        // that the in-memory lookup above matches it next time.
        if b.params != params {
            let mut owned = (*b).clone();
            owned.params.key = key;
            b = Arc::new(owned);
        }
        self.bakes.push(b.clone());
        Ok(b)
    }
}

/// True when `m` is a rotation (orthonormal, determinant +1) to 1e-4.
fn is_rotation(m: Mat3) -> bool {
    let e = (m.transpose() * m - Mat3::IDENTITY).to_cols_array();
    m.is_finite() && e.iter().all(|x| x.abs() < 1e-4) && (m.determinant() - 1.0).abs() < 1e-4
}

impl Relighter for WaveletMethod {
    fn name(&self) -> &'static str {
        WAVELET_METHOD_NAME
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            SceneFeature::Environment => Support::Full,
            SceneFeature::Visibility if self.options.ao > 0 => {
                Support::Approximate(AO_APPROXIMATION)
            }
            SceneFeature::Visibility
            | SceneFeature::PointLights
            | SceneFeature::AreaLights
            | SceneFeature::LightFields
            | SceneFeature::Medium
            | SceneFeature::NormalMaps
            | SceneFeature::SpatiallyVaryingBrdf
            | SceneFeature::Animation => Support::No,
        }
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        // A feature it cannot render at all is never silently dropped; the
        // caller's `check_scene` decides whether approximations are allowed.
        check_scene(self, scene, true)?;
        self.cache_warnings.clear();
        let params = self.options.rotation_params();
        if self.rotation.is_none() {
            let (rot, used) =
                bake_or_load_rotation(&params, &self.options.cache_dir, progress).map_err(fail)?;
            self.loads += 1;
            self.cache_warnings
                .extend(used.warning(&format!("method {WAVELET_METHOD_NAME}")));
            let mut r = WaveletRenderer::new(rot.clone(), self.options.terms)
                .map_err(|e| invalid("terms", e))?;
            r.normal_interp = self.options.normal_interp;
            self.rotation = Some(rot);
            self.renderer = Some(r);
        }
        let mut object_bakes = Vec::with_capacity(scene.objects.len());
        for o in &scene.objects {
            progress.check()?;
            object_bakes.push(self.brdf_bake(o, progress)?);
        }
        let meshes: Vec<Arc<Mesh>> = scene.objects.iter().map(|o| o.mesh.clone()).collect();
        let rays = self.options.ao;
        let seed = self.options.ao_seed;
        // Ambient occlusion per vertex on a ground quad holds no shadow: such
        // objects are shaded on a refined copy (kept while the scene's
        // meshes are the same), and said; one the cap leaves coarse is
        // warned about.
        let same_source = self.check_same_meshes(scene).is_ok();
        let (refined, still) = match (rays > 0 && scene.visibility, self.options.refine_coarse) {
            (true, true) => {
                let (s, refined, still) = scene.with_coarse_objects_refined();
                if !(same_source && self.shaded.1) {
                    self.shaded = (s.objects.iter().map(|o| o.mesh.clone()).collect(), true);
                }
                (refined, still)
            }
            (occluded, _) => {
                self.shaded = (meshes.clone(), false);
                let coarse = if occluded {
                    scene.coarse_objects()
                } else {
                    Vec::new()
                };
                (Vec::new(), coarse)
            }
        };
        let shaded = &self.shaded.0;
        let ao_valid = self.ao.as_ref().is_some_and(|a| {
            a.rays == rays
                && a.seed == seed
                && relight_render::method::same_mesh_list(a.meshes.iter(), shaded.iter())
        });
        if rays == 0 {
            self.ao = None;
        } else if !ao_valid {
            let meshes = shaded;
            let refs: Vec<&Mesh> = meshes.iter().map(|m| m.as_ref()).collect();
            let bvh = SceneBvh::build(&refs);
            let values = (0..refs.len())
                .map(|i| bvh.vertex_ambient_occlusion(i, rays, seed, progress))
                .collect::<Result<Vec<_>, _>>()?;
            self.ao = Some(AoCache {
                meshes: meshes.clone(),
                rays,
                seed,
                values,
            });
        }
        self.meshes = meshes;
        self.object_bakes = object_bakes;
        self.colors.clear();
        self.warnings = std::mem::take(&mut self.cache_warnings);
        self.warnings.extend(
            refined
                .iter()
                .map(|r| {
                    format!(
                        "method wavelet: ambient occlusion is per vertex, and {}",
                        r.describe()
                    )
                })
                .chain(still.iter().map(|c| {
                    format!(
                        "method wavelet: ambient occlusion is per vertex, and {}: the shadows \
                     between them are lost; give it a finer mesh (`builtin = \"ground-grid\"` \
                     for a floor)",
                        c.describe()
                    )
                })),
        );
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let t = Instant::now();
        if !is_rotation(scene.world_from_env) {
            return Err(invalid(
                "world_from_env",
                format!(
                    "{:?} is not a rotation (orthonormal, determinant +1)",
                    scene.world_from_env
                ),
            ));
        }
        let renderer = self
            .renderer
            .as_mut()
            .ok_or_else(|| stale("call prepare before set_lighting"))?;
        progress.check()?;
        renderer
            .set_lighting(&scene.env, scene.world_from_env)
            .map_err(fail)?;
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
        request.validate(WAVELET_METHOD_NAME)?;
        let t = Instant::now();
        self.check_same_meshes(scene)?;
        let renderer = self
            .renderer
            .as_ref()
            .ok_or_else(|| stale("call prepare before render"))?;
        progress.check()?;
        let k = request.aa;
        let mut camera = request.camera;
        camera.width *= k;
        camera.height *= k;
        let refs: Vec<&BrdfBake> = self.object_bakes.iter().map(|b| b.as_ref()).collect();
        let ao = self.ao.as_ref().map(|a| &a.values[..]);
        // Empty pixels of a frame at one sample per pixel all get the shared
        // background (`render_frame`); supersampled ones need the
        // environment in their empty samples.
        let shaded: Vec<&Arc<Mesh>> = self.shaded.0.iter().collect();
        // Shaded straight into the frame handed out (the pass writes every
        // pixel of a new image: no zero-fill, no copy).
        let mut frame = Image::new(0, 0);
        renderer
            .render_meshes_into(
                &shaded,
                &scene.env,
                &refs,
                &camera,
                ao,
                &mut self.raster,
                &mut self.colors,
                k > 1,
                &mut frame,
            )
            .map_err(fail)?;
        Ok(Rendered::from_samples_cached(
            Cow::Owned(frame),
            &self.raster,
            k,
            &mut self.coverage,
            std::mem::take(&mut self.pending_lighting_ms),
            t,
        ))
    }

    /// Step 2 of the last frame: the slice terms it multiplied with local
    /// lighting (the dot products of the visible vertices that the memo did
    /// not hold, [`crate::memo`]) × RGB, plus the Gouraud resolve (3 × RGB per
    /// pixel); step 1 as the rotation-matrix entries the kept terms touch
    /// (nnz × terms / N) × RGB, for every sampled normal: an upper bound, as
    /// frames form the products of the normals they blend only.
    fn frame_work(
        &self,
        _scene: &Scene,
        request: &FrameRequest,
    ) -> Option<relight_render::method::FrameWork> {
        let rot = self.rotation.as_ref()?;
        let p = rot.params();
        let pixels =
            (request.camera.width * request.camera.height * request.aa * request.aa) as f64;
        let view = self.colors.terms_last as f64 * 3.0
            + pixels * relight_render::raster::GOURAUD_FMA_PER_SAMPLE;
        let lighting = rot.nnz() as f64 * self.options.terms as f64 / p.source_len() as f64 * 3.0;
        Some(relight_render::method::FrameWork {
            view_fma: view,
            lighting_fma: lighting,
        })
    }

    /// Rotation matrices plus the prepared scene's distinct BRDF bakes.
    fn data_bytes(&self) -> u64 {
        let rot = self.rotation.as_ref().map_or(0, |r| r.size_bytes());
        let b = &self.object_bakes;
        let bakes: u64 = b
            .iter()
            .enumerate()
            .filter(|(i, x)| !b[..*i].iter().any(|y| Arc::ptr_eq(x, y)))
            .map(|(_, x)| bake_bytes(x))
            .sum();
        rot + bakes
    }
}
