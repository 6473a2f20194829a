//! [`ShExpMethod`]: soft shadows of dynamic blockers by SH exponentiation
//! behind the method interface ([`Relighter`], name `shexp`).
//!
//! # What it renders
//! Per receiver vertex `p` with normal `N` (thesis §5.2.4):
//! * **dynamic receivers** (objects with an animation at `prepare`):
//!   `L_H(N) · g`, `L_H(N) = L ∗ H(N)` read bilinearly from a table over
//!   normals (a corner-sampled octahedral grid of [`LH_TABLE_SIZE`]²), and
//!   `g = exp(Σ_b log g_b)` over the blocker spheres of every *other* object;
//!   a vertex its own object occludes ([`ShExpOptions::self_shadow`]) shades
//!   `L · (T_p ∗ g)` instead, `T_p` baked against its own mesh in its frame
//!   at `prepare` (as a static receiver's) and turned with it per frame (the
//!   thesis bakes only static receivers; a rigid object's own occlusion
//!   moves with it, so it bakes the same way);
//! * **static receivers**: `(L ∗ T_p) · g_dyn` with `T_p = H(N_p)·g_static`
//!   baked by ray tracing the static meshes (cosine-weighted stratified rays
//!   with the exact `H(N_p)` as control variate:
//!   `T_p = H(N_p) − (1/K) Σ_k [blocked_k] y(s_k)`, exact where nothing is
//!   blocked), and `g_dyn` the exponentiated logs of the dynamic blockers
//!   only.
//!
//! **Area lights** ([`crate::area`]): the scene's textured rectangles are
//! projected into SH per receiver point with the clamped cosine (and a
//! static receiver's static visibility) folded in, `F(p, N)`, and the
//! receiver adds `F · g`: a dynamic one projects `F` per frame, a static one
//! adds it to its lit transfer when a light changes.
//!
//! **Flat receivers** (a ground quad has too few vertices for a shadow): with
//! [`ShExpOptions::visibility_texture`] set, the plane is shaded at the texel
//! centres of a visibility texture and looked up per pixel
//! ([`crate::texels`]); otherwise one with fewer than
//! [`ShExpOptions::flat_receiver_vertices`] vertices is refined by midpoint
//! subdivision until it has at least that many, and the method shades and
//! draws the refined mesh (the same surface).
//!
//! Blockers are the sphere sets ([`crate::spheres`]) of every object that is
//! not flat (a flat object — smallest box extent under 1 % of its largest —
//! only receives). Each receiver object's vertices are grouped in clusters of
//! about [`ShExpOptions::cluster_vertices`]; per cluster and frame the
//! hierarchy of every other blocker is walked: a node whose largest possible
//! half-angle seen from the cluster is under `min_angle` is dropped, one
//! under `lod_angle` is used whole instead of its children (§5.2.4 culling),
//! as its proxy sphere ([`crate::spheres`]: it keeps the leaves' summed solid
//! angle), and per vertex a sphere entirely below the tangent plane is skipped.
//!
//! Blockers follow the scene's animated transforms: `render` takes the scene
//! at the frame's time ([`Scene::at_time`]); each dynamic object's similarity
//! transform since `prepare` is recovered from four reference vertices and
//! moves its spheres and clusters. A static object that moved is an error
//! (prepare again).
//!
//! Materials are shaded as diffuse: a Lambertian BRDF exactly; any other with
//! its normal-incidence albedo, and [`Relighter::warnings`] says so.

use crate::accumulate::{Scratch, add_blocker_log, mul_blocker_visibility, zonal_rotation_factors};
use crate::area::AreaLightSh;
use crate::exp::{ExpKind, Exponentiator, OlFit, SquaringHistogram};
use crate::lanes::{Lane, LaneBlocker, LaneKernel, LaneReceivers, LaneScratch, W};
use crate::log_table::LogTable;
use crate::shade::{irradiance_zonal, oct_decode, oct_encode};
use crate::spheres::{FitOptions, Sphere, SphereSet, fit_spheres};
use crate::texels::TexelGrid;
use glam::{Affine3A, Mat3, Vec3};
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_render::method::{
    FrameRequest, MethodError, Relighter, Rendered, SceneFeature, Support, check_scene,
};
use relight_render::raster::{Background, DrawCall, RasterOptions, Rasterizer};
use relight_render::{Image, Numbered, Progress, Rng, Scene, SceneBvh};
use relight_sh::product::TripleProduct;
use std::borrow::Cow;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// The method's name on the command line.
pub const SHEXP_METHOD_NAME: &str = "shexp";

/// Side of the `L_H(N)` table over normals.
pub const LH_TABLE_SIZE: usize = 33;

/// Largest SH order the method accepts.
pub const MAX_SHEXP_ORDER: usize = 8;

/// Most texels per side of a visibility texture (4096² receiver points).
pub const MAX_VISIBILITY_TEXTURE: usize = 4096;

/// Settings of [`ShExpMethod`]; `Default` holds the defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShExpOptions {
    /// SH bands n (2..=[`MAX_SHEXP_ORDER`]). Default 4 (the thesis' scenes).
    pub order: usize,
    /// The exponential, or product accumulation. Default PS*-2 (Fig. 5.5).
    pub exp: ExpKind,
    /// Leaf spheres per blocker object. Default 32.
    pub spheres: usize,
    /// Receiver vertices per cluster. Default 512.
    pub cluster_vertices: usize,
    /// Blockers under this half-angle (degrees) from a cluster are dropped. Default 1°.
    pub min_angle_deg: f32,
    /// A hierarchy node under this half-angle is used whole (its proxy sphere)
    /// instead of its children. Default 7°.
    pub lod_angle_deg: f32,
    /// Strata per side of the static self-shadowing bake (rays = side²). Default 12.
    pub bake_strata: usize,
    /// Flat receivers with fewer vertices are refined to at least this many
    /// (0: never). Default 16 384. Unused with a visibility texture.
    pub flat_receiver_vertices: usize,
    /// Dynamic receivers shadow themselves: their own occlusion is baked in
    /// their frame like a static receiver's (`T_p`) and rotated with them
    /// per frame. Default on.
    pub self_shadow: bool,
    /// Texels per side of a flat receiver's visibility texture
    /// ([`crate::texels`]): its plane is shaded at the texel centres and
    /// looked up per pixel instead of refined into vertices. Default 0 (off:
    /// refine).
    pub visibility_texture: usize,
}

impl Default for ShExpOptions {
    fn default() -> Self {
        Self {
            order: 4,
            exp: ExpKind::PsStar(2),
            spheres: 32,
            cluster_vertices: 512,
            min_angle_deg: 1.0,
            lod_angle_deg: 7.0,
            bake_strata: 12,
            flat_receiver_vertices: 16_384,
            self_shadow: true,
            visibility_texture: 0,
        }
    }
}

/// One receiver cluster: an object's vertices and their bounding sphere
/// (in the object's frame at `prepare`).
#[derive(Clone, Debug)]
struct Cluster {
    object: usize,
    vertices: Vec<u32>,
    bound: Sphere,
}

