//! What the viewer shows and how a frame is made: the scene, the orbit
//! camera, the lighting rotation and the method — every method reached
//! through the method interface ([`Relighter`]), exactly as the CLI reaches it,
//! so the same scene, method and settings give the same image in both.
//!
//! Each method is created, checked against the scene ([`check_scene`]) and
//! prepared (bake or cache load) on first use, and kept between frames:
//!
//! | input | call |
//! |---|---|
//! | right-drag (lighting rotation) | [`Relighter::set_lighting`] with the environment's `world_from_env` turned and the point lights moved about the orbit target; a change the method would bake again for ([`Relighter::lighting_rebakes`]: nearfield's tilted area light) waits for the release, the drag's frames keeping the last lighting with a note; at the release the window bakes it on its worker thread ([`Viewer::lighting_bake_due`], [`Viewer::apply_lighting`]); a lighting the method refuses (fog: a point light turned into an object) draws an empty frame that says why, and is not tried again until the lighting changes |
//! | area-light edit (move in its plane, scale, texture; [`crate::light`]) | [`Relighter::set_lighting`] with the scene's area lights edited (`Tab` picks which one the edits go to), then turned by the lighting rotation — never a new `prepare` |
//! | drag, zoom, resize (view change) | [`render_frame`] for the orbit camera; a view the method refuses (fog: the eye zoomed out to more than 40 mean free paths from the fog ball) draws an empty frame that says why (`Frame::refused`) |
//! | still view | progressive antialiasing: each [`Viewer::frame`] adds one pass of one sample per pixel at the next sub-pixel offset of an `aa × aa` grid ([`Camera::with_pixel_offset`]) to a running mean, until `aa²` passes ([`Viewer::refining`]); Monte Carlo methods (the reference) instead add a pass of their own samples per frame |
//!
//! The mean of the `aa²` offset passes is the `aa × aa` box-filtered frame
//! (`FrameRequest::aa`): sample `(i, j)` of pixel `(x, y)` sees the same
//! point, `(x + (i + ½)/aa, y + (j + ½)/aa)`, either way. Only the shared
//! background differs, by quadrature (four corners per pass instead of four
//! per pixel). A pass costs one preview frame, so input is never blocked
//! for longer than that.
//!
//! # Animation
//! A scene whose objects move plays with [`Viewer::toggle_play`]: each
//! [`Viewer::advance`] moves the clock, looping over the keys
//! ([`Scene::animation_end`]), and frames show the posed scene
//! [`Scene::at_time`]. A method that supports [`SceneFeature::Animation`]
//! (shexp) is prepared once and follows the motion every frame; any other is
//! prepared on the pose of the moment ([`posed_for`](relight_render::method::posed_for)), so the clock does not
//! move while it is shown, and the frame says why; choosing it after the clock
//! moved prepares it again at the new pose.

use crate::light::{LightEdit, LightTextures};
use crate::orbit::Orbit;
use glam::{Mat3, Vec2, Vec3};
use relight_assets::ToneMap;
use relight_methods::{MethodKind, MethodOptions};
use relight_render::method::{
    FrameRequest, FrameWork, MAX_AA, MethodError, SceneFeature, check_scene, follows_animation,
    render_frame,
};
use relight_render::{Camera, Image, Progress, Relighter, Scene};
use std::time::Instant;

/// What can go wrong in the viewer.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    #[error(transparent)]
    Method(#[from] MethodError),
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
    #[error(
        "method {method} is not among the viewer's methods ({available}); `relight render --method {method}` renders it"
    )]
    NotInViewer { method: String, available: String },
}

/// Settings of the viewer.
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    /// The methods keys 1, 2, … switch between, each with its options.
    pub methods: Vec<MethodOptions>,
    /// Samples per pixel side when the view is still (1…8).
    pub aa: usize,
    /// Accept what a method renders approximately (with a warning on screen).
    pub approximate: bool,
}

/// Samples per pixel side of a still frame unless `--aa` says otherwise.
pub const DEFAULT_STILL_AA: usize = 2;

/// Every real-time method, the Monte Carlo reference and LTC, on keys 1–9.
/// Not the radiance cache: its frames are Monte Carlo direct light plus
/// cache lookups without progressive passes (0.64 s for a 320 × 180 frame
/// of `examples/glossy-cache.toml`), so each would block input for
/// seconds; `relight render --method radiance-cache` renders it.
impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            methods: [
                MethodKind::Wavelet,
                MethodKind::Sh,
                MethodKind::Fog,
                MethodKind::ShExp,
                MethodKind::Reference,
                MethodKind::Ndf,
                MethodKind::Nearfield,
                MethodKind::Triple,
                MethodKind::Ltc,
            ]
            .into_iter()
            .map(MethodOptions::default_for)
            .collect(),
            aa: DEFAULT_STILL_AA,
            approximate: false,
        }
    }
}

