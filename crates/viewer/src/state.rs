//! What the viewer shows and how a frame is made: the scene, the orbit
//! camera, the lighting rotation and the method, with each method's
//! precomputation kept between frames so that only the per-frame step runs.
//!
//! | method | on a lighting change | on a view change |
//! |---|---|---|
//! | wavelet | step 1: project + rotate into every sampled normal's frame | step 2: per-vertex sparse dot products, Gouraud |
//! | sh | project, rotate the coefficients (exact) | per-pixel rotation of the transfer vectors |
//! | fog | the point lights turn about the orbit target (one carried into an object sits the frame out) | per-pixel analytic airlight + surface radiance |
//! | reference | resample the map rotated; start again | start again; each still frame adds a pass of samples (no visibility, like `verify`) |

use crate::orbit::Orbit;
use glam::Mat3;
use relight_fog::{FogSettings, FogTables, PointLight};
use relight_render::{Image, Progress, Scene};
use relight_shlight::ShRenderer;
use relight_wavelet::{BrdfBake, RotationParams, WaveletRenderer};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// What can go wrong in the viewer.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    #[error("wavelet method: {0}")]
    Wavelet(#[from] relight_wavelet::WaveletError),
    #[error("sh method: {0}")]
    Sh(#[from] relight_shlight::ShLightError),
    #[error("fog method: {0}")]
    Fog(#[from] relight_fog::FogError),
    #[error("reference: {0}")]
    Reference(#[from] relight_render::reference::ReferenceError),
    #[error(transparent)]
    Asset(#[from] relight_assets::AssetError),
    #[error("window: {0}")]
    Window(String),
    #[error("{what} = {value}: {why}")]
    Invalid {
        what: &'static str,
        value: String,
        why: &'static str,
    },
}

/// The methods the viewer switches between (keys 1–4): the three
/// real-time ones and the Monte Carlo reference, which refines while the
/// view is still.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewMethod {
    Wavelet,
    Sh,
    Fog,
    Reference,
}

impl ViewMethod {
    /// Lower-case name, as on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Wavelet => "wavelet",
            Self::Sh => "sh",
            Self::Fog => "fog",
            Self::Reference => "reference",
        }
    }
}

/// Parameters of the methods (the CLI's `render` flags).
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    /// Wavelet source side n, normal tessellation side and lighting terms.
    pub n: usize,
    pub ntess: usize,
    pub terms: usize,
    /// SH bands.
    pub sh_order: usize,
    /// Fog extinction coefficient β (1/world unit).
    pub beta: f32,
    /// Samples per pixel side when the view is still (1…8).
    pub aa: usize,
    /// Bake cache of the wavelet method.
    pub cache: PathBuf,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            n: 64,
            ntess: 32,
            terms: 256,
            sh_order: 6,
            beta: 0.04,
            aa: 2,
            cache: relight_wavelet::default_cache_dir(),
        }
    }
}

/// One drawn frame.
#[derive(Clone, Debug)]
pub struct Frame {
    pub image: Image,
    /// Time of the per-frame work (ms), lighting update included.
    pub ms: f64,
    /// Samples per pixel side it was drawn with (raster methods).
    pub aa: usize,
    /// Monte Carlo samples per pixel accumulated so far (reference; 0 for
    /// the raster methods).
    pub spp: u32,
}

/// Samples per pixel the reference accumulates before it stops refining.
pub const REFERENCE_MAX_SPP: u32 = 1024;

/// The reference's running sum, valid for one camera, lighting and size.
struct Accumulation {
    key: (Orbit, Mat3, usize, usize),
    sum: Vec<glam::Vec3>,
    spp: u32,
    passes: u64,
}

struct WaveletState {
    renderer: WaveletRenderer,
    bakes: Vec<Arc<BrdfBake>>,
    /// The lighting rotation step 1 last ran with.
    lit: Option<Mat3>,
}

