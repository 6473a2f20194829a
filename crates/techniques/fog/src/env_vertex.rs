//! The fog method's environment part shaded per vertex (Gouraud), the
//! default of [`crate::method::FogRelighter`] ([`EnvShading::PerVertex`]).
//!
//! The surface radiance of the environment part (sun-thesis-2008 §3.6.4,
//! eqs. 3.35–3.37: the SH lighting L′ filtered by the fog's PSF) is the SH
//! shading of Kautz et al. 2002, `L_o = ⟨L′, B(n, ω_o)⟩`, the transfer of
//! the BRDF for normal n and view ω_o. The thesis computes its model "for
//! each vertex or pixel" (§3.5, after eq. 3.29); here the environment term
//! is evaluated at the vertices of the triangles the frame shows and
//! interpolated with the rasterizer's perspective-correct barycentrics
//! (the point-light part stays per pixel). Per shaded vertex:
//!
//! 1. the local frame z = n, x = the view's tangent part (so ω_o has azimuth
//!    0 and no Z rotation is needed), y = z × x;
//! 2. `B(θ_o)` from the BRDF's table ([`BrdfShTable::lookup_mono`], one
//!    vector where the table is rank-1, else three), times the band window;
//! 3. `B` rotated from the local frame to world (exact ZYZ: three Z
//!    rotations and two fixed X matrices; a frame's sides go in batches of
//!    [`TRANSFER_RUN`], [`VertexShader::transfer_run`]) and dotted with the
//!    world-frame lighting `L′` ([`EnvLighting`]), three channels.
//!
//! So a lighting change rotates only the n² lighting coefficients (no
//! per-vertex lighting), and a frame's work is O(visible vertices · n³)
//! instead of O(covered samples · n³).
//!
//! Where the view is below a vertex's shading horizon (n·ω_o ≤
//! [`MIN_COS_VIEW`], silhouettes) the transfer is read at that grazing
//! cosine instead of zero (the per-pixel path returns black there).
//! Two-sided like the per-pixel path: a vertex of a triangle seen from the
//! back shades with −n.

use crate::ball_light::BallIrradiance;
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use relight_render::Scene;
use relight_render::raster::{NO_TRIANGLE, Rasterizer};
use relight_sh::fast::ROTATE_BATCH_MAX_ORDER;
use relight_sh::project::ShRgb;
use relight_sh::rotation::{EulerZyz, IvanicRuedenberg, Rot3, ShRotation, ZyzRotation};
use relight_shlight::{BrdfShTable, ChosenWindow, LightingFilter, ShLightError};
use relight_sphere::EnvMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// Where the environment part of the fog method is shaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvShading {
    /// At the visible vertices, interpolated (module docs); the default.
    PerVertex,
    /// At every sample ([`relight_shlight::LitScene`], per-pixel rotation).
    PerPixel,
}

/// The smallest cosine between a vertex normal and the view at which the
/// transfer is read (module docs).
pub const MIN_COS_VIEW: f32 = 0.05;

/// The most SH coefficients per channel (order 8).
const MAXN: usize = 64;

/// `Σ a_i b_i` over the shorter slice, in eight interleaved partial sums
/// (the compiler keeps them in vector registers): a plain `sum()` over the
/// products is one chain of dependent adds, 36 of them per channel at
/// order 6. Only the summation order differs (rounding, ≈ 1e-7 relative).
#[inline(always)]
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    for (k, (x, y)) in ra.iter().zip(rb).enumerate() {
        acc[k] += x * y;
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]))
}

/// The environment lighting of one lighting change in the world frame:
/// the projection rotated by `world_from_env` (exact Ivanic–Ruedenberg)
/// and filtered ([`LightingFilter`]: L′_lm = (direct + bands\[l\]) L_lm).
#[derive(Clone, Debug)]
pub struct EnvLighting {
    order: usize,
    /// L′ in the world frame, per channel `order²`.
    lit: [Vec<f32>; 3],
    /// The filter's direct weight and its filtered part alone (for empty
    /// pixels; `None` without a filter or with all band weights zero).
    filtered: Option<[Vec<f32>; 3]>,
    direct: f32,
    env_from_world: Mat3,
}

