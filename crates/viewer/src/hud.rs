//! The heads-up display drawn into every frame of `relight view`: what is
//! shown, how fast, how well, and the keys — in the frame itself, not only in
//! the window title.
//!
//! | where | what |
//! |---|---|
//! | top left | method (`[k/n]` its key), ms of the frame's work and the fps it allows; the method's settings (order or terms, AA or spp); the measured error against the reference; the area light (centre, size, texture, and whether the light-editing mode is on) when the scene has one |
//! | centre | why the method draws nothing (its refusal, [`Frame::message`]) or what it approximates; while a method prepares, its phase and a progress bar |
//! | bottom left | the key help (`h` hides the HUD); with an area light, its editing keys: `l` (or Shift held) makes a left drag move the light in its own plane, following the cursor, and the wheel scale it; `t` cycles its texture; with several, `Tab` picks the light the edits go to ([`crate::light`]) |
//!
//! # The error shown
//! The relative RMS error over object pixels, √Σ‖a − r‖² / √Σ‖r‖² (the
//! `verify` and `relight compare` measure, [`Image::relative_rms_error`]), of
//! the frame against **the reference rendered for the same view**: the
//! [`ErrorMeter`] keeps the last reference frame the viewer drew, keyed by
//! camera, size, lighting rotation and area-light edit. Switching to the reference (its key)
//! and back measures any method at that view, against as many samples per
//! pixel as the reference had accumulated (shown beside the error, since
//! the reference's own noise is part of the figure). No estimate is made
//! where no reference exists for the view: the HUD says how to get one.
//! Object pixels are those fully covered in a coverage raster of the scene
//! ([`rasterize_coverage`], [`COVERAGE_SUBSAMPLES`]² samples per pixel),
//! computed once per reference view.

use crate::light::LightEdit;
use crate::state::{Frame, Viewer};
use crate::text::{Canvas, GREEN, GREY, Line, RED, Rect, WHITE, YELLOW, line_height, wrap};
use relight_methods::{MethodKind, MethodOptions};
use relight_render::method::{COVERAGE_SUBSAMPLES, rasterize_coverage};
use relight_render::{Camera, Image};

/// The measured error of a frame against the reference, when known.
#[derive(Clone, Debug, PartialEq)]
pub enum ErrorReading {
    /// Relative RMS error over object pixels against a reference of `spp`
    /// samples per pixel at the same view.
    Measured { relative: f64, reference_spp: u32 },
    /// The frame is the reference itself.
    IsReference,
    /// No reference for this view yet.
    NoReference,
    /// The method drew nothing.
    NotDrawn,
}

/// What the HUD shows for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct HudInfo {
    pub method: MethodKind,
    /// 1-based key of the method and how many there are.
    pub key: usize,
    pub methods: Vec<MethodKind>,
    /// Milliseconds of the frame's work (lighting update included).
    pub ms: f64,
    /// Frames per second the whole redraw allows (frame, display, HUD).
    pub fps: f64,
    /// The method's settings, e.g. `order 6 · rotation exact · 2×2 AA`.
    pub settings: String,
    pub error: ErrorReading,
    /// A refusal (nothing drawn) or a warning (approximated).
    pub message: Option<String>,
    /// True when `message` is a refusal.
    pub refused: bool,
    /// The reference is still adding samples.
    pub refining: bool,
    /// The animation clock (seconds) and whether it runs, for a moving scene.
    pub clock: Option<(f32, bool)>,
    /// The edited area light as drawn (centre, size, texture), when the
    /// scene has one.
    pub light: Option<String>,
    /// The scene's area lights.
    pub lights: usize,
    /// The light-editing mode is on (drag moves and the wheel scales the light).
    pub light_mode: bool,
}

