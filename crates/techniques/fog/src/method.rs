//! [`FogRelighter`]: the fog method behind the method interface
//! ([`relight_render::method::Relighter`], name `fog`). It renders a whole
//! [`Scene`] in its homogeneous medium as the sum of two images of the same
//! camera and antialiasing:
//!
//! 1. **Point lights** by the analytic single-scattering model (Sun 2008,
//!    ch. 3; [`crate::render`]): every covered pixel is L = e^{−T_vp} L_p + L_a
//!    (eq. 3.29) with each object's BRDF fitted to the paper's Lambert + Phong
//!    surface ([`FogMaterial::fit`]); an empty pixel gets the airlight along
//!    its ray's span in the fog ball (eq. 3.16 over the finite segment). The
//!    eye may be outside the ball: the model then runs from each ray's entry
//!    ([`crate::view_segment`], exact).
//! 2. **The environment** as the thesis' foggy lighting (§3.6.4,
//!    eqs. 3.35–3.37) with the ball's own scattering kernel: SH shading
//!    ([`relight_shlight::LitScene`]) of the lighting L′_lm = (e^{−T} + a·w_l)
//!    L_lm at T = β·R ([`relight_render::Medium::env_thickness`]; a the
//!    albedo scales the single-scattered part), w_l the kernel's band weights
//!    ([`EnvGlow::Ball`], [`crate::psf::ball_convolution_weights`]: the
//!    directional environment entering the ball at its edge, exact at its
//!    centre; [`EnvGlow::Thesis`] keeps the thesis' point-source PSF). An
//!    empty pixel shows e^{−T_d} L(d) + g·a·(K ⊛ L)(d) for its ray's chord of
//!    optical thickness T_d and glow weight g, and a surface's radiance
//!    crosses its view segment in the ball as L = e^{−βD} L_s + s·a·L̄·G_c
//!    with L̄ = (1/4π)∫L dω: the segment's share s of the scattering, taken
//!    with g from [`crate::view_segment::ChordGlow`] (exact for a uniform
//!    sky). Each surface is shaded with the centre's lighting, scaled by
//!    its factor for its place in the ball
//!    ([`crate::ball_light::BallIrradiance`], exact for a Lambertian
//!    surface under a uniform sky).
//!    By default the surface part is shaded at the frame's visible vertices
//!    and interpolated ([`crate::env_vertex`], [`EnvShading::PerVertex`]);
//!    [`EnvShading::PerPixel`] shades every sample with `env_rotation`.
//!
//! Both parts shade one visibility buffer: the frame is rasterized once.
//!
//! What it reads: β, albedo and R from `scene.medium` (none, or β = 0: plain
//! direct lighting of the point lights plus the unfogged environment), the
//! lights from `scene.point_lights` (it never invents lights;
//! [`crate::default_scene_lights`] is a helper for scenes that want some),
//! and the environment with `world_from_env`. Every default lives in
//! [`FogOptions::default`].
//!
//! # What it does not render
//! No shadows (the analytic model has no visibility), no normal maps, no
//! spatially varying BRDFs, no area lights: [`Relighter::supports`] says
//! [`Support::No`] and `check_scene` turns those into errors. The environment
//! is rendered by the thesis' model of §3.6.4 and so is [`Support::Full`]: its
//! approximations ([`ENVIRONMENT_APPROXIMATION`]) are the method's error, which
//! `relight verify methods` measures against the reference. Every point
//! light must lie inside the fog ball, and surfaces are assumed inside it
//! too; the eye may be anywhere within 40 mean free paths of it
//! ([`crate::view_segment::MAX_EYE_DEPTH`]). BRDFs other than Lambert +
//! Phong are fitted, not evaluated.
//!
//! # Timings
//! `set_lighting` — the band weights of eq. 3.35, the chord table when the
//! medium changed, light checks, and the
//! filtered environment's SH rotated to the world frame (per vertex: one
//! rotation of n² coefficients, [`EnvLighting`]; per pixel: into every
//! vertex frame, [`relight_shlight::LitScene::light`], when the
//! environment, its rotation or the medium changed) — is the lighting
//! change; `render` — the rasterization, the visible vertices' environment
//! shading and the per-pixel passes — is the view change.

use crate::FogError;
use crate::ball_light::BallIrradiance;
use crate::env_vertex::{
    BackgroundScratch, EnvLighting, EnvShading, VertexFrame, VertexShader, faces_eye,
};
use crate::model::{FogMaterial, Phase, PointLight};
use crate::render::{
    FogMode, FogObject, FogSettings, rasterize_objects, render_fog_into, shade_fog_raster,
    validate_lights,
};
use crate::table::{FogTables, Interp};
use crate::view_segment;
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_render::method::{
    FrameRequest, FrameTimings, FrameWork, MethodError, Relighter, Rendered, SceneFeature, Support,
    coverage_of_raster, frame_paints_background,
};
use relight_render::raster::{NO_TRIANGLE, Rasterizer};
use relight_render::{Camera, Image, Medium, Numbered, Progress, Scene};
use relight_shlight::{Background, LightingFilter, LitScene, ShRenderer, ShRotationMethod};
use relight_sphere::EnvMap;
use std::sync::Arc;
use std::time::Instant;

