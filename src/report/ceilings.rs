//! The device's ceilings: a pure-FMA kernel (GFLOP/s) and a buffer copy (GB/s), each timed with
//! GPU timestamps around its dispatch, so each effect pass can be read as a fraction of what the
//! device does at best. The ceiling is the best of the runs (the least disturbed), p50 is shown
//! beside it.

use crate::gpu::memory::MemoryLocation;

use crate::gpu::barriers::{cmd_barriers, memory_barrier};
use crate::gpu::commands::FrameCommands;
use crate::gpu::memory::{Buffer, Memory};
use crate::gpu::pipeline::{
    create_compute_pipeline, write_set, Bound, BufferRange, DescriptorPool, Pipeline,
};
use crate::gpu::recorder::Recorder;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::timestamps::TimestampPool;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::profile::Summary;
use crate::Runtime;

use super::table::{Cell, Fmt, Table};
use super::{ReportOptions, Section, Steps};

/// FLOP per invocation per loop round of shaders/ceiling_fma.comp: 256 steps of 2 vec4 FMAs.
const FLOP_PER_ROUND: f64 = 256.0 * 2.0 * 4.0 * 2.0;
/// Invocations of the FMA kernel: enough to fill a large GPU (an H100 holds ~270 000 resident
/// invocations), far more than a CPU's cores need.
const FMA_INVOCATIONS: u32 = 1 << 20;
/// vec4s each invocation of shaders/ceiling_copy.comp copies.
const COPIES_PER_INVOCATION: u64 = 16;

/// The measured ceilings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ceilings {
    /// Best GFLOP/s of the FMA kernel.
    pub gflops: f64,
    /// Best GB/s (10⁹ bytes read + written per second) of the copy kernel.
    pub gbps: f64,
}

/// One kernel's runs.
struct Runs {
    ms: Vec<f64>,
    work: f64,
}

impl Runs {
    fn best_rate(&self) -> f64 {
        self.ms.iter().map(|ms| self.work / (ms * 1e-3) / 1e9).fold(0.0, f64::max)
    }
}

/// Records `dispatch` between two timestamps `runs` times (one submission each) and returns the
/// GPU milliseconds of each.
fn time_runs(
    ctx: &GpuContext,
    pipeline: &Pipeline,
    set: vk::DescriptorSet,
    push: &[u8],
    groups: (u32, u32),
    runs: usize,
) -> GpuResult<Vec<f64>> {
    let mut commands = FrameCommands::new(ctx, "ceiling")?;
    let mut stamps = TimestampPool::new(ctx, 2)?;
    let mut out = Vec::with_capacity(runs);
    for _ in 0..runs {
        commands.begin(ctx)?;
        let cmd = commands.cmd;
        stamps.reset(ctx, cmd);
        // The previous run wrote the same buffer: order the writes.
        let write = vk::AccessFlags2::SHADER_STORAGE_WRITE | vk::AccessFlags2::SHADER_STORAGE_READ;
        let stage = vk::PipelineStageFlags2::COMPUTE_SHADER;
        cmd_barriers(&ctx.device, cmd, &[], &[memory_barrier(stage, write, stage, write)]);
        let rec = Recorder { ctx, cmd };
        ctx.begin_label(cmd, &pipeline.name);
        rec.bind_pipeline(pipeline, set);
        rec.push_constants(pipeline, push);
        stamps.write(ctx, cmd);
        rec.dispatch_groups(groups.0, groups.1);
        stamps.write(ctx, cmd);
        ctx.end_label(cmd);
        commands.submit_and_wait(ctx, &pipeline.name)?;
        // The fence signalled: the timestamps are there.
        let ns = stamps.try_read_ns(ctx)?.unwrap_or_default();
        if let [begin, end] = ns[..] {
            out.push((end - begin) * 1e-6);
        }
    }
    Ok(out)
}

/// One ceiling kernel: its shader, the sizes of its storage buffers (bindings 0..), its push
/// constants and its dispatch.
struct Kernel<'a> {
    shader: &'a str,
    buffer_bytes: &'a [u64],
    push: &'a [u8],
    groups: (u32, u32),
}

/// Builds `kernel`, runs it `runs` times, frees everything.
fn run_kernel(
    ctx: &GpuContext,
    memory: &Memory,
    compiler: &mut ShaderCompiler,
    kernel: &Kernel,
    runs: usize,
) -> GpuResult<Vec<f64>> {
    let Kernel { shader, buffer_bytes, push, groups } = *kernel;
    let spirv = compiler.compile(shader, &[])?;
    let pipeline = create_compute_pipeline(ctx, shader, &spirv, push.len() as u32)?;
    let mut buffers: Vec<Buffer> = Vec::new();
    for (i, &bytes) in buffer_bytes.iter().enumerate() {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let name = format!("{shader} buffer {i}");
        buffers.push(memory.create_buffer(ctx, &name, bytes, usage, MemoryLocation::GpuOnly)?);
    }
    let pool = DescriptorPool::new(ctx, "ceiling descriptors", 1)?;
    let set = pool.allocate(ctx, pipeline.set_layout, shader)?;
    let bound: Vec<(u32, Bound)> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| (i as u32, Bound::Storage(BufferRange::whole(b.raw))))
        .collect();
    write_set(ctx, set, &bound);
    time_runs(ctx, &pipeline, set, push, groups, runs)
}

