//! tonemap: HDR → sRGB with exposure and the ACES filmic curve (Narkowicz 2015 fit), into hadou's
//! own `ldr` image. Runs when hadou's result is its own image (headless); a game's colour target
//! gets `composite` instead. CPU twin: `effects::tonemap::tonemap_pixel`.
//!
//! The HDR target is pre-exposed (`effects::tonemap::pre_exposure`): a fixed exposure multiplies
//! it by exposure / pre-exposure. `exposure = "auto"` runs shaders/exposure.comp first, one
//! workgroup measuring this frame's luminance into a small host-visible buffer of the slot, which
//! tonemap.comp reads in the same frame: nothing waits for the GPU. Frames that follow each other
//! are smoothed: when the slot comes round again (its frame finished) its measurement is read back
//! and folded into the adapted luminance (`effects::tonemap::adapt`, over the frames' scene time), which
//! later frames start from; a first frame (a headless render) uses its own measurement alone.

use super::{Binding, FrameContext, Pass, PassRecording, Reader};
use crate::effects::tonemap::{adapt, adaptation_weight, tonemap_factor};
use crate::gpu::memory::{Buffer, MemoryLocation};
use crate::gpu::pipeline::{create_compute_pipeline, BufferRange, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene::ExposureMode;
use crate::targets::Target;

pub struct TonemapPass {
    /// Fixed exposure (tonemap.comp as it is).
    pipeline: Pipeline,
    /// `exposure = "auto"`: the measurement, then tonemap.comp with AUTO_EXPOSURE.
    measure: Pipeline,
    auto: Pipeline,
    params: Params,
    /// This frame measures its exposure.
    auto_frame: bool,
    state: AutoExposure,
}

/// The automatic exposure's state across frames, shared by `tonemap` and `composite`: per frame
/// slot a host-visible buffer exposure.comp writes its measurement into, and the adapted
/// luminance the measurements of finished frames have been folded into.
#[derive(Default)]
pub(crate) struct AutoExposure {
    /// Per frame slot: the measurement buffer, and the scene time of the frame that last wrote
    /// it (None once read back, or when that frame had a fixed exposure).
    slots: Vec<(Buffer, Option<f64>)>,
    /// Per view (`FrameContext::view`), the adapted log2 luminance and the scene time of the frame
    /// it last took in: each view adapts to what it sees, as it would rendered alone. Adaptation
    /// follows the frames' scene time (`FrameInputs::time`), not the wall clock: the same frames
    /// give the same pictures on any machine, and a paused game's exposure holds still.
    adapted: Vec<Option<(f64, f64)>>,
}

impl AutoExposure {
    /// A frame with a fixed exposure: the next automatic one starts afresh.
    pub fn reset(&mut self) {
        self.adapted.clear();
        self.slots.iter_mut().for_each(|(_, pending)| *pending = None);
    }

    /// This frame's automatic exposure: folds the slot's finished measurement into the adapted
    /// luminance, and returns (log2 pre-exposure, history, weight) for the push constants with
    /// the buffer exposure.comp writes this frame's measurement into.
    pub fn prepare(&mut self, frame: &FrameContext) -> GpuResult<((f32, f32, f32), BufferRange)> {
        while self.slots.len() <= frame.slot {
            let size = std::mem::size_of::<Measured>() as u64;
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            let buffer =
                frame.memory.create_buffer(frame.ctx, "exposure", size, usage, MemoryLocation::GpuToCpu)?;
            self.slots.push((buffer, None));
        }
        if self.adapted.len() <= frame.view {
            self.adapted.resize(frame.view + 1, None);
        }
        // The slot's last frame was this view's (a slot serves one view).
        let adapted = &mut self.adapted[frame.view];
        read_back(&mut self.slots[frame.slot], adapted);
        let now = frame.time;
        let pre_log2 = frame.pre_exposure.log2() as f32;
        let (history, weight) = match *adapted {
            // Time that went back is a new timeline (a reloaded level): the frame's own measurement.
            Some((_, since)) if now < since => {
                *adapted = None;
                (0.0, 1.0)
            }
            None => (0.0, 1.0),
            Some((a, since)) => (a as f32, adaptation_weight(now - since) as f32),
        };
        self.slots[frame.slot].1 = Some(now);
        Ok(((pre_log2, history, weight), BufferRange::whole(self.slots[frame.slot].0.raw)))
    }

    /// The first view's adapted log2 luminance (None before a measurement has been read back).
    pub fn adapted_log2_luminance(&self) -> Option<f64> {
        self.adapted.first().copied().flatten().map(|(l, _)| l)
    }
}

/// Folds the measurement of a slot's finished frame into its view's adapted luminance.
fn read_back((buffer, pending): &mut (Buffer, Option<f64>), adapted: &mut Option<(f64, f64)>) {
    let Some(at) = pending.take() else { return };
    let Some(bytes) = buffer.mapped() else { return };
    let Some(m) = bytes.get(..std::mem::size_of::<Measured>()) else { return };
    let measured = bytemuck::pod_read_unaligned::<Measured>(m).log2_average as f64;
    if !measured.is_finite() {
        return;
    }
    let folded = match *adapted {
        None => measured,
        Some((a, since)) => adapt(Some(a), measured, at - since),
    };
    *adapted = Some((folded, at));
}

/// Push constants of shaders/tonemap.comp and shaders/exposure.comp (common/exposure.glsl; size
/// checked against the shader).
#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Params {
    exposure: f32,
    width: u32,
    height: u32,
    pre_log2: f32,
    history: f32,
    weight: f32,
}