/// The method's name on the command line.
pub const NAME: &str = "fog";

/// How the environment part approximates (the text of its
/// [`Support::Approximate`]).
pub const ENVIRONMENT_APPROXIMATION: &str = "in a medium the environment lights every surface \
     with the directions of the fog ball's centre (T = β·R, sun-thesis eqs. 3.35–3.37 with the \
     ball's single-scattering kernel, band-limited to the SH order), scaled to the surface's place \
     as a uniform sky's irradiance, and the light a view ray scatters has the centre's \
     directions, scaled to its chord as a uniform sky's; no shadows or multiple scattering";

/// Every default of the fog method (the one place they live).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FogOptions {
    /// Side of the 2D airlight and G tables (Figure 3.6: 64² suffices).
    pub table_size: usize,
    /// Analytic single scattering, or classic OpenGL GL_EXP fog for
    /// comparison (then the environment is only blended by e^{−βD} and the
    /// background is the fog colour).
    pub mode: FogMode,
    /// Table interpolation.
    pub interp: Interp,
    /// SH order (bands) of the environment part.
    pub env_order: usize,
    /// Per-pixel SH rotation of the environment part (matters only on
    /// curved, tangent-framed meshes; no normal maps are applied).
    pub env_rotation: ShRotationMethod,
    /// The environment's single-scattered glow: the ball's exact kernel
    /// (the default) or the thesis' point-source PSF.
    pub env_glow: EnvGlow,
    /// Reject point lights inside closed meshes (brute force per lighting
    /// change, O(lights × triangles)).
    pub check_lights_inside: bool,
    /// Where the environment part is shaded: at the visible vertices
    /// (Gouraud, [`crate::env_vertex`]; the default, what the thesis' model
    /// allows "for each vertex or pixel") or per sample with `env_rotation`.
    pub env_shading: EnvShading,
}

impl Default for FogOptions {
    fn default() -> Self {
        Self {
            table_size: 64,
            mode: FogMode::Analytic,
            interp: Interp::Bilinear,
            env_order: 6,
            env_rotation: ShRotationMethod::Exact,
            env_glow: EnvGlow::Ball,
            check_lights_inside: true,
            env_shading: EnvShading::PerVertex,
        }
    }
}

/// The kernel that scatters the environment into the view (and into the
/// light a surface receives) in the environment part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvGlow {
    /// Single scattering of the directional environment in the scene's
    /// fog ball, exact at its centre
    /// ([`crate::psf::ball_convolution_weights`]).
    Ball,
    /// The thesis' PSF (eqs. 3.30–3.35): point sources at distance R in an
    /// unbounded medium; `factorized`: the empirical T e^{−T} NPSF of
    /// eq. 3.32 (what the thesis uses), else the exact PSF_T of eq. 3.30.
    Thesis { factorized: bool },
}

/// The medium as the method reads it: β (0 without one), albedo, radius.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MediumParams {
    beta: f32,
    albedo: f32,
    radius: Option<f32>,
}

impl MediumParams {
    fn of(scene: &Scene) -> Result<Self, MethodError> {
        let Some(m) = scene.medium else {
            return Ok(Self {
                beta: 0.0,
                albedo: 1.0,
                radius: None,
            });
        };
        let bad = |option: &'static str, message: String| MethodError::InvalidOption {
            method: NAME,
            option,
            message,
        };
        if !(m.beta.is_finite() && m.beta >= 0.0) {
            return Err(bad(
                "medium.beta",
                format!("must be finite and ≥ 0 (got {})", m.beta),
            ));
        }
        if !(0.0..=1.0).contains(&m.albedo) {
            return Err(bad(
                "medium.albedo",
                format!("must be in [0, 1] (got {})", m.albedo),
            ));
        }
        if !(m.radius.is_finite() && m.radius > 0.0) {
            return Err(bad(
                "medium.radius",
                format!("must be finite and > 0 (got {})", m.radius),
            ));
        }
        Ok(Self {
            beta: m.beta,
            albedo: m.albedo,
            radius: Some(m.radius),
        })
    }

    /// Optical thickness from the centre to the environment.
    fn env_thickness(&self) -> f32 {
        self.radius.map_or(0.0, |r| self.beta * r)
    }

    /// The fog ball, where there is a medium (β > 0).
    fn ball(&self) -> Option<Medium> {
        self.radius
            .filter(|_| self.beta > 0.0)
            .map(|radius| Medium {
                beta: self.beta,
                albedo: self.albedo,
                radius,
            })
    }
}

/// The lighting of the last [`Relighter::set_lighting`].
#[derive(Clone, Debug)]
struct Lighting {
    medium: MediumParams,
    lights: Vec<PointLight>,
    /// The environment's mean radiance (1/4π)∫L dω (rotation invariant).
    env_mean: Vec3,
    /// (T, albedo, filter) of the environment part, cached.
    filter: (f32, f32, LightingFilter),
    /// The empty pixels' weights along their chords through the ball, and
    /// the surfaces' factors for their place in it (`None`: no ball or
    /// β = 0), cached with the medium.
    chords: Option<(view_segment::ChordGlow, BallIrradiance)>,
}

