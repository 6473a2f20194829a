//! The wavelet renderer (`--method wavelet`, wavelet-rotation-2006 §3
//! "Environment Map Rendering").
//!
//! # Two steps
//! 1. **Lighting change** ([`WaveletRenderer::set_lighting`]): the (rotated)
//!    environment is sampled onto the `n × n` octahedral map (solid-angle
//!    mean of ss × ss samples per texel, ss ≥ 4 and ≈ one sample per
//!    environment texel), Haar-transformed, approximated by its
//!    top `terms` coefficients (one RGB index set), and multiplied by the
//!    rotation matrices: `L̃_k = 𝐑_k 𝐋` for sampled normals `k`, stored
//!    densely (`ntess² × M` RGB, `Vec3A`) so that step 2 gathers by index.
//!    The products are formed on demand (`LocalLighting`): a lighting
//!    change marks every `L̃_k` stale, and a frame forms only those of the
//!    normals its vertices blend (on the default scene's first view 627 of
//!    the 1024: a camera sees the surfaces that face it, and each vertex
//!    blends four neighbours).
//! 2. **View change** ([`WaveletRenderer::shade_vertices`]): per vertex, the
//!    four sampled normals around the vertex normal get bilinear weights
//!    `w_c`; a view direction picks the nearest baked BRDF slice `𝐅` (paper:
//!    no view interpolation, a dense view grid instead) and the colour is a
//!    sparse dot product with the local lighting (paper Eq. 7), times an
//!    optional per-vertex ambient occlusion. [`NormalInterp::Paper`]: one
//!    slice for the vertex's local view in its [`crate::octa::shading_frame`],
//!    `𝐅 · Σ_c w_c L̃_c`. [`NormalInterp::MirrorAligned`] (default): one slice
//!    per neighbour, for the view whose mirror direction in that neighbour's
//!    frame is the vertex's world mirror direction, `Σ_c w_c 𝐅_c · L̃_c` — no
//!    ghost highlights between sampled normals. The colours are drawn by the
//!    rasterizer with Gouraud shading ([`WaveletRenderer::render`]) or
//!    evaluated per pixel ([`WaveletRenderer::render_per_pixel`]).
//!
//! Vertices seen from behind (`n · ω_o < 0`) are shaded with `ω_o` pushed to
//! just above the horizon (a closed mesh hides them anyway).

use crate::brdf_bake::BrdfBake;
use crate::error::{WaveletError, bad};
use crate::lighting::{OctSamples, haar_rgb};
use crate::memo::DotMemo;
use crate::octa::{grid_normal, normal_bilinear, shading_frame, shading_frame_fast};
use crate::rotation::RotationMatrices;
use glam::{Mat3, Vec3, Vec3A};
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_haar::{Ranking, SparseRgb, energy_fraction, top_k_rgb};
use relight_render::cull::{ClosedMeshes, cull_for_closed};
use relight_render::method::same_mesh_list;
use relight_render::raster::{Background, DrawCall, NO_TRIANGLE, RasterOptions, Rasterizer};
use relight_render::{Camera, Image, Numbered, Scene};
use relight_sphere::EnvMap;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, PoisonError, RwLock, RwLockReadGuard};
use std::time::Instant;

/// How the local lighting of the four sampled normals around a vertex normal
/// is combined (the view-change step, paper §3 "Environment Map Rendering").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum NormalInterp {
    /// The paper's rule: one BRDF slice for the vertex's local view `ω_o`,
    /// dotted with the bilinear blend `Σ_c w_c L̃_c` of the neighbours' local
    /// lighting. A sharp highlight appears once per neighbour, shifted by the
    /// angle between the vertex normal and that neighbour's normal (ghosting
    /// between sampled normals).
    Paper,
    /// Mirror-aligned blend (ours, the default): for each neighbour `c` the
    /// slice is picked for the view `ω_o^c` whose mirror direction in `c`'s
    /// frame is the vertex's world mirror direction `r = 2(n·ω_o)n − ω_o`
    /// (`ω_o^c = (−r_c.x, −r_c.y, r_c.z)`), and the colours are blended:
    /// `B = Σ_c w_c 𝐅(ω_o^c) · L̃_c`. A glossy lobe is centred on the same
    /// world direction for all four neighbours, so the highlights coincide
    /// (the rule that makes reflection-vector-indexed prefiltered maps work).
    /// Same number of lighting gathers as `Paper` (4 × slice terms) but four
    /// slices are read instead of one: ≈ 1.7× its view-change CPU time
    /// (`relight bench wavelet`). View-independent slices (Lambert) give
    /// identical results. Measured on the default scene (N = 64², 256 terms,
    /// 4096-spp reference, `relight verify wavelet`): antialiased error
    /// (4 × 4 samples per pixel) 0.093 → 0.045 at ntess = 32² and
    /// 0.270 → 0.047 at ntess = 16²; Gouraud image 0.197 → 0.185 (GGX 0.2
    /// sphere 0.087 → 0.060); at ntess = 8², 0.66 → 0.20.
    #[default]
    MirrorAligned,
}

/// What one lighting change did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LightingStats {
    /// Terms kept.
    pub terms: usize,
    /// Fraction of the lighting's Haar L2 energy kept by the terms.
    pub energy_fraction: f64,
    /// Sampling + transform + selection, ms (the rotation-matrix products
    /// follow on demand, `LocalLighting`).
    pub project_ms: f64,
}

/// The local lighting `L̃_k = 𝐑_k 𝐋` of the sampled normals (step 1),
/// formed on demand: [`WaveletRenderer::render_into`] forms the rows of the
/// normals its frame's vertices blend, the other entry points every row
/// they read. A lighting change clears `ready`.
#[derive(Debug, Default)]
struct LocalLighting {
    /// `ntess² × M` RGB; row `k` is valid where `ready[k]`.
    values: Vec<Vec3A>,
    /// Per sampled normal: whether its row holds the current lighting.
    ready: Vec<bool>,
}

/// The wavelet renderer state: rotation matrices and the local lighting of
/// every sampled normal.
pub struct WaveletRenderer {
    rot: Arc<RotationMatrices>,
    terms: usize,
    /// Ranking of the lighting's non-linear approximation.
    pub ranking: Ranking,
    light: SparseRgb,
    /// Behind a lock so that the `&self` frame paths can form missing rows.
    local: RwLock<LocalLighting>,
    world_from_env: Mat3,
    /// Samples per octahedral texel side when sampling a lighting function
    /// ([`WaveletRenderer::set_lighting_fn`], default 4). [`WaveletRenderer::set_lighting`]
    /// picks `max(this, ⌈√(env texels / N)⌉)` (≤ 8) so that every environment
    /// texel is sampled about once: a small sun keeps its energy.
    pub lighting_supersample: usize,
    /// Rule for combining the four sampled normals around a vertex normal.
    pub normal_interp: NormalInterp,
    /// Shading frames of the sampled normals (`ntess²`).
    frames: Vec<relight_sphere::Frame>,
    /// Incremented by every lighting change (keys [`VertexColors`]).
    lighting_generation: u64,
    /// This renderer among all (keys [`VertexColors`] with the generation).
    id: u64,
    /// The sample points of the last lighting's octahedral map.
    samples: Option<OctSamples>,
}

