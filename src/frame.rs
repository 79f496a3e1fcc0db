//! Builds the pass list the scene needs and records it. Every pass is wrapped the same way:
//! debug label, barriers, timestamp pair (kajiya's record_pass_cb). Recording only: the caller
//! (the headless `Runtime` or a game embedding `renderer::Renderer`) submits and waits.

use crate::gpu::barriers::cmd_barriers;
use crate::gpu::memory::Memory;
use crate::gpu::recorder::Recorder;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::timestamps::TimestampPool;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::passes::energy_wave::EnergyWavePass;
use crate::passes::light_id::LightIdPass;
use crate::passes::metaballs::MetaballsPass;
use crate::passes::raster::RasterPass;
use crate::passes::tonemap::TonemapPass;
use crate::passes::translucency::{self, shared_data, TranslucencyPass};
use crate::passes::{Pass, PassInputs};
use crate::scene::Scene;
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};

/// The passes a frame runs, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    Raster,
    LightId,
    Metaballs,
    Translucency,
    EnergyWave,
    Tonemap,
}

/// Only the passes this scene needs.
pub fn plan(scene: &Scene) -> Vec<PassKind> {
    // The raster always runs: it clears the G-buffer every later pass reads, even with no instances.
    let mut kinds = vec![PassKind::Raster];
    // After the raster (depth-tested against it), before the wave (which the metaballs clip).
    // Right after the raster, whose images it binds: on lavapipe a dispatch waits only for the
    // render passes that wrote what it binds, and timestamps are written by the rasterizer, so
    // after light_id (which it does not read) the dispatch would overlap light_id's rasterizing
    // and its timestamps would straddle the wrong work (measured: 0.06 ms for a 2.9 ms pass).
    if !scene.metaballs.is_empty() {
        kinds.push(PassKind::Metaballs);
    }
    // The light's view of the translucent instances (it does not read the raster's images).
    let translucent = translucency::needed(scene);
    if translucent {
        kinds.push(PassKind::LightId);
    }
    // Reads the G-buffer the raster and the metaballs wrote; before the wave, which adds on top.
    if translucent {
        kinds.push(PassKind::Translucency);
    }
    if !scene.waves.is_empty() {
        kinds.push(PassKind::EnergyWave);
    }
    kinds.push(PassKind::Tonemap);
    kinds
}

fn boxed<P: Pass + 'static>(pass: GpuResult<P>) -> GpuResult<Box<dyn Pass>> {
    pass.map(|p| Box::new(p) as Box<dyn Pass>)
}

pub fn build_passes(
    ctx: &GpuContext,
    memory: &Memory,
    compiler: &mut ShaderCompiler,
    scene: &Scene,
    kinds: &[PassKind],
) -> GpuResult<Vec<Box<dyn Pass>>> {
    let mut passes: Vec<Box<dyn Pass>> = Vec::new();
    // One bake and upload of the thickness LUTs, shared by light_id and translucency.
    let mut translucent = None;
    for kind in kinds {
        let pass = match kind {
            PassKind::Raster => boxed(RasterPass::new(ctx, compiler)),
            PassKind::LightId => shared_data(&mut translucent, ctx, memory, scene)
                .and_then(|d| boxed(LightIdPass::new(ctx, memory, compiler, d))),
            PassKind::Metaballs => boxed(MetaballsPass::new(ctx, memory, compiler, scene)),
            PassKind::Translucency => shared_data(&mut translucent, ctx, memory, scene)
                .and_then(|d| boxed(TranslucencyPass::new(ctx, memory, compiler, d))),
            PassKind::EnergyWave => boxed(EnergyWavePass::new(ctx, memory, compiler, scene)),
            PassKind::Tonemap => boxed(TonemapPass::new(ctx, compiler)),
        };
        match pass {
            Ok(p) => passes.push(p),
            Err(e) => {
                passes.iter_mut().for_each(|p| p.destroy(ctx, memory));
                translucency::release(translucent, ctx, memory);
                return Err(e);
            }
        }
    }
    // The passes hold their own references.
    translucency::release(translucent, ctx, memory);
    Ok(passes)
}

/// The images the passes touch: only these are created.
pub fn targets_used(passes: &[Box<dyn Pass>]) -> Vec<Target> {
    let mut used: Vec<Target> = passes.iter().flat_map(|p| p.uses()).map(|(t, _)| t).collect();
    used.sort();
    used.dedup();
    used
}

/// GPU time of one pass in one frame.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PassTiming {
    pub name: String,
    /// Start, from the frame's first timestamp.
    pub start_ms: f64,
    pub gpu_ms: f64,
}