/// The fog method (see the module docs).
pub struct FogRelighter {
    options: FogOptions,
    /// Fitted surface of each object, from [`Relighter::prepare`].
    materials: Vec<FogMaterial>,
    tables: Option<FogTables>,
    /// The SH renderer of the environment part: its BRDF bakes, the
    /// lighting filter and rotation.
    sh: ShRenderer,
    /// The environment part's SH state between frames (scenes with an
    /// environment), so a view change only rasterizes and shades it.
    env: Option<LitScene>,
    /// The environment part of the last frame (supersampled), reused
    /// ([`EnvShading::PerPixel`]).
    env_image: Image,
    /// [`EnvShading::PerVertex`]: the objects' transfers, the world-frame
    /// lighting of the last lighting change and the per-vertex colours.
    vertex: Option<(VertexShader, VertexFrame)>,
    env_lighting: Option<EnvLighting>,
    lighting: Option<Lighting>,
    /// Per sample of the last per-vertex environment pass in a medium: a
    /// covered sample's view segment weights, an empty one's chord weights
    /// (`ChordGlow`), and the medium they were found for. They depend on the
    /// view and the medium only, so a lighting change under a still camera
    /// reads them.
    view_weights: Vec<[f32; 2]>,
    view_weights_for: Option<MediumParams>,
    rasterizer: Rasterizer,
    /// Which meshes are closed (their back faces culled from outside).
    closed: relight_render::cull::ClosedMeshes,
    /// What `rasterizer` holds: the (supersampled) camera and the meshes
    /// drawn, so a lighting change under a still camera draws no triangles.
    rasterized: Option<(Camera, Vec<Arc<Mesh>>)>,
    phase: Phase,
    /// The environment of the last lighting change and its mean radiance
    /// (1/4π)∫L dω: a sum over every texel with its exact solid angle,
    /// rotation invariant, so a lighting change that only turns the
    /// environment reuses it.
    env_mean: Option<(EnvMap, Vec3)>,
}

impl std::fmt::Debug for FogRelighter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FogRelighter")
            .field("options", &self.options)
            .field("materials", &self.materials)
            .finish_non_exhaustive()
    }
}

fn failed(e: impl std::error::Error + Send + Sync + 'static) -> MethodError {
    MethodError::failed(NAME, e)
}

impl FogRelighter {
    /// A fog method with `options`.
    ///
    /// # Errors
    /// A table size below 2 or an SH order outside what the SH renderer
    /// supports ([`MethodError::InvalidOption`]).
    pub fn new(options: FogOptions) -> Result<Self, MethodError> {
        if !(2..=crate::table::MAX_TABLE_SIZE).contains(&options.table_size) {
            return Err(MethodError::InvalidOption {
                method: NAME,
                option: "table_size",
                message: FogError::TableSize {
                    size: options.table_size,
                }
                .to_string(),
            });
        }
        let sh = ShRenderer::new(options.env_order, options.env_rotation).map_err(|e| {
            MethodError::InvalidOption {
                method: NAME,
                option: "env_order",
                message: e.to_string(),
            }
        })?;
        Ok(Self {
            options,
            materials: Vec::new(),
            tables: None,
            sh,
            env: None,
            env_image: Image::new(1, 1),
            vertex: None,
            env_lighting: None,
            lighting: None,
            view_weights: Vec::new(),
            view_weights_for: None,
            rasterizer: Rasterizer::new(),
            closed: relight_render::cull::ClosedMeshes::default(),
            rasterized: None,
            phase: Phase::isotropic(),
            env_mean: None,
        })
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &FogOptions {
        &self.options
    }

    /// The per-band multipliers of the environment part at optical
    /// thickness `t` and albedo `albedo` (eqs. 3.35–3.37): direct e^{−T},
    /// bands a·w_l, w_l the [`EnvGlow`] kernel's (the thesis' √(4π/(2l+1))
    /// PSF_l, or the ball's).
    #[must_use]
    pub fn environment_filter(&self, t: f32, albedo: f32) -> LightingFilter {
        if t <= 0.0 {
            return LightingFilter {
                direct: 1.0,
                bands: Vec::new(),
            };
        }
        let (t64, order) = (f64::from(t), self.options.env_order);
        let w = match self.options.env_glow {
            EnvGlow::Ball => crate::psf::ball_convolution_weights(t64, order),
            EnvGlow::Thesis { factorized } => {
                crate::psf::convolution_weights(t64, order, factorized)
            }
        };
        LightingFilter {
            direct: (-t).exp(),
            bands: w.iter().map(|&x| albedo * x as f32).collect(),
        }
    }

    fn objects<'s>(&self, scene: &'s Scene) -> Vec<FogObject<'s>> {
        scene
            .objects
            .iter()
            .zip(&self.materials)
            .map(|(o, m)| FogObject {
                mesh: &o.mesh,
                material: *m,
            })
            .collect()
    }

    fn is_prepared_for(&self, scene: &Scene) -> bool {
        self.tables.is_some()
            && self.materials.len() == scene.objects.len()
            && match &self.env {
                Some(e) => scene.has_environment() && e.is_built_for(scene),
                None => !scene.has_environment(),
            }
    }

    /// Whether the environment part runs in the OpenGL-fog mode (no PSF:
    /// the plain environment, a black sky).
    fn opengl(&self) -> bool {
        matches!(self.options.mode, FogMode::OpenGl { .. })
    }

    /// The environment part at `camera` (the supersampled frame) into
    /// `self.env_image`, before the view segment: `false` without an
    /// environment.
    fn environment_image(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        progress: &dyn Progress,
    ) -> Result<bool, MethodError> {
        let opengl = self.opengl();
        let Some(env) = self.env.as_mut() else {
            return Ok(false);
        };
        progress.check()?;
        let background = if opengl {
            Background::Black
        } else {
            Background::All
        };
        let maps = vec![None; scene.objects.len()];
        env.shade_raster_into(
            &self.rasterizer,
            scene,
            camera,
            self.options.env_order,
            self.options.env_rotation,
            &maps,
            f32::INFINITY,
            background,
            &mut self.env_image,
        )
        .map_err(failed)?;
        Ok(true)
    }
}

