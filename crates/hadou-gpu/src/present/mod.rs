//! Presenting to a window: a Vulkan surface's swapchain, recreated when the window changes, and the
//! per-frame semaphores and fences around acquire and present. Generic over ash handles (it knows
//! nothing about hadou's passes), so a game that owns its device can use it as well as the viewer.
//!
//! A frame:
//! 1. [`Presenter::acquire`] waits until this frame-in-flight slot's previous submission finished,
//!    then acquires an image. `None` means "draw nothing this time": the window is minimized
//!    (0×0) or the swapchain was out of date and has been marked for recreation.
//! 2. The caller records commands that write [`Acquired::image`] (layout `UNDEFINED` on entry,
//!    `PRESENT_SRC_KHR` on exit) and submits them once, waiting on [`Acquired::wait`], signalling
//!    [`Acquired::signal`] and [`Acquired::fence`] — the fence is reset by `acquire`, so a
//!    submission with it must follow.
//! 3. [`Presenter::present`] queues the image. A frame whose recording or submission failed calls
//!    [`Presenter::abandon`] instead: it signals the fence and consumes the acquire semaphore with
//!    an empty submission, so the slot's next wait returns; `acquire` refuses (an error, not a
//!    wait that never returns) while the previous image was neither presented nor abandoned.
//!
//! A renderer that allows one frame in flight only (hadou's `Renderer` writes its per-frame data
//! on the host) sets `PresentConfig::frames_in_flight = 1`: `acquire` then waits for the previous
//! frame's fence, which is that renderer's contract.
//!
//! `VK_ERROR_OUT_OF_DATE_KHR` and `VK_SUBOPTIMAL_KHR` from either call, and
//! [`Presenter::window_resized`], make the next `acquire` recreate the swapchain (after a device
//! wait idle: resizes are rare, and it keeps the old images' ownership simple).
//!
//! On a window: `WindowOutput::open(Arc<window>, options, config)` makes the presenting context,
//! the presenter and the pixel copier in one safe call (window.rs; the viewer uses it). A game
//! that owns its device and surface makes its `Presenter` with `Presenter::new` on its handles.

mod copy;
mod swapchain;
mod window;

pub use copy::PixelCopier;
pub use swapchain::{choose_extent, Acquired, PresentConfig, Presenter};
pub use window::WindowOutput;
