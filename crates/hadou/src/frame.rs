//! The pass runner: records a frame's passes into a command buffer. Every pass is wrapped the
//! same way (kajiya's record_pass_cb): the images it declared made and transitioned, the buffers
//! it writes ordered against their readers, its descriptor set allocated from the slot's pool and
//! written from its bindings, then debug label and timestamp pair around its commands. The runner
//! knows nothing of any particular pass. Recording only: the caller submits.

use crate::gpu::barriers::{cmd_barriers, memory_barrier};
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::{bind_set, Bound, BufferRange, DescriptorPool};
use crate::gpu::recorder::Recorder;
use crate::gpu::ring::{TexelView, UploadRing};
use crate::gpu::timestamps::TimestampPool;
use crate::gpu::{vk, GpuContext};
use crate::passes::{Binding, FrameContext, ImageUse, Pass, PassRecording, Reader};
use crate::scene::Scene;
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};

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
    /// What passes counted on the device this frame, by name (`"metaballs.dropped"`, ...; see
    /// each pass's docs), in the order they were first reported.
    pub counters: Vec<(&'static str, u64)>,
}

impl FrameStats {
    /// The counter `name` (0 when no pass reported it this frame).
    pub fn counter(&self, name: &str) -> u64 {
        self.counters.iter().find(|(n, _)| *n == name).map_or(0, |(_, v)| *v)
    }

    /// Adds `value` to the counter `name` (a pass reporting after its frame finished).
    pub fn add(&mut self, name: &'static str, value: u64) {
        match self.counters.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => *v += value,
            None => self.counters.push((name, value)),
        }
    }

    /// Raises the counter `name` to at least `value`.
    pub fn max(&mut self, name: &'static str, value: u64) {
        match self.counters.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => *v = (*v).max(value),
            None => self.counters.push((name, value)),
        }
    }
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

/// A frame being recorded into one slot.
pub(crate) struct SlotFrame<'a> {
    pub ctx: &'a GpuContext,
    pub memory: &'a Memory,
    pub cmd: vk::CommandBuffer,
    pub slot: usize,
    /// The view of the frame (`FrameContext::view`).
    pub view: usize,
    /// The slot's descriptor pool, reset for this frame.
    pub pool: &'a DescriptorPool,
    pub ring: &'a mut UploadRing,
    pub targets: &'a mut Targets,
    pub scene: &'a Scene,
    pub scene_gpu: &'a SceneGpu,
    pub uniforms: BufferRange,
    pub instances: BufferRange,
    pub materials: BufferRange,
    pub time: f64,
    /// `effects::tonemap::pre_exposure` of the scene, once per frame.
    pub pre_exposure: f64,
    pub embedded: bool,
    pub depth_imported: bool,
    /// `PassRecording::host_reads`.
    pub host_reads: Option<&'a [Target]>,
    /// `FrameContext::motion`.
    pub motion: Option<crate::passes::MotionFrame>,
}

/// A prepared pass: its descriptor set and the buffers it writes.
struct Prepared {
    sets: Vec<vk::DescriptorSet>,
    written: Vec<(BufferRange, Reader)>,
    /// The images it declared this frame (`Pass::images`, asked once).
    uses: Vec<ImageUse>,
}

