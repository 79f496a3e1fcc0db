//! composite: hadou's HDR result drawn over the game's colour target (shaders/composite.frag):
//! over where hadou drew a surface, added where only the wave glows. One pipeline per colour
//! format the game has used (and its AUTO_EXPOSURE twin). With `exposure = "auto"` the pass first
//! dispatches shaders/exposure.comp (one workgroup, outside the rendering) to measure the frame,
//! which the fragment shader reads after a barrier: the same measurement and adaptation across
//! frames as `tonemap` (`tonemap::AutoExposure`), nothing waited for.

use super::tonemap::AutoExposure;
use super::{Binding, FrameContext, ImageUse, Pass, PassRecording, Reader};
use crate::gpu::barriers::{cmd_barriers, memory_barrier, ImageAccess};
use crate::gpu::fullscreen::create_fullscreen_pipeline;
use crate::gpu::pipeline::{create_compute_pipeline, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene::ExposureMode;
use crate::targets::Target;

/// Push constants of shaders/composite.frag (size checked against the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Params {
    exposure: f32,
    pre_log2: f32,
    history: f32,
    weight: f32,
}

crate::gpu::layout::gpu_layout!(Params as "Params" { exposure, pre_log2, history, weight });

/// What the shader writes for a colour format (see `ExternalColor`): its MODE define.
pub fn mode_for(format: vk::Format) -> u32 {
    let name = format!("{format:?}");
    if name.ends_with("_SRGB") {
        0
    } else if name.ends_with("_SFLOAT") || name.ends_with("UFLOAT_PACK32") {
        2
    } else {
        1
    }
}

/// Runs last in an embedded frame whose game hands its colour target (`FrameInputs::color`),
/// imported for the frame as `GameColor`. One pipeline per colour format the game has used.
pub struct CompositePass {
    /// Per colour format: the fixed-exposure pipeline and its AUTO_EXPOSURE twin.
    pipelines: Vec<(vk::Format, Pipeline, Pipeline)>,
    /// exposure.comp, made with the first pipelines.
    measure: Option<Pipeline>,
    /// This frame's target format (its pipeline exists: `use_format`).
    format: vk::Format,
    params: Params,
    /// This frame's exposure.comp push constants (`exposure = "auto"`).
    measure_params: super::tonemap::Params,
    /// This frame measures its exposure.
    auto_frame: bool,
    state: AutoExposure,
}

impl CompositePass {
    pub fn new() -> Self {
        CompositePass {
            pipelines: Vec::new(),
            measure: None,
            format: vk::Format::UNDEFINED,
            params: Params::default(),
            measure_params: Default::default(),
            auto_frame: false,
            state: AutoExposure::default(),
        }
    }

    /// Makes the pipeline for `format` the first time a game hands a target of that format.
    pub fn use_format(
        &mut self,
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        format: vk::Format,
    ) -> GpuResult<()> {
        self.format = format;
        if self.pipelines.iter().any(|(f, ..)| *f == format) {
            return Ok(());
        }
        let vertex = compiler.compile("fullscreen.vert", &[])?;
        // Only the format's own output path is compiled (composite.frag: MODE).
        let mode = mode_for(format).to_string();
        let fragment = compiler.compile("composite.frag", &[("MODE", mode.as_str())])?;
        let push = std::mem::size_of::<Params>() as u32;
        let p = create_fullscreen_pipeline(ctx, "composite", &vertex, &fragment, push, format)?;
        let fragment =
            compiler.compile("composite.frag", &[("MODE", mode.as_str()), ("AUTO_EXPOSURE", "1")])?;
        let auto =
            create_fullscreen_pipeline(ctx, "composite (auto exposure)", &vertex, &fragment, push, format)?;
        self.pipelines.push((format, p, auto));
        if self.measure.is_none() {
            let spirv = compiler.compile("exposure.comp", &[])?;
            let push = std::mem::size_of::<super::tonemap::Params>() as u32;
            self.measure = Some(create_compute_pipeline(ctx, "exposure", &spirv, push)?);
        }
        Ok(())
    }

    /// This frame's drawing pipeline: for the target's format, with the frame's exposure kind.
    fn current(&self) -> Option<&Pipeline> {
        let (_, fixed, auto) = self.pipelines.iter().find(|(f, ..)| *f == self.format)?;
        Some(if self.auto_frame { auto } else { fixed })
    }
}