impl EnvLighting {
    /// `projection` (the environment's SH in its own frame) turned by
    /// `world_from_env` and filtered by `filter`.
    ///
    /// # Errors
    /// A matrix that is not a rotation, an unsupported order.
    pub fn new(
        projection: &ShRgb,
        world_from_env: Mat3,
        filter: Option<&LightingFilter>,
    ) -> Result<Self, ShLightError> {
        let order = projection.order;
        let mut light = projection.clone();
        let mut env_from_world = Mat3::IDENTITY;
        if world_from_env != Mat3::IDENTITY {
            let r = Rot3::try_from_mat3(world_from_env)?;
            let plan = IvanicRuedenberg::<f32>::new(order)?;
            let mut rot = ShRotation::<f32>::identity(order)?;
            plan.build(&r, &mut rot);
            light = light.rotated(&rot);
            env_from_world = world_from_env.transpose();
        }
        let (mut direct, mut filtered) = (1.0, None);
        if let Some(f) = filter {
            direct = f.direct;
            let band = |i: usize| {
                let l = relight_sh::sh_lm(i).0;
                f.bands.get(l).copied().unwrap_or(0.0)
            };
            let only: [Vec<f32>; 3] = std::array::from_fn(|c| {
                light.channels[c]
                    .iter()
                    .enumerate()
                    .map(|(i, v)| v * band(i))
                    .collect()
            });
            for c in &mut light.channels {
                for (i, v) in c.iter_mut().enumerate() {
                    *v *= f.direct + band(i);
                }
            }
            if f.bands.iter().any(|&w| w != 0.0) {
                filtered = Some(only);
            }
        }
        Ok(Self {
            order,
            lit: light.channels,
            filtered,
            direct,
            env_from_world,
        })
    }

    /// Bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Whether empty samples add a filtered SH part (a medium's PSF).
    #[must_use]
    pub fn is_filtered(&self) -> bool {
        self.filtered.is_some()
    }

    /// What an empty sample in world direction `d` (unit) shows:
    /// direct · env(d) + max(0, the filtered part at d), as the per-pixel
    /// path's background; with `weights`, `weights[0] · env(d) +
    /// weights[1] · max(0, the filtered part at d)`.
    #[must_use]
    pub fn background(&self, env: &EnvMap, d: Vec3, weights: Option<[f32; 2]>) -> Vec3 {
        let [direct, glow] = weights.unwrap_or([self.direct, 1.0]);
        let seen = env.eval(self.env_from_world * d);
        match &self.filtered {
            None => direct * seen,
            Some(sh) => direct * seen + glow * self.filtered_at(sh, d),
        }
    }

    /// [`EnvLighting::background`] of every direction of `dirs` (unit,
    /// world), added to `out`: the environment by
    /// [`EnvMap::eval_many`] (lat-long lookups in blocks, bit for bit the
    /// one-at-a-time lookup), the filtered part eight directions at a time
    /// by [`relight_sh::fast::shade_rgb_batch`] (AVX2 lanes across
    /// directions, up to its order; the same sums up to rounding), one by
    /// one above it. With `weights`, direction i shows
    /// `weights[i][0] · env(d) + weights[i][1] · max(0, filtered(d))`
    /// instead (a fog ball's chord, [`crate::view_segment::ChordGlow`]).
    ///
    /// # Panics
    /// `out` or `weights` shorter than `dirs`.
    pub fn add_background(
        &self,
        env: &EnvMap,
        dirs: &[Vec3],
        weights: Option<&[[f32; 2]]>,
        scratch: &mut BackgroundScratch,
        out: &mut [Vec3],
    ) {
        assert!(out.len() >= dirs.len(), "add_background: output too short");
        let n = dirs.len();
        assert!(
            weights.is_none_or(|w| w.len() >= n),
            "add_background: weights too short"
        );
        let BackgroundScratch { seen, dirs3, sh } = scratch;
        seen.resize(n, Vec3::ZERO);
        env.eval_many(self.env_from_world, dirs, seen);
        let batched = self.filtered.as_ref().is_some_and(|f| {
            dirs3.clear();
            dirs3.extend(dirs.iter().map(|d| d.to_array()));
            sh.resize(n, [0.0; 3]);
            relight_sh::fast::shade_rgb_batch(self.order, [&f[0], &f[1], &f[2]], dirs3, sh).is_ok()
        });
        for (i, o) in out[..n].iter_mut().enumerate() {
            let [direct, glow] = weights.map_or([self.direct, 1.0], |w| w[i]);
            *o += direct * seen[i]
                + glow
                    * match (&self.filtered, batched) {
                        (None, _) => Vec3::ZERO,
                        (Some(_), true) => Vec3::from_array(sh[i]).max(Vec3::ZERO),
                        (Some(f), false) => self.filtered_at(f, dirs[i]),
                    };
        }
    }