/// Source of [`WaveletRenderer`] ids.
static NEXT_RENDERER_ID: AtomicU64 = AtomicU64::new(1);

/// `w` with its local z raised to just above the horizon (1e-3) when below.
#[inline]
fn above_horizon(mut w: Vec3) -> Vec3 {
    if w.z < 1e-3 {
        w.z = 1e-3;
        w = w.normalize();
    }
    w
}

impl std::fmt::Debug for WaveletRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WaveletRenderer")
            .field("rot", &self.rot)
            .field("terms", &self.terms)
            .finish()
    }
}

impl WaveletRenderer {
    /// A renderer over `rot` keeping `terms` lighting coefficients (1..=N).
    ///
    /// # Errors
    /// `terms` out of range.
    pub fn new(rot: Arc<RotationMatrices>, terms: usize) -> Result<Self, WaveletError> {
        let p = *rot.params();
        if terms == 0 || terms > p.source_len() {
            return Err(bad(
                "terms",
                terms,
                format!("must be in 1..=N = {} (n = {})", p.source_len(), p.n),
            ));
        }
        Ok(Self {
            rot,
            terms,
            ranking: Ranking::Magnitude,
            light: SparseRgb::default(),
            local: RwLock::new(LocalLighting {
                values: vec![Vec3A::ZERO; p.normals() * p.target_len()],
                ready: vec![false; p.normals()],
            }),
            world_from_env: Mat3::IDENTITY,
            lighting_supersample: 4,
            normal_interp: NormalInterp::default(),
            frames: (0..p.normals())
                .map(|k| shading_frame(grid_normal(k, p.ntess).as_vec3()))
                .collect(),
            lighting_generation: 0,
            id: NEXT_RENDERER_ID.fetch_add(1, Ordering::Relaxed),
            samples: None,
        })
    }

    /// The rotation matrices.
    #[must_use]
    pub fn rotation(&self) -> &RotationMatrices {
        &self.rot
    }

    /// The current sparse source lighting.
    #[must_use]
    pub fn lighting(&self) -> &SparseRgb {
        &self.light
    }

    /// Local lighting of sampled normal `k` (M Haar coefficients, RGB),
    /// formed first if the current lighting lacks it.
    ///
    /// # Errors
    /// `k` ≥ ntess².
    pub fn local_lighting(&self, k: usize) -> Result<Vec<Vec3A>, WaveletError> {
        let normals = self.rot.params().normals();
        if k >= normals {
            return Err(bad("k", k, format!("must be < ntess² = {normals}")));
        }
        let mut wanted = vec![false; normals];
        wanted[k] = true;
        let local = self.local_for(&wanted)?;
        let mm = self.rot.params().target_len();
        Ok(local.values[k * mm..(k + 1) * mm].to_vec())
    }

