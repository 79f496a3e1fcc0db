//! The viewer's GPU side: a runtime whose device presents to the window, the swapchain, and the
//! copy of each rendered frame into it. The runtime renders and reads the tonemapped sRGB colour
//! back; `PixelCopier` copies it into the swapchain image as it is, so the swapchain format is a
//! `*_UNORM` one (an `*_SRGB` view would have the bytes encoded a second time by a shader write;
//! a copy keeps them either way).

use std::sync::Arc;

use anyhow::Context;
use hadou::gpu::present::{PresentConfig, WindowOutput};
use hadou::gpu::validation::ValidationLog;
use hadou::gpu::ContextOptions;
use hadou::scene::camera::Camera;
use hadou::scene::Scene;
use hadou::{FrameRequest, FrameStats, Runtime};
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
    output: WindowOutput<Window>,
    runtime: Runtime,
}

impl ViewerGpu {
    /// A device presenting to `window` (held as long as its surface).
    pub fn new(window: Arc<Window>) -> anyhow::Result<Self> {
        let (ctx, output) = WindowOutput::open(window, &ContextOptions::from_env(), PresentConfig::default())
            .context("opening the window's Vulkan surface")?;
        // On failure `with_context` has dropped the device already: the presenter and copier have
        // no Drop of their own, so their handles are simply abandoned with it.
        let runtime = Runtime::with_context(ctx)?;
        Ok(ViewerGpu { output, runtime })
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
        self.output.presenter.window_resized();
    }

    /// Renders at the swapchain's size and presents. `None`: nothing to draw now (minimized, or the
    /// swapchain is being recreated).
    pub fn frame(
        &mut self,
        window: (u32, u32),
        camera: Camera,
        time: f64,
    ) -> anyhow::Result<Option<Presented>> {
        let Some(acquired) = self.output.presenter.acquire(window)? else { return Ok(None) };
        let queue = self.runtime.context().queue;
        match self.render_and_copy(&acquired, camera, time) {
            Ok((rgba, stats, start)) => {
                self.output.presenter.present(queue, &acquired)?;
                let present_ms = start.elapsed().as_secs_f64() * 1e3;
                let (width, height) = (acquired.extent.width, acquired.extent.height);
                Ok(Some(Presented { width, height, rgba, stats, present_ms }))
            }
            Err(e) => {
                // Nothing was submitted with the image's fence: give the image back so the next
                // acquire (or the device's teardown) does not wait on a fence nothing signals.
                if let Err(back) = self.output.presenter.abandon(queue, &acquired) {
                    log::warn!("giving back the swapchain image after a failed frame: {back}");
                }
                Err(e)
            }
        }
    }

    /// Renders at the acquired image's size and copies the colour into it (one submission, the
    /// last fallible step, signals the image's fence); the instant is when the copy began.
    fn render_and_copy(
        &mut self,
        acquired: &hadou::gpu::present::Acquired,
        camera: Camera,
        time: f64,
    ) -> anyhow::Result<(Vec<u8>, FrameStats, std::time::Instant)> {
        self.runtime.renderer().set_camera(camera)?;
        let mut request = FrameRequest::new(acquired.extent.width, acquired.extent.height);
        request.time = time;
        let frame = self.runtime.render(&request)?;
        let rgba = frame.color.context("the runtime returned no colour")?;
        let queue = self.runtime.context().queue;
        let start = std::time::Instant::now();
        self.output.copier.copy_and_submit(queue, acquired, &rgba)?;
        Ok((rgba, frame.stats, start))
    }
}

impl Drop for ViewerGpu {
    fn drop(&mut self) {
        // Before the runtime (declared after them) drops the device and instance.
        self.output.destroy();
    }
}
