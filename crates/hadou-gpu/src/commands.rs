//! One command pool, one primary command buffer and its fence: the headless runtime's frame
//! slots and one-off uploads. Dropped only when no submission of it is pending.

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuError, GpuResult, VkResultExt};

pub struct FrameCommands {
    device: ash::Device,
    pool: vk::CommandPool,
    pub cmd: vk::CommandBuffer,
    fence: vk::Fence,
    /// Submitted and not yet waited for.
    pending: bool,
}

impl FrameCommands {
    pub fn new(ctx: &GpuContext, name: &str) -> GpuResult<Self> {
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let mut commands = FrameCommands {
            device: ctx.device.clone(),
            pool: vk::CommandPool::null(),
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            pending: false,
        };
        // SAFETY: valid device; everything is destroyed by Drop.
        commands.pool =
            unsafe { ctx.device.create_command_pool(&pool_info, None) }.vk("vkCreateCommandPool")?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(commands.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool was just created on this device; it frees the buffer when destroyed.
        commands.cmd =
            unsafe { ctx.device.allocate_command_buffers(&alloc) }.vk("vkAllocateCommandBuffers")?[0];
        // SAFETY: valid device; destroyed by Drop.
        commands.fence =
            unsafe { ctx.device.create_fence(&vk::FenceCreateInfo::default(), None) }.vk("vkCreateFence")?;
        ctx.name_object(commands.pool, &format!("{name} pool"));
        ctx.name_object(commands.cmd, &format!("{name} cmd"));
        ctx.name_object(commands.fence, &format!("{name} fence"));
        Ok(commands)
    }

    /// Resets and begins the command buffer, after waiting for its previous submission.
    pub fn begin(&mut self, ctx: &GpuContext) -> GpuResult<()> {
        self.wait(ctx, "the previous frame")?;
        // SAFETY: the previous submission finished (waited above).
        unsafe {
            ctx.device
                .reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
                .vk("vkResetCommandBuffer")?;
            let info =
                vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            ctx.device.begin_command_buffer(self.cmd, &info).vk("vkBeginCommandBuffer")
        }
    }

    /// Ends recording without submitting (a frame abandoned after an error).
    pub fn end(&self, ctx: &GpuContext) -> GpuResult<()> {
        // SAFETY: the command buffer is recording (begin was called).
        unsafe { ctx.device.end_command_buffer(self.cmd) }.vk("vkEndCommandBuffer")
    }

    /// Ends recording and submits with the fence, without waiting. `last_pass` names the pass
    /// for a device-lost error.
    pub fn submit(&mut self, ctx: &GpuContext, last_pass: &str) -> GpuResult<()> {
        // SAFETY: the command buffer is recording (begin was called); the fence is unsignalled and
        // not in use (created so, or reset by wait); the submit arrays outlive the call.
        unsafe {
            ctx.device.end_command_buffer(self.cmd).map_err(|r| lost(r, "vkEndCommandBuffer", last_pass))?;
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
            let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds)];
            ctx.device
                .queue_submit2(ctx.queue, &submit, self.fence)
                .map_err(|r| lost(r, "vkQueueSubmit2", last_pass))?;
        }
        self.pending = true;
        Ok(())
    }

    /// Waits for the last submission, if one is pending (counted in `GpuContext::host_waits`).
    pub fn wait(&mut self, ctx: &GpuContext, last_pass: &str) -> GpuResult<()> {
        if !self.pending {
            return Ok(());
        }
        ctx.resources().count_fence_wait();
        // SAFETY: the fence belongs to this device and was submitted.
        unsafe {
            let waited = ctx.device.wait_for_fences(&[self.fence], true, u64::MAX);
            let reset = ctx.device.reset_fences(&[self.fence]);
            waited.map_err(|r| lost(r, "vkWaitForFences", last_pass))?;
            reset.map_err(|r| lost(r, "vkResetFences", last_pass))?;
        }
        self.pending = false;
        Ok(())
    }

    /// Ends recording, submits, and waits for the fence.
    pub fn submit_and_wait(&mut self, ctx: &GpuContext, last_pass: &str) -> GpuResult<()> {
        self.submit(ctx, last_pass)?;
        self.wait(ctx, last_pass)
    }
}

fn lost(r: vk::Result, call: &'static str, last_pass: &str) -> GpuError {
    match r {
        vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost { last_pass: last_pass.into() },
        r => Err::<(), _>(r).vk(call).unwrap_err(),
    }
}

impl Drop for FrameCommands {
    fn drop(&mut self) {
        // SAFETY: no submission is pending (the owner waited, or the device is idle); the pool
        // frees its command buffer. Null handles (a constructor that failed) are ignored.
        unsafe {
            if self.pending {
                let _ = self.device.wait_for_fences(&[self.fence], true, u64::MAX);
            }
            self.device.destroy_fence(self.fence, None);
            self.device.destroy_command_pool(self.pool, None);
        }
    }
}
