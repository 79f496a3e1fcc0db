//! upscaler_out: a temporal upscaler's inputs written into the game's own images
//! (`View::upscaler`, shaders/upscaler_out.comp) after the frame's passes: hadou's motion where it
//! drew a surface (the game's own motion elsewhere is kept), and the larger of the game's and
//! hadou's reactive and composition masks. One pipeline per set of the game's formats, built the
//! first time a frame brings them (as `composite`'s per colour format).

use super::{Binding, FrameContext, Pass, PassRecording};
use crate::gpu::pipeline::{create_compute_pipeline, Bound, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::targets::Target;

/// The storage format qualifier of a motion image the pass writes, if it can.
pub fn motion_qualifier(format: vk::Format) -> Option<&'static str> {
    match format {
        vk::Format::R16G16_SFLOAT => Some("rg16f"),
        vk::Format::R32G32_SFLOAT => Some("rg32f"),
        _ => None,
    }
}

/// The storage format qualifier of a mask image (reactive, composition) the pass writes, if it can.
pub fn mask_qualifier(format: vk::Format) -> Option<&'static str> {
    match format {
        vk::Format::R8_UNORM => Some("r8"),
        vk::Format::R16_SFLOAT => Some("r16f"),
        vk::Format::R32_SFLOAT => Some("r32f"),
        _ => None,
    }
}

/// The game's formats of a frame: motion, and the masks it gave.
pub type Formats = (vk::Format, Option<vk::Format>, Option<vk::Format>);

#[derive(Default)]
pub struct UpscalerOutPass {
    pipelines: Vec<(Formats, Pipeline)>,
    /// This frame's formats (`use_formats`) and size.
    formats: Option<Formats>,
    extent: vk::Extent2D,
}

impl UpscalerOutPass {
    pub fn new() -> Self {
        Self::default()
    }

    /// The frame's formats, their pipeline built when new (the formats are checked by the caller).
    pub fn use_formats(
        &mut self,
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        formats: Formats,
    ) -> GpuResult<()> {
        self.formats = Some(formats);
        if self.pipelines.iter().any(|(f, _)| *f == formats) {
            return Ok(());
        }
        let (motion, reactive, composition) = formats;
        let mut defines = vec![("MOTION_FORMAT", motion_qualifier(motion).unwrap_or("rg32f"))];
        if let Some(q) = reactive.and_then(mask_qualifier) {
            defines.push(("REACTIVE_FORMAT", q));
        }
        if let Some(q) = composition.and_then(mask_qualifier) {
            defines.push(("COMPOSITION_FORMAT", q));
        }
        let spirv = compiler.compile("upscaler_out.comp", &defines)?;
        self.pipelines.push((formats, create_compute_pipeline(ctx, "upscaler_out", &spirv, 0)?));
        Ok(())
    }

    fn current(&self) -> Option<&Pipeline> {
        let formats = self.formats?;
        self.pipelines.iter().find(|(f, _)| *f == formats).map(|(_, p)| p)
    }
}

impl Pass for UpscalerOutPass {
    fn name(&self) -> &'static str {
        "upscaler_out"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        self.extent = frame.extent;
        let (_, reactive, composition) = self.formats.unwrap_or((vk::Format::UNDEFINED, None, None));
        // Bindings 5 and 6: the masks the game gave; a pipeline without one declares nothing there.
        let mask = |given: bool, target| {
            if given {
                Binding::read_write(target)
            } else {
                Binding::Bound(Bound::Unused)
            }
        };
        Ok(vec![
            Binding::read(Target::Ids),
            Binding::read(Target::Motion),
            Binding::read(Target::Reactive),
            Binding::read(Target::Composition),
            Binding::read_write(Target::GameMotion),
            mask(reactive.is_some(), Target::GameReactive),
            mask(composition.is_some(), Target::GameComposition),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        self.current().into_iter().collect()
    }

    fn record(&self, pass: &PassRecording) {
        let Some(pipeline) = self.current() else { return };
        pass.rec.bind_pipeline(pipeline, pass.set(0));
        pass.rec.dispatch_2d(self.extent.width, self.extent.height, (8, 8));
    }
}