impl FogRelighter {
    /// One supersampled frame (`request.aa` per side) under `lighting`:
    /// one rasterization, the point lights per pixel, then the environment
    /// part carried along each covered pixel's view segment.
    fn frame(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        lighting: &Lighting,
        progress: &dyn Progress,
    ) -> Result<Image, MethodError> {
        let k = request.aa;
        let mut big = request.camera;
        big.width *= k;
        big.height *= k;
        let m = lighting.medium;
        // 1. Point lights, on the frame's one visibility buffer.
        let mut image = Image::new(big.width, big.height);
        // Whether the visibility buffer is the last frame's (same camera
        // and meshes): then the visible vertices' transfers are too.
        let mut reused = false;
        {
            let objects = self.objects(scene);
            let tables = self.tables.as_ref().expect("built by prepare");
            let mut settings = FogSettings::new(tables, m.beta);
            settings.phase = self.phase.clone();
            settings.interp = self.options.interp;
            settings.mode = self.options.mode;
            settings.check_lights_inside = false;
            settings.albedo = m.albedo;
            settings.ball_radius = m.radius;
            let fog_err = |e| match e {
                FogError::Cancelled => MethodError::Cancelled,
                e => failed(e),
            };
            if self.opengl() {
                self.rasterized = None;
                render_fog_into(
                    &mut self.rasterizer,
                    &objects,
                    &big,
                    &lighting.lights,
                    &settings,
                    &mut image,
                )
                .map_err(fog_err)?;
            } else {
                let same = self.rasterized.as_ref().is_some_and(|(c, meshes)| {
                    *c == big
                        && meshes.len() == scene.objects.len()
                        && meshes
                            .iter()
                            .zip(&scene.objects)
                            .all(|(m, o)| Arc::ptr_eq(m, &o.mesh))
                });
                reused = same;
                if !same {
                    self.rasterized = None;
                    let closed = self.closed.of(scene);
                    rasterize_objects(&mut self.rasterizer, &objects, &closed, &big)
                        .map_err(fog_err)?;
                    self.rasterized =
                        Some((big, scene.objects.iter().map(|o| o.mesh.clone()).collect()));
                }
                shade_fog_raster(
                    &self.rasterizer,
                    &objects,
                    &big,
                    &lighting.lights,
                    &settings,
                    &mut image,
                )
                .map_err(fog_err)?;
            }
        }
        progress.check()?;
        // What the view segments scatter into the eye, per unit of a
        // uniform sky's share (`ChordView::segment_to`): a L̄ G_c.
        let scatter = match &lighting.chords {
            Some((c, _)) if !self.opengl() => lighting.env_mean * (m.albedo * c.centre()),
            _ => Vec3::ZERO,
        };
        // Surfaces lit for their place in the ball (not in the OpenGL mode).
        let factors = match &lighting.chords {
            Some((_, f)) if !self.opengl() => Some(f),
            _ => None,
        };
        let r = &self.rasterizer;
        let g = r.gbuffer();
        let eye = big.eye;
        let w = big.width;
        // The view segment to the surface point `p` in the ball
        // (`ChordView::segment_to`): [e^{−βD}, its share of scattering].
        let chords = lighting.chords.as_ref().map(|(c, _)| c.view(eye));
        let segment_weights = |p: Vec3| chords.map_or([1.0, 0.0], |c| c.segment_to(p - eye));
        // The view segment: e^{−βD} L_s + s a L̄ G_c.
        // `corners`: the triangle's vertex positions.
        // The per-pixel path: `e` at barycentrics `b` of a triangle with
        // `corners` and vertex `normals` (where the mesh has them), lit for
        // its place in the ball, then across its view segment.
        let segment_at = |corners: &[Vec3; 3], normals: Option<[Vec3; 3]>, b: [f32; 2], e: Vec3| {
            let l = [1.0 - b[0] - b[1], b[0], b[1]];
            let p = corners[0] * l[0] + corners[1] * l[1] + corners[2] * l[2];
            let e = match factors {
                Some(f) => {
                    let n = normals
                        .map_or(Vec3::ZERO, |n| n[0] * l[0] + n[1] * l[1] + n[2] * l[2])
                        .try_normalize()
                        .unwrap_or_else(|| {
                            (corners[1] - corners[0])
                                .cross(corners[2] - corners[0])
                                .normalize_or_zero()
                        });
                    // The side the eye sees.
                    let n = if n.dot(eye - p) < 0.0 { -n } else { n };
                    e * f.factor(p, n)
                }
                None => e,
            };
            let [f, share] = segment_weights(p);
            e * f + scatter * share
        };
        // An empty sample's environment weights along its chord through
        // the ball (`None`: no medium, the lighting's own).
        let chord = |d: Vec3| chords.map(|c| c.weights(d));
        let segment = |d: usize, tri: usize, b: [f32; 2], e: Vec3| {
            let mesh = &scene.objects[d].mesh;
            let t = mesh.indices[tri];
            let normals = (mesh.normals.len() == mesh.positions.len())
                .then(|| t.map(|v| mesh.normals[v as usize]));
            segment_at(&t.map(|v| mesh.positions[v as usize]), normals, b, e)
        };
        // 2. The environment.
        let opengl = self.opengl();
        if let (Some((shader, vframe)), Some(light)) = (self.vertex.as_mut(), &self.env_lighting) {
            progress.check()?;
            if reused && vframe.is_shaded() {
                // A lighting change under a still camera: the same vertex
                // sides and transfers, only the dot products with the new
                // lighting (bit for bit what `shade` gives).
                vframe.relight(shader, light, factors);
            } else {
                vframe.shade(scene, r, eye, shader, light, factors);
            }
            let vframe = &*vframe;
            let rays = big.ray_frame();
            // `render_frame` paints every pixel no object touches: then only
            // the empty samples of partly covered pixels need the
            // environment here (none at one sample per pixel).
            let painted = frame_paints_background(scene);
            let h = big.height;
            let partly_covered = |x: usize, y: usize| {
                k > 1 && {
                    let (bx, by) = (x / k * k, y / k * k);
                    (by..(by + k).min(h)).any(|yy| {
                        g.triangle[yy * w + bx..yy * w + (bx + k).min(w)]
                            .iter()
                            .any(|&t| t != NO_TRIANGLE)
                    })
                }
            };
            // The view's weights: kept from the last frame when it had the
            // same visibility buffer and medium, else found and kept.
            let cached = chords.is_some();
            let kept = cached
                && reused
                && self.view_weights_for == Some(m)
                && self.view_weights.len() == g.triangle.len();
            self.view_weights_for = None;
            if cached && !kept {
                self.view_weights.clear();
                self.view_weights.resize(g.triangle.len(), [1.0, 0.0]);
            }
            let weights = &mut self.view_weights;
            let mut weight_rows: Vec<&mut [[f32; 2]]> = if cached {
                weights.chunks_mut(w).collect()
            } else {
                (0..image.height).map(|_| &mut [][..]).collect()
            };
            image
                .pixels
                .par_chunks_mut(w)
                .zip(weight_rows.par_iter_mut())
                .enumerate()
                .for_each_init(SegmentRow::default, |s, (y, (row, wrow))| {
                    s.clear();
                    // Neighbouring pixels of one triangle share its lookup,
                    // corners, side and vertex colours (the same values as
                    // fetched per pixel).
                    let mut last = NO_TRIANGLE;
                    let mut tri_of: Option<([Vec3; 3], [Vec3; 3])> = None;
                    for x in 0..row.len() {
                        let i = y * w + x;
                        let id = g.triangle[i];
                        if id != last {
                            last = id;
                            tri_of = (id != NO_TRIANGLE).then(|| r.locate(id)).flatten().map(
                                |(d, tri)| {
                                    let mesh = &scene.objects[d].mesh;
                                    let t = mesh.indices[tri];
                                    let front = faces_eye(&mesh.positions, t, eye);
                                    (
                                        t.map(|v| mesh.positions[v as usize]),
                                        vframe.corners(d, t, front),
                                    )
                                },
                            );
                        }
                        match &tri_of {
                            Some((p, c)) => {
                                let b = g.barycentrics[i];
                                let lam = Vec3::new(1.0 - b[0] - b[1], b[0], b[1]);
                                let e = c[0] * lam.x + c[1] * lam.y + c[2] * lam.z;
                                if kept {
                                    s.push(x, e, wrow[x]);
                                } else {
                                    // Weighed in a batch below.
                                    let q = p[0] * lam.x + p[1] * lam.y + p[2] * lam.z;
                                    s.push(x, e, [1.0, 0.0]);
                                    if chords.is_some() {
                                        s.push_to_eye(q - eye);
                                    }
                                }
                            }
                            None if !opengl && (!painted || partly_covered(x, y)) => {
                                let d = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
                                let weights = if kept {
                                    Some(wrow[x])
                                } else {
                                    let v = chord(d);
                                    if let Some(v) = v {
                                        wrow[x] = v;
                                    }
                                    v
                                };
                                s.push_empty(x, d, weights);
                            }
                            None => {}
                        }
                    }
                    if let (Some(c), false) = (&chords, kept) {
                        s.weigh_segments(c, wrow);
                    }
                    s.add_segments(scatter, row);
                    s.add_background(light, &scene.env, row);
                });
            if cached {
                self.view_weights_for = Some(m);
            }
        } else if self.environment_image(scene, &big, progress)? {
            let env = &self.env_image;
            let rays = big.ray_frame();
            let env_from_world = scene.world_from_env.transpose();
            let r = &self.rasterizer;
            let g = r.gbuffer();
            image
                .pixels
                .par_chunks_mut(w)
                .zip(env.pixels.par_chunks(w))
                .enumerate()
                .for_each(|(y, (row, env_row))| {
                    for (x, (px, e)) in row.iter_mut().zip(env_row).enumerate() {
                        let i = y * w + x;
                        let id = g.triangle[i];
                        *px += match (id != NO_TRIANGLE).then(|| r.locate(id)).flatten() {
                            Some((d, tri)) => segment(d, tri, g.barycentrics[i], *e),
                            None if opengl => *e,
                            None => {
                                let d = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
                                match chord(d) {
                                    // The renderer drew the centre's e^{−T} L(d) +
                                    // glow(d); the chord's weights rescale the two.
                                    Some([direct, glow]) => {
                                        let seen = scene.env.eval(env_from_world * d);
                                        let centre = lighting.filter.2.direct * seen;
                                        direct * seen + glow * (*e - centre)
                                    }
                                    _ => *e,
                                }
                            }
                        };
                    }
                });
        }
        Ok(image)
    }
}