/// Per object, what `prepare` built.
#[derive(Debug)]
struct ObjectState {
    mesh: Arc<Mesh>,
    /// The points shaded: a refined flat receiver, the texel centres of its
    /// visibility texture, or `mesh`.
    receiver: Arc<Mesh>,
    /// A flat receiver's visibility texture (then `receiver` holds its texels).
    texels: Option<TexelGrid>,
    dynamic: bool,
    /// Sphere set at `prepare` (None: not a blocker).
    spheres: Option<SphereSet>,
    /// Reference vertices for the transform recovery.
    refs: [u32; 4],
    /// Diffuse albedo.
    albedo: Vec3,
    /// Static receivers: `T_p` per vertex (order² each).
    transfer: Vec<f32>,
    /// Dynamic receivers that occlude themselves: `T_p` against their own
    /// mesh in their frame at `prepare` (order² per vertex; empty when no
    /// vertex is occluded), rotated with the object per frame.
    self_transfer: Vec<f32>,
    /// Per vertex: some of its own rays were blocked (it shades through
    /// `self_transfer`; the others take the exact `L_H(N)` table).
    self_occluded: Vec<bool>,
    /// Static receivers under area lights: `F(p, N)` per vertex, RGB
    /// (3·order² each; [`crate::area`]), kept until the lights change.
    area_transfer: Vec<f32>,
    /// Static receivers: `L ∗ T_p` (+ `F`), RGB, per vertex (3·order² each).
    lit_transfer: Vec<f32>,
}

struct State {
    objects: Vec<ObjectState>,
    clusters: Vec<Cluster>,
    /// `L` (world frame), RGB, f64.
    light: [Vec<f64>; 3],
    /// The scene's area lights, projected per receiver point ([`crate::area`]),
    /// and the lights they were made from.
    area: AreaLightSh,
    area_lights: Vec<relight_render::AreaLight>,
    /// The scene had visibility at `prepare`.
    visibility: bool,
    /// `L_H(N)` over the octahedral grid, RGB interleaved per texel (3·order²).
    lh_table: Vec<f32>,
    colors: Vec<Vec<Vec3>>,
    /// The meshes `render` draws: those the last colours belong to, or for a
    /// visibility texture the object's own mesh at the frame's pose.
    drawn: Vec<Arc<Mesh>>,
    /// Per object, prepare-pose from frame-pose (the inverse of its motion):
    /// what a visibility-texture lookup transforms pixels by.
    prepare_from_now: Vec<Affine3A>,
    warnings: Vec<String>,
}

/// SH exponentiation soft shadows as a [`Relighter`] (module docs).
pub struct ShExpMethod {
    options: ShExpOptions,
    table: Arc<LogTable>,
    expo: Exponentiator<f32>,
    lanes: LaneKernel,
    state: Option<State>,
    raster: Rasterizer,
    histogram: SquaringHistogram,
    /// Blocker–vertex pairs the last frame accumulated (before the
    /// per-vertex tangent-plane test), and its vertices.
    last_pairs: (u64, u64),
    pending_lighting_ms: f64,
    /// The environment's projection, kept by its texels: a lighting change
    /// that turns it (`world_from_env`) projects nothing again.
    env_projection: relight_sh::project::EnvProjection,
}

impl std::fmt::Debug for ShExpMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShExpMethod")
            .field("options", &self.options)
            .field("prepared", &self.state.is_some())
            .finish_non_exhaustive()
    }
}

fn invalid(option: &'static str, message: String) -> MethodError {
    MethodError::InvalidOption {
        method: SHEXP_METHOD_NAME,
        option,
        message,
    }
}

fn failed(why: &str) -> MethodError {
    MethodError::failed(
        SHEXP_METHOD_NAME,
        crate::ShExpError::InvalidParameter {
            what: "scene",
            why: why.to_string(),
        },
    )
}

/// Which kernel shades the vertices of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// [`crate::lanes`]: 16 vertices at once (the default; product
    /// accumulation always runs per vertex).
    Lanes,
    /// One vertex at a time by [`crate::accumulate`] and
    /// [`Exponentiator::exp`]: the reference the lane kernel is tested against.
    PerVertex,
}

impl ShExpMethod {
    /// A method with `options`.
    ///
    /// # Errors
    /// [`MethodError::InvalidOption`] naming the option.
    pub fn new(options: ShExpOptions) -> Result<Self, MethodError> {
        if !(2..=MAX_SHEXP_ORDER).contains(&options.order) {
            return Err(invalid(
                "order",
                format!("must be 2…{MAX_SHEXP_ORDER} (got {})", options.order),
            ));
        }
        if options.spheres == 0 || options.cluster_vertices == 0 || options.bake_strata == 0 {
            return Err(invalid(
                "spheres",
                "sphere, cluster and bake counts must be ≥ 1".into(),
            ));
        }
        if options.visibility_texture > MAX_VISIBILITY_TEXTURE {
            return Err(invalid(
                "visibility-texture",
                format!(
                    "texels per side must be ≤ {MAX_VISIBILITY_TEXTURE} (got {})",
                    options.visibility_texture
                ),
            ));
        }
        if !(options.min_angle_deg >= 0.0 && options.lod_angle_deg >= options.min_angle_deg) {
            return Err(invalid(
                "lod-angle",
                format!(
                    "need 0 ≤ min angle ({}) ≤ lod angle ({})",
                    options.min_angle_deg, options.lod_angle_deg
                ),
            ));
        }
        let table = Arc::new(
            LogTable::with_defaults(options.order).map_err(|e| invalid("order", e.to_string()))?,
        );
        let ol = OlFit::fit(&table);
        let lanes =
            LaneKernel::new(&table, ol.clone()).map_err(|e| invalid("order", e.to_string()))?;
        let expo =
            Exponentiator::new(options.order, ol).map_err(|e| invalid("order", e.to_string()))?;
        Ok(Self {
            options,
            table,
            expo,
            lanes,
            state: None,
            raster: Rasterizer::new(),
            histogram: SquaringHistogram::new(),
            last_pairs: (0, 0),
            env_projection: relight_sh::project::EnvProjection::default(),
            pending_lighting_ms: 0.0,
        })
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &ShExpOptions {
        &self.options
    }

    /// Squarings used by the exponentials since the last [`Self::take_histogram`].
    pub fn take_histogram(&mut self) -> SquaringHistogram {
        std::mem::replace(&mut self.histogram, SquaringHistogram::new())
    }

    /// Of the last frame: (blocker spheres summed over vertices, vertices):
    /// what §5.2.4's culling left per cluster, before the per-vertex
    /// tangent-plane test.
    #[must_use]
    pub fn last_frame_pairs(&self) -> (u64, u64) {
        self.last_pairs
    }

    /// Leaf spheres of every blocker object (as prepared), with the object index.
    #[must_use]
    pub fn sphere_sets(&self) -> Vec<(usize, &SphereSet)> {
        self.state.as_ref().map_or(Vec::new(), |s| {
            s.objects
                .iter()
                .enumerate()
                .filter_map(|(i, o)| o.spheres.as_ref().map(|s| (i, s)))
                .collect()
        })
    }

    /// Number of receiver clusters.
    #[must_use]
    pub fn cluster_count(&self) -> usize {
        self.state.as_ref().map_or(0, |s| s.clusters.len())
    }

    /// The last shaded per-vertex radiance of each object, one value per
    /// point of [`Self::receiver_points`].
    #[must_use]
    pub fn vertex_colors(&self) -> &[Vec<Vec3>] {
        self.state.as_ref().map_or(&[], |s| &s.colors)
    }

    /// The points object `i` is shaded at, at `prepare`'s pose: its vertices,
    /// a flat receiver's refined vertices, or its visibility texture's texel
    /// centres.
    #[must_use]
    pub fn receiver_points(&self, i: usize) -> Option<&Mesh> {
        self.state
            .as_ref()
            .and_then(|s| s.objects.get(i))
            .map(|o| o.receiver.as_ref())
    }
}

/// Diffuse albedo of `brdf`: `π f(N, N)`, and whether it is Lambertian
/// (constant over a few direction pairs).
fn diffuse_albedo(brdf: &dyn relight_brdf::Brdf) -> (Vec3, bool) {
    let n = Vec3::Z;
    let f0 = brdf.eval(n, n);
    let pairs = [
        (Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.3, 0.4, 0.866)),
        (Vec3::new(0.0, 0.8, 0.6), Vec3::new(0.8, 0.0, 0.6)),
    ];
    let lambert = pairs.iter().all(|(a, b)| {
        (brdf.eval(*a, *b) - f0).abs().max_element() <= 1e-4 * (1.0 + f0.max_element())
    });
    if lambert {
        return (f0 * std::f32::consts::PI, true);
    }
    // Directional albedo at normal incidence, by a fixed cosine-weighted grid.
    let mut sum = Vec3::ZERO;
    let k = 32;
    for i in 0..k {
        for j in 0..k {
            let (u, v) = ((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
            let r = u.sqrt();
            let phi = 2.0 * std::f32::consts::PI * v;
            let wi = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u).max(0.0).sqrt());
            sum += brdf.eval(n, wi) * std::f32::consts::PI;
        }
    }
    ((sum / (k * k) as f32).min(Vec3::ONE), false)
}

