//! depth_out: hadou's nearest surfaces (its instances and metaballs) written into the game's
//! depth image in the game's own convention (`ExternalDepth::write`), so that the game's later
//! passes are hidden behind them. A full-screen triangle (shaders/depth_out.frag) that discards
//! where hadou drew nothing; no depth test: those surfaces were already tested against the game's
//! depth (the raster against the imported depth, the metaballs against `distance`). CPU twin:
//! `depth_import::store_depth`.

use super::{Binding, FrameContext, ImageUse, Pass, PassRecording};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::pipeline::{create_graphics_pipeline, Blend, Bound, GraphicsDesc, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::renderer::DepthConvention;
use crate::targets::Target;

/// Push constants of shaders/depth_out.frag (size checked against the shader). The camera's ray
/// frame and the frame's size are the frame's uniforms (`FrameUniforms`: `ray_right`, `ray_up`,
/// `ray_forward`, `counts`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Params {
    /// The game's projection (stored d = −A + B / z): A, B; z, w: 0.
    planes: [f32; 4],
}

crate::gpu::layout::gpu_layout!(Params as "Params" { planes });

/// A storage image read by the fragment shader.
const FRAGMENT_STORAGE_READ: ImageAccess = ImageAccess {
    stage: vk::PipelineStageFlags2::FRAGMENT_SHADER,
    access: vk::AccessFlags2::SHADER_STORAGE_READ,
    layout: vk::ImageLayout::GENERAL,
};

/// One pipeline per depth format the game has handed (dynamic rendering bakes the format in).
pub struct DepthOutPass {
    pipelines: Vec<(vk::Format, Pipeline)>,
    format: vk::Format,
    convention: Option<DepthConvention>,
    params: Params,
}

impl DepthOutPass {
    pub fn new() -> Self {
        DepthOutPass {
            pipelines: Vec::new(),
            format: vk::Format::UNDEFINED,
            convention: None,
            params: Params::default(),
        }
    }

    /// This frame's depth image format and convention; makes the format's pipeline the first time.
    pub fn use_depth(
        &mut self,
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        format: vk::Format,
        convention: DepthConvention,
    ) -> GpuResult<()> {
        (self.format, self.convention) = (format, Some(convention));
        if self.pipelines.iter().any(|(f, _)| *f == format) {
            return Ok(());
        }
        let vertex = compiler.compile("fullscreen.vert", &[])?;
        let fragment = compiler.compile("depth_out.frag", &[])?;
        let pipeline = create_graphics_pipeline(
            ctx,
            &GraphicsDesc {
                name: "depth_out",
                vertex: &vertex,
                fragment: &fragment,
                push_constant_bytes: std::mem::size_of::<Params>() as u32,
                vertex_bindings: &[],
                vertex_attributes: &[],
                color_formats: &[],
                depth_format: format,
                depth_compare: vk::CompareOp::ALWAYS,
                cull_mode: vk::CullModeFlags::NONE,
                blend: Blend::Replace,
            },
        )?;
        self.pipelines.push((format, pipeline));
        Ok(())
    }

    fn current(&self) -> Option<&Pipeline> {
        self.pipelines.iter().find(|(f, _)| *f == self.format).map(|(_, p)| p)
    }
}

impl Default for DepthOutPass {
    fn default() -> Self {
        Self::new()
    }
}

impl Pass for DepthOutPass {
    fn name(&self) -> &'static str {
        "depth_out"
    }

    fn images(&self) -> Vec<ImageUse> {
        vec![ImageUse::new(Target::GameDepth, ImageAccess::DEPTH_ATTACHMENT)]
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let (a, b) = self.convention.map_or((0.0, 1.0), |c| c.coefficients());
        self.params = Params { planes: [a as f32, b as f32, 0.0, 0.0] };
        Ok(vec![
            Binding::Image(ImageUse::new(Target::Ids, FRAGMENT_STORAGE_READ)),
            Binding::Image(ImageUse::new(Target::Distance, FRAGMENT_STORAGE_READ)),
            Binding::Bound(Bound::Uniform(frame.uniforms)),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        self.current().into_iter().collect()
    }

    fn record(&self, pass: &PassRecording) {
        let Some(pipeline) = self.current() else { return };
        let rec = pass.rec;
        let depth = pass.targets.image(Target::GameDepth);
        rec.begin_rendering_views(pass.targets.extent, &[], Some((depth.view, None)));
        rec.bind_pipeline(pipeline, pass.set(0));
        rec.push_constants(pipeline, bytemuck::bytes_of(&self.params));
        rec.draw_fullscreen();
        rec.end_rendering();
    }
}