/// One image row of the per-vertex environment pass, gathered before it
/// is shaded: the covered pixels' columns, surface radiance L_s and view
/// segment weights; the empty pixels' columns and view directions, so that
/// their background is shaded in batches ([`EnvLighting::add_background`]).
#[derive(Default)]
struct SegmentRow {
    x: Vec<u32>,
    radiance: Vec<Vec3>,
    /// [e^{−βD}, the segment's share of scattering] (`ChordView::segments`).
    segment: Vec<[f32; 2]>,
    /// The covered pixels' surface points from the eye, when their weights
    /// are found in this row (structure of arrays for the batch).
    to_eye: [Vec<f32>; 3],
    /// The empty pixels: columns, view directions, their chords' weights
    /// (`view_segment::ChordGlow`), and the background's
    /// filtered part and sums.
    empty_x: Vec<u32>,
    empty_dir: Vec<Vec3>,
    empty_weights: Vec<[f32; 2]>,
    empty_scratch: BackgroundScratch,
    empty_sum: Vec<Vec3>,
}

impl SegmentRow {
    fn clear(&mut self) {
        self.x.clear();
        self.radiance.clear();
        self.segment.clear();
        for v in &mut self.to_eye {
            v.clear();
        }
        self.empty_x.clear();
        self.empty_dir.clear();
        self.empty_weights.clear();
    }