/// Four well-spread vertex indices (for the similarity recovery).
fn reference_vertices(p: &[Vec3]) -> [u32; 4] {
    if p.is_empty() {
        return [0; 4];
    }
    let far = |f: &dyn Fn(Vec3) -> f32| {
        (0..p.len())
            .max_by(|&a, &b| f(p[a]).total_cmp(&f(p[b])))
            .unwrap_or(0) as u32
    };
    let a = 0u32;
    let pa = p[0];
    let b = far(&|q| q.distance_squared(pa));
    let pb = p[b as usize];
    let ab = (pb - pa).normalize_or_zero();
    let c = far(&|q| (q - pa).reject_from_normalized(ab).length_squared());
    let pc = p[c as usize];
    let nrm = (pb - pa).cross(pc - pa).normalize_or_zero();
    let d = far(&|q| (q - pa).dot(nrm).abs());
    [a, b, c, d]
}

/// The similarity taking `old` to `new` (by the reference vertices): the map
/// and its scale. Planar meshes use the normal as the third axis.
fn recover_similarity(old: &Mesh, new: &Mesh, refs: [u32; 4]) -> Option<(Affine3A, f32)> {
    let g = |m: &Mesh, i: u32| m.positions.get(i as usize).copied();
    let (o0, o1, o2, o3) = (
        g(old, refs[0])?,
        g(old, refs[1])?,
        g(old, refs[2])?,
        g(old, refs[3])?,
    );
    let (n0, n1, n2, n3) = (
        g(new, refs[0])?,
        g(new, refs[1])?,
        g(new, refs[2])?,
        g(new, refs[3])?,
    );
    let (a1, a2) = (o1 - o0, o2 - o0);
    let (b1, b2) = (n1 - n0, n2 - n0);
    let mut a3 = o3 - o0;
    let mut b3 = n3 - n0;
    let vol = a1.cross(a2).dot(a3).abs();
    if vol <= 1e-9 * a1.length().powi(3).max(1e-30) {
        a3 = a1.cross(a2);
        b3 = b1.cross(b2);
        let s2 = b3.length() / a3.length().max(1e-30);
        b3 /= s2.sqrt().max(1e-30);
    }
    let a = Mat3::from_cols(a1, a2, a3);
    if a.determinant().abs() < 1e-20 {
        return None;
    }
    let m = Mat3::from_cols(b1, b2, b3) * a.inverse();
    let scale = m.determinant().abs().cbrt();
    let t = n0 - m * o0;
    Some((Affine3A::from_mat3_translation(m, t), scale))
}

/// The same area lights (the same texture objects): the static receivers'
/// `F` need not be projected again.
fn same_area_lights(a: &[relight_render::AreaLight], b: &[relight_render::AreaLight]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| {
            x.center == y.center
                && x.size == y.size
                && x.world_from_light == y.world_from_light
                && x.intensity == y.intensity
                && match (&x.texture, &y.texture) {
                    (None, None) => true,
                    (Some(p), Some(q)) => Arc::ptr_eq(p, q),
                    _ => false,
                }
        })
}

/// Flat objects only receive.
fn is_flat(mesh: &Mesh) -> bool {
    mesh.bounds().is_none_or(|b| {
        let e = b.extent();
        e.min_element() < 0.01 * e.max_element()
    })
}

/// Clusters of an object's vertices: k-means on positions.
fn cluster_vertices(object: usize, mesh: &Mesh, per: usize) -> Vec<Cluster> {
    let p = &mesh.positions;
    if p.is_empty() {
        return Vec::new();
    }
    let k = p.len().div_ceil(per).clamp(1, 256);
    // Seeds: every (len/k)-th vertex, then Lloyd iterations.
    let mut centers: Vec<Vec3> = (0..k).map(|i| p[i * p.len() / k]).collect();
    let mut assign = vec![0u32; p.len()];
    for _ in 0..6 {
        assign.par_iter_mut().zip(p).for_each(|(a, q)| {
            let mut best = (f32::MAX, 0u32);
            for (j, c) in centers.iter().enumerate() {
                let d = q.distance_squared(*c);
                if d < best.0 {
                    best = (d, j as u32);
                }
            }
            *a = best.1;
        });
        let mut sum = vec![(Vec3::ZERO, 0u32); k];
        for (a, q) in assign.iter().zip(p) {
            sum[*a as usize].0 += *q;
            sum[*a as usize].1 += 1;
        }
        for (c, s) in centers.iter_mut().zip(&sum) {
            if s.1 > 0 {
                *c = s.0 / s.1 as f32;
            }
        }
    }
    let mut groups = vec![Vec::new(); k];
    for (v, a) in assign.iter().enumerate() {
        groups[*a as usize].push(v as u32);
    }
    groups
        .into_iter()
        .zip(centers)
        .filter(|(g, _)| !g.is_empty())
        .map(|(vertices, c)| {
            let r = vertices
                .iter()
                .map(|&v| p[v as usize].distance(c))
                .fold(0.0f32, f32::max);
            Cluster {
                object,
                vertices,
                bound: Sphere {
                    center: c.to_array(),
                    radius: r,
                },
            }
        })
        .collect()
}