/// One drawn frame.
#[derive(Clone, Debug)]
pub struct Frame {
    pub image: Image,
    /// Time of the per-frame work (ms), lighting update included.
    pub ms: f64,
    /// Samples per pixel side it is refining to (raster methods; 1 while
    /// dragging).
    pub aa: usize,
    /// Antialiasing passes accumulated so far (of `aa²`).
    pub passes: usize,
    /// Monte Carlo samples per pixel accumulated so far (0 for deterministic
    /// methods).
    pub spp: u32,
    /// Why the method drew nothing (it cannot render the scene, this
    /// lighting or this view), or what it approximates; shown on screen.
    pub message: Option<String>,
    /// The frame is empty and `message` says why.
    pub refused: bool,
}

impl Frame {
    /// An empty `width × height` frame that says `why`.
    fn refused(width: usize, height: usize, since: Instant, aa: usize, why: String) -> Self {
        Self {
            image: Image::new(width, height),
            ms: since.elapsed().as_secs_f64() * 1e3,
            aa,
            passes: 0,
            spp: 0,
            message: Some(why),
            refused: true,
        }
    }
}

/// One method's state: created, checked and prepared on first use.
struct Slot {
    options: MethodOptions,
    method: Option<Box<dyn Relighter>>,
    /// Why it cannot render the scene (checked once).
    refused: Option<String>,
    /// What the method approximates in the scene (checked once).
    warnings: Vec<String>,
    /// The method's own warnings, which a lighting change may change, as
    /// read at the last frame that was not a preview: a drag's frames keep
    /// them (reading them may cost a pass over the vertices).
    method_warnings: Vec<String>,
    /// The lighting `set_lighting` last ran with.
    lit: Option<Lighting>,
    /// A lighting the method refused (fog: a point light dragged into an
    /// object) and why: shown instead of a frame, and not tried again
    /// until the lighting changes.
    unlit: Option<(Lighting, String)>,
    /// Samples accumulated in the last frame (progressive methods).
    spp: u32,
    /// Whether the method integrates pixels itself (Monte Carlo), learned
    /// from its first frame.
    monte_carlo: Option<bool>,
    /// `Some(t)` when prepared on the scene posed at `t` (a method that does
    /// not animate, on a moving scene).
    posed_at: Option<f32>,
}

