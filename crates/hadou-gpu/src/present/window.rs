//! A presenting context for a window in one safe call: the instance with the window system's
//! surface extensions, the surface, a device that presents to it, the presenter and the pixel
//! copier made on that context's own handles. The window is held (an `Arc`) as long as the
//! surface, so no caller promise is left but one: `destroy` before the context is dropped.

use std::sync::Arc;

use raw_window_handle::{HasDisplayHandle, HasWindowHandle};

use super::{PixelCopier, PresentConfig, Presenter};
use crate::context::{ContextOptions, GpuContext, PresentRequest};
use crate::error::{GpuError, GpuResult};

/// A window's presenter and pixel copier, on the context `open` returned with them.
pub struct WindowOutput<W> {
    /// The swapchain of the window's surface.
    pub presenter: Presenter,
    /// Copies RGBA8 pixels into the swapchain images.
    pub copier: PixelCopier,
    /// Kept alive while the surface exists.
    _window: Arc<W>,
}

impl<W: HasDisplayHandle + HasWindowHandle> WindowOutput<W> {
    /// A context presenting to `window` (chosen as `GpuContext::new` does, among devices that can
    /// present to it), with its presenter and copier. Call `destroy` before dropping the context.
    pub fn open(
        window: Arc<W>,
        options: &ContextOptions,
        config: PresentConfig,
    ) -> GpuResult<(GpuContext, Self)> {
        let unsupported = |what: &'static str, e: &dyn std::fmt::Display| GpuError::SurfaceUnsupported {
            what,
            message: e.to_string(),
        };
        let display =
            window.display_handle().map_err(|e| unsupported("the window's display handle", &e))?.as_raw();
        let handle = window.window_handle().map_err(|e| unsupported("the window handle", &e))?.as_raw();
        let extensions = ash_window::enumerate_required_extensions(display)
            .map_err(|e| unsupported("window system", &format!("no Vulkan surface extension for it: {e}")))?;
        let create_surface = |entry: &ash::Entry, instance: &ash::Instance| {
            // SAFETY: the handles come from `window`, which the returned value holds (an Arc) for
            // as long as the surface exists (destroyed by `destroy`).
            unsafe { ash_window::create_surface(entry, instance, display, handle, None) }
        };
        let request = PresentRequest { instance_extensions: extensions, create_surface: &create_surface };
        let (ctx, surface) = GpuContext::new_presenting(options, &request)?;
        let frames = config.frames_in_flight;
        // SAFETY: surface, device and instance are ctx's own and related (ctx chose a device that
        // presents to the surface); the caller destroys the presenter before dropping ctx.
        let mut presenter = unsafe {
            Presenter::new(&ctx.entry, &ctx.instance, ctx.physical_device, &ctx.device, surface, config)
        }?;
        // SAFETY: as above, ctx's handles; `frames` is the presenter's frames in flight.
        let copier = match unsafe {
            PixelCopier::new(&ctx.instance, ctx.physical_device, &ctx.device, ctx.queue_family, frames)
        } {
            Ok(c) => c,
            Err(e) => {
                presenter.destroy();
                return Err(e);
            }
        };
        Ok((ctx, WindowOutput { presenter, copier, _window: window }))
    }

    /// Destroys the copier, the swapchain and the surface (before the context is dropped).
    pub fn destroy(&mut self) {
        self.copier.destroy();
        self.presenter.destroy();
    }
}