fn normals_of(mesh: &Mesh) -> Vec<Vec3> {
    if mesh.normals.len() == mesh.positions.len() {
        mesh.normals.clone()
    } else {
        mesh.smooth_normals()
    }
}

/// Walks `set`'s hierarchy for a cluster bounded by `(cc, cr)` (culling rules
/// in the module docs), pushing the spheres to use.
fn gather(
    set: &SphereSet,
    cc: Vec3,
    cr: f32,
    sin_min: f32,
    sin_lod: f32,
    out: &mut Vec<LaneBlocker>,
) {
    let mut stack = [0u32; 64];
    let mut top = 0;
    if set.nodes.is_empty() {
        return;
    }
    stack[0] = 0;
    top += 1;
    while top > 0 {
        top -= 1;
        let node = &set.nodes[stack[top] as usize];
        let s = node.sphere;
        let d = s.c().distance(cc) - cr;
        // sin of the largest half-angle any point of the cluster sees.
        let sin_max = if d <= s.radius { 1.0 } else { s.radius / d };
        if sin_max < sin_min {
            continue;
        }
        match node.children {
            Some([a, b]) if sin_max >= sin_lod && top + 2 <= stack.len() => {
                stack[top] = a;
                stack[top + 1] = b;
                top += 2;
            }
            // A leaf, or a node used whole: its proxy (`SphereNode::proxy`).
            _ => out.push(LaneBlocker {
                c: node.proxy.center,
                r: node.proxy.radius,
            }),
        }
    }
}

impl ShExpMethod {
    /// Projects the environment in world space: per texel in its own frame
    /// with the texels' exact solid angles ([`relight_sh::project::project_env`]),
    /// then turned by `world_from_env` in the SH domain. (Until session 38 a
    /// product quadrature of degree `4·order + 60` read the map at its nodes,
    /// a few degrees apart: a sun a texel or two wide fell on a node or
    /// between nodes, and the embedded demo scene's sun came out about twice
    /// as bright as the reference's, relative RMS 1.08 over its objects.)
    /// The projection is kept ([`relight_sh::project::EnvProjection`]) while
    /// the map's texels stay the same.
    fn project_light(&mut self, scene: &Scene) -> Result<[Vec<f64>; 3], MethodError> {
        let n = self.options.order;
        let mut sh = self
            .env_projection
            .project(&scene.env, n)
            .map_err(|e| MethodError::failed(SHEXP_METHOD_NAME, e))?
            .0
            .clone();
        if scene.world_from_env != Mat3::IDENTITY {
            let r = relight_sh::rotation::Rot3::try_from_mat3(scene.world_from_env)
                .map_err(|e| MethodError::failed(SHEXP_METHOD_NAME, e))?;
            let rot = relight_sh::rotation::ShRotation::<f32>::from_rotation(n, &r)
                .map_err(|e| MethodError::failed(SHEXP_METHOD_NAME, e))?;
            sh = sh.rotated(&rot);
        }
        Ok(sh.channels.map(|c| c.into_iter().map(f64::from).collect()))
    }

    /// `L_H` over the octahedral grid and `L ∗ T_p` (+ the area lights' `F`)
    /// per static vertex; the static `F` again when `area_changed`.
    fn light_tables(&self, state: &mut State, area_changed: bool) {
        let n = self.options.order;
        let nn = n * n;
        let tp = TripleProduct::<f64>::new(n).expect("order checked in new");
        let h = irradiance_zonal(n);
        let m: Vec<nalgebra_free::Mat> = state
            .light
            .iter()
            .map(|l| nalgebra_free::Mat::product_matrix(&tp, l))
            .collect();
        let size = LH_TABLE_SIZE;
        let mut table = vec![0.0f32; size * size * 3 * nn];
        table
            .par_chunks_mut(3 * nn)
            .enumerate()
            .for_each(|(t, out)| {
                let (i, j) = (t % size, t / size);
                let uv = glam::Vec2::new(i as f32, j as f32) / (size - 1) as f32;
                let nrm = oct_decode(uv).as_dvec3();
                let mut hv = vec![0.0; nn];
                relight_sh::rotation::rotate_zonal(n, &h, nrm.to_array(), &mut hv);
                for c in 0..3 {
                    let lh = m[c].apply(&hv);
                    for k in 0..nn {
                        out[c * nn + k] = lh[k] as f32;
                    }
                }
            });
        state.lh_table = table;
        if area_changed {
            self.static_area_transfer(state);
        }
        // Per static vertex: `L ∗ X_p`, `X_p = T_p` (baked visibility) or
        // `H(N_p)` (none baked), plus the area lights' `F(p, N)`.
        let h32: Vec<f32> = h.iter().map(|&v| v as f32).collect();
        for o in &mut state.objects {
            if o.transfer.is_empty() && o.area_transfer.is_empty() {
                o.lit_transfer.clear();
                continue;
            }
            let mesh = &o.receiver;
            let normals = if o.transfer.is_empty() {
                normals_of(mesh)
            } else {
                Vec::new()
            };
            let (transfer, area) = (&o.transfer, &o.area_transfer);
            let mut lt = vec![0.0f32; mesh.positions.len() * 3 * nn];
            lt.par_chunks_mut(3 * nn).enumerate().for_each_init(
                || vec![0.0f32; nn],
                |x, (v, out)| {
                    if transfer.is_empty() {
                        let nrm = normals[v].normalize_or(Vec3::Y);
                        relight_sh::rotation::rotate_zonal(n, &h32, nrm.to_array(), x);
                    } else {
                        x.copy_from_slice(&transfer[v * nn..(v + 1) * nn]);
                    }
                    let xd: Vec<f64> = x.iter().map(|&v| f64::from(v)).collect();
                    for c in 0..3 {
                        let r = m[c].apply(&xd);
                        for k in 0..nn {
                            out[c * nn + k] = r[k] as f32;
                        }
                    }
                    if !area.is_empty() {
                        for (o, a) in out.iter_mut().zip(&area[v * 3 * nn..(v + 1) * 3 * nn]) {
                            *o += a;
                        }
                    }
                },
            );
            o.lit_transfer = lt;
        }
    }

