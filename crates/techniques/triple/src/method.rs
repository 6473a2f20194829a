//! [`TripleMethod`]: triple-product relighting behind the method interface
//! ([`Relighter`], name `triple`).
//!
//! # What it renders
//! Distant environment lighting × binary visibility × each object's BRDF,
//! per pixel, as the top-only spherical-wavelet triple product in the
//! point's local frame (spherical-wavelets-triple-product-2006 Eq. 7,
//! [`crate::shade`]). A spatially varying BRDF (two BRDFs blended by a
//! texture over the uvs) shades both tables and blends the results, exact by
//! the linearity of Eq. 7 in the BRDF (the paper blends the coefficients, the
//! same sum). Point and area lights are refused
//! ([`MethodError::Unsupported`]). A homogeneous medium is rendered as
//! sun-thesis-2008 §3.6.5 proposes: the same product fed with the
//! environment convolved by the fog ball's single-scattering kernel (the
//! thesis' PSF, corrected for the ball), then the view segment's
//! attenuation and airlight per pixel ([`crate::medium`]); the eye may be
//! outside the ball.
//!
//! # Bump mapping (§3.3)
//! With a normal map, each pixel's frame is built from its bumped normal
//! (`NormalMap::perturb` of the interpolated normal and tangent): the
//! lighting is looked up and the BRDF's view taken in that frame, while the
//! visibility stays the vertices' rows, unrotated, as the paper does. This
//! is an approximation wherever visibility is on: the visibility is the
//! geometric surface's, indexed as if it had turned with the bump
//! ([`Relighter::warnings`] says so). A flat map (every texel +Z) leaves the
//! frame, so the image, exactly as without it. As in the reference, a bumped
//! normal that faces away from the viewer shades black (where the map is
//! flat the pixel is not bumped and shades as without the map). Per-vertex shading
//! cannot show a bump and refuses normal maps.
//!
//! | call | work |
//! |---|---|
//! | [`Relighter::prepare`] | one BRDF table per distinct BRDF and the per-vertex visibility of every object, each from the disk cache or baked on a miss ([`crate::cache`]); then `set_lighting` |
//! | [`Relighter::set_lighting`] | a new environment: prefilter and build the lighting table ([`crate::lighting`]); a rotation (`world_from_env`) with `twists > 1`: nothing (a lookup change); with `twists = 1`: rebuild |
//! | [`Relighter::render`] | rasterize at `aa × aa`, then per pixel ([`Shading::Pixel`]: the lighting looked up in the pixel's own frame from the interpolated normal, the vertices' visibility interpolated, the BRDF at the pixel's view) or per vertex ([`Shading::Vertex`], Gouraud, the paper's Fig. 5 comparison) |
//!
//! # Selection
//! By default the renderer keeps the first `terms = 20·4^m` coefficients
//! (top-only, the paper's GPU choice): every function is stored as its
//! `20·4^m` cell averages and shaded per pixel. [`Selection::Adaptive`]
//! keeps each function's `terms` largest area-weighted terms instead
//! ([`crate::adaptive`]): it reads the 5120-cell tables, so it shades per
//! vertex ([`Shading::Vertex`]) with the isotropic lighting table
//! (`twists = 1`), and says so as an error otherwise.

use crate::adaptive::{ADAPTIVE_LEVEL, select_visibility, shade_adaptive};
use crate::basis::{Basis, triangles};
use crate::brdf_table::BrdfTable;
use crate::cache::{self, BRDF_MAGIC, VIS_MAGIC, bake_or_load, hash_parts};
use crate::interpolated::{ObjectFunctions, TriangleTables};
use crate::lighting::{LightTable, frame_of, prefilter};
use crate::medium::FoggyLighting;
use crate::quadrature::{LeafGrid, Weighting};
use crate::select::Selection;
use crate::shade::{
    BYTES_PER_CELL, FMA_PER_CELL, FMA_PER_CELL_INTERPOLATED, FMA_PER_VERTEX_CELL, shade_point,
};
use crate::storage::{Planes, Storage};
use crate::visibility::{bake_point_visibility, bake_vertex_visibility};
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_render::method::{
    FrameRequest, FrameWork, MethodError, ObjectRaster, Relighter, Rendered, SceneFeature, Support,
    check_scene,
};
use relight_render::raster::Background;
use relight_render::{Image, Numbered, Progress, Scene, SceneBvh};
use relight_sphere::{EnvMap, Frame};
use relight_wavelet::{CacheUse, WaveletError};
use serde::Serialize;
use std::borrow::Cow;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// The method's name on the command line.
pub const TRIPLE_METHOD_NAME: &str = "triple";

/// Where the product is evaluated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Shading {
    /// Per pixel, the lighting looked up from the pixel's own frame.
    #[default]
    Pixel,
    /// Per vertex, colours interpolated (Gouraud; Fig. 5).
    Vertex,
    /// Per pixel, Eq. 7 of the functions interpolated from the triangle's
    /// three vertices (§3.3's pseudocode: `L_p`, `V_p`, `ρ_p` by
    /// barycentric interpolation of the vertices' lighting looked up in the
    /// vertex frame and BRDF at the vertex's view). Cheaper per pixel than
    /// [`Shading::Pixel`] ([`crate::shade::FMA_PER_CELL_INTERPOLATED`]
    /// against [`FMA_PER_CELL`]); no bump mapping (the lighting frame is
    /// the vertices').
    Interpolated,
}

impl Shading {
    /// The name on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Pixel => "pixel",
            Self::Vertex => "vertex",
            Self::Interpolated => "interpolated",
        }
    }
}

impl std::str::FromStr for Shading {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "pixel" => Ok(Self::Pixel),
            "vertex" => Ok(Self::Vertex),
            "interpolated" => Ok(Self::Interpolated),
            o => Err(format!(
                "unknown shading {o:?}: use pixel, interpolated or vertex"
            )),
        }
    }
}

