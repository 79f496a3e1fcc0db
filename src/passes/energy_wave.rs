//! energy_wave: for every pixel, the closed-form line integral H of each wave along the view ray
//! from the camera to the first surface (the `distance` target) or the camera's far distance;
//! adds colour × intensity × H to the HDR colour and writes Σ H to the `energy` target.
//! `method = "raymarch"` waves are sampled instead (the baseline). CPU twins:
//! `effects::energy_wave` (f64) and `effects::energy_wave_f32` (the shader's arithmetic).

use gpu_allocator::MemoryLocation;

use super::{Pass, PassInputs};
use crate::effects::energy_wave::WaveParams;
use crate::effects::energy_wave_f32::{gpu_wave, GpuWave};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::{Buffer, Memory};
use crate::gpu::pipeline::{binding, create_compute_pipeline, write_set, Bound, DescriptorPool, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene::{Scene, WaveMethod, WaveState};
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};

/// How a wave is drawn: keep in sync with `WaveStyle` in shaders/energy_wave.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WaveStyle {
    /// rgb: colour × intensity.
    pub emission: [f32; 4],
    /// x: 0 analytic, 1 raymarch; y: steps; z: jitter (0/1).
    pub method: [u32; 4],
}

/// Push constants: the camera frame for the pixel rays. Keep in sync with shaders/energy_wave.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RayParams {
    /// x: right × tan(fov/2) × aspect.
    pub right: [f32; 4],
    /// y: image up × tan(fov/2).
    pub up: [f32; 4],
    pub forward: [f32; 4],
    /// width, height, wave count, 0.
    pub dims: [u32; 4],
    /// x: the camera's far distance (L where no surface is hit).
    pub far: [f32; 4],
}

const _: () = {
    assert!(std::mem::size_of::<WaveStyle>() == 32);
    assert!(std::mem::size_of::<RayParams>() == 80);
};

impl RayParams {
    pub fn new(scene: &Scene, extent: vk::Extent2D, wave_count: u32) -> Self {
        let cam = &scene.camera;
        let [right, up, forward] = cam.ray_frame(extent.width, extent.height).to_f32();
        RayParams {
            right,
            up,
            forward,
            dims: [extent.width, extent.height, wave_count, 0],
            far: [cam.far as f32, 0.0, 0.0, 0.0],
        }
    }
}

/// The f64 parameters of a wave's state (what the references integrate).
pub fn wave_params(state: &WaveState) -> WaveParams {
    WaveParams {
        origin: state.origin,
        direction: state.direction,
        a: state.a,
        b: state.b,
        core: state.core,
        length: state.length,
    }
}

pub fn wave_style(state: &WaveState, method: WaveMethod) -> WaveStyle {
    let e = state.emission;
    let method = match method {
        WaveMethod::Analytic => [0, 0, 0, 0],
        WaveMethod::Raymarch { steps, jitter } => [1, steps, u32::from(jitter), 0],
    };
    WaveStyle { emission: [e.x as f32, e.y as f32, e.z as f32, 0.0], method }
}

pub struct EnergyWavePass {
    pipeline: Pipeline,
    set: vk::DescriptorSet,
    waves: Option<Buffer>,
    styles: Option<Buffer>,
    params: RayParams,
}

