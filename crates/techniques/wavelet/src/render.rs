//! The wavelet renderer (`--method wavelet`, wavelet-rotation-2006 §3
//! "Environment Map Rendering").
//!
//! # Two steps
//! 1. **Lighting change** ([`WaveletRenderer::set_lighting`]): the (rotated)
//!    environment is sampled onto the `n × n` octahedral map (solid-angle
//!    mean of ss × ss samples per texel, ss ≥ 4 and ≈ one sample per
//!    environment texel), Haar-transformed, approximated by its
//!    top `terms` coefficients (one RGB index set), and multiplied by every
//!    rotation matrix: `L̃_k = 𝐑_k 𝐋` for all sampled normals `k`, stored
//!    densely (`ntess² × M` RGB, `Vec3A`) so that step 2 gathers by index.
//! 2. **View change** ([`WaveletRenderer::shade_vertices`]): per vertex, the
//!    local view direction `ω_o` in the vertex's [`crate::octa::shading_frame`] picks the
//!    nearest baked BRDF slice `𝐅` (paper: no view interpolation, a dense
//!    view grid instead); the local lighting is bilinearly interpolated over
//!    the four nearest sampled normals; the colour is the sparse dot product
//!    `𝐅 · Σ_c w_c L̃_c` (paper Eq. 7), times an optional per-vertex ambient
//!    occlusion. The colours are drawn by the rasterizer with Gouraud shading.
//!
//! Vertices seen from behind (`n · ω_o < 0`) are shaded with `ω_o` pushed to
//! just above the horizon (a closed mesh hides them anyway).

use crate::brdf_bake::BrdfBake;
use crate::error::{WaveletError, bad};
use crate::lighting::{haar_rgb, sample_octahedral};
use crate::octa::{normal_bilinear, shading_frame_fast};
use crate::rotation::RotationMatrices;
use glam::{Mat3, Vec3, Vec3A};
use rayon::prelude::*;
use relight_haar::{Ranking, SparseRgb, energy_fraction, top_k_rgb};
use relight_render::raster::{Background, DrawCall, RasterOptions, Rasterizer};
use relight_render::{Camera, Image, Scene};
use relight_sphere::EnvMap;
use std::sync::Arc;
use std::time::Instant;

/// What one lighting change did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LightingStats {
    /// Terms kept.
    pub terms: usize,
    /// Fraction of the lighting's Haar L2 energy kept by the terms.
    pub energy_fraction: f64,
    /// Sampling + transform + selection, ms.
    pub project_ms: f64,
    /// Multiplication by every rotation matrix, ms.
    pub rotate_ms: f64,
}

/// The wavelet renderer state: rotation matrices and the local lighting of
/// every sampled normal.
pub struct WaveletRenderer {
    rot: Arc<RotationMatrices>,
    terms: usize,
    /// Ranking of the lighting's non-linear approximation.
    pub ranking: Ranking,
    light: SparseRgb,
    local: Vec<Vec3A>,
    world_from_env: Mat3,
    /// Samples per octahedral texel side when sampling a lighting function
    /// ([`WaveletRenderer::set_lighting_fn`], default 4). [`WaveletRenderer::set_lighting`]
    /// picks `max(this, ⌈√(env texels / N)⌉)` (≤ 8) so that every environment
    /// texel is sampled about once: a small sun keeps its energy.
    pub lighting_supersample: usize,
}

impl std::fmt::Debug for WaveletRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WaveletRenderer")
            .field("rot", &self.rot)
            .field("terms", &self.terms)
            .finish()
    }
}