impl HudInfo {
    /// The HUD of `frame`, just drawn by `viewer`, with `error` from an
    /// [`ErrorMeter`] and `redraw_ms` the whole redraw's time (for the fps).
    #[must_use]
    pub fn new(viewer: &Viewer, frame: &Frame, error: ErrorReading, redraw_ms: f64) -> Self {
        let methods = viewer.methods();
        let method = viewer.method();
        let key = methods.iter().position(|m| *m == method).unwrap_or(0) + 1;
        Self {
            method,
            key,
            methods,
            ms: frame.ms,
            fps: if redraw_ms > 0.0 {
                1e3 / redraw_ms
            } else {
                0.0
            },
            settings: settings(viewer.method_options(), frame),
            error,
            message: frame.message.clone(),
            refused: frame.refused,
            refining: viewer.refining(),
            clock: viewer
                .is_animated()
                .then(|| (viewer.time(), viewer.clock_runs())),
            light: light_line(viewer),
            lights: viewer.lit_scene().area_lights.len(),
            light_mode: viewer.light_mode,
        }
    }

    /// The top-left panel's lines.
    #[must_use]
    pub fn status_lines(&self) -> Vec<Line> {
        let mut lines = vec![
            Line::new(
                format!(
                    "{} [{}/{}]  {:.1} ms  {:.0} fps",
                    self.method,
                    self.key,
                    self.methods.len(),
                    self.ms,
                    self.fps
                ),
                WHITE,
            ),
            Line::new(
                match self.clock {
                    Some((t, runs)) => format!(
                        "{} · t {t:.2} s {}",
                        self.settings,
                        if runs { "playing" } else { "paused" }
                    ),
                    None => self.settings.clone(),
                },
                GREY,
            ),
        ];
        let reference_key = self
            .methods
            .iter()
            .position(|m| *m == MethodKind::Reference)
            .map(|i| i + 1);
        let error = match &self.error {
            ErrorReading::Measured {
                relative,
                reference_spp,
            } => Line::new(
                format!(
                    "error vs reference: {:.1} % rel. RMS ({reference_spp} spp, object pixels)",
                    100.0 * relative
                ),
                GREEN,
            ),
            ErrorReading::IsReference => Line::new(
                if self.refining {
                    "the reference: refining while the view is still"
                } else {
                    "the reference: converged to its spp"
                },
                GREEN,
            ),
            ErrorReading::NoReference => Line::new(
                match reference_key {
                    Some(k) => format!("error: no reference for this view (press {k}, then back)"),
                    None => "error: no reference among the methods".into(),
                },
                GREY,
            ),
            ErrorReading::NotDrawn => Line::new("error: nothing drawn", GREY),
        };
        lines.push(error);
        if let Some(l) = &self.light {
            lines.push(if self.light_mode {
                Line::new(format!("{l}  [editing]"), YELLOW)
            } else {
                Line::new(l.clone(), GREY)
            });
        }
        lines
    }

    /// The bottom panel's key help.
    #[must_use]
    pub fn help_lines(&self) -> Vec<Line> {
        let keys: Vec<String> = self
            .methods
            .iter()
            .enumerate()
            .map(|(i, m)| format!("{} {m}", i + 1))
            .collect();
        let mut lines = vec![Line::new(
            if self.light_mode {
                "drag: move area light in its plane   wheel: scale it   right drag: turn lighting   r: reset"
            } else {
                "drag: orbit   right drag: turn lighting   wheel: zoom   r: reset"
            },
            GREY,
        )];
        if self.light.is_some() {
            lines.push(Line::new(
                format!(
                    "{}   t: light texture{}",
                    if self.light_mode {
                        "l: back to orbit"
                    } else {
                        "l or hold Shift: edit area light (drag moves, wheel scales)"
                    },
                    if self.lights > 1 {
                        "   Tab: next light"
                    } else {
                        ""
                    }
                ),
                GREY,
            ));
        }
        lines.push(Line::new(
            format!(
                "{}   a: AA{}{}   h: hide HUD   s: save   q: quit",
                keys.join("  "),
                if self.clock.is_some() {
                    "   p: play"
                } else {
                    ""
                },
                if matches!(self.method, MethodKind::Ndf | MethodKind::Sh) {
                    "   n: normal filter"
                } else {
                    ""
                }
            ),
            GREY,
        ));
        lines
    }
}