impl EnergyWavePass {
    pub fn new(
        ctx: &GpuContext,
        memory: &Memory,
        compiler: &mut ShaderCompiler,
        scene: &Scene,
    ) -> GpuResult<Self> {
        let spirv = compiler.compile("energy_wave.comp", &[])?;
        let compute = vk::ShaderStageFlags::COMPUTE;
        let bindings = [
            binding(0, vk::DescriptorType::STORAGE_IMAGE, compute),
            binding(1, vk::DescriptorType::STORAGE_IMAGE, compute),
            binding(2, vk::DescriptorType::STORAGE_IMAGE, compute),
            binding(3, vk::DescriptorType::STORAGE_BUFFER, compute),
            binding(4, vk::DescriptorType::STORAGE_BUFFER, compute),
        ];
        let push = std::mem::size_of::<RayParams>() as u32;
        let pipeline = create_compute_pipeline(ctx, "energy_wave", &spirv, &bindings, push)?;
        let mut pass = EnergyWavePass {
            pipeline,
            set: vk::DescriptorSet::null(),
            waves: None,
            styles: None,
            params: RayParams::default(),
        };
        let n = scene.waves.len().max(1) as u64;
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let sizes = [std::mem::size_of::<GpuWave>() as u64 * n, std::mem::size_of::<WaveStyle>() as u64 * n];
        for (i, size) in sizes.into_iter().enumerate() {
            let name = if i == 0 { "energy_wave waves" } else { "energy_wave styles" };
            match memory.create_buffer(ctx, name, size, usage, MemoryLocation::CpuToGpu) {
                Ok(b) if i == 0 => pass.waves = Some(b),
                Ok(b) => pass.styles = Some(b),
                Err(e) => {
                    pass.destroy(ctx, memory);
                    return Err(e);
                }
            }
        }
        Ok(pass)
    }
}

impl Pass for EnergyWavePass {
    fn name(&self) -> &'static str {
        "energy_wave"
    }

    fn prepare(&mut self, scene: &Scene, time: f64, extent: vk::Extent2D) -> GpuResult<()> {
        let camera = scene.camera.position;
        let states: Vec<WaveState> = scene.waves.iter().map(|w| w.at(time)).collect();
        let waves: Vec<GpuWave> = states.iter().map(|s| gpu_wave(&wave_params(s), camera)).collect();
        let styles: Vec<WaveStyle> =
            states.iter().zip(&scene.waves).map(|(s, w)| wave_style(s, w.method)).collect();
        if let (Some(wb), Some(sb)) = (&mut self.waves, &mut self.styles) {
            wb.write(0, bytemuck::cast_slice(&waves))?;
            sb.write(0, bytemuck::cast_slice(&styles))?;
        }
        self.params = RayParams::new(scene, extent, waves.len() as u32);
        Ok(())
    }

    fn uses(&self) -> Vec<(Target, ImageAccess)> {
        vec![
            (Target::Distance, ImageAccess::COMPUTE_READ),
            (Target::Hdr, ImageAccess::COMPUTE_READ_WRITE),
            (Target::Energy, ImageAccess::COMPUTE_WRITE),
        ]
    }

    fn bind(
        &mut self,
        ctx: &GpuContext,
        pool: &DescriptorPool,
        _: &SceneGpu,
        targets: &Targets,
    ) -> GpuResult<()> {
        let (Some(waves), Some(styles)) = (&self.waves, &self.styles) else { return Ok(()) };
        self.set = pool.allocate(ctx, self.pipeline.set_layout, "energy_wave set")?;
        write_set(
            ctx,
            self.set,
            &[
                (0, Bound::StorageImage(targets.image(Target::Distance).view)),
                (1, Bound::StorageImage(targets.image(Target::Hdr).view)),
                (2, Bound::StorageImage(targets.image(Target::Energy).view)),
                (3, Bound::Storage(waves.raw)),
                (4, Bound::Storage(styles.raw)),
            ],
        );
        Ok(())
    }

    fn record(&self, inputs: &PassInputs) {
        let extent = inputs.targets.extent;
        inputs.rec.bind_pipeline(&self.pipeline, self.set);
        inputs.rec.push_constants(
            &self.pipeline,
            vk::ShaderStageFlags::COMPUTE,
            bytemuck::bytes_of(&self.params),
        );
        inputs.rec.dispatch_2d(extent.width, extent.height, (8, 8));
    }

    fn destroy(&mut self, ctx: &GpuContext, memory: &Memory) {
        self.pipeline.destroy(ctx);
        if let Some(b) = self.waves.take() {
            memory.destroy_buffer(ctx, b);
        }
        if let Some(b) = self.styles.take() {
            memory.destroy_buffer(ctx, b);
        }
    }
}
