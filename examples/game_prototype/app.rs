//! The window loop both windowed hosts share (the ash prototype and the wgpu host): a winit
//! window, the game's keys, frame pacing by `dt`, the title every half second and `GAME_FRAMES`.
//! What differs — the device, the surface, how a frame is drawn — is the host's [`Running`].

use std::sync::Arc;
use std::time::Instant;

use winit::application::ApplicationHandler;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use super::game::Input;

/// A host running in a window.
pub trait Running: Sized {
    /// Its device and surface for `window`.
    fn start(window: Arc<Window>) -> Result<Self, String>;
    /// The window's new inner size.
    fn resized(&mut self, width: u32, height: u32);
    /// A key pressed that the game's movement does not use (Esc is the loop's).
    fn key(&mut self, _code: KeyCode) {}
    /// Updates the world by `dt` seconds and draws a frame.
    fn frame(&mut self, window: &Window, input: &Input, dt: f64) -> Result<(), String>;
    /// The window title (timings).
    fn title(&mut self) -> String;
    /// Tears the host down, reporting what validation counted.
    fn stop(self);
}

struct App<R> {
    title: &'static str,
    window: Option<Arc<Window>>,
    running: Option<R>,
    input: Input,
    last: Option<Instant>,
    title_at: Option<Instant>,
    failed: Option<String>,
    frames: u64,
    /// `GAME_FRAMES=N`: quit after N frames (smoke runs under Xvfb).
    frame_limit: Option<u64>,
}

impl<R: Running> App<R> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, why: String) {
        self.failed = Some(why);
        event_loop.exit();
    }
}

impl<R: Running> ApplicationHandler for App<R> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attributes = Window::default_attributes()
            .with_title(self.title)
            .with_inner_size(winit::dpi::LogicalSize::new(960.0, 540.0));
        let window = match event_loop.create_window(attributes) {
            Ok(w) => Arc::new(w),
            Err(e) => return self.fail(event_loop, format!("cannot open a window: {e}")),
        };
        match R::start(window.clone()) {
            Ok(r) => self.running = Some(r),
            Err(e) => self.fail(event_loop, e),
        }
        self.window = Some(window);
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(r) = &mut self.running {
                    r.resized(size.width, size.height);
                }
            }
            WindowEvent::KeyboardInput {
                event: KeyEvent { physical_key: PhysicalKey::Code(code), state, .. },
                ..
            } => {
                let down = state == ElementState::Pressed;
                match code {
                    _ if self.input.key(code, down) => {}
                    KeyCode::Escape => event_loop.exit(),
                    _ if down => {
                        if let Some(r) = &mut self.running {
                            r.key(code);
                        }
                    }
                    _ => {}
                }
            }
            WindowEvent::RedrawRequested => {
                let (Some(window), Some(running)) = (&self.window, &mut self.running) else { return };
                let now = Instant::now();
                let dt = self.last.map(|l| (now - l).as_secs_f64()).unwrap_or(0.0).min(0.1);
                self.last = Some(now);
                if let Err(e) = running.frame(window, &self.input, dt) {
                    return self.fail(event_loop, e);
                }
                self.frames += 1;
                if self.frame_limit.is_some_and(|n| self.frames >= n) {
                    event_loop.exit();
                }
                if self.title_at.is_none_or(|t| now.duration_since(t).as_secs_f64() > 0.5) {
                    window.set_title(&running.title());
                    self.title_at = Some(now);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }
}

/// Runs host `R` in a window titled `title` until it is closed, Esc, an error or `GAME_FRAMES`.
pub fn run<R: Running>(title: &'static str) -> Result<(), String> {
    let event_loop = EventLoop::new().map_err(|e| format!("no window system: {e}"))?;
    let frame_limit = std::env::var("GAME_FRAMES").ok().and_then(|n| n.parse().ok());
    let mut app = App::<R> {
        title,
        window: None,
        running: None,
        input: Input::default(),
        last: None,
        title_at: None,
        failed: None,
        frames: 0,
        frame_limit,
    };
    let result = event_loop.run_app(&mut app);
    if let Some(r) = app.running.take() {
        r.stop();
    }
    match app.failed.or(result.err().map(|e| e.to_string())) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
