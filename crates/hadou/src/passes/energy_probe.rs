//! energy_probe: the energy-wave integral on the GPU for rays given in a buffer (not pixels), so
//! tests can feed exact hard rays and compare the shader's arithmetic with the f64 reference. A
//! pass like the others, recorded by the same runner in a frame of its own
//! (`Runtime::energy_probe`).

use crate::gpu::memory::MemoryLocation;

use super::{Binding, FrameContext, Pass, PassRecording, Reader};
use crate::effects::energy_wave_f32::GpuWave;
use crate::gpu::memory::Buffer;
use crate::gpu::pipeline::{create_compute_pipeline, Bound, BufferRange, Pipeline};
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

/// Push constants of shaders/energy_probe.comp (size checked against the shader).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ProbeParams {
    counts: [u32; 4],
    offset: [f32; 4],
}

crate::gpu::layout::gpu_layout!(ProbeParams as "ProbeParams" { counts, offset });

/// One ray: unit direction `u` (camera-relative, as the pass builds it) and clip distance `l`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeRay {
    pub u: [f32; 3],
    pub l: f32,
}

/// H for every (ray, wave), ray-major, into a host-readable buffer.
pub struct ProbePass {
    pipeline: Pipeline,
    waves: Vec<GpuWave>,
    rays: Vec<[f32; 4]>,
    params: ProbeParams,
    results: Buffer,
}

impl ProbePass {
    pub fn new(
        ctx: &GpuContext,
        memory: &crate::gpu::memory::Memory,
        compiler: &mut ShaderCompiler,
        waves: &[GpuWave],
        rays: &[ProbeRay],
        method: ProbeMethod,
    ) -> GpuResult<Self> {
        let spirv = compiler.compile("energy_probe.comp", &[])?;
        let push = std::mem::size_of::<ProbeParams>() as u32;
        let pipeline = create_compute_pipeline(ctx, "energy_probe", &spirv, push)?;
        let (m, steps, offset) = match method {
            ProbeMethod::Analytic => (0, 0, 0.5),
            ProbeMethod::Raymarch { steps, offset } => (1, steps, offset),
        };
        let params = ProbeParams {
            counts: [rays.len() as u32, waves.len() as u32, m, steps],
            offset: [offset, 0.0, 0.0, 0.0],
        };
        let size = (rays.len() as u64).saturating_mul(waves.len() as u64).saturating_mul(4);
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let results = memory.create_buffer(ctx, "probe results", size, usage, MemoryLocation::GpuToCpu)?;
        let rays = rays.iter().map(|r| [r.u[0], r.u[1], r.u[2], r.l]).collect();
        Ok(ProbePass { pipeline, waves: waves.to_vec(), rays, params, results })
    }

    /// The results, after the probe's frame finished.
    pub fn results(&self) -> Vec<f32> {
        let count = self.rays.len() * self.waves.len();
        let bytes = self.results.mapped().unwrap_or_default();
        bytes.chunks_exact(4).take(count).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
    }
}

impl Pass for ProbePass {
    fn name(&self) -> &'static str {
        "energy_probe"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        Ok(vec![
            Binding::Bound(Bound::Storage(frame.upload(&self.waves)?)),
            Binding::Bound(Bound::Storage(frame.upload(&self.rays)?)),
            Binding::Written(BufferRange::whole(self.results.raw), Reader::Host),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
        pass.rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        pass.rec.dispatch_2d(self.params.counts[0], 1, (64, 1));
    }
}
