#![doc = include_str!("../../../README.md")]
#![warn(missing_docs)]
// Vulkan is called only by the GPU crate (hadou-gpu); this crate records through its safe types.
// The one exception is the signal handler of `output::interrupt` (tests/layers.rs checks both).
#![deny(unsafe_code)]

pub mod aov;
pub mod bake;
pub mod budget;
pub mod builtin;
pub mod compare;
pub mod effect;
#[doc(hidden)]
pub mod effects;
#[doc(hidden)]
pub mod frame;
pub use hadou_gpu as gpu;
pub mod output;
#[doc(hidden)]
pub mod passes;
#[doc(hidden)]
pub use hadou_gpu::present;
pub mod reference;
pub mod renderer;
pub mod runtime;
pub mod scene;
#[doc(hidden)]
pub mod scene_gpu;
#[doc(hidden)]
pub mod scene_textures;
#[doc(hidden)]
pub mod targets;
pub mod testing;

pub use aov::{Aov, AovImage};
pub use effects::metaballs::device::{DeviceBall, DeviceBalls};
pub use effects::metaballs::Ball;
pub use frame::{FrameStats, PassTiming};
pub use gpu::{DeviceInfo, GpuError, HostWaits, ValidationCounts};
/// Every shader source hadou embeds, by its path under `shaders/`: what `gpu::shader::ShaderCompiler`
/// compiles for the renderer (`HADOU_SHADER_DIR` points at a tree to read instead, for hot reload).
pub use passes::SHADERS;
pub use renderer::assets::SpawnedGltf;
pub use renderer::bakes::BakeProgress;
pub use renderer::ids::{MaterialId, MeshId};
pub use renderer::instances::{InstanceId, LightId};
pub use renderer::world::{GroupId, MetaballsDesc, WaveDesc, WaveId};
pub use renderer::{
    AovReadback, DepthConvention, Exposure, ExternalColor, ExternalDepth, ExternalImage, FrameInputs,
    FrameTimings, GameMatrix, GameVector, RecordedFrame, Renderer, RendererOptions, UpscalerTargets, View,
    ViewCamera, WaveUpdate, MAX_VIEWS,
};
pub use runtime::{FrameOutput, FrameRequest, Runtime, RuntimeOptions};

/// Everything the library can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The device, the driver, a shader or a GPU limit.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A scene file or a scene description that is not valid.
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    /// An effect registration, or a frame its passes cannot record (an image nobody writes).
    #[error(transparent)]
    Effect(#[from] effect::EffectError),
    /// An output file that could not be written.
    #[error(transparent)]
    Output(#[from] output::OutputError),
    /// A frame was requested before `load_scene`.
    #[error("no scene loaded (call load_scene first)")]
    NoScene,
    /// `RendererOptions::frames_in_flight` outside 1..=4.
    #[error("frames_in_flight {0} is outside 1..={max}", max = renderer::MAX_FRAMES_IN_FLIGHT)]
    FramesInFlight(usize),
    /// A frame size the device cannot hold.
    #[error("frame size {width}x{height} outside 1..={max} (the device's maxImageDimension2D)")]
    FrameSize {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
        /// The largest side the device takes.
        max: u32,
    },
    /// `frame_finished` named a frame that was never recorded.
    #[error("frame {frame} was not recorded (frames 0..{recorded} were)")]
    FrameNotRecorded {
        /// The frame named.
        frame: u64,
        /// How many frames were recorded.
        recorded: u64,
    },
    /// A read-back was asked for before any frame was recorded.
    #[error("no frame recorded yet (or it was 0 × 0)")]
    NoFrameRecorded,
    /// An image the scene's passes do not write was asked for (an AOV of an effect it lacks).
    #[error("AOV {target} is not produced by this scene's passes ({passes}): it needs {needs}")]
    NotProduced {
        /// The image asked for.
        target: &'static str,
        /// The scene's passes, comma-separated.
        passes: String,
        /// What the scene lacks for that image, e.g. "a \[\[wave\]\]".
        needs: &'static str,
    },
    /// The game's depth convention cannot be inverted.
    #[error("external depth: {0}")]
    DepthConvention(String),
    /// The game's depth image has a format hadou does not sample.
    #[error(
        "external depth: format {0:?} is not a depth format hadou samples (D32_SFLOAT, D16_UNORM, \
         D24_UNORM_S8_UINT)"
    )]
    DepthFormat(gpu::vk::Format),
    /// An update named a part of an object by a position it does not have (a ball of a metaball
    /// group past its list).
    #[error("{kind} {index}: the scene has {count}")]
    UnknownId {
        /// What was named: "ball of the metaball group".
        kind: &'static str,
        /// The index given.
        index: usize,
        /// How many of that kind there are.
        count: usize,
    },
    /// An id (`InstanceId`, `LightId`, `WaveId`, `GroupId`, `MaterialId`) that names nothing in
    /// the world: despawned, from a scene loaded before, or from another renderer.
    #[error("id {0} names nothing in the world (despawned?)")]
    StaleId(u64),
    /// An update with values hadou cannot use; `expected` says what is.
    #[error("{what}: {expected}")]
    InvalidUpdate {
        /// The update refused, with its values.
        what: String,
        /// What would be accepted.
        expected: String,
    },
    /// `hadou report`: a measurement could not be made (the reason).
    #[error("report: {0}")]
    Report(String),
}