/// The edited area light of the last frame (which of how many, centre,
/// size, texture), when the scene has one.
fn light_line(viewer: &Viewer) -> Option<String> {
    let lights = &viewer.lit_scene().area_lights;
    let i = viewer.edited_light();
    let l = lights.get(i)?;
    let which = if lights.len() > 1 {
        format!(" {} of {} (Tab: next)", i + 1, lights.len())
    } else {
        String::new()
    };
    let c = l.center;
    let texture = match viewer.light_edit().texture {
        _ if l.light_field.is_some() => "light field (its views)",
        crate::light::LightTexture::Scene if l.texture.is_none() => "none",
        t => t.name(),
    };
    Some(format!(
        "area light{which}: centre ({:.2}, {:.2}, {:.2}) · {:.2} × {:.2} · texture {texture}",
        c.x, c.y, c.z, l.size.x, l.size.y
    ))
}

/// The settings line of a method's options and its frame.
#[must_use]
pub fn settings(options: &MethodOptions, frame: &Frame) -> String {
    let quality = if frame.spp > 0 {
        String::new()
    } else if frame.aa > 1 {
        format!(" · {}×{} AA", frame.aa, frame.aa)
    } else {
        " · no AA".into()
    };
    match options {
        MethodOptions::Wavelet(w) => format!(
            "n {} (N = {}) · terms {} · AO rays {}{quality}",
            w.n,
            w.n * w.n,
            w.terms,
            w.ao
        ),
        MethodOptions::Sh(s) => format!(
            "order {} ({} coefficients) · rotation {} · normal filter {}{quality}",
            s.order,
            s.order * s.order,
            s.rotation,
            s.normal_filter.name()
        ),
        MethodOptions::RadianceCache(r) => format!(
            "a {} · order {} · rotation {}{quality}",
            r.error,
            r.order,
            r.rotation.name()
        ),
        MethodOptions::Triple(t) => format!(
            "{} terms (top-only) · {} twists{quality}",
            t.terms, t.twists
        ),
        MethodOptions::Fog(f) => format!(
            "{} · environment order {}{quality}",
            // The mode's type is the fog crate's; its Debug name suffices here.
            if format!("{:?}", f.mode).starts_with("Analytic") {
                "analytic single scattering"
            } else {
                "OpenGL exponential fog"
            },
            f.env_order
        ),
        MethodOptions::Reference(r) => format!("{}/{} spp", frame.spp, r.spp),
        MethodOptions::ShExp(x) => format!(
            "order {} · {} · {} spheres per blocker{quality}",
            x.order,
            x.exp.name(),
            x.spheres
        ),
        MethodOptions::Ndf(n) => format!(
            "normal filter {}{} · {} · {} lobes{quality}",
            n.filter.name(),
            if n.probe_masks {
                ", mask per probe"
            } else {
                ""
            },
            n.brdf.label(),
            n.vmf.lobes
        ),
        MethodOptions::Nearfield(n) => format!(
            "order {} · face {} · source {} % · target {} %{quality}",
            n.order,
            n.face,
            n.source_terms * 100.0,
            n.target_terms * 100.0
        ),
        MethodOptions::Ltc(l) => format!(
            "{}{quality}",
            if l.specular {
                "diffuse + GGX"
            } else {
                "diffuse only"
            }
        ),
    }
}

/// Pixel scale of the HUD's glyphs for a `height`-pixel frame (1 up to
/// ~750 pixels, then 2, …).
#[must_use]
pub fn hud_scale(height: usize) -> usize {
    ((height + 250) / 500).max(1)
}

