//! A 2D image a compute shader samples, filled once from host bytes: scene data baked on the CPU
//! (the thickness pair table of seed 003). `stage_compute_image` makes the image and a staging
//! buffer holding the bytes; the copy is recorded by the first frame that reads it
//! (`StagedCopy::record`, nothing waited for), which leaves the image in SHADER_READ_ONLY_OPTIMAL
//! for good, so the passes reading it need no barrier of their own afterwards.

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::barriers::{cmd_barriers, image_barrier, ImageAccess};
use super::context::GpuContext;
use super::error::{GpuError, GpuResult};
use super::memory::{Buffer, Image, Memory};
use super::recorder::Recorder;

/// A staged image's copy not yet recorded: the staging buffer (retired with the frame that records
/// the copy) and where it goes.
pub struct StagedCopy {
    staging: Buffer,
    image: vk::Image,
    format: vk::Format,
    extent: vk::Extent2D,
}

impl StagedCopy {
    /// Writes `data` into the staging buffer at `offset` (the image's bytes, row 0 first); an
    /// error naming the buffer past its end.
    pub fn write(&mut self, offset: usize, data: &[u8]) -> GpuResult<()> {
        self.staging.write(offset, data)
    }

    /// Records the copy into the frame's command buffer and leaves the image ready for compute
    /// shaders to sample (`ImageAccess::COMPUTE_SAMPLED`).
    pub fn record(self, rec: &Recorder) {
        let (ctx, cmd) = (rec.ctx, rec.cmd);
        let to_dst =
            image_barrier(self.image, self.format, ImageAccess::UNDEFINED, ImageAccess::TRANSFER_DST);
        cmd_barriers(&ctx.device, cmd, &to_dst.into_iter().collect::<Vec<_>>(), &[]);
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
            )
            .image_extent(vk::Extent3D { width: self.extent.width, height: self.extent.height, depth: 1 });
        // SAFETY: recording; the staging buffer holds exactly the image's bytes (checked when it was
        // staged) and the image is in TRANSFER_DST_OPTIMAL after the barrier; both are retired only
        // with the frames that may use them.
        unsafe {
            ctx.device.cmd_copy_buffer_to_image(
                cmd,
                self.staging.raw,
                self.image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
        let to_read =
            image_barrier(self.image, self.format, ImageAccess::TRANSFER_DST, ImageAccess::COMPUTE_SAMPLED);
        cmd_barriers(&ctx.device, cmd, &to_read.into_iter().collect::<Vec<_>>(), &[]);
        // The staging buffer drops here: retired with the frame being recorded.
    }
}

/// Creates a sampled 2D image of `extent` and `format` named `name` and a staging buffer holding
/// `bytes` (tightly packed rows of `texel_bytes`-byte texels, row 0 first): the copy is recorded
/// by the frame that first reads the image (`StagedCopy::record`). Waits for nothing.
pub fn stage_compute_image(
    ctx: &GpuContext,
    memory: &Memory,
    name: &str,
    extent: vk::Extent2D,
    format: vk::Format,
    texel_bytes: u64,
    bytes: &[u8],
) -> GpuResult<(Image, StagedCopy)> {
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
    let (image, mut copy) = stage_empty_compute_image(ctx, memory, name, extent, format, texel_bytes)?;
    copy.write(0, bytes)?;
    Ok((image, copy))
}

/// `stage_compute_image` with the staging buffer not written yet: the caller fills it with
/// `StagedCopy::write` (a slice at a time, e.g. spread over frames) before the copy is recorded.
pub fn stage_empty_compute_image(
    ctx: &GpuContext,
    memory: &Memory,
    name: &str,
    extent: vk::Extent2D,
    format: vk::Format,
    texel_bytes: u64,
) -> GpuResult<(Image, StagedCopy)> {
    let bytes = extent.width as u64 * extent.height as u64 * texel_bytes;
    let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
    let image = memory.create_image(ctx, name, extent, format, usage)?;
    let src = vk::BufferUsageFlags::TRANSFER_SRC;
    let staging =
        memory.create_buffer(ctx, &format!("{name} staging"), bytes, src, MemoryLocation::CpuToGpu)?;
    let copy = StagedCopy { staging, image: image.raw, format, extent };
    Ok((image, copy))
}
