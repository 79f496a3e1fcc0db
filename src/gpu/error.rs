//! GPU errors with messages a person can act on.

use ash::vk;

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "the Vulkan loader (libvulkan.so.1) could not be loaded: {0}. \
         Install it with `apt-get install libvulkan1` (plus a driver, e.g. mesa-vulkan-drivers for software rendering)"
    )]
    NoLoader(String),
    #[error(
        "no Vulkan driver is installed (vkCreateInstance returned VK_ERROR_INCOMPATIBLE_DRIVER). \
         For software rendering on the CPU install Mesa's lavapipe: `apt-get install mesa-vulkan-drivers`; \
         check VK_DRIVER_FILES / VK_ICD_FILENAMES if they are set"
    )]
    NoDriver,
    #[error(
        "validation was requested but the Khronos validation layer is not installed: \
         `apt-get install vulkan-validationlayers` (or unset HADOU_VALIDATION)"
    )]
    ValidationLayerMissing,
    #[error("no suitable Vulkan device{filter}:\n{}", list_devices(devices))]
    NoSuitableDevice { filter: String, devices: Vec<(String, String)> },
    #[error("device {device} lacks required feature {feature}")]
    MissingFeature { device: String, feature: &'static str },
    #[error(
        "the GPU device was lost (the last pass recorded was `{last_pass}`); the driver reset or crashed"
    )]
    DeviceLost { last_pass: String },
    #[error("out of device memory while allocating {what}")]
    OutOfDeviceMemory { what: String },
    #[error("out of host memory while allocating {what}")]
    OutOfHostMemory { what: String },
    #[error("{call} failed: {result:?}")]
    Vk { call: &'static str, result: vk::Result },
    #[error("shader {name}: {message}")]
    Shader { name: String, message: String },
    #[error("{what}: {message}")]
    Limit { what: String, message: String },
}

fn list_devices(devices: &[(String, String)]) -> String {
    if devices.is_empty() {
        return "  (the driver reported no devices)".into();
    }
    devices.iter().map(|(name, why)| format!("  - {name}: {why}")).collect::<Vec<_>>().join("\n")
}

pub type GpuResult<T> = Result<T, GpuError>;

/// Attaches the call name to a raw Vulkan result, mapping the results that have their own variant.
pub trait VkResultExt<T> {
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