/// Margin of the HUD's panels from the frame's edges and around their text.
fn margin(scale: usize) -> usize {
    6 * scale
}

/// Where [`draw_hud`] puts its panels on a `width × height` frame: status,
/// message (if any) and help.
#[must_use]
pub fn layout(info: &HudInfo, width: usize, height: usize) -> Vec<Rect> {
    let s = hud_scale(height);
    let m = margin(s);
    let status = fitted(info.status_lines(), width, s);
    let mut rects = vec![crate::text::panel_rect(m, m, s, &status, m)];
    if let Some(lines) = message_lines(info, width, s) {
        rects.push(centred(&lines, width, height, s));
    }
    let help = fitted(info.help_lines(), width, s);
    let hr = crate::text::panel_rect(0, 0, s, &help, m);
    rects.push(Rect {
        x: m,
        y: height.saturating_sub(hr.h + m),
        ..hr
    });
    rects
}

fn message_lines(info: &HudInfo, width: usize, s: usize) -> Option<Vec<Line>> {
    let msg = info.message.as_deref()?;
    let chars = (width * 3 / 4) / (crate::text::GLYPH * s);
    let color = if info.refused { RED } else { YELLOW };
    let mut lines = Vec::new();
    if info.refused {
        lines.push(Line::new(
            format!("{} draws nothing here:", info.method),
            WHITE,
        ));
    }
    lines.extend(wrap(msg, chars).into_iter().map(|l| Line::new(l, color)));
    Some(lines)
}

fn centred(lines: &[Line], width: usize, height: usize, s: usize) -> Rect {
    let m = margin(s);
    let r = crate::text::panel_rect(0, 0, s, lines, m);
    Rect {
        x: width.saturating_sub(r.w) / 2,
        y: height.saturating_sub(r.h) / 2,
        ..r
    }
}

/// Draws the HUD of `info` over `canvas` (a frame already tone-mapped into
/// it).
pub fn draw_hud(canvas: &mut Canvas, info: &HudInfo) {
    let (w, h) = (canvas.width(), canvas.height());
    let s = hud_scale(h);
    let m = margin(s);
    let rects = layout(info, w, h);
    canvas.panel(
        rects[0].x,
        rects[0].y,
        s,
        &fitted(info.status_lines(), w, s),
        m,
    );
    if let Some(lines) = message_lines(info, w, s) {
        canvas.panel(rects[1].x, rects[1].y, s, &lines, m);
    }
    let help = rects[rects.len() - 1];
    canvas.panel(help.x, help.y, s, &fitted(info.help_lines(), w, s), m);
}

/// `lines` wrapped at spaces to fit a panel on a `width`-pixel frame at
/// glyph scale `s` (the key help of nine methods is wider than a 960-pixel
/// window, a method's settings can be wider than a small one); each piece
/// keeps its line's colour.
fn fitted(lines: Vec<Line>, width: usize, s: usize) -> Vec<Line> {
    let chars = width.saturating_sub(4 * margin(s)) / (crate::text::GLYPH * s);
    lines
        .into_iter()
        .flat_map(|l| {
            wrap(&l.text, chars)
                .into_iter()
                .map(move |t| Line::new(t.trim_end(), l.color))
        })
        .collect()
}

/// What a method's preparation has reached: the phase and its counts.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct PrepareStatus {
    /// What runs, e.g. "preparing wavelet".
    pub title: String,
    pub phase: String,
    pub done: u64,
    pub total: u64,
    /// Seconds since it started.
    pub elapsed_s: u64,
}

