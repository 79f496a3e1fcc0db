//! The only code that calls ash: context, memory, pipelines, shaders, barriers, timestamps, recording.

pub mod barriers;
pub mod commands;
pub mod context;
pub mod error;
pub mod fullscreen;
pub mod memory;
pub mod pipeline;
pub mod pipeline_cache;
pub mod recorder;
pub(crate) mod reflect;
pub(crate) mod resources;
pub mod ring;
pub mod shader;
pub mod texel_buffer;
pub mod timestamps;
pub mod upload;
pub mod validation;

pub use ash::vk;
pub use context::{ContextOptions, DeviceInfo, EnabledFeatures, GpuContext, PresentRequest, RawVulkan};
pub use error::{GpuError, GpuResult};
pub use resources::HostWaits;
pub use validation::ValidationCounts;