    /// max(0, the filtered part at `d`), one direction.
    fn filtered_at(&self, sh: &[Vec<f32>; 3], d: Vec3) -> Vec3 {
        let nn = self.order * self.order;
        let mut y = [0.0f32; MAXN];
        relight_sh::basis::eval_sh_into(self.order, d.to_array(), &mut y[..nn]);
        let y = &y[..nn];
        Vec3::new(dot(&sh[0], y), dot(&sh[1], y), dot(&sh[2], y)).max(Vec3::ZERO)
    }
}

/// Per-thread buffers of [`EnvLighting::add_background`].
#[derive(Default)]
pub struct BackgroundScratch {
    seen: Vec<Vec3>,
    dirs3: Vec<[f32; 3]>,
    sh: Vec<[f32; 3]>,
}

/// One object's transfer: its BRDF table and band window per coefficient.
#[derive(Clone, Debug)]
struct Transfer {
    table: Arc<BrdfShTable>,
    window: Vec<f32>,
}

/// Per-thread buffers of [`VertexShader::shade`].
pub struct Scratch {
    b: [f32; 3 * MAXN],
    bw: [f32; 3 * MAXN],
    tmp: [f32; MAXN],
}

impl Scratch {
    /// Zeroed buffers.
    #[must_use]
    pub fn new() -> Box<Self> {
        Box::new(Self {
            b: [0.0; 3 * MAXN],
            bw: [0.0; 3 * MAXN],
            tmp: [0.0; MAXN],
        })
    }
}

/// The per-vertex environment shading of a scene's objects (module docs).
pub struct VertexShader {
    order: usize,
    zyz: ZyzRotation<f32>,
    transfers: Vec<Transfer>,
}

impl std::fmt::Debug for VertexShader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VertexShader")
            .field("order", &self.order)
            .field("objects", &self.transfers.len())
            .finish_non_exhaustive()
    }
}

impl VertexShader {
    /// Shading at `order` bands with one (table, window) per object (the
    /// window's factors per band, as [`relight_shlight::LitScene::windows`]).
    ///
    /// # Errors
    /// An order above a table's or above 8, tables and windows of
    /// different counts.
    pub fn new(
        order: usize,
        tables: &[Arc<BrdfShTable>],
        windows: &[ChosenWindow],
    ) -> Result<Self, ShLightError> {
        let bad = |why: String| ShLightError::InvalidParameter {
            what: "per-vertex environment",
            why,
        };
        if tables.len() != windows.len() {
            return Err(bad(format!(
                "{} tables but {} windows",
                tables.len(),
                windows.len()
            )));
        }
        if order * order > MAXN || tables.iter().any(|t| t.order() < order) {
            return Err(bad(format!("order {order} above a table's or above 8")));
        }
        let transfers = tables
            .iter()
            .zip(windows)
            .map(|(t, w)| Transfer {
                table: t.clone(),
                window: (0..order * order)
                    .map(|i| {
                        w.factors
                            .get(relight_sh::sh_lm(i).0)
                            .copied()
                            .unwrap_or(1.0) as f32
                    })
                    .collect(),
            })
            .collect();
        Ok(Self {
            order,
            zyz: ZyzRotation::new(order)?,
            transfers,
        })
    }

    /// Bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// `L_o = ⟨L′, B(n, ω_o)⟩` of object `obj` for unit shading normal `n`
    /// and unit direction to the eye `wo` (module docs, steps 1–3):
    /// [`VertexShader::transfer`] then [`VertexShader::apply`].
    #[must_use]
    pub fn shade(
        &self,
        obj: usize,
        light: &EnvLighting,
        n: Vec3,
        wo: Vec3,
        s: &mut Scratch,
    ) -> Vec3 {
        let Scratch { b, bw, tmp } = s;
        let ch = self.transfer_into(obj, n, wo, b, tmp, bw);
        self.apply(obj, light, &bw[..ch * self.order * self.order])
    }

