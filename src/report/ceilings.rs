//! The device's ceilings: a pure-FMA kernel (GFLOP/s) and a buffer copy (GB/s), each timed with
//! GPU timestamps around its dispatch, so each effect pass can be read as a fraction of what the
//! device does at best. The ceiling is the best of the runs (the least disturbed), p50 is shown
//! beside it.

use hadou::gpu::memory::MemoryLocation;

use crate::profile::Summary;
use hadou::gpu::barriers::{cmd_barriers, memory_barrier};
use hadou::gpu::commands::FrameCommands;
use hadou::gpu::memory::{Buffer, Memory};
use hadou::gpu::pipeline::{
    create_compute_pipeline, write_set, Bound, BufferRange, DescriptorPool, Pipeline,
};
use hadou::gpu::recorder::Recorder;
use hadou::gpu::shader::ShaderCompiler;
use hadou::gpu::timestamps::TimestampPool;
use hadou::gpu::{vk, GpuContext, GpuResult};
use hadou::Runtime;

use super::table::{Cell, Fmt, Table};
use super::{ReportOptions, Section, Steps};

/// FLOP per invocation per loop round of shaders/ceiling_fma.comp: 256 steps of 2 vec4 FMAs,
/// and with ADD_CHAIN one vec4 add more per step.
const FLOP_PER_ROUND: f64 = 256.0 * 2.0 * 4.0 * 2.0;
const ADD_FLOP_PER_ROUND: f64 = 256.0 * 4.0;

/// An arithmetic kernel: shaders/ceiling_fma.comp built with `defines`.
struct Arithmetic {
    /// The table's name.
    name: &'static str,
    defines: &'static [(&'static str, &'static str)],
    flop_per_round: f64,
}

const ARITHMETIC_KERNELS: [Arithmetic; 2] = [
    Arithmetic { name: "fma", defines: &[], flop_per_round: FLOP_PER_ROUND },
    Arithmetic {
        name: "fma+add",
        defines: &[("ADD_CHAIN", "1")],
        flop_per_round: FLOP_PER_ROUND + ADD_FLOP_PER_ROUND,
    },
];
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
    /// Loop rounds per run (the FMA kernel's calibrated count; 1 for the copy kernel).
    rounds: u32,
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

/// One ceiling kernel built and bound: its pipeline, its storage buffers (bindings 0..) and
/// their descriptor set, freed on drop.
struct Kernel<'a> {
    ctx: &'a GpuContext,
    pipeline: Pipeline,
    set: vk::DescriptorSet,
    _pool: DescriptorPool,
    _buffers: Vec<Buffer>,
}

impl<'a> Kernel<'a> {
    fn new(
        ctx: &'a GpuContext,
        memory: &Memory,
        compiler: &mut ShaderCompiler,
        shader: &str,
        defines: &[(&str, &str)],
        buffer_bytes: &[u64],
        push_bytes: u32,
    ) -> GpuResult<Kernel<'a>> {
        let spirv = compiler.compile(shader, defines)?;
        let pipeline = create_compute_pipeline(ctx, shader, &spirv, push_bytes)?;
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
        Ok(Kernel { ctx, pipeline, set, _pool: pool, _buffers: buffers })
    }

    /// GPU ms of each of `runs` dispatches of `groups` with `push`.
    fn time(&self, push: &[u8], groups: (u32, u32), runs: usize) -> GpuResult<Vec<f64>> {
        time_runs(self.ctx, &self.pipeline, self.set, push, groups, runs)
    }
}

/// How long one run of a ceiling kernel must take at least: far above the timestamps' resolution
/// and a dispatch's launch and ramp-down, so the rate measured is the device's steady state. A
/// fixed amount of work does not do that on every device: the 4.3 GFLOP the quick report used to
/// run are 30 ms on lavapipe but well under 1 ms on a large GPU, where launch and the last wave's
/// tail dominate, and the "ceiling" came out below what effect passes reached (146 % and 294 %
/// of it in a `report --quick`).
fn min_run_ms(quick: bool) -> f64 {
    if quick {
        20.0
    } else {
        100.0
    }
}

/// The most loop rounds a run may take (2^16 rounds are 2.8e14 FLOP: minutes on any device).
const MAX_ROUNDS: u32 = 1 << 16;