/// The viewer's state: everything a frame needs, input applied by the
/// window layer ([`crate::window`]) or by tests.
pub struct Viewer {
    scene: Scene,
    /// The camera.
    pub orbit: Orbit,
    home: Orbit,
    /// Lighting rotation: yaw about +Y and pitch about +X, degrees.
    pub light_yaw_deg: f32,
    pub light_pitch_deg: f32,
    pub method: ViewMethod,
    /// Antialias still frames (`opts.aa` samples per side) or not.
    pub antialias: bool,
    opts: ViewerOptions,
    wavelet: Option<WaveletState>,
    /// Taken out while it renders (its builder methods take it by value).
    sh: Option<ShRenderer>,
    fog_tables: Option<FogTables>,
    fog_lights: Vec<PointLight>,
    /// The environment rotated for the reference, with its rotation.
    rotated_env: Option<(Mat3, relight_sphere::EnvMap)>,
    accumulation: Option<Accumulation>,
}

impl Viewer {
    /// A viewer of `scene` from its own camera, starting with `method`.
    ///
    /// # Errors
    /// Out-of-range options.
    pub fn new(scene: Scene, method: ViewMethod, opts: ViewerOptions) -> Result<Self, ViewerError> {
        if !(1..=8).contains(&opts.aa) {
            return Err(ViewerError::Invalid {
                what: "aa",
                value: opts.aa.to_string(),
                why: "must be 1…8 samples per pixel side",
            });
        }
        if !(opts.beta.is_finite() && opts.beta >= 0.0) {
            return Err(ViewerError::Invalid {
                what: "beta",
                value: opts.beta.to_string(),
                why: "must be a finite number ≥ 0",
            });
        }
        RotationParams::new(opts.n, opts.ntess, 1).validate()?;
        let sh = ShRenderer::new(opts.sh_order, relight_shlight::ShRotationMethod::Exact)?;
        let orbit = Orbit::from_camera(&scene.camera);
        Ok(Self {
            scene,
            orbit,
            home: orbit,
            light_yaw_deg: 0.0,
            light_pitch_deg: 0.0,
            method,
            antialias: true,
            opts,
            wavelet: None,
            sh: Some(sh),
            fog_tables: None,
            fog_lights: relight_fog::default_scene_lights(4),
            rotated_env: None,
            accumulation: None,
        })
    }

    /// Back to the starting camera and lighting.
    pub fn reset(&mut self) {
        self.orbit = self.home;
        self.light_yaw_deg = 0.0;
        self.light_pitch_deg = 0.0;
    }

    /// The starting camera's distance to its target.
    #[must_use]
    pub fn home_distance(&self) -> f32 {
        self.home.distance
    }

    /// `world_from_env` of the current lighting rotation.
    #[must_use]
    pub fn light_rotation(&self) -> Mat3 {
        relight_sphere::rotation_from_yaw_pitch_roll([
            self.light_yaw_deg,
            self.light_pitch_deg,
            0.0,
        ])
    }

    /// Runs the current method's precomputation now (bakes or loads the
    /// wavelet data, builds the fog tables), so the first frame is fast.
    ///
    /// # Errors
    /// As the method's bake.
    pub fn prepare(&mut self, progress: &dyn Progress) -> Result<(), ViewerError> {
        match self.method {
            ViewMethod::Wavelet => self.wavelet_state(progress).map(|_| ()),
            ViewMethod::Fog => self.fog_tables().map(|_| ()),
            ViewMethod::Sh | ViewMethod::Reference => Ok(()),
        }
    }

    /// The wavelet method's matrices, BRDF slices and renderer, baked or
    /// loaded on first use.
    fn wavelet_state(&mut self, progress: &dyn Progress) -> Result<&mut WaveletState, ViewerError> {
        if let Some(w) = self.wavelet.take() {
            return Ok(self.wavelet.insert(w));
        }
        let p = RotationParams::new(self.opts.n, self.opts.ntess, 1);
        let rot = relight_wavelet::bake_or_load_rotation(&p, &self.opts.cache, progress)?;
        let bakes = relight_wavelet::bake_or_load_scene_brdfs(
            &self.scene,
            p.m,
            64,
            128,
            &self.opts.cache,
            progress,
        )?;
        let terms = self.opts.terms.min(p.source_len());
        Ok(self.wavelet.insert(WaveletState {
            renderer: WaveletRenderer::new(rot, terms)?,
            bakes,
            lit: None,
        }))
    }