    /// Values per vertex side a world-frame transfer of this shader takes
    /// at most (`order²` per channel, three channels where a table is not
    /// rank-1).
    #[must_use]
    pub fn transfer_len(&self) -> usize {
        let ch = if self
            .transfers
            .iter()
            .all(|t| t.table.mono_colour().is_some())
        {
            1
        } else {
            3
        };
        ch * self.order * self.order
    }

    /// Steps 1–3 up to the dot product: the windowed transfer `B(n, ω_o)`
    /// of object `obj` turned to the world frame, into `out` (`order²`
    /// values per channel: one channel where the object's table is rank-1,
    /// else three); returns the channel count. It does not depend on the
    /// lighting, so a lighting change under a still camera only needs
    /// [`VertexShader::apply`].
    pub fn transfer(
        &self,
        obj: usize,
        n: Vec3,
        wo: Vec3,
        s: &mut Scratch,
        out: &mut [f32],
    ) -> usize {
        let Scratch { b, tmp, .. } = s;
        self.transfer_into(obj, n, wo, b, tmp, out)
    }

    /// `L_o = ⟨L′, B⟩` from a world-frame transfer of
    /// [`VertexShader::transfer`] (`t`: its channels × `order²` values).
    #[must_use]
    pub fn apply(&self, obj: usize, light: &EnvLighting, t: &[f32]) -> Vec3 {
        let k = self.order * self.order;
        let dot = |a: &[f32], b: &[f32]| dot(&a[..k], &b[..k]);
        match self.transfers[obj].table.mono_colour() {
            Some(rho) => {
                let w = &t[..k];
                Vec3::new(
                    dot(&light.lit[0], w),
                    dot(&light.lit[1], w),
                    dot(&light.lit[2], w),
                ) * Vec3::from_array(rho)
            }
            None => Vec3::new(
                dot(&light.lit[0], &t[..k]),
                dot(&light.lit[1], &t[k..2 * k]),
                dot(&light.lit[2], &t[2 * k..3 * k]),
            ),
        }
    }

    fn transfer_into(
        &self,
        obj: usize,
        n: Vec3,
        wo: Vec3,
        b: &mut [f32],
        tmp: &mut [f32],
        bw: &mut [f32],
    ) -> usize {
        let k = self.order * self.order;
        let (channels, world_from_local) = self.local_transfer(obj, n, wo, b);
        // Local (x, y, n) → world.
        let e: EulerZyz<f32> = Rot3::from_mat3_unchecked(world_from_local).euler_zyz();
        let bw = &mut bw[..channels * k];
        for (src, dst) in b[..channels * k]
            .chunks_exact(k)
            .zip(bw.chunks_exact_mut(k))
        {
            self.zyz.apply_euler(&e, src, dst, &mut tmp[..k]);
        }
        channels
    }

    /// Steps 1–2: the windowed local-frame transfer `B(θ_o)` of object
    /// `obj` into `b` (`order²` values per channel) and the frame's
    /// world-from-local matrix (columns x, y, n); returns the channel count.
    fn local_transfer(&self, obj: usize, n: Vec3, wo: Vec3, b: &mut [f32]) -> (usize, Mat3) {
        let tr = &self.transfers[obj];
        let k = self.order * self.order;
        let c = n.dot(wo);
        let x = (wo - c * n)
            .try_normalize()
            .unwrap_or_else(|| n.any_orthonormal_vector());
        let y = n.cross(x);
        let c = c.clamp(MIN_COS_VIEW, 1.0);
        let mono = tr.table.mono_colour();
        let channels = if mono.is_some() { 1 } else { 3 };
        let b = &mut b[..channels * k];
        if mono.is_some() {
            tr.table.lookup_mono(c, self.order, b);
        } else {
            tr.table.lookup(c, self.order, b);
        }
        for ch in b.chunks_exact_mut(k) {
            for (v, h) in ch.iter_mut().zip(&tr.window) {
                *v *= h;
            }
        }
        (channels, Mat3::from_cols(x, y, n))
    }

