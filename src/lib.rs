#![doc = include_str!("../README.md")]

pub mod aov;
pub mod effects;
pub mod frame;
pub mod gpu;
pub mod output;
pub mod passes;
pub mod present;
pub mod profile;
pub mod renderer;
pub mod report;
pub mod runtime;
pub mod scene;
pub mod scene_gpu;
pub mod targets;
#[doc(hidden)]
pub mod testing;

pub use aov::{Aov, AovImage};
pub use frame::{FrameStats, PassTiming};
pub use gpu::{DeviceInfo, GpuError, ValidationCounts};
pub use renderer::{
    DepthConvention, ExternalColor, ExternalDepth, FrameInputs, FrameTimings, RecordedFrame, Renderer,
    WaveUpdate,
};
pub use runtime::{FrameOutput, FrameRequest, Runtime, RuntimeOptions};

/// Everything the library can fail with.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    #[error(transparent)]
    Output(#[from] output::OutputError),
    #[error("invalid request: {0}")]
    InvalidRequest(String),
}
