//! The metaballs pass's ball table when a group's balls come from the game's buffer
//! ([`DeviceBalls`], `Renderer::set_metaball_buffer`): a per-slot buffer the host fills with the
//! other groups' balls, into which the frame copies the game's records on the device and
//! completes them there (shaders/metaballs_device.comp: ρ*·R, the slope bound, a ball with a
//! value that is not finite turned into one that adds nothing, and counted). The binning and the
//! casts then read the table through its texel view, as they read the host's.

use crate::effects::metaballs::device::{DeviceBalls, DEVICE_BALL_BYTES};
use crate::gpu::barriers::{cmd_barriers, memory_barrier};
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::{create_compute_pipeline, Pipeline};
use crate::gpu::recorder::Recorder;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::texel_buffer::{TexelBuffer, Texels};
use crate::gpu::{vk, GpuContext, GpuResult};

/// Push constants of shaders/metaballs_device.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DeviceBallParams {
    /// x: the group's first ball in the table, y: its count, z: the kernel (`Kernel::gpu_id`), w: 1
    /// when the records carry the balls' previous centres and the pass keeps them (motion vectors
    /// on: the pipeline is made with MB_PREVIOUS).
    pub range: [u32; 4],
    /// x: T, y: the kernel's slope bound γ (`Kernel::max_slope`), z, w: 0.
    pub values: [f32; 4],
}

crate::gpu::layout::gpu_layout!(DeviceBallParams as "DeviceBallParams" { range, values });

/// One device group of a frame: where its records are and where they go.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceCopy {
    pub source: DeviceBalls,
    pub params: DeviceBallParams,
}

/// The completing pipeline (made only for a world with a device group).
pub struct DeviceBallPipeline {
    pub pipeline: Pipeline,
}

impl DeviceBallPipeline {
    /// `previous`: also copies the balls' previous centres (motion vectors on).
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler, previous: bool) -> GpuResult<Self> {
        let defines: &[(&str, &str)] = if previous { &[("MB_PREVIOUS", "1")] } else { &[] };
        let spirv = compiler.compile("metaballs_device.comp", defines)?;
        let push = std::mem::size_of::<DeviceBallParams>() as u32;
        Ok(DeviceBallPipeline {
            pipeline: create_compute_pipeline(ctx, "metaballs device balls", &spirv, push)?,
        })
    }
}

/// The slot's table, grown to hold `bytes` (the slot's previous frame has finished), with the
/// host's balls written where they go (`host`: byte offset, bytes). The game's groups' ranges are
/// not written here: their copies fill them on the device.
pub fn table<'a>(
    slot: &'a mut Option<TexelBuffer>,
    ctx: &GpuContext,
    memory: &Memory,
    host: &[(usize, &[u8])],
    bytes: u64,
) -> GpuResult<&'a TexelBuffer> {
    if slot.as_ref().is_none_or(|t| t.buffer.size < bytes) {
        let grown = bytes + bytes / 2;
        *slot = Some(TexelBuffer::device_table(ctx, memory, "metaballs ball table", grown, Texels::U32x4)?);
    }
    let Some(table) = slot.as_mut() else { unreachable!("made above") };
    for (offset, data) in host {
        table.write_at(*offset, data)?;
    }
    Ok(table)
}

/// Records the copies of the game's records into `table` and their completion (`set`: the
/// completing pipeline's), each behind the barrier it needs: the game's earlier writes before the
/// copies, every later command after the copies' reads (the game may write its buffer again),
/// and the table's writes before the binning's and the casts' reads.
pub fn record(
    rec: &Recorder,
    pipeline: &DeviceBallPipeline,
    set: vk::DescriptorSet,
    table: vk::Buffer,
    copies: &[DeviceCopy],
) {
    if copies.is_empty() {
        return;
    }
    let device = &rec.ctx.device;
    let (all, copy, compute) = (
        vk::PipelineStageFlags2::ALL_COMMANDS,
        vk::PipelineStageFlags2::COPY,
        vk::PipelineStageFlags2::COMPUTE_SHADER,
    );
    let game_writes =
        memory_barrier(all, vk::AccessFlags2::MEMORY_WRITE, copy, vk::AccessFlags2::TRANSFER_READ);
    cmd_barriers(device, rec.cmd, &[], &[game_writes]);
    for c in copies {
        let [first, count, ..] = c.params.range;
        let (dst, size) = (u64::from(first) * DEVICE_BALL_BYTES, u64::from(count) * DEVICE_BALL_BYTES);
        rec.copy_buffer(c.source.buffer, c.source.offset, table, dst, size);
    }
    let copied = memory_barrier(
        copy,
        vk::AccessFlags2::TRANSFER_WRITE,
        compute,
        vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
    );
    // The game's next writes to its buffer wait for the copies' reads (an execution dependency).
    let read = memory_barrier(copy, vk::AccessFlags2::NONE, all, vk::AccessFlags2::NONE);
    cmd_barriers(device, rec.cmd, &[], &[copied, read]);
    rec.bind_pipeline(&pipeline.pipeline, set);
    for c in copies {
        rec.push_constants(&pipeline.pipeline, bytemuck::bytes_of(&c.params));
        rec.dispatch_groups(c.params.range[1].div_ceil(64), 1);
    }
    rec.compute_to_texel_and_indirect_barrier();
}