/// The loop rounds that make one run of the FMA kernel last at least `min_ms`: starting from one
/// round, `time_at(rounds)` (ms of one run) is asked again with the rounds scaled by the time
/// still missing (at least ×2, at most ×64 at once), until a run is long enough or the rounds
/// reach `MAX_ROUNDS`.
fn calibrate_rounds(min_ms: f64, mut time_at: impl FnMut(u32) -> GpuResult<f64>) -> GpuResult<u32> {
    let mut rounds = 1u32;
    loop {
        let ms = time_at(rounds)?;
        if ms >= min_ms || rounds >= MAX_ROUNDS {
            return Ok(rounds);
        }
        // A run too short to time (0 ms) jumps by the most; otherwise by what is missing, with
        // a margin so a run that scales a little sublinearly still gets there next time.
        let factor = if ms > 0.0 { (1.25 * min_ms / ms).ceil().clamp(2.0, 64.0) } else { 64.0 };
        rounds = (rounds as f64 * factor).min(MAX_ROUNDS as f64) as u32;
    }
}

/// Measures the ceilings on the runtime's device: each arithmetic kernel (ARITHMETIC_KERNELS, in
/// order), then the copy kernel.
fn measure(runtime: &Runtime, quick: bool, steps: &mut Steps) -> GpuResult<(Vec<Runs>, Runs)> {
    let ctx = runtime.context();
    let memory = Memory::new(ctx)?;
    let mut compiler = ShaderCompiler::new(hadou::SHADERS)?;
    let runs = if quick { 5 } else { 10 };
    let mut arithmetic = Vec::new();
    for Arithmetic { name, defines, flop_per_round } in ARITHMETIC_KERNELS {
        steps.next(&format!("ceiling: {name} kernel"));
        let fma_bytes = [FMA_INVOCATIONS as u64 * 16];
        let kernel = Kernel::new(ctx, &memory, &mut compiler, "ceiling_fma.comp", defines, &fma_bytes, 8)?;
        let groups = (FMA_INVOCATIONS / 64, 1);
        let push = |rounds: u32| -> [u32; 2] { [rounds, 0] };
        // The first run also pays the JIT: calibration runs are not counted.
        let rounds = calibrate_rounds(min_run_ms(quick), |rounds| {
            let ms = kernel.time(bytemuck::cast_slice(&push(rounds)), groups, 1)?;
            Ok(ms.first().copied().unwrap_or(0.0))
        })?;
        let ms = kernel.time(bytemuck::cast_slice(&push(rounds)), groups, runs)?;
        arithmetic.push(Runs { ms, work: FMA_INVOCATIONS as f64 * rounds as f64 * flop_per_round, rounds });
    }
    steps.next("ceiling: copy kernel");
    // Far larger than any CPU cache (lavapipe's memory is the host's).
    let bytes: u64 = if quick { 32 << 20 } else { 256 << 20 };
    // A whole number of groups of 64 invocations, each copying COPIES_PER_INVOCATION vec4s.
    let invocations = (bytes / 16 / COPIES_PER_INVOCATION) as u32;
    let kernel = Kernel::new(ctx, &memory, &mut compiler, "ceiling_copy.comp", &[], &[bytes, bytes], 4)?;
    let copy_ms = kernel.time(bytemuck::bytes_of(&invocations), (invocations / 64, 1), runs + 1)?;
    // The first run is left out: it pays for first touches of the memory and the JIT.
    let copy = Runs { ms: copy_ms[1..].to_vec(), work: 2.0 * bytes as f64, rounds: 1 };
    Ok((arithmetic, copy))
}