/// Draws a centred panel with the preparation's phase and a progress bar.
pub fn draw_progress(canvas: &mut Canvas, status: &PrepareStatus) {
    let (w, h) = (canvas.width(), canvas.height());
    let s = hud_scale(h);
    let m = margin(s);
    let pct = if status.total > 0 {
        100.0 * status.done.min(status.total) as f64 / status.total as f64
    } else {
        0.0
    };
    let lines = vec![
        Line::new(format!("{} ({} s)", status.title, status.elapsed_s), WHITE),
        Line::new(
            format!(
                "{}: {}/{} ({pct:.0} %)",
                status.phase, status.done, status.total
            ),
            GREY,
        ),
        // Room for the bar.
        Line::new(" ".repeat(40), GREY),
        Line::new("Esc/q: quit", GREY),
    ];
    let r = centred(&lines, w, h, s);
    canvas.panel(r.x, r.y, s, &lines, m);
    let lh = line_height(s);
    let bar = Rect {
        x: r.x + m,
        y: r.y + m + 2 * lh,
        w: r.w - 2 * m,
        h: crate::text::GLYPH * s,
    };
    canvas.fill(bar, 0x40_40_48, 1.0);
    canvas.fill(
        Rect {
            w: (bar.w as f64 * pct / 100.0).round() as usize,
            ..bar
        },
        GREEN,
        1.0,
    );
}

/// Identifies a view: camera, image size, lighting rotation and area-light
/// edit.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ViewKey {
    camera: Camera,
    light: [f32; 2],
    /// The edited light, its edit and the resets so far: together they
    /// change with every area-light edit.
    edit: (usize, LightEdit, u32),
}

fn key_of(viewer: &Viewer, width: usize, height: usize) -> ViewKey {
    ViewKey {
        camera: viewer.camera(width, height),
        light: [viewer.light_yaw_deg, viewer.light_pitch_deg],
        edit: (
            viewer.edited_light(),
            viewer.light_edit(),
            viewer.light_resets(),
        ),
    }
}

/// The last reference frame and its object pixels.
struct ReferenceView {
    key: ViewKey,
    image: Image,
    spp: u32,
    objects: Vec<bool>,
}

/// Keeps the reference the viewer drew last and measures other methods'
/// frames at the same view against it (see the module docs).
#[derive(Default)]
pub struct ErrorMeter {
    reference: Option<ReferenceView>,
}

impl ErrorMeter {
    /// Records `frame` (just drawn by `viewer`) if it is the reference, and
    /// returns its error reading.
    pub fn observe(&mut self, viewer: &Viewer, frame: &Frame) -> ErrorReading {
        let (w, h) = (frame.image.width, frame.image.height);
        let key = key_of(viewer, w, h);
        if frame.refused {
            return ErrorReading::NotDrawn;
        }
        if viewer.method() == MethodKind::Reference {
            let objects = match self.reference.take() {
                Some(r) if r.key == key => r.objects,
                _ => object_pixels(viewer, &key.camera),
            };
            self.reference = Some(ReferenceView {
                key,
                image: frame.image.clone(),
                spp: frame.spp,
                objects,
            });
            return ErrorReading::IsReference;
        }
        match &self.reference {
            Some(r) if r.key == key && r.objects.iter().any(|&o| o) => ErrorReading::Measured {
                relative: frame.image.relative_rms_error(&r.image, Some(&r.objects)),
                reference_spp: r.spp,
            },
            _ => ErrorReading::NoReference,
        }
    }
}