    /// `F(p, N)` of the area lights ([`crate::area`]) at every static
    /// receiver point, with a shadow ray per quadrature cell against the
    /// static meshes when the scene has visibility.
    fn static_area_transfer(&self, state: &mut State) {
        let nn = self.options.order * self.options.order;
        let area = &state.area;
        let static_meshes: Vec<Arc<Mesh>> = state
            .objects
            .iter()
            .filter(|o| !o.dynamic)
            .map(|o| o.mesh.clone())
            .collect();
        let refs: Vec<&Mesh> = static_meshes.iter().map(|m| m.as_ref()).collect();
        let bvh = (state.visibility && !area.is_empty()).then(|| SceneBvh::build(&refs));
        for o in &mut state.objects {
            o.area_transfer.clear();
            if o.dynamic || area.is_empty() {
                continue;
            }
            let mesh = &o.receiver;
            let normals = normals_of(mesh);
            let mut at = vec![0.0f32; mesh.positions.len() * 3 * nn];
            at.par_chunks_mut(3 * nn).enumerate().for_each_init(
                || vec![0.0f32; nn],
                |y, (v, out)| {
                    let (p, nrm) = (mesh.positions[v], normals[v].normalize_or(Vec3::Y));
                    let origin = relight_render::bvh::offset_ray_origin(p, nrm);
                    let weight = |w: Vec3, r: f32| {
                        let c = w.dot(nrm);
                        let shadowed = c > 0.0
                            && bvh
                                .as_ref()
                                .is_some_and(|b| b.occluded(origin, w, r * (1.0 - 1e-4)));
                        if c > 0.0 && !shadowed {
                            c * std::f32::consts::FRAC_1_PI
                        } else {
                            0.0
                        }
                    };
                    area.project_weighted(p, weight, y, out);
                },
            );
            o.area_transfer = at;
        }
    }

    /// Bakes `T_p = H(N_p)·g` for every vertex of `mesh` against the meshes
    /// of `bvh`, by cosine-weighted stratified rays with the exact `H(N_p)`
    /// as control variate: `T_p = H(N_p) − (1/K) Σ_k [occluded_k] y(s_k)`
    /// (unbiased; exact where no ray is blocked). Also returns, per vertex,
    /// whether any ray was.
    fn bake_transfer(
        &self,
        bvh: &SceneBvh<'_>,
        mesh: &Mesh,
        seed: u64,
        progress: &dyn Progress,
    ) -> Result<(Vec<f32>, Vec<bool>), MethodError> {
        let n = self.options.order;
        let nn = n * n;
        let k = self.options.bake_strata;
        let normals = normals_of(mesh);
        let h32: Vec<f32> = irradiance_zonal(n).iter().map(|&v| v as f32).collect();
        let mut out = vec![0.0f32; mesh.positions.len() * nn];
        let mut occluded = vec![false; mesh.positions.len()];
        let chunk = 1024;
        for (ci, (block, occ)) in out
            .chunks_mut(chunk * nn)
            .zip(occluded.chunks_mut(chunk))
            .enumerate()
        {
            progress.check()?;
            block
                .par_chunks_mut(nn)
                .zip(occ.par_iter_mut())
                .enumerate()
                .for_each(|(vi, (t, blocked))| {
                    let v = ci * chunk + vi;
                    let nrm = normals[v].normalize_or(Vec3::Y);
                    relight_sh::rotation::rotate_zonal(n, &h32, nrm.to_array(), t);
                    let frame = relight_sphere::Frame::from_z(nrm);
                    let o = relight_render::bvh::offset_ray_origin(mesh.positions[v], nrm);
                    let mut rng = Rng::new(seed, v as u64);
                    let mut y = vec![0.0f32; nn];
                    let w = 1.0 / (k * k) as f32;
                    for a in 0..k {
                        for b in 0..k {
                            let local = crate::shade::cosine_stratum(a, b, k, &mut rng);
                            let d = frame.from_local(local).normalize();
                            if !bvh.occluded(o, d, f32::INFINITY) {
                                continue;
                            }
                            *blocked = true;
                            relight_sh::eval_sh_into(n, d.to_array(), &mut y);
                            for (t, y) in t.iter_mut().zip(&y) {
                                *t -= w * y;
                            }
                        }
                    }
                });
        }
        Ok((out, occluded))
    }

    /// Shades every vertex of `scene` (as prepared, objects possibly moved by
    /// their animation) into [`Self::vertex_colors`]; the per-frame shadow work.
    ///
    /// # Errors
    /// Not prepared, other meshes than prepared, or a static object moved.
    pub fn shade_vertices(&mut self, scene: &Scene) -> Result<(), MethodError> {
        self.shade_vertices_with(scene, Kernel::Lanes)
    }

