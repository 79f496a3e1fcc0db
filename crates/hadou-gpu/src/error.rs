//! GPU errors with messages a person can act on.

use ash::vk;

/// Why a GPU operation failed; each message says what to install or change where it can.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// The Vulkan loader library could not be loaded (the loader's error text).
    #[error(
        "the Vulkan loader (libvulkan.so.1) could not be loaded: {0}. \
         Install it with `apt-get install libvulkan1` (plus a driver, e.g. mesa-vulkan-drivers for software rendering)"
    )]
    NoLoader(String),
    /// The loader found no Vulkan driver (`VK_ERROR_INCOMPATIBLE_DRIVER`).
    #[error(
        "no Vulkan driver is installed (vkCreateInstance returned VK_ERROR_INCOMPATIBLE_DRIVER). \
         For software rendering on the CPU install Mesa's lavapipe: `apt-get install mesa-vulkan-drivers`; \
         check VK_DRIVER_FILES / VK_ICD_FILENAMES if they are set"
    )]
    NoDriver,
    /// Validation was asked for (`HADOU_VALIDATION`) but the Khronos layer is not installed.
    #[error(
        "validation was requested but the Khronos validation layer is not installed: \
         `apt-get install vulkan-validationlayers` (or unset HADOU_VALIDATION)"
    )]
    ValidationLayerMissing,
    /// No device (or loader) meets hadou's needs: Vulkan 1.3, its features, a graphics + compute
    /// queue with timestamps (and presenting, when asked), the name filter.
    #[error("no suitable Vulkan device{filter}:\n{}", list_devices(devices))]
    NoSuitableDevice {
        /// `" matching HADOU_DEVICE=…"` when a filter was given, else empty.
        filter: String,
        /// Each device considered and why it was refused: (label, reason).
        devices: Vec<(String, String)>,
    },
    /// A device lacks a feature hadou needs (or the game did not enable it, for `from_raw`).
    #[error("device {device} lacks required feature {feature}")]
    MissingFeature {
        /// The device's name.
        device: String,
        /// The feature missing.
        feature: &'static str,
    },
    /// `VK_ERROR_DEVICE_LOST`: the driver reset or crashed.
    #[error(
        "the GPU device was lost (the last pass recorded was `{last_pass}`); the driver reset or crashed"
    )]
    DeviceLost {
        /// The last pass recorded before the loss, or the call that reported it.
        last_pass: String,
    },
    /// `VK_ERROR_OUT_OF_DEVICE_MEMORY`.
    #[error("out of device memory while allocating {what}")]
    OutOfDeviceMemory {
        /// The allocation or call that failed.
        what: String,
    },
    /// `VK_ERROR_OUT_OF_HOST_MEMORY`.
    #[error("out of host memory while allocating {what}")]
    OutOfHostMemory {
        /// The allocation or call that failed.
        what: String,
    },
    /// Any other failed Vulkan call.
    #[error("{call} failed: {result:?}")]
    Vk {
        /// The Vulkan function, e.g. `"vkCreateDevice"`.
        call: &'static str,
        /// What it returned.
        result: vk::Result,
    },
    /// A shader that could not be found, compiled, or matched to its pipeline layout.
    #[error("shader {name}: {message}")]
    Shader {
        /// The shader's name.
        name: String,
        /// The compiler's or the check's message.
        message: String,
    },
    /// A size or count past one of the device's limits (`VkPhysicalDeviceLimits`): make the
    /// scene (or what `what` names) smaller, or use a device with a larger limit.
    #[error("{what}: {message}")]
    DeviceLimit {
        /// What was being made, e.g. `"metaballs entries"`.
        what: String,
        /// The limit's Vulkan name, e.g. `"maxTexelBufferElements"`.
        limit: &'static str,
        /// How much was needed, in the limit's unit.
        needed: u64,
        /// The device's limit.
        max: u64,
        /// The explanation, with what to change.
        message: String,
    },
    /// An image of a size the device cannot create: a side of 0 or past `maxImageDimension2D`.
    #[error("{what}: size {width}x{height} outside 1..={max} (maxImageDimension2D)")]
    ImageSize {
        /// The image.
        what: String,
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
        /// The device's maxImageDimension2D.
        max: u32,
    },
    /// The GPU memory allocator failed other than by running out of memory (its message).
    #[error("{what}: {message}")]
    Allocator {
        /// The allocation (or `"the allocator"` when making it).
        what: String,
        /// The allocator's message.
        message: String,
    },
    /// No memory type of the device has the properties needed.
    #[error("{what}: no memory type with {properties:?}")]
    NoMemoryType {
        /// The allocation.
        what: String,
        /// The properties wanted.
        properties: vk::MemoryPropertyFlags,
    },
    /// A GPU object was asked for after its context was destroyed.
    #[error("{what}: the GPU context was destroyed")]
    ContextDestroyed {
        /// What was asked for.
        what: String,
    },
    /// `RawVulkan::queue_family` or `queue_index` (`GpuContext::from_raw`) names no queue hadou
    /// can record on (graphics + compute with timestamps).
    #[error("{field}: {message}")]
    RawQueue {
        /// `"queue_family"` or `"queue_index"`.
        field: &'static str,
        /// What the device has instead.
        message: String,
    },
    /// The window's surface offers nothing hadou can present with (a format, an image usage).
    #[error("{what}: {message}")]
    SurfaceUnsupported {
        /// `"swapchain format"`, `"swapchain image usage"`, `"pixel copy"`, or the window's handles
        /// and window system (`WindowOutput::open`).
        what: &'static str,
        /// What was wanted and what the surface offers.
        message: String,
    },
    /// `Presenter::acquire` called while the previous image was neither presented nor given back
    /// with `Presenter::abandon`: its fence was reset for a submission that never came, so waiting
    /// on it would never return.
    #[error("swapchain image {index} (frame slot {slot}): {message}")]
    FrameNotFinished {
        /// The image index of the unfinished frame.
        index: u32,
        /// Its frame-in-flight slot.
        slot: usize,
        /// What to call.
        message: String,
    },
    /// Pixels handed to the presenter's copy that are not one RGBA8 image of the acquired size.
    #[error("pixel copy: {bytes} bytes for a {width}x{height} RGBA8 image")]
    PixelCount {
        /// The bytes given.
        bytes: usize,
        /// The acquired image's width.
        width: u32,
        /// The acquired image's height.
        height: u32,
    },
    /// A thickness table could not be baked (the bake's reason), or the bake thread panicked.
    #[error("{what}: {message}")]
    Bake {
        /// The table.
        what: String,
        /// Why.
        message: String,
    },
    /// A write into a buffer that is not host-visible, or past its end (`memory::Buffer::write`).
    #[error("{buffer}: {message}")]
    BufferWrite {
        /// The buffer's name.
        buffer: String,
        /// What was written where, and the buffer's size.
        message: String,
    },
    /// A broken invariant inside hadou (a bug, not something the caller can change), e.g. a
    /// pass name its registry lacks.
    #[error("{what}: {message} (an internal error of hadou)")]
    Internal {
        /// Where.
        what: String,
        /// What went wrong.
        message: String,
    },
}

fn list_devices(devices: &[(String, String)]) -> String {
    if devices.is_empty() {
        return "  (the driver reported no devices)".into();
    }
    devices.iter().map(|(name, why)| format!("  - {name}: {why}")).collect::<Vec<_>>().join("\n")
}

/// `Result` with a `GpuError`.
pub type GpuResult<T> = Result<T, GpuError>;

/// Attaches the call name to a raw Vulkan result, mapping the results that have their own variant.
pub trait VkResultExt<T> {
    /// Maps the error to a `GpuError` naming `call`.
    fn vk(self, call: &'static str) -> GpuResult<T>;
}

impl<T> VkResultExt<T> for Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> GpuResult<T> {
        self.map_err(|result| match result {
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY => GpuError::OutOfDeviceMemory { what: call.into() },
            vk::Result::ERROR_OUT_OF_HOST_MEMORY => GpuError::OutOfHostMemory { what: call.into() },
            vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost { last_pass: format!("(during {call})") },
            result => GpuError::Vk { call, result },
        })
    }
}
