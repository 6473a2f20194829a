//! The window: winit events drive a [`Viewer`]; frames are tone-mapped into
//! a softbuffer surface (CPU pixels, no GPU needed) with the HUD
//! ([`crate::hud`]) drawn over them.
//!
//! Controls: left drag orbits the camera, right drag turns the lighting,
//! the wheel zooms; `1`–`9` switch methods (the reference refines while the
//! view is still), `a` toggles antialiasing, `h` the HUD, `r` resets, `s`
//! saves the frame as PNG + EXR (`relight-view-N`, the first N free in the
//! working folder; a failed write is printed, not fatal), `Esc`/`q` quits. While a button is held
//! frames skip antialiasing (preview).
//!
//! With an area light in the scene ([`crate::light`]): `l` toggles the
//! light-editing mode (or hold Shift), in which a left drag moves the first
//! area light in its own plane, following the cursor, and the wheel scales
//! it; `t` cycles its texture; `Tab` passes the edits to the next light. Every edit reaches the methods through
//! `set_lighting`, in the next frame, without preparing again.
//!
//! A method prepares (bakes or loads its data) on a worker thread the first
//! time it is shown: the window keeps drawing, with the phase and a progress
//! bar in the frame and the same progress on stderr, and `Esc`/`q` cancels
//! the bake and quits. A lighting change that bakes again (nearfield's
//! tilted area light, held back while the drag lasts) runs there too, at
//! the release, behind the same panel.

use crate::hud::{ErrorMeter, HudInfo, PrepareStatus, draw_hud, draw_progress};
use crate::state::{Frame, Viewer, ViewerError};
use crate::text::Canvas;
use relight_render::{NoProgress, Progress};
use std::num::NonZeroU32;
use std::path::Path;
use std::rc::Rc;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::{Scope, ScopedJoinHandle};
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, ModifiersState, NamedKey};
use winit::window::{Window, WindowId};

/// Degrees of turn per pixel of mouse drag.
const DEG_PER_PIXEL: f32 = 0.3;

/// How often the window redraws its progress panel while a method prepares.
const PROGRESS_PERIOD: Duration = Duration::from_millis(100);

/// Progress of a preparation on the worker thread, read by the window and
/// forwarded to the caller's progress (stderr).
struct SharedProgress<'e> {
    stderr: &'e dyn Progress,
    phase: Mutex<String>,
    done: AtomicU64,
    total: AtomicU64,
    cancel: AtomicBool,
}

impl Progress for SharedProgress<'_> {
    fn start(&self, what: &str, total: u64) {
        *self.phase.lock().unwrap_or_else(|e| e.into_inner()) = what.to_string();
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        self.stderr.start(what, total);
    }
    fn inc(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
        self.stderr.inc(n);
    }
    fn finish(&self) {
        self.stderr.finish();
    }
    fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed) || self.stderr.is_cancelled()
    }
}

/// What the worker thread runs: a method's first preparation, or the
/// bake a lighting change needs ([`Viewer::lighting_bake_due`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Job {
    Prepare,
    Lighting,
}

impl Job {
    /// What runs, for the panel, the window title and stderr.
    fn title(self, method: &str) -> String {
        match self {
            Self::Prepare => format!("preparing {method}"),
            Self::Lighting => format!("baking {method} for the new lighting"),
        }
    }

    /// What has happened when it ends, for stderr.
    fn done(self) -> &'static str {
        match self {
            Self::Prepare => "prepared",
            Self::Lighting => "baked for the new lighting",
        }
    }
}

/// A preparation running on the worker thread.
struct Preparing<'s> {
    method: String,
    job: Job,
    started: Instant,
    handle: ScopedJoinHandle<'s, (Viewer, Result<(), ViewerError>)>,
}

struct App<'s, 'e> {
    /// `None` while a worker thread prepares a method.
    viewer: Option<Viewer>,
    preparing: Option<Preparing<'s>>,
    scope: &'s Scope<'s, 'e>,
    progress: &'e SharedProgress<'e>,
    size: (u32, u32),
    window: Option<Rc<Window>>,
    surface: Option<softbuffer::Surface<Rc<Window>, Rc<Window>>>,
    drag: Option<MouseButton>,
    cursor: Option<PhysicalPosition<f64>>,
    modifiers: ModifiersState,
    last: Option<Frame>,
    meter: ErrorMeter,
    show_hud: bool,
    /// Milliseconds of the last whole redraw (frame, display, HUD, present).
    redraw_ms: f64,
    shots: usize,
    /// When the animation clock last moved (while it plays).
    tick: Option<Instant>,
    error: Option<ViewerError>,
}