/// The ceilings section; its numbers are returned for the other sections' fractions.
pub fn section(
    runtime: &Runtime,
    opts: &ReportOptions,
    steps: &mut Steps,
) -> Result<(Section, Ceilings), super::ReportError> {
    let (arithmetic, copy) = measure(runtime, opts.quick, steps)?;
    let mut table = Table::new(
        "ceilings",
        "Device ceilings",
        &["kernel", "runs", "loop rounds", "ms p50", "best", "p50", "unit", "work per run"],
    );
    let row = |name: &str, r: &Runs, unit: &str, work: String| {
        let p50 = Summary::of(&r.ms).map_or(f64::NAN, |s| s.p50);
        vec![
            Cell::text(name),
            Cell::Num(r.ms.len() as f64, Fmt::Int),
            Cell::Num(r.rounds as f64, Fmt::Int),
            Cell::Num(p50, Fmt::Fixed(3)),
            Cell::Num(r.best_rate(), Fmt::Fixed(2)),
            Cell::Num(r.work / (p50 * 1e-3) / 1e9, Fmt::Fixed(2)),
            Cell::text(unit),
            Cell::text(work),
        ]
    };
    for (kernel, runs) in ARITHMETIC_KERNELS.iter().zip(&arithmetic) {
        table.push(row(kernel.name, runs, "GFLOP/s", format!("{:.3e} FLOP", runs.work)));
    }
    table.push(row("copy", &copy, "GB/s", format!("{:.3e} bytes read + written", copy.work)));
    let gflops = arithmetic.iter().map(Runs::best_rate).fold(0.0, f64::max);
    let ceilings = Ceilings { gflops, gbps: copy.best_rate() };
    let min_ms = min_run_ms(opts.quick);
    let text = format!(
        "`shaders/ceiling_fma.comp`: {FMA_INVOCATIONS} invocations, each stepping 2 independent vec4 FMA \
         chains 256 times per loop round, written out (4096 FLOP per round; FMA = 2 FLOP); `fma+add` adds a \
         vec4 add chain to each step (5120 FLOP per round). Each kernel's loop rounds are calibrated first, so \
         that one run lasts at least {min_ms:.0} ms: far above a dispatch's launch and tail on any device (a \
         fixed amount of work was 30 ms on lavapipe and a fraction of a millisecond on a large GPU, whose \
         \"ceiling\" then read below what the effect passes reached). \
         `shaders/ceiling_copy.comp`: \
         {COPIES_PER_INVOCATION} vec4s read and written per invocation, strided so neighbours touch \
         neighbouring memory, buffers of {:.0} MiB each. Times are GPU timestamps around the dispatch; the first run \
         of each kernel is discarded (shader JIT, first touch of the memory); a ceiling is the best run, and the \
         arithmetic ceiling the better of the two kernels.\n\n\
         Why it bounds the passes: a pass is credited 2 FLOP per FMA and 1 per add, multiply, division, square \
         root or comparison (`src/report/costs.rs`). Every instruction a pass issues goes to the same FP \
         pipes the kernels keep full with independent work: FMA pipes (2 FLOP per lane and cycle at most), and \
         on devices that have them, separate add pipes, which `fma+add` fills too. So a pass cannot retire \
         more FLOP per second than the better kernel, up to the counts' estimate (±30 %) and the kernels' \
         own latency hiding; a pass reading above 100 % would be a miscounted pass.\n\n\
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A device with a fixed launch cost and a per-round cost: the calibrated run is long enough,
    /// so its rate is within the launch's share of the steady state; not far longer than needed.
    #[test]
    fn calibration_reaches_the_steady_state() {
        for (launch_ms, round_ms) in [(0.05, 2e-5), (0.01, 30.0), (0.0, 0.003), (2.0, 1e-6)] {
            let mut asked = Vec::new();
            let rounds = calibrate_rounds(20.0, |r| {
                asked.push(r);
                Ok(launch_ms + round_ms * r as f64)
            })
            .unwrap();
            let ms = launch_ms + round_ms * rounds as f64;
            assert!(ms >= 20.0 || rounds == MAX_ROUNDS, "{launch_ms} {round_ms}: {rounds} rounds, {ms} ms");
            // The last step multiplied by at most 1.25 × the missing time (or 2): never more
            // than ~2.5× the target unless one round alone is longer.
            assert!(rounds == 1 || ms <= 2.5 * 20.0 + round_ms, "{rounds} rounds, {ms} ms");
            assert!(asked.windows(2).all(|w| w[1] > w[0]), "{asked:?}");
        }
        // A run that reads 0 ms (below the timestamps' resolution) still grows, to the cap.
        assert_eq!(calibrate_rounds(20.0, |_| Ok(0.0)).unwrap(), MAX_ROUNDS);
    }
}
