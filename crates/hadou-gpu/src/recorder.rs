//! Command recording for passes: the few commands hadou's passes use, so pass code states what
//! it does and this crate stays the only code that calls ash.

use ash::vk;

use super::context::GpuContext;
use super::memory::{Buffer, ImageHandles};
use super::pipeline::Pipeline;

pub struct Recorder<'a> {
    pub ctx: &'a GpuContext,
    pub cmd: vk::CommandBuffer,
}

/// A colour attachment of a dynamic-rendering pass, cleared to `clear` at the start.
pub struct ColorTarget {
    pub view: vk::ImageView,
    pub clear: vk::ClearColorValue,
}

impl Recorder<'_> {
    fn device(&self) -> &ash::Device {
        &self.ctx.device
    }

    pub fn bind_pipeline(&self, pipeline: &Pipeline, set: vk::DescriptorSet) {
        // SAFETY: recording; the pipeline and set are live until the frame's fence.
        unsafe {
            self.device().cmd_bind_pipeline(self.cmd, pipeline.bind_point, pipeline.raw);
            self.device().cmd_bind_descriptor_sets(
                self.cmd,
                pipeline.bind_point,
                pipeline.layout,
                0,
                &[set],
                &[],
            );
        }
    }

    /// Binds `set` as set `index` (> 0: a set the caller made for a layout it gave the pipeline,
    /// `create_graphics_pipeline_with_sets`) for the draws that follow.
    pub fn bind_set(&self, pipeline: &Pipeline, index: u32, set: vk::DescriptorSet) {
        // SAFETY: recording; the pipeline's layout has set `index` (the caller's contract) and the
        // set is live until the frame's fence.
        unsafe {
            self.device().cmd_bind_descriptor_sets(
                self.cmd,
                pipeline.bind_point,
                pipeline.layout,
                index,
                &[set],
                &[],
            )
        };
    }

    /// Copies a texture's mip levels from `staging` into `image` (a colour image of that many
    /// levels, never used before: its contents are discarded) and leaves it ready to sample in
    /// fragment shaders. `levels`: each level's byte offset in `staging` and its size, level 0
    /// first, tightly packed texels.
    pub fn upload_texture(&self, staging: &Buffer, image: vk::Image, levels: &[(u64, vk::Extent2D)]) {
        use super::barriers::cmd_barriers;
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .level_count(levels.len() as u32)
            .layer_count(1);
        let barrier = |src: (vk::PipelineStageFlags2, vk::AccessFlags2),
                       dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
                       layouts: (vk::ImageLayout, vk::ImageLayout)| {
            vk::ImageMemoryBarrier2::default()
                .src_stage_mask(src.0)
                .src_access_mask(src.1)
                .dst_stage_mask(dst.0)
                .dst_access_mask(dst.1)
                .old_layout(layouts.0)
                .new_layout(layouts.1)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image)
                .subresource_range(range)
        };
        let copy = (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE);
        let before = barrier(
            (vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE),
            copy,
            (vk::ImageLayout::UNDEFINED, vk::ImageLayout::TRANSFER_DST_OPTIMAL),
        );
        cmd_barriers(self.device(), self.cmd, &[before], &[]);
        let regions: Vec<vk::BufferImageCopy> = levels
            .iter()
            .enumerate()
            .map(|(level, &(offset, extent))| {
                vk::BufferImageCopy::default()
                    .buffer_offset(offset)
                    .image_subresource(
                        vk::ImageSubresourceLayers::default()
                            .aspect_mask(vk::ImageAspectFlags::COLOR)
                            .mip_level(level as u32)
                            .layer_count(1),
                    )
                    .image_extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 })
            })
            .collect();
        // SAFETY: recording, outside rendering; staging and image are live until the frame's
        // fence; the image is in TRANSFER_DST layout (the barrier above) and the buffer holds every
        // level at its offset (the caller's contract).
        unsafe {
            self.device().cmd_copy_buffer_to_image(
                self.cmd,
                staging.raw,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &regions,
            )
        };
        let after = barrier(
            copy,
            (vk::PipelineStageFlags2::FRAGMENT_SHADER, vk::AccessFlags2::SHADER_SAMPLED_READ),
            (vk::ImageLayout::TRANSFER_DST_OPTIMAL, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
        );
        cmd_barriers(self.device(), self.cmd, &[after], &[]);
    }

    /// The push constants of `pipeline`, for the stages its shaders read them in.
    pub fn push_constants(&self, pipeline: &Pipeline, bytes: &[u8]) {
        // SAFETY: recording; the layout is live until the frame's fence, and `bytes` is the Rust
        // push-constant struct whose size `layouts` checked against the shaders (not re-checked here).
        unsafe {
            self.device().cmd_push_constants(self.cmd, pipeline.layout, pipeline.push_stages, 0, bytes)
        };
    }

    /// Makes one compute dispatch's storage writes visible to the next one's reads and writes.
    pub fn compute_to_compute_barrier(&self) {
        use super::barriers::{cmd_barriers, memory_barrier};
        let (stage, access) =
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE);
        let read_write = vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        cmd_barriers(self.device(), self.cmd, &[], &[memory_barrier(stage, access, stage, read_write)]);
    }

    /// Makes one compute dispatch's storage writes visible to the next dispatch's reads and
    /// writes and to its indirect arguments.
    pub fn compute_to_indirect_barrier(&self) {
        use super::barriers::{cmd_barriers, memory_barrier};
        let (stage, access) =
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE);
        let read_write = vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        let b = memory_barrier(
            stage,
            access,
            stage | vk::PipelineStageFlags2::DRAW_INDIRECT,
            read_write | vk::AccessFlags2::INDIRECT_COMMAND_READ,
        );
        cmd_barriers(self.device(), self.cmd, &[], &[b]);
    }

    /// Makes one compute dispatch's storage writes visible to the next dispatches' storage reads
    /// and writes, their texel-buffer reads and their indirect arguments.
    pub fn compute_to_texel_and_indirect_barrier(&self) {
        use super::barriers::{cmd_barriers, memory_barrier};
        let (stage, access) =
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE);
        let reads = vk::AccessFlags2::SHADER_STORAGE_READ
            | vk::AccessFlags2::SHADER_STORAGE_WRITE
            | vk::AccessFlags2::SHADER_SAMPLED_READ
            | vk::AccessFlags2::INDIRECT_COMMAND_READ;
        let b = memory_barrier(stage, access, stage | vk::PipelineStageFlags2::DRAW_INDIRECT, reads);
        cmd_barriers(self.device(), self.cmd, &[], &[b]);
    }

    /// A compute dispatch whose workgroup counts are read from `buffer` at `offset`.
    pub fn dispatch_indirect(&self, buffer: vk::Buffer, offset: u64) {
        // SAFETY: recording with a compute pipeline bound; the caller's buffer is live until the
        // frame's fence.
        unsafe { self.device().cmd_dispatch_indirect(self.cmd, buffer, offset) };
    }

    /// Copies `size` bytes from `src` at `src_offset` to `dst` at `dst_offset` (a buffer of the
    /// game's into one of hadou's: the caller places the barriers around it).
    pub fn copy_buffer(&self, src: vk::Buffer, src_offset: u64, dst: vk::Buffer, dst_offset: u64, size: u64) {
        let region = vk::BufferCopy { src_offset, dst_offset, size };
        // SAFETY: recording outside a render pass; both buffers are live until the frame's fence
        // (the caller's contract for `src`) and the region lies within them.
        unsafe { self.device().cmd_copy_buffer(self.cmd, src, dst, &[region]) };
    }

    /// Makes one compute dispatch's storage-buffer writes visible to a following copy.
    pub fn compute_to_copy_barrier(&self) {
        use super::barriers::{cmd_barriers, memory_barrier};
        let b = memory_barrier(
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::TRANSFER_READ,
        );
        cmd_barriers(self.device(), self.cmd, &[], &[b]);
    }

    /// Clears a whole single-mip colour image in GENERAL layout (a storage image) to `value`.
    pub fn clear_general_image(&self, image: &ImageHandles, value: vk::ClearColorValue) {
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .level_count(1)
            .layer_count(1);
        // SAFETY: recording; the image is live until the frame's fence and in GENERAL layout (the
        // caller's contract); `value` and `range` outlive the call.
        unsafe {
            self.device().cmd_clear_color_image(
                self.cmd,
                image.raw,
                vk::ImageLayout::GENERAL,
                &value,
                &[range],
            )
        };
    }

    /// Makes a clear's writes visible to the fragment shaders' storage reads and writes after it.
    pub fn clear_to_fragment_barrier(&self) {
        use super::barriers::{cmd_barriers, memory_barrier};
        let b = memory_barrier(
            vk::PipelineStageFlags2::CLEAR,
            vk::AccessFlags2::TRANSFER_WRITE,
            vk::PipelineStageFlags2::FRAGMENT_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
        );
        cmd_barriers(self.device(), self.cmd, &[], &[b]);
    }

    /// Dispatches x × y workgroups.
    pub fn dispatch_groups(&self, x: u32, y: u32) {
        // SAFETY: the command buffer is recording with a compute pipeline and its set bound (the
        // caller's contract of every Recorder call after bind_pipeline).
        unsafe { self.device().cmd_dispatch(self.cmd, x, y, 1) };
    }

    /// Dispatches enough `group`-sized workgroups to cover width × height.
    pub fn dispatch_2d(&self, width: u32, height: u32, group: (u32, u32)) {
        // SAFETY: recording with a compute pipeline and its set bound.
        unsafe { self.device().cmd_dispatch(self.cmd, width.div_ceil(group.0), height.div_ceil(group.1), 1) };
    }

    /// Begins dynamic rendering over the full extent, clearing every attachment; sets viewport and scissor.
    pub fn begin_rendering(
        &self,
        extent: vk::Extent2D,
        colors: &[ColorTarget],
        depth: vk::ImageView,
        depth_clear: f32,
    ) {
        let colors: Vec<_> =
            colors.iter().map(|c| (c.view, Some(vk::ClearValue { color: c.clear }))).collect();
        let depth_clear =
            vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: depth_clear, stencil: 0 } };
        self.begin_rendering_views(extent, &colors, Some((depth, Some(depth_clear))));
    }

    /// Begins dynamic rendering over the full extent into image views; each attachment is cleared
    /// to its value, or loaded when it has none (e.g. depth imported from a game).
    pub fn begin_rendering_views(
        &self,
        extent: vk::Extent2D,
        colors: &[(vk::ImageView, Option<vk::ClearValue>)],
        depth: Option<(vk::ImageView, Option<vk::ClearValue>)>,
    ) {
        let attachment = |view: vk::ImageView, clear: Option<vk::ClearValue>, layout| {
            let info = vk::RenderingAttachmentInfo::default()
                .image_view(view)
                .image_layout(layout)
                .store_op(vk::AttachmentStoreOp::STORE);
            match clear {
                Some(value) => info.load_op(vk::AttachmentLoadOp::CLEAR).clear_value(value),
                None => info.load_op(vk::AttachmentLoadOp::LOAD),
            }
        };
        let color_infos: Vec<_> = colors
            .iter()
            .map(|&(view, clear)| attachment(view, clear, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL))
            .collect();
        let depth_info =
            depth.map(|(view, clear)| attachment(view, clear, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL));
        let area = vk::Rect2D { offset: vk::Offset2D::default(), extent };
        let mut info =
            vk::RenderingInfo::default().render_area(area).layer_count(1).color_attachments(&color_infos);
        if let Some(d) = &depth_info {
            info = info.depth_attachment(d);
        }
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: recording, outside a render pass; the attachment views are live until the frame's
        // fence, and `info`'s attachment arrays outlive the call.
        unsafe {
            self.device().cmd_begin_rendering(self.cmd, &info);
            self.device().cmd_set_viewport(self.cmd, 0, &[viewport]);
            self.device().cmd_set_scissor(self.cmd, 0, &[area]);
        }
    }

    pub fn end_rendering(&self) {
        // SAFETY: recording inside the rendering begun by begin_rendering_views.
        unsafe { self.device().cmd_end_rendering(self.cmd) };
    }

    /// One instanced indexed draw of a mesh's buffers.
    pub fn draw_mesh(
        &self,
        vertices: &Buffer,
        indices: &Buffer,
        index_count: u32,
        first_instance: u32,
        instances: u32,
    ) {
        // SAFETY: recording inside rendering with a graphics pipeline bound; both buffers are live
        // until the frame's fence.
        unsafe {
            self.device().cmd_bind_vertex_buffers(self.cmd, 0, &[vertices.raw], &[0]);
            self.device().cmd_bind_index_buffer(self.cmd, indices.raw, 0, vk::IndexType::UINT32);
            self.device().cmd_draw_indexed(self.cmd, index_count, instances, 0, 0, first_instance);
        }
    }

    /// Binds `vertices` at vertex input `binding` (a pipeline's second binding; `draw_mesh` binds
    /// binding 0), for the draws that follow.
    pub fn bind_vertex_buffer(&self, binding: u32, vertices: &Buffer) {
        self.bind_vertex_range(binding, vertices.raw, 0);
    }

    /// Binds `buffer` from `offset` at vertex input `binding` (a range of an upload ring).
    pub fn bind_vertex_range(&self, binding: u32, buffer: vk::Buffer, offset: u64) {
        // SAFETY: recording with a graphics pipeline bound; the buffer is live until the frame's
        // fence.
        unsafe { self.device().cmd_bind_vertex_buffers(self.cmd, binding, &[buffer], &[offset]) };
    }

    /// A full-screen triangle (no vertex buffer: the vertex shader makes it from gl_VertexIndex).
    pub fn draw_fullscreen(&self) {
        // SAFETY: recording inside rendering with a graphics pipeline bound; no buffers are read.
        unsafe { self.device().cmd_draw(self.cmd, 3, 1, 0, 0) };
    }

    /// Copies a buffer of rows of `row_length` texels into the depth image's `region` (in
    /// TRANSFER_DST layout); the buffer's first texel goes to the region's top-left corner.
    pub fn copy_buffer_to_depth(
        &self,
        buffer: &Buffer,
        row_length: u32,
        image: &ImageHandles,
        region: vk::Rect2D,
    ) {
        let vk::Rect2D { offset, extent } = region;
        let region = vk::BufferImageCopy::default()
            .buffer_row_length(row_length)
            .image_subresource(
                vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::DEPTH).layer_count(1),
            )
            .image_offset(vk::Offset3D { x: offset.x, y: offset.y, z: 0 })
            .image_extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 });
        // SAFETY: recording, outside rendering; buffer and image are live until the frame's fence;
        // the image is in TRANSFER_DST layout, the region lies inside it and the buffer holds
        // `row_length` × its height texels (the caller's contract).
        unsafe {
            self.device().cmd_copy_buffer_to_image(
                self.cmd,
                buffer.raw,
                image.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }

    /// Copies a whole colour image (in TRANSFER_SRC layout) into a buffer, tightly packed.
    pub fn copy_image_to_buffer(&self, image: &ImageHandles, buffer: &Buffer) {
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
            )
            .image_extent(vk::Extent3D { width: image.extent.width, height: image.extent.height, depth: 1 });
        // SAFETY: recording, outside rendering; image and buffer are live until the frame's fence;
        // the image is in TRANSFER_SRC layout and the buffer holds the whole image (the caller's
        // contract).
        unsafe {
            self.device().cmd_copy_image_to_buffer(
                self.cmd,
                image.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.raw,
                &[region],
            )
        };
    }
}