fn object_pixels(viewer: &Viewer, camera: &Camera) -> Vec<bool> {
    rasterize_coverage(viewer.scene(), camera, COVERAGE_SUBSAMPLES)
        .map(|c| c.object_mask())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ViewerOptions;
    use relight_render::NoProgress;

    fn options() -> ViewerOptions {
        let mut o = ViewerOptions::default();
        for m in &mut o.methods {
            match m {
                MethodOptions::Sh(s) => s.order = 3,
                MethodOptions::Reference(r) => {
                    r.spp = 8;
                    r.pass_spp = 4;
                }
                _ => {}
            }
        }
        o.aa = 1;
        o
    }

    #[test]
    fn the_hud_names_method_time_settings_error_and_keys() {
        let scene = relight_scene::default_scene(48, 27);
        let mut v = Viewer::new(scene, MethodKind::Sh, options()).unwrap();
        let mut meter = ErrorMeter::default();
        let f = v.frame(48, 27, false, &NoProgress).unwrap();
        let e = meter.observe(&v, &f);
        assert_eq!(e, ErrorReading::NoReference);
        let info = HudInfo::new(&v, &f, e, 20.0);
        let status = info.status_lines();
        assert!(status[0].text.starts_with("sh [2/9]"), "{:?}", status[0]);
        assert!(status[0].text.contains("50 fps"), "{:?}", status[0]);
        assert!(status[1].text.contains("order 3"), "{:?}", status[1]);
        assert!(status[2].text.contains("press 5"), "{:?}", status[2]);
        let help: String = info.help_lines().iter().map(|l| l.text.clone()).collect();
        for k in [
            "1 wavelet",
            "2 sh",
            "3 fog",
            "4 shexp",
            "5 reference",
            "6 ndf",
            "7 nearfield",
            "8 triple",
            "9 ltc",
            "q: quit",
        ] {
            assert!(help.contains(k), "{help}");
        }
        assert!(help.contains("n: normal filter"), "{help}");
        // On the default 960 × 540 window every panel fits: the key help
        // (142 characters, 1136 pixels) is wrapped, not cut.
        for (w, h) in [(960, 540), (640, 360)] {
            for r in layout(&info, w, h) {
                assert!(r.x + r.w <= w && r.y + r.h <= h, "{r:?} outside {w}×{h}");
            }
        }
        // So does every default method's status (its settings line is
        // 444 pixels wide for wavelet) in a window resized to 320 × 180.
        for m in &ViewerOptions::default().methods {
            let each = HudInfo {
                method: m.kind(),
                settings: settings(m, &f),
                ..info.clone()
            };
            for r in layout(&each, 320, 180) {
                assert!(r.x + r.w <= 320, "{}: {r:?}", m.kind());
            }
        }
        let wrapped: String = fitted(info.help_lines(), 960, 1)
            .iter()
            .map(|l| l.text.clone() + " ")
            .collect();
        for k in ["9 ltc", "q: quit", "n: normal filter"] {
            assert!(wrapped.contains(k), "{wrapped}");
        }
        // n cycles the normal filter of ndf and of sh's filtering mode.
        v.select(0);
        assert!(!v.cycle_normal_filter());
        v.select(1);
        assert!(v.cycle_normal_filter());
        match v.method_options() {
            MethodOptions::Sh(o) => assert_eq!(o.normal_filter.name(), "unnormalized"),
            _ => panic!("method 2 is sh"),
        }
        v.select(5);
        let filter = |v: &Viewer| match v.method_options() {
            MethodOptions::Ndf(o) => o.filter.name(),
            _ => "not ndf",
        };
        let probes = |v: &Viewer| match v.method_options() {
            MethodOptions::Ndf(o) => o.probe_masks,
            _ => false,
        };
        assert_eq!((filter(&v), probes(&v)), ("sh", false));
        // The sh filter comes again with a mask per footprint probe.
        assert!(v.cycle_normal_filter());
        assert_eq!((filter(&v), probes(&v)), ("sh", true));
        assert!(v.cycle_normal_filter());
        assert_eq!((filter(&v), probes(&v)), ("vmf", false));
        assert!(v.cycle_normal_filter());
        assert_eq!(filter(&v), "none");
        let ndf_help = HudInfo {
            method: MethodKind::Ndf,
            ..info.clone()
        };
        let help: String = ndf_help
            .help_lines()
            .iter()
            .map(|l| l.text.clone())
            .collect();
        assert!(help.contains("n: normal filter"), "{help}");
        // The reference for this view, then sh again: a measured error.
        v.select(4);
        let r = v.frame(48, 27, false, &NoProgress).unwrap();
        assert_eq!(meter.observe(&v, &r), ErrorReading::IsReference);
        let probe_masks = MethodOptions::Ndf(relight_ndf::NdfOptions {
            probe_masks: true,
            ..relight_ndf::NdfOptions::default()
        });
        let line = settings(&probe_masks, &r);
        assert!(
            line.starts_with("normal filter sh, mask per probe ·"),
            "{line}"
        );
        v.select(1);
        let f2 = v.frame(48, 27, false, &NoProgress).unwrap();
        match meter.observe(&v, &f2) {
            ErrorReading::Measured {
                relative,
                reference_spp,
            } => {
                assert_eq!(reference_spp, 4);
                // SH order 3 against a 4-spp reference: clearly wrong, not absurd.
                assert!(relative > 0.01 && relative < 2.0, "{relative}");
            }
            other => panic!("{other:?}"),
        }
        // Another view: the reference no longer applies.
        v.orbit.rotate(15.0, 0.0);
        let f3 = v.frame(48, 27, false, &NoProgress).unwrap();
        assert_eq!(meter.observe(&v, &f3), ErrorReading::NoReference);
    }

    #[test]
    fn a_refusal_is_drawn_in_the_frame_and_only_the_hud_area_changes() {
        let mut scene = relight_scene::default_scene(160, 120);
        scene.point_lights.push(relight_render::PointLight::new(
            glam::Vec3::Y * 3.0,
            glam::Vec3::ONE,
        ));
        let mut v = Viewer::new(scene, MethodKind::Sh, options()).unwrap();
        let f = v.frame(320, 240, false, &NoProgress).unwrap();
        let mut meter = ErrorMeter::default();
        let e = meter.observe(&v, &f);
        assert_eq!(e, ErrorReading::NotDrawn);
        let info = HudInfo::new(&v, &f, e, 1.0);
        assert!(info.refused);
        let (w, h) = (320, 240);
        let mut words = vec![0u32; w * h];
        crate::to_display(&f.image, &mut words);
        let before = words.clone();
        let rects = layout(&info, w, h);
        assert_eq!(rects.len(), 3, "status, refusal, help");
        let mut canvas = Canvas::new(&mut words, w, h);
        draw_hud(&mut canvas, &info);
        let mut changed_in = vec![0usize; rects.len()];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let inside = rects.iter().position(|r| r.contains(x, y));
                match inside {
                    Some(k) => changed_in[k] += usize::from(words[i] != before[i]),
                    None => assert_eq!(words[i], before[i], "({x}, {y}) outside the HUD"),
                }
            }
        }
        // Every panel drew text: the refusal's red glyphs among them.
        assert!(changed_in.iter().all(|&c| c > 50), "{changed_in:?}");
        let r = rects[1];
        let red = (r.y..r.y + r.h)
            .flat_map(|y| (r.x..r.x + r.w).map(move |x| (x, y)))
            .filter(|&(x, y)| words[y * w + x] == RED)
            .count();
        assert!(red > 50, "{red} red pixels in the refusal");
        let text: String = info.message.clone().unwrap();
        assert!(text.contains("point lights"), "{text}");
    }

    #[test]
    fn the_progress_panel_fills_its_bar_in_proportion() {
        let (w, h) = (400, 200);
        let bar_green = |done: u64| {
            let mut words = vec![0u32; w * h];
            let mut c = Canvas::new(&mut words, w, h);
            draw_progress(
                &mut c,
                &PrepareStatus {
                    title: "preparing wavelet".into(),
                    phase: "rotation matrices".into(),
                    done,
                    total: 100,
                    elapsed_s: 3,
                },
            );
            words.iter().filter(|&&p| p == GREEN).count()
        };
        let (a, b, c) = (bar_green(0), bar_green(50), bar_green(100));
        assert_eq!(a, 0);
        assert!(b > 0 && (2 * b as i64 - c as i64).abs() <= 16, "{b} vs {c}");
    }
}