    /// The local lighting with the rows `wanted` marks formed: a read lock
    /// when they are all current, else the missing rows are formed under a
    /// write lock first.
    fn local_for(
        &self,
        wanted: &[bool],
    ) -> Result<RwLockReadGuard<'_, LocalLighting>, WaveletError> {
        {
            let local = self.local.read().unwrap_or_else(PoisonError::into_inner);
            if wanted.iter().zip(&local.ready).all(|(&w, &r)| r || !w) {
                return Ok(local);
            }
        }
        {
            let mut guard = self.local.write().unwrap_or_else(PoisonError::into_inner);
            let LocalLighting { values, ready } = &mut *guard;
            let missing: Vec<bool> = wanted.iter().zip(&*ready).map(|(&w, &r)| w && !r).collect();
            self.rot
                .local_lighting_some(&self.light, values, &missing)?;
            for (r, m) in ready.iter_mut().zip(missing) {
                *r |= m;
            }
        }
        Ok(self.local.read().unwrap_or_else(PoisonError::into_inner))
    }

    /// The local lighting with every row formed.
    fn local_all(&self) -> Result<RwLockReadGuard<'_, LocalLighting>, WaveletError> {
        self.local_for(&vec![true; self.rot.params().normals()])
    }

    /// Marks, per sampled normal, whether one of `normals` blends it
    /// ([`normal_bilinear`]'s four neighbours).
    fn normals_blended(&self, normals: impl ParallelIterator<Item = Vec3>) -> Vec<bool> {
        let p = self.rot.params();
        let count = p.normals();
        normals
            .fold(
                || vec![false; count],
                |mut w, n| {
                    for k in normal_bilinear(n, p.ntess).0 {
                        w[k as usize] = true;
                    }
                    w
                },
            )
            .reduce(
                || vec![false; count],
                |mut a, b| {
                    for (x, y) in a.iter_mut().zip(b) {
                        *x |= y;
                    }
                    a
                },
            )
    }

    /// Starts a new lighting: every local-lighting row stale.
    fn lighting_changed(&mut self) {
        self.lighting_generation += 1;
        let local = self.local.get_mut().unwrap_or_else(PoisonError::into_inner);
        local.ready.fill(false);
    }

    /// Step 1 for an environment map rotated by `world_from_env`
    /// (`L_world(d) = env(world_from_envᵀ d)`, bilinear lookups).
    ///
    /// # Errors
    /// Only internal size errors.
    pub fn set_lighting(
        &mut self,
        env: &EnvMap,
        world_from_env: Mat3,
    ) -> Result<LightingStats, WaveletError> {
        let env_from_world = world_from_env.transpose();
        self.world_from_env = world_from_env;
        let n = self.rot.params().n;
        let ss = ((env.texels.len() as f64 / (n * n) as f64).sqrt().ceil() as usize)
            .clamp(self.lighting_supersample.max(1), 8);
        self.project(ss, |s| s.sample_env(env, env_from_world))
    }

    /// Step 1 for a lighting function of the world direction.
    ///
    /// # Errors
    /// Only internal size errors.
    pub fn set_lighting_fn(
        &mut self,
        f: impl Fn(Vec3) -> Vec3 + Sync,
    ) -> Result<LightingStats, WaveletError> {
        self.project(self.lighting_supersample.max(1), |s| s.sample(f))
    }

    /// Step 1's projection: `sample` gives the octahedral texels from the
    /// sample points at `ss × ss` per texel.
    fn project(
        &mut self,
        ss: usize,
        sample: impl FnOnce(&OctSamples) -> Vec<[f32; 3]>,
    ) -> Result<LightingStats, WaveletError> {
        let t0 = Instant::now();
        let n = self.rot.params().n;
        let samples = match self.samples.take() {
            Some(s) if s.size() == (n, ss.max(1)) => s,
            _ => OctSamples::new(n, ss),
        };
        let coeffs = haar_rgb(&sample(&samples), n);
        self.samples = Some(samples);
        self.light = top_k_rgb(&coeffs, n, self.terms, self.ranking);
        let energy = energy_fraction(&self.light, &coeffs);
        self.lighting_changed();
        Ok(LightingStats {
            terms: self.light.nnz(),
            energy_fraction: energy,
            project_ms: t0.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Step 1 from an already sparse source lighting (Haar coefficients on the n × n map).
    ///
    /// # Errors
    /// Indices ≥ N.
    pub fn set_lighting_sparse(&mut self, light: SparseRgb) -> Result<(), WaveletError> {
        self.rot.check_light(&light)?;
        self.light = light;
        self.lighting_changed();
        Ok(())
    }

    /// One BRDF bake per object, baked for this target size m; one normal per vertex.
    fn check_scene(&self, scene: &Scene, brdfs: &[&BrdfBake]) -> Result<(), WaveletError> {
        let meshes: Vec<&Arc<Mesh>> = scene.objects.iter().map(|o| &o.mesh).collect();
        self.check_meshes(&meshes, brdfs)
    }

    /// [`Self::check_scene`] for the meshes drawn.
    fn check_meshes(&self, meshes: &[&Arc<Mesh>], brdfs: &[&BrdfBake]) -> Result<(), WaveletError> {
        if brdfs.len() != meshes.len() {
            return Err(bad(
                "brdfs",
                brdfs.len(),
                format!("need one BRDF bake per object ({})", meshes.len()),
            ));
        }
        let m = self.rot.params().m;
        if let Some(b) = brdfs.iter().find(|b| b.params.m != m) {
            return Err(bad(
                "brdf m",
                b.params.m,
                format!("must equal the rotation matrices' m = {m}"),
            ));
        }
        for (i, mesh) in meshes.iter().enumerate() {
            if mesh.normals.len() != mesh.positions.len() {
                return Err(bad(
                    "mesh normals",
                    mesh.normals.len(),
                    format!("{} needs one normal per vertex", Numbered::object(i)),
                ));
            }
        }
        Ok(())
    }

    /// Colour of one surface point (normal `n`, unit view direction `wo`, world).
    #[inline]
    fn shade_point(&self, local: &[Vec3A], n: Vec3, wo: Vec3, brdf: &BrdfBake) -> Vec3A {
        let p = self.rot.params();
        let (mm, ntess) = (p.target_len(), p.ntess);
        let (nk, nw) = normal_bilinear(n, ntess);
        let lit = |c: usize| &local[nk[c] as usize * mm..][..mm];
        let above = above_horizon;
        // A view-independent slice makes both rules identical: take the cheaper.
        let rule = if brdf.view_independent {
            NormalInterp::Paper
        } else {
            self.normal_interp
        };
        match rule {
            NormalInterp::Paper => {
                let wl = above(shading_frame_fast(n).to_local(wo));
                let (idx, val) = brdf.slice(brdf.nearest_slice(wl));
                let (l0, l1, l2, l3) = (lit(0), lit(1), lit(2), lit(3));
                let mut acc = Vec3A::ZERO;
                for (&j, &f) in idx.iter().zip(val) {
                    let j = j as usize;
                    acc += f * (l0[j] * nw[0] + l1[j] * nw[1] + l2[j] * nw[2] + l3[j] * nw[3]);
                }
                acc.max(Vec3A::ZERO)
            }
            NormalInterp::MirrorAligned => {
                let r = 2.0 * n.dot(wo) * n - wo;
                let slice = |c: usize| {
                    let rc = self.frames[nk[c] as usize].to_local(r);
                    brdf.slice(brdf.nearest_slice(above(Vec3::new(-rc.x, -rc.y, rc.z))))
                };
                let ((i0, v0), (i1, v1), (i2, v2), (i3, v3)) =
                    (slice(0), slice(1), slice(2), slice(3));
                let (l0, l1, l2, l3) = (lit(0), lit(1), lit(2), lit(3));
                // One fused loop: four independent accumulator chains (all
                // slices hold `terms` entries, zero-padded).
                let (mut a0, mut a1, mut a2, mut a3) =
                    (Vec3A::ZERO, Vec3A::ZERO, Vec3A::ZERO, Vec3A::ZERO);
                let k = i0.len();
                let (i1, i2, i3) = (&i1[..k], &i2[..k], &i3[..k]);
                let (v0, v1, v2, v3) = (&v0[..k], &v1[..k], &v2[..k], &v3[..k]);
                for t in 0..k {
                    a0 += v0[t] * l0[i0[t] as usize];
                    a1 += v1[t] * l1[i1[t] as usize];
                    a2 += v2[t] * l2[i2[t] as usize];
                    a3 += v3[t] * l3[i3[t] as usize];
                }
                let out = a0 * nw[0] + a1 * nw[1] + a2 * nw[2] + a3 * nw[3];
                out.max(Vec3A::ZERO)
            }
        }
    }

    /// `𝐅_s · L̃_c`: slice `s` of `brdf` dotted with the local lighting of
    /// sampled normal `c` (paper Eq. 7), one accumulator in term order — the
    /// chain [`WaveletRenderer::shade_point`]'s mirror-aligned loop runs per
    /// neighbour, so the bits are the same.
    #[inline]
    fn slice_dot(&self, local: &[Vec3A], brdf: &BrdfBake, s: usize, c: usize) -> Vec3A {
        let mm = self.rot.params().target_len();
        let l = &local[c * mm..][..mm];
        let (idx, val) = brdf.slice(s);
        let mut a = Vec3A::ZERO;
        for (&j, &f) in idx.iter().zip(val) {
            a += f * l[j as usize];
        }
        a
    }

    /// [`WaveletRenderer::shade_point`] through a [`DotMemo`]: the four
    /// neighbours' dot products `𝐅_(s_c) · L̃_c` are looked up by the pair
    /// key `base + s_c · normals + c` (`base` is the bake's first key) and
    /// blended, `B = Σ_c w_c 𝐅_(s_c) · L̃_c`. Mirror-aligned: the same bits
    /// as `shade_point`. A view-independent bake uses slice 0 for every view
    /// (its slices are equal to 1e-6), and the paper's rule blends the
    /// products of its one slice instead of the lighting (equal by
    /// linearity, to rounding). Returns the colour and how many products
    /// were computed.
    #[inline]
    fn shade_point_memo(
        &self,
        local: &[Vec3A],
        n: Vec3,
        wo: Vec3,
        brdf: &BrdfBake,
        base: u32,
        memo: &DotMemo,
    ) -> (Vec3A, u32) {
        let p = self.rot.params();
        let normals = p.normals() as u32;
        let (nk, nw) = normal_bilinear(n, p.ntess);
        let slices: [usize; 4] = if brdf.view_independent {
            [0; 4]
        } else {
            match self.normal_interp {
                NormalInterp::Paper => {
                    [brdf.nearest_slice(above_horizon(shading_frame_fast(n).to_local(wo))); 4]
                }
                NormalInterp::MirrorAligned => {
                    let r = 2.0 * n.dot(wo) * n - wo;
                    nk.map(|k| {
                        let rc = self.frames[k as usize].to_local(r);
                        brdf.nearest_slice(above_horizon(Vec3::new(-rc.x, -rc.y, rc.z)))
                    })
                }
            }
        };
        let mut computed = 0;
        let a: [Vec3A; 4] = std::array::from_fn(|c| {
            let key = base + slices[c] as u32 * normals + nk[c];
            let (v, fresh) = memo.get_or(key, || {
                self.slice_dot(local, brdf, slices[c], nk[c] as usize)
            });
            computed += u32::from(fresh);
            v
        });
        let out = a[0] * nw[0] + a[1] * nw[1] + a[2] * nw[2] + a[3] * nw[3];
        (out.max(Vec3A::ZERO), computed)
    }

    /// Per-pixel variant of [`WaveletRenderer::render_with_mask`]: the same
    /// computation as a vertex, evaluated at every pixel with the
    /// interpolated normal (no Gouraud interpolation of colours; AO not applied).
    ///
    /// # Errors
    /// As [`WaveletRenderer::render`].
    pub fn render_per_pixel(
        &self,
        scene: &Scene,
        brdfs: &[&BrdfBake],
        camera: &Camera,
    ) -> Result<(Image, Vec<bool>), WaveletError> {
        self.check_scene(scene, brdfs)?;
        let normals: Vec<Vec<f32>> = scene
            .objects
            .iter()
            .map(|o| o.mesh.normals.iter().flat_map(|n| n.to_array()).collect())
            .collect();
        let draws: Vec<DrawCall> = scene
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                DrawCall::new(&o.mesh.positions, &o.mesh.indices)
                    .with_object_id(i as u32)
                    .with_attributes(3, &normals[i])
            })
            .collect();
        let mut img = Image::new(camera.width, camera.height);
        let env = &scene.env;
        let env_from_world = self.world_from_env.transpose();
        let bg = |d: Vec3| env.eval(env_from_world * d);
        let opts = RasterOptions::default().fit_depth(camera, &draws);
        let mut raster = Rasterizer::new();
        // Pixel normals reach every sampled normal between the vertices'.
        let local = self.local_all()?;
        let local = &local.values;
        let shader = |f: &relight_render::raster::Fragment| {
            let a = f.attributes;
            let n = Vec3::new(a[0], a[1], a[2]).normalize_or(f.normal);
            Vec3::from(self.shade_point(local, n, f.to_eye, brdfs[f.object as usize]))
        };
        raster
            .render(
                camera,
                &draws,
                shader,
                Background::Environment(&bg),
                &opts,
                &mut img,
            )
            .map_err(|e| bad("raster", e, "rasterization failed"))?;
        Ok((img, raster.gbuffer().coverage_mask()))
    }

    /// Step 2: colour of every vertex (`out[v]`), seen from `eye`, with the
    /// BRDF slices `brdf` and optional per-vertex ambient occlusion `ao`.
    ///
    /// # Errors
    /// Mismatched lengths, or a BRDF baked for another target size m.
    pub fn shade_vertices(
        &self,
        positions: &[Vec3],
        normals: &[Vec3],
        brdf: &BrdfBake,
        eye: Vec3,
        ao: Option<&[f32]>,
        out: &mut [Vec3],
    ) -> Result<(), WaveletError> {
        let p = self.rot.params();
        if brdf.params.m != p.m {
            return Err(bad(
                "brdf m",
                brdf.params.m,
                format!("must equal the rotation matrices' m = {}", p.m),
            ));
        }
        if normals.len() != positions.len() || out.len() != positions.len() {
            return Err(bad(
                "normals",
                normals.len(),
                format!(
                    "need one normal and output per vertex ({})",
                    positions.len()
                ),
            ));
        }
        if let Some(a) = ao.filter(|a| a.len() != positions.len()) {
            return Err(bad(
                "ao",
                a.len(),
                format!("need one value per vertex ({})", positions.len()),
            ));
        }
        let local = self.local_for(&self.normals_blended(normals.par_iter().copied()))?;
        let local = &local.values;
        out.par_chunks_mut(1024).enumerate().for_each(|(chunk, o)| {
            for (q, c) in o.iter_mut().enumerate() {
                let v = chunk * 1024 + q;
                let n = normals[v];
                let wo = (eye - positions[v]).normalize_or(n);
                let a = ao.map_or(1.0, |a| a[v]);
                *c = Vec3::from(self.shade_point(local, n, wo, brdf)) * a;
            }
        });
        Ok(())
    }

    /// Renders `scene` (objects' meshes with their normals; `brdfs[i]` baked
    /// for object `i`'s material; `ao[i]` optional per-vertex ambient
    /// occlusion of object `i`) through the rasterizer with Gouraud shading;
    /// the background shows the environment (rotated as lit).
    ///
    /// # Errors
    /// Mismatched inputs, meshes without normals, or a rasterizer error.
    pub fn render(
        &self,
        scene: &Scene,
        brdfs: &[&BrdfBake],
        camera: &Camera,
        ao: Option<&[Vec<f32>]>,
    ) -> Result<Image, WaveletError> {
        Ok(self.render_with_mask(scene, brdfs, camera, ao)?.0)
    }

    /// [`WaveletRenderer::render`], also returning the per-pixel coverage
    /// mask (true where an object is seen).
    ///
    /// # Errors
    /// As [`WaveletRenderer::render`].
    pub fn render_with_mask(
        &self,
        scene: &Scene,
        brdfs: &[&BrdfBake],
        camera: &Camera,
        ao: Option<&[Vec<f32>]>,
    ) -> Result<(Image, Vec<bool>), WaveletError> {
        let mut raster = Rasterizer::new();
        let mut img = Image::new(camera.width, camera.height);
        let mut cache = VertexColors::default();
        self.render_into(
            scene,
            brdfs,
            camera,
            ao,
            &mut raster,
            &mut cache,
            true,
            &mut img,
        )?;
        Ok((img, raster.gbuffer().coverage_mask()))
    }

    /// [`WaveletRenderer::render`] into `out` with a caller-kept `raster`
    /// and vertex-colour cache (their buffers reused across frames;
    /// afterwards the rasterizer's visibility buffer holds the frame's
    /// triangle ids, draw `i` = object `i`). `env_background` false leaves
    /// empty pixels black (for a caller that fills them itself).
    ///
    /// The rasterization is skipped when `raster` still holds the one this
    /// cache last asked for with the same camera and meshes (a lighting
    /// change, [`Rasterizer::generation`]).
    ///
    /// Step 2 runs only for the vertices of triangles seen in this frame's
    /// visibility buffer, and only once per eye position and lighting: a
    /// vertex no visible triangle uses cannot change a pixel, and a pass that
    /// moves the image by a sub-pixel offset reuses every colour already
    /// computed ([`VertexColors`]); objects with a view-independent bake
    /// (Lambert) keep their colours across view changes. The dot products
    /// go through the cache's [`DotMemo`] (each distinct slice × normal pair
    /// once per lighting, [`crate::memo`]). The image is the one shading
    /// every vertex with `WaveletRenderer::shade_point` gives: bit for bit
    /// for view-dependent bakes under [`NormalInterp::MirrorAligned`], to
    /// rounding (1e-5) otherwise.
    ///
    /// # Errors
    /// As [`WaveletRenderer::render`].
    #[allow(clippy::too_many_arguments)]
    pub fn render_into(
        &self,
        scene: &Scene,
        brdfs: &[&BrdfBake],
        camera: &Camera,
        ao: Option<&[Vec<f32>]>,
        raster: &mut Rasterizer,
        cache: &mut VertexColors,
        env_background: bool,
        out: &mut Image,
    ) -> Result<(), WaveletError> {
        let meshes: Vec<&Arc<Mesh>> = scene.objects.iter().map(|o| &o.mesh).collect();
        self.render_meshes_into(
            &meshes,
            &scene.env,
            brdfs,
            camera,
            ao,
            raster,
            cache,
            env_background,
            out,
        )
    }

    /// [`Self::render_into`] for meshes drawn in place of the scene's, one
    /// per object (a coarse object's refined copy,
    /// [`Scene::with_coarse_objects_refined`]), under the environment `env`.
    ///
    /// # Errors
    /// As [`WaveletRenderer::render`].
    #[allow(clippy::too_many_arguments)]
    pub fn render_meshes_into(
        &self,
        meshes: &[&Arc<Mesh>],
        env: &EnvMap,
        brdfs: &[&BrdfBake],
        camera: &Camera,
        ao: Option<&[Vec<f32>]>,
        raster: &mut Rasterizer,
        cache: &mut VertexColors,
        env_background: bool,
        out: &mut Image,
    ) -> Result<(), WaveletError> {
        self.check_meshes(meshes, brdfs)?;
        if let Some(a) = ao.filter(|a| a.len() != meshes.len()) {
            return Err(bad(
                "ao",
                a.len(),
                format!("need one AO list per object ({})", meshes.len()),
            ));
        }
        for (i, a) in ao.iter().flat_map(|a| a.iter()).enumerate() {
            let n = meshes[i].positions.len();
            if a.len() != n {
                return Err(bad(
                    "ao",
                    a.len(),
                    format!("{} needs one value per vertex ({n})", Numbered::object(i)),
                ));
            }
        }
        // Closed, outward meshes cull their back faces: the same visible
        // triangles (each back face is behind a front face of its own mesh),
        // half the triangles to raster. Open ones (the floor) keep both sides.
        let closed = cache.closed.of_meshes(meshes);
        let draws: Vec<DrawCall> = meshes
            .iter()
            .zip(&closed)
            .enumerate()
            .map(|(i, (mesh, closed))| {
                DrawCall::new(&mesh.positions, &mesh.indices)
                    .with_object_id(i as u32)
                    .with_cull(cull_for_closed(closed.as_ref(), camera.eye))
            })
            .collect();
        // A lighting change keeps the camera: the visibility buffer of the
        // last frame is this frame's when the rasterizer still holds it.
        if !cache.raster_holds(raster, camera, meshes, &closed) {
            let opts = RasterOptions::default().fit_depth(camera, &draws);
            raster
                .rasterize(camera, &draws, &opts)
                .map_err(|e| bad("raster", e, "rasterization failed"))?;
            cache.rastered = Some(RasterKey {
                generation: raster.generation(),
                camera: *camera,
                meshes: meshes.iter().map(|&m| m.clone()).collect(),
                closed: closed.clone(),
            });
        }
        let sizes: Vec<usize> = meshes.iter().map(|m| m.positions.len()).collect();
        // The memo's keys: one range of slices × normals per distinct bake.
        let normals = self.rot.params().normals() as u64;
        let mut bakes: Vec<usize> = Vec::with_capacity(brdfs.len());
        let mut bases: Vec<u64> = Vec::with_capacity(brdfs.len());
        let mut next_key = 0u64;
        for (i, b) in brdfs.iter().enumerate() {
            let addr = std::ptr::from_ref::<BrdfBake>(b) as usize;
            bakes.push(addr);
            match bakes[..i].iter().position(|&a| a == addr) {
                Some(j) => bases.push(bases[j]),
                None => {
                    bases.push(next_key);
                    let slices = b.indices.len() / b.params.terms.max(1);
                    next_key += slices as u64 * normals;
                }
            }
        }
        let use_memo = next_key <= u64::from(DotMemo::MAX_KEY) + 1;
        let view_dependent: Vec<bool> = brdfs.iter().map(|b| !b.view_independent).collect();
        let key = ColorKey {
            renderer: self.id,
            lighting: self.lighting_generation,
            interp: self.normal_interp,
            bakes,
            memo: use_memo,
        };
        cache.begin(camera.eye, key, &sizes, &view_dependent);
        // The vertices of visible triangles, once per visibility buffer.
        let generation = raster.generation();
        if cache.visible.as_ref().is_none_or(|(g, _)| *g != generation) {
            let list = cache.scan_visible(raster, &draws);
            cache.visible = Some((generation, list));
        }
        // Those not yet shaded for this eye and lighting, in mesh order.
        let todo: Vec<(u32, u32)> = {
            let stamps = &cache.stamps;
            let current = &cache.current;
            let visible = cache.visible.as_ref().map_or(&[][..], |(_, v)| &v[..]);
            visible
                .par_iter()
                .with_min_len(4096)
                .filter(|&&(d, v)| {
                    let stamp = current[d as usize];
                    stamps[d as usize][v as usize].swap(stamp, Ordering::Relaxed) != stamp
                })
                .copied()
                .collect()
        };
        // Step 1's products for the normals these vertices blend.
        let local = self.local_for(
            &self.normals_blended(
                todo.par_iter()
                    .map(|&(d, v)| meshes[d as usize].normals[v as usize]),
            ),
        )?;
        let local = &local.values;
        let eye = camera.eye;
        let memo = cache.memo.as_ref().filter(|_| use_memo);
        let slice_terms = |d: usize| brdfs[d].params.terms as u32;
        let shaded: Vec<(Vec3, u32)> = todo
            .par_iter()
            .with_min_len(256)
            .map(|&(d, v)| {
                let (d, v) = (d as usize, v as usize);
                let mesh = meshes[d];
                let n = mesh.normals[v];
                let wo = (eye - mesh.positions[v]).normalize_or(n);
                let a = ao.map_or(1.0, |a| a[d][v]);
                let (c, dots) = match memo {
                    // Pair keys fit: `bases[d] + s · normals + c < next_key`.
                    Some(m) => self.shade_point_memo(local, n, wo, brdfs[d], bases[d] as u32, m),
                    None => (self.shade_point(local, n, wo, brdfs[d]), 4),
                };
                (Vec3::from(c) * a, dots * slice_terms(d))
            })
            .collect();
        let mut terms = 0u64;
        for (&(d, v), (c, t)) in todo.iter().zip(shaded) {
            cache.colors[d as usize][v as usize] = c;
            terms += u64::from(t);
        }
        cache.shaded_last = todo.len();
        cache.terms_last = terms;
        let color_refs: Vec<&[Vec3]> = cache.colors.iter().map(|c| &c[..]).collect();
        let env_from_world = self.world_from_env.transpose();
        let bg = |d: Vec3| env.eval(env_from_world * d);
        let background = if env_background {
            Background::Environment(&bg)
        } else {
            Background::Color(Vec3::ZERO)
        };
        raster
            .shade_gouraud(&draws, &color_refs, background, out)
            .map_err(|e| bad("raster", e, "rasterization failed"))?;
        Ok(())
    }
}