    /// [`VertexShader::transfer`] of up to [`TRANSFER_RUN`] vertex sides
    /// `(obj, n, wo)` at once, side `j` into `out[j · stride ..]`; their
    /// vectors are turned to world together by
    /// [`relight_sh::fast::rotate_batch`] (eight at a time, lanes across
    /// vectors, on a CPU with AVX2 and FMA; the same ZYZ rotation as
    /// [`VertexShader::transfer`] up to rounding, test
    /// `batched_transfers_match_one_at_a_time`), one by one above its
    /// largest order.
    ///
    /// # Panics
    /// More than [`TRANSFER_RUN`] sides, or `out` shorter than
    /// `sides.len() · stride` with `stride` < [`VertexShader::transfer_len`].
    pub fn transfer_run(
        &self,
        sides: &[(usize, Vec3, Vec3)],
        run: &mut TransferRun,
        out: &mut [f32],
        stride: usize,
    ) {
        assert!(
            sides.len() <= TRANSFER_RUN
                && stride >= self.transfer_len()
                && out.len() >= sides.len() * stride,
            "transfer_run: at most TRANSFER_RUN sides, stride ≥ transfer_len, out ≥ sides · stride"
        );
        let k = self.order * self.order;
        if self.order > ROTATE_BATCH_MAX_ORDER {
            for (&(obj, n, wo), t) in sides.iter().zip(out.chunks_exact_mut(stride)) {
                self.transfer_into(obj, n, wo, &mut run.b, &mut run.tmp, t);
            }
            return;
        }
        run.rots.clear();
        run.channels.clear();
        let mut vectors = 0;
        for &(obj, n, wo) in sides {
            let (ch, world_from_local) =
                self.local_transfer(obj, n, wo, &mut run.src[vectors * k..]);
            let r = Rot3::from_mat3_unchecked(world_from_local);
            run.rots.extend(std::iter::repeat_n(r, ch));
            run.channels.push(ch as u8);
            vectors += ch;
        }
        relight_sh::fast::rotate_batch(
            self.order,
            &run.rots,
            &run.src[..vectors * k],
            &mut run.dst[..vectors * k],
        )
        .expect("order ≤ ROTATE_BATCH_MAX_ORDER and lengths sized by TransferRun");
        let mut at = 0;
        for (&ch, t) in run.channels.iter().zip(out.chunks_exact_mut(stride)) {
            let len = usize::from(ch) * k;
            t[..len].copy_from_slice(&run.dst[at..at + len]);
            at += len;
        }
    }
}

/// Vertex sides whose transfers [`VertexShader::transfer_run`] turns in
/// one batch.
pub const TRANSFER_RUN: usize = 64;

/// Per-thread buffers of [`VertexShader::transfer_run`].
pub struct TransferRun {
    rots: Vec<Rot3<f32>>,
    channels: Vec<u8>,
    src: Vec<f32>,
    dst: Vec<f32>,
    b: [f32; 3 * MAXN],
    tmp: [f32; MAXN],
}

impl TransferRun {
    /// Buffers for [`TRANSFER_RUN`] sides of three channels at the
    /// largest order.
    #[must_use]
    pub fn new() -> Box<Self> {
        Box::new(Self {
            rots: Vec::with_capacity(3 * TRANSFER_RUN),
            channels: Vec::with_capacity(TRANSFER_RUN),
            src: vec![0.0; 3 * TRANSFER_RUN * MAXN],
            dst: vec![0.0; 3 * TRANSFER_RUN * MAXN],
            b: [0.0; 3 * MAXN],
            tmp: [0.0; MAXN],
        })
    }
}

/// Bits of a vertex mark: seen on a front- or back-facing triangle.
const FRONT: u8 = 1;
const BACK: u8 = 2;

/// The per-vertex colours of one frame (module docs).
pub struct VertexFrame {
    /// Per object, per vertex: which sides the frame shows (reset by
    /// [`VertexFrame::shade`]).
    marks: Vec<Vec<AtomicU8>>,
    /// Per object, per vertex: the radiance of the front and back side.
    front: Vec<Vec<Vec3>>,
    back: Vec<Vec<Vec3>>,
    /// The vertex sides the last [`VertexFrame::shade`] shaded (object,
    /// vertex, back side) and their world-frame transfers, `stride` values
    /// each, for [`VertexFrame::relight`].
    sides: Vec<(u32, u32, bool)>,
    transfers: Vec<f32>,
    stride: usize,
    colours: Vec<Vec3>,
    /// Whether `sides` and `transfers` hold a [`VertexFrame::shade`].
    shaded: bool,
    /// Per side: where it sits in the fog ball, as
    /// [`BallIrradiance::coordinates`] (its colour is scaled by the factor
    /// there, when a medium gives one).
    ball_at: Vec<[f32; 2]>,
}

