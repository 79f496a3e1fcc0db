//! A small game that owns its Vulkan device and swapchain, rasterizes its own scene (floor,
//! player, pillars) into its own colour and depth, and embeds hadou for the energy wave, the
//! translucent target and the metaball slime. Keys (README): hold Space to charge the wave (a and
//! b grow, the beam extends), release to fire; A/D or ←/→ move the player; R resets; P drops a glTF
//! prop; V splits the screen (a second view from the side, one hadou frame of two views); Esc quits.
//! Per-pass GPU times (hadou's latest finished frame) are in the window title.
//!
//! `cargo run --release --example game_prototype` (HADOU_VALIDATION=1 turns validation on,
//! GAME_FRAMES=N quits after N frames, GAME_SPLIT=1 starts in split screen, GAME_BUDGET_MS=MS
//! gives hadou a frame budget).

mod game;
mod gpu;
mod painter;
mod slime_sim;

use std::cell::Cell;
use std::time::Instant;

use ash::vk;
use game::{ColorTarget, Game, Input};
use hadou::present::{PresentConfig, Presenter};
use raw_window_handle::{HasDisplayHandle, HasWindowHandle, RawDisplayHandle, RawWindowHandle};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

struct Running {
    game: Game,
    presenter: Presenter,
}

#[derive(Default)]
struct App {
    window: Option<Window>,
    running: Option<Running>,
    input: Input,
    last: Option<Instant>,
    title_at: Option<Instant>,
    failed: Option<String>,
    frames: u64,
    /// `GAME_FRAMES=N`: quit after N frames (smoke runs under Xvfb).
    frame_limit: Option<u64>,
}

fn handles(window: &Window) -> Result<(RawDisplayHandle, RawWindowHandle), String> {
    let display = window.display_handle().map_err(|e| e.to_string())?.as_raw();
    let handle = window.window_handle().map_err(|e| e.to_string())?.as_raw();
    Ok((display, handle))
}

/// The game's device, able to present to the window's surface, and a swapchain on it.
fn start(window: &Window) -> Result<Running, String> {
    let (display, handle) = handles(window)?;
    let extensions = ash_window::enumerate_required_extensions(display).map_err(|e| e.to_string())?;
    let surface = Cell::new(vk::SurfaceKHR::null());
    let can_present =
        |entry: &ash::Entry, instance: &ash::Instance, physical: vk::PhysicalDevice, family: u32| {
            if surface.get() == vk::SurfaceKHR::null() {
                // SAFETY: the window outlives the surface (the presenter destroys it first).
                match unsafe { ash_window::create_surface(entry, instance, display, handle, None) } {
                    Ok(s) => surface.set(s),
                    Err(_) => return false,
                }
            }
            let loader = ash::khr::surface::Instance::new(entry, instance);
            // SAFETY: plain query; `physical` and the surface come from this instance.
            unsafe { loader.get_physical_device_surface_support(physical, family, surface.get()) }
                .unwrap_or(false)
        };
    let validation = std::env::var("HADOU_VALIDATION").is_ok_and(|v| v == "1");
    let device_extensions = [ash::khr::swapchain::NAME.as_ptr()];
    let vk = gpu::GameVk::new(validation, extensions, &device_extensions, &can_present)?;
    let config = PresentConfig {
        // The game writes linear colour: an _SRGB swapchain encodes it.
        formats: vec![vk::Format::B8G8R8A8_SRGB, vk::Format::R8G8B8A8_SRGB],
        // Split screen copies its views' colours into the image.
        usage: vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_DST,
        // As many frames in flight as the game (and hadou) have slots.
        frames_in_flight: gpu::FRAMES_IN_FLIGHT,
        ..PresentConfig::default()
    };
    // SAFETY: handles from one instance; the surface presents from the chosen queue family;
    // Running::stop destroys the presenter before the device.
    let presenter =
        unsafe { Presenter::new(&vk.entry, &vk.instance, vk.physical, &vk.device, surface.get(), config) }
            .map_err(|e| e.to_string())?;
    let mut game = Game::new(vk)?;
    game.split = std::env::var("GAME_SPLIT").is_ok_and(|v| v == "1");
    Ok(Running { game, presenter })
}