crate::gpu::layout::gpu_layout!(Params as "Params" { exposure, width, height, pre_log2, history, weight });

impl Params {
    /// exposure.comp's push constants for a `width` × `height` frame (`AutoExposure::prepare`).
    pub(crate) fn measurement(width: u32, height: u32, (pre_log2, history, weight): (f32, f32, f32)) -> Self {
        Params { exposure: 0.0, width, height, pre_log2, history, weight }
    }
}

/// What shaders/exposure.comp writes (`Measured`).
#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Measured {
    /// log2 of the scene's measured average luminance (cd/m² in physical units).
    pub log2_average: f32,
    pub pixels: u32,
    pub surfaces: u32,
    pub unused: u32,
}

crate::gpu::layout::gpu_layout!(Measured as "Measured" { log2_average, pixels, surfaces, unused });

impl TonemapPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let push = std::mem::size_of::<Params>() as u32;
        let spirv = compiler.compile("tonemap.comp", &[])?;
        let pipeline = create_compute_pipeline(ctx, "tonemap", &spirv, push)?;
        let spirv = compiler.compile("exposure.comp", &[])?;
        let measure = create_compute_pipeline(ctx, "exposure", &spirv, push)?;
        let spirv = compiler.compile("tonemap.comp", &[("AUTO_EXPOSURE", "1")])?;
        let auto = create_compute_pipeline(ctx, "tonemap_auto", &spirv, push)?;
        Ok(TonemapPass {
            pipeline,
            measure,
            auto,
            params: Params::default(),
            auto_frame: false,
            state: Default::default(),
        })
    }

    /// The adapted log2 luminance of the automatic exposure (None before a measurement has been
    /// read back, or with a fixed exposure).
    pub fn adapted_log2_luminance(&self) -> Option<f64> {
        self.state.adapted_log2_luminance()
    }
}

impl Pass for TonemapPass {
    fn name(&self) -> &'static str {
        "tonemap"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let e = frame.extent;
        self.auto_frame = frame.scene.render.exposure_mode == ExposureMode::Auto;
        if !self.auto_frame {
            self.state.reset();
            let exposure = tonemap_factor(frame.scene, frame.pre_exposure) as f32;
            self.params = Params { exposure, width: e.width, height: e.height, ..Params::default() };
            return Ok(vec![Binding::read(Target::Hdr), Binding::write(Target::Ldr)]);
        }
        let (auto, buffer) = self.state.prepare(frame)?;
        self.params = Params::measurement(e.width, e.height, auto);
        Ok(vec![
            Binding::read(Target::Hdr),
            Binding::write(Target::Ldr),
            Binding::read(Target::Ids),
            Binding::Written(buffer, Reader::Host),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        if self.auto_frame {
            vec![&self.measure, &self.auto]
        } else {
            vec![&self.pipeline]
        }
    }

    fn record(&self, pass: &PassRecording) {
        let (w, h) = (self.params.width, self.params.height);
        if self.auto_frame {
            pass.rec.bind_pipeline(&self.measure, pass.set(0));
            pass.rec.push_constants(&self.measure, bytemuck::bytes_of(&self.params));
            pass.rec.dispatch_groups(1, 1);
            pass.rec.compute_to_compute_barrier();
            pass.rec.bind_pipeline(&self.auto, pass.set(1));
            pass.rec.push_constants(&self.auto, bytemuck::bytes_of(&self.params));
        } else {
            pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
            pass.rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        }
        pass.rec.dispatch_2d(w, h, (8, 8));
    }
}
