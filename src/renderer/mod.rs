//! The recording core: a loaded scene's passes, GPU data and images, recorded into a command
//! buffer the caller gives. It never submits or waits per frame. The headless `Runtime` and a game
//! that embeds hadou (`GpuContext::from_raw`) both render through it.
//!
//! Frame contract (embedding): hadou writes its per-frame parameters (uniforms, wave and metaball
//! tables) on the host inside `record_frame`, so the previous frame hadou recorded must have
//! finished on the GPU first (the game waits on that frame's fence — one hadou frame in flight).
//! Timestamps are read a frame or more later without waiting (`latest_timings`).

mod composite;
pub mod depth_import;
mod external;
mod inputs;
pub(crate) mod readback;
mod record;
mod timings;
mod update;

use std::mem::ManuallyDrop;

pub use inputs::{DepthConvention, ExternalColor, ExternalDepth, FrameInputs, RecordedFrame};
pub use readback::AovReadback;
pub use timings::FrameTimings;
pub use update::WaveUpdate;

use crate::frame::{build_passes, plan};
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::DescriptorPool;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{GpuContext, GpuResult};
use crate::passes::Pass;
use crate::scene::Scene;
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};
use crate::Error;
use external::External;
use timings::TimingRing;

/// Frames whose timestamps can be pending at once (the game's frames in flight + one).
pub const TIMING_FRAMES: usize = 3;

struct Loaded {
    scene: Scene,
    gpu: SceneGpu,
    passes: Vec<Box<dyn Pass>>,
    /// Instance transforms changed since the last upload.
    instances_dirty: bool,
}

/// hadou's passes, scene data and images on one device. See the module docs for the frame contract.
///
/// Drop (or `Drop` of the owner) destroys everything hadou created, after `vkDeviceWaitIdle`; the
/// context it was made with (owning or `from_raw`) is dropped last.
pub struct Renderer {
    loaded: Option<Loaded>,
    targets: Option<Targets>,
    external: External,
    timings: TimingRing,
    pool: DescriptorPool,
    compiler: ShaderCompiler,
    frame_index: u64,
    memory: ManuallyDrop<Memory>,
    ctx: GpuContext,
}

impl Renderer {
    /// A renderer with no scene on `ctx` (from `GpuContext::new` or `GpuContext::from_raw`).
    pub fn new(ctx: GpuContext) -> Result<Self, Error> {
        let memory = Memory::new(&ctx)?;
        let compiler = ShaderCompiler::new()?;
        let pool = DescriptorPool::new(&ctx, "frame descriptors", 32)?;
        let timings = match TimingRing::new(&ctx, TIMING_FRAMES) {
            Ok(t) => t,
            Err(e) => {
                pool.destroy(&ctx);
                return Err(e.into());
            }
        };
        Ok(Renderer {
            loaded: None,
            targets: None,
            external: External::default(),
            timings,
            pool,
            compiler,
            frame_index: 0,
            memory: ManuallyDrop::new(memory),
            ctx,
        })
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    pub fn memory(&self) -> &Memory {
        &self.memory
    }

    pub fn compiler(&mut self) -> &mut ShaderCompiler {
        &mut self.compiler
    }

    pub fn scene(&self) -> Option<&Scene> {
        self.loaded.as_ref().map(|l| &l.scene)
    }

    pub fn scene_gpu(&self) -> Option<&SceneGpu> {
        self.loaded.as_ref().map(|l| &l.gpu)
    }

    /// The passes the loaded scene runs, in order.
    pub fn pass_names(&self) -> Vec<&'static str> {
        self.loaded.as_ref().map(|l| l.passes.iter().map(|p| p.name()).collect()).unwrap_or_default()
    }

    /// Whether the loaded scene's passes write `target` (so it can be read back).
    pub fn produces(&self, target: Target) -> bool {
        self.loaded
            .as_ref()
            .is_some_and(|l| l.passes.iter().any(|p| p.uses().iter().any(|(t, _)| *t == target)))
    }