/// Settings of [`TripleMethod`]; `Default` holds the defaults (the one place
/// they live).
#[derive(Clone, Debug, PartialEq)]
pub struct TripleOptions {
    /// Coefficients kept: `20·4^m`, m = 0..=4 (20, 80, 320, 1280, 5120). Default 320.
    pub terms: usize,
    /// Coefficient selection. Default top-only (adaptive: verify only).
    pub selection: Selection,
    /// Twist bins of the lighting table (1 = isotropic 642-normal table,
    /// rebuilt per rotation). Default 16.
    pub twists: usize,
    /// θ rows of the BRDF view grid (φ columns = 2×). Default 32.
    pub brdf_views: usize,
    /// Sub-levels of the BRDF quadrature below the level-4 leaves. Default 1.
    pub brdf_sub: usize,
    /// Solid-angle weighting of the BRDF term. Default exact.
    pub weighting: Weighting,
    /// Icosahedral level of the visibility rays (≥ m; 4 = 5120 directions). Default 4.
    pub vis_level: usize,
    /// Per pixel or per vertex. Default per pixel.
    pub shading: Shading,
    /// Where bakes are cached. Default [`cache::default_cache_dir`].
    pub cache_dir: PathBuf,
    /// How the tables are kept ([`crate::storage`]). Default compact
    /// (lighting f16, BRDF and visibility 8-bit: the storage, within
    /// its budgets; `relight verify triple` reports what it costs against
    /// f32).
    pub storage: Storage,
    /// Texels per side of each object's visibility texture over its uvs
    /// ([`crate::vis_texture`]); 0 keeps visibility per vertex. Objects
    /// without uvs stay per vertex (with a warning). Default 0.
    pub visibility_texture: usize,
    /// Without a visibility texture, shade objects too coarse for
    /// per-vertex visibility (a ground quad) on a refined copy
    /// ([`Scene::with_coarse_objects_refined`], with a warning); off: warn
    /// only (verify's Fig. 6 row shows the coarse floor as given). Default on.
    pub refine_coarse: bool,
}

impl Default for TripleOptions {
    fn default() -> Self {
        Self {
            terms: 320,
            selection: Selection::Top,
            twists: 16,
            brdf_views: 32,
            brdf_sub: 1,
            weighting: Weighting::Exact,
            vis_level: 4,
            shading: Shading::Pixel,
            cache_dir: cache::default_cache_dir(),
            storage: Storage::Compact,
            visibility_texture: 0,
            refine_coarse: true,
        }
    }
}

impl TripleOptions {
    /// The top-only level `m` of `terms` (`terms = 20·4^m`), if valid.
    #[must_use]
    pub fn level(&self) -> Option<usize> {
        (0..=4).find(|&m| triangles(m) == self.terms)
    }
}

/// One object's prepared data.
struct Prepared {
    /// The mesh shaded: the scene's, or a coarse object's refined copy
    /// ([`Scene::with_coarse_objects_refined`]).
    mesh: Arc<Mesh>,
    /// The scene's mesh, which later calls must still have.
    source: Arc<Mesh>,
    brdf: Arc<BrdfTable>,
    /// The spatially varying blend: the second BRDF's table and the weight.
    blend: Option<(Arc<BrdfTable>, relight_render::BrdfBlend)>,
    vis: Option<Arc<Planes>>,
    /// Side of the visibility texture `vis` holds (0: one row per vertex).
    vis_res: usize,
    /// The texture's uvs per triangle corner and per vertex (its own uvs,
    /// or packed charts: [`crate::vis_texture::Charts`]), with a texture.
    vis_uvs: Option<Arc<(crate::vis_texture::Charts, Vec<glam::Vec2>)>>,
    /// Adaptive selection: each vertex's visibility cut to `terms` terms.
    vis_sparse: Option<Arc<Vec<crate::select::SparseVec>>>,
    /// The object's normal map (bump mapping; the mesh has uvs and tangents).
    normal_map: Option<Arc<relight_render::NormalMap>>,
}

/// Triple-product relighting as a [`Relighter`] (module docs).
pub struct TripleMethod {
    options: TripleOptions,
    m: usize,
    grid: Option<LeafGrid>,
    brdfs: Vec<(String, Arc<BrdfTable>)>,
    objects: Vec<Prepared>,
    /// The prefiltered environment (foggy in a medium) and the hash of the
    /// source and medium it came from.
    env: Option<(u64, EnvMap)>,
    /// The scene's medium as lighting ([`crate::medium`]), when it has one.
    fog: Option<FoggyLighting>,
    table: Option<LightTable>,
    world_from_env: Mat3,
    /// The visibility buffer, kept while the camera and meshes are (a
    /// lighting turn shades it again).
    view: ObjectRaster,
    colors: Vec<Vec<Vec3>>,
    /// Per object, the vertices' functions of [`Shading::Interpolated`].
    vertex_fns: Vec<VertexFunctions>,
    /// The covered triangles' tensors of [`Shading::Interpolated`].
    triangle_tables: TriangleTables,
    pending_lighting_ms: f64,
    loads: usize,
    bakes: usize,
    table_builds: usize,
    warnings: Vec<String>,
}

impl std::fmt::Debug for TripleMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TripleMethod")
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

fn invalid(option: &'static str, message: impl ToString) -> MethodError {
    MethodError::InvalidOption {
        method: TRIPLE_METHOD_NAME,
        option,
        message: message.to_string(),
    }
}

fn fail(e: WaveletError) -> MethodError {
    MethodError::failed(TRIPLE_METHOD_NAME, e)
}

fn stale(why: &str) -> MethodError {
    invalid("scene", why)
}

fn mesh_bytes(m: &Mesh) -> Vec<f32> {
    let mut v: Vec<f32> = m.positions.iter().flat_map(|p| p.to_array()).collect();
    v.extend(m.normals.iter().flat_map(|p| p.to_array()));
    v.extend(m.indices.iter().flat_map(|t| t.map(|i| i as f32)));
    v
}

