//! Synchronization2 helpers: every image remembers how it was last used, and a pass states how it
//! will use it next; the difference becomes one image barrier (niagara-style).

use ash::vk;

use super::memory::subresource_range;

/// One way of using an image: the stage, the access and the layout it must be in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageAccess {
    pub stage: vk::PipelineStageFlags2,
    pub access: vk::AccessFlags2,
    pub layout: vk::ImageLayout,
}

const WRITES: vk::AccessFlags2 = vk::AccessFlags2::from_raw(
    vk::AccessFlags2::SHADER_WRITE.as_raw()
        | vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw()
        | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw()
        | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
        | vk::AccessFlags2::TRANSFER_WRITE.as_raw()
        | vk::AccessFlags2::HOST_WRITE.as_raw()
        | vk::AccessFlags2::MEMORY_WRITE.as_raw(),
);

impl ImageAccess {
    /// Not yet used: contents undefined.
    pub const UNDEFINED: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::NONE,
        access: vk::AccessFlags2::NONE,
        layout: vk::ImageLayout::UNDEFINED,
    };
    pub const COLOR_ATTACHMENT: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
        access: vk::AccessFlags2::from_raw(
            vk::AccessFlags2::COLOR_ATTACHMENT_READ.as_raw()
                | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw(),
        ),
        layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
    };
    pub const DEPTH_ATTACHMENT: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::from_raw(
            vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS.as_raw()
                | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS.as_raw(),
        ),
        access: vk::AccessFlags2::from_raw(
            vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ.as_raw()
                | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw(),
        ),
        layout: vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
    };
    /// A storage image read by a fragment shader (a full-screen effect pass reading `distance`).
    pub const FRAGMENT_READ: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::FRAGMENT_SHADER,
        access: vk::AccessFlags2::SHADER_STORAGE_READ,
        layout: vk::ImageLayout::GENERAL,
    };
    /// The destination of `vkCmdClearColorImage` on a storage image (GENERAL layout).
    pub const CLEAR_GENERAL: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::CLEAR,
        access: vk::AccessFlags2::TRANSFER_WRITE,
        layout: vk::ImageLayout::GENERAL,
    };
    pub const COMPUTE_READ: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
        access: vk::AccessFlags2::SHADER_STORAGE_READ,
        layout: vk::ImageLayout::GENERAL,
    };
    pub const COMPUTE_WRITE: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
        access: vk::AccessFlags2::SHADER_STORAGE_WRITE,
        layout: vk::ImageLayout::GENERAL,
    };
    pub const COMPUTE_READ_WRITE: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
        access: vk::AccessFlags2::from_raw(
            vk::AccessFlags2::SHADER_STORAGE_READ.as_raw() | vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw(),
        ),
        layout: vk::ImageLayout::GENERAL,
    };
    /// Sampled in a compute shader (e.g. depth with a NEAREST sampler).
    pub const COMPUTE_SAMPLED: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
        access: vk::AccessFlags2::SHADER_SAMPLED_READ,
        layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
    };
    pub const TRANSFER_SRC: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::COPY,
        access: vk::AccessFlags2::TRANSFER_READ,
        layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
    };
    pub const TRANSFER_DST: ImageAccess = ImageAccess {
        stage: vk::PipelineStageFlags2::from_raw(
            vk::PipelineStageFlags2::COPY.as_raw() | vk::PipelineStageFlags2::CLEAR.as_raw(),
        ),
        access: vk::AccessFlags2::TRANSFER_WRITE,
        layout: vk::ImageLayout::TRANSFER_DST_OPTIMAL,
    };

    /// Whether this use writes the image.
    pub fn writes(&self) -> bool {
        self.access.intersects(WRITES)
    }
}

/// Builds the barrier taking an image from `prev` to `next`, or None when no hazard exists
/// (read after read in the same layout).
pub fn image_barrier(
    image: vk::Image,
    format: vk::Format,
    prev: ImageAccess,
    next: ImageAccess,
) -> Option<vk::ImageMemoryBarrier2<'static>> {
    if prev.layout == next.layout && !prev.writes() && !next.writes() {
        return None;
    }
    Some(
        vk::ImageMemoryBarrier2::default()
            .src_stage_mask(prev.stage)
            .src_access_mask(prev.access & WRITES)
            .dst_stage_mask(next.stage)
            .dst_access_mask(next.access)
            .old_layout(prev.layout)
            .new_layout(next.layout)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(subresource_range(format)),
    )
}

/// A global memory barrier, e.g. transfer writes before host reads.
pub fn memory_barrier(
    src_stage: vk::PipelineStageFlags2,
    src_access: vk::AccessFlags2,
    dst_stage: vk::PipelineStageFlags2,
    dst_access: vk::AccessFlags2,
) -> vk::MemoryBarrier2<'static> {
    vk::MemoryBarrier2::default()
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)
}

/// Records the barriers in one vkCmdPipelineBarrier2; nothing when both lists are empty.
pub fn cmd_barriers(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    images: &[vk::ImageMemoryBarrier2],
    memory: &[vk::MemoryBarrier2],
) {
    if images.is_empty() && memory.is_empty() {
        return;
    }
    let dep = vk::DependencyInfo::default().image_memory_barriers(images).memory_barriers(memory);
    // SAFETY: cmd is recording; the barriers name live images.
    unsafe { device.cmd_pipeline_barrier2(cmd, &dep) };
}