/// Opens a `width × height` window on `viewer` and runs until it closes.
///
/// Fails fast, before any method prepares, when no display is set.
///
/// # Errors
/// None of `DISPLAY`, `WAYLAND_DISPLAY` or `WAYLAND_SOCKET` is set.
pub fn check_display() -> Result<(), ViewerError> {
    let any = ["DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()));
    if any {
        Ok(())
    } else {
        Err(ViewerError::Window(
            "cannot open a window (needs DISPLAY or WAYLAND_DISPLAY; `relight render` works without one)"
                .into(),
        ))
    }
}

/// Opens a `width × height` window on `viewer` and runs until it closes;
/// methods prepare on a worker thread, reporting to the window and to
/// `stderr` (the caller's progress: the CLI's bars and Ctrl-C).
///
/// # Errors
/// No display (e.g. no `DISPLAY`/`WAYLAND_DISPLAY`), or a method's error.
pub fn run(
    viewer: Viewer,
    width: u32,
    height: u32,
    stderr: &dyn Progress,
) -> Result<(), ViewerError> {
    let event_loop = EventLoop::new().map_err(|e| {
        ViewerError::Window(format!(
            "cannot open a window (needs DISPLAY or WAYLAND_DISPLAY; `relight render` works without one): {e}"
        ))
    })?;
    event_loop.set_control_flow(ControlFlow::Wait);
    let progress = SharedProgress {
        stderr,
        phase: Mutex::new(String::new()),
        done: AtomicU64::new(0),
        total: AtomicU64::new(0),
        cancel: AtomicBool::new(false),
    };
    std::thread::scope(|scope| {
        let mut app = App {
            viewer: Some(viewer),
            preparing: None,
            scope,
            progress: &progress,
            size: (width.max(1), height.max(1)),
            window: None,
            surface: None,
            drag: None,
            cursor: None,
            modifiers: ModifiersState::empty(),
            last: None,
            meter: ErrorMeter::default(),
            show_hud: true,
            redraw_ms: 0.0,
            shots: 0,
            tick: None,
            error: None,
        };
        let ran = event_loop.run_app(&mut app);
        // Closed while a method prepared: stop the bake and wait for it.
        if let Some(p) = app.preparing.take() {
            progress.cancel.store(true, Ordering::Relaxed);
            let _ = p.handle.join();
        }
        ran.map_err(|e| ViewerError::Window(e.to_string()))?;
        app.error.map_or(Ok(()), Err)
    })
}

impl<'s, 'e> App<'s, 'e> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewerError) {
        self.error = Some(e);
        event_loop.exit();
    }

    fn quit(&mut self, event_loop: &ActiveEventLoop) {
        self.progress.cancel.store(true, Ordering::Relaxed);
        event_loop.exit();
    }

    /// Starts `job` for the current method on a worker thread.
    fn start_preparing(&mut self, job: Job) {
        let Some(mut viewer) = self.viewer.take() else {
            return;
        };
        let method = viewer.method().name().to_string();
        eprintln!("relight: view: {} …", job.title(&method));
        self.progress.done.store(0, Ordering::Relaxed);
        self.progress.total.store(0, Ordering::Relaxed);
        *self
            .progress
            .phase
            .lock()
            .unwrap_or_else(|e| e.into_inner()) = "starting".into();
        let progress: &'e SharedProgress<'e> = self.progress;
        let handle = self.scope.spawn(move || {
            let r = match job {
                Job::Prepare => viewer.prepare(progress),
                Job::Lighting => viewer.apply_lighting(progress),
            };
            (viewer, r)
        });
        self.preparing = Some(Preparing {
            method,
            job,
            started: Instant::now(),
            handle,
        });
    }

    /// Takes the viewer back once its worker thread has finished.
    fn poll_preparing(&mut self) -> Result<(), ViewerError> {
        if !self
            .preparing
            .as_ref()
            .is_some_and(|p| p.handle.is_finished())
        {
            return Ok(());
        }
        let p = self.preparing.take().expect("checked above");
        let (viewer, result) = p
            .handle
            .join()
            .map_err(|_| ViewerError::Window(format!("preparing {} panicked", p.method)))?;
        self.viewer = Some(viewer);
        eprintln!(
            "relight: view: {} {} in {:.1} s",
            p.method,
            p.job.done(),
            p.started.elapsed().as_secs_f64()
        );
        result
    }

    fn present(
        surface: &mut softbuffer::Surface<Rc<Window>, Rc<Window>>,
        (w, h): (u32, u32),
        draw: impl FnOnce(&mut [u32]),
    ) -> Result<(), ViewerError> {
        let (Some(nw), Some(nh)) = (NonZeroU32::new(w), NonZeroU32::new(h)) else {
            return Ok(());
        };
        surface
            .resize(nw, nh)
            .map_err(|e| ViewerError::Window(e.to_string()))?;
        let mut buffer = surface
            .buffer_mut()
            .map_err(|e| ViewerError::Window(e.to_string()))?;
        draw(&mut buffer);
        buffer
            .present()
            .map_err(|e| ViewerError::Window(e.to_string()))
    }

    /// The progress screen: the last frame (or black) under the panel.
    fn redraw_progress(&mut self) -> Result<(), ViewerError> {
        let (Some(p), Some(surface)) = (self.preparing.as_ref(), self.surface.as_mut()) else {
            return Ok(());
        };
        let status = PrepareStatus {
            title: p.job.title(&p.method),
            phase: self
                .progress
                .phase
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .clone(),
            done: self.progress.done.load(Ordering::Relaxed),
            total: self.progress.total.load(Ordering::Relaxed),
            elapsed_s: p.started.elapsed().as_secs(),
        };
        let (w, h) = (self.size.0 as usize, self.size.1 as usize);
        let last = self.last.as_ref();
        Self::present(surface, self.size, |buf| {
            match last {
                Some(f) if f.image.width == w && f.image.height == h => {
                    crate::state::to_display(&f.image, buf);
                }
                _ => buf.fill(0),
            }
            draw_progress(&mut Canvas::new(buf, w, h), &status);
        })?;
        if let Some(win) = &self.window {
            win.set_title(&format!("relight — {}", status.title));
        }
        Ok(())
    }

    fn redraw(&mut self) -> Result<(), ViewerError> {
        self.poll_preparing()?;
        if self.preparing.is_some() {
            return self.redraw_progress();
        }
        if self.viewer.as_ref().is_some_and(|v| !v.is_prepared()) {
            self.start_preparing(Job::Prepare);
            return self.redraw_progress();
        }
        // A lighting change that bakes again (held back while the drag
        // lasted) bakes here, off the event loop, at the release.
        if self.drag.is_none() && self.viewer.as_mut().is_some_and(Viewer::lighting_bake_due) {
            self.start_preparing(Job::Lighting);
            return self.redraw_progress();
        }
        let (Some(window), Some(surface), Some(viewer)) = (
            self.window.as_ref(),
            self.surface.as_mut(),
            self.viewer.as_mut(),
        ) else {
            return Ok(());
        };
        let t = Instant::now();
        let (w, h) = self.size;
        if w == 0 || h == 0 {
            return Ok(());
        }
        // The clock moves by the wall time since the last frame it moved in.
        if viewer.clock_runs() {
            if let Some(k) = self.tick {
                viewer.advance(t.duration_since(k).as_secs_f32());
            }
            self.tick = Some(t);
        } else {
            self.tick = None;
        }
        let frame = viewer.frame(w as usize, h as usize, self.drag.is_some(), &NoProgress)?;
        let error = self.meter.observe(viewer, &frame);
        // The fps of the last whole redraw (this frame's work on the first).
        let redraw_ms = if self.redraw_ms > 0.0 {
            self.redraw_ms
        } else {
            frame.ms
        };
        let info = HudInfo::new(viewer, &frame, error, redraw_ms);
        let show_hud = self.show_hud;
        Self::present(surface, self.size, |buf| {
            crate::state::to_display(&frame.image, buf);
            if show_hud {
                draw_hud(&mut Canvas::new(buf, w as usize, h as usize), &info);
            }
        })?;
        self.redraw_ms = t.elapsed().as_secs_f64() * 1e3;
        window.set_title(&format!(
            "relight — {} — {:.1} ms",
            viewer.method().name(),
            frame.ms
        ));
        let refining = viewer.refining();
        self.last = Some(frame);
        // The reference keeps adding samples while the view is still; a
        // playing animation draws its next frame.
        if (self.drag.is_none() && refining) || self.tick.is_some() {
            window.request_redraw();
        }
        Ok(())
    }

    /// Whether the left drag and the wheel edit the area light now: light
    /// mode or Shift held, with an area light in the scene.
    fn editing_light(&self) -> bool {
        self.viewer
            .as_ref()
            .is_some_and(|v| v.has_area_light() && (v.light_mode || self.modifiers.shift_key()))
    }

    fn request_redraw(&self) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) -> Result<(), ViewerError> {
        match key {
            Key::Named(NamedKey::Escape) => self.quit(event_loop),
            Key::Named(NamedKey::Tab) => {
                let Some(viewer) = self.viewer.as_mut() else {
                    return Ok(());
                };
                if !viewer.edit_next_light() {
                    return Ok(());
                }
            }
            Key::Character(c) => {
                if c.as_str() == "q" {
                    self.quit(event_loop);
                    return Ok(());
                }
                // Input other than quitting waits for a preparation to end.
                let Some(viewer) = self.viewer.as_mut() else {
                    return Ok(());
                };
                match c.as_str() {
                    "1" | "2" | "3" | "4" | "5" | "6" | "7" | "8" | "9" => {
                        let i: usize = c.parse().unwrap_or(1);
                        viewer.select(i - 1);
                    }
                    "a" => viewer.antialias = !viewer.antialias,
                    "p" => {
                        viewer.toggle_play();
                        self.tick = None;
                    }
                    "n" => {
                        if !viewer.cycle_normal_filter() {
                            return Ok(());
                        }
                    }
                    "l" => {
                        if !viewer.has_area_light() {
                            return Ok(());
                        }
                        viewer.light_mode = !viewer.light_mode;
                    }
                    "t" => {
                        if !viewer.cycle_light_texture() {
                            return Ok(());
                        }
                    }
                    "h" => self.show_hud = !self.show_hud,
                    "r" => viewer.reset(),
                    "s" => {
                        if let Some(f) = &self.last {
                            let (n, stem) =
                                crate::state::free_shot_stem(Path::new("."), self.shots);
                            self.shots = n;
                            // A shot that cannot be written is said, not fatal.
                            match Viewer::save(f, &stem) {
                                Ok(()) => {
                                    eprintln!("relight view: wrote {}.png and .exr", stem.display())
                                }
                                Err(e) => eprintln!("relight view: screenshot not saved: {e}"),
                            }
                        }
                        return Ok(());
                    }
                    _ => return Ok(()),
                }
            }
            _ => return Ok(()),
        }
        self.request_redraw();
        Ok(())
    }
}