/// Records `passes` in order, each as one scope.
pub(crate) fn record_passes(
    f: &mut SlotFrame,
    passes: &mut [&mut dyn Pass],
    timestamps: &mut Timestamps,
    scopes: &mut Vec<Scope>,
) -> Result<(), crate::Error> {
    let extent = f.targets.extent;
    let mut views: Vec<TexelView> = Vec::new();
    let mut prepared = Vec::with_capacity(passes.len());
    for pass in passes.iter_mut() {
        let mut frame = FrameContext {
            ctx: f.ctx,
            memory: f.memory,
            scene: f.scene,
            scene_gpu: f.scene_gpu,
            uniforms: f.uniforms,
            instances: f.instances,
            materials: f.materials,
            time: f.time,
            pre_exposure: f.pre_exposure,
            extent,
            slot: f.slot,
            view: f.view,
            embedded: f.embedded,
            depth_imported: f.depth_imported,
            motion: f.motion,
            ring: &mut *f.ring,
            views: &mut views,
        };
        let bindings = pass.prepare(&mut frame)?;
        // Each image is declared once: by its binding, or in images() when no binding shows it.
        let uses = crate::effect::declared_images(&**pass, pass.images(), &bindings)?;
        // After prepare: a pass may size its images from this frame (the light maps).
        for image in &uses {
            f.targets.ensure(f.ctx, f.memory, image.target, image.extent)?;
        }
        let mut written = Vec::new();
        let bound: Vec<Bound> = bindings
            .iter()
            .map(|b| match *b {
                Binding::Image(u) => Bound::StorageImage(f.targets.image(u.target).view),
                Binding::SampledImage(u, sampler) => Bound::Sampled(f.targets.image(u.target).view, sampler),
                Binding::Bound(b) => b,
                Binding::Written(range, reader) => {
                    written.push((range, reader));
                    Bound::Storage(range)
                }
            })
            .collect();
        let sets = pass
            .pipelines()
            .into_iter()
            .map(|p| bind_set(f.ctx, f.pool, p, &bound))
            .collect::<Result<_, _>>()?;
        prepared.push(Prepared { sets, written, uses });
    }
    // The sets are written: the views may go (they are retired with the frame).
    drop(views);
    // Images no pass of this frame uses any more go (retired with the frame).
    let used: Vec<Target> = prepared.iter().flat_map(|p| p.uses.iter().map(|u| u.target)).collect();
    f.targets.retain_only(&used);
    // Before any command: a pass reading what no earlier pass writes refuses the frame.
    let names: Vec<&'static str> = passes.iter().map(|p| p.name()).collect();
    crate::effect::check_reads(names.iter().copied().zip(prepared.iter().map(|p| p.uses.as_slice())))?;
    let rec = Recorder { ctx: f.ctx, cmd: f.cmd };
    // Every pass's images, by pass, for `PassRecording::used_later_by`.
    let uses: Vec<(&'static str, Vec<Target>)> =
        names.iter().zip(&prepared).map(|(n, p)| (*n, p.uses.iter().map(|u| u.target).collect())).collect();
    for (index, (pass, p)) in passes.iter().zip(&prepared).enumerate() {
        // A history image with no previous frame to read is cleared to zeros first.
        let targets: Vec<Target> = p.uses.iter().map(|u| u.target).collect();
        f.targets.clear_fresh_history(&rec, &targets);
        let barriers: Vec<_> =
            p.uses.iter().filter_map(|u| f.targets.transition(u.target, u.access)).collect();
        let stage = match pass.pipelines().first().map(|p| p.bind_point) {
            Some(vk::PipelineBindPoint::COMPUTE) => vk::PipelineStageFlags2::COMPUTE_SHADER,
            _ => vk::PipelineStageFlags2::ALL_GRAPHICS,
        };
        let write = vk::AccessFlags2::SHADER_STORAGE_WRITE;
        // Written buffers: wait for their readers in earlier frames (write after read).
        let before: Vec<_> = p
            .written
            .iter()
            .map(|(_, reader)| memory_barrier(reader.stage().0, vk::AccessFlags2::NONE, stage, write))
            .collect();
        let recording = PassRecording {
            rec: &rec,
            targets: f.targets,
            scene_gpu: f.scene_gpu,
            scene: f.scene,
            sets: p.sets.clone(),
            pre_exposure: f.pre_exposure,
            embedded: f.embedded,
            depth_imported: f.depth_imported,
            later: &uses[index + 1..],
            host_reads: f.host_reads,
        };
        scopes.push(record_scope(f.ctx, f.cmd, timestamps, pass.name(), &barriers, || {
            cmd_barriers(&f.ctx.device, f.cmd, &[], &before);
            pass.record(&recording);
            // Host readers see the writes after the frame's fence.
            let after: Vec<_> = p
                .written
                .iter()
                .filter(|(_, r)| *r == Reader::Host)
                .map(|(_, r)| memory_barrier(stage, write, r.stage().0, r.stage().1))
                .collect();
            cmd_barriers(&f.ctx.device, f.cmd, &[], &after);
        }));
    }
    Ok(())
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
