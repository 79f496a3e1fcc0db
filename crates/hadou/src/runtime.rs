//! The headless runtime: create it, load a scene, render frames, read back colour and AOVs. A thin
//! owner around the recording core (`renderer::Renderer`, 2 frame slots): its own device, a
//! command buffer and fence per slot, and the read-back. `render` waits for its frame (it returns
//! the pixels); `submit` does not (a frame loop that only needs the timings, like `hadou profile`).

use std::time::Instant;

use crate::aov::{Aov, AovImage};
use crate::frame::{ms, FrameStats};
use crate::gpu::commands::FrameCommands;
use crate::gpu::{ContextOptions, DeviceInfo, GpuContext, ValidationCounts};
use crate::renderer::{AovReadback, FrameInputs, Renderer, RendererOptions};
use crate::scene::Scene;
use crate::targets::Target;
use crate::Error;

/// How the runtime is created. `RuntimeOptions::from_env()` reads `HADOU_VALIDATION` and `HADOU_DEVICE`.
#[derive(Clone, Debug, Default)]
pub struct RuntimeOptions {
    /// Khronos validation with synchronization validation (tests always turn it on).
    pub validation: bool,
    /// Use the first device whose name contains this.
    pub device: Option<String>,
    /// The effects it runs (`Effects::builtin()` by default; `crate::effect`).
    pub effects: crate::effect::Effects,
}

impl RuntimeOptions {
    /// Options from the environment: `HADOU_VALIDATION=1` (or `true`), `HADOU_DEVICE=<substring>`.
    pub fn from_env() -> Self {
        let c = ContextOptions::from_env();
        RuntimeOptions { validation: c.validation, device: c.device_filter, effects: Default::default() }
    }
}

/// One frame to render.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRequest {
    /// Image width in pixels, 1..=the device's maxImageDimension2D.
    pub width: u32,
    /// Image height in pixels, 1..=the device's maxImageDimension2D.
    pub height: u32,
    /// Scene time in seconds (animation).
    pub time: f64,
    /// Read back the tonemapped sRGB colour.
    pub color: bool,
    /// AOVs to read back.
    pub aovs: Vec<Aov>,
}

impl FrameRequest {
    /// A width × height frame at time 0 with colour and no AOVs.
    pub fn new(width: u32, height: u32) -> Self {
        FrameRequest { width, height, time: 0.0, color: true, aovs: Vec::new() }
    }
}

/// What a frame produced.
#[derive(Clone, Debug)]
pub struct FrameOutput {
    /// The request's width in pixels.
    pub width: u32,
    /// The request's height in pixels.
    pub height: u32,
    /// RGBA8, sRGB-encoded, row 0 at the top; present when requested.
    pub color: Option<Vec<u8>>,
    /// The requested AOVs, in request order.
    pub aovs: Vec<(Aov, AovImage)>,
    /// GPU pass times, device counters and CPU times of this frame.
    pub stats: FrameStats,
}

impl FrameOutput {
    /// The image of `aov`; None when it was not requested.
    pub fn aov(&self, aov: Aov) -> Option<&AovImage> {
        self.aovs.iter().find(|(a, _)| *a == aov).map(|(_, img)| img)
    }
}

/// The headless runtime. Owns its Vulkan device; frames are rendered one at a time.
///
/// ```
/// use hadou::{Runtime, RuntimeOptions, FrameRequest, Aov};
/// let mut runtime = Runtime::new(&RuntimeOptions { validation: true, ..Default::default() })?;
/// // `builtin:NAME`: a scene of assets/scenes built into the library (a game names its file).
/// runtime.load_scene(hadou::builtin::load("builtin:showcase".as_ref())?)?;
/// let mut request = FrameRequest::new(512, 512);
/// request.aovs.push(Aov::Depth);
/// let frame = runtime.render(&request)?;
/// let depth = frame.aov(Aov::Depth).unwrap();
/// println!("centre depth {}", depth.data[256 * 512 + 256]);
/// assert_eq!(runtime.validation_counts().errors, 0);
/// # Ok::<(), hadou::Error>(())
/// ```
pub struct Runtime {
    /// One per frame slot (frame n records into `commands[n % slots]`).
    commands: Vec<FrameCommands>,
    renderer: Renderer,
}

