//! Copies CPU pixels into acquired swapchain images through host-visible staging buffers (one per
//! frame in flight): the path for a renderer whose frame ends on the CPU, like hadou's headless
//! `Runtime`, whose tonemapped colour comes back as RGBA8.

use ash::vk;

use super::swapchain::Acquired;
use crate::error::{GpuError, GpuResult, VkResultExt};

struct Staging {
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    size: u64,
    mapped: *mut u8,
}

struct CopySlot {
    cmd: vk::CommandBuffer,
    staging: Option<Staging>,
}

/// Staging buffers and command buffers for [`PixelCopier::copy_and_submit`].
pub struct PixelCopier {
    device: ash::Device,
    memory_props: vk::PhysicalDeviceMemoryProperties,
    pool: vk::CommandPool,
    slots: Vec<CopySlot>,
}

impl PixelCopier {
    /// # Safety
    /// Valid, related handles that outlive the copier; `destroy` before the device is destroyed.
    /// `frames_in_flight` must match the presenter's.
    pub unsafe fn new(
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
        device: &ash::Device,
        queue_family: u32,
        frames_in_flight: usize,
    ) -> GpuResult<Self> {
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let pool = device.create_command_pool(&pool_info, None).vk("vkCreateCommandPool")?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(frames_in_flight.max(1) as u32);
        let cmds = match device.allocate_command_buffers(&alloc) {
            Ok(c) => c,
            Err(e) => {
                device.destroy_command_pool(pool, None);
                return Err(e).vk("vkAllocateCommandBuffers");
            }
        };
        Ok(PixelCopier {
            device: device.clone(),
            memory_props: instance.get_physical_device_memory_properties(physical),
            pool,
            slots: cmds.into_iter().map(|cmd| CopySlot { cmd, staging: None }).collect(),
        })
    }

    /// Copies `rgba` (RGBA8, row 0 at the top, `acquired.extent` in size) into the acquired image,
    /// reordered to its format's channel order, and submits: waits on `acquired.wait`, leaves the
    /// image in `PRESENT_SRC_KHR`, signals `acquired.signal` and `acquired.fence`.
    /// The bytes are copied as they are: an `*_UNORM` swapchain shows sRGB-encoded input correctly.
    pub fn copy_and_submit(&mut self, queue: vk::Queue, acquired: &Acquired, rgba: &[u8]) -> GpuResult<()> {
        let e = acquired.extent;
        let size = e.width as u64 * e.height as u64 * 4;
        if rgba.len() as u64 != size {
            return Err(GpuError::PixelCount { bytes: rgba.len(), width: e.width, height: e.height });
        }
        let swap_rb = match acquired.format {
            vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB => true,
            vk::Format::R8G8B8A8_UNORM | vk::Format::R8G8B8A8_SRGB => false,
            f => {
                return Err(GpuError::SurfaceUnsupported {
                    what: "pixel copy",
                    message: format!("swapchain format {f:?} is not an 8-bit RGBA/BGRA format"),
                })
            }
        };
        let slot = acquired.slot.min(self.slots.len() - 1);
        // SAFETY: the presenter waited on this slot's fence, so its previous copy has finished.
        let staging = unsafe { self.staging(slot, size)? };
        // SAFETY: `mapped` points at `size` coherent bytes that no submission is reading now.
        let dst = unsafe { std::slice::from_raw_parts_mut(staging.mapped, size as usize) };
        if swap_rb {
            for (d, s) in dst.chunks_exact_mut(4).zip(rgba.chunks_exact(4)) {
                d.copy_from_slice(&[s[2], s[1], s[0], s[3]]);
            }
        } else {
            dst.copy_from_slice(rgba);
        }
        let buffer = staging.buffer;
        // SAFETY: the slot's command buffer is not pending (its fence was waited in acquire, as for
        // `staging` above); the staging buffer holds the image's bytes; the image, semaphores and
        // fence come from the presenter's acquire on this copier's device.
        unsafe { self.record_and_submit(queue, self.slots[slot].cmd, buffer, acquired) }
    }

