//! composite: hadou's HDR result drawn over the game's colour target (shaders/composite.frag):
//! over where hadou drew a surface, added where only the wave glows. One pipeline per colour
//! format the game has used.

use super::inputs::ExternalColor;
use crate::gpu::fullscreen::create_fullscreen_pipeline;
use crate::gpu::pipeline::{binding, write_set, Bound, DescriptorPool, Pipeline};
use crate::gpu::recorder::Recorder;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};

/// Push constants; keep in sync with shaders/composite.frag.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    exposure: f32,
    mode: u32,
}

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

pub struct Composite {
    pipelines: Vec<(vk::Format, Pipeline)>,
    pool: DescriptorPool,
    /// Reads hadou's `hdr`; rewritten when the frame's images are made anew.
    set: Option<vk::DescriptorSet>,
}

fn bindings() -> [vk::DescriptorSetLayoutBinding<'static>; 1] {
    [binding(0, vk::DescriptorType::STORAGE_IMAGE, vk::ShaderStageFlags::FRAGMENT)]
}

impl Composite {
    pub fn new(ctx: &GpuContext) -> GpuResult<Self> {
        let pool = DescriptorPool::new(ctx, "composite descriptors", 1)?;
        Ok(Composite { pipelines: Vec::new(), pool, set: None })
    }

    /// The pipeline for `format`, built the first time the game hands a target of that format.
    fn pipeline(
        &mut self,
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        format: vk::Format,
    ) -> GpuResult<usize> {
        if let Some(i) = self.pipelines.iter().position(|(f, _)| *f == format) {
            return Ok(i);
        }
        let vertex = compiler.compile("fullscreen.vert", &[])?;
        let fragment = compiler.compile("composite.frag", &[])?;
        let push = std::mem::size_of::<Params>() as u32;
        let p = create_fullscreen_pipeline(ctx, "composite", &vertex, &fragment, &bindings(), push, format)?;
        self.pipelines.push((format, p));
        Ok(self.pipelines.len() - 1)
    }

    /// Points the set at `hdr` (after the frame's images were made anew; no frame pending).
    fn set(
        &mut self,
        ctx: &GpuContext,
        layout: vk::DescriptorSetLayout,
        hdr: vk::ImageView,
    ) -> GpuResult<vk::DescriptorSet> {
        if let Some(set) = self.set {
            return Ok(set);
        }
        let set = self.pool.allocate(ctx, layout, "composite set")?;
        write_set(ctx, set, &[(0, Bound::StorageImage(hdr))]);
        self.set = Some(set);
        Ok(set)
    }

    /// Gets the pipeline and set ready outside any command recording state.
    pub fn prepare(
        &mut self,
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        format: vk::Format,
        hdr: vk::ImageView,
    ) -> GpuResult<()> {
        let i = self.pipeline(ctx, compiler, format)?;
        let layout = self.pipelines[i].1.set_layout;
        self.set(ctx, layout, hdr)?;
        Ok(())
    }

    /// Draws into `color` (already in COLOR_ATTACHMENT_OPTIMAL); `prepare` ran for its format.
    pub fn record(&self, rec: &Recorder, color: &ExternalColor, extent: vk::Extent2D, exposure: f64) {
        let (Some((_, pipeline)), Some(set)) =
            (self.pipelines.iter().find(|(f, _)| *f == color.format), self.set)
        else {
            return;
        };
        rec.begin_rendering_views(extent, &[(color.view, None)], None);
        rec.bind_pipeline(pipeline, set);
        let params = Params { exposure: exposure as f32, mode: mode_for(color.format) };
        rec.push_constants(pipeline, vk::ShaderStageFlags::FRAGMENT, bytemuck::bytes_of(&params));
        rec.draw_fullscreen();
        rec.end_rendering();
    }

    /// Drops the set (the images it points at are being replaced). No frame pending.
    pub fn drop_sized(&mut self, ctx: &GpuContext) {
        if self.set.take().is_some() {
            let _ = self.pool.reset(ctx);
        }
    }

    pub fn destroy(self, ctx: &GpuContext) {
        for (_, p) in &self.pipelines {
            p.destroy(ctx);
        }
        self.pool.destroy(ctx);
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