    /// [`Self::shade_vertices`] by `kernel` (the lane kernel or the
    /// per-vertex reference; both compute the same colours up to f32 rounding).
    ///
    /// # Errors
    /// As [`Self::shade_vertices`].
    pub fn shade_vertices_with(
        &mut self,
        scene: &Scene,
        kernel: Kernel,
    ) -> Result<(), MethodError> {
        let opts = self.options;
        let n = opts.order;
        let nn = n * n;
        let state = self
            .state
            .as_mut()
            .ok_or_else(|| failed("call prepare before render"))?;
        if scene.objects.len() != state.objects.len() {
            return Err(failed(
                "the objects changed since prepare; call prepare again",
            ));
        }
        // Current transforms (prepare → now) of every object.
        let mut moved: Vec<(Affine3A, f32)> = Vec::with_capacity(state.objects.len());
        for (i, (o, so)) in scene.objects.iter().zip(&state.objects).enumerate() {
            if Arc::ptr_eq(&o.mesh, &so.mesh) {
                moved.push((Affine3A::IDENTITY, 1.0));
                continue;
            }
            if o.mesh.positions.len() != so.mesh.positions.len() {
                return Err(failed(&format!(
                    "{} has another mesh than at prepare; call prepare again",
                    Numbered::object(i)
                )));
            }
            let t = recover_similarity(&so.mesh, &o.mesh, so.refs).ok_or_else(|| {
                failed(&format!(
                    "{}: cannot recover its motion",
                    Numbered::object(i)
                ))
            })?;
            let still = t.0.matrix3.abs_diff_eq(glam::Mat3A::IDENTITY, 1e-5)
                && t.0.translation.abs().max_element() < 1e-6;
            if !so.dynamic && !still {
                return Err(failed(&format!(
                    "{} moved but was static at prepare (its shadows are baked); call prepare again",
                    Numbered::object(i)
                )));
            }
            moved.push(t);
        }
        let sets: Vec<Option<SphereSet>> = state
            .objects
            .iter()
            .zip(&moved)
            .map(|(o, (m, s))| o.spheres.as_ref().map(|set| set.transformed(*m, *s)))
            .collect();
        let dynamic: Vec<bool> = state.objects.iter().map(|o| o.dynamic).collect();
        // The receiver meshes now: the scene's, or the refined mesh moved.
        let receivers: Vec<Arc<Mesh>> = state
            .objects
            .iter()
            .zip(&scene.objects)
            .zip(&moved)
            .map(|((so, o), (m, _))| {
                if Arc::ptr_eq(&so.receiver, &so.mesh) {
                    o.mesh.clone()
                } else if *m == Affine3A::IDENTITY {
                    so.receiver.clone()
                } else {
                    Arc::new((*so.receiver).clone().transformed(*m))
                }
            })
            .collect();
        let visibility = scene.visibility;
        let (sin_min, sin_lod) = (
            opts.min_angle_deg.to_radians().sin(),
            opts.lod_angle_deg.to_radians().sin(),
        );
        let table = &*self.table;
        let factors = zonal_rotation_factors(n);
        let hist = Mutex::new(SquaringHistogram::new());
        let pairs = std::sync::atomic::AtomicU64::new(0);
        let mut colors: Vec<Vec<Vec3>> = receivers
            .iter()
            .map(|m| vec![Vec3::ZERO; m.positions.len()])
            .collect();
        let lanes = &self.lanes;
        let use_lanes = kernel == Kernel::Lanes && opts.exp != ExpKind::Product;
        let area = &state.area;
        // Self-shadowed dynamic receivers: their transfer turned with them
        // (the similarity's rotation), and L in f32 for `L · (T ∗ g)`.
        let self_rotations: Vec<Option<relight_sh::rotation::ShRotation<f32>>> = state
            .objects
            .iter()
            .zip(&moved)
            .map(|(o, (m, scale))| {
                if o.self_transfer.is_empty() {
                    return None;
                }
                let r = Mat3::from(m.matrix3) / scale.max(1e-30);
                relight_sh::rotation::Rot3::try_from_mat3(r)
                    .ok()
                    .and_then(|r| relight_sh::rotation::ShRotation::from_rotation(n, &r).ok())
            })
            .collect();
        let light32: [Vec<f32>; 3] = state
            .light
            .clone()
            .map(|c| c.iter().map(|&v| v as f32).collect());
        let tp32 = self.expo.tensor();
        let unshadowed = |g: &mut [f32]| {
            g.fill(0.0);
            g[0] = (4.0 * std::f32::consts::PI).sqrt();
        };
        // Per cluster: blockers, then its vertices' colours.
        let results: Vec<Vec<(u32, Vec3)>> = state
            .clusters
            .par_iter()
            .map_init(
                || PerThread {
                    scr: Scratch::new(n),
                    expo: self.expo.clone(),
                    blockers: Vec::new(),
                    f: vec![0.0f32; nn],
                    g: vec![0.0f32; nn],
                    lane_scratch: LaneScratch::new(n),
                    rec: LaneReceivers::default(),
                    fl: vec![[0.0; W]; nn],
                    gl: vec![[0.0; W]; nn],
                    area: AreaScratch::new(n),
                },
                |t, cl| {
                    let obj = cl.object;
                    let (m, s) = moved[obj];
                    let cc = m.transform_point3(cl.bound.c());
                    let cr = cl.bound.radius * s;
                    t.blockers.clear();
                    if visibility {
                        for (b, set) in sets.iter().enumerate() {
                            let Some(set) = set else { continue };
                            // Never the receiver's own spheres; static receivers
                            // have the static blockers baked in.
                            if b == obj || (!dynamic[obj] && !dynamic[b]) {
                                continue;
                            }
                            gather(set, cc, cr, sin_min, sin_lod, &mut t.blockers);
                        }
                    }
                    let mesh = &receivers[obj];
                    let so = &state.objects[obj];
                    let normal = |v: u32| {
                        mesh.normals
                            .get(v as usize)
                            .copied()
                            .unwrap_or(Vec3::Y)
                            .normalize_or(Vec3::Y)
                    };
                    // A dynamic receiver's area light, `F(p, N) · g`
                    // ([`crate::area`]; static ones have it in `lit_transfer`).
                    let dynamic_area = so.lit_transfer.is_empty() && !area.is_empty();
                    let self_rotation = self_rotations[obj].as_ref();
                    let shade = |v: u32, nrm: Vec3, g: &[f32], s: &mut AreaScratch| {
                        let vi = v as usize;
                        if let Some(rot) = self_rotation
                            && so.self_occluded[vi]
                        {
                            // `(L + A(p)) · (T_p ∗ g)`, T_p turned to world.
                            rot.apply(&so.self_transfer[vi * nn..(vi + 1) * nn], &mut s.t);
                            tp32.product(&s.t, g, &mut s.q);
                            let mut rgb = Vec3::new(
                                dot(&light32[0], &s.q),
                                dot(&light32[1], &s.q),
                                dot(&light32[2], &s.q),
                            );
                            if !area.is_empty()
                                && area.project(mesh.positions[vi], &mut s.y, &mut s.f)
                            {
                                rgb += Vec3::new(
                                    dot(&s.f[..nn], &s.q),
                                    dot(&s.f[nn..2 * nn], &s.q),
                                    dot(&s.f[2 * nn..], &s.q),
                                );
                            }
                            return (v, (rgb * so.albedo).max(Vec3::ZERO));
                        }
                        let mut rgb = if so.lit_transfer.is_empty() {
                            lh_dot(&state.lh_table, nn, nrm, g)
                        } else {
                            let lt =
                                &so.lit_transfer[v as usize * 3 * nn..(v as usize + 1) * 3 * nn];
                            Vec3::new(
                                dot(&lt[..nn], g),
                                dot(&lt[nn..2 * nn], g),
                                dot(&lt[2 * nn..], g),
                            )
                        };
                        let cosine = |w: Vec3, _| w.dot(nrm).max(0.0) * std::f32::consts::FRAC_1_PI;
                        if dynamic_area
                            && area.project_weighted(
                                mesh.positions[v as usize],
                                cosine,
                                &mut s.y,
                                &mut s.f,
                            )
                        {
                            rgb += Vec3::new(
                                dot(&s.f[..nn], g),
                                dot(&s.f[nn..2 * nn], g),
                                dot(&s.f[2 * nn..], g),
                            );
                        }
                        (v, (rgb * so.albedo).max(Vec3::ZERO))
                    };
                    let mut local = SquaringHistogram::new();
                    let mut out = Vec::with_capacity(cl.vertices.len());
                    if use_lanes {
                        for chunk in cl.vertices.chunks(W) {
                            let mut nrms = [Vec3::ZERO; W];
                            for j in 0..W {
                                let v = chunk[j.min(chunk.len() - 1)];
                                nrms[j] = normal(v);
                                t.rec.set(j, mesh.positions[v as usize], nrms[j]);
                            }
                            let any = if t.blockers.is_empty() {
                                0
                            } else {
                                lanes.accumulate(&t.rec, &t.blockers, &mut t.fl)
                            };
                            if any == 0 {
                                unshadowed(&mut t.g);
                                for (j, &v) in chunk.iter().enumerate() {
                                    out.push(shade(v, nrms[j], &t.g, &mut t.area));
                                }
                                continue;
                            }
                            lanes.exp(
                                opts.exp,
                                &t.fl,
                                any,
                                chunk.len(),
                                &mut t.lane_scratch,
                                &mut t.gl,
                                &mut local,
                            );
                            for (j, &v) in chunk.iter().enumerate() {
                                for (g, gl) in t.g.iter_mut().zip(&t.gl) {
                                    *g = gl[j];
                                }
                                out.push(shade(v, nrms[j], &t.g, &mut t.area));
                            }
                        }
                    } else {
                        let product = opts.exp == ExpKind::Product;
                        for &v in &cl.vertices {
                            let p = mesh.positions[v as usize];
                            let nrm = normal(v);
                            let (f, g) = (&mut t.f, &mut t.g);
                            let any = t
                                .blockers
                                .iter()
                                .any(|b| (Vec3::from(b.c) - p).dot(nrm) > -b.r);
                            if any {
                                f.fill(0.0);
                                if product {
                                    f[0] = (4.0 * std::f32::consts::PI).sqrt();
                                }
                                for b in &t.blockers {
                                    let d = Vec3::from(b.c) - p;
                                    if d.dot(nrm) <= -b.r {
                                        continue;
                                    }
                                    let dist = d.length();
                                    let (theta, dir) = if dist <= b.r {
                                        (
                                            std::f32::consts::FRAC_PI_2,
                                            if dist > 0.0 { d / dist } else { nrm },
                                        )
                                    } else {
                                        ((b.r / dist).asin(), d / dist)
                                    };
                                    if product {
                                        mul_blocker_visibility(
                                            t.expo.tensor(),
                                            &factors,
                                            theta,
                                            dir.to_array(),
                                            &mut t.scr,
                                            f,
                                        );
                                    } else {
                                        add_blocker_log(
                                            table,
                                            &factors,
                                            theta,
                                            dir.to_array(),
                                            &mut t.scr,
                                            f,
                                        );
                                    }
                                }
                                let (sq, capped) = t.expo.exp(opts.exp, f, g);
                                local.counts[sq as usize] += 1;
                                local.capped += u64::from(capped);
                            } else {
                                unshadowed(g);
                            }
                            out.push(shade(v, nrm, g, &mut t.area));
                        }
                    }
                    hist.lock().expect("histogram lock").merge(&local);
                    pairs.fetch_add(
                        (t.blockers.len() * cl.vertices.len()) as u64,
                        std::sync::atomic::Ordering::Relaxed,
                    );
                    out
                },
            )
            .collect();
        for (cl, r) in state.clusters.iter().zip(results) {
            for (v, c) in r {
                colors[cl.object][v as usize] = c;
            }
        }
        state.colors = colors;
        state.prepare_from_now = moved.iter().map(|(m, _)| m.inverse()).collect();
        state.drawn = receivers
            .into_iter()
            .zip(&state.objects)
            .zip(&scene.objects)
            .map(|((r, so), o)| {
                if so.texels.is_some() {
                    o.mesh.clone()
                } else {
                    r
                }
            })
            .collect();
        self.histogram
            .merge(&hist.into_inner().expect("histogram lock"));
        self.last_pairs = (
            pairs.into_inner(),
            state.clusters.iter().map(|c| c.vertices.len() as u64).sum(),
        );
        Ok(())
    }
}

