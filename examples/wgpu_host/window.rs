//! Window mode: a winit window and a wgpu surface; each frame wgpu draws the game into the
//! surface texture, hadou composites into the same texture, wgpu presents it. Keys as the game
//! prototype's (Space charges, release fires, A/D or ←/→ move, R resets, Esc quits).

use std::sync::Arc;
use std::time::Instant;

use winit::application::ApplicationHandler;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use super::device::WgpuVulkan;
use super::game::Input;
use super::gpu::FRAMES_IN_FLIGHT;
use super::host::WgpuHost;

struct Running {
    /// Dropped before the host's device and instance (`stop`).
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    host: WgpuHost,
}

impl Running {
    fn start(window: Arc<Window>) -> Result<Running, String> {
        let validation = std::env::var("HADOU_VALIDATION").is_ok_and(|v| v == "1");
        let gpu = WgpuVulkan::new(validation)?;
        let surface = gpu.instance.create_surface(window.clone()).map_err(|e| e.to_string())?;
        let caps = surface.get_capabilities(&gpu.adapter);
        // hadou writes tonemapped linear colour into an _SRGB target (the hardware encodes).
        let format = caps.formats.iter().copied().find(|f| f.is_srgb()).ok_or("no sRGB surface format")?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::Fifo,
            desired_maximum_frame_latency: FRAMES_IN_FLIGHT as u32,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![],
        };
        surface.configure(&gpu.device, &config);
        let host = WgpuHost::new(gpu, FRAMES_IN_FLIGHT)?;
        Ok(Running { surface, config, host })
    }

    fn resize(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 {
            (self.config.width, self.config.height) = (width, height);
            self.surface.configure(&self.host.gpu.device, &self.config);
        }
    }

    fn frame(&mut self, input: &Input, dt: f64) -> Result<(), String> {
        self.host.update(input, dt)?;
        let frame = match self.surface.get_current_texture() {
            Ok(f) => f,
            // Out of date or lost: configure again and skip this frame.
            Err(wgpu::SurfaceError::Outdated | wgpu::SurfaceError::Lost) => {
                self.surface.configure(&self.host.gpu.device, &self.config);
                return Ok(());
            }
            Err(e) => return Err(e.to_string()),
        };
        let view = frame.texture.create_view(&Default::default());
        let mut encoder = self.host.begin_frame()?;
        self.host.record_game(&mut encoder, &frame.texture, &view)?;
        let recorded = self.host.record_hadou(&mut encoder, &frame.texture, &view)?;
        self.host.submit(encoder, recorded);
        frame.present();
        Ok(())
    }

    fn title(&self) -> String {
        let passes = self.host.world.as_ref().and_then(|w| w.hadou.latest_timings()).map(|t| {
            let total: f64 = t.passes.iter().map(|p| p.gpu_ms).sum();
            format!("hadou {total:.2} ms GPU")
        });
        format!("hadou in a wgpu host — {}", passes.unwrap_or_default())
    }

    fn stop(self) {
        let Running { surface, host, .. } = self;
        drop(surface);
        let messages = host.destroy();
        let (errors, warnings) = messages.counts();
        println!("validation: {errors} errors, {warnings} warnings");
        if errors + warnings > 0 {
            eprintln!("{:?}", messages.texts.lock().map(|t| t.clone()).unwrap_or_default());
        }
    }
}

#[derive(Default)]
struct App {
    window: Option<Arc<Window>>,
    running: Option<Running>,
    input: Input,
    last: Option<Instant>,
    title_at: Option<Instant>,
    failed: Option<String>,
    frames: u64,
    /// `GAME_FRAMES=N`: quit after N frames (smoke runs under Xvfb).
    frame_limit: Option<u64>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attributes = Window::default_attributes()
            .with_title("hadou in a wgpu host")
            .with_inner_size(winit::dpi::LogicalSize::new(960.0, 540.0));
        let window = match event_loop.create_window(attributes) {
            Ok(w) => Arc::new(w),
            Err(e) => {
                self.failed = Some(format!("cannot open a window: {e}"));
                event_loop.exit();
                return;
            }
        };
        match Running::start(window.clone()) {
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
            WindowEvent::Resized(size) => {
                if let Some(r) = &mut self.running {
                    r.resize(size.width, size.height);
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
                    _ => {}
                }
            }
            WindowEvent::RedrawRequested => {
                let (Some(window), Some(running)) = (&self.window, &mut self.running) else { return };
                let now = Instant::now();
                let dt = self.last.map(|l| (now - l).as_secs_f64()).unwrap_or(0.0).min(0.1);
                self.last = Some(now);
                if let Err(e) = running.frame(&self.input, dt) {
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

pub fn run() -> Result<(), String> {
    let event_loop = EventLoop::new().map_err(|e| format!("no window system: {e}"))?;
    let frame_limit = std::env::var("GAME_FRAMES").ok().and_then(|n| n.parse().ok());
    let mut app = App { frame_limit, ..App::default() };
    let result = event_loop.run_app(&mut app);
    if let Some(r) = app.running.take() {
        r.stop();
    }
    match app.failed.or(result.err().map(|e| e.to_string())) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
