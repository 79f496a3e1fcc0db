//! tonemap: HDR → sRGB with exposure and the ACES filmic curve (Narkowicz 2015 fit), into hadou's
//! own `ldr` image. Runs when hadou's result is its own image (headless); a game's colour target
//! gets `composite` instead. CPU twin: `effects::tonemap::tonemap_pixel`.

use super::{Binding, FrameContext, ImageUse, Pass, PassRecording};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::pipeline::{create_compute_pipeline, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{GpuContext, GpuResult};
use crate::targets::Target;

pub struct TonemapPass {
    pipeline: Pipeline,
    params: Params,
}

/// Push constants of shaders/tonemap.comp (size checked against the shader).
#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Params {
    exposure: f32,
    width: u32,
    height: u32,
}

crate::gpu::layout::gpu_layout!(Params as "Params" { exposure, width, height });

impl TonemapPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let spirv = compiler.compile("tonemap.comp", &[])?;
        let push = std::mem::size_of::<Params>() as u32;
        Ok(TonemapPass {
            pipeline: create_compute_pipeline(ctx, "tonemap", &spirv, push)?,
            params: Params::default(),
        })
    }
}

impl Pass for TonemapPass {
    fn name(&self) -> &'static str {
        "tonemap"
    }

    fn images(&self) -> Vec<ImageUse> {
        vec![
            ImageUse::new(Target::Hdr, ImageAccess::COMPUTE_READ),
            ImageUse::new(Target::Ldr, ImageAccess::COMPUTE_WRITE),
        ]
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let e = frame.extent;
        self.params =
            Params { exposure: frame.scene.render.exposure as f32, width: e.width, height: e.height };
        Ok(vec![Binding::Image(Target::Hdr), Binding::Image(Target::Ldr)])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
        pass.rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        pass.rec.dispatch_2d(self.params.width, self.params.height, (8, 8));
    }
}