/// Per-thread buffers of [`ShExpMethod::shade_vertices_with`].
struct PerThread {
    scr: Scratch,
    expo: Exponentiator<f32>,
    blockers: Vec<LaneBlocker>,
    f: Vec<f32>,
    g: Vec<f32>,
    lane_scratch: LaneScratch,
    rec: LaneReceivers,
    fl: Vec<Lane>,
    gl: Vec<Lane>,
    area: AreaScratch,
}

/// Per-thread buffers of a dynamic receiver's area light and
/// self-shadowing: the SH basis, `F(p, N)` or `A(p)` (RGB; [`crate::area`]),
/// the turned transfer `T_p` and `T_p ∗ g`.
struct AreaScratch {
    y: Vec<f32>,
    f: Vec<f32>,
    t: Vec<f32>,
    q: Vec<f32>,
}

impl AreaScratch {
    fn new(n: usize) -> Self {
        let nn = n * n;
        Self {
            y: vec![0.0; nn],
            f: vec![0.0; 3 * nn],
            t: vec![0.0; nn],
            q: vec![0.0; nn],
        }
    }
}

/// `a · b` in eight partial sums, so that it compiles to vector code (an
/// iterator `sum` is one serial chain of scalar adds: it had cost 8 % of a
/// dino-like frame).
#[inline]
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f32 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    let mut acc = [0.0f32; 8];
    for (x, y) in ca.zip(cb) {
        for i in 0..8 {
            acc[i] += x[i] * y[i];
        }
    }
    acc.iter().sum::<f32>() + tail
}

/// `L_H(N) · g` by bilinear lookup in the octahedral table.
#[inline]
fn lh_dot(table: &[f32], nn: usize, nrm: Vec3, g: &[f32]) -> Vec3 {
    let size = LH_TABLE_SIZE;
    let uv = oct_encode(nrm) * (size - 1) as f32;
    let (i, j) = ((uv.x as usize).min(size - 2), (uv.y as usize).min(size - 2));
    let (fx, fy) = (uv.x - i as f32, uv.y - j as f32);
    let mut out = Vec3::ZERO;
    for (di, dj, w) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let t = &table[((j + dj) * size + i + di) * 3 * nn..][..3 * nn];
        out += w * Vec3::new(
            dot(&t[..nn], g),
            dot(&t[nn..2 * nn], g),
            dot(&t[2 * nn..], g),
        );
    }
    out
}

/// A dense product matrix without nalgebra in the hot path.
mod nalgebra_free {
    use relight_sh::product::TripleProduct;

    pub struct Mat {
        n: usize,
        m: Vec<f64>,
    }

    impl Mat {
        /// `(M_f)_{ij} = Σ_k Γ_{ijk} f_k` (eq. 5.10).
        pub fn product_matrix(tp: &TripleProduct<f64>, f: &[f64]) -> Self {
            let m = tp.product_matrix(f);
            let n = m.nrows();
            Self {
                n,
                m: (0..n * n).map(|k| m[(k / n, k % n)]).collect(),
            }
        }

        pub fn apply(&self, v: &[f64]) -> Vec<f64> {
            (0..self.n)
                .map(|i| (0..self.n).map(|j| self.m[i * self.n + j] * v[j]).sum())
                .collect()
        }
    }
}

