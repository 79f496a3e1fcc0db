//! The headless runtime: create it, load a scene, render frames, read back colour and AOVs.

use std::mem::ManuallyDrop;

use crate::aov::{Aov, AovImage};
use crate::frame::{build_passes, plan, targets_used, FrameRunner, FrameStats, Readback};
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::DescriptorPool;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, ContextOptions, DeviceInfo, GpuContext, GpuError, ValidationCounts};
use crate::passes::Pass;
use crate::scene::Scene;
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};
use crate::Error;

/// How the runtime is created. `RuntimeOptions::from_env()` reads `HADOU_VALIDATION` and `HADOU_DEVICE`.
#[derive(Clone, Debug, Default)]
pub struct RuntimeOptions {
    /// Khronos validation with synchronization validation (tests always turn it on).
    pub validation: bool,
    /// Use the first device whose name contains this.
    pub device: Option<String>,
}

impl RuntimeOptions {
    pub fn from_env() -> Self {
        let c = ContextOptions::from_env();
        RuntimeOptions { validation: c.validation, device: c.device_filter }
    }
}

/// One frame to render.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRequest {
    pub width: u32,
    pub height: u32,
    /// Scene time in seconds (animation).
    pub time: f64,
    /// Read back the tonemapped sRGB colour.
    pub color: bool,
    /// AOVs to read back.
    pub aovs: Vec<Aov>,
}

impl FrameRequest {
    pub fn new(width: u32, height: u32) -> Self {
        FrameRequest { width, height, time: 0.0, color: true, aovs: Vec::new() }
    }
}

/// What a frame produced.
#[derive(Clone, Debug)]
pub struct FrameOutput {
    pub width: u32,
    pub height: u32,
    /// RGBA8, sRGB-encoded, row 0 at the top; present when requested.
    pub color: Option<Vec<u8>>,
    pub aovs: Vec<(Aov, AovImage)>,
    pub stats: FrameStats,
}

impl FrameOutput {
    pub fn aov(&self, aov: Aov) -> Option<&AovImage> {
        self.aovs.iter().find(|(a, _)| *a == aov).map(|(_, img)| img)
    }
}

struct Loaded {
    scene: Scene,
    gpu: SceneGpu,
    passes: Vec<Box<dyn Pass>>,
}

/// The headless runtime. Owns its Vulkan device; frames are rendered one at a time.
///
/// ```
/// use hadou::{Runtime, RuntimeOptions, FrameRequest, Aov};
/// let mut runtime = Runtime::new(&RuntimeOptions { validation: true, device: None })?;
/// runtime.load_scene(hadou::scene::load_scene("assets/scenes/showcase.toml".as_ref())?)?;
/// let mut request = FrameRequest::new(512, 512);
/// request.aovs.push(Aov::Depth);
/// let frame = runtime.render(&request)?;
/// let depth = frame.aov(Aov::Depth).unwrap();
/// println!("centre depth {}", depth.data[256 * 512 + 256]);
/// assert_eq!(runtime.validation_counts().errors, 0);
/// # Ok::<(), hadou::Error>(())
/// ```
pub struct Runtime {
    loaded: Option<Loaded>,
    targets: Option<Targets>,
    runner: FrameRunner,
    pool: DescriptorPool,
    compiler: ShaderCompiler,
    memory: ManuallyDrop<Memory>,
    ctx: GpuContext,
}

impl Runtime {
    pub fn new(options: &RuntimeOptions) -> Result<Self, Error> {
        let ctx = GpuContext::new(&ContextOptions {
            validation: options.validation,
            device_filter: options.device.clone(),
        })?;
        let memory = Memory::new(&ctx)?;
        let compiler = ShaderCompiler::new()?;
        let pool = DescriptorPool::new(&ctx, "frame descriptors", 32)?;
        let runner = match FrameRunner::new(&ctx) {
            Ok(r) => r,
            Err(e) => {
                pool.destroy(&ctx);
                return Err(e.into());
            }
        };
        Ok(Runtime {
            loaded: None,
            targets: None,
            runner,
            pool,
            compiler,
            memory: ManuallyDrop::new(memory),
            ctx,
        })
    }

    pub fn device_info(&self) -> &DeviceInfo {
        &self.ctx.info
    }

    /// Validation errors and warnings counted since creation (zero unless validation is on).
    pub fn validation_counts(&self) -> ValidationCounts {
        self.ctx.validation_counts()
    }

    /// The validation log; it outlives the runtime, so it also shows what shutdown reported.
    pub fn validation_log(&self) -> std::sync::Arc<crate::gpu::validation::ValidationLog> {
        self.ctx.validation_log()
    }

    /// The Vulkan context, for code that records its own commands next to hadou's.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The first validation messages received, for test failure output.
    pub fn validation_messages(&self) -> Vec<String> {
        self.ctx.validation_messages()
    }

    pub fn scene(&self) -> Option<&Scene> {
        self.loaded.as_ref().map(|l| &l.scene)
    }

    /// The loaded scene's GPU buffers: one vertex/index buffer pair per mesh, and the draws.
    pub fn scene_gpu(&self) -> Option<&SceneGpu> {
        self.loaded.as_ref().map(|l| &l.gpu)
    }

    /// Evaluates the energy-wave shader code for explicit rays (not pixels): H for every
    /// (ray, wave), ray-major. Tests use it to feed the GPU exact hard rays.
    pub fn energy_probe(
        &mut self,
        waves: &[crate::effects::energy_wave_f32::GpuWave],
        rays: &[crate::passes::energy_probe::ProbeRay],
        method: crate::passes::energy_probe::ProbeMethod,
    ) -> Result<Vec<f32>, Error> {
        let run = crate::passes::energy_probe::run_probe;
        Ok(run(&self.ctx, &self.memory, &mut self.compiler, waves, rays, method)?)
    }

