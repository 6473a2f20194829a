//! The window: winit events drive a [`Viewer`]; frames are tone-mapped into
//! a softbuffer surface (CPU pixels, no GPU needed).
//!
//! Controls: left drag orbits the camera, right drag turns the lighting,
//! the wheel zooms; `1`–`4` switch to wavelet / sh / fog / reference (which
//! refines while the view is still), `a` toggles
//! antialiasing, `r` resets, `s` saves the frame as PNG + EXR, `Esc`/`q`
//! quits. While a button is held frames skip antialiasing (preview); the
//! title shows the method and the frame time.

use crate::state::{Frame, Viewer, ViewerError};
use relight_render::NoProgress;
use std::num::NonZeroU32;
use std::path::PathBuf;
use std::rc::Rc;
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// Degrees of turn per pixel of mouse drag.
const DEG_PER_PIXEL: f32 = 0.3;

struct App {
    viewer: Viewer,
    size: (u32, u32),
    window: Option<Rc<Window>>,
    surface: Option<softbuffer::Surface<Rc<Window>, Rc<Window>>>,
    drag: Option<MouseButton>,
    cursor: Option<PhysicalPosition<f64>>,
    last: Option<Frame>,
    shots: usize,
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

/// # Errors
/// No display (e.g. no `DISPLAY`/`WAYLAND_DISPLAY`), or a method's error.
pub fn run(viewer: Viewer, width: u32, height: u32) -> Result<(), ViewerError> {
    let event_loop = EventLoop::new().map_err(|e| {
        ViewerError::Window(format!(
            "cannot open a window (needs DISPLAY or WAYLAND_DISPLAY; `relight render` works without one): {e}"
        ))
    })?;
    event_loop.set_control_flow(ControlFlow::Wait);
    let mut app = App {
        viewer,
        size: (width.max(1), height.max(1)),
        window: None,
        surface: None,
        drag: None,
        cursor: None,
        last: None,
        shots: 0,
        error: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewerError::Window(e.to_string()))?;
    app.error.map_or(Ok(()), Err)
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewerError) {
        self.error = Some(e);
        event_loop.exit();
    }

    fn redraw(&mut self) -> Result<(), ViewerError> {
        let (Some(window), Some(surface)) = (self.window.as_ref(), self.surface.as_mut()) else {
            return Ok(());
        };
        let (w, h) = self.size;
        let (Some(nw), Some(nh)) = (NonZeroU32::new(w), NonZeroU32::new(h)) else {
            return Ok(());
        };
        let frame = self
            .viewer
            .frame(w as usize, h as usize, self.drag.is_some(), &NoProgress)?;
        surface
            .resize(nw, nh)
            .map_err(|e| ViewerError::Window(e.to_string()))?;
        let mut buffer = surface
            .buffer_mut()
            .map_err(|e| ViewerError::Window(e.to_string()))?;
        crate::state::to_display(&frame.image, &mut buffer);
        buffer
            .present()
            .map_err(|e| ViewerError::Window(e.to_string()))?;
        let quality = if frame.spp > 0 {
            format!(" ({} spp)", frame.spp)
        } else if frame.aa > 1 {
            format!(" ({}×{} AA)", frame.aa, frame.aa)
        } else {
            String::new()
        };
        let note = frame
            .message
            .as_deref()
            .map_or(String::new(), |m| format!(" — {m}"));
        window.set_title(&format!(
            "relight — {} — {:.1} ms{quality}{note} — drag: orbit, right drag: light, 1-{}: method, a: AA, s: save",
            self.viewer.method().name(),
            frame.ms,
            self.viewer.methods().len(),
        ));
        self.last = Some(frame);
        // The reference keeps adding samples while the view is still.
        if self.drag.is_none() && self.viewer.refining() {
            window.request_redraw();
        }
        Ok(())
    }

    fn request_redraw(&self) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) -> Result<(), ViewerError> {
        match key {
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Character(c) => match c.as_str() {
                "q" => event_loop.exit(),
                "1" | "2" | "3" | "4" | "5" | "6" | "7" | "8" | "9" => {
                    let i: usize = c.parse().unwrap_or(1);
                    self.viewer.select(i - 1);
                }
                "a" => self.viewer.antialias = !self.viewer.antialias,
                "r" => self.viewer.reset(),
                "s" => {
                    if let Some(f) = &self.last {
                        self.shots += 1;
                        let stem = PathBuf::from(format!("relight-view-{}", self.shots));
                        Viewer::save(f, &stem)?;
                        eprintln!("relight view: wrote {}.png and .exr", stem.display());
                    }
                    return Ok(());
                }
                _ => return Ok(()),
            },
            _ => return Ok(()),
        }
        self.request_redraw();
        Ok(())
    }
}

impl ApplicationHandler for App {
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
                event_loop.exit();
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
            WindowEvent::CursorMoved { position, .. } => {
                if let (Some(b), Some(last)) = (self.drag, self.cursor) {
                    let (dx, dy) = (
                        (position.x - last.x) as f32 * DEG_PER_PIXEL,
                        (position.y - last.y) as f32 * DEG_PER_PIXEL,
                    );
                    match b {
                        MouseButton::Left => self.viewer.orbit.rotate(-dx, dy),
                        MouseButton::Right => {
                            self.viewer.light_yaw_deg += dx;
                            self.viewer.light_pitch_deg += dy;
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
                let min = 0.05 * self.viewer.home_distance();
                self.viewer.orbit.zoom(steps, min);
                self.request_redraw();
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
}
