//! The viewer's GPU side: a runtime whose device presents to the window, the swapchain, and the
//! copy of each rendered frame into it. The runtime renders and reads the tonemapped sRGB colour
//! back; `PixelCopier` copies it into the swapchain image as it is, so the swapchain format is a
//! `*_UNORM` one (an `*_SRGB` view would have the bytes encoded a second time by a shader write;
//! a copy keeps them either way).

use std::sync::Arc;

use anyhow::Context;
use hadou::gpu::validation::ValidationLog;
use hadou::gpu::{ContextOptions, GpuContext, PresentRequest};
use hadou::present::{PixelCopier, PresentConfig, Presenter};
use hadou::scene::camera::Camera;
use hadou::scene::Scene;
use hadou::{FrameRequest, FrameStats, Runtime};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::Window;

/// A frame that reached the window.
pub struct Presented {
    pub width: u32,
    pub height: u32,
    /// RGBA8, sRGB-encoded, row 0 at the top (what a screenshot writes).
    pub rgba: Vec<u8>,
    pub stats: FrameStats,
    /// CPU ms spent filling the staging buffer, submitting the copy and presenting.
    pub present_ms: f64,
}

pub struct ViewerGpu {
    presenter: Presenter,
    copier: PixelCopier,
    runtime: Runtime,
}

impl ViewerGpu {
    /// The window must outlive the returned value (the surface refers to it).
    pub fn new(window: &Window) -> anyhow::Result<Self> {
        let display = window.display_handle().context("window display handle")?.as_raw();
        let handle = window.window_handle().context("window handle")?.as_raw();
        let extensions = ash_window::enumerate_required_extensions(display)
            .context("no Vulkan surface extension for this window system")?;
        let create_surface = |entry: &ash::Entry, instance: &ash::Instance| {
            // SAFETY: the handles come from a live window that outlives the surface (see above).
            unsafe { ash_window::create_surface(entry, instance, display, handle, None) }
        };
        let request = PresentRequest { instance_extensions: extensions, create_surface: &create_surface };
        let (ctx, surface) = GpuContext::new_presenting(&ContextOptions::from_env(), &request)?;
        let config = PresentConfig::default();
        let frames = config.frames_in_flight;
        // SAFETY: the surface and device belong to ctx's instance; both are destroyed (Drop below)
        // before the runtime, which owns ctx, is dropped.
        let mut presenter = unsafe {
            Presenter::new(&ctx.entry, &ctx.instance, ctx.physical_device, &ctx.device, surface, config)
        }?;
        // SAFETY: as above, ctx's handles; `frames` is the presenter's frames in flight, and the
        // copier is destroyed (Drop below) before the runtime drops the device.
        let copier = match unsafe {
            PixelCopier::new(&ctx.instance, ctx.physical_device, &ctx.device, ctx.queue_family, frames)
        } {
            Ok(c) => c,
            Err(e) => {
                presenter.destroy();
                return Err(e.into());
            }
        };
        // On failure `with_context` has dropped the device already: the presenter and copier have
        // no Drop of their own, so their handles are simply abandoned with it.
        let runtime = Runtime::with_context(ctx)?;
        Ok(ViewerGpu { presenter, copier, runtime })
    }

    pub fn validation_log(&self) -> Arc<ValidationLog> {
        self.runtime.validation_log()
    }

    /// Loads `scene` (rebuilding its passes) and places the camera.
    pub fn load(&mut self, scene: &Scene, camera: Camera) -> Result<(), String> {
        self.runtime.load_scene(scene.clone()).map_err(|e| e.to_string())?;
        self.runtime.renderer().set_camera(camera).map_err(|e| e.to_string())
    }

    pub fn window_resized(&mut self) {
        self.presenter.window_resized();
    }

    /// Renders at the swapchain's size and presents. `None`: nothing to draw now (minimized, or the
    /// swapchain is being recreated).
    pub fn frame(
        &mut self,
        window: (u32, u32),
        camera: Camera,
        time: f64,
    ) -> anyhow::Result<Option<Presented>> {
        let Some(acquired) = self.presenter.acquire(window)? else { return Ok(None) };
        let (width, height) = (acquired.extent.width, acquired.extent.height);
        self.runtime.renderer().set_camera(camera)?;
        let mut request = FrameRequest::new(width, height);
        request.time = time;
        let frame = self.runtime.render(&request)?;
        let rgba = frame.color.context("the runtime returned no colour")?;
        let queue = self.runtime.context().queue;
        let start = std::time::Instant::now();
        self.copier.copy_and_submit(queue, &acquired, &rgba)?;
        self.presenter.present(queue, &acquired)?;
        let present_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(Some(Presented { width, height, rgba, stats: frame.stats, present_ms }))
    }
}

impl Drop for ViewerGpu {
    fn drop(&mut self) {
        // Before the runtime (declared after them) drops the device and instance.
        self.copier.destroy();
        self.presenter.destroy();
    }
}
