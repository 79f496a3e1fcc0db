//! energy_wave: for every pixel, the closed-form line integral H of each wave along the view ray
//! from the camera to the first surface (the `distance` target) or the camera's far distance;
//! adds colour × intensity × H to the HDR colour and writes Σ H to the `energy` target.
//! `method = "raymarch"` waves are sampled instead (the baseline). CPU twins:
//! `effects::energy_wave` (f64) and `effects::energy_wave_f32` (the shader's arithmetic).

use super::{Binding, FrameContext, Pass, PassRecording};
use crate::effects::energy_wave::WaveParams;
use crate::effects::energy_wave_f32::{gpu_wave, GpuWave};
use crate::gpu::pipeline::{create_compute_pipeline, Bound, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene::{WaveMethod, WaveState};
use crate::targets::Target;

/// How a wave is drawn: `WaveStyle` in shaders/energy_wave.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WaveStyle {
    /// rgb: colour × intensity; w: the cutoff.
    pub emission: [f32; 4],
    /// x: 0 analytic, 1 raymarch; y: steps; z: jitter (0/1).
    pub method: [u32; 4],
}

crate::gpu::layout::gpu_layout!(WaveStyle as "WaveStyle" { emission, method });

/// Push constants (size checked against shaders/energy_wave.comp when the pipeline is made). The
/// camera's ray frame, the frame size and the far distance are the frame's uniforms
/// (`FrameUniforms`: `ray_right`, `ray_up`, `ray_forward`, `counts`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct EnergyWaveParams {
    /// x: the wave count (the live waves uploaded); y, z, w: 0.
    pub counts: [u32; 4],
}

crate::gpu::layout::gpu_layout!(EnergyWaveParams as "EnergyWaveParams" { counts });

const _: () = {
    assert!(std::mem::size_of::<WaveStyle>() == 32);
    assert!(std::mem::size_of::<EnergyWaveParams>() == 16);
};

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
    WaveStyle { emission: [e.x as f32, e.y as f32, e.z as f32, state.cutoff as f32], method }
}

pub struct EnergyWavePass {
    pipeline: Pipeline,
    params: EnergyWaveParams,
    /// The frame's size: the dispatch.
    extent: vk::Extent2D,
}

impl EnergyWavePass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let spirv = compiler.compile("energy_wave.comp", &[])?;
        let push = std::mem::size_of::<EnergyWaveParams>() as u32;
        let pipeline = create_compute_pipeline(ctx, "energy_wave", &spirv, push)?;
        let extent = vk::Extent2D::default();
        Ok(EnergyWavePass { pipeline, params: EnergyWaveParams::default(), extent })
    }
}

impl Pass for EnergyWavePass {
    fn name(&self) -> &'static str {
        "energy_wave"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let scene = frame.scene;
        let camera = scene.camera.position;
        // A wave with a = b = 0 integrates to 0 everywhere: it is not uploaded or looped over.
        let live: Vec<(WaveState, WaveMethod)> = scene
            .waves()
            .iter()
            .map(|w| (w.at(frame.time), w.method))
            .filter(|(s, _)| s.a != 0.0 || s.b != 0.0)
            .collect();
        let waves: Vec<GpuWave> = live.iter().map(|(s, _)| gpu_wave(&wave_params(s), camera)).collect();
        // The glow is pre-exposed as the frame's other radiances (`effects::tonemap::pre_exposure`).
        let p = frame.pre_exposure;
        let styles: Vec<WaveStyle> =
            live.iter().map(|(s, m)| wave_style(&WaveState { emission: s.emission * p, ..*s }, *m)).collect();
        self.params = EnergyWaveParams { counts: [waves.len() as u32, 0, 0, 0] };
        self.extent = frame.extent;
        // The shader reads wave 0 before its loop (count 0 still binds one, zeroed, unused).
        let (waves, styles) = if waves.is_empty() {
            (vec![bytemuck::Zeroable::zeroed()], vec![WaveStyle::default()])
        } else {
            (waves, styles)
        };
        Ok(vec![
            Binding::read(Target::Distance),
            Binding::read_write(Target::Hdr),
            Binding::write(Target::Energy),
            Binding::Bound(Bound::Storage(frame.upload(&waves)?)),
            Binding::Bound(Bound::Storage(frame.upload(&styles)?)),
            Binding::Bound(Bound::Uniform(frame.uniforms)),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        let vk::Extent2D { width, height } = self.extent;
        pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
        pass.rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        pass.rec.dispatch_2d(width, height, (8, 8));
    }
}