    fn push(&mut self, x: usize, radiance: Vec3, segment: [f32; 2]) {
        self.x.push(x as u32);
        self.radiance.push(radiance);
        self.segment.push(segment);
    }

    /// The last pushed pixel's surface point, from the eye.
    fn push_to_eye(&mut self, v: Vec3) {
        for (c, x) in self.to_eye.iter_mut().zip(v.to_array()) {
            c.push(x);
        }
    }

    /// The view segment weights of every covered pixel of the row (each
    /// with its [`Self::push_to_eye`]), kept in `cache` too where it holds
    /// the row (a lighting change under a still camera reads them).
    fn weigh_segments(&mut self, chords: &view_segment::ChordView, cache: &mut [[f32; 2]]) {
        let [vx, vy, vz] = &self.to_eye;
        chords.segments(vx, vy, vz, &mut self.segment);
        if !cache.is_empty() {
            for (&x, &w) in self.x.iter().zip(&self.segment) {
                cache[x as usize] = w;
            }
        }
    }

    /// An empty pixel; `weights`: its chord's (`None`: no medium, the
    /// lighting's own).
    fn push_empty(&mut self, x: usize, dir: Vec3, weights: Option<[f32; 2]>) {
        self.empty_x.push(x as u32);
        self.empty_dir.push(dir);
        if let Some(w) = weights {
            self.empty_weights.push(w);
        }
    }

    /// Adds e^{−βD} L_s + s `scatter` (the view segment of §3.6.4 in the
    /// ball, `ChordView::segments`) to each gathered pixel of `row`.
    fn add_segments(&mut self, scatter: Vec3, row: &mut [Vec3]) {
        for ((&x, &e), &[f, share]) in self.x.iter().zip(&self.radiance).zip(&self.segment) {
            row[x as usize] += e * f + scatter * share;
        }
    }