impl TripleMethod {
    /// A method with `options` (checked here; nothing is baked before `prepare`).
    ///
    /// # Errors
    /// [`MethodError::InvalidOption`] naming the option.
    pub fn new(options: TripleOptions) -> Result<Self, MethodError> {
        let m = if options.selection == Selection::Adaptive {
            Self::check_adaptive(&options)?;
            ADAPTIVE_LEVEL
        } else {
            options.level().ok_or_else(|| {
                invalid(
                    "terms",
                    format!(
                        "must be 20·4^m: 20, 80, 320, 1280 or 5120 (complete levels, top-only), \
                         got {}",
                        options.terms
                    ),
                )
            })?
        };
        if !(1..=64).contains(&options.twists) {
            return Err(invalid(
                "twists",
                format!("must be 1..=64, got {}", options.twists),
            ));
        }
        if !(2..=128).contains(&options.brdf_views) {
            return Err(invalid(
                "brdf-views",
                format!("must be 2..=128, got {}", options.brdf_views),
            ));
        }
        if options.brdf_sub > 3 {
            return Err(invalid(
                "brdf-sub",
                format!("must be 0..=3, got {}", options.brdf_sub),
            ));
        }
        if options.visibility_texture > crate::vis_texture::MAX_RES {
            return Err(invalid(
                "visibility-texture",
                format!(
                    "texels per side must be ≤ {} (got {})",
                    crate::vis_texture::MAX_RES,
                    options.visibility_texture
                ),
            ));
        }
        if !(m..=5).contains(&options.vis_level) {
            return Err(invalid(
                "vis-level",
                format!(
                    "must be {m}..=5 (at least the level of terms), got {}",
                    options.vis_level
                ),
            ));
        }
        Ok(Self {
            options,
            m,
            grid: None,
            brdfs: Vec::new(),
            objects: Vec::new(),
            env: None,
            fog: None,
            table: None,
            world_from_env: Mat3::IDENTITY,
            view: ObjectRaster::new(),
            colors: Vec::new(),
            vertex_fns: Vec::new(),
            triangle_tables: TriangleTables::default(),
            pending_lighting_ms: 0.0,
            loads: 0,
            bakes: 0,
            table_builds: 0,
            warnings: Vec::new(),
        })
    }