impl Runtime {
    /// A runtime on its own device, chosen as `GpuContext::new` does.
    pub fn new(options: &RuntimeOptions) -> Result<Self, Error> {
        let ctx = GpuContext::new(&ContextOptions {
            validation: options.validation,
            device_filter: options.device.clone(),
        })?;
        let renderer_options = RendererOptions { effects: options.effects.clone(), ..Default::default() };
        Self::with_renderer_options(ctx, &renderer_options)
    }

    /// A runtime on a context the caller created, e.g. `GpuContext::new_presenting` for a window
    /// (`hadou view`). The runtime owns the context from here on.
    pub fn with_context(ctx: GpuContext) -> Result<Self, Error> {
        Self::with_renderer_options(ctx, &RendererOptions::default())
    }

    /// A runtime on `ctx` whose renderer is made with `options` (its effects; its
    /// `frames_in_flight` slots each get a command buffer and fence).
    pub fn with_renderer_options(ctx: GpuContext, options: &RendererOptions) -> Result<Self, Error> {
        // The renderer first: if a command buffer fails, dropping it frees everything it made.
        let renderer = Renderer::with_options(ctx, options)?;
        let commands = (0..renderer.frames_in_flight())
            .map(|i| FrameCommands::new(renderer.context(), &format!("frame slot {i}")))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Runtime { commands, renderer })
    }

    /// The device in use.
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

    /// The loaded scene; None before `load_scene`.
    pub fn scene(&self) -> Option<&Scene> {
        self.renderer.scene()
    }

    /// Evaluates the energy-wave shader code for explicit rays (not pixels): H for every
    /// (ray, wave), ray-major. Tests use it to feed the GPU exact hard rays.
    pub fn energy_probe(
        &mut self,
        waves: &[crate::effects::energy_wave_f32::GpuWave],
        rays: &[crate::passes::energy_probe::ProbeRay],
        method: crate::passes::energy_probe::ProbeMethod,
    ) -> Result<Vec<f32>, Error> {
        if waves.is_empty() || rays.is_empty() {
            return Ok(Vec::new());
        }
        let (ctx, memory, compiler) = self.renderer.parts();
        let mut probe =
            crate::passes::energy_probe::ProbePass::new(ctx, memory, compiler, waves, rays, method)?;
        let slot = self.next_slot();
        self.commands[slot].begin(self.renderer.context())?;
        let cmd = self.commands[slot].cmd;
        let frame = match self.renderer.record_one_off(cmd, &mut probe) {
            Ok(f) => f,
            Err(e) => {
                let _ = self.commands[slot].end(self.renderer.context());
                return Err(e);
            }
        };
        self.commands[slot].submit_and_wait(self.renderer.context(), "energy_probe")?;
        self.renderer.frame_finished(frame)?;
        Ok(probe.results())
    }

    /// The slot the next frame records into.
    fn next_slot(&self) -> usize {
        (self.renderer.next_frame() % self.commands.len() as u64) as usize
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
    /// uses (`Renderer::record_frame`), submits, waits on the frame's fence.
    pub fn render(&mut self, request: &FrameRequest) -> Result<FrameOutput, Error> {
        let frame_start = Instant::now();
        let (frame, readback, cpu_record_ms) = self.record(request)?;
        let submit_start = Instant::now();
        let slot = (frame % self.commands.len() as u64) as usize;
        let last_pass = self.renderer.pass_names().last().copied().unwrap_or("none");
        self.commands[slot].submit_and_wait(self.renderer.context(), last_pass)?;
        let cpu_submit_wait_ms = ms(submit_start.elapsed());
        self.renderer.frame_finished(frame)?;
        let mut stats =
            self.renderer.latest_stats().filter(|(f, _)| *f == frame).map(|(_, s)| s).unwrap_or_default();
        stats.cpu_record_ms = cpu_record_ms;
        stats.cpu_submit_wait_ms = cpu_submit_wait_ms;
        let (color, aovs) = collect_output(request, &readback)?;
        stats.cpu_frame_ms = ms(frame_start.elapsed());
        Ok(FrameOutput { width: request.width, height: request.height, color, aovs, stats })
    }

    /// Records and submits one frame without waiting for it (frames overlap the CPU's work on the
    /// next one, up to the slots): for loops that only need timings. Returns the frame's number;
    /// its statistics come with `Runtime::finished_stats` once a later frame (or `wait_all`)
    /// finished it.
    pub fn submit(&mut self, request: &FrameRequest) -> Result<u64, Error> {
        let request = FrameRequest { color: false, aovs: Vec::new(), ..request.clone() };
        let (frame, _readback, _) = self.record(&request)?;
        let slot = (frame % self.commands.len() as u64) as usize;
        let last_pass = self.renderer.pass_names().last().copied().unwrap_or("none");
        self.commands[slot].submit(self.renderer.context(), last_pass)?;
        Ok(frame)
    }

    /// Waits for every submitted frame and reports them finished.
    pub fn wait_all(&mut self) -> Result<(), Error> {
        for c in &mut self.commands {
            c.wait(self.renderer.context(), "the last frame")?;
        }
        if let Some(last) = self.renderer.next_frame().checked_sub(1) {
            self.renderer.frame_finished(last)?;
        }
        Ok(())
    }

    /// Records frame `request` into its slot's command buffer (waiting for that slot's previous
    /// submission: the frame contract) with the read-backs it asks for.
    fn record(&mut self, request: &FrameRequest) -> Result<(u64, AovReadback, f64), Error> {
        let max = self.context().limits.max_image_dimension2_d;
        if request.width == 0 || request.height == 0 || request.width > max || request.height > max {
            return Err(Error::FrameSize { width: request.width, height: request.height, max });
        }
        if self.renderer.scene().is_none() {
            return Err(Error::NoScene);
        }
        let mut wanted: Vec<Target> = request.aovs.iter().map(|a| a.target()).collect();
        if request.color {
            wanted.push(Target::Ldr);
        }
        // What the frame's passes do not write is refused by `record_readback` once the frame is
        // recorded (they declare their images as they prepare it); nothing is submitted then.
        let slot = self.next_slot();
        // The slot's previous frame must have finished before it is recorded again.
        self.commands[slot].begin(self.renderer.context())?;
        let record_start = Instant::now();
        let cmd = self.commands[slot].cmd;
        let inputs = FrameInputs::headless(request.width, request.height, request.time);
        // Only what is read back is written (an AOV no pass reads, e.g. `energy`).
        self.renderer.set_readbacks(Some(&request.aovs));
        // A temporal upscaler's inputs asked for: their passes are built (once).
        let upscaler = request.aovs.iter().any(|a| Aov::UPSCALER.contains(a));
        if upscaler && self.renderer.scene().is_some_and(|s| !s.render.motion_vectors) {
            self.renderer.set_motion_vectors(true)?;
        }
        let recorded = self
            .renderer
            .record_frame(cmd, &inputs)
            .and_then(|frame| self.renderer.record_readback(cmd, &wanted).map(|readback| (frame, readback)));
        match recorded {
            Ok((frame, readback)) => Ok((frame.frame, readback, ms(record_start.elapsed()))),
            Err(e) => {
                // Close the command buffer so the next frame can reset it; nothing is submitted.
                let _ = self.commands[slot].end(self.renderer.context());
                self.renderer.abandon_frame();
                Err(e)
            }
        }
    }

    /// What the device measured and counted in frame `frame`, once it is known finished.
    pub fn finished_stats(&self, frame: u64) -> Option<FrameStats> {
        self.renderer.latest_stats().filter(|(f, _)| *f == frame).map(|(_, s)| s)
    }
}