/// What the colours in a [`VertexColors`] were computed for, besides the
/// eye: the renderer and its lighting, the blend rule, and the bakes (by
/// address, object by object).
#[derive(Clone, Debug, PartialEq)]
struct ColorKey {
    renderer: u64,
    lighting: u64,
    interp: NormalInterp,
    bakes: Vec<usize>,
    /// Whether the pair keys fit the memo.
    memo: bool,
}

/// Per-vertex colours kept between frames by [`WaveletRenderer::render_into`],
/// with the memo of their dot products ([`DotMemo`]). A colour is valid for
/// one lighting and, for an object whose bake depends on the view, one eye
/// position: a view-independent (Lambert) object keeps its colours across
/// view changes. A stamp per vertex says which colours are current; each
/// object has its own current stamp.
#[derive(Debug, Default)]
pub struct VertexColors {
    key: Option<ColorKey>,
    eye: Option<Vec3>,
    counter: u32,
    current: Vec<u32>,
    stamps: Vec<Vec<AtomicU32>>,
    colors: Vec<Vec<Vec3>>,
    memo: Option<DotMemo>,
    /// Which meshes are closed (their back faces culled from outside).
    closed: ClosedMeshes,
    /// What the caller's rasterizer was last rasterized for here.
    rastered: Option<RasterKey>,
    /// The vertices of the triangles a visibility buffer shows, `(object,
    /// vertex)` in mesh order, and the buffer's [`Rasterizer::generation`]:
    /// a lighting change under a still camera reuses them instead of
    /// scanning the buffer again.
    visible: Option<(u64, Vec<(u32, u32)>)>,
    /// Per vertex: the scan that last listed it in `visible` (dedup).
    seen: Vec<Vec<AtomicU32>>,
    seen_counter: u32,
    /// Vertices step 2 shaded in the last frame.
    pub shaded_last: usize,
    /// Slice terms step 2 multiplied with local lighting in the last frame
    /// (each an RGB multiply-add): the dot products the memo did not hold.
    pub terms_last: u64,
}

