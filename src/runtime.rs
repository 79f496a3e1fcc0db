//! The headless runtime: create it, load a scene, render frames, read back colour and AOVs. A thin
//! owner around the recording core (`renderer::Renderer`): its own device, one command buffer and
//! fence, and the read-back.

use std::time::Instant;

use crate::aov::{Aov, AovImage};
use crate::frame::{ms, FrameStats};
use crate::gpu::commands::FrameCommands;
use crate::gpu::{ContextOptions, DeviceInfo, GpuContext, ValidationCounts};
use crate::renderer::readback::not_read_back;
use crate::renderer::{AovReadback, FrameInputs, Renderer};
use crate::scene::Scene;
use crate::scene_gpu::SceneGpu;
use crate::targets::Target;
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
    commands: FrameCommands,
    renderer: Renderer,
}

impl Runtime {
    pub fn new(options: &RuntimeOptions) -> Result<Self, Error> {
        let ctx = GpuContext::new(&ContextOptions {
            validation: options.validation,
            device_filter: options.device.clone(),
        })?;
        Self::with_context(ctx)
    }

    /// A runtime on a context the caller created, e.g. `GpuContext::new_presenting` for a window
    /// (`hadou view`). The runtime owns the context from here on.
    pub fn with_context(ctx: GpuContext) -> Result<Self, Error> {
        // The renderer first: if the command buffer fails, dropping it frees everything it made.
        let renderer = Renderer::new(ctx)?;
        let commands = FrameCommands::new(renderer.context(), "frame")?;
        Ok(Runtime { commands, renderer })
    }

    pub fn device_info(&self) -> &DeviceInfo {
        &self.renderer.context().info
    }

    /// Validation errors and warnings counted since creation (zero unless validation is on).
    pub fn validation_counts(&self) -> ValidationCounts {
        self.renderer.context().validation_counts()
    }

    /// The validation log; it outlives the runtime, so it also shows what shutdown reported.
    pub fn validation_log(&self) -> std::sync::Arc<crate::gpu::validation::ValidationLog> {
        self.renderer.context().validation_log()
    }

    /// The Vulkan context, for code that records its own commands next to hadou's.
    pub fn context(&self) -> &GpuContext {
        self.renderer.context()
    }

    /// The recording core (update API, timings).
    pub fn renderer(&mut self) -> &mut Renderer {
        &mut self.renderer
    }

    /// The first validation messages received, for test failure output.
    pub fn validation_messages(&self) -> Vec<String> {
        self.renderer.context().validation_messages()
    }

    pub fn scene(&self) -> Option<&Scene> {
        self.renderer.scene()
    }

    /// The loaded scene's GPU buffers: one vertex/index buffer pair per mesh, and the draws.
    pub fn scene_gpu(&self) -> Option<&SceneGpu> {
        self.renderer.scene_gpu()
    }

    /// Evaluates the energy-wave shader code for explicit rays (not pixels): H for every
    /// (ray, wave), ray-major. Tests use it to feed the GPU exact hard rays.
    pub fn energy_probe(
        &mut self,
        waves: &[crate::effects::energy_wave_f32::GpuWave],
        rays: &[crate::passes::energy_probe::ProbeRay],
        method: crate::passes::energy_probe::ProbeMethod,
    ) -> Result<Vec<f32>, Error> {
        let (ctx, memory, compiler) = self.renderer.parts();
        Ok(crate::passes::energy_probe::run_probe(ctx, memory, compiler, waves, rays, method)?)
    }