    /// Adds the background ([`EnvLighting::add_background`]) to the
    /// gathered empty pixels of `row`.
    fn add_background(&mut self, light: &EnvLighting, env: &EnvMap, row: &mut [Vec3]) {
        self.empty_sum.clear();
        self.empty_sum.resize(self.empty_x.len(), Vec3::ZERO);
        let weights =
            (self.empty_weights.len() == self.empty_dir.len()).then_some(&self.empty_weights[..]);
        light.add_background(
            env,
            &self.empty_dir,
            weights,
            &mut self.empty_scratch,
            &mut self.empty_sum,
        );
        for (&x, &v) in self.empty_x.iter().zip(&self.empty_sum) {
            row[x as usize] += v;
        }
    }
}

impl Relighter for FogRelighter {
    fn name(&self) -> &'static str {
        NAME
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            // The environment is rendered by the thesis' own model (§3.6.4),
            // whose approximations (ENVIRONMENT_APPROXIMATION) are this
            // method's error, measured by `verify methods`, as band-limiting
            // is SH's.
            SceneFeature::PointLights | SceneFeature::Medium | SceneFeature::Environment => {
                Support::Full
            }
            SceneFeature::AreaLights
            | SceneFeature::LightFields
            | SceneFeature::Visibility
            | SceneFeature::NormalMaps
            | SceneFeature::SpatiallyVaryingBrdf
            | SceneFeature::Animation => Support::No,
        }
    }

    /// Under an environment, what the SH pipeline refuses
    /// ([`relight_shlight::check_objects`]: anisotropic BRDFs, meshes without
    /// normals); point lights fit any BRDF ([`FogMaterial::fit`]).
    fn check_objects(&self, scene: &Scene) -> Result<(), MethodError> {
        if scene.has_environment() {
            relight_shlight::check_objects(scene, &|_| false).map_err(failed)?;
        }
        Ok(())
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        progress.check()?;
        self.materials = scene
            .objects
            .iter()
            .map(|o| FogMaterial::fit(o.brdf.as_ref()))
            .collect();
        let have = |t: &FogTables| {
            t.size == self.options.table_size
                && self
                    .materials
                    .iter()
                    .all(|m| m.ks == Vec3::ZERO || t.g_table(m.n).is_some())
        };
        if !self.tables.as_ref().is_some_and(have) {
            self.tables = Some(
                FogTables::build_for(self.options.table_size, &self.materials).map_err(failed)?,
            );
        }
        progress.check()?;
        let previous = self.env.take();
        self.vertex = None;
        self.env_lighting = None;
        if scene.has_environment() {
            let env =
                LitScene::build(&self.sh, scene, &|_| false, previous, progress).map_err(failed)?;
            if self.options.env_shading == EnvShading::PerVertex {
                let shader = VertexShader::new(self.options.env_order, env.tables(), env.windows())
                    .map_err(failed)?;
                self.vertex = Some((shader, VertexFrame::new(scene)));
            }
            self.env = Some(env);
        }
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let start = Instant::now();
        progress.check()?;
        let medium = MediumParams::of(scene)?;
        let lights: Vec<PointLight> = scene
            .point_lights
            .iter()
            .map(|l| PointLight::new(l.position, l.intensity))
            .collect();
        {
            let objects = self.objects(scene);
            validate_lights(
                &objects,
                &lights,
                medium.beta,
                self.options.check_lights_inside,
            )
            .map_err(failed)?;
        }
        if let Some(r) = medium.radius {
            let outside = |p: Vec3| p.length() >= r;
            if let Some((i, l)) = lights.iter().enumerate().find(|(_, l)| outside(l.position)) {
                return Err(MethodError::InvalidOption {
                    method: NAME,
                    option: "point_lights",
                    message: format!(
                        "{} at {} lies outside the fog ball of radius {r}",
                        Numbered::point_light(i),
                        l.position
                    ),
                });
            }
        }
        let t = medium.env_thickness();
        let filter = match &self.lighting {
            Some(l) if l.filter.0 == t && l.filter.1 == medium.albedo => l.filter.clone(),
            _ => (t, medium.albedo, self.environment_filter(t, medium.albedo)),
        };
        let has_env = scene.has_environment();
        let env_mean = if has_env {
            match &self.env_mean {
                Some((env, mean)) if *env == scene.env => *mean,
                _ => {
                    let mean = scene.env.integral() / (4.0 * std::f32::consts::PI);
                    self.env_mean = Some((scene.env.clone(), mean));
                    mean
                }
            }
        } else {
            Vec3::ZERO
        };
        check_rotation(scene.world_from_env)?;
        let opengl = self.opengl();
        if let Some(env) = self.env.as_mut() {
            let filter = if opengl {
                LightingFilter {
                    direct: 1.0,
                    bands: Vec::new(),
                }
            } else {
                filter.2.clone()
            };
            if self.vertex.is_some() {
                // World-frame lighting only: no per-vertex rotation.
                let projection = env.projection(scene).map_err(failed)?;
                self.env_lighting = Some(
                    EnvLighting::new(projection, scene.world_from_env, Some(&filter))
                        .map_err(failed)?,
                );
            } else {
                self.sh.set_lighting_filter(Some(filter)).map_err(failed)?;
                self.sh
                    .set_lighting_rotation(scene.world_from_env)
                    .map_err(failed)?;
                env.light(&self.sh, scene, progress).map_err(failed)?;
            }
        }
        let chords = match &self.lighting {
            Some(l) if l.medium == medium => l.chords.clone(),
            _ => medium.ball().map(|b| {
                let chords = view_segment::ChordGlow::new(&b);
                let factors = BallIrradiance::new(&b, &chords);
                (chords, factors)
            }),
        };
        self.lighting = Some(Lighting {
            medium,
            lights,
            env_mean,
            filter,
            chords,
        });
        Ok(start.elapsed().as_secs_f64() * 1e3)
    }

    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError> {
        request.validate(NAME)?;
        let mut timings = FrameTimings::default();
        if !self.is_prepared_for(scene) {
            let t = Instant::now();
            self.prepare(scene, progress)?;
            timings.lighting_ms = t.elapsed().as_secs_f64() * 1e3;
        } else if self.lighting.is_none() {
            timings.lighting_ms = self.set_lighting(scene, progress)?;
        }
        let start = Instant::now();
        let lighting = self.lighting.take().expect("set by prepare");
        let frame = self.frame(scene, request, &lighting, progress);
        self.lighting = Some(lighting);
        let image = frame?;
        let k = request.aa;
        // Coverage from this frame's own visibility buffer.
        let coverage = coverage_of_raster(
            &self.rasterizer,
            request.camera.width,
            request.camera.height,
            k,
        );
        let image = if k == 1 {
            image
        } else {
            image.box_downsample(k)
        };
        timings.view_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(Rendered {
            image,
            coverage: Some(Arc::new(coverage)),
            timings,
            noise: None,
        })
    }

    fn data_bytes(&self) -> u64 {
        self.tables.as_ref().map_or(0, |t| {
            let tables = t
                .tail
                .iter()
                .chain(t.g.iter().map(|(_, g)| g))
                .chain([&t.f]);
            tables
                .map(|x| 4 * (x.values().len() + x.quads().len()) as u64)
                .sum()
        })
    }

    /// The last frame's lane operations ([`crate::work`]) from its
    /// visibility buffer: the point-light evaluations, the visible vertex
    /// sides, the environment pass. `None` in the per-pixel environment and
    /// OpenGL-fog modes (not counted) and before a frame. `set_lighting`
    /// only filters and turns the environment's SH vector (a few hundred
    /// operations: `lighting_fma` 0); the frame after it redoes this work
    /// less the raster and the vertex transfers' turn, so the view change's
    /// count bounds it.
    fn frame_work(&self, scene: &Scene, request: &FrameRequest) -> Option<FrameWork> {
        if self.opengl() || self.options.env_shading != EnvShading::PerVertex {
            return None;
        }
        let lighting = self.lighting.as_ref()?;
        let g = self.rasterizer.gbuffer();
        let samples = g.triangle.len();
        if samples == 0 {
            return None;
        }
        let covered = g.triangle.iter().filter(|&&t| t != NO_TRIANGLE).count();
        let empty = samples - covered;
        let fogged = !frame_paints_background(scene);
        let env = self.vertex.as_ref().zip(self.env_lighting.as_ref());
        let env_order = env.map_or(0, |((shader, _), _)| shader.order());
        // With the eye outside the ball every covered sample (surfaces lie
        // inside it) and every empty one whose ray enters it is shaded once
        // more from its entry.
        let camera = request.camera;
        let entries = match lighting.medium.ball() {
            Some(b) if !lighting.lights.is_empty() && camera.eye.length() >= b.radius => {
                let (w, k) = (g.width, request.aa);
                let mut big = camera;
                big.width *= k;
                big.height *= k;
                let rays = big.ray_frame();
                let entering = g
                    .triangle
                    .iter()
                    .enumerate()
                    .filter(|&(i, &t)| {
                        t == NO_TRIANGLE && {
                            let d = rays.dir((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                            b.ball_span(camera.eye, d)
                                .is_some_and(|(t_in, _)| t_in > 0.0)
                        }
                    })
                    .count();
                covered + entering
            }
            _ => 0,
        };
        let counts = crate::work::FrameCounts {
            covered,
            entries,
            edge: if lighting.medium.radius.is_some() && !lighting.lights.is_empty() {
                empty
            } else {
                0
            },
            background: if fogged { empty } else { 0 },
            lights: lighting.lights.len(),
            vertex_sides: env.map_or(0, |((_, frame), _)| frame.side_count()),
            env_order,
            x_nonzeros: relight_sh::rotation::ZyzRotation::<f32>::new(env_order.max(1))
                .map_or(0, |z| z.x_nonzeros()),
            filtered_background: env.is_some_and(|(_, light)| light.is_filtered()),
        };
        let ops = crate::work::frame_ops(&counts);
        Some(FrameWork {
            view_fma: ops,
            lighting_fma: 0.0,
        })
    }
}

/// Checks that `m` is a rotation (the SH renderer rotates the lighting by it).
fn check_rotation(m: Mat3) -> Result<(), MethodError> {
    relight_sh::rotation::Rot3::<f32>::try_from_mat3(m)
        .map(|_| ())
        .map_err(|e| MethodError::InvalidOption {
            method: NAME,
            option: "world_from_env",
            message: e.to_string(),
        })
}