/// Loop rounds of the FMA kernel: 4.3 GFLOP (quick) or 34 GFLOP per run.
fn fma_iterations(quick: bool) -> u32 {
    if quick {
        1
    } else {
        8
    }
}

/// Measures both ceilings on the runtime's device.
fn measure(runtime: &Runtime, quick: bool, steps: &mut Steps) -> GpuResult<(Runs, Runs)> {
    let ctx = runtime.context();
    let memory = Memory::new(ctx)?;
    let mut compiler = ShaderCompiler::new(crate::passes::SHADERS)?;
    let runs = if quick { 3 } else { 10 };
    let iterations = fma_iterations(quick);
    steps.next("ceiling: FMA kernel");
    let push: [u32; 2] = [iterations, 0];
    let fma_ms = run_kernel(
        ctx,
        &memory,
        &mut compiler,
        &Kernel {
            shader: "ceiling_fma.comp",
            buffer_bytes: &[FMA_INVOCATIONS as u64 * 16],
            push: bytemuck::cast_slice(&push),
            groups: (FMA_INVOCATIONS / 64, 1),
        },
        runs + 1,
    )?;
    let fma =
        Runs { ms: fma_ms[1..].to_vec(), work: FMA_INVOCATIONS as f64 * iterations as f64 * FLOP_PER_ROUND };
    steps.next("ceiling: copy kernel");
    // Far larger than any CPU cache (lavapipe's memory is the host's).
    let bytes: u64 = if quick { 32 << 20 } else { 256 << 20 };
    // A whole number of groups of 64 invocations, each copying COPIES_PER_INVOCATION vec4s.
    let invocations = (bytes / 16 / COPIES_PER_INVOCATION) as u32;
    let copy_ms = run_kernel(
        ctx,
        &memory,
        &mut compiler,
        &Kernel {
            shader: "ceiling_copy.comp",
            buffer_bytes: &[bytes, bytes],
            push: bytemuck::bytes_of(&invocations),
            groups: (invocations / 64, 1),
        },
        runs + 1,
    )?;
    // The first run of each is left out: it pays for first touches of the memory and the JIT.
    let copy = Runs { ms: copy_ms[1..].to_vec(), work: 2.0 * bytes as f64 };
    Ok((fma, copy))
}

/// The ceilings section; its numbers are returned for the other sections' fractions.
pub fn section(
    runtime: &Runtime,
    opts: &ReportOptions,
    steps: &mut Steps,
) -> Result<(Section, Ceilings), super::ReportError> {
    let (fma, copy) = measure(runtime, opts.quick, steps)?;
    let iterations = fma_iterations(opts.quick);
    let mut table = Table::new(
        "ceilings",
        "Device ceilings",
        &["kernel", "runs", "ms p50", "best", "p50", "unit", "work per run"],
    );
    let row = |name: &str, r: &Runs, unit: &str, work: String| {
        let p50 = Summary::of(&r.ms).map_or(f64::NAN, |s| s.p50);
        vec![
            Cell::text(name),
            Cell::Num(r.ms.len() as f64, Fmt::Int),
            Cell::Num(p50, Fmt::Fixed(3)),
            Cell::Num(r.best_rate(), Fmt::Fixed(2)),
            Cell::Num(r.work / (p50 * 1e-3) / 1e9, Fmt::Fixed(2)),
            Cell::text(unit),
            Cell::text(work),
        ]
    };
    table.push(row("fma", &fma, "GFLOP/s", format!("{:.3e} FLOP", fma.work)));
    table.push(row("copy", &copy, "GB/s", format!("{:.3e} bytes read + written", copy.work)));
    let ceilings = Ceilings { gflops: fma.best_rate(), gbps: copy.best_rate() };
    let text = format!(
        "`shaders/ceiling_fma.comp`: {FMA_INVOCATIONS} invocations, each stepping 2 independent vec4 FMA \
         chains 256 times per loop round, written out (4096 FLOP per round, {iterations} rounds; FMA = 2 FLOP). \
         `shaders/ceiling_copy.comp`: \
         {COPIES_PER_INVOCATION} vec4s read and written per invocation, strided so neighbours touch \
         neighbouring memory, buffers of {:.0} MiB each. Times are GPU timestamps around the dispatch; the first run \
         of each kernel is discarded (shader JIT, first touch of the memory); the ceiling is the best run.\n\n\
         The other sections read each pass against these: achieved GFLOP/s = FLOP per pixel × pixels / pass \
         time, achieved GB/s likewise with bytes per pixel; the per-pixel counts are estimates read from the \
         shaders (see `src/report/costs.rs`, where each count is argued). The copy kernel measures storage-buffer \
         traffic; a pass that moves its bytes through storage images (the tonemap) can read above 100 % of \
         it where the device's image path is the faster one (as measured on lavapipe).",
        copy.work / 2.0 / (1 << 20) as f64
    );
    Ok((
        Section { id: "ceilings", title: "Device ceilings".into(), text, tables: vec![table], plots: vec![] },
        ceilings,
    ))
}
