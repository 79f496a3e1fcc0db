//! Samplers: NEAREST for `texelFetch` and depth reads (D32 on lavapipe has no linear filtering),
//! or any the caller describes (a glTF file's texture samplers).

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuResult, VkResultExt};
use super::resources::{Garbage, Releaser};

/// A sampler; passes hold it next to the images they sample.
pub struct Sampler {
    pub raw: vk::Sampler,
    releaser: Releaser,
}

impl Drop for Sampler {
    fn drop(&mut self) {
        self.releaser.retire(Garbage::Sampler(self.raw));
    }
}

impl Sampler {
    /// A sampler made from `info` (filters, address modes, lod range).
    pub fn new(ctx: &GpuContext, name: &str, info: &vk::SamplerCreateInfo) -> GpuResult<Sampler> {
        // SAFETY: valid device; retired by Drop.
        let raw = unsafe { ctx.device.create_sampler(info, None) }.vk("vkCreateSampler")?;
        ctx.name_object(raw, name);
        Ok(Sampler { raw, releaser: ctx.releaser() })
    }

    /// NEAREST filtering, clamped, no mipmaps: what `texelFetch` and depth (D32 on lavapipe) need.
    pub fn nearest(ctx: &GpuContext, name: &str) -> GpuResult<Sampler> {
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(0.0);
        // SAFETY: valid device; destroyed by `destroy`.
        let raw = unsafe { ctx.device.create_sampler(&info, None) }.vk("vkCreateSampler")?;
        ctx.name_object(raw, name);
        Ok(Sampler { raw, releaser: ctx.releaser() })
    }
}
