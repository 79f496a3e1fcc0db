//! Named buffers and images allocated through gpu-allocator. Dropping one queues it for release
//! once the frames that may use it have finished (`gpu::resources`).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::AllocationError;
/// Where a buffer lives: device-local, or host-visible for uploads and read-backs.
pub use gpu_allocator::MemoryLocation;

use super::context::GpuContext;
use super::error::{GpuError, GpuResult, VkResultExt};
use super::resources::{Garbage, Releaser, Resources};

/// Allocates buffers and images on a context's allocator.
#[derive(Clone)]
pub struct Memory {
    resources: Arc<Resources>,
}

pub struct Buffer {
    pub raw: vk::Buffer,
    pub size: u64,
    pub name: String,
    allocation: Option<Allocation>,
    releaser: Releaser,
}

pub struct Image {
    pub raw: vk::Image,
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    pub name: String,
    allocation: Option<Allocation>,
    releaser: Releaser,
}

/// The raw handles of an image (hadou's or a game's), for recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageHandles {
    pub raw: vk::Image,
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
}

fn map_alloc_error(e: AllocationError, what: &str) -> GpuError {
    match e {
        AllocationError::OutOfMemory => GpuError::OutOfDeviceMemory { what: what.into() },
        other => GpuError::Allocator { what: what.into(), message: other.to_string() },
    }
}

impl Buffer {
    /// The mapped bytes of a host-visible buffer.
    pub fn mapped(&self) -> Option<&[u8]> {
        self.allocation.as_ref()?.mapped_slice().map(|s| &s[..self.size as usize])
    }

    pub fn mapped_mut(&mut self) -> Option<&mut [u8]> {
        let size = self.size as usize;
        self.allocation.as_mut()?.mapped_slice_mut().map(|s| &mut s[..size])
    }

    /// Copies `data` into a host-visible buffer at `offset`.
    pub fn write(&mut self, offset: usize, data: &[u8]) -> GpuResult<()> {
        let name = self.name.clone();
        let dst = self.mapped_mut().ok_or_else(|| GpuError::BufferWrite {
            buffer: name.clone(),
            message: "buffer is not host-visible".into(),
        })?;
        let end = offset.checked_add(data.len()).filter(|&e| e <= dst.len()).ok_or_else(|| {
            GpuError::BufferWrite {
                buffer: name,
                message: format!(
                    "write of {} bytes at {offset} past the end ({} bytes)",
                    data.len(),
                    dst.len()
                ),
            }
        })?;
        dst[offset..end].copy_from_slice(data);
        Ok(())
    }
}

impl Memory {
    /// The context's allocator (one per device, shared by every `Memory` made from it).
    pub fn new(ctx: &GpuContext) -> GpuResult<Self> {
        Ok(Memory { resources: ctx.resources().clone() })
    }

    fn allocate(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: MemoryLocation,
        linear: bool,
    ) -> GpuResult<Allocation> {
        self.resources.with_allocator(name, |allocator| {
            allocator
                .allocate(&AllocationCreateDesc {
                    name,
                    requirements,
                    location,
                    linear,
                    allocation_scheme: AllocationScheme::GpuAllocatorManaged,
                })
                .map_err(|e| map_alloc_error(e, name))
        })
    }

    pub fn create_buffer(
        &self,
        ctx: &GpuContext,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> GpuResult<Buffer> {
        let size = size.max(4); // zero-sized buffers are invalid; empty scenes still bind something
        let info =
            vk::BufferCreateInfo::default().size(size).usage(usage).sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device; the buffer is freed by its Drop.
        let raw = unsafe { ctx.device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        let mut buffer = Buffer { raw, size, name: name.into(), allocation: None, releaser: ctx.releaser() };
        // SAFETY: `raw` was just created on this device.
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(raw) };
        let allocation = self.allocate(name, requirements, location, true)?;
        // SAFETY: fresh allocation satisfying the requirements.
        let bound = unsafe { ctx.device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) };
        buffer.allocation = Some(allocation);
        bound.vk("vkBindBufferMemory")?;
        ctx.name_object(raw, name);
        Ok(buffer)
    }

    pub fn create_image(
        &self,
        ctx: &GpuContext,
        name: &str,
        extent: vk::Extent2D,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> GpuResult<Image> {
        self.create_image_levels(ctx, name, extent, format, usage, 1)
    }

    /// A 2D image with `levels` mip levels (at least 1), its view over all of them.
    pub fn create_image_levels(
        &self,
        ctx: &GpuContext,
        name: &str,
        extent: vk::Extent2D,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        levels: u32,
    ) -> GpuResult<Image> {
        let levels = levels.max(1);
        let max = ctx.limits.max_image_dimension2_d;
        if extent.width == 0 || extent.height == 0 || extent.width > max || extent.height > max {
            return Err(GpuError::ImageSize {
                what: name.into(),
                width: extent.width,
                height: extent.height,
                max,
            });
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 })
            .mip_levels(levels)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device; freed by the image's Drop.
        let raw = unsafe { ctx.device.create_image(&info, None) }.vk("vkCreateImage")?;
        let mut image = Image {
            raw,
            view: vk::ImageView::null(),
            format,
            extent,
            name: name.into(),
            allocation: None,
            releaser: ctx.releaser(),
        };
        // SAFETY: `raw` was just created on this device.
        let requirements = unsafe { ctx.device.get_image_memory_requirements(raw) };
        let allocation = self.allocate(name, requirements, MemoryLocation::GpuOnly, false)?;
        // SAFETY: fresh allocation satisfying the requirements; the image has no memory bound yet.
        let bound = unsafe { ctx.device.bind_image_memory(raw, allocation.memory(), allocation.offset()) };
        image.allocation = Some(allocation);
        bound.vk("vkBindImageMemory")?;
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(subresource_range(format).level_count(levels));
        // SAFETY: the image is live with its memory bound; the view is destroyed before the image
        // (its Drop retires both, view first).
        image.view = unsafe { ctx.device.create_image_view(&view_info, None) }.vk("vkCreateImageView")?;
        ctx.name_object(raw, name);
        ctx.name_object(image.view, &format!("{name} view"));
        Ok(image)
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        self.releaser.retire(Garbage::Buffer(self.raw, self.allocation.take()));
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        if self.view != vk::ImageView::null() {
            self.releaser.retire(Garbage::ImageView(self.view));
        }
        self.releaser.retire(Garbage::Image(self.raw, self.allocation.take()));
    }
}

pub fn is_depth_format(format: vk::Format) -> bool {
    matches!(format, vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::D24_UNORM_S8_UINT)
}

pub fn subresource_range(format: vk::Format) -> vk::ImageSubresourceRange {
    let aspect =
        if is_depth_format(format) { vk::ImageAspectFlags::DEPTH } else { vk::ImageAspectFlags::COLOR };
    vk::ImageSubresourceRange::default().aspect_mask(aspect).level_count(1).layer_count(1)
}
