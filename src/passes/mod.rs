//! One file per pass. A pass declares the images it touches and how; the runner in frame.rs
//! places the barriers, the debug label and the timestamps around its commands.

pub mod energy_probe;
pub mod energy_wave;
pub mod gpu_structs;
pub mod light_id;
pub mod metaballs;
pub mod raster;
pub mod tonemap;
pub mod translucency;

use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::DescriptorPool;
use crate::gpu::recorder::Recorder;
use crate::gpu::{GpuContext, GpuResult};
use crate::scene::Scene;
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};

/// What every pass sees while recording.
pub struct PassInputs<'a> {
    pub rec: &'a Recorder<'a>,
    pub targets: &'a Targets,
    pub scene_gpu: &'a SceneGpu,
    pub scene: &'a Scene,
    /// Scene time in seconds.
    pub time: f64,
    /// Embedded in a game's frame: the background is transparent black (hadou's result is
    /// composited over the game's colour).
    pub embedded: bool,
    /// `Depth` and `Distance` hold the game's imported depth: load them, do not clear them.
    pub depth_imported: bool,
}

pub trait Pass {
    /// The pass's one name: file, shader, debug label, timestamp scope, test.
    fn name(&self) -> &'static str;
    /// Per-frame host work before recording (e.g. writing this frame's parameters). The previous
    /// frame has finished, so buffers the pass owns are free to write.
    fn prepare(&mut self, _scene: &Scene, _time: f64, _extent: crate::gpu::vk::Extent2D) -> GpuResult<()> {
        Ok(())
    }
    /// Per-frame host work that needs the device, right after `prepare` (e.g. growing a buffer
    /// this frame needs and rewriting the pass's own descriptors). The previous frame has finished.
    fn prepare_device(&mut self, _ctx: &GpuContext, _memory: &Memory) -> GpuResult<()> {
        Ok(())
    }
    /// After the frame's fence: adds what the pass counted on the device to the frame's stats.
    fn report(&self, _stats: &mut crate::frame::FrameStats) {}
    /// The images this pass reads or writes, and how.
    fn uses(&self) -> Vec<(Target, ImageAccess)>;
    /// Points the pass's descriptors at the scene's buffers and the frame's images
    /// (after either was created anew; the pool was reset before).
    fn bind(
        &mut self,
        ctx: &GpuContext,
        pool: &DescriptorPool,
        scene_gpu: &SceneGpu,
        targets: &Targets,
    ) -> GpuResult<()>;
    fn record(&self, inputs: &PassInputs);
    fn destroy(&mut self, ctx: &GpuContext, memory: &Memory);
}
