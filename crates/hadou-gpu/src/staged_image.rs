//! A 2D image a compute shader samples, filled once from host bytes: scene data baked on the CPU
//! (the thickness pair table of seed 003). A staging buffer, a one-off command buffer waited for by
//! its own fence (at load, or when a run-time bake is put in use: once per table, never per frame),
//! then the image stays in SHADER_READ_ONLY_OPTIMAL for good, so the passes reading it need no
//! barrier of their own.

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::barriers::{cmd_barriers, image_barrier, ImageAccess};
use super::commands::FrameCommands;
use super::context::GpuContext;
use super::error::{GpuError, GpuResult};
use super::memory::{Image, Memory};

/// Creates a sampled 2D image of `extent` and `format` named `name`, fills it with `bytes` (tightly
/// packed rows of `texel_bytes`-byte texels, row 0 first) and leaves it ready for compute shaders
/// to sample (`ImageAccess::COMPUTE_SAMPLED`). Waits for the copy.
pub fn upload_compute_image(
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
        return Err(GpuError::Shader {
            name: name.into(),
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
    let src = vk::BufferUsageFlags::TRANSFER_SRC;
    let mut staging =
        memory.create_buffer(ctx, &format!("{name} staging"), expected, src, MemoryLocation::CpuToGpu)?;
    staging.write(0, bytes)?;
    let mut commands = FrameCommands::new(ctx, &format!("{name} upload"))?;
    commands.begin(ctx)?;
    let cmd = commands.cmd;
    let to_dst = image_barrier(image.raw, format, ImageAccess::UNDEFINED, ImageAccess::TRANSFER_DST);
    cmd_barriers(&ctx.device, cmd, &to_dst.into_iter().collect::<Vec<_>>(), &[]);
    let region = vk::BufferImageCopy::default()
        .image_subresource(
            vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
        )
        .image_extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 });
    // SAFETY: recording; the staging buffer holds exactly the image's bytes (checked above) and the
    // image is in TRANSFER_DST_OPTIMAL after the barrier; both outlive the wait below.
    unsafe {
        ctx.device.cmd_copy_buffer_to_image(
            cmd,
            staging.raw,
            image.raw,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &[region],
        )
    };
    let to_read = image_barrier(image.raw, format, ImageAccess::TRANSFER_DST, ImageAccess::COMPUTE_SAMPLED);
    cmd_barriers(&ctx.device, cmd, &to_read.into_iter().collect::<Vec<_>>(), &[]);
    commands.submit_and_wait(ctx, name)?;
    Ok(image)
}
