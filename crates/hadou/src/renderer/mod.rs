//! The recording core: a loaded scene's passes, GPU data and images, recorded into a command
//! buffer the caller gives. It never submits, and never waits in steady state. The headless
//! `Runtime` and a game that embeds hadou (`GpuContext::from_raw`) both render through it.
//!
//! # Frame contract (embedding)
//!
//! The renderer has `frames_in_flight` frame slots (1..=4, default 2). Frame n (the n-th
//! `record_frame`, `RecordedFrame::frame`) is recorded into slot n mod frames_in_flight, which
//! owns that frame's per-frame data (an upload ring for constants, instance, wave and metaball
//! tables), its descriptor sets and its timestamps. **Before recording frame n, the host
//! guarantees that every frame up to n − frames_in_flight has finished on the GPU** — the usual
//! game loop with one fence per frame in flight does exactly that when hadou's frames_in_flight
//! equals the game's. hadou relies on it to reuse the slot and to free what was dropped:
//! every GPU object hadou drops (a grown buffer, the old images after a resize, a reloaded scene's
//! data) is retired with the newest frame that may use it and destroyed only once that frame is
//! known finished. A host that knows more (it waited on a fence) may say so with
//! `frame_finished`, so timings arrive and memory is freed sooner.
//!
//! Timestamps are read only from frames known to be finished, never waited for
//! (`latest_timings`).

pub mod assets;
pub mod bakes;
mod budget;
mod deform;
mod effects;
mod game_math;
pub mod ids;
mod inputs;
pub mod instances;
mod look;
mod motion;
pub(crate) mod readback;
mod record;
mod slots;
mod timings;
mod update;
pub mod view_projection;
mod views;
pub mod world;

pub use deform::vertex_normals;
pub use game_math::{GameMatrix, GameVector};
pub use inputs::{
    DepthConvention, ExternalColor, ExternalDepth, ExternalImage, FrameInputs, RecordedFrame, UpscalerTargets,
};
pub use look::Exposure;
pub use readback::AovReadback;
pub use timings::FrameTimings;
pub use update::WaveUpdate;
pub use views::{View, ViewCamera, MAX_VIEWS};

use crate::effect::{Effects, ScenePasses};
use crate::gpu::memory::Memory;
use crate::gpu::pipeline_cache::PipelineCache;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::GpuContext;
use crate::passes::composite::CompositePass;
use crate::passes::depth_import::DepthImportPass;
use crate::passes::depth_out::DepthOutPass;
use crate::passes::tonemap::TonemapPass;
use crate::passes::Pass;
use crate::scene::Scene;
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};
use crate::Error;
use slots::Slot;
use timings::FinishedFrame;

/// How a `Renderer` is made.
#[derive(Clone, Debug)]
pub struct RendererOptions {
    /// Frame slots (1..=4): how many of hadou's frames may be in flight at once. See the module
    /// docs for the contract.
    pub frames_in_flight: usize,
    /// Where the pipeline cache file lives; `None`: the bake cache's folder
    /// (`effects::bake_cache::default_cache_dir`), no file when that is unknown.
    pub pipeline_cache_dir: Option<std::path::PathBuf>,
    /// The effects it runs (`Effects::builtin()` by default); a scene read with other effects'
    /// tables is refused by `load_scene`.
    pub effects: Effects,
    /// A GPU time per frame, in ms, the effects' quality levels are fitted into
    /// (`Renderer::set_frame_budget`, `crate::budget`); None: the scene's `[render] budget_ms`.
    pub frame_budget_ms: Option<f64>,
}

impl Default for RendererOptions {
    fn default() -> Self {
        RendererOptions {
            frames_in_flight: 2,
            pipeline_cache_dir: None,
            effects: Effects::builtin(),
            frame_budget_ms: None,
        }
    }
}

/// The most frame slots a renderer takes.
pub const MAX_FRAMES_IN_FLIGHT: usize = 4;

struct Loaded {
    scene: Scene,
    gpu: SceneGpu,
    /// The scene passes (running and parked) and the data they share.
    passes: ScenePasses,
    /// The id of each of `scene.waves()` and `scene.metaballs()` (spawned or from the file).
    wave_ids: Vec<u64>,
    group_ids: Vec<u64>,
    /// The id of each of `scene.instances`, `scene.lights` and `scene.materials`.
    instance_ids: Vec<u64>,
    light_ids: Vec<u64>,
    material_ids: Vec<u64>,
    /// The id of each of `scene.meshes` (`assets::RETIRED` once despawned).
    mesh_ids: Vec<u64>,
    /// Thickness tables being baked at run time.
    bakes: bakes::Bakes,
    /// Instance transforms or materials changed since their tables were built.
    tables_dirty: bool,
    /// Per mesh with a `wobble`: its loaded positions, and the scene time last applied.
    wobble: deform::WobbleState,
    /// The projection the game gave with `set_view_projection` (None after `set_camera` or a
    /// load): what `DepthConvention::Camera` means.
    game_projection: Option<glam::DMat4>,
    /// With motion vectors on: each instance's model matrix (f64) in the frame recorded last, by
    /// id, and each view's unjittered camera then.
    prev_models: std::collections::HashMap<u64, glam::DMat4>,
    prev_cameras: Vec<Option<crate::scene::camera::Camera>>,
}