/// What one frame cost.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FrameStats {
    pub passes: Vec<PassTiming>,
    /// GPU time from the first pass's start to the last one's end.
    pub gpu_frame_ms: f64,
    /// CPU time to record the command buffer.
    pub cpu_record_ms: f64,
    /// CPU time from submit until the fence signalled.
    pub cpu_submit_wait_ms: f64,
    /// Whole frame on the CPU: uniforms, record, submit, wait, read-back.
    pub cpu_frame_ms: f64,
    /// metaballs: pixels whose cast could not finish (more than 32 support spheres overlap at a
    /// point, or the clipping did not converge): a surface may be missing there (logged).
    pub metaball_overflow: u64,
    /// metaballs: pixels where a metaball is the nearest surface, and the Bézier-clipping steps
    /// their casts spent (sum, max).
    pub metaball_hits: u64,
    pub metaball_clip_steps: u64,
    pub metaball_clip_steps_max: u64,
}

/// One timestamped stretch of a frame (a pass, the depth import, the composite, the read-back).
#[derive(Clone, Copy, Debug)]
pub struct Scope {
    pub name: &'static str,
    pub begin: Option<u32>,
    pub end: Option<u32>,
}

/// Where a frame's timestamps go: `None` when no query pool was free (the frame is then untimed).
pub type Timestamps<'a> = Option<&'a mut TimestampPool>;

/// Records `body` inside the debug label `name`, after `barriers`, between two timestamps.
pub fn record_scope(
    ctx: &GpuContext,
    cmd: vk::CommandBuffer,
    timestamps: &mut Timestamps,
    name: &'static str,
    barriers: &[vk::ImageMemoryBarrier2],
    body: impl FnOnce(),
) -> Scope {
    ctx.begin_label(cmd, name);
    cmd_barriers(&ctx.device, cmd, barriers, &[]);
    let begin = timestamps.as_mut().and_then(|t| t.write(ctx, cmd));
    body();
    let end = timestamps.as_mut().and_then(|t| t.write(ctx, cmd));
    ctx.end_label(cmd);
    Scope { name, begin, end }
}

/// What recording the scene's passes needs.
pub struct PassRecording<'a> {
    pub ctx: &'a GpuContext,
    pub cmd: vk::CommandBuffer,
    pub passes: &'a [Box<dyn Pass>],
    pub targets: &'a mut Targets,
    pub scene_gpu: &'a SceneGpu,
    pub scene: &'a Scene,
    pub time: f64,
    /// See `PassInputs::embedded` and `PassInputs::depth_imported`.
    pub embedded: bool,
    pub depth_imported: bool,
    /// Passes not to record this frame (e.g. tonemap when the game's colour is the output).
    pub skip: &'a [&'static str],
}

/// Records every pass of the frame, each as one scope.
pub fn record_passes(r: PassRecording, timestamps: &mut Timestamps, scopes: &mut Vec<Scope>) {
    let rec = Recorder { ctx: r.ctx, cmd: r.cmd };
    for pass in r.passes.iter().filter(|p| !r.skip.contains(&p.name())) {
        let barriers: Vec<_> =
            pass.uses().into_iter().filter_map(|(t, access)| r.targets.transition(t, access)).collect();
        let inputs = PassInputs {
            rec: &rec,
            targets: r.targets,
            scene_gpu: r.scene_gpu,
            scene: r.scene,
            time: r.time,
            embedded: r.embedded,
            depth_imported: r.depth_imported,
        };
        scopes.push(record_scope(r.ctx, r.cmd, timestamps, pass.name(), &barriers, || pass.record(&inputs)));
    }
}

/// Per-scope GPU times from the frame's timestamps (nanoseconds, in write order).
pub fn pass_timings(scopes: &[Scope], ticks: &[f64]) -> (Vec<PassTiming>, f64) {
    let at = |i: Option<u32>| i.and_then(|i| ticks.get(i as usize).copied());
    let first = ticks.first().copied().unwrap_or(0.0);
    let mut passes = Vec::new();
    for scope in scopes {
        if let (Some(b), Some(e)) = (at(scope.begin), at(scope.end)) {
            passes.push(PassTiming {
                name: scope.name.to_string(),
                start_ms: (b - first).max(0.0) / 1e6,
                gpu_ms: (e - b).max(0.0) / 1e6,
            });
        }
    }
    let frame_ms = ticks.last().map(|last| (last - first).max(0.0) / 1e6).unwrap_or(0.0);
    (passes, frame_ms)
}

pub fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}