impl ApplicationHandler for App<'_, '_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attrs = Window::default_attributes()
            .with_title("relight")
            .with_inner_size(PhysicalSize::new(self.size.0, self.size.1));
        let made = event_loop
            .create_window(attrs)
            .map_err(|e| ViewerError::Window(e.to_string()))
            .and_then(|w| {
                let w = Rc::new(w);
                let ctx = softbuffer::Context::new(w.clone())
                    .map_err(|e| ViewerError::Window(e.to_string()))?;
                let s = softbuffer::Surface::new(&ctx, w.clone())
                    .map_err(|e| ViewerError::Window(e.to_string()))?;
                Ok((w, s))
            });
        match made {
            Ok((w, s)) => {
                w.request_redraw();
                self.window = Some(w);
                self.surface = Some(s);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let result = match event {
            WindowEvent::CloseRequested => {
                self.quit(event_loop);
                Ok(())
            }
            WindowEvent::Resized(s) => {
                self.size = (s.width, s.height);
                self.request_redraw();
                Ok(())
            }
            WindowEvent::RedrawRequested => self.redraw(),
            WindowEvent::MouseInput { state, button, .. } => {
                self.drag = (state == ElementState::Pressed).then_some(button);
                // A release redraws at full quality.
                self.request_redraw();
                Ok(())
            }
            WindowEvent::ModifiersChanged(m) => {
                self.modifiers = m.state();
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                let editing = self.editing_light();
                let (w, h) = (self.size.0 as usize, self.size.1 as usize);
                if let (Some(b), Some(last), Some(viewer)) =
                    (self.drag, self.cursor, self.viewer.as_mut())
                {
                    let (dx, dy) = (
                        (position.x - last.x) as f32 * DEG_PER_PIXEL,
                        (position.y - last.y) as f32 * DEG_PER_PIXEL,
                    );
                    match b {
                        MouseButton::Left if editing => {
                            let px = |p: PhysicalPosition<f64>| (p.x as f32, p.y as f32);
                            viewer.drag_light(px(last), px(position), w, h);
                        }
                        MouseButton::Left => viewer.orbit.rotate(-dx, dy),
                        MouseButton::Right => {
                            viewer.light_yaw_deg += dx;
                            viewer.light_pitch_deg += dy;
                        }
                        _ => {}
                    }
                    self.request_redraw();
                }
                self.cursor = Some(position);
                Ok(())
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                let editing = self.editing_light();
                if let Some(viewer) = self.viewer.as_mut() {
                    if editing {
                        viewer.scale_light(steps);
                    } else {
                        let min = 0.05 * viewer.home_distance();
                        viewer.orbit.zoom(steps, min);
                    }
                    self.request_redraw();
                }
                Ok(())
            }
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(event_loop, &event.logical_key)
            }
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.fail(event_loop, e);
        }
    }

    /// While a method prepares, wake up to redraw its progress.
    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.preparing.is_some() {
            self.request_redraw();
            event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + PROGRESS_PERIOD));
        } else {
            event_loop.set_control_flow(ControlFlow::Wait);
        }
    }
}
