//! The only code that calls ash: context, memory, pipelines, shaders, barriers, timestamps, recording.

#[doc(hidden)]
pub mod barriers;
#[doc(hidden)]
pub mod commands;
pub mod context;
pub mod error;
#[doc(hidden)]
pub mod fullscreen;
pub(crate) mod layout;
#[doc(hidden)]
pub mod memory;
#[doc(hidden)]
pub mod pipeline;
#[doc(hidden)]
pub mod pipeline_cache;
#[doc(hidden)]
pub mod recorder;
pub(crate) mod reflect;
pub(crate) mod resources;
#[doc(hidden)]
pub mod ring;
#[doc(hidden)]
pub mod sampler;
#[doc(hidden)]
pub mod shader;
#[doc(hidden)]
pub mod texel_buffer;
#[doc(hidden)]
pub mod timestamps;
pub mod validation;

pub use ash::vk;
pub use context::{ContextOptions, DeviceInfo, EnabledFeatures, GpuContext, PresentRequest, RawVulkan};
pub use error::{GpuError, GpuResult};
pub use resources::HostWaits;
pub use validation::ValidationCounts;