impl Loaded {
    fn pass_list(&self) -> impl Iterator<Item = &dyn Pass> {
        self.passes.running.iter().map(|a| a.pass.as_ref())
    }
}

/// The passes that run only for some frames: the game's depth in, the output out.
#[derive(Default)]
struct Edges {
    depth_import: Option<DepthImportPass>,
    depth_out: Option<DepthOutPass>,
    tonemap: Option<TonemapPass>,
    composite: Option<CompositePass>,
    upscaler_out: Option<crate::passes::upscaler_out::UpscalerOutPass>,
}

/// hadou's passes, scene data and images on one device. See the module docs for the frame contract.
///
/// Dropping it frees everything hadou created, after `vkDeviceWaitIdle` (teardown); the context
/// it was made with (owning or `from_raw`) is dropped last.
pub struct Renderer {
    loaded: Option<Loaded>,
    /// Per view (`record_views`; one for `record_frame`): its images.
    targets: Vec<Targets>,
    edges: Edges,
    /// Per frame slot, a slot per view its frames recorded (the first is `record_frame`'s). The
    /// passes see view v of frame slot i as slot i + frames_in_flight·v (`slot_index`).
    slots: Vec<Vec<Slot>>,
    /// The number the next recorded frame gets.
    next_frame: u64,
    /// The frame slot of the frame recorded last (where a read-back recorded after it goes).
    current: Option<usize>,
    /// The views the frame recorded last recorded (a 0 × 0 view is skipped).
    current_views: Vec<usize>,
    /// The sub-pixel jitter of the frames (`set_jitter`), in pixels.
    jitter: glam::DVec2,
    /// The images the host reads back after a frame (`set_readbacks`); None: any. And those the
    /// frame recorded last was recorded for (what its read-backs may copy).
    readbacks: Option<Vec<Target>>,
    current_readbacks: Option<Vec<Target>>,
    /// Frames up to this one are known to have finished.
    finished_through: Option<u64>,
    latest: Option<FinishedFrame>,
    /// The frame budget: its setting, its cost model, the levels frames were recorded with.
    budget: budget::FrameBudget,
    effects: Effects,
    compiler: ShaderCompiler,
    pipeline_cache: Option<PipelineCache>,
    memory: Memory,
    ctx: GpuContext,
}

impl Renderer {
    /// A renderer with no scene on `ctx` (from `GpuContext::new` or `GpuContext::from_raw`), with
    /// the default options (2 frames in flight).
    pub fn new(ctx: GpuContext) -> Result<Self, Error> {
        Self::with_options(ctx, &RendererOptions::default())
    }

    /// A renderer with no scene on `ctx`; `Error::FramesInFlight` when `options.frames_in_flight`
    /// is outside 1..=`MAX_FRAMES_IN_FLIGHT`.
    pub fn with_options(ctx: GpuContext, options: &RendererOptions) -> Result<Self, Error> {
        let n = options.frames_in_flight;
        if !(1..=MAX_FRAMES_IN_FLIGHT).contains(&n) {
            return Err(Error::FramesInFlight(n));
        }
        if let Some(ms) = options.frame_budget_ms.filter(|ms| !crate::budget::BUDGET_RANGE_MS.contains(ms)) {
            return Err(Error::InvalidUpdate {
                what: format!("RendererOptions::frame_budget_ms {ms}"),
                expected: "a number of milliseconds in [0.001, 1000000]".into(),
            });
        }
        let memory = Memory::new(&ctx)?;
        let compiler = ShaderCompiler::new(crate::passes::SHADERS)?;
        let dir = options.pipeline_cache_dir.clone().or_else(crate::effects::bake_cache::default_cache_dir);
        let pipeline_cache = PipelineCache::open(&ctx, dir.as_deref())?;
        ctx.set_pipeline_cache(pipeline_cache.raw);
        let slots = (0..n).map(|i| Ok(vec![Slot::new(&ctx, i)?])).collect::<Result<Vec<_>, Error>>()?;
        Ok(Renderer {
            loaded: None,
            targets: Vec::new(),
            edges: Edges::default(),
            slots,
            next_frame: 0,
            current: None,
            current_views: Vec::new(),
            jitter: glam::DVec2::ZERO,
            readbacks: None,
            current_readbacks: None,
            finished_through: None,
            latest: None,
            budget: budget::FrameBudget::new(options.frame_budget_ms),
            effects: options.effects.clone(),
            compiler,
            pipeline_cache: Some(pipeline_cache),
            memory,
            ctx,
        })
    }