impl Running {
    fn frame(&mut self, window: &Window, input: &Input, dt: f64) -> Result<(), String> {
        self.game.update(input, dt)?;
        let size = window.inner_size();
        let Some(acquired) = self.presenter.acquire((size.width, size.height)).map_err(|e| e.to_string())?
        else {
            return Ok(()); // minimized or out of date: nothing drawn this time
        };
        if let Err(e) = self.record_and_submit(&acquired) {
            // Nothing was submitted with the image's fence: give the image back, so the next
            // acquire does not wait on a fence nothing will signal.
            if let Err(back) = self.presenter.abandon(self.game.vk.queue, &acquired) {
                return Err(format!("{e} (and giving the swapchain image back failed: {back})"));
            }
            return Err(e);
        }
        self.presenter.present(self.game.vk.queue, &acquired).map_err(|e| e.to_string())
    }

    /// Records the frame into the acquired image and submits it (the last fallible step).
    fn record_and_submit(&mut self, acquired: &hadou::present::Acquired) -> Result<(), String> {
        // The presenter waited on this slot's fence: frame n − FRAMES_IN_FLIGHT has finished.
        self.game.vk.begin_waited_slot(acquired.slot)?;
        let target = ColorTarget {
            image: acquired.image,
            view: acquired.view,
            format: acquired.format,
            extent: acquired.extent,
            final_layout: vk::ImageLayout::PRESENT_SRC_KHR,
        };
        self.game.record(&target)?;
        let wait = (acquired.wait, vk::PipelineStageFlags2::ALL_COMMANDS);
        self.game.vk.submit(wait, acquired.signal, acquired.fence)
    }

    fn title(&mut self) -> String {
        let state = &self.game.state;
        let mut title =
            format!("hadou game prototype — charge {:.0}%, hits {}", 100.0 * state.charge, state.hits);
        if let Some(t) = self.game.hadou.latest_timings() {
            for p in &t.passes {
                title += &format!(" | {} {:.2} ms", p.name, p.gpu_ms);
            }
        }
        title
    }

    fn stop(mut self) {
        // SAFETY: the game's device is live until `self.game.destroy()` below.
        unsafe {
            let _ = self.game.vk.device.device_wait_idle();
        }
        self.presenter.destroy();
        let messages = self.game.destroy();
        let (errors, warnings) = messages.counts();
        eprintln!("validation: {errors} errors, {warnings} warnings");
        for text in messages.texts.lock().map(|t| t.clone()).unwrap_or_default() {
            eprintln!("  {text}");
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attributes = Window::default_attributes()
            .with_title("hadou game prototype")
            .with_inner_size(winit::dpi::LogicalSize::new(960.0, 540.0));
        let window = match event_loop.create_window(attributes) {
            Ok(w) => w,
            Err(e) => {
                self.failed = Some(format!("cannot open a window: {e}"));
                event_loop.exit();
                return;
            }
        };
        match start(&window) {
            Ok(r) => self.running = Some(r),
            Err(e) => {
                self.failed = Some(e);
                event_loop.exit();
            }
        }
        self.window = Some(window);
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(_) => {
                if let Some(r) = &mut self.running {
                    r.presenter.window_resized();
                }
            }
            WindowEvent::KeyboardInput {
                event: KeyEvent { physical_key: PhysicalKey::Code(code), state, .. },
                ..
            } => {
                let down = state == ElementState::Pressed;
                match code {
                    _ if self.input.key(code, down) => {}
                    KeyCode::KeyP if down => {
                        if let Some(r) = &mut self.running {
                            if let Err(e) = r.game.toggle_prop(std::path::Path::new(game::PROP)) {
                                eprintln!("prop: {e}");
                            }
                        }
                    }
                    KeyCode::KeyV if down => {
                        if let Some(r) = &mut self.running {
                            r.game.split = !r.game.split;
                        }
                    }
                    KeyCode::Escape => event_loop.exit(),
                    _ => {}
                }
            }
            WindowEvent::RedrawRequested => {
                let (Some(window), Some(running)) = (&self.window, &mut self.running) else { return };
                let now = Instant::now();
                let dt = self.last.map(|l| (now - l).as_secs_f64()).unwrap_or(0.0).min(0.1);
                self.last = Some(now);
                if let Err(e) = running.frame(window, &self.input, dt) {
                    self.failed = Some(e);
                    event_loop.exit();
                    return;
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

fn main() {
    let event_loop = match EventLoop::new() {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: no window system: {e}");
            std::process::exit(1);
        }
    };
    let frame_limit = std::env::var("GAME_FRAMES").ok().and_then(|n| n.parse().ok());
    let mut app = App { frame_limit, ..App::default() };
    let result = event_loop.run_app(&mut app);
    if let Some(r) = app.running.take() {
        r.stop();
    }
    if let Some(e) = app.failed.or(result.err().map(|e| e.to_string())) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