/// Lighting rotation from yaw (about world +Y), pitch (about +X) and roll
/// (about +Z), in degrees: `world_from_env = R_y(yaw) · R_x(pitch) · R_z(roll)`.
#[must_use]
pub fn light_rotation(yaw_deg: f32, pitch_deg: f32, roll_deg: f32) -> Mat3 {
    Mat3::from_rotation_y(yaw_deg.to_radians())
        * Mat3::from_rotation_x(pitch_deg.to_radians())
        * Mat3::from_rotation_z(roll_deg.to_radians())
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
            local: vec![Vec3A::ZERO; p.normals() * p.target_len()],
            world_from_env: Mat3::IDENTITY,
            lighting_supersample: 4,
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

    /// Local lighting of sampled normal `k` (M Haar coefficients, RGB).
    #[must_use]
    pub fn local_lighting(&self, k: usize) -> &[Vec3A] {
        let mm = self.rot.params().target_len();
        &self.local[k * mm..(k + 1) * mm]
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
        self.project(ss, |d| env.eval(env_from_world * d))
    }

    /// Step 1 for a lighting function of the world direction.
    ///
    /// # Errors
    /// Only internal size errors.
    pub fn set_lighting_fn(
        &mut self,
        f: impl Fn(Vec3) -> Vec3 + Sync,
    ) -> Result<LightingStats, WaveletError> {
        self.project(self.lighting_supersample.max(1), f)
    }

    fn project(
        &mut self,
        ss: usize,
        f: impl Fn(Vec3) -> Vec3 + Sync,
    ) -> Result<LightingStats, WaveletError> {
        let t0 = Instant::now();
        let n = self.rot.params().n;
        let coeffs = haar_rgb(&sample_octahedral(n, ss, f), n);
        self.light = top_k_rgb(&coeffs, n, self.terms, self.ranking);
        let energy = energy_fraction(&self.light, &coeffs);
        let t1 = Instant::now();
        self.rot.local_lighting(&self.light, &mut self.local)?;
        Ok(LightingStats {
            terms: self.light.nnz(),
            energy_fraction: energy,
            project_ms: (t1 - t0).as_secs_f64() * 1e3,
            rotate_ms: t1.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Step 1 from an already sparse source lighting (Haar coefficients on the n × n map).
    ///
    /// # Errors
    /// Indices ≥ N.
    pub fn set_lighting_sparse(&mut self, light: SparseRgb) -> Result<(), WaveletError> {
        self.light = light;
        self.rot.local_lighting(&self.light, &mut self.local)
    }

    /// Colour of one surface point (normal `n`, unit view direction `wo`, world).
    #[inline]
    fn shade_point(&self, n: Vec3, wo: Vec3, brdf: &BrdfBake) -> Vec3A {
        let p = self.rot.params();
        let (mm, ntess) = (p.target_len(), p.ntess);
        let frame = shading_frame_fast(n);
        let mut wl = frame.to_local(wo);
        if wl.z < 1e-3 {
            wl.z = 1e-3;
            wl = wl.normalize();
        }
        let (idx, val) = brdf.slice(brdf.nearest_slice(wl));
        let (nk, nw) = normal_bilinear(n, ntess);
        let local = &self.local;
        let l0 = &local[nk[0] as usize * mm..][..mm];
        let l1 = &local[nk[1] as usize * mm..][..mm];
        let l2 = &local[nk[2] as usize * mm..][..mm];
        let l3 = &local[nk[3] as usize * mm..][..mm];
        let mut acc = Vec3A::ZERO;
        for (&j, &f) in idx.iter().zip(val) {
            let j = j as usize;
            acc += f * (l0[j] * nw[0] + l1[j] * nw[1] + l2[j] * nw[2] + l3[j] * nw[3]);
        }
        acc.max(Vec3A::ZERO)
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
        if brdfs.len() != scene.objects.len() {
            return Err(bad(
                "brdfs",
                brdfs.len(),
                format!("need one BRDF bake per object ({})", scene.objects.len()),
            ));
        }
        let p = self.rot.params();
        for b in brdfs {
            if b.params.m != p.m {
                return Err(bad(
                    "brdf m",
                    b.params.m,
                    format!("must equal the rotation matrices' m = {}", p.m),
                ));
            }
        }
        let normals: Vec<Vec<f32>> = scene
            .objects
            .iter()
            .map(|o| o.mesh.normals.iter().flat_map(|n| n.to_array()).collect())
            .collect();
        for (i, o) in scene.objects.iter().enumerate() {
            if o.mesh.normals.len() != o.mesh.positions.len() {
                return Err(bad(
                    "mesh normals",
                    o.mesh.normals.len(),
                    format!("object {i} needs one normal per vertex"),
                ));
            }
        }
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
        let shader = |f: &relight_render::raster::Fragment| {
            let a = f.attributes;
            let n = Vec3::new(a[0], a[1], a[2]).normalize_or(f.normal);
            Vec3::from(self.shade_point(n, f.to_eye, brdfs[f.object as usize]))
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
        out.par_chunks_mut(1024).enumerate().for_each(|(chunk, o)| {
            for (q, c) in o.iter_mut().enumerate() {
                let v = chunk * 1024 + q;
                let n = normals[v];
                let wo = (eye - positions[v]).normalize_or(n);
                let a = ao.map_or(1.0, |a| a[v]);
                *c = Vec3::from(self.shade_point(n, wo, brdf)) * a;
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
        if brdfs.len() != scene.objects.len() {
            return Err(bad(
                "brdfs",
                brdfs.len(),
                format!("need one BRDF bake per object ({})", scene.objects.len()),
            ));
        }
        if let Some(a) = ao.filter(|a| a.len() != scene.objects.len()) {
            return Err(bad(
                "ao",
                a.len(),
                format!("need one AO list per object ({})", scene.objects.len()),
            ));
        }
        let mut colors = Vec::with_capacity(scene.objects.len());
        for (i, obj) in scene.objects.iter().enumerate() {
            let mesh = &obj.mesh;
            if mesh.normals.len() != mesh.positions.len() {
                return Err(bad(
                    "mesh normals",
                    mesh.normals.len(),
                    format!("object {i} needs one normal per vertex"),
                ));
            }
            let mut c = vec![Vec3::ZERO; mesh.positions.len()];
            self.shade_vertices(
                &mesh.positions,
                &mesh.normals,
                brdfs[i],
                camera.eye,
                ao.map(|a| &a[i][..]),
                &mut c,
            )?;
            colors.push(c);
        }
        let draws: Vec<DrawCall> = scene
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                DrawCall::new(&o.mesh.positions, &o.mesh.indices).with_object_id(i as u32)
            })
            .collect();
        let color_refs: Vec<&[Vec3]> = colors.iter().map(|c| &c[..]).collect();
        let mut img = Image::new(camera.width, camera.height);
        let env = &scene.env;
        let env_from_world = self.world_from_env.transpose();
        let bg = |d: Vec3| env.eval(env_from_world * d);
        let opts = RasterOptions::default().fit_depth(camera, &draws);
        let mut raster = Rasterizer::new();
        raster
            .render_gouraud(
                camera,
                &draws,
                &color_refs,
                Background::Environment(&bg),
                &opts,
                &mut img,
            )
            .map_err(|e| bad("raster", e, "rasterization failed"))?;
        Ok((img, raster.gbuffer().coverage_mask()))
    }
}