    /// What adaptive selection needs ([`crate::adaptive`]): per-vertex
    /// shading, the isotropic lighting table, visibility per vertex.
    fn check_adaptive(o: &TripleOptions) -> Result<(), MethodError> {
        let leaves = triangles(ADAPTIVE_LEVEL);
        if !(1..=leaves).contains(&o.terms) {
            return Err(invalid(
                "terms",
                format!(
                    "adaptive selection keeps 1..={leaves} terms, got {}",
                    o.terms
                ),
            ));
        }
        if o.shading != Shading::Vertex {
            return Err(invalid(
                "select",
                "adaptive selection shades per vertex (each vertex cuts its own 5120-term \
                 functions): add --shading vertex",
            ));
        }
        if o.twists != 1 {
            return Err(invalid(
                "twists",
                format!(
                    "adaptive selection reads the 5120-cell lighting table, which with {} twists \
                     would hold {} MB: use --twists 1 (a rotation rebuilds it)",
                    o.twists,
                    642 * o.twists * 3 * leaves * 4 / 1_000_000
                ),
            ));
        }
        if o.visibility_texture > 0 {
            return Err(invalid(
                "visibility-texture",
                "adaptive selection keeps visibility per vertex",
            ));
        }
        Ok(())
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &TripleOptions {
        &self.options
    }

    /// Bakes loaded from the cache, bakes computed, lighting tables built.
    #[must_use]
    pub fn counts(&self) -> (usize, usize, usize) {
        (self.loads, self.bakes, self.table_builds)
    }

    /// Pixels the last frame covered.
    #[must_use]
    pub fn covered_pixels(&self) -> usize {
        self.view.raster().gbuffer().covered_pixels()
    }

    /// The lighting table, once lit.
    #[must_use]
    pub fn table(&self) -> Option<&LightTable> {
        self.table.as_ref()
    }

    fn brdf_table(
        &mut self,
        brdf: &dyn relight_brdf::Brdf,
        progress: &dyn Progress,
    ) -> Result<Arc<BrdfTable>, MethodError> {
        let key = brdf.label();
        if let Some((_, t)) = self.brdfs.iter().find(|(k, _)| *k == key) {
            return Ok(t.clone());
        }
        progress.check()?;
        let o = &self.options;
        let views = o.brdf_views;
        let cells = crate::lighting::padded_cells(self.m);
        let len = views * 2 * views * 3 * cells;
        let weighting = o.weighting;
        let p = cache::params(
            self.m as u32,
            views as u32,
            u32::from(weighting == Weighting::Paper),
            o.brdf_sub as u32,
            hash_parts(&[key.as_bytes()]),
            len,
        );
        if self.grid.as_ref().is_none_or(|g| g.sub() != o.brdf_sub) {
            self.grid = Some(
                LeafGrid::new(Basis::paper(), o.brdf_sub).map_err(|e| invalid("brdf-sub", e))?,
            );
        }
        let grid = self.grid.as_ref().expect("just built");
        let m = self.m;
        let (data, used) = bake_or_load(&o.cache_dir, "brdf", BRDF_MAGIC, p, || {
            Ok::<_, WaveletError>(BrdfTable::bake(brdf, grid, m, views, weighting).into_values())
        })
        .map_err(fail)?;
        let t = Arc::new(BrdfTable {
            m,
            views,
            stride: cells,
            data: Planes::scaled(data, cells, o.storage.brdf_u8()),
        });
        self.count(&used);
        self.brdfs.push((key, t.clone()));
        Ok(t)
    }

    /// Counts a load or a bake; a replaced cache file is also a warning.
    fn count(&mut self, used: &CacheUse) {
        if used.loaded() {
            self.loads += 1;
        } else {
            self.bakes += 1;
        }
        self.warnings
            .extend(used.warning(&format!("method {TRIPLE_METHOD_NAME}")));
    }

    /// Rebakes one material's BRDF table (a material edit): drops the
    /// in-memory table of `old`'s description so the next `prepare` bakes
    /// the object's new BRDF, touching nothing else.
    pub fn forget_brdf(&mut self, old: &dyn relight_brdf::Brdf) {
        let key = format!("{old:?}");
        self.brdfs.retain(|(k, _)| *k != key);
    }

    fn lookup_rotation(&self) -> Mat3 {
        // G = (S Rᵀ) F_x with S the table's space_from_env (lighting docs).
        let s = self.table.as_ref().map_or(Mat3::IDENTITY, |t| t.built_for);
        s * self.world_from_env.transpose()
    }
}

/// The bumped normal at `uv` (the map's tangent-space normal in the frame of
/// `n` and `tangent`, `NormalMap::perturb`); `None` where the map is flat
/// (+Z): the pixel shades exactly as without the map.
#[inline]
fn bumped(
    map: &relight_render::NormalMap,
    n: Vec3,
    tangent: glam::Vec4,
    uv: glam::Vec2,
) -> Option<Vec3> {
    let m = map.sample(uv);
    if m.x == 0.0 && m.y == 0.0 {
        return None;
    }
    Some(map.perturb(n, tangent, uv))
}

/// The visibility texture's rows: texels far from every chart (never read)
/// hold `V ≡ 1` ([`crate::vis_texture`]).
fn bake_texel_visibility(
    bvh: &SceneBvh,
    points: &[Option<(Vec3, Vec3)>],
    m: usize,
    vis_level: usize,
    progress: &dyn Progress,
) -> Result<Vec<f32>, WaveletError> {
    let covered: Vec<(Vec3, Vec3)> = points.iter().flatten().copied().collect();
    let baked = bake_point_visibility(bvh, &covered, m, vis_level, progress)?;
    let stride = baked.stride;
    let mut out = vec![1.0f32; points.len() * stride];
    let mut k = 0;
    for (i, p) in points.iter().enumerate() {
        if p.is_some() {
            out[i * stride..(i + 1) * stride]
                .copy_from_slice(&baked.values[k * stride..(k + 1) * stride]);
            k += 1;
        }
    }
    Ok(out)
}

fn is_rotation(m: Mat3) -> bool {
    let e = (m.transpose() * m - Mat3::IDENTITY).to_cols_array();
    m.is_finite() && e.iter().all(|x| x.abs() < 1e-4) && (m.determinant() - 1.0).abs() < 1e-4
}

/// Which product a point is shaded with, and its visibility.
#[derive(Clone, Copy)]
enum Product<'a> {
    /// The top-only kernel ([`shade_point`]) with the visibility rows and
    /// weights (`None`: V ≡ 1).
    TopOnly(Option<(&'a Planes, [usize; 4], [f32; 4])>),
    /// Adaptive selection of `n` terms ([`crate::adaptive`]) with the
    /// vertex's selected visibility.
    Adaptive(Option<&'a crate::select::SparseVec>, usize),
}

/// The lighting and BRDF table entries of a point with world normal `n`
/// seen from `to_eye` (the frame of `n` turned by the lighting rotation
/// `rot`; the view clamped just above the horizon).
#[inline]
fn point_taps(
    table: &LightTable,
    rot: Mat3,
    brdf: &BrdfTable,
    n: Vec3,
    to_eye: Vec3,
) -> ([crate::lighting::Tap; 6], [crate::lighting::Tap; 4]) {
    let f = frame_of(n);
    let mut wo = f.to_local(to_eye);
    if wo.z < 1e-4 {
        wo.z = 1e-4;
        wo = wo.normalize();
    }
    let g = Frame {
        x: rot * f.x,
        y: rot * f.y,
        z: rot * f.z,
    };
    (table.lookup(&g), brdf.lookup(wo))
}

/// A pixel's visibility rows and weights in object `p` (`None`: V ≡ 1):
/// four texels of its visibility texture, or its triangle's three vertices,
/// at barycentrics `l` of triangle `triangle`; rows of `stride` cells.
#[inline]
fn pixel_visibility(
    p: &Prepared,
    triangle: usize,
    l: Vec3,
    stride: usize,
) -> Option<(&Planes, [usize; 4], [f32; 4])> {
    p.vis.as_ref().map(|v| {
        if let (true, Some(c)) = (p.vis_res > 0, &p.vis_uvs) {
            let (t, w) = crate::vis_texture::taps(c.0.uv(triangle, l), p.vis_res);
            (v.as_ref(), t.map(|t| t * stride), w)
        } else {
            let [a, b, c] = p.mesh.indices[triangle].map(|i| i as usize * stride);
            (v.as_ref(), [a, b, c, a], [l.x, l.y, l.z, 0.0])
        }
    })
}

/// The f32 rows of `planes`, `len` long (made f32 if it was not).
fn f32_rows(planes: &mut Planes, len: usize) -> &mut Vec<f32> {
    if !matches!(planes, Planes::F32(_)) {
        *planes = Planes::default();
    }
    let Planes::F32(v) = planes else {
        unreachable!("made f32 just above")
    };
    v.resize(len, 0.0);
    v
}

/// Computes object `p`'s vertex functions (the lighting looked up in each
/// vertex's frame, each BRDF at the vertex's view from `eye`) into `fns`.
/// Every BRDF table of the method has the same view grid, so one set of
/// BRDF taps serves both tables of a blend.
fn vertex_functions(
    table: &LightTable,
    rot: Mat3,
    p: &Prepared,
    eye: Vec3,
    fns: &mut VertexFunctions,
) {
    let padded = table.padded;
    let row = 3 * padded;
    let len = p.mesh.positions.len() * row;
    let light = f32_rows(&mut fns.light, len);
    let brdf = f32_rows(&mut fns.brdf, len);
    let second = match &p.blend {
        Some(_) => Some(f32_rows(
            fns.second.get_or_insert_with(Planes::default),
            len,
        )),
        None => {
            fns.second = None;
            None
        }
    };
    let used = &fns.used;
    let one = |v: usize, l: &mut [f32], b: &mut [f32]| {
        if !used[v] {
            return None;
        }
        let n = p.mesh.normals[v];
        let to_eye = (eye - p.mesh.positions[v]).normalize_or(n);
        let (lt, bt) = point_taps(table, rot, &p.brdf, n, to_eye);
        crate::shade::blend_function(&table.data, &lt, table.stride, padded, l);
        crate::shade::blend_function(&p.brdf.data, &bt, p.brdf.stride, padded, b);
        Some(bt)
    };
    fns.vis.clear();
    if let (Some(v), 0) = (&p.vis, p.vis_res) {
        fns.vis.resize(p.mesh.positions.len() * padded, 0.0);
        fns.vis
            .par_chunks_mut(padded)
            .enumerate()
            .with_min_len(256)
            .for_each(|(i, out)| {
                let tap = crate::lighting::Tap {
                    offset: (i * padded) as u32,
                    weight: 1.0,
                };
                crate::shade::blend_function(v, &[tap], padded, padded, out);
            });
    }
    let rows = light.par_chunks_mut(row).zip(brdf.par_chunks_mut(row));
    match (second, &p.blend) {
        (Some(second), Some((table2, _))) => rows
            .zip(second.par_chunks_mut(row))
            .enumerate()
            .with_min_len(64)
            .for_each(|(v, ((l, b), b2))| {
                if let Some(bt) = one(v, l, b) {
                    crate::shade::blend_function(&table2.data, &bt, table2.stride, padded, b2);
                }
            }),
        _ => rows.enumerate().with_min_len(64).for_each(|(v, (l, b))| {
            one(v, l, b);
        }),
    }
}

/// Marks, per object, the vertices of the triangles `triangle_ids` (the
/// G-buffer's global ids, objects' triangles numbered in order) shows.
fn mark_used_vertices(triangle_ids: &[u32], objects: &[Prepared], fns: &mut [VertexFunctions]) {
    let mut offsets = Vec::with_capacity(objects.len() + 1);
    let mut total = 0usize;
    for (p, f) in objects.iter().zip(fns.iter_mut()) {
        offsets.push(total);
        total += p.mesh.indices.len();
        f.used.clear();
        f.used.resize(p.mesh.positions.len(), false);
    }
    offsets.push(total);
    let mut last = usize::MAX;
    for &id in triangle_ids {
        let id = id as usize;
        if id >= total || id == last {
            continue;
        }
        last = id;
        let d = offsets.partition_point(|&o| o <= id) - 1;
        for v in objects[d].mesh.indices[id - offsets[d]] {
            fns[d].used[v as usize] = true;
        }
    }
}

/// One object's vertex functions for [`Shading::Interpolated`]: per vertex,
/// three channel planes of `padded` cells (f32), of the lighting and of each
/// BRDF (the second: a spatially varying blend's).
#[derive(Default)]
struct VertexFunctions {
    light: Planes,
    brdf: Planes,
    second: Option<Planes>,
    /// Per-vertex visibility decoded to f32 (`padded` cells per vertex;
    /// empty without per-vertex visibility).
    vis: Vec<f32>,
    /// The vertices of the triangles the frame shows: only their functions
    /// are computed (the others' rows are stale and never read).
    used: Vec<bool>,
}

impl VertexFunctions {
    /// The object's functions for [`TriangleTables`], when its visibility
    /// is per vertex (or absent).
    fn tables_input<'a>(&'a self, p: &'a Prepared) -> Option<ObjectFunctions<'a>> {
        let f32s = |planes: &'a Planes| match planes {
            Planes::F32(v) => &v[..],
            _ => &[],
        };
        (p.vis_res == 0).then(|| ObjectFunctions {
            indices: &p.mesh.indices,
            light: f32s(&self.light),
            brdf: f32s(&self.brdf),
            second: self.second.as_ref().map(f32s),
            vis: p.vis.is_some().then_some(&self.vis[..]),
        })
    }
}

/// Shades one point: world normal `n`, to-eye `to_eye`, by `product`.
#[inline]
fn shade_world(
    table: &LightTable,
    rot: Mat3,
    brdf: &BrdfTable,
    n: Vec3,
    to_eye: Vec3,
    product: Product,
) -> Vec3 {
    let (lt, bt) = point_taps(table, rot, brdf, n, to_eye);
    match product {
        Product::TopOnly(vis) => shade_point(
            &table.data,
            &lt,
            &brdf.data,
            &bt,
            vis,
            table.stride,
            table.padded,
        ),
        Product::Adaptive(vis, terms) => shade_adaptive(table, &lt, brdf, &bt, vis, terms),
    }
}

/// [`shade_world`] with the object's BRDF blend: by linearity of Eq. 7 in
/// the BRDF, `(1 − w) B(ρ₁) + w B(ρ₂)` with `w` the weight texture at the uv.
#[inline]
fn shade_blended(
    table: &LightTable,
    rot: Mat3,
    p: &Prepared,
    n: Vec3,
    to_eye: Vec3,
    vis: Product,
    uv: impl Fn() -> glam::Vec2,
) -> Vec3 {
    let Some((second, blend)) = &p.blend else {
        return shade_world(table, rot, &p.brdf, n, to_eye, vis);
    };
    let w = blend.weight_at(uv());
    let a = if w < 1.0 {
        shade_world(table, rot, &p.brdf, n, to_eye, vis)
    } else {
        Vec3::ZERO
    };
    let b = if w > 0.0 {
        shade_world(table, rot, second, n, to_eye, vis)
    } else {
        Vec3::ZERO
    };
    a * (1.0 - w) + b * w
}

impl Relighter for TripleMethod {
    fn name(&self) -> &'static str {
        TRIPLE_METHOD_NAME
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            // The medium by the thesis' model (§3.6.5 on §3.6.4's), whose
            // approximations are this method's error, as for `fog`.
            SceneFeature::Environment | SceneFeature::Visibility | SceneFeature::Medium => {
                Support::Full
            }
            SceneFeature::PointLights
            | SceneFeature::AreaLights
            | SceneFeature::LightFields
            | SceneFeature::Animation => Support::No,
            SceneFeature::NormalMaps => match self.options.shading {
                Shading::Pixel => Support::Full,
                Shading::Vertex | Shading::Interpolated => Support::No,
            },
            SceneFeature::SpatiallyVaryingBrdf => Support::Full,
        }
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        check_scene(self, scene, false)?;
        for (i, o) in scene.objects.iter().enumerate() {
            if o.mesh.normals.len() != o.mesh.positions.len() {
                return Err(invalid(
                    "scene",
                    format!(
                        "{} has no vertex normals (one per vertex is needed)",
                        Numbered::object(i)
                    ),
                ));
            }
            if o.blend.is_some() && o.mesh.uvs.len() != o.mesh.positions.len() {
                return Err(invalid(
                    "scene",
                    format!(
                        "{} blends two BRDFs by a texture but has no uvs",
                        Numbered::object(i)
                    ),
                ));
            }
            if o.normal_map.is_some()
                && (o.mesh.uvs.len() != o.mesh.positions.len()
                    || o.mesh.tangents.len() != o.mesh.positions.len())
            {
                return Err(invalid(
                    "scene",
                    format!(
                        "{} has a normal map but no uvs and tangents per vertex",
                        Numbered::object(i)
                    ),
                ));
            }
        }
        self.warnings.clear();
        if scene.visibility && scene.objects.iter().any(|o| o.normal_map.is_some()) {
            self.warnings.push(
                "triple: bump mapping looks the lighting up in the bumped frame while visibility \
                 stays the vertices' (the paper's approximation, §3.3)"
                    .into(),
            );
        }
        // Per-vertex visibility on a ground quad loses every shadow: without
        // a visibility texture, such objects are shaded on a refined copy
        // (and said); with one, an object it cannot cover is warned about
        // below.
        let given = scene;
        let (refined_scene, refined, coarse) = if !scene.visibility {
            (Cow::Borrowed(scene), Vec::new(), Vec::new())
        } else if self.options.visibility_texture == 0 && self.options.refine_coarse {
            scene.with_coarse_objects_refined()
        } else {
            (Cow::Borrowed(scene), Vec::new(), scene.coarse_objects())
        };
        let scene: &Scene = &refined_scene;
        for r in &refined {
            self.warnings.push(format!(
                "triple: visibility is sampled per vertex, and {}",
                r.describe()
            ));
        }
        let meshes: Vec<&Mesh> = scene.objects.iter().map(|o| o.mesh.as_ref()).collect();
        let scene_key: Vec<u64> = meshes
            .iter()
            .map(|m| hash_parts(&[bytemuck::cast_slice(&mesh_bytes(m))]))
            .collect();
        let mut bvh: Option<SceneBvh> = None;
        let same_scene =
            relight_render::method::same_meshes(self.objects.iter().map(|p| &p.source), given);
        let mut objects = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            let brdf = self.brdf_table(o.brdf.as_ref(), progress)?;
            let blend = match &o.blend {
                Some(b) => Some((self.brdf_table(b.second.as_ref(), progress)?, b.clone())),
                None => None,
            };
            // Keep visibility already held for the same meshes (all of
            // them: the others cast its shadows; the same scene meshes
            // refine to the same copies).
            let held = self
                .objects
                .get(i)
                .filter(|p| same_scene && p.vis.is_some() == scene.visibility);
            let res = self.options.visibility_texture;
            let charts = if res > 0 && scene.visibility {
                let c = crate::vis_texture::Charts::of(&o.mesh, res);
                if c.is_none() {
                    self.warnings.push(format!(
                        "triple: {} has no uvs and its {} triangles need a visibility \
                         texture of at least {} texels a side for one chart each: its \
                         visibility stays per vertex",
                        Numbered::object(i),
                        o.mesh.indices.len(),
                        crate::vis_texture::MIN_CELL
                            * (o.mesh.indices.len() as f64).sqrt().ceil() as usize
                    ));
                } else if o.mesh.uvs.len() != o.mesh.positions.len() {
                    self.warnings.push(format!(
                        "triple: {} has no uvs: its visibility texture uses one packed \
                         chart per triangle",
                        Numbered::object(i)
                    ));
                }
                c
            } else {
                None
            };
            let texels = charts
                .as_ref()
                .map(|c| crate::vis_texture::texel_points(&o.mesh, c, res));
            let vis_res = if texels.is_some() { res } else { 0 };
            if vis_res == 0
                && let Some(c) = coarse.iter().find(|c| c.object == i)
            {
                // Per-vertex visibility on a ground quad loses every shadow.
                self.warnings.push(format!(
                    "triple: visibility is sampled per vertex, and {}: shadows that fall \
                     between them are lost; pass --visibility-texture 128 (over its uvs) or give \
                     it a finer mesh",
                    c.describe()
                ));
            }
            let vis = if !scene.visibility {
                None
            } else if let Some(p) = held.filter(|p| p.vis_res == vis_res) {
                p.vis.clone()
            } else {
                let stride = crate::lighting::padded_cells(self.m);
                let key =
                    hash_parts(&[bytemuck::cast_slice(&scene_key), &(i as u64).to_le_bytes()]);
                let (m, vl) = (self.m, self.options.vis_level);
                let (values, used) = match &texels {
                    None => {
                        let len = o.mesh.positions.len() * stride;
                        let p = cache::params(m as u32, vl as u32, 0, 0, key, len);
                        bake_or_load(&self.options.cache_dir, "vis", VIS_MAGIC, p, || {
                            let b = bvh.get_or_insert_with(|| SceneBvh::build(&meshes));
                            bake_vertex_visibility(b, i, m, vl, progress)
                                .map(|v| v.values)
                                .map_err(WaveletError::from)
                        })
                    }
                    Some(points) => {
                        let len = points.len() * stride;
                        let uvs = charts.as_ref().map(|c| c.key_bytes()).unwrap_or_default();
                        let key = hash_parts(&[&key.to_le_bytes(), &uvs]);
                        let p = cache::params(m as u32, vl as u32, res as u32, 1, key, len);
                        bake_or_load(&self.options.cache_dir, "vistex", VIS_MAGIC, p, || {
                            let b = bvh.get_or_insert_with(|| SceneBvh::build(&meshes));
                            bake_texel_visibility(b, points, m, vl, progress)
                        })
                    }
                }
                .map_err(fail)?;
                self.count(&used);
                Some(Arc::new(Planes::scaled(
                    values,
                    stride,
                    self.options.storage.visibility_u8(),
                )))
            };
            objects.push(Prepared {
                mesh: o.mesh.clone(),
                source: given.objects[i].mesh.clone(),
                brdf,
                blend,
                vis_sparse: match (&vis, self.options.selection) {
                    (Some(v), Selection::Adaptive) => Some(Arc::new(select_visibility(
                        v,
                        o.mesh.positions.len(),
                        crate::lighting::padded_cells(self.m),
                        self.options.terms,
                    ))),
                    _ => None,
                },
                vis,
                vis_res,
                vis_uvs: charts.map(|c| {
                    let v = c.vertex_uvs(&o.mesh);
                    Arc::new((c, v))
                }),
                normal_map: o.normal_map.clone(),
            });
        }
        self.objects = objects;
        self.colors.clear();
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let t = Instant::now();
        if !is_rotation(scene.world_from_env) {
            return Err(invalid(
                "world_from_env",
                format!("{:?} is not a rotation", scene.world_from_env),
            ));
        }
        progress.check()?;
        let medium = scene.medium.filter(|m| m.beta > 0.0);
        // The map's fingerprint (word-wise, in streams): a byte-wise hash of
        // the default scene's map cost about 3 ms of every rotation.
        let h = scene.env.fingerprint()
            ^ medium.map_or(0, |m| {
                hash_parts(&[bytemuck::cast_slice(&[m.beta, m.albedo, m.radius])])
            });
        if self.env.as_ref().is_none_or(|(k, _)| *k != h) {
            let pre = prefilter(&scene.env, self.m);
            self.fog = match medium {
                Some(m) => Some(
                    FoggyLighting::new(&scene.env, &m)
                        .map_err(|e| MethodError::failed(TRIPLE_METHOD_NAME, e))?,
                ),
                None => None,
            };
            let pre = match &self.fog {
                Some(f) => f.fog_map(&pre),
                None => pre,
            };
            self.env = Some((h, pre));
            self.table = None;
        }
        let twists = self.options.twists;
        let rebuild = match &self.table {
            None => true,
            Some(t) => twists == 1 && t.built_for != scene.world_from_env,
        };
        self.world_from_env = scene.world_from_env;
        if rebuild {
            let env = &self.env.as_ref().expect("set above").1;
            let space = if twists == 1 {
                scene.world_from_env
            } else {
                Mat3::IDENTITY
            };
            self.table = Some(
                LightTable::build(env, space, self.m, twists).with_storage(self.options.storage),
            );
            self.table_builds += 1;
        }
        self.colors.clear();
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
        request.validate(TRIPLE_METHOD_NAME)?;
        let t0 = Instant::now();
        let same =
            relight_render::method::same_meshes(self.objects.iter().map(|p| &p.source), scene);
        if !same {
            return Err(stale(
                "the objects changed since `prepare`; call prepare again",
            ));
        }
        let table = self
            .table
            .as_ref()
            .ok_or_else(|| stale("call prepare before render"))?;
        progress.check()?;
        let k = request.aa;
        // The shaded meshes: a coarse object's refined copy, not the scene's.
        let meshes: Vec<&Arc<Mesh>> = self.objects.iter().map(|p| &p.mesh).collect();
        let (camera, draws) = self
            .view
            .draw_meshes(&meshes, request)
            .map_err(|e| invalid("raster", e))?;
        let env = &scene.env;
        let env_from_world = scene.world_from_env.transpose();
        let fog = self.fog.as_ref();
        let eye = camera.eye;
        let bg = |d: Vec3| match fog {
            Some(f) => f.background(env, eye, d, env_from_world * d),
            None => env.eval(env_from_world * d),
        };
        // In a medium the foggy sky is the method's own (`render_frame`
        // fills no background then).
        let background = if k > 1 || fog.is_some() {
            Background::Environment(&bg)
        } else {
            Background::Color(Vec3::ZERO)
        };
        // Surface radiance `c` at `p` with normal `n` through the medium.
        let segment = |c: Vec3, p: Vec3, n: Vec3| match fog {
            Some(f) => {
                let t = (p - eye).length();
                if t > 0.0 {
                    f.segment(c, n, eye, (p - eye) / t, t)
                } else {
                    c
                }
            }
            None => c,
        };
        let rot = self.lookup_rotation();
        let objects = &self.objects;
        let stride = table.padded;
        // Shaded straight into the frame handed out (each pass writes every
        // pixel of a new image: no zero-fill, no copy).
        let mut frame = Image::new(0, 0);
        match self.options.shading {
            Shading::Pixel => {
                self.view
                    .raster()
                    .shade(
                        &draws,
                        |frag| {
                            let p = &objects[frag.draw as usize];
                            let tri = p.mesh.indices[frag.triangle as usize];
                            let l = frag.barycentrics;
                            let nrm = &p.mesh.normals;
                            let mut n = (nrm[tri[0] as usize] * l.x
                                + nrm[tri[1] as usize] * l.y
                                + nrm[tri[2] as usize] * l.z)
                                .normalize_or(frag.normal);
                            let uv = || {
                                let u = &p.mesh.uvs;
                                u[tri[0] as usize] * l.x
                                    + u[tri[1] as usize] * l.y
                                    + u[tri[2] as usize] * l.z
                            };
                            let vis = pixel_visibility(p, frag.triangle as usize, l, stride);
                            if let Some(map) = &p.normal_map {
                                let t = &p.mesh.tangents;
                                let tangent = t[tri[0] as usize] * l.x
                                    + t[tri[1] as usize] * l.y
                                    + t[tri[2] as usize] * l.z;
                                if let Some(b) = bumped(map, n, tangent, uv()) {
                                    // The reference's convention: a bumped
                                    // normal facing away from the viewer
                                    // shades black.
                                    if b.dot(frag.to_eye) <= 0.0 {
                                        return segment(Vec3::ZERO, frag.position, n);
                                    }
                                    n = b;
                                }
                            }
                            segment(
                                shade_blended(
                                    table,
                                    rot,
                                    p,
                                    n,
                                    frag.to_eye,
                                    Product::TopOnly(vis),
                                    uv,
                                ),
                                frag.position,
                                n,
                            )
                        },
                        background,
                        &mut frame,
                    )
                    .map_err(|e| invalid("raster", e))?;
            }
            Shading::Interpolated => {
                let row = 3 * stride;
                self.vertex_fns
                    .resize_with(objects.len(), VertexFunctions::default);
                mark_used_vertices(
                    &self.view.raster().gbuffer().triangle,
                    objects,
                    &mut self.vertex_fns,
                );
                for (p, fns) in objects.iter().zip(&mut self.vertex_fns) {
                    vertex_functions(table, rot, p, eye, fns);
                }
                let fns = &self.vertex_fns;
                let inputs: Vec<Option<ObjectFunctions>> = objects
                    .iter()
                    .zip(fns)
                    .map(|(p, f)| f.tables_input(p))
                    .collect();
                self.triangle_tables
                    .build(&self.view.raster().gbuffer().triangle, &inputs, stride);
                let tables = &self.triangle_tables;
                self.view
                    .raster()
                    .shade(
                        &draws,
                        |frag| {
                            let p = &objects[frag.draw as usize];
                            let f = &fns[frag.draw as usize];
                            let tri = p.mesh.indices[frag.triangle as usize];
                            let l = frag.barycentrics;
                            let (d, t) = (frag.draw as usize, frag.triangle as usize);
                            if let Some(c) = tables.shade(d, t, l, false) {
                                let c = match &p.blend {
                                    Some((_, blend)) => {
                                        let u = &p.mesh.uvs;
                                        let uv = u[tri[0] as usize] * l.x
                                            + u[tri[1] as usize] * l.y
                                            + u[tri[2] as usize] * l.z;
                                        let w = blend.weight_at(uv);
                                        let c2 = tables.shade(d, t, l, true).unwrap_or(Vec3::ZERO);
                                        c * (1.0 - w) + c2 * w
                                    }
                                    None => c,
                                };
                                return segment(c, frag.position, frag.normal);
                            }
                            let mut lt = [crate::lighting::Tap::default(); 6];
                            let mut bt = [crate::lighting::Tap::default(); 4];
                            for (a, w) in [l.x, l.y, l.z].into_iter().enumerate() {
                                let tap = crate::lighting::Tap {
                                    offset: (tri[a] as usize * row) as u32,
                                    weight: w,
                                };
                                lt[a] = tap;
                                bt[a] = tap;
                            }
                            let vis = pixel_visibility(p, frag.triangle as usize, l, stride);
                            let shade = |brdf: &Planes| {
                                shade_point(&f.light, &lt, brdf, &bt, vis, stride, stride)
                            };
                            let c = match (&p.blend, &f.second) {
                                (Some((_, blend)), Some(second)) => {
                                    let u = &p.mesh.uvs;
                                    let uv = u[tri[0] as usize] * l.x
                                        + u[tri[1] as usize] * l.y
                                        + u[tri[2] as usize] * l.z;
                                    let w = blend.weight_at(uv);
                                    let a = if w < 1.0 { shade(&f.brdf) } else { Vec3::ZERO };
                                    let b = if w > 0.0 { shade(second) } else { Vec3::ZERO };
                                    a * (1.0 - w) + b * w
                                }
                                _ => shade(&f.brdf),
                            };
                            segment(c, frag.position, frag.normal)
                        },
                        background,
                        &mut frame,
                    )
                    .map_err(|e| invalid("raster", e))?;
            }
            Shading::Vertex => {
                let adaptive =
                    (self.options.selection == Selection::Adaptive).then_some(self.options.terms);
                self.colors = objects
                    .iter()
                    .map(|p| {
                        (0..p.mesh.positions.len())
                            .into_par_iter()
                            .with_min_len(64)
                            .map(|v| {
                                let n = p.mesh.normals[v];
                                let to_eye = (eye - p.mesh.positions[v]).normalize_or(n);
                                let vis = p.vis.as_ref().map(|vv| {
                                    if let (true, Some(c)) = (p.vis_res > 0, &p.vis_uvs) {
                                        let (t, w) = crate::vis_texture::taps(c.1[v], p.vis_res);
                                        (vv.as_ref(), t.map(|t| t * stride), w)
                                    } else {
                                        (vv.as_ref(), [v * stride; 4], [1.0, 0.0, 0.0, 0.0])
                                    }
                                });
                                let vis = match adaptive {
                                    Some(terms) => Product::Adaptive(
                                        p.vis_sparse.as_ref().map(|s| &s[v]),
                                        terms,
                                    ),
                                    None => Product::TopOnly(vis),
                                };
                                segment(
                                    shade_blended(table, rot, p, n, to_eye, vis, || p.mesh.uvs[v]),
                                    p.mesh.positions[v],
                                    n,
                                )
                            })
                            .collect()
                    })
                    .collect();
                let refs: Vec<&[Vec3]> = self.colors.iter().map(|c| &c[..]).collect();
                self.view
                    .raster()
                    .shade_gouraud(&draws, &refs, background, &mut frame)
                    .map_err(|e| invalid("raster", e))?;
            }
        }
        Ok(self.view.rendered(
            Cow::Owned(frame),
            k,
            std::mem::take(&mut self.pending_lighting_ms),
            t0,
        ))
    }

    /// Multiply-adds per cell ([`FMA_PER_CELL`] per pixel sample or vertex)
    /// × padded cells; interpolated: [`FMA_PER_VERTEX_CELL`] per vertex of a
    /// shown triangle and
    /// [`crate::interpolated::FMA_PER_TRIANGLE_CELL`] per built triangle per
    /// cell, [`crate::interpolated::FMA_PER_PIXEL`] per pixel of those
    /// triangles, [`FMA_PER_CELL_INTERPOLATED`] per cell for the others.
    fn frame_work(&self, scene: &Scene, request: &FrameRequest) -> Option<FrameWork> {
        let table = self.table.as_ref()?;
        let pixels = self.view.raster().gbuffer().covered_pixels();
        let vertices: usize = scene.objects.iter().map(|o| o.mesh.positions.len()).sum();
        let per_cell = match self.options.shading {
            Shading::Pixel => pixels * FMA_PER_CELL,
            Shading::Vertex => vertices * FMA_PER_CELL,
            Shading::Interpolated => {
                // Pixels of triangles with a tensor cost a fixed count;
                // the others (visibility textures) the per-cell kernel.
                let g = self.view.raster().gbuffer();
                let tensor_pixels = g
                    .triangle
                    .iter()
                    .filter(|&&t| self.triangle_tables.covers(t))
                    .count();
                let t = &self.triangle_tables;
                let fixed = tensor_pixels * crate::interpolated::FMA_PER_PIXEL;
                let vertices: usize = self
                    .vertex_fns
                    .iter()
                    .map(|f| f.used.iter().filter(|&&u| u).count())
                    .sum();
                return Some(FrameWork {
                    view_fma: (fixed
                        + ((pixels - tensor_pixels) * FMA_PER_CELL_INTERPOLATED
                            + t.built() * crate::interpolated::FMA_PER_TRIANGLE_CELL
                            + vertices * FMA_PER_VERTEX_CELL)
                            * table.padded) as f64,
                    lighting_fma: 0.0,
                });
            }
        };
        let _ = request;
        Some(FrameWork {
            view_fma: (per_cell * table.padded) as f64,
            lighting_fma: 0.0,
        })
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    fn data_bytes(&self) -> u64 {
        let t = self.table.as_ref().map_or(0, LightTable::bytes);
        let b: u64 = self.brdfs.iter().map(|(_, b)| b.bytes()).sum();
        let v: u64 = self
            .objects
            .iter()
            .filter_map(|p| p.vis.as_ref())
            .map(|v| v.bytes())
            .sum();
        t + b + v
    }
}

