//! One command pool, one primary command buffer and its fence: hadou records a frame, submits it
//! and waits (headless), so resources are reusable as soon as the fence signals.

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuError, GpuResult, VkResultExt};

pub struct FrameCommands {
    pool: vk::CommandPool,
    pub cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl FrameCommands {
    pub fn new(ctx: &GpuContext, name: &str) -> GpuResult<Self> {
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device; destroyed in destroy().
        let pool = unsafe { ctx.device.create_command_pool(&pool_info, None) }.vk("vkCreateCommandPool")?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let cmd = match unsafe { ctx.device.allocate_command_buffers(&alloc) } {
            Ok(c) => c[0],
            Err(e) => {
                unsafe { ctx.device.destroy_command_pool(pool, None) };
                return Err(e).vk("vkAllocateCommandBuffers");
            }
        };
        let fence = match unsafe { ctx.device.create_fence(&vk::FenceCreateInfo::default(), None) } {
            Ok(f) => f,
            Err(e) => {
                unsafe { ctx.device.destroy_command_pool(pool, None) };
                return Err(e).vk("vkCreateFence");
            }
        };
        ctx.name_object(pool, &format!("{name} pool"));
        ctx.name_object(cmd, &format!("{name} cmd"));
        ctx.name_object(fence, &format!("{name} fence"));
        Ok(FrameCommands { pool, cmd, fence })
    }

    pub fn begin(&self, ctx: &GpuContext) -> GpuResult<()> {
        // SAFETY: the previous submission finished (wait() returned) before begin is called again.
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

    /// Ends recording, submits, and waits for the fence. `last_pass` names the pass for a device-lost error.
    pub fn submit_and_wait(&self, ctx: &GpuContext, last_pass: &str) -> GpuResult<()> {
        let lost = |r: vk::Result, call: &'static str| match r {
            vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost { last_pass: last_pass.into() },
            r => Err::<(), _>(r).vk(call).unwrap_err(),
        };
        unsafe {
            ctx.device.end_command_buffer(self.cmd).map_err(|r| lost(r, "vkEndCommandBuffer"))?;
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
            let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds)];
            ctx.device
                .queue_submit2(ctx.queue, &submit, self.fence)
                .map_err(|r| lost(r, "vkQueueSubmit2"))?;
            let waited = ctx.device.wait_for_fences(&[self.fence], true, u64::MAX);
            let reset = ctx.device.reset_fences(&[self.fence]);
            waited.map_err(|r| lost(r, "vkWaitForFences"))?;
            reset.map_err(|r| lost(r, "vkResetFences"))
        }
    }

    pub fn destroy(&self, ctx: &GpuContext) {
        // SAFETY: called after the last wait; the pool frees its command buffer.
        unsafe {
            ctx.device.destroy_fence(self.fence, None);
            ctx.device.destroy_command_pool(self.pool, None);
        }
    }
}