impl Slot {
    /// Gives the method `lighting` (`scene` carries it) unless it has it
    /// already or refused it; nothing for a method not created. A refusal
    /// is kept in `unlit`, not returned: only cancellation is an error.
    fn light(
        &mut self,
        scene: &Scene,
        lighting: Lighting,
        progress: &dyn Progress,
    ) -> Result<(), ViewerError> {
        if self.lit != Some(lighting)
            && self.unlit_at(lighting).is_none()
            && let Some(m) = self.method.as_mut()
        {
            match m.set_lighting(scene, progress) {
                Ok(_) => {
                    self.lit = Some(lighting);
                    self.unlit = None;
                }
                Err(MethodError::Cancelled) => return Err(MethodError::Cancelled.into()),
                Err(e) => {
                    self.unlit = Some((
                        lighting,
                        format!(
                            "{e}; nothing is drawn at this lighting: turn the lighting further (right drag) or reset it (r)"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Why the method refused `lighting`, if it did.
    fn unlit_at(&self, lighting: Lighting) -> Option<String> {
        let (at, why) = self.unlit.as_ref()?;
        (*at == lighting).then(|| why.clone())
    }
}

/// The scene the frames draw: the pose at the clock's time when the scene
/// is animated, else the lit scene.
fn shown_scene<'a>(posed: &'a Option<(f32, Scene)>, lit_scene: &'a Scene) -> &'a Scene {
    match posed {
        Some((_, s)) if lit_scene.is_animated() => s,
        _ => lit_scene,
    }
}

/// The lighting of a frame: the rotation (right drag) and the area-light
/// edit.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Lighting {
    rotation: Mat3,
    /// The edited light and its edit (the others' edits change only
    /// while they are the edited one).
    light: usize,
    edit: LightEdit,
    /// Bumped by a reset, which may change lights other than the edited one.
    resets: u32,
}

/// What a run of antialiasing passes accumulates for.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AccumKey {
    method: usize,
    camera: Camera,
    lighting: Lighting,
    time: f32,
}

/// The running sum of the antialiasing passes of one still view.
#[derive(Debug, Default)]
struct Accumulation {
    key: Option<AccumKey>,
    sum: Vec<Vec3>,
    passes: usize,
}

/// The viewer's state: everything a frame needs, input applied by the
/// window layer ([`crate::window`]) or by tests.
pub struct Viewer {
    /// The scene as loaded.
    scene: Scene,
    /// The scene with the current lighting rotation and light edit applied.
    lit_scene: Scene,
    lit: Lighting,
    /// The edit of each area light ([`crate::light`]).
    light_edits: Vec<LightEdit>,
    /// Each area light's built-in textures.
    light_textures: Vec<LightTextures>,
    /// The area light the edits go to (the `Tab` key).
    edited_light: usize,
    /// Resets so far ([`Lighting::resets`]).
    resets: u32,
    /// Light-editing mode (the `l` key): a left drag moves the area light
    /// and the wheel scales it, instead of orbiting and zooming.
    pub light_mode: bool,
    /// Methods prepared (created and baked or loaded) so far.
    prepares: usize,
    /// The camera.
    pub orbit: Orbit,
    home: Orbit,
    /// Lighting rotation: yaw about +Y and pitch about +X, degrees.
    pub light_yaw_deg: f32,
    pub light_pitch_deg: f32,
    /// Index into the methods of [`ViewerOptions::methods`].
    current: usize,
    /// Antialias still frames (`aa` samples per side) or not.
    pub antialias: bool,
    aa: usize,
    approximate: bool,
    slots: Vec<Slot>,
    accum: Accumulation,
    /// The frame last shown empty with the method's refusal of its
    /// lighting or view: nothing to refine until something changes.
    refused_at: Option<AccumKey>,
    /// Size of the last frame drawn.
    last_size: Option<(usize, usize)>,
    /// The animation clock (seconds) and whether it runs.
    time: f32,
    playing: bool,
    /// `lit_scene` posed at a time, for a moving scene (its meshes are
    /// made once per time, so a method prepared on them keeps seeing them).
    posed: Option<(f32, Scene)>,
}

impl Viewer {
    /// A viewer of `scene` from its own camera, starting with `first`
    /// (which must be among `opts.methods`).
    ///
    /// # Errors
    /// Out-of-range options.
    pub fn new(scene: Scene, first: MethodKind, opts: ViewerOptions) -> Result<Self, ViewerError> {
        if !(1..=MAX_AA).contains(&opts.aa) {
            return Err(ViewerError::Invalid {
                what: "aa",
                value: opts.aa.to_string(),
                why: "must be 1…8 samples per pixel side",
            });
        }
        let current = opts
            .methods
            .iter()
            .position(|m| m.kind() == first)
            .ok_or_else(|| ViewerError::NotInViewer {
                method: first.name().to_string(),
                available: opts
                    .methods
                    .iter()
                    .map(|m| m.kind().name())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        let orbit = Orbit::from_camera(&scene.camera);
        let light_textures: Vec<LightTextures> = scene
            .area_lights
            .iter()
            .map(LightTextures::for_light)
            .collect();
        Ok(Self {
            lit_scene: scene.clone(),
            lit: Lighting {
                rotation: Mat3::IDENTITY,
                light: 0,
                edit: LightEdit::default(),
                resets: 0,
            },
            light_edits: vec![LightEdit::default(); light_textures.len()],
            light_textures,
            edited_light: 0,
            resets: 0,
            light_mode: false,
            prepares: 0,
            scene,
            orbit,
            home: orbit,
            light_yaw_deg: 0.0,
            light_pitch_deg: 0.0,
            current,
            antialias: true,
            aa: opts.aa,
            approximate: opts.approximate,
            slots: opts
                .methods
                .into_iter()
                .map(|options| Slot {
                    options,
                    method: None,
                    refused: None,
                    warnings: Vec::new(),
                    method_warnings: Vec::new(),
                    lit: None,
                    unlit: None,
                    spp: 0,
                    monte_carlo: None,
                    posed_at: None,
                })
                .collect(),
            accum: Accumulation::default(),
            refused_at: None,
            last_size: None,
            time: 0.0,
            playing: false,
            posed: None,
        })
    }

    /// The method shown.
    #[must_use]
    pub fn method(&self) -> MethodKind {
        self.slots[self.current].options.kind()
    }

    /// The methods keys 1, 2, … select, in order.
    #[must_use]
    pub fn methods(&self) -> Vec<MethodKind> {
        self.slots.iter().map(|s| s.options.kind()).collect()
    }

    /// Shows the `index`-th method (0-based); out of range is ignored.
    pub fn select(&mut self, index: usize) {
        if index < self.slots.len() {
            self.current = index;
        }
    }

    /// Shows the next normal filter (representation or baseline,
    /// `NdfFilter::next_for`; the `n` key) of the ndf method, or of the sh
    /// method's filtering mode (its normal-mapped Lambertian objects): the
    /// method is made and prepared again with it. The ndf method's sh filter
    /// comes twice, with the footprint's view mask and then with a mask per
    /// probe (`NdfOptions::probe_masks`). False, and nothing changes, for
    /// another method.
    pub fn cycle_normal_filter(&mut self) -> bool {
        let slot = &mut self.slots[self.current];
        match &mut slot.options {
            MethodOptions::Ndf(o) if o.filter == relight_ndf::NdfFilter::Sh && !o.probe_masks => {
                o.probe_masks = true;
            }
            MethodOptions::Ndf(o) => {
                o.probe_masks = false;
                o.filter = o.filter.next_for(o.brdf);
            }
            MethodOptions::Sh(o) => {
                o.normal_filter = o.normal_filter.next_for(relight_ndf::NdfBrdf::Lambert);
            }
            _ => return false,
        }
        slot.method = None;
        slot.refused = None;
        slot.warnings.clear();
        slot.method_warnings.clear();
        slot.lit = None;
        slot.unlit = None;
        slot.posed_at = None;
        slot.monte_carlo = None;
        self.accum = Accumulation::default();
        true
    }

    /// Back to the starting camera and lighting (every area light as
    /// loaded; the edited one stays selected).
    pub fn reset(&mut self) {
        self.orbit = self.home;
        self.light_yaw_deg = 0.0;
        self.light_pitch_deg = 0.0;
        self.light_edits.fill(LightEdit::default());
        self.resets = self.resets.wrapping_add(1);
    }

    /// True when the scene has an area light to edit ([`crate::light`]).
    #[must_use]
    pub fn has_area_light(&self) -> bool {
        !self.scene.area_lights.is_empty()
    }

    /// The current edit of the edited area light ([`Self::edited_light`]).
    #[must_use]
    pub fn light_edit(&self) -> LightEdit {
        self.light_edits
            .get(self.edited_light)
            .copied()
            .unwrap_or_default()
    }

    /// How many times [`Self::reset`] ran (a reset may change lights other
    /// than the edited one).
    #[must_use]
    pub fn light_resets(&self) -> u32 {
        self.resets
    }

    /// The index of the area light that moves, scales and textures go to.
    #[must_use]
    pub fn edited_light(&self) -> usize {
        self.edited_light
    }

    /// Edits go to the next area light (the `Tab` key; after the last, the
    /// first). False without an area light.
    pub fn edit_next_light(&mut self) -> bool {
        if !self.has_area_light() {
            return false;
        }
        self.edited_light = (self.edited_light + 1) % self.light_edits.len();
        true
    }

    /// The edited light's edit, for changing.
    fn edit_mut(&mut self) -> &mut LightEdit {
        &mut self.light_edits[self.edited_light]
    }

    /// Moves the edited area light by `delta` along its own `x̂` and `ŷ` (world
    /// units, in its plane). False, and nothing changes, without an area
    /// light or for a non-finite `delta`.
    pub fn move_light(&mut self, delta: Vec2) -> bool {
        if !self.has_area_light() || !delta.is_finite() {
            return false;
        }
        self.edit_mut().offset += delta;
        true
    }

    /// Moves the edited area light in its plane so that the point of the plane
    /// under pixel `from` of a `width × height` frame goes under pixel `to`
    /// (the light follows the cursor). A step is at most the orbit's
    /// distance to its target. False, and nothing changes, without an area
    /// light or when either pixel's ray misses the plane (parallel to it, or
    /// the plane behind the eye).
    pub fn drag_light(
        &mut self,
        from: (f32, f32),
        to: (f32, f32),
        width: usize,
        height: usize,
    ) -> bool {
        if !self.has_area_light() || width == 0 || height == 0 {
            return false;
        }
        self.update_lighting();
        let l = &self.lit_scene.area_lights[self.edited_light];
        let (c, n) = (l.center, l.normal());
        let (x, y) = (l.world_from_light.x_axis, l.world_from_light.y_axis);
        let rays = self.camera(width, height).ray_frame();
        let eye = rays.origin();
        let hit = |(px, py): (f32, f32)| {
            let d = rays.dir(px, py);
            let den = d.dot(n);
            let t = (c - eye).dot(n) / den;
            (den.abs() > 1e-4 && t.is_finite() && t > 0.0).then(|| eye + d * t)
        };
        let (Some(a), Some(b)) = (hit(from), hit(to)) else {
            return false;
        };
        let step = (b - a).clamp_length_max(self.orbit.distance);
        self.move_light(Vec2::new(step.dot(x), step.dot(y)))
    }

    /// Scales the edited area light by [`crate::light::SCALE_PER_STEP`] per
    /// `steps` (wheel steps; negative: smaller). False without an area light.
    pub fn scale_light(&mut self, steps: f32) -> bool {
        if !self.has_area_light() {
            return false;
        }
        self.edit_mut().scale_by_steps(steps);
        true
    }

    /// Gives the edited area light the next texture ([`crate::light::LightTexture`]:
    /// the scene's own, checker, stripes, gradient; the `t` key). False
    /// without an area light.
    pub fn cycle_light_texture(&mut self) -> bool {
        if !self.has_area_light() {
            return false;
        }
        let e = self.edit_mut();
        e.texture = e.texture.next();
        true
    }

    /// The scene as the last frame drew it: the lighting rotation and the
    /// area-light edit applied.
    #[must_use]
    pub fn lit_scene(&self) -> &Scene {
        &self.lit_scene
    }

    /// How many times a method was prepared (created, then baked or loaded)
    /// since the viewer started. A lighting change or light edit prepares
    /// nothing.
    #[must_use]
    pub fn prepares(&self) -> usize {
        self.prepares
    }

    /// The lighting asked for (it reaches `lit_scene` at the next frame).
    fn lighting(&self) -> Lighting {
        Lighting {
            rotation: self.light_rotation(),
            light: self.edited_light,
            edit: self.light_edit(),
            resets: self.resets,
        }
    }

    /// The starting camera's distance to its target.
    #[must_use]
    pub fn home_distance(&self) -> f32 {
        self.home.distance
    }

    /// The current lighting rotation (yaw about +Y, then pitch), applied on
    /// top of the scene's own `world_from_env`.
    #[must_use]
    pub fn light_rotation(&self) -> Mat3 {
        relight_sphere::rotation_from_yaw_pitch_roll([
            self.light_yaw_deg,
            self.light_pitch_deg,
            0.0,
        ])
    }

    /// The camera of a `width × height` frame: the scene's own while the
    /// orbit is at home (so the viewer and `relight render` see the same
    /// rays), else the orbit's.
    #[must_use]
    pub fn camera(&self, width: usize, height: usize) -> Camera {
        if self.orbit == self.home {
            let mut c = self.scene.camera;
            c.width = width;
            c.height = height;
            c
        } else {
            self.orbit.camera(width, height)
        }
    }

    /// Brings `lit_scene` to the current lighting: the area lights
    /// edited ([`crate::light`]), then the environment turned and the point
    /// and area lights carried about the home orbit target.
    fn update_lighting(&mut self) {
        let lighting = self.lighting();
        if lighting == self.lit {
            return;
        }
        let r = lighting.rotation;
        // Only the lighting changes: no copy of meshes or environment.
        let target = self.home.target;
        let (src, s) = (&self.scene, &mut self.lit_scene);
        s.world_from_env = r * src.world_from_env;
        for (l, l0) in s.point_lights.iter_mut().zip(&src.point_lights) {
            l.position = target + r * (l0.position - target);
        }
        let edits = self.light_edits.iter().zip(&self.light_textures);
        for ((l, l0), (edit, textures)) in s.area_lights.iter_mut().zip(&src.area_lights).zip(edits)
        {
            *l = edit.apply(l0, textures);
            // Unturned, the light is exactly the edited one (a reset gives
            // the scene's own, bit for bit).
            if r != Mat3::IDENTITY {
                l.center = target + r * (l.center - target);
                l.world_from_light = r * l.world_from_light;
            }
        }
        self.lit = lighting;
    }

    /// Brings `posed` to the clock and the lighting, for a moving scene: new
    /// meshes only when the time changed.
    fn refresh_pose(&mut self) {
        let (t, lit) = (self.time, &self.lit_scene);
        if !lit.is_animated() {
            return;
        }
        match &mut self.posed {
            Some((pt, p)) if *pt == t => {
                p.world_from_env = lit.world_from_env;
                p.point_lights.clone_from(&lit.point_lights);
                p.area_lights.clone_from(&lit.area_lights);
            }
            _ => self.posed = Some((t, lit.at_time(t))),
        }
    }

    /// Creates, checks and prepares the current method if not done yet.
    ///
    /// # Errors
    /// As the method's bake (a refusal is not an error: it is shown).
    pub fn prepare(&mut self, progress: &dyn Progress) -> Result<(), ViewerError> {
        self.update_lighting();
        self.refresh_pose();
        let time = self.time;
        let slot = &mut self.slots[self.current];
        // A method prepared on another pose prepares again at this one.
        if slot.posed_at.is_some_and(|t| t != time) {
            slot.method = None;
            slot.posed_at = None;
        }
        if slot.method.is_some() || slot.refused.is_some() || slot.unlit_at(self.lit).is_some() {
            return Ok(());
        }
        let mut m = relight_methods::create(&slot.options)?;
        // As `posed_for`, with the pose the frames draw (the same meshes).
        let posed = self.lit_scene.is_animated() && !follows_animation(m.as_ref());
        let scene = match &self.posed {
            Some((_, s)) if posed => s,
            _ => &self.lit_scene,
        };
        match check_scene(m.as_ref(), scene, self.approximate) {
            Err(e) => {
                slot.refused = Some(e.to_string());
                return Ok(());
            }
            Ok(w) => slot.warnings = w,
        }
        self.prepares += 1;
        match m.prepare(scene, progress) {
            // The scene lacks what the method needs (nearfield: an area
            // light): shown on screen like a refusal, not a failure.
            Err(
                e @ MethodError::InvalidOption {
                    option: "scene", ..
                },
            ) => {
                slot.refused = Some(e.to_string());
                return Ok(());
            }
            Err(MethodError::Cancelled) => return Err(MethodError::Cancelled.into()),
            // The lighting the method is prepared with is refused (fog: a
            // point light turned into an object): shown until it changes.
            Err(e) => {
                slot.unlit = Some((
                    self.lit,
                    format!(
                        "{e}; the method could not be prepared at this lighting: turn the lighting (right drag) to try again"
                    ),
                ));
                return Ok(());
            }
            Ok(_) => {}
        }
        slot.method_warnings = m.warnings();
        slot.posed_at = posed.then_some(time);
        slot.lit = Some(self.lit);
        slot.method = Some(m);
        Ok(())
    }

    /// Draws a `width × height` frame; `preview` (while the user drags)
    /// skips antialiasing. A still view adds one antialiasing pass per call
    /// (module docs) until [`Viewer::refining`] is false.
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
        let t = Instant::now();
        self.prepare(progress)?;
        self.last_size = Some((width, height));
        let aa = if preview || !self.antialias {
            1
        } else {
            self.aa
        };
        let camera = self.camera(width, height);
        let lighting = self.lit;
        let key = AccumKey {
            method: self.current,
            camera,
            lighting,
            time: self.time,
        };
        self.refresh_pose();
        let scene = shown_scene(&self.posed, &self.lit_scene);
        let stopped = self.playing && !self.slots[self.current].animates();
        let slot = &mut self.slots[self.current];
        let Some(method) = slot.method.as_mut() else {
            // Not created: refused (prepare says why, or it would be).
            let why = slot.refused.clone().or_else(|| slot.unlit_at(lighting));
            return Ok(Frame::refused(
                width,
                height,
                t,
                aa,
                why.unwrap_or_default(),
            ));
        };
        // A lighting change that would bake again (nearfield: a tilted
        // area light) waits while a drag lasts: the frame keeps the last
        // lighting and says so, and the frame at the release (not a preview)
        // bakes once.
        let deferred =
            preview && slot.lit.is_some_and(|l| l != lighting) && method.lighting_rebakes(scene);
        if !deferred {
            slot.light(scene, lighting, progress)?;
            // A lighting the method refuses is shown, not fatal: the frame
            // is empty and says why until the lighting changes again.
            if let Some(why) = slot.unlit_at(lighting) {
                self.refused_at = Some(key);
                return Ok(Frame::refused(width, height, t, aa, why));
            }
        }
        let method = slot.method.as_mut().expect("created: checked above");
        if !preview {
            slot.method_warnings = method.warnings();
        }
        let mut notes = slot.warnings.clone();
        notes.extend(slot.method_warnings.iter().cloned());
        if deferred {
            notes.push(format!(
                "method {} bakes again for this lighting: it waits until the drag ends",
                method.name()
            ));
        }
        if stopped {
            notes.push(format!(
                "method {} cannot render {} without preparing again: the clock waits at t = {:.2} s",
                method.name(),
                SceneFeature::Animation,
                self.time
            ));
        }
        let message = (!notes.is_empty()).then(|| notes.join("; "));
        // A method's first frame says whether it is Monte Carlo; until then
        // (and for Monte Carlo methods) frames are not offset.
        let accumulate = aa > 1 && slot.monte_carlo == Some(false);
        let acc = &mut self.accum;
        if !accumulate || acc.key != Some(key) {
            acc.key = None;
            acc.passes = 0;
        }
        if accumulate && acc.passes >= aa * aa {
            // Refined: the view has every pass already.
            return Ok(Frame {
                image: mean_image(width, height, &acc.sum, acc.passes),
                ms: t.elapsed().as_secs_f64() * 1e3,
                aa,
                passes: acc.passes,
                spp: 0,
                message,
                refused: false,
            });
        }
        // Pass i of a still view samples the i-th point of the aa × aa grid.
        let i = acc.passes;
        let request_camera = if accumulate {
            let offset = |k: usize| (k as f32 + 0.5) / aa as f32 - 0.5;
            camera.with_pixel_offset(offset(i % aa), offset(i / aa))
        } else {
            camera
        };
        // Progressive methods restart on any change and add a pass per
        // frame while nothing changes, up to their own `spp`.
        let request = FrameRequest {
            camera: request_camera,
            aa: 1,
            progressive: true,
        };
        let out = match render_frame(method.as_mut(), scene, &request, progress) {
            Ok(out) => out,
            Err(MethodError::Cancelled) => return Err(MethodError::Cancelled.into()),
            // A view the method refuses (fog: the eye zoomed far out of the
            // fog ball) is shown, not fatal, like a refused lighting.
            Err(e) => {
                self.refused_at = Some(key);
                let why = format!(
                    "{e}; nothing is drawn at this view: move the camera (drag, wheel) or reset it (r)"
                );
                return Ok(Frame::refused(width, height, t, aa, why));
            }
        };
        self.refused_at = None;
        let spp = out.noise.map_or(0, |n| n.spp);
        slot.spp = spp;
        slot.monte_carlo = Some(out.noise.is_some());
        if out.noise.is_some() || !accumulate {
            acc.key = None;
            return Ok(Frame {
                image: out.image,
                ms: t.elapsed().as_secs_f64() * 1e3,
                aa: if out.noise.is_some() { 1 } else { aa },
                passes: 1,
                spp,
                message,
                refused: false,
            });
        }
        if acc.key.is_none() {
            acc.key = Some(key);
            acc.sum.clear();
            acc.sum.resize(width * height, Vec3::ZERO);
        }
        {
            use rayon::prelude::*;
            acc.sum
                .par_chunks_mut(width.max(1))
                .zip(out.image.pixels.par_chunks(width.max(1)))
                .for_each(|(s, p)| {
                    for (s, p) in s.iter_mut().zip(p) {
                        *s += *p;
                    }
                });
        }
        acc.passes += 1;
        Ok(Frame {
            image: mean_image(width, height, &acc.sum, acc.passes),
            ms: t.elapsed().as_secs_f64() * 1e3,
            aa,
            passes: acc.passes,
            spp: 0,
            message,
            refused: false,
        })
    }

    /// Whether the current view would still refine: the next still frame
    /// adds an antialiasing pass (fewer than `aa²` so far), or the Monte
    /// Carlo reference has fewer than its `spp` samples per pixel.
    #[must_use]
    pub fn refining(&self) -> bool {
        let slot = &self.slots[self.current];
        if slot.method.is_none() {
            return false;
        }
        let key = self.last_size.map(|(w, h)| AccumKey {
            method: self.current,
            camera: self.camera(w, h),
            lighting: self.lighting(),
            time: self.time,
        });
        // A frame shown empty with a refusal has nothing to refine.
        if key.is_some() && self.refused_at == key {
            return false;
        }
        if slot.monte_carlo == Some(true) {
            return match &slot.options {
                MethodOptions::Reference(r) => slot.spp < r.spp,
                _ => false,
            };
        }
        let Some(key) = key else {
            return false;
        };
        if !self.antialias || self.aa <= 1 {
            return false;
        }
        self.accum.key != Some(key) || self.accum.passes < self.aa * self.aa
    }

    /// The current method's own count of one frame's arithmetic at
    /// `width × height` ([`Relighter::frame_work`]), once prepared.
    #[must_use]
    pub fn frame_work(&self, width: usize, height: usize) -> Option<FrameWork> {
        let slot = &self.slots[self.current];
        let request = FrameRequest::new(self.camera(width, height));
        slot.method.as_ref()?.frame_work(&self.lit_scene, &request)
    }

    /// Writes `frame` as `stem.png` (tone-mapped) and `stem.exr` (linear)
    /// (the window's `s` key, at [`free_shot_stem`]).
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

    /// The scene as loaded (before the lighting rotation).
    #[must_use]
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The options of the method shown.
    #[must_use]
    pub fn method_options(&self) -> &MethodOptions {
        &self.slots[self.current].options
    }

    /// True when the method shown is prepared but not yet given the
    /// current lighting, and giving it would bake again
    /// ([`Relighter::lighting_rebakes`]: nearfield's tilted area light).
    /// The window then runs [`Viewer::apply_lighting`] on a worker thread,
    /// with progress, instead of stalling inside [`Viewer::frame`].
    pub fn lighting_bake_due(&mut self) -> bool {
        self.update_lighting();
        self.refresh_pose();
        let lighting = self.lit;
        let scene = shown_scene(&self.posed, &self.lit_scene);
        let slot = &self.slots[self.current];
        slot.lit.is_some_and(|l| l != lighting)
            && slot.unlit_at(lighting).is_none()
            && slot
                .method
                .as_ref()
                .is_some_and(|m| m.lighting_rebakes(scene))
    }

    /// Gives the method shown the current lighting now
    /// ([`Relighter::set_lighting`]), whatever it costs: the bake that
    /// [`Viewer::lighting_bake_due`] announces. Nothing to do for a method
    /// not prepared (its preparation takes the lighting) or already lit.
    /// A lighting the method refuses is kept for the next frame to show.
    ///
    /// # Errors
    /// Cancellation through `progress`.
    pub fn apply_lighting(&mut self, progress: &dyn Progress) -> Result<(), ViewerError> {
        self.update_lighting();
        self.refresh_pose();
        let lighting = self.lit;
        let scene = shown_scene(&self.posed, &self.lit_scene);
        self.slots[self.current].light(scene, lighting, progress)
    }

    /// True once the method shown has been created, checked and prepared
    /// (or refused, or its preparation refused this lighting): the next
    /// [`Viewer::frame`] will not bake.
    #[must_use]
    pub fn is_prepared(&self) -> bool {
        let slot = &self.slots[self.current];
        (slot.method.is_some() && slot.posed_at.is_none_or(|t| t == self.time))
            || slot.refused.is_some()
            || slot.unlit_at(self.lighting()).is_some()
    }

    /// The animation clock, seconds.
    #[must_use]
    pub fn time(&self) -> f32 {
        self.time
    }

    /// Sets the animation clock (seconds; a non-finite value is ignored).
    pub fn set_time(&mut self, time: f32) {
        if time.is_finite() {
            self.time = time;
        }
    }

    /// Whether the animation clock runs.
    #[must_use]
    pub fn playing(&self) -> bool {
        self.playing
    }

    /// True when the scene's objects move.
    #[must_use]
    pub fn is_animated(&self) -> bool {
        self.scene.is_animated()
    }

    /// Starts or stops the clock (module docs, *Animation*); a static scene
    /// has none.
    pub fn toggle_play(&mut self) {
        self.playing = !self.playing && self.is_animated();
    }

    /// Whether the clock runs now: playing, with a method shown that follows
    /// the motion.
    #[must_use]
    pub fn clock_runs(&self) -> bool {
        self.playing && self.slots[self.current].animates()
    }

    /// Moves the clock `dt` seconds while it runs and the method shown follows
    /// the motion (module docs), looping over the animation's keys; returns
    /// whether it moved.
    pub fn advance(&mut self, dt: f32) -> bool {
        if !self.clock_runs() || !dt.is_finite() || dt <= 0.0 {
            return false;
        }
        let end = self.scene.animation_end();
        self.time = if end > 0.0 {
            (self.time + dt) % end
        } else {
            0.0
        };
        true
    }

    /// Why the method shown cannot render the scene, once checked.
    #[must_use]
    pub fn refusal(&self) -> Option<&str> {
        self.slots[self.current].refused.as_deref()
    }
}

impl Slot {
    /// Prepared, and follows the motion of a moving scene without preparing
    /// again.
    fn animates(&self) -> bool {
        self.method.as_deref().is_some_and(follows_animation)
    }
}

/// The mean of `passes` accumulated frames.
/// The first screenshot stem `dir/relight-view-N` after number `last` for
/// which neither `.png` nor `.exr` exists, and its N: shots of an earlier
/// session in the same folder are not overwritten.
#[must_use]
pub fn free_shot_stem(dir: &std::path::Path, last: usize) -> (usize, std::path::PathBuf) {
    let mut n = last;
    loop {
        n += 1;
        let stem = dir.join(format!("relight-view-{n}"));
        if !stem.with_extension("png").exists() && !stem.with_extension("exr").exists() {
            return (n, stem);
        }
    }
}

/// The mean of `passes` accumulated passes, rows in parallel (written once:
/// no zeroed image first).
fn mean_image(width: usize, height: usize, sum: &[Vec3], passes: usize) -> Image {
    use rayon::prelude::*;
    let inv = 1.0 / passes.max(1) as f32;
    let n = width * height;
    let mut pixels = Vec::with_capacity(n);
    sum.par_iter()
        .take(n)
        .map(|s| *s * inv)
        .collect_into_vec(&mut pixels);
    pixels.resize(n, Vec3::ZERO);
    Image {
        width,
        height,
        pixels,
    }
}

/// sRGB bytes of display-referred [0, 1] in 4096 steps, built once per
/// process (it was rebuilt every frame).
fn srgb_lut() -> &'static [u32; 4096] {
    static LUT: std::sync::OnceLock<Box<[u32; 4096]>> = std::sync::OnceLock::new();
    LUT.get_or_init(|| {
        let mut lut = Box::new([0u32; 4096]);
        for (i, v) in lut.iter_mut().enumerate() {
            let s = relight_assets::linear_to_srgb(i as f32 / 4095.0);
            *v = (s * 255.0 + 0.5).clamp(0.0, 255.0) as u32;
        }
        lut
    })
}

/// Tone-maps `image` (ACES, sRGB) into 0x00RRGGBB words for a window.
///
/// Per row, the lookup-table positions of a block of pixels are computed
/// first (a branch-free loop over the block's floats that the compiler
/// vectorises), then read from the table: the per-channel loop with the
/// table read inside it ran scalar, 5 ms of a 960×540 wavelet frame. On a
/// CPU with AVX2 ([`relight_isa::avx2`]) the rows run through a copy
/// compiled for it (eight floats per vector, not four; the same
/// operations, so the same words).
pub fn to_display(image: &Image, out: &mut [u32]) {
    to_display_on(image, out, relight_isa::avx2());
}

/// [`to_display`], through the AVX2 copy of the row loop when `avx2` (the
/// caller has checked the CPU), else the portable one.
pub(crate) fn to_display_on(image: &Image, out: &mut [u32], avx2: bool) {
    use rayon::prelude::*;
    let tone = ToneMap::default();
    // One exp2 per frame, not three per pixel (it was 13 % of a wavelet frame).
    let scale = tone.scale();
    let lut = srgb_lut();
    let w = image.width.max(1);
    out.par_chunks_mut(w)
        .zip(image.pixels.par_chunks(w))
        .for_each(|(dst, src)| {
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: the caller checked AVX2 (`relight_isa::avx2`).
                unsafe { display_row_avx2(&tone, scale, lut, dst, src) };
                return;
            }
            let _ = avx2;
            display_row(&tone, scale, lut, dst, src);
        });
}

/// [`display_row`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn display_row_avx2(
    tone: &ToneMap,
    scale: f32,
    lut: &[u32; 4096],
    dst: &mut [u32],
    src: &[Vec3],
) {
    display_row(tone, scale, lut, dst, src);
}

/// The sRGB table positions of `flat`'s values, tone-mapped by `tone`.
#[inline(always)]
fn lut_positions(tone: ToneMap, scale: f32, flat: &[f32], at: &mut [u32]) {
    for (a, &x) in at.iter_mut().zip(flat) {
        let i = tone.apply_scaled(x, scale) * 4095.0 + 0.5;
        // SAFETY: `apply_scaled` is in [0, 1], so `i` is finite and in
        // [0.5, 4095.5]: it fits a u32. (The saturating `as` kept this loop
        // scalar.)
        *a = unsafe { i.to_int_unchecked::<u32>() };
    }
}

/// One row of [`to_display`].
#[inline(always)]
fn display_row(tone: &ToneMap, scale: f32, lut: &[u32; 4096], dst: &mut [u32], src: &[Vec3]) {
    /// Pixels per block.
    const BLOCK: usize = 64;
    let mut at = [0u32; 3 * BLOCK];
    for (dst, src) in dst.chunks_mut(BLOCK).zip(src.chunks(BLOCK)) {
        let flat: &[f32] = bytemuck::cast_slice(src);
        // One loop per operator, each seeing a constant one: with the
        // operator's `match` inside, the loop ran scalar.
        use relight_assets::ToneOperator as Op;
        match tone.operator {
            Op::Aces => lut_positions(
                ToneMap {
                    operator: Op::Aces,
                    ..*tone
                },
                scale,
                flat,
                &mut at,
            ),
            Op::Reinhard => lut_positions(
                ToneMap {
                    operator: Op::Reinhard,
                    ..*tone
                },
                scale,
                flat,
                &mut at,
            ),
            Op::Clamp => lut_positions(
                ToneMap {
                    operator: Op::Clamp,
                    ..*tone
                },
                scale,
                flat,
                &mut at,
            ),
        }
        for (d, a) in dst.iter_mut().zip(at.chunks_exact(3)) {
            let c = |i: u32| lut[(i as usize).min(4095)];
            *d = (c(a[0]) << 16) | (c(a[1]) << 8) | c(a[2]);
        }
    }
}
