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

mod app;
mod game;
mod gpu;
mod painter;
mod slime_sim;

use std::cell::Cell;
use std::sync::Arc;

use ash::vk;
use game::{ColorTarget, Game, Input};
use hadou::present::{PresentConfig, Presenter};
use raw_window_handle::{HasDisplayHandle, HasWindowHandle, RawDisplayHandle, RawWindowHandle};
use winit::keyboard::KeyCode;
use winit::window::Window;

struct Running {
    game: Game,
    presenter: Presenter,
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

impl app::Running for Running {
    fn start(window: Arc<Window>) -> Result<Running, String> {
        start(&window)
    }

    fn resized(&mut self, _width: u32, _height: u32) {
        self.presenter.window_resized();
    }

    fn key(&mut self, code: KeyCode) {
        match code {
            KeyCode::KeyP => {
                if let Err(e) = self.game.toggle_prop(std::path::Path::new(game::PROP)) {
                    eprintln!("prop: {e}");
                }
            }
            KeyCode::KeyV => self.game.split = !self.game.split,
            _ => {}
        }
    }

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

impl Running {
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
}

fn main() {
    if let Err(e) = app::run::<Running>("hadou game prototype") {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