    /// The passes the loaded scene runs, in order.
    pub fn pass_names(&self) -> Vec<&'static str> {
        self.loaded.as_ref().map(|l| l.passes.iter().map(|p| p.name()).collect()).unwrap_or_default()
    }

    /// Uploads the scene and builds the passes it needs, replacing any scene loaded before.
    pub fn load_scene(&mut self, scene: Scene) -> Result<(), Error> {
        self.unload();
        let gpu = SceneGpu::new(&self.ctx, &self.memory, &scene)?;
        let passes = match build_passes(&self.ctx, &self.memory, &mut self.compiler, &scene, &plan(&scene)) {
            Ok(p) => p,
            Err(e) => {
                gpu.destroy(&self.ctx, &self.memory);
                return Err(e.into());
            }
        };
        self.loaded = Some(Loaded { scene, gpu, passes });
        // Descriptors point at the new scene's buffers: rebind on the next frame.
        if let Some(targets) = self.targets.take() {
            targets.destroy(&self.ctx, &self.memory);
        }
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

    /// (Re)creates the frame's images when the size changed, and points every pass at them.
    fn ensure_targets(&mut self, width: u32, height: u32) -> Result<(), Error> {
        let extent = vk::Extent2D { width, height };
        if self.targets.as_ref().is_some_and(|t| t.extent == extent) {
            return Ok(());
        }
        if let Some(old) = self.targets.take() {
            self.ctx.wait_idle()?;
            old.destroy(&self.ctx, &self.memory);
        }
        let wanted = self.loaded.as_ref().map(|l| targets_used(&l.passes)).unwrap_or_default();
        let targets = Targets::new(&self.ctx, &self.memory, extent, &wanted)?;
        self.pool.reset(&self.ctx)?;
        if let Some(loaded) = &mut self.loaded {
            for pass in &mut loaded.passes {
                if let Err(e) = pass.bind(&self.ctx, &self.pool, &loaded.gpu, &targets) {
                    targets.destroy(&self.ctx, &self.memory);
                    return Err(e.into());
                }
            }
        }
        self.targets = Some(targets);
        Ok(())
    }

    /// Renders one frame and reads back what was requested.
    pub fn render(&mut self, request: &FrameRequest) -> Result<FrameOutput, Error> {
        let max = self.ctx.limits.max_image_dimension2_d;
        if request.width == 0 || request.height == 0 || request.width > max || request.height > max {
            return Err(Error::InvalidRequest(format!(
                "frame size {}x{} outside 1..={max} (the device's maxImageDimension2D)",
                request.width, request.height
            )));
        }
        if self.loaded.is_none() {
            return Err(Error::InvalidRequest("no scene loaded (call load_scene first)".into()));
        }
        self.ensure_targets(request.width, request.height)?;
        let (Some(loaded), Some(targets)) = (&mut self.loaded, &mut self.targets) else {
            return Err(Error::InvalidRequest("no scene loaded".into()));
        };
        loaded.gpu.update_uniforms(&loaded.scene, request.width, request.height)?;
        let mut wanted: Vec<Target> = request.aovs.iter().map(|a| a.target()).collect();
        if let Some(missing) = wanted.iter().find(|t| !targets.contains(**t)) {
            return Err(Error::InvalidRequest(format!(
                "AOV {} is not produced by this scene's passes ({}): e.g. `energy` needs a [[wave]]",
                missing.name(),
                loaded.passes.iter().map(|p| p.name()).collect::<Vec<_>>().join(", ")
            )));
        }
        if request.color {
            wanted.push(Target::Ldr);
        }
        wanted.sort();
        wanted.dedup();
        let (stats, readbacks) = self.runner.run(
            &self.ctx,
            &self.memory,
            &mut loaded.passes,
            targets,
            &loaded.gpu,
            &loaded.scene,
            request.time,
            &wanted,
        )?;
        let output = collect_output(request, stats, &readbacks);
        readbacks.into_iter().for_each(|r| self.memory.destroy_buffer(&self.ctx, r.buffer));
        output
    }
}

fn collect_output(
    request: &FrameRequest,
    stats: FrameStats,
    readbacks: &[Readback],
) -> Result<FrameOutput, Error> {
    let bytes = |target: Target| -> Result<&[u8], Error> {
        readbacks.iter().find(|r| r.target == target).and_then(|r| r.buffer.mapped()).ok_or_else(|| {
            Error::Gpu(GpuError::Limit { what: target.name().into(), message: "not read back".into() })
        })
    };
    let color = if request.color { Some(bytes(Target::Ldr)?.to_vec()) } else { None };
    let mut aovs = Vec::new();
    for &aov in &request.aovs {
        aovs.push((aov, AovImage::decode(aov, request.width, request.height, bytes(aov.target())?)));
    }
    Ok(FrameOutput { width: request.width, height: request.height, color, aovs, stats })
}

impl Drop for Runtime {
    fn drop(&mut self) {
        let _ = self.ctx.wait_idle();
        self.unload();
        if let Some(t) = self.targets.take() {
            t.destroy(&self.ctx, &self.memory);
        }
        self.runner.destroy(&self.ctx);
        self.pool.destroy(&self.ctx);
        // SAFETY: dropped exactly once, before the context (a field declared after it) is dropped.
        unsafe { ManuallyDrop::drop(&mut self.memory) };
    }
}