impl Relighter for ShExpMethod {
    fn name(&self) -> &'static str {
        SHEXP_METHOD_NAME
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            SceneFeature::Environment
            | SceneFeature::Visibility
            | SceneFeature::Animation
            | SceneFeature::AreaLights => Support::Full,
            SceneFeature::PointLights
            | SceneFeature::LightFields
            | SceneFeature::Medium
            | SceneFeature::NormalMaps
            | SceneFeature::SpatiallyVaryingBrdf => Support::No,
        }
    }

    fn warnings(&self) -> Vec<String> {
        self.state
            .as_ref()
            .map_or(Vec::new(), |s| s.warnings.clone())
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        check_scene(self, scene, false)?;
        let opts = self.options;
        let mut warnings = Vec::new();
        let mut objects = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            progress.check()?;
            let (albedo, lambert) = diffuse_albedo(o.brdf.as_ref());
            if !lambert {
                warnings.push(format!(
                    "shexp: {}: its BRDF is not Lambertian; shaded as diffuse with albedo ({:.2}, {:.2}, {:.2})",
                    Numbered::object(i),
                    albedo.x, albedo.y, albedo.z
                ));
            }
            let spheres = if is_flat(&o.mesh) || o.mesh.indices.is_empty() {
                None
            } else {
                Some(
                    fit_spheres(
                        &o.mesh,
                        &FitOptions {
                            spheres: opts.spheres,
                            ..FitOptions::default()
                        },
                    )
                    .map_err(|e| MethodError::failed(SHEXP_METHOD_NAME, e))?,
                )
            };
            let mut receiver = o.mesh.clone();
            let texels = if is_flat(&o.mesh) {
                TexelGrid::new(&o.mesh, opts.visibility_texture)
            } else {
                None
            };
            if let Some(g) = &texels {
                receiver = Arc::new(g.receiver_points());
            } else if is_flat(&o.mesh) && opts.flat_receiver_vertices > 0 {
                let mut m = (*o.mesh).clone();
                while m.positions.len() < opts.flat_receiver_vertices && !m.indices.is_empty() {
                    m = m.subdivide_midpoint();
                }
                if m.normals.len() != m.positions.len() {
                    m.normals = m.smooth_normals();
                }
                receiver = Arc::new(m);
            }
            objects.push(ObjectState {
                mesh: o.mesh.clone(),
                receiver,
                texels,
                dynamic: o.animation.is_some(),
                spheres,
                refs: reference_vertices(&o.mesh.positions),
                albedo,
                transfer: Vec::new(),
                self_transfer: Vec::new(),
                self_occluded: Vec::new(),
                area_transfer: Vec::new(),
                lit_transfer: Vec::new(),
            });
        }
        // Static self-shadowing against the static meshes.
        if scene.visibility {
            let statics: Vec<&Mesh> = scene
                .objects
                .iter()
                .filter(|o| o.animation.is_none())
                .map(|o| o.mesh.as_ref())
                .collect();
            let bvh = SceneBvh::build(&statics);
            for (i, o) in objects.iter_mut().enumerate() {
                if !o.dynamic {
                    let r = o.receiver.clone();
                    o.transfer = self.bake_transfer(&bvh, &r, 0x5e0 + i as u64, progress)?.0;
                }
            }
            // Dynamic receivers: their own occlusion, in their own frame.
            if opts.self_shadow {
                for (i, o) in objects.iter_mut().enumerate() {
                    if o.dynamic && o.spheres.is_some() {
                        let own = SceneBvh::build(&[o.mesh.as_ref()]);
                        let r = o.receiver.clone();
                        let (t, occ) = self.bake_transfer(&own, &r, 0x5e1 + i as u64, progress)?;
                        if occ.iter().any(|&b| b) {
                            o.self_transfer = t;
                            o.self_occluded = occ;
                        }
                    }
                }
            }
        }
        let clusters: Vec<Cluster> = objects
            .iter()
            .enumerate()
            .flat_map(|(i, o)| cluster_vertices(i, &o.receiver, opts.cluster_vertices))
            .collect();
        let nn = opts.order * opts.order;
        self.state = Some(State {
            objects,
            clusters,
            light: [vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]],
            area: AreaLightSh::new(opts.order, &[]),
            area_lights: Vec::new(),
            visibility: scene.visibility,
            lh_table: Vec::new(),
            colors: Vec::new(),
            drawn: Vec::new(),
            prepare_from_now: Vec::new(),
            warnings,
        });
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let t = Instant::now();
        progress.check()?;
        relight_render::reference::validate_scene(scene)
            .map_err(|e| MethodError::failed(SHEXP_METHOD_NAME, e))?;
        let light = self.project_light(scene)?;
        let mut state = self
            .state
            .take()
            .ok_or_else(|| failed("call prepare before set_lighting"))?;
        state.light = light;
        let area_changed = !same_area_lights(&state.area_lights, &scene.area_lights);
        if area_changed {
            state.area = AreaLightSh::new(self.options.order, &scene.area_lights);
            state.area_lights = scene.area_lights.clone();
        }
        self.light_tables(&mut state, area_changed);
        self.state = Some(state);
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
        request.validate(SHEXP_METHOD_NAME)?;
        let t = Instant::now();
        progress.check()?;
        self.shade_vertices(scene)?;
        let k = request.aa;
        let mut camera = request.camera;
        camera.width *= k;
        camera.height *= k;
        let state = self
            .state
            .as_ref()
            .ok_or_else(|| failed("call prepare before render"))?;
        let textured = state.objects.iter().any(|o| o.texels.is_some());
        let draws: Vec<DrawCall> = state
            .drawn
            .iter()
            .zip(&state.colors)
            .enumerate()
            .map(|(i, (m, c))| {
                let d = DrawCall::new(&m.positions, &m.indices).with_object_id(i as u32);
                // With a visibility texture in the frame, the other objects'
                // colours travel as vertex attributes of the per-pixel pass.
                if textured && state.objects[i].texels.is_none() {
                    d.with_attributes(3, bytemuck::cast_slice(c))
                } else {
                    d
                }
            })
            .collect();
        let ropts = RasterOptions::default().fit_depth(&camera, &draws);
        let env_from_world = scene.world_from_env.transpose();
        let bg = |d: Vec3| scene.env.eval(env_from_world * d);
        let background = if k > 1 {
            Background::Environment(&bg)
        } else {
            Background::Color(Vec3::ZERO)
        };
        let mut frame = Image::new(camera.width, camera.height);
        if textured {
            let shader = |f: &relight_render::raster::Fragment| {
                let o = f.object as usize;
                match &state.objects[o].texels {
                    Some(g) => g.lookup(&state.colors[o], &state.prepare_from_now[o], f.position),
                    None => Vec3::from_slice(f.attributes),
                }
            };
            self.raster
                .render(&camera, &draws, shader, background, &ropts, &mut frame)
                .map_err(|e| MethodError::failed(SHEXP_METHOD_NAME, e))?;
        } else {
            let refs: Vec<&[Vec3]> = state.colors.iter().map(|c| &c[..]).collect();
            self.raster
                .render_gouraud(&camera, &draws, &refs, background, &ropts, &mut frame)
                .map_err(|e| MethodError::failed(SHEXP_METHOD_NAME, e))?;
        }
        Ok(Rendered::from_samples(
            Cow::Owned(frame),
            &self.raster,
            k,
            std::mem::take(&mut self.pending_lighting_ms),
            t,
        ))
    }

    fn data_bytes(&self) -> u64 {
        let s = self.state.as_ref().map_or(0, |s| {
            s.lh_table.len() * 4
                + s.objects
                    .iter()
                    .map(|o| {
                        (o.transfer.len()
                            + o.self_transfer.len()
                            + o.area_transfer.len()
                            + o.lit_transfer.len())
                            * 4
                    })
                    .sum::<usize>()
        });
        (s + self.table.bytes()) as u64
    }
}