impl std::fmt::Debug for VertexFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VertexFrame")
            .field("objects", &self.marks.len())
            .finish_non_exhaustive()
    }
}

/// Whether triangle `t` of `mesh` faces the eye (its geometric normal
/// towards it; the sign is the same at every point of its plane).
#[inline]
#[must_use]
pub fn faces_eye(positions: &[Vec3], t: [u32; 3], eye: Vec3) -> bool {
    let (p0, p1, p2) = (
        positions[t[0] as usize],
        positions[t[1] as usize],
        positions[t[2] as usize],
    );
    (p1 - p0).cross(p2 - p0).dot(eye - p0) >= 0.0
}

impl VertexFrame {
    /// Buffers for `scene`'s objects.
    #[must_use]
    pub fn new(scene: &Scene) -> Self {
        let sizes: Vec<usize> = scene
            .objects
            .iter()
            .map(|o| o.mesh.positions.len())
            .collect();
        Self {
            marks: sizes
                .iter()
                .map(|&n| (0..n).map(|_| AtomicU8::new(0)).collect())
                .collect(),
            front: sizes.iter().map(|&n| vec![Vec3::ZERO; n]).collect(),
            back: sizes.iter().map(|&n| vec![Vec3::ZERO; n]).collect(),
            sides: Vec::new(),
            transfers: Vec::new(),
            stride: 0,
            colours: Vec::new(),
            shaded: false,
            ball_at: Vec::new(),
        }
    }

    /// Whether the buffers fit `scene`'s objects.
    #[must_use]
    pub fn fits(&self, scene: &Scene) -> bool {
        self.marks.len() == scene.objects.len()
            && self
                .marks
                .iter()
                .zip(&scene.objects)
                .all(|(m, o)| m.len() == o.mesh.positions.len())
    }

    /// Shades every vertex side of the triangles visible in `raster`
    /// (rasterized from `scene`'s meshes, draw i = object i, seen from
    /// `eye`) with `shader` under `light`, each scaled by its place in the
    /// fog ball where `ball` is given ([`BallIrradiance::factor`]).
    pub fn shade(
        &mut self,
        scene: &Scene,
        raster: &Rasterizer,
        eye: Vec3,
        shader: &VertexShader,
        light: &EnvLighting,
        ball: Option<&BallIrradiance>,
    ) {
        let g = raster.gbuffer();
        let w = g.width.max(1);
        let marks = &self.marks;
        g.triangle.par_chunks(w).for_each(|ids| {
            let mut last = NO_TRIANGLE;
            for &id in ids {
                if id == NO_TRIANGLE || id == last {
                    continue;
                }
                last = id;
                let Some((d, tri)) = raster.locate(id) else {
                    continue;
                };
                let mesh = &scene.objects[d].mesh;
                let t = mesh.indices[tri];
                let bit = if faces_eye(&mesh.positions, t, eye) {
                    FRONT
                } else {
                    BACK
                };
                for v in t {
                    let m = &marks[d][v as usize];
                    if m.load(Ordering::Relaxed) & bit == 0 {
                        m.fetch_or(bit, Ordering::Relaxed);
                    }
                }
            }
        });
        // The marked sides in vertex order (marks reset for the next frame).
        self.sides.clear();
        for (d, m) in self.marks.iter().enumerate() {
            let found: Vec<(u32, u32, bool)> = m
                .par_iter()
                .enumerate()
                .with_min_len(4096)
                .flat_map_iter(|(v, m)| {
                    let bits = m.load(Ordering::Relaxed);
                    if bits != 0 {
                        m.store(0, Ordering::Relaxed);
                    }
                    [(FRONT, false), (BACK, true)]
                        .into_iter()
                        .filter(move |(bit, _)| bits & bit != 0)
                        .map(move |(_, back)| (d as u32, v as u32, back))
                })
                .collect();
            self.sides.extend(found);
        }
        // Each side's world-frame transfer, kept, and its colour.
        self.stride = shader.transfer_len();
        let stride = self.stride.max(1);
        self.transfers.resize(self.sides.len() * stride, 0.0);
        let objects = &scene.objects;
        let k = shader.order * shader.order;
        self.colours.resize(self.sides.len(), Vec3::ZERO);
        self.ball_at.resize(self.sides.len(), [0.0; 2]);
        self.sides
            .par_chunks(TRANSFER_RUN)
            .zip(self.transfers.par_chunks_mut(TRANSFER_RUN * stride))
            .zip(self.colours.par_chunks_mut(TRANSFER_RUN))
            .zip(self.ball_at.par_chunks_mut(TRANSFER_RUN))
            .for_each_init(
                || (TransferRun::new(), Vec::with_capacity(TRANSFER_RUN)),
                |(run, items), (((sides, t), colours), ball_at)| {
                    items.clear();
                    items.extend(sides.iter().zip(ball_at.iter_mut()).map(
                        |(&(d, v, back), at)| {
                            let (d, v) = (d as usize, v as usize);
                            let mesh = &objects[d].mesh;
                            let p = mesh.positions[v];
                            let n = mesh.normals.get(v).copied().unwrap_or(Vec3::Z);
                            let n = n.normalize_or(Vec3::Z);
                            let wo = (eye - p).normalize_or(n);
                            let n = if back { -n } else { n };
                            *at = BallIrradiance::coordinates(p, n);
                            (d, n, wo)
                        },
                    ));
                    shader.transfer_run(items, run, t, stride);
                    for (((&(d, _, _), t), c), at) in items
                        .iter()
                        .zip(t.chunks_exact(stride))
                        .zip(colours)
                        .zip(ball_at.iter())
                    {
                        let ch = if shader.transfers[d].table.mono_colour().is_some() {
                            1
                        } else {
                            3
                        };
                        let f = ball.map_or(1.0, |b| b.factor_at(*at));
                        *c = shader.apply(d, light, &t[..ch * k]) * f;
                    }
                },
            );
        self.scatter();
        self.shaded = true;
    }

