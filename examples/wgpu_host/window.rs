//! Window mode: a winit window and a wgpu surface; each frame wgpu draws the game into the
//! surface texture, hadou composites into the same texture, wgpu presents it. Keys as the game
//! prototype's (Space charges, release fires, A/D or ←/→ move, R resets, Esc quits).

use std::sync::Arc;

use winit::window::Window;

use super::app;
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

impl app::Running for Running {
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

    fn resized(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 {
            (self.config.width, self.config.height) = (width, height);
            self.surface.configure(&self.host.gpu.device, &self.config);
        }
    }

    fn frame(&mut self, _window: &Window, input: &Input, dt: f64) -> Result<(), String> {
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

    fn title(&mut self) -> String {
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

pub fn run() -> Result<(), String> {
    app::run::<Running>("hadou in a wgpu host")
}