    /// The Vulkan context it records with.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The number the next recorded frame gets (`RecordedFrame::frame`).
    pub fn next_frame(&self) -> u64 {
        self.next_frame
    }

    /// Its number of frame slots (`RendererOptions::frames_in_flight`).
    pub fn frames_in_flight(&self) -> usize {
        self.slots.len()
    }

    /// The loaded scene; None before `load_scene`.
    pub fn scene(&self) -> Option<&Scene> {
        self.loaded.as_ref().map(|l| &l.scene)
    }

    /// The loaded scene's instanced draws (one per mesh with instances) and its mesh buffer pairs.
    pub fn draws(&self) -> (Vec<crate::scene_gpu::Draw>, usize) {
        self.loaded.as_ref().map_or((Vec::new(), 0), |l| (l.gpu.draws.clone(), l.gpu.meshes.len()))
    }

    /// The scene passes the loaded scene runs, in order, and the output pass of a headless frame.
    pub fn pass_names(&self) -> Vec<&'static str> {
        let Some(l) = &self.loaded else { return Vec::new() };
        l.pass_list().map(|p| p.name()).chain(["tonemap"]).collect()
    }

    /// Whether the frame recorded last holds `target` — one of its passes declared it — so
    /// `record_aov_readback` after it can copy it (the headless colour always can). Before any
    /// frame, nothing else: a pass declares the images it binds when it prepares a frame.
    pub fn produces(&self, target: Target) -> bool {
        target == Target::Ldr || self.targets.first().is_some_and(|t| t.contains(target))
    }

    /// Declares the AOVs the following frames will read back (`record_aov_readback`,
    /// `record_view_aov_readback`): an AOV nothing else reads is then not written when it is not
    /// among them (the energy wave's `energy`: a storage-image store per pixel). Reading back an
    /// AOV not declared is refused (`Error::NotProduced`). `None` (the default): any AOV may be
    /// read back, and every one the passes produce is written.
    pub fn set_readbacks(&mut self, aovs: Option<&[crate::Aov]>) {
        self.readbacks = aovs.map(|a| a.iter().map(|a| a.target()).collect());
    }

    /// Uploads the scene and builds the passes it needs (pipelines are built here, through the
    /// pipeline cache; only the depth-import and composite pipelines of an embedded frame wait
    /// for the first frame that brings an external depth or colour target, and no later frame,
    /// update or resize builds one — `tests/embedding.rs` counts), replacing any scene loaded
    /// before. The old scene's
    /// objects are retired with the frames that may still use them: no device wait. Baked tables
    /// are uploaded through a one-off command buffer on the context's queue, waited for by its
    /// own fence: call it while nothing else submits to that queue.
    pub fn load_scene(&mut self, scene: Scene) -> Result<(), Error> {
        self.effects.check_scene(&scene)?;
        self.reset_budget();
        let gpu = SceneGpu::new(&self.ctx, &self.memory, &scene)?;
        let mut passes = ScenePasses::default();
        passes.sync(&self.ctx, &self.memory, &mut self.compiler, &self.effects, &scene)?;
        let wave_ids = (0..scene.waves().len()).map(|_| self.next_id()).collect();
        let group_ids = (0..scene.metaballs().len()).map(|_| self.next_id()).collect();
        let instance_ids = (0..scene.instances.len()).map(|_| self.next_id()).collect();
        let light_ids = (0..scene.lights.len()).map(|_| self.next_id()).collect();
        let material_ids = (0..scene.materials.len()).map(|_| self.next_id()).collect();
        let mesh_ids = (0..scene.meshes.len()).map(|_| self.next_id()).collect();
        self.loaded = Some(Loaded {
            scene,
            gpu,
            passes,
            wave_ids,
            group_ids,
            instance_ids,
            light_ids,
            material_ids,
            mesh_ids,
            bakes: Default::default(),
            tables_dirty: false,
            wobble: deform::WobbleState::default(),
            game_projection: None,
            prev_models: Default::default(),
            prev_cameras: Vec::new(),
        });
        if let Some(l) = &mut self.loaded {
            l.wobble = deform::WobbleState::new(&l.scene);
        }
        Ok(())
    }

    /// Builds what the first frame of `inputs` needs (the output pass, the depth import, the
    /// frame's images), so that frame does not pay for it.
    pub fn prepare(&mut self, inputs: &FrameInputs) -> Result<(), Error> {
        self.check_inputs(inputs)?;
        self.ensure_edges(inputs)?;
        let targets = view_targets(&mut self.targets, 0, inputs.extent);
        let Some(loaded) = &self.loaded else { return Ok(()) };
        let edges = [
            self.edges.depth_import.as_ref().filter(|_| inputs.depth.is_some()).map(|p| p as &dyn Pass),
            self.edges.tonemap.as_ref().filter(|_| inputs.color.is_none()).map(|p| p as &dyn Pass),
            self.edges.composite.as_ref().filter(|_| inputs.color.is_some()).map(|p| p as &dyn Pass),
        ];
        let passes = loaded.pass_list().chain(edges.into_iter().flatten());
        for pass in passes {
            for image in pass.images() {
                targets.ensure(&self.ctx, &self.memory, image.target, image.extent)?;
            }
        }
        Ok(())
    }

    /// Tells hadou that frame `frame` (and every one before it) has finished on the GPU: its
    /// timings and device counters are read, and what was retired with it is freed. Optional (the
    /// frame contract implies it `frames_in_flight` frames later); it never waits.
    pub fn frame_finished(&mut self, frame: u64) -> Result<(), Error> {
        if frame >= self.next_frame {
            return Err(Error::FrameNotRecorded { frame, recorded: self.next_frame });
        }
        if self.finished_through.is_some_and(|f| f >= frame) {
            return Ok(());
        }
        self.finished_through = Some(frame);
        let in_flight = self.slots.len();
        let passes: Vec<&dyn Pass> = self.loaded.iter().flat_map(|l| l.pass_list()).collect();
        for (i, views) in self.slots.iter_mut().enumerate() {
            // A frame slot's views all hold the same frame (each began with it).
            let mut stats = crate::frame::FrameStats::default();
            let mut done = None;
            for (v, slot) in views.iter_mut().enumerate() {
                done = slot.finish(slot_index(i, v, in_flight), v, frame, &passes, &mut stats).or(done);
            }
            if let Some(done) = done {
                self.budget.observe(done, &stats);
                if self.latest.as_ref().is_none_or(|l| l.frame < done) {
                    self.latest = Some(FinishedFrame { frame: done, stats });
                }
            }
        }
        self.ctx.frames_finished(frame);
        Ok(())
    }

    /// The per-pass GPU times of the newest frame known to have finished (see `frame_finished`);
    /// None until one has. Never touches the device.
    pub fn latest_timings(&self) -> Option<FrameTimings> {
        self.latest.as_ref().map(|l| l.timings())
    }

    /// What the device counted in the newest frame known to have finished (metaball statistics),
    /// with its timings.
    pub fn latest_stats(&self) -> Option<(u64, crate::frame::FrameStats)> {
        self.latest.as_ref().map(|l| (l.frame, l.stats.clone()))
    }

    /// Tells hadou the command buffer of the frame just recorded will not be submitted (an error
    /// after `record_frame`): its timestamps are not waited for.
    pub fn abandon_frame(&mut self) {
        if let Some(i) = self.current.take() {
            self.slots[i].iter_mut().for_each(Slot::abandon);
        }
    }

    /// Validation results of the owning context (zero for `from_raw`: the game's messenger counts).
    pub fn validation_counts(&self) -> crate::gpu::ValidationCounts {
        self.ctx.validation_counts()
    }

    /// The shader compiler, for code that builds pipelines next to hadou's (tests, the report).
    pub(crate) fn parts(&mut self) -> (&GpuContext, &Memory, &mut ShaderCompiler) {
        (&self.ctx, &self.memory, &mut self.compiler)
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        // Teardown: the only device wait. Everything hadou made is retired, then freed.
        let _ = self.ctx.wait_idle();
        if let Some(cache) = &self.pipeline_cache {
            // Registered: SIGINT/SIGTERM during the save removes its temporary.
            cache.save(&crate::output::interrupt::write_through_temporary);
        }
        self.loaded = None;
        self.targets.clear();
        self.edges = Edges::default();
        self.slots.clear();
        self.ctx.set_pipeline_cache(Default::default());
        self.pipeline_cache = None;
        self.ctx.destroy_retired();
        // The context (the last field) is dropped after this.
    }
}

/// The slot the passes see for view `view` of frame slot `frame_slot` (`FrameContext::slot`).
fn slot_index(frame_slot: usize, view: usize, frames_in_flight: usize) -> usize {
    frame_slot + frames_in_flight * view
}

/// View `view`'s images, made on its first frame, sized for this one.
fn view_targets(targets: &mut Vec<Targets>, view: usize, extent: crate::gpu::vk::Extent2D) -> &mut Targets {
    while targets.len() <= view {
        targets.push(Targets::new(extent));
    }
    let t = &mut targets[view];
    t.extent = extent;
    t
}

#[cfg(test)]
mod send_check {
    /// A game keeps its renderer on a render thread or in an ECS resource.
    #[test]
    fn renderer_is_send() {
        fn send<T: Send>() {}
        send::<super::Renderer>();
        send::<crate::Runtime>();
    }
}
