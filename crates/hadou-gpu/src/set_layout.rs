//! Descriptor set layouts a caller owns, for the sets past 0 of a pipeline
//! (`pipeline::create_graphics_pipeline_with_sets`): e.g. the raster's per-material textures,
//! written once when a scene is loaded rather than every frame.

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuResult, VkResultExt};
use super::resources::{Garbage, Releaser};

/// A descriptor set layout, retired by Drop.
pub struct SetLayout {
    pub raw: vk::DescriptorSetLayout,
    releaser: Releaser,
}

impl SetLayout {
    /// `count` combined image samplers at bindings 0..count, read by `stages`.
    pub fn samplers(
        ctx: &GpuContext,
        name: &str,
        count: u32,
        stages: vk::ShaderStageFlags,
    ) -> GpuResult<Self> {
        let bindings: Vec<_> = (0..count)
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b)
                    .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                    .descriptor_count(1)
                    .stage_flags(stages)
            })
            .collect();
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid device; `bindings` outlives the call; retired by Drop.
        let raw = unsafe { ctx.device.create_descriptor_set_layout(&info, None) }
            .vk("vkCreateDescriptorSetLayout")?;
        ctx.name_object(raw, name);
        Ok(SetLayout { raw, releaser: ctx.releaser() })
    }
}

impl Drop for SetLayout {
    fn drop(&mut self) {
        self.releaser.retire(Garbage::SetLayout(self.raw));
    }
}