    /// The fog tables for the scene's fitted materials, built on first use.
    fn fog_tables(&mut self) -> Result<&FogTables, ViewerError> {
        if let Some(t) = self.fog_tables.take() {
            return Ok(self.fog_tables.insert(t));
        }
        let objects = relight_fog::scene_objects(&self.scene);
        let tables = FogTables::build_for(64, objects.iter().map(|o| &o.material))?;
        Ok(self.fog_tables.insert(tables))
    }

    /// Draws a `width × height` frame; `preview` (while the user drags)
    /// skips antialiasing.
    ///
    /// # Errors
    /// The method's errors (bad sizes, cancellation of a first bake).
    pub fn frame(
        &mut self,
        width: usize,
        height: usize,
        preview: bool,
        progress: &dyn Progress,
    ) -> Result<Frame, ViewerError> {
        // The reference integrates each pixel itself: no supersampling.
        let aa = if preview || !self.antialias || self.method == ViewMethod::Reference {
            1
        } else {
            self.opts.aa
        };
        let t = Instant::now();
        let rotation = self.light_rotation();
        let mut scene = self.scene.clone();
        scene.camera = self.orbit.camera(width * aa, height * aa);
        let image = match self.method {
            ViewMethod::Reference => {
                return self.reference_pass(scene, preview, rotation, progress, t);
            }
            ViewMethod::Wavelet => {
                let w = self.wavelet_state(progress)?;
                if w.lit != Some(rotation) {
                    w.renderer.set_lighting(&scene.env, rotation)?;
                    w.lit = Some(rotation);
                }
                let refs: Vec<&BrdfBake> = w.bakes.iter().map(AsRef::as_ref).collect();
                w.renderer.render(&scene, &refs, &scene.camera, None)?
            }
            ViewMethod::Sh => {
                // The renderer supersamples itself.
                scene.camera = self.orbit.camera(width, height);
                let sh = match self.sh.take() {
                    Some(sh) => sh,
                    None => ShRenderer::new(
                        self.opts.sh_order,
                        relight_shlight::ShRotationMethod::Exact,
                    )?,
                }
                .with_supersampling(aa)
                .with_lighting_rotation(rotation)?;
                let out = sh.render(&scene, None, progress);
                self.sh = Some(sh);
                return Ok(Frame {
                    image: out?.image,
                    ms: t.elapsed().as_secs_f64() * 1e3,
                    aa,
                    spp: 0,
                });
            }
            ViewMethod::Fog => {
                let target = self.orbit.target;
                let mut lights: Vec<PointLight> = self
                    .fog_lights
                    .iter()
                    .map(|l| {
                        PointLight::new(target + rotation * (l.position - target), l.intensity)
                    })
                    .collect();
                let beta = self.opts.beta;
                let objects = relight_fog::scene_objects(&scene);
                let settings = FogSettings::new(self.fog_tables()?, beta);
                // A light the rotation carries into an object sits this
                // frame out (the model needs lights in the medium).
                loop {
                    match relight_fog::render_fog(&objects, &scene.camera, &lights, &settings) {
                        Err(relight_fog::FogError::LightInsideGeometry { index, .. })
                            if index < lights.len() =>
                        {
                            lights.remove(index);
                        }
                        other => break other?,
                    }
                }
            }
        };
        Ok(Frame {
            image: image.box_downsample(aa),
            ms: t.elapsed().as_secs_f64() * 1e3,
            aa,
            spp: 0,
        })
    }