type Collected = (Option<Vec<u8>>, Vec<(Aov, AovImage)>);

fn collect_output(request: &FrameRequest, readback: &AovReadback) -> Result<Collected, Error> {
    let color = if request.color {
        let bytes = readback.bytes(Target::Ldr).ok_or(Error::NotProduced {
            target: "ldr",
            passes: String::new(),
            needs: Target::Ldr.needs(),
        })?;
        // A 16384² colour is 1 GiB: a failed allocation is an error, not an abort.
        let mut color = Vec::new();
        color.try_reserve_exact(bytes.len()).map_err(|_| crate::GpuError::OutOfHostMemory {
            what: format!("the colour read-back ({} bytes)", bytes.len()),
        })?;
        color.extend_from_slice(bytes);
        Some(color)
    } else {
        None
    };
    let mut aovs = Vec::new();
    for &aov in &request.aovs {
        let missing =
            Error::NotProduced { target: aov.name(), passes: String::new(), needs: aov.target().needs() };
        aovs.push((aov, readback.try_aov(aov)?.ok_or(missing)?));
    }
    Ok((color, aovs))
}

impl Drop for Runtime {
    fn drop(&mut self) {
        for c in &mut self.commands {
            let _ = c.wait(self.renderer.context(), "shutdown");
        }
        // The command buffers go first (the renderer, declared after, then its context).
        self.commands.clear();
    }
}