/// Bytes read per shaded point of `terms` coefficients kept in `storage`:
/// [`BYTES_PER_CELL`] per padded cell less what each compact table saves
/// (six lighting taps × RGB at 2 of 4 bytes, four BRDF taps × RGB and three
/// visibility rows at 3 of 4); under [`Shading::Interpolated`], three vertices' f32
/// lighting and BRDF functions (RGB) and the visibility rows.
#[must_use]
pub fn bytes_per_point(terms: usize, storage: Storage, shading: Shading) -> usize {
    let vis = if storage.visibility_u8() { 3 } else { 3 * 4 };
    let per_cell = match shading {
        // Three vertices' f32 lighting and BRDF functions, RGB.
        Shading::Interpolated => 3 * (3 + 3) * 4 + vis,
        Shading::Pixel | Shading::Vertex => {
            BYTES_PER_CELL
                - if storage.lighting_f16() { 3 * 6 * 2 } else { 0 }
                - if storage.brdf_u8() { 3 * 4 * 3 } else { 0 }
                - (3 * 4 - vis)
        }
    };
    per_cell * terms.div_ceil(8) * 8
}

/// The top-only level `m` of `terms = 20·4^m` (0 when not a level).
#[must_use]
pub fn level_of(terms: usize) -> usize {
    (0..=4).find(|&m| triangles(m) == terms).unwrap_or(0)
}
