//! Builds the pass list the scene needs and runs it. Every pass is wrapped the same way:
//! debug label, barriers, timestamp pair (kajiya's record_pass_cb).

use std::time::Instant;

use gpu_allocator::MemoryLocation;

use crate::gpu::barriers::{cmd_barriers, memory_barrier, ImageAccess};
use crate::gpu::commands::FrameCommands;
use crate::gpu::memory::{Buffer, Memory};
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
    // The light's view of the translucent instances (it does not read the raster's images).
    let translucent = translucency::needed(scene);
    if translucent {
        kinds.push(PassKind::LightId);
    }
    // After the raster (depth-tested against it), before the wave (which the metaballs clip).
    if !scene.metaballs.is_empty() {
        kinds.push(PassKind::Metaballs);
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

pub struct FrameRunner {
    commands: FrameCommands,
    timestamps: TimestampPool,
}

/// A target copied to a host-visible buffer at the end of the frame.
pub struct Readback {
    pub target: Target,
    pub buffer: Buffer,
}

impl FrameRunner {
    pub fn new(ctx: &GpuContext) -> GpuResult<Self> {
        let commands = FrameCommands::new(ctx, "frame")?;
        match TimestampPool::new(ctx, 64) {
            Ok(timestamps) => Ok(FrameRunner { commands, timestamps }),
            Err(e) => {
                commands.destroy(ctx);
                Err(e)
            }
        }
    }

    /// Records, submits and waits for one frame; returns its stats and the requested read-backs.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &mut self,
        ctx: &GpuContext,
        memory: &Memory,
        passes: &mut [Box<dyn Pass>],
        targets: &mut Targets,
        scene_gpu: &SceneGpu,
        scene: &Scene,
        time: f64,
        readback: &[Target],
    ) -> GpuResult<(FrameStats, Vec<Readback>)> {
        let frame_start = Instant::now();
        for pass in passes.iter_mut() {
            pass.prepare(scene, time, targets.extent)?;
            pass.prepare_device(ctx, memory)?;
        }
        let mut buffers = Vec::new();
        for &target in readback {
            let e = targets.extent;
            let size = e.width as u64 * e.height as u64 * target.texel_bytes();
            let name = format!("readback {}", target.name());
            match memory.create_buffer(
                ctx,
                &name,
                size,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            ) {
                Ok(buffer) => buffers.push(Readback { target, buffer }),
                Err(e) => {
                    buffers.into_iter().for_each(|r: Readback| memory.destroy_buffer(ctx, r.buffer));
                    return Err(e);
                }
            }
        }
        let result = self.record_and_submit(ctx, passes, targets, scene_gpu, scene, time, &buffers);
        match result {
            Ok(mut stats) => {
                passes.iter().for_each(|p| p.report(&mut stats));
                stats.cpu_frame_ms = ms(frame_start.elapsed());
                Ok((stats, buffers))
            }
            Err(e) => {
                buffers.into_iter().for_each(|r| memory.destroy_buffer(ctx, r.buffer));
                Err(e)
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn record_and_submit(
        &mut self,
        ctx: &GpuContext,
        passes: &[Box<dyn Pass>],
        targets: &mut Targets,
        scene_gpu: &SceneGpu,
        scene: &Scene,
        time: f64,
        readback: &[Readback],
    ) -> GpuResult<FrameStats> {
        let record_start = Instant::now();
        let cmd = self.commands.cmd;
        self.commands.begin(ctx)?;
        self.timestamps.reset(ctx, cmd);
        targets.discard_all();
        let rec = Recorder { ctx, cmd };
        let mut scopes: Vec<(&str, Option<u32>, Option<u32>)> = Vec::new();
        for pass in passes {
            let barriers: Vec<_> =
                pass.uses().into_iter().filter_map(|(t, access)| targets.transition(t, access)).collect();
            ctx.begin_label(cmd, pass.name());
            cmd_barriers(&ctx.device, cmd, &barriers, &[]);
            let begin = self.timestamps.write(ctx, cmd);
            pass.record(&PassInputs { rec: &rec, targets, scene_gpu, scene, time });
            let end = self.timestamps.write(ctx, cmd);
            ctx.end_label(cmd);
            scopes.push((pass.name(), begin, end));
        }
        if !readback.is_empty() {
            ctx.begin_label(cmd, "readback");
            let barriers: Vec<_> = readback
                .iter()
                .filter_map(|r| targets.transition(r.target, ImageAccess::TRANSFER_SRC))
                .collect();
            cmd_barriers(&ctx.device, cmd, &barriers, &[]);
            let begin = self.timestamps.write(ctx, cmd);
            for r in readback {
                rec.copy_image_to_buffer(targets.image(r.target), &r.buffer);
            }
            let to_host = memory_barrier(
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_WRITE,
                vk::PipelineStageFlags2::HOST,
                vk::AccessFlags2::HOST_READ,
            );
            cmd_barriers(&ctx.device, cmd, &[], &[to_host]);
            let end = self.timestamps.write(ctx, cmd);
            ctx.end_label(cmd);
            scopes.push(("readback", begin, end));
        }
        let cpu_record_ms = ms(record_start.elapsed());
        let submit_start = Instant::now();
        let last_pass = scopes.last().map(|s| s.0).unwrap_or("none");
        self.commands.submit_and_wait(ctx, last_pass)?;
        let cpu_submit_wait_ms = ms(submit_start.elapsed());
        let ticks = self.timestamps.read_ns(ctx)?;
        let at = |i: Option<u32>| i.and_then(|i| ticks.get(i as usize).copied());
        let mut stats = FrameStats { cpu_record_ms, cpu_submit_wait_ms, ..Default::default() };
        let first = ticks.first().copied().unwrap_or(0.0);
        for (name, begin, end) in &scopes {
            if let (Some(b), Some(e)) = (at(*begin), at(*end)) {
                stats.passes.push(PassTiming {
                    name: name.to_string(),
                    start_ms: (b - first).max(0.0) / 1e6,
                    gpu_ms: (e - b).max(0.0) / 1e6,
                });
            }
        }
        if let Some(last) = ticks.last() {
            stats.gpu_frame_ms = (last - first).max(0.0) / 1e6;
        }
        Ok(stats)
    }

    pub fn destroy(&self, ctx: &GpuContext) {
        self.timestamps.destroy(ctx);
        self.commands.destroy(ctx);
    }
}

fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}