impl Default for CompositePass {
    fn default() -> Self {
        Self::new()
    }
}

/// hadou's HDR image read by the composite's fragment shader.
const FRAGMENT_STORAGE_READ: ImageAccess = ImageAccess {
    stage: vk::PipelineStageFlags2::FRAGMENT_SHADER,
    access: vk::AccessFlags2::SHADER_STORAGE_READ,
    layout: vk::ImageLayout::GENERAL,
};

/// The same, read by exposure.comp before (`exposure = "auto"`).
const MEASURED_FRAGMENT_STORAGE_READ: ImageAccess = ImageAccess {
    stage: vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw() | vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw(),
    ),
    access: vk::AccessFlags2::SHADER_STORAGE_READ,
    layout: vk::ImageLayout::GENERAL,
};

impl Pass for CompositePass {
    fn name(&self) -> &'static str {
        "composite"
    }

    fn images(&self) -> Vec<ImageUse> {
        vec![ImageUse::new(Target::GameColor, ImageAccess::COLOR_ATTACHMENT)]
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        self.auto_frame = frame.scene.render.exposure_mode == ExposureMode::Auto && self.measure.is_some();
        if !self.auto_frame {
            self.state.reset();
            // exposure / pre-exposure: the HDR target is pre-exposed (`effects::tonemap::pre_exposure`).
            let exposure = crate::effects::tonemap::tonemap_factor(frame.scene, frame.pre_exposure) as f32;
            self.params = Params { exposure, ..Params::default() };
            return Ok(vec![Binding::Image(ImageUse::new(Target::Hdr, FRAGMENT_STORAGE_READ))]);
        }
        let (auto, buffer) = self.state.prepare(frame)?;
        let (pre_log2, history, weight) = auto;
        self.params = Params { exposure: 0.0, pre_log2, history, weight };
        self.measure_params =
            super::tonemap::Params::measurement(frame.extent.width, frame.extent.height, auto);
        // Binding 1 is exposure.comp's and tonemap.comp's `ldr`, unused here: the HDR again.
        let hdr = Binding::Image(ImageUse::new(Target::Hdr, MEASURED_FRAGMENT_STORAGE_READ));
        Ok(vec![hdr, hdr, Binding::read(Target::Ids), Binding::Written(buffer, Reader::Host)])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        match (self.auto_frame, &self.measure) {
            (true, Some(measure)) => [Some(measure), self.current()].into_iter().flatten().collect(),
            _ => self.current().into_iter().collect(),
        }
    }

    fn record(&self, pass: &PassRecording) {
        let Some(pipeline) = self.current() else { return };
        let rec = pass.rec;
        let mut set = pass.set(0);
        if let (true, Some(measure)) = (self.auto_frame, &self.measure) {
            rec.bind_pipeline(measure, pass.set(0));
            rec.push_constants(measure, bytemuck::bytes_of(&self.measure_params));
            rec.dispatch_groups(1, 1);
            // The measurement, written by the compute shader, read by the fragment shader.
            let (write, read) =
                (vk::AccessFlags2::SHADER_STORAGE_WRITE, vk::AccessFlags2::SHADER_STORAGE_READ);
            let b = memory_barrier(
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                write,
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                read,
            );
            cmd_barriers(&rec.ctx.device, rec.cmd, &[], &[b]);
            set = pass.set(1);
        }
        let color = pass.targets.image(Target::GameColor);
        rec.begin_rendering_views(pass.targets.extent, &[(color.view, None)], None);
        rec.bind_pipeline(pipeline, set);
        rec.push_constants(pipeline, bytemuck::bytes_of(&self.params));
        rec.draw_fullscreen();
        rec.end_rendering();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_by_format() {
        assert_eq!(mode_for(vk::Format::B8G8R8A8_SRGB), 0);
        assert_eq!(mode_for(vk::Format::R8G8B8A8_UNORM), 1);
        assert_eq!(mode_for(vk::Format::R16G16B16A16_SFLOAT), 2);
        assert_eq!(mode_for(vk::Format::B10G11R11_UFLOAT_PACK32), 2);
    }
}