    /// The passes the loaded scene runs, in order.
    pub fn pass_names(&self) -> Vec<&'static str> {
        self.renderer.pass_names()
    }

    /// Uploads the scene and builds the passes it needs, replacing any scene loaded before.
    pub fn load_scene(&mut self, scene: Scene) -> Result<(), Error> {
        self.renderer.load_scene(scene)
    }

    /// Renders one frame and reads back what was requested: records through the same core a game
    /// uses (`Renderer::record_frame`), submits, waits on the fence.
    pub fn render(&mut self, request: &FrameRequest) -> Result<FrameOutput, Error> {
        let frame_start = Instant::now();
        let max = self.context().limits.max_image_dimension2_d;
        if request.width == 0 || request.height == 0 || request.width > max || request.height > max {
            return Err(Error::InvalidRequest(format!(
                "frame size {}x{} outside 1..={max} (the device's maxImageDimension2D)",
                request.width, request.height
            )));
        }
        if self.renderer.scene().is_none() {
            return Err(Error::InvalidRequest("no scene loaded (call load_scene first)".into()));
        }
        let mut wanted: Vec<Target> = request.aovs.iter().map(|a| a.target()).collect();
        if request.color {
            wanted.push(Target::Ldr);
        }
        if let Some(missing) = wanted.iter().find(|t| !self.renderer.produces(**t)) {
            return Err(Error::InvalidRequest(format!(
                "AOV {} is not produced by this scene's passes ({}){}",
                missing.name(),
                self.renderer.pass_names().join(", "),
                producer_hint(*missing)
            )));
        }
        let record_start = Instant::now();
        self.commands.begin(self.renderer.context())?;
        let cmd = self.commands.cmd;
        let inputs = FrameInputs::headless(request.width, request.height, request.time);
        let recorded = self
            .renderer
            .record_frame(cmd, &inputs)
            .and_then(|frame| self.renderer.record_readback(cmd, &wanted).map(|readback| (frame, readback)));
        let (frame, readback) = match recorded {
            Ok(r) => r,
            Err(e) => {
                // Close the command buffer so the next frame can reset it; nothing is submitted.
                let _ = self.commands.end(self.renderer.context());
                self.renderer.abandon_frame();
                return Err(e);
            }
        };
        let cpu_record_ms = ms(record_start.elapsed());
        let submit_start = Instant::now();
        let last_pass = self.renderer.pass_names().last().copied().unwrap_or("none");
        if let Err(e) = self.commands.submit_and_wait(self.renderer.context(), last_pass) {
            self.renderer.release_readback(readback);
            return Err(e.into());
        }
        let cpu_submit_wait_ms = ms(submit_start.elapsed());
        let mut stats = FrameStats { cpu_record_ms, cpu_submit_wait_ms, ..Default::default() };
        // The fence signalled, so this frame's timestamps are written: the poll finds them.
        if let Some(t) = self.renderer.latest_timings()?.filter(|t| t.frame == frame.frame) {
            stats.passes = t.passes.clone();
            stats.gpu_frame_ms = t.gpu_frame_ms;
        }
        self.renderer.report(&mut stats);
        let output = collect_output(request, &readback);
        self.renderer.release_readback(readback);
        let (color, aovs) = output?;
        stats.cpu_frame_ms = ms(frame_start.elapsed());
        Ok(FrameOutput { width: request.width, height: request.height, color, aovs, stats })
    }
}

type Collected = (Option<Vec<u8>>, Vec<(Aov, AovImage)>);

fn collect_output(request: &FrameRequest, readback: &AovReadback) -> Result<Collected, Error> {
    let color = if request.color {
        Some(readback.bytes(Target::Ldr).ok_or_else(|| not_read_back(Target::Ldr))?.to_vec())
    } else {
        None
    };
    let mut aovs = Vec::new();
    for &aov in &request.aovs {
        aovs.push((aov, readback.aov(aov).ok_or_else(|| not_read_back(aov.target()))?));
    }
    Ok((color, aovs))
}

impl Drop for Runtime {
    fn drop(&mut self) {
        let _ = self.renderer.context().wait_idle();
        self.commands.destroy(self.renderer.context());
        // The renderer (declared after) then destroys its resources and the context.
    }
}

/// What a scene needs for a target that only an optional pass writes.
fn producer_hint(target: Target) -> &'static str {
    match target {
        Target::Energy => ": `energy` needs a [[wave]]",
        Target::Thickness => ": `thickness` needs an instance with a translucent material",
        _ => "",
    }
}
