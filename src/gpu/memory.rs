//! Named buffers and images allocated through gpu-allocator. Owners free them explicitly with
//! `Memory::destroy_*` after the frame's fence; validation reports anything left at shutdown.

use std::sync::Mutex;

use ash::vk;
use gpu_allocator::vulkan::{
    Allocation, AllocationCreateDesc, AllocationScheme, Allocator, AllocatorCreateDesc,
};
use gpu_allocator::{AllocationError, MemoryLocation};

use super::context::GpuContext;
use super::error::{GpuError, GpuResult, VkResultExt};

pub struct Memory {
    allocator: Mutex<Allocator>,
}

pub struct Buffer {
    pub raw: vk::Buffer,
    pub size: u64,
    pub name: String,
    allocation: Option<Allocation>,
}

pub struct Image {
    pub raw: vk::Image,
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    pub name: String,
    allocation: Option<Allocation>,
}

fn map_alloc_error(e: AllocationError, what: &str) -> GpuError {
    match e {
        AllocationError::OutOfMemory => GpuError::OutOfDeviceMemory { what: what.into() },
        other => GpuError::Limit { what: what.into(), message: other.to_string() },
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
        let dst = self.mapped_mut().ok_or_else(|| GpuError::Limit {
            what: name.clone(),
            message: "buffer is not host-visible".into(),
        })?;
        let end =
            offset.checked_add(data.len()).filter(|&e| e <= dst.len()).ok_or_else(|| GpuError::Limit {
                what: name,
                message: format!(
                    "write of {} bytes at {offset} past the end ({} bytes)",
                    data.len(),
                    dst.len()
                ),
            })?;
        dst[offset..end].copy_from_slice(data);
        Ok(())
    }
}

impl Memory {
    pub fn new(ctx: &GpuContext) -> GpuResult<Self> {
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: ctx.instance.clone(),
            device: ctx.device.clone(),
            physical_device: ctx.physical_device,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| map_alloc_error(e, "the allocator"))?;
        Ok(Memory { allocator: Mutex::new(allocator) })
    }

    fn allocate(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: MemoryLocation,
        linear: bool,
    ) -> GpuResult<Allocation> {
        let mut allocator = self.allocator.lock().map_err(|_| GpuError::Limit {
            what: name.into(),
            message: "allocator poisoned by an earlier panic".into(),
        })?;
        allocator
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|e| map_alloc_error(e, name))
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
        // SAFETY: valid device; the buffer is destroyed by destroy_buffer.
        let raw = unsafe { ctx.device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(raw) };
        let allocation = match self.allocate(name, requirements, location, true) {
            Ok(a) => a,
            Err(e) => {
                unsafe { ctx.device.destroy_buffer(raw, None) };
                return Err(e);
            }
        };
        // SAFETY: fresh allocation satisfying the requirements.
        if let Err(e) =
            unsafe { ctx.device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) }
        {
            self.free(allocation);
            unsafe { ctx.device.destroy_buffer(raw, None) };
            return Err(e).vk("vkBindBufferMemory");
        }
        ctx.name_object(raw, name);
        Ok(Buffer { raw, size, name: name.into(), allocation: Some(allocation) })
    }

    pub fn create_image(
        &self,
        ctx: &GpuContext,
        name: &str,
        extent: vk::Extent2D,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> GpuResult<Image> {
        let max = ctx.limits.max_image_dimension2_d;
        if extent.width == 0 || extent.height == 0 || extent.width > max || extent.height > max {
            return Err(GpuError::Limit {
                what: name.into(),
                message: format!(
                    "size {}x{} outside 1..={max} (maxImageDimension2D)",
                    extent.width, extent.height
                ),
            });
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device; destroyed by destroy_image.
        let raw = unsafe { ctx.device.create_image(&info, None) }.vk("vkCreateImage")?;
        let requirements = unsafe { ctx.device.get_image_memory_requirements(raw) };
        let allocation = match self.allocate(name, requirements, MemoryLocation::GpuOnly, false) {
            Ok(a) => a,
            Err(e) => {
                unsafe { ctx.device.destroy_image(raw, None) };
                return Err(e);
            }
        };
        let bound = unsafe { ctx.device.bind_image_memory(raw, allocation.memory(), allocation.offset()) };
        let view = bound.and_then(|_| {
            let view_info = vk::ImageViewCreateInfo::default()
                .image(raw)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(subresource_range(format));
            unsafe { ctx.device.create_image_view(&view_info, None) }
        });
        let view = match view {
            Ok(v) => v,
            Err(e) => {
                self.free(allocation);
                unsafe { ctx.device.destroy_image(raw, None) };
                return Err(e).vk("vkCreateImageView");
            }
        };
        ctx.name_object(raw, name);
        ctx.name_object(view, &format!("{name} view"));
        Ok(Image { raw, view, format, extent, name: name.into(), allocation: Some(allocation) })
    }

    fn free(&self, allocation: Allocation) {
        if let Ok(mut allocator) = self.allocator.lock() {
            if let Err(e) = allocator.free(allocation) {
                log::warn!("freeing GPU memory failed: {e}");
            }
        }
    }

    /// Frees a buffer. The caller guarantees the GPU no longer uses it (after the frame's fence).
    pub fn destroy_buffer(&self, ctx: &GpuContext, mut buffer: Buffer) {
        unsafe { ctx.device.destroy_buffer(buffer.raw, None) };
        if let Some(a) = buffer.allocation.take() {
            self.free(a);
        }
    }

    /// Frees an image and its view. The caller guarantees the GPU no longer uses it.
    pub fn destroy_image(&self, ctx: &GpuContext, mut image: Image) {
        unsafe {
            ctx.device.destroy_image_view(image.view, None);
            ctx.device.destroy_image(image.raw, None);
        }
        if let Some(a) = image.allocation.take() {
            self.free(a);
        }
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
