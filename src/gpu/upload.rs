//! One-off uploads at scene load: a 2D image filled from host bytes through a staging buffer (then
//! left in SHADER_READ_ONLY_OPTIMAL for sampling by compute and fragment shaders), and a NEAREST
//! sampler to read it with `texelFetch`.

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::barriers::{cmd_barriers, image_barrier, ImageAccess};
use super::commands::FrameCommands;
use super::context::GpuContext;
use super::error::{GpuError, GpuResult, VkResultExt};
use super::memory::{Image, Memory};
use super::resources::{Garbage, Releaser};

/// Where an uploaded image waits to be sampled: fragment and compute shaders.
pub const SAMPLED_ANYWHERE: ImageAccess = ImageAccess {
    stage: vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw() | vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw(),
    ),
    access: vk::AccessFlags2::SHADER_SAMPLED_READ,
    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
};

/// Creates a sampled 2D image of `extent` and `format` named `name`, fills it with `bytes` (tightly
/// packed rows of `texel_bytes`-byte texels, row 0 first) and waits for the copy. The image is left
/// in SHADER_READ_ONLY_OPTIMAL, made visible to fragment and compute shaders by the upload's own
/// barrier, and never changes layout afterwards (so frames need no barrier for it).
pub fn upload_image(
    ctx: &GpuContext,
    memory: &Memory,
    name: &str,
    extent: vk::Extent2D,
    format: vk::Format,
    texel_bytes: u64,
    bytes: &[u8],
) -> GpuResult<Image> {
    let expected = extent.width as u64 * extent.height as u64 * texel_bytes;
    if bytes.len() as u64 != expected {
        return Err(GpuError::Limit {
            what: name.into(),
            message: format!(
                "{} bytes given for a {}x{} image of {texel_bytes}-byte texels ({expected} bytes)",
                bytes.len(),
                extent.width,
                extent.height
            ),
        });
    }
    let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
    let image = memory.create_image(ctx, name, extent, format, usage)?;
    let staging_name = format!("{name} staging");
    let src = vk::BufferUsageFlags::TRANSFER_SRC;
    let mut staging = memory.create_buffer(ctx, &staging_name, expected, src, MemoryLocation::CpuToGpu)?;
    staging.write(0, bytes)?;
    {
        let mut commands = FrameCommands::new(ctx, &format!("{name} upload"))?;
        commands.begin(ctx)?;
        {
            let cmd = commands.cmd;
            let to_dst = image_barrier(image.raw, format, ImageAccess::UNDEFINED, ImageAccess::TRANSFER_DST);
            cmd_barriers(&ctx.device, cmd, &to_dst.into_iter().collect::<Vec<_>>(), &[]);
            let region = vk::BufferImageCopy::default()
                .image_subresource(
                    vk::ImageSubresourceLayers::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .layer_count(1),
                )
                .image_extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 });
            // SAFETY: recording; the buffer holds exactly the image's bytes, the image is in
            // TRANSFER_DST_OPTIMAL after the barrier above.
            unsafe {
                ctx.device.cmd_copy_buffer_to_image(
                    cmd,
                    staging.raw,
                    image.raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                )
            };
            let to_read = image_barrier(image.raw, format, ImageAccess::TRANSFER_DST, SAMPLED_ANYWHERE);
            cmd_barriers(&ctx.device, cmd, &to_read.into_iter().collect::<Vec<_>>(), &[]);
        }
        // A one-off fence wait at load, not a frame: the staging buffer is freed with the frames.
        commands.submit_and_wait(ctx, &format!("{name} upload"))?;
    }
    Ok(image)
}

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