    unsafe fn record_and_submit(
        &self,
        queue: vk::Queue,
        cmd: vk::CommandBuffer,
        buffer: vk::Buffer,
        acquired: &Acquired,
    ) -> GpuResult<()> {
        let d = &self.device;
        d.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()).vk("vkResetCommandBuffer")?;
        let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        d.begin_command_buffer(cmd, &begin).vk("vkBeginCommandBuffer")?;
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .level_count(1)
            .layer_count(1);
        // The acquire semaphore is waited at the COPY stage; the transition chains after it.
        let to_dst = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .dst_stage_mask(vk::PipelineStageFlags2::COPY)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .image(acquired.image)
            .subresource_range(range);
        d.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&[to_dst]));
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
            )
            .image_extent(vk::Extent3D {
                width: acquired.extent.width,
                height: acquired.extent.height,
                depth: 1,
            });
        d.cmd_copy_buffer_to_image(
            cmd,
            buffer,
            acquired.image,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &[region],
        );
        // Presentation waits on the semaphore signalled after this; no later stage reads the image.
        let to_present = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
            .image(acquired.image)
            .subresource_range(range);
        d.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&[to_present]));
        d.end_command_buffer(cmd).vk("vkEndCommandBuffer")?;
        let waits = [vk::SemaphoreSubmitInfo::default()
            .semaphore(acquired.wait)
            .stage_mask(vk::PipelineStageFlags2::COPY)];
        let signals = [vk::SemaphoreSubmitInfo::default()
            .semaphore(acquired.signal)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
        let submit = [vk::SubmitInfo2::default()
            .wait_semaphore_infos(&waits)
            .command_buffer_infos(&cmds)
            .signal_semaphore_infos(&signals)];
        d.queue_submit2(queue, &submit, acquired.fence).vk("vkQueueSubmit2")
    }

    /// The slot's staging buffer, (re)created when the size changed.
    unsafe fn staging(&mut self, slot: usize, size: u64) -> GpuResult<&Staging> {
        if self.slots[slot].staging.as_ref().is_some_and(|s| s.size != size) {
            if let Some(old) = self.slots[slot].staging.take() {
                self.free(old);
            }
        }
        if self.slots[slot].staging.is_none() {
            self.slots[slot].staging = Some(self.create_staging(size)?);
        }
        Ok(self.slots[slot].staging.as_ref().expect("created above"))
    }

    unsafe fn create_staging(&self, size: u64) -> GpuResult<Staging> {
        let d = &self.device;
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(vk::BufferUsageFlags::TRANSFER_SRC)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let buffer = d.create_buffer(&info, None).vk("vkCreateBuffer")?;
        let reqs = d.get_buffer_memory_requirements(buffer);
        let wanted = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
        let props = &self.memory_props;
        let Some(type_index) = (0..props.memory_type_count).find(|&i| {
            reqs.memory_type_bits & (1 << i) != 0
                && props.memory_types[i as usize].property_flags.contains(wanted)
        }) else {
            d.destroy_buffer(buffer, None);
            return Err(GpuError::NoMemoryType { what: "staging buffer".into(), properties: wanted });
        };
        let alloc =
            vk::MemoryAllocateInfo::default().allocation_size(reqs.size).memory_type_index(type_index);
        let memory = match d.allocate_memory(&alloc, None) {
            Ok(m) => m,
            Err(e) => {
                d.destroy_buffer(buffer, None);
                return Err(e).vk("vkAllocateMemory");
            }
        };
        let mapped = d
            .bind_buffer_memory(buffer, memory, 0)
            .and_then(|_| d.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()));
        match mapped {
            Ok(ptr) => Ok(Staging { buffer, memory, size, mapped: ptr as *mut u8 }),
            Err(e) => {
                d.destroy_buffer(buffer, None);
                d.free_memory(memory, None);
                Err(e).vk("vkMapMemory")
            }
        }
    }

    unsafe fn free(&self, staging: Staging) {
        self.device.destroy_buffer(staging.buffer, None);
        self.device.free_memory(staging.memory, None); // unmaps it
    }

    /// Waits for the device, then frees the buffers and the command pool.
    pub fn destroy(&mut self) {
        // SAFETY: after the idle wait no submission uses these objects.
        unsafe {
            let _ = self.device.device_wait_idle();
            for slot in &mut self.slots {
                if let Some(s) = slot.staging.take() {
                    self.device.destroy_buffer(s.buffer, None);
                    self.device.free_memory(s.memory, None);
                }
            }
            self.slots.clear();
            if self.pool != vk::CommandPool::null() {
                self.device.destroy_command_pool(self.pool, None);
                self.pool = vk::CommandPool::null();
            }
        }
    }
}