/// The rasterization a [`VertexColors`] asked for: the rasterizer's
/// generation it produced ([`Rasterizer::generation`]), the camera, and the
/// draws (each object's mesh, kept alive so that its address stays its own,
/// and whether its back faces were culled).
#[derive(Debug)]
struct RasterKey {
    generation: u64,
    camera: Camera,
    meshes: Vec<std::sync::Arc<relight_geom::Mesh>>,
    closed: Vec<Option<relight_geom::Aabb>>,
}

impl VertexColors {
    /// Whether `raster` holds this cache's last rasterization and it is the
    /// one `camera`, `meshes` and `closed` ask for.
    fn raster_holds(
        &self,
        raster: &Rasterizer,
        camera: &Camera,
        meshes: &[&Arc<Mesh>],
        closed: &[Option<relight_geom::Aabb>],
    ) -> bool {
        self.rastered.as_ref().is_some_and(|k| {
            k.generation != 0
                && k.generation == raster.generation()
                && k.camera == *camera
                && k.closed == closed
                && same_mesh_list(k.meshes.iter(), meshes.iter().copied())
        })
    }

    /// Starts a frame for `eye` and `key` over meshes of `sizes` vertices,
    /// `view_dependent[i]` when object `i`'s colours change with the eye;
    /// afterwards `current[i]` is the stamp of object `i`'s valid colours.
    /// The distinct vertices of the triangles `raster`'s visibility buffer
    /// shows (draw `d` = object `d`), sorted: in mesh order, neighbouring
    /// vertices have nearby normals and views, so consecutive ones read the
    /// same local-lighting rows, slices and memo pairs while they are in
    /// cache (the scan order jumps across objects and rows).
    fn scan_visible(&mut self, raster: &Rasterizer, draws: &[DrawCall]) -> Vec<(u32, u32)> {
        self.seen_counter = self.seen_counter.wrapping_add(1);
        if self.seen_counter == 0 {
            for s in self.seen.iter().flatten() {
                s.store(0, Ordering::Relaxed);
            }
            self.seen_counter = 1;
        }
        let (mark, seen) = (self.seen_counter, &self.seen);
        let g = raster.gbuffer();
        let mut list = g
            .triangle
            .par_chunks(g.width.max(1))
            .fold(Vec::new, |mut list: Vec<(u32, u32)>, ids| {
                let mut last = NO_TRIANGLE;
                for &id in ids {
                    if id == NO_TRIANGLE || id == last {
                        continue;
                    }
                    last = id;
                    let Some((d, t)) = raster.locate(id) else {
                        continue;
                    };
                    for &v in &draws[d].triangles[t] {
                        // A vertex is seen from several triangles: test
                        // before the (locked) swap that claims it.
                        let s = &seen[d][v as usize];
                        if s.load(Ordering::Relaxed) != mark
                            && s.swap(mark, Ordering::Relaxed) != mark
                        {
                            list.push((d as u32, v));
                        }
                    }
                }
                list
            })
            .reduce(Vec::new, |mut a, mut b| {
                if a.len() < b.len() {
                    std::mem::swap(&mut a, &mut b);
                }
                a.extend_from_slice(&b);
                a
            });
        list.par_sort_unstable();
        list
    }

