//! composite: hadou's HDR result drawn over the game's colour target (shaders/composite.frag):
//! over where hadou drew a surface, added where only the wave glows. One pipeline per colour
//! format the game has used.

use super::{Binding, FrameContext, ImageUse, Pass, PassRecording};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::fullscreen::create_fullscreen_pipeline;
use crate::gpu::pipeline::Pipeline;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::targets::Target;

/// Push constants of shaders/composite.frag (size checked against the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Params {
    exposure: f32,
    mode: u32,
}

crate::gpu::layout::gpu_layout!(Params as "Params" { exposure, mode });

/// What the shader writes for a colour format (see `ExternalColor`).
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
    pipelines: Vec<(vk::Format, Pipeline)>,
    /// This frame's target format (its pipeline exists: `use_format`).
    format: vk::Format,
    params: Params,
}

impl CompositePass {
    pub fn new() -> Self {
        CompositePass { pipelines: Vec::new(), format: vk::Format::UNDEFINED, params: Params::default() }
    }

    /// Makes the pipeline for `format` the first time a game hands a target of that format.
    pub fn use_format(
        &mut self,
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        format: vk::Format,
    ) -> GpuResult<()> {
        self.format = format;
        if self.pipelines.iter().any(|(f, _)| *f == format) {
            return Ok(());
        }
        let vertex = compiler.compile("fullscreen.vert", &[])?;
        let fragment = compiler.compile("composite.frag", &[])?;
        let push = std::mem::size_of::<Params>() as u32;
        let p = create_fullscreen_pipeline(ctx, "composite", &vertex, &fragment, push, format)?;
        self.pipelines.push((format, p));
        Ok(())
    }

    fn current(&self) -> Option<&Pipeline> {
        self.pipelines.iter().find(|(f, _)| *f == self.format).map(|(_, p)| p)
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

impl Pass for CompositePass {
    fn name(&self) -> &'static str {
        "composite"
    }

    fn images(&self) -> Vec<ImageUse> {
        vec![
            ImageUse::new(Target::Hdr, FRAGMENT_STORAGE_READ),
            ImageUse::new(Target::GameColor, ImageAccess::COLOR_ATTACHMENT),
        ]
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        // exposure / pre-exposure: the HDR target is pre-exposed (`effects::tonemap::pre_exposure`).
        let exposure = crate::effects::tonemap::tonemap_factor(frame.scene) as f32;
        self.params = Params { exposure, mode: mode_for(self.format) };
        Ok(vec![Binding::Image(Target::Hdr)])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        self.current().into_iter().collect()
    }

    fn record(&self, pass: &PassRecording) {
        let Some(pipeline) = self.current() else { return };
        let rec = pass.rec;
        let color = pass.targets.image(Target::GameColor);
        rec.begin_rendering_views(pass.targets.extent, &[(color.view, None)], None);
        rec.bind_pipeline(pipeline, pass.set(0));
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