    /// Uploads the scene and builds the passes it needs (pipelines are built here, never per
    /// frame), replacing any scene loaded before. May submit one-off uploads (baked tables) to the
    /// context's queue and wait for them: call it while nothing else submits to that queue.
    pub fn load_scene(&mut self, scene: Scene) -> Result<(), Error> {
        if self.pool.raw == crate::gpu::vk::DescriptorPool::null() {
            return Err(Error::InvalidRequest("the renderer was destroyed".into()));
        }
        self.unload();
        let gpu = SceneGpu::new(&self.ctx, &self.memory, &scene)?;
        let passes = match build_passes(&self.ctx, &self.memory, &mut self.compiler, &scene, &plan(&scene)) {
            Ok(p) => p,
            Err(e) => {
                gpu.destroy(&self.ctx, &self.memory);
                return Err(e.into());
            }
        };
        self.loaded = Some(Loaded { scene, gpu, passes, instances_dirty: false });
        // Descriptors point at the new scene's buffers: rebuilt on the next frame.
        self.drop_targets();
        Ok(())
    }

    fn unload(&mut self) {
        if let Some(old) = self.loaded.take() {
            let _ = self.ctx.wait_idle();
            let mut passes = old.passes;
            passes.iter_mut().for_each(|p| p.destroy(&self.ctx, &self.memory));
            old.gpu.destroy(&self.ctx, &self.memory);
        }
    }

    /// Destroys the size-dependent images (after the device is idle).
    fn drop_targets(&mut self) {
        if let Some(t) = self.targets.take() {
            let _ = self.ctx.wait_idle();
            t.destroy(&self.ctx, &self.memory);
        }
        self.external.drop_sized(&self.ctx, &self.memory);
    }

    /// After the frame's fence: adds what passes counted on the device (metaball statistics).
    pub fn report(&self, stats: &mut crate::frame::FrameStats) {
        if let Some(l) = &self.loaded {
            l.passes.iter().for_each(|p| p.report(stats));
        }
    }

    /// Destroys everything hadou created on the device, waiting for the device to be idle first.
    /// Called by Drop; call it earlier to control when (it is idempotent). Afterwards the renderer
    /// has no scene and refuses `load_scene`: only dropping it is left.
    pub fn destroy(&mut self) {
        let _ = self.ctx.wait_idle();
        self.unload();
        self.drop_targets();
        self.external.destroy(&self.ctx, &self.memory);
        self.timings.destroy(&self.ctx);
        self.pool.destroy(&self.ctx);
        self.pool = DescriptorPool { raw: crate::gpu::vk::DescriptorPool::null() };
    }

    /// Energy-wave shader code for explicit rays, for tests (see `Runtime::energy_probe`).
    pub(crate) fn parts(&mut self) -> (&GpuContext, &Memory, &mut ShaderCompiler) {
        (&self.ctx, &self.memory, &mut self.compiler)
    }

    /// Validation results of the owning context (zero for `from_raw`: the game's messenger counts).
    pub fn validation_counts(&self) -> crate::gpu::ValidationCounts {
        self.ctx.validation_counts()
    }

    /// The per-pass GPU times of the newest frame the GPU has finished, polled without waiting
    /// (`vkGetQueryPoolResults` without WAIT); None until one has finished. With one frame in
    /// flight, frame N's times are there once its fence signalled.
    pub fn latest_timings(&mut self) -> GpuResult<Option<&FrameTimings>> {
        self.timings.poll(&self.ctx)?;
        Ok(self.timings.latest())
    }

    /// Tells hadou the command buffer of the frame just recorded will not be submitted (an
    /// error after `record_frame`), so its timestamp pool is free again.
    pub fn abandon_frame(&mut self) {
        self.timings.abandon_current(&self.ctx);
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        self.destroy();
        // SAFETY: dropped exactly once, before the context (a field declared after it) is dropped.
        unsafe { ManuallyDrop::drop(&mut self.memory) };
    }
}
