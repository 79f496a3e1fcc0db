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

/// The copy that fills an image staged by `stage_image`, with the barriers around it, recorded
/// into a command buffer by `record` (a one-off at load, or the next frame's for a run-time bake).
/// Dropping it after recording retires the staging buffer with the frames that may still read it.
pub struct ImageCopy {
    staging: super::memory::Buffer,
    image: vk::Image,
    format: vk::Format,
    extent: vk::Extent2D,
}

impl ImageCopy {
    /// Records the copy on a one-off command buffer and waits for it by its own fence (at load,
    /// not in a frame); the staging buffer is freed with the frames.
    pub fn submit_once(self, ctx: &GpuContext) -> GpuResult<()> {
        let mut commands = FrameCommands::new(ctx, "image upload")?;
        commands.begin(ctx)?;
        self.record(ctx, commands.cmd);
        commands.submit_and_wait(ctx, "image upload")
    }

    /// Records the upload: to TRANSFER_DST, the copy, then to SHADER_READ_ONLY_OPTIMAL visible to
    /// fragment and compute shaders (`SAMPLED_ANYWHERE`); the image never changes layout after.
    pub fn record(&self, ctx: &GpuContext, cmd: vk::CommandBuffer) {
        let (image, format, extent) = (self.image, self.format, self.extent);
        let to_dst = image_barrier(image, format, ImageAccess::UNDEFINED, ImageAccess::TRANSFER_DST);
        cmd_barriers(&ctx.device, cmd, &to_dst.into_iter().collect::<Vec<_>>(), &[]);
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
            )
            .image_extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 });
        // SAFETY: recording; the buffer holds exactly the image's bytes, the image is in
        // TRANSFER_DST_OPTIMAL after the barrier above.
        unsafe {
            ctx.device.cmd_copy_buffer_to_image(
                cmd,
                self.staging.raw,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
        let to_read = image_barrier(image, format, ImageAccess::TRANSFER_DST, SAMPLED_ANYWHERE);
        cmd_barriers(&ctx.device, cmd, &to_read.into_iter().collect::<Vec<_>>(), &[]);
    }
}

/// Creates a sampled 2D image of `extent` and `format` named `name` and the copy that fills it
/// with `bytes` (tightly packed rows of `texel_bytes`-byte texels, row 0 first), not recorded yet.
pub fn stage_image(
    ctx: &GpuContext,
    memory: &Memory,
    name: &str,
    extent: vk::Extent2D,
    format: vk::Format,
    texel_bytes: u64,
    bytes: &[u8],
) -> GpuResult<(Image, ImageCopy)> {
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
    let copy = ImageCopy { staging, image: image.raw, format, extent };
    Ok((image, copy))
}

/// `stage_image`, then the copy on a one-off command buffer, waited for by its own fence (at
/// load, not in a frame). The image is left in SHADER_READ_ONLY_OPTIMAL for good.
pub fn upload_image(
    ctx: &GpuContext,
    memory: &Memory,
    name: &str,
    extent: vk::Extent2D,
    format: vk::Format,
    texel_bytes: u64,
    bytes: &[u8],
) -> GpuResult<Image> {
    let (image, copy) = stage_image(ctx, memory, name, extent, format, texel_bytes, bytes)?;
    copy.submit_once(ctx)?;
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