    /// Vertex sides the last [`VertexFrame::shade`] shaded.
    #[must_use]
    pub fn side_count(&self) -> usize {
        self.sides.len()
    }

    /// Whether a [`VertexFrame::shade`] ran, so [`VertexFrame::relight`]
    /// may follow (for the same raster, eye and shader: the caller's check).
    #[must_use]
    pub fn is_shaded(&self) -> bool {
        self.shaded
    }

    /// The colours of the vertex sides the last [`VertexFrame::shade`]
    /// shaded, under new lighting `light` (and fog ball factors `ball`),
    /// from their kept transfers: what `shade` of the same frame (raster,
    /// eye, shader) would give, bit for bit, at the cost of the dot
    /// products alone.
    pub fn relight(
        &mut self,
        shader: &VertexShader,
        light: &EnvLighting,
        ball: Option<&BallIrradiance>,
    ) {
        let stride = self.stride.max(1);
        let k = shader.order * shader.order;
        self.sides
            .par_iter()
            .zip(self.transfers.par_chunks(stride))
            .zip(self.ball_at.par_iter())
            .with_min_len(256)
            .map(|((&(d, _, _), t), at)| {
                let d = d as usize;
                let ch = if shader.transfers[d].table.mono_colour().is_some() {
                    1
                } else {
                    3
                };
                shader.apply(d, light, &t[..ch * k]) * ball.map_or(1.0, |b| b.factor_at(*at))
            })
            .collect_into_vec(&mut self.colours);
        self.scatter();
    }

    /// Writes `colours` to the front and back arrays of `sides`.
    fn scatter(&mut self) {
        for (&(d, v, back), &c) in self.sides.iter().zip(&self.colours) {
            let (d, v) = (d as usize, v as usize);
            if back {
                self.back[d][v] = c;
            } else {
                self.front[d][v] = c;
            }
        }
    }

    /// The interpolated radiance on triangle `t` of object `d` at
    /// barycentrics `lam` (weights of its three vertices), on its `front`
    /// or back side, after [`VertexFrame::shade`] of a frame that shows it.
    #[inline]
    #[must_use]
    pub fn at(&self, d: usize, t: [u32; 3], lam: Vec3, front: bool) -> Vec3 {
        let c = self.corners(d, t, front);
        c[0] * lam.x + c[1] * lam.y + c[2] * lam.z
    }

    /// The colours of triangle `t`'s three vertices on its `front` or back
    /// side (what [`VertexFrame::at`] interpolates).
    #[inline]
    #[must_use]
    pub fn corners(&self, d: usize, t: [u32; 3], front: bool) -> [Vec3; 3] {
        let c = if front { &self.front[d] } else { &self.back[d] };
        t.map(|v| c[v as usize])
    }
}