    fn begin(&mut self, eye: Vec3, key: ColorKey, sizes: &[usize], view_dependent: &[bool]) {
        let same_sizes = self.colors.len() == sizes.len()
            && self.colors.iter().zip(sizes).all(|(c, &n)| c.len() == n);
        if !same_sizes {
            self.colors = sizes.iter().map(|&n| vec![Vec3::ZERO; n]).collect();
            self.stamps = sizes
                .iter()
                .map(|&n| (0..n).map(|_| AtomicU32::new(0)).collect())
                .collect();
            self.seen = sizes
                .iter()
                .map(|&n| (0..n).map(|_| AtomicU32::new(0)).collect())
                .collect();
            self.seen_counter = 0;
            self.visible = None;
            self.current = vec![0; sizes.len()];
            self.counter = 0;
            self.key = None;
        }
        let new_lighting = self.key.as_ref() != Some(&key);
        if !new_lighting && self.eye == Some(eye) {
            return;
        }
        self.counter = self.counter.wrapping_add(1);
        let all = if self.counter == 0 {
            for s in self.stamps.iter().flatten() {
                s.store(0, Ordering::Relaxed);
            }
            self.counter = 1;
            true
        } else {
            new_lighting
        };
        for (c, &dep) in self.current.iter_mut().zip(view_dependent) {
            if all || dep {
                *c = self.counter;
            }
        }
        if new_lighting {
            if key.memo {
                self.memo.get_or_insert_with(DotMemo::default).reset();
            }
            self.key = Some(key);
        }
        self.eye = Some(eye);
    }

