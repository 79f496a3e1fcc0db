//! energy_probe: the energy-wave integral on the GPU for rays given in a buffer (not pixels), so
//! tests can feed exact hard rays and compare the shader's arithmetic with the f64 reference.

use gpu_allocator::MemoryLocation;

use crate::effects::energy_wave_f32::GpuWave;
use crate::gpu::barriers::{cmd_barriers, memory_barrier};
use crate::gpu::commands::FrameCommands;
use crate::gpu::memory::{Buffer, Memory};
use crate::gpu::pipeline::{binding, create_compute_pipeline, write_set, Bound, DescriptorPool};
use crate::gpu::recorder::Recorder;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};

/// Which integral the probe evaluates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProbeMethod {
    Analytic,
    /// `steps` samples at (i + offset)·L/steps.
    Raymarch {
        steps: u32,
        offset: f32,
    },
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ProbeParams {
    counts: [u32; 4],
    offset: [f32; 4],
}

/// One ray: unit direction `u` (camera-relative, as the pass builds it) and clip distance `l`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeRay {
    pub u: [f32; 3],
    pub l: f32,
}

/// H for every (ray, wave), ray-major: `result[r * waves.len() + w]`.
pub fn run_probe(
    ctx: &GpuContext,
    memory: &Memory,
    compiler: &mut ShaderCompiler,
    waves: &[GpuWave],
    rays: &[ProbeRay],
    method: ProbeMethod,
) -> GpuResult<Vec<f32>> {
    if waves.is_empty() || rays.is_empty() {
        return Ok(Vec::new());
    }
    let spirv = compiler.compile("energy_probe.comp", &[])?;
    let compute = vk::ShaderStageFlags::COMPUTE;
    let bindings = [
        binding(0, vk::DescriptorType::STORAGE_BUFFER, compute),
        binding(1, vk::DescriptorType::STORAGE_BUFFER, compute),
        binding(2, vk::DescriptorType::STORAGE_BUFFER, compute),
    ];
    let pipeline = create_compute_pipeline(
        ctx,
        "energy_probe",
        &spirv,
        &bindings,
        std::mem::size_of::<ProbeParams>() as u32,
    )?;
    let mut buffers: Vec<Buffer> = Vec::new();
    let result = (|| {
        let ray_words: Vec<[f32; 4]> = rays.iter().map(|r| [r.u[0], r.u[1], r.u[2], r.l]).collect();
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        for (name, bytes) in [
            ("probe waves", bytemuck::cast_slice::<GpuWave, u8>(waves)),
            ("probe rays", bytemuck::cast_slice(&ray_words)),
        ] {
            let mut b =
                memory.create_buffer(ctx, name, bytes.len() as u64, storage, MemoryLocation::CpuToGpu)?;
            let written = b.write(0, bytes);
            buffers.push(b);
            written?;
        }
        let out_size = (rays.len() * waves.len() * 4) as u64;
        buffers.push(memory.create_buffer(
            ctx,
            "probe results",
            out_size,
            storage,
            MemoryLocation::GpuToCpu,
        )?);
        let pool = DescriptorPool::new(ctx, "probe descriptors", 1)?;
        let recorded = (|| {
            let set = pool.allocate(ctx, pipeline.set_layout, "probe set")?;
            write_set(
                ctx,
                set,
                &[
                    (0, Bound::Storage(buffers[0].raw)),
                    (1, Bound::Storage(buffers[1].raw)),
                    (2, Bound::Storage(buffers[2].raw)),
                ],
            );
            let (m, steps, offset) = match method {
                ProbeMethod::Analytic => (0, 0, 0.5),
                ProbeMethod::Raymarch { steps, offset } => (1, steps, offset),
            };
            let params = ProbeParams {
                counts: [rays.len() as u32, waves.len() as u32, m, steps],
                offset: [offset, 0.0, 0.0, 0.0],
            };
            let commands = FrameCommands::new(ctx, "energy_probe")?;
            let run = (|| {
                commands.begin(ctx)?;
                let rec = Recorder { ctx, cmd: commands.cmd };
                ctx.begin_label(commands.cmd, "energy_probe");
                rec.bind_pipeline(&pipeline, set);
                rec.push_constants(&pipeline, compute, bytemuck::bytes_of(&params));
                rec.dispatch_2d(rays.len() as u32, 1, (64, 1));
                let to_host = memory_barrier(
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_WRITE,
                    vk::PipelineStageFlags2::HOST,
                    vk::AccessFlags2::HOST_READ,
                );
                cmd_barriers(&ctx.device, commands.cmd, &[], &[to_host]);
                ctx.end_label(commands.cmd);
                commands.submit_and_wait(ctx, "energy_probe")
            })();
            commands.destroy(ctx);
            run
        })();
        pool.destroy(ctx);
        recorded?;
        let bytes = buffers[2].mapped().unwrap_or_default();
        Ok(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
    })();
    buffers.into_iter().for_each(|b| memory.destroy_buffer(ctx, b));
    pipeline.destroy(ctx);
    result
}
