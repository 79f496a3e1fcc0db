//! hadou's GPU layer: the only crate that depends on ash and calls Vulkan — context, memory,
//! pipelines, shaders, barriers, timestamps, recording, presenting to a window. The layers above
//! (`hadou`: scenes, effects, passes, the renderer; the `hadou` command line) have no `ash`
//! dependency and no `unsafe` code of their own (`#![deny(unsafe_code)]`, checked by
//! `tests/layers.rs`): they record through the safe types here and name Vulkan's plain types
//! (formats, layouts, handles a game hands in) through `vk`.

#![warn(missing_docs)]

#[doc(hidden)]
pub mod barriers;
#[doc(hidden)]
pub mod commands;
pub mod context;
pub mod error;
#[doc(hidden)]
pub mod fullscreen;
#[doc(hidden)]
pub mod layout;
#[doc(hidden)]
pub mod memory;
#[doc(hidden)]
pub mod pipeline;
#[doc(hidden)]
pub mod pipeline_cache;
#[doc(hidden)]
pub mod present;
#[doc(hidden)]
pub mod recorder;
#[doc(hidden)]
pub mod reflect;
pub(crate) mod resources;
#[doc(hidden)]
pub mod ring;
#[doc(hidden)]
pub mod sampler;
#[doc(hidden)]
pub mod set_layout;
#[doc(hidden)]
pub mod shader;
#[doc(hidden)]
pub mod staged_image;
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