    /// Forgets every colour (the meshes or materials changed).
    pub fn clear(&mut self) {
        self.key = None;
        self.closed = ClosedMeshes::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf_bake::{BrdfBakeParams, bake_brdf};
    use crate::rotation::{RotationParams, bake_rotation};
    use relight_brdf::{Brdf, Ggx, Lambert};
    use relight_geom::shapes;
    use relight_render::{NoProgress, Object};
    use relight_sphere::Param;

    /// Two GGX spheres sharing one bake and a Lambert torus, small bakes.
    fn setup() -> (WaveletRenderer, Scene, Vec<BrdfBake>) {
        let p = RotationParams::new(16, 8, 1);
        let rot = Arc::new(bake_rotation(&p, &NoProgress).unwrap());
        let mut r = WaveletRenderer::new(rot, 64).unwrap();
        r.set_lighting_fn(|d: Vec3| {
            let sun = Vec3::new(0.4, 0.8, 0.3).normalize();
            Vec3::new(0.3, 0.4, 0.5) + Vec3::splat(5.0 * d.dot(sun).max(0.0).powi(20))
        })
        .unwrap();
        let ggx: Arc<dyn Brdf> = Arc::new(Ggx::isotropic(0.2, Vec3::ONE).unwrap());
        let lambert: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::splat(0.8)).unwrap());
        let bakes = vec![
            bake_brdf(
                &BrdfBakeParams::new("ggx", p.m, 16, 32),
                ggx.as_ref(),
                &NoProgress,
            )
            .unwrap(),
            bake_brdf(
                &BrdfBakeParams::new("lambert", p.m, 16, 32),
                lambert.as_ref(),
                &NoProgress,
            )
            .unwrap(),
        ];
        assert!(!bakes[0].view_independent && bakes[1].view_independent);
        let sphere = |x: f32| Arc::new(shapes::uv_sphere_at(Vec3::new(x, 0.0, 0.0), 0.5, 40, 20));
        let torus = shapes::torus(0.45, 0.18, 40, 16)
            .transformed(glam::Affine3A::from_translation(Vec3::new(0.0, -0.6, 0.0)));
        let scene = Scene::new(
            vec![
                Object::new(sphere(-1.1), ggx.clone()),
                Object::new(Arc::new(torus), lambert),
                Object::new(sphere(1.1), ggx),
            ],
            EnvMap::from_fn(
                Param::LatLong {
                    width: 32,
                    height: 16,
                },
                |_| Vec3::ONE,
            ),
            Camera {
                eye: Vec3::new(0.0, 0.5, 4.0),
                target: Vec3::ZERO,
                up: Vec3::Y,
                vfov_deg: 50.0,
                width: 96,
                height: 64,
                image_offset: glam::Vec2::ZERO,
            },
        );
        (r, scene, bakes)
    }

    /// Every colour `cache` holds as current vs `shade_point` for `eye`:
    /// bit for bit for view-dependent bakes under the mirror-aligned rule,
    /// else to 1e-5 (relative, floor 1). Returns how many were checked per object.
    fn check(
        r: &WaveletRenderer,
        scene: &Scene,
        brdfs: &[&BrdfBake],
        cache: &VertexColors,
        eye: Vec3,
    ) -> Vec<usize> {
        let exact = r.normal_interp == NormalInterp::MirrorAligned;
        // Every row formed: a row formed on demand for a frame is the same
        // product as one formed here.
        let local = r.local_all().unwrap();
        let local = &local.values;
        (0..scene.objects.len())
            .map(|d| {
                let mesh = &scene.objects[d].mesh;
                let mut checked = 0;
                for v in 0..mesh.positions.len() {
                    if cache.stamps[d][v].load(Ordering::Relaxed) != cache.current[d] {
                        continue;
                    }
                    let n = mesh.normals[v];
                    let wo = (eye - mesh.positions[v]).normalize_or(n);
                    let want = Vec3::from(r.shade_point(local, n, wo, brdfs[d]));
                    let got = cache.colors[d][v];
                    if exact && !brdfs[d].view_independent {
                        assert_eq!(
                            got.to_array().map(f32::to_bits),
                            want.to_array().map(f32::to_bits),
                            "object {d} vertex {v}"
                        );
                    } else {
                        let e =
                            (got - want).abs().max_element() / want.abs().max_element().max(1.0);
                        assert!(e < 1e-5, "object {d} vertex {v}: {got} vs {want}");
                    }
                    checked += 1;
                }
                checked
            })
            .collect()
    }

    /// Culling the back faces of the closed meshes (the spheres and the
    /// torus) draws the image drawing both sides gives, bit for bit.
    #[test]
    fn culling_closed_meshes_keeps_the_image() {
        let (r, scene, bakes) = setup();
        let brdfs = [&bakes[0], &bakes[1], &bakes[0]];
        let mut raster = Rasterizer::new();
        for eye in [Vec3::new(0.0, 0.5, 4.0), Vec3::new(-2.5, 1.5, 2.0)] {
            let cam = Camera {
                eye,
                ..scene.camera
            };
            let mut draw = |cull: bool| {
                let mut cache = VertexColors::default();
                let mut img = Image::new(cam.width, cam.height);
                let mut go = |cache: &mut VertexColors| {
                    r.render_into(
                        &scene,
                        &brdfs,
                        &cam,
                        None,
                        &mut raster,
                        cache,
                        true,
                        &mut img,
                    )
                    .unwrap();
                };
                if !cull {
                    cache.closed = ClosedMeshes::disabled();
                }
                go(&mut cache);
                let closed = cache.closed.of(&scene);
                assert_eq!(
                    closed.iter().all(Option::is_some),
                    cull,
                    "all three are closed (culling on)"
                );
                (img, raster.gbuffer().covered_pixels())
            };
            let (culled, covered) = draw(true);
            let (both, covered_both) = draw(false);
            assert!(covered > 300, "{covered}");
            assert_eq!(covered, covered_both);
            for (a, b) in culled.pixels.iter().zip(&both.pixels) {
                assert_eq!(
                    a.to_array().map(f32::to_bits),
                    b.to_array().map(f32::to_bits)
                );
            }
        }
    }

    #[test]
    fn memo_and_kept_colours_equal_shading_every_vertex() {
        let (mut r, scene, bakes) = setup();
        let brdfs = [&bakes[0], &bakes[1], &bakes[0]];
        let (mut raster, mut cache) = (Rasterizer::new(), VertexColors::default());
        let mut img = Image::new(0, 0);
        let mut cam = scene.camera;
        let mut frame = |r: &WaveletRenderer, cam: &Camera, cache: &mut VertexColors| {
            img = Image::new(cam.width, cam.height);
            r.render_into(
                &scene,
                &brdfs,
                cam,
                None,
                &mut raster,
                cache,
                true,
                &mut img,
            )
            .unwrap();
            check(r, &scene, &brdfs, cache, cam.eye)
        };
        let first = frame(&r, &cam, &mut cache);
        assert!(first.iter().all(|&n| n > 100), "{first:?}");
        let dots_first = cache.terms_last;
        // Fewer products than 4 per vertex: neighbours share pairs.
        assert!(
            dots_first < 4 * 32 * cache.shaded_last as u64,
            "{dots_first}"
        );
        // A view change: the torus (Lambert) keeps its colours, the spheres are shaded again.
        cam.eye = Vec3::new(0.6, 0.7, 3.9);
        let shaded_before = cache.shaded_last;
        let second = frame(&r, &cam, &mut cache);
        assert!(second[0] > 100 && second[2] > 100, "{second:?}");
        assert!(
            cache.shaded_last < shaded_before,
            "{} vs {shaded_before}",
            cache.shaded_last
        );
        // Same eye again: nothing to shade.
        frame(&r, &cam, &mut cache);
        assert_eq!(cache.shaded_last, 0);
        // A lighting change: every colour again, matching the new lighting.
        r.set_lighting_fn(|d: Vec3| Vec3::new(1.0 + d.x, 0.5, 0.8 + 0.5 * d.y))
            .unwrap();
        frame(&r, &cam, &mut cache);
        assert!(
            cache.shaded_last >= shaded_before / 2,
            "{}",
            cache.shaded_last
        );
        // The paper's rule (products of one slice blended, to rounding).
        r.normal_interp = NormalInterp::Paper;
        let paper = frame(&r, &cam, &mut cache);
        assert!(paper.iter().all(|&n| n > 100), "{paper:?}");
    }

    /// A frame forms only the local lighting of the normals its vertices
    /// blend, and its image is the one every row formed up front gives, bit
    /// for bit; a lighting change makes every row stale again.
    #[test]
    fn frames_form_only_the_local_lighting_they_blend() {
        let (mut r, scene, bakes) = setup();
        let brdfs = [&bakes[0], &bakes[1], &bakes[0]];
        let cam = scene.camera;
        let formed = |r: &WaveletRenderer| {
            let local = r.local.read().unwrap();
            local.ready.iter().filter(|&&x| x).count()
        };
        let light = |d: Vec3| Vec3::new(1.0 + d.x, 0.5, 0.8 + 0.5 * d.y);
        r.set_lighting_fn(light).unwrap();
        assert_eq!(formed(&r), 0, "a lighting change forms nothing");
        let draw = |r: &WaveletRenderer| {
            let mut img = Image::new(cam.width, cam.height);
            r.render_into(
                &scene,
                &brdfs,
                &cam,
                None,
                &mut Rasterizer::new(),
                &mut VertexColors::default(),
                true,
                &mut img,
            )
            .unwrap();
            img.pixels
                .iter()
                .map(|p| p.to_array().map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        let lazy = draw(&r);
        let normals = r.rot.params().normals();
        let used = formed(&r);
        assert!(
            used > 0 && used < normals,
            "{used} of {normals} rows formed for one view"
        );
        r.set_lighting_fn(light).unwrap();
        drop(r.local_all().unwrap());
        assert_eq!(formed(&r), normals);
        assert_eq!(lazy, draw(&r), "rows formed on demand differ");
    }

    /// A lighting change under the same camera reuses the visibility buffer
    /// (the rasterizer's generation stays) and draws the image a fresh
    /// rasterizer and cache draw, bit for bit; a rasterization by anyone
    /// else in between, or another camera, rasterizes again.
    #[test]
    fn lighting_change_reuses_the_visibility_buffer() {
        let (mut r, scene, bakes) = setup();
        let brdfs = [&bakes[0], &bakes[1], &bakes[0]];
        let cam = scene.camera;
        let draw = |r: &WaveletRenderer, raster: &mut Rasterizer, cache: &mut VertexColors| {
            let mut img = Image::new(cam.width, cam.height);
            r.render_into(&scene, &brdfs, &cam, None, raster, cache, true, &mut img)
                .unwrap();
            img
        };
        let bits = |img: &Image| -> Vec<[u32; 3]> {
            img.pixels
                .iter()
                .map(|p| p.to_array().map(f32::to_bits))
                .collect()
        };
        let (mut raster, mut cache) = (Rasterizer::new(), VertexColors::default());
        draw(&r, &mut raster, &mut cache);
        let g0 = raster.generation();
        assert_ne!(g0, 0);
        r.set_lighting_fn(|d: Vec3| Vec3::new(1.0 + d.x, 0.5, 0.8 + 0.5 * d.y))
            .unwrap();
        let kept = draw(&r, &mut raster, &mut cache);
        assert_eq!(raster.generation(), g0, "the buffer was rasterized again");
        let fresh = draw(&r, &mut Rasterizer::new(), &mut VertexColors::default());
        assert_eq!(bits(&kept), bits(&fresh));
        // Someone else draws into the rasterizer: this cache must not trust it.
        let other = Camera {
            eye: Vec3::new(-2.5, 1.5, 2.0),
            ..cam
        };
        r.render_into(
            &scene,
            &brdfs,
            &other,
            None,
            &mut raster,
            &mut VertexColors::default(),
            true,
            &mut Image::new(cam.width, cam.height),
        )
        .unwrap();
        let g1 = raster.generation();
        assert_ne!(g1, g0);
        let again = draw(&r, &mut raster, &mut cache);
        assert_ne!(raster.generation(), g1, "a stale buffer was reused");
        assert_eq!(bits(&again), bits(&fresh));
    }
}