    /// Whether the reference would still refine the current view.
    #[must_use]
    pub fn refining(&self) -> bool {
        self.method == ViewMethod::Reference
            && self
                .accumulation
                .as_ref()
                .is_none_or(|a| a.spp < REFERENCE_MAX_SPP)
    }

    /// One progressive pass of the reference renderer over `scene` (the
    /// viewer's scene at the frame's camera; 1 sample per pixel while
    /// dragging, 4 when still), added to the running mean of this view; a
    /// new camera, lighting or size starts the mean again.
    fn reference_pass(
        &mut self,
        mut scene: Scene,
        preview: bool,
        rotation: Mat3,
        progress: &dyn Progress,
        t: Instant,
    ) -> Result<Frame, ViewerError> {
        let (width, height) = (scene.camera.width, scene.camera.height);
        let key = (self.orbit, rotation, width, height);
        let mut acc = match self.accumulation.take() {
            Some(a) if a.key == key && !preview => a,
            _ => Accumulation {
                key,
                sum: vec![glam::Vec3::ZERO; width * height],
                spp: 0,
                passes: 0,
            },
        };
        if rotation != Mat3::IDENTITY {
            if self
                .rotated_env
                .as_ref()
                .is_none_or(|(r, _)| *r != rotation)
            {
                self.rotated_env = Some((rotation, self.scene.env.rotated(rotation, 2)));
            }
            if let Some((_, env)) = &self.rotated_env {
                scene.env = env.clone();
            }
        }
        let pass = if preview { 1 } else { 4 };
        if acc.spp < REFERENCE_MAX_SPP {
            let opts = relight_render::reference::ReferenceOptions {
                spp: pass,
                pass_spp: pass,
                seed: acc.passes,
                ..Default::default()
            };
            scene.visibility = false;
            let img = relight_render::reference::render_reference(&scene, &opts, progress)?.image;
            for (s, p) in acc.sum.iter_mut().zip(&img.pixels) {
                *s += *p * pass as f32;
            }
            acc.spp += pass;
            acc.passes += 1;
        }
        let mut image = Image::new(width, height);
        let inv = 1.0 / acc.spp.max(1) as f32;
        for (o, s) in image.pixels.iter_mut().zip(&acc.sum) {
            *o = *s * inv;
        }
        let spp = acc.spp;
        self.accumulation = Some(acc);
        Ok(Frame {
            image,
            ms: t.elapsed().as_secs_f64() * 1e3,
            aa: 1,
            spp,
        })
    }

    /// Writes `frame` as `stem.png` (tone-mapped) and `stem.exr` (linear).
    ///
    /// # Errors
    /// Unwritable files.
    pub fn save(frame: &Frame, stem: &std::path::Path) -> Result<(), ViewerError> {
        let img = &frame.image;
        relight_assets::write_png(
            &stem.with_extension("png"),
            img.width,
            img.height,
            &img.pixels,
            relight_assets::ToneMap::default(),
        )?;
        relight_assets::write_exr(
            &stem.with_extension("exr"),
            img.width,
            img.height,
            &img.pixels,
        )?;
        Ok(())
    }
}

/// Tone-maps `image` (ACES, sRGB) into 0x00RRGGBB words for a window.
pub fn to_display(image: &Image, out: &mut [u32]) {
    use rayon::prelude::*;
    let tone = relight_assets::ToneMap::default();
    // sRGB of display-referred [0, 1] in 4096 steps.
    let lut: Vec<u32> = (0..4096)
        .map(|i| {
            let v = relight_assets::linear_to_srgb(i as f32 / 4095.0);
            (v * 255.0 + 0.5).clamp(0.0, 255.0) as u32
        })
        .collect();
    let w = image.width.max(1);
    out.par_chunks_mut(w)
        .zip(image.pixels.par_chunks(w))
        .for_each(|(dst, src)| {
            for (d, p) in dst.iter_mut().zip(src) {
                let c = |x: f32| lut[(tone.apply(x) * 4095.0 + 0.5) as usize];
                *d = (c(p.x) << 16) | (c(p.y) << 8) | c(p.z);
            }
        });
}
