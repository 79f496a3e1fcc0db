//! The host of a frame loop with frames in flight: a command buffer and a fence per slot on
//! hadou's own device. It waits only on the fence of the frame that last used a slot before
//! recording that slot again (hadou's frame contract); these waits are the host's, not hadou's.
#![allow(dead_code)]

use ash::vk;
use hadou::gpu::GpuContext;

/// The host's side: a command buffer and a fence per slot, on hadou's own device.
pub struct Host {
    device: ash::Device,
    queue: vk::Queue,
    pool: vk::CommandPool,
    cmds: Vec<vk::CommandBuffer>,
    fences: Vec<vk::Fence>,
    submitted: Vec<bool>,
}

impl Host {
    pub fn new(ctx: &GpuContext, slots: usize) -> Host {
        let device = ctx.device.clone();
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: hadou's live device; the pool is destroyed by `destroy`, before the context.
        let pool = unsafe { device.create_command_pool(&info, None) }.unwrap();
        let alloc =
            vk::CommandBufferAllocateInfo::default().command_pool(pool).command_buffer_count(slots as u32);
        // SAFETY: the pool was just created on this device; it frees the buffers when destroyed.
        let cmds = unsafe { device.allocate_command_buffers(&alloc) }.unwrap();
        let fences = (0..slots)
            // SAFETY: valid device; the fences are destroyed by `destroy`.
            .map(|_| unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }.unwrap())
            .collect();
        Host { device, queue: ctx.queue, pool, cmds, fences, submitted: vec![false; slots] }
    }

    /// Waits for the slot's previous frame (the host's guarantee), then begins its command buffer.
    pub fn begin(&mut self, slot: usize) -> vk::CommandBuffer {
        self.wait(slot);
        let cmd = self.cmds[slot];
        // SAFETY: the slot's previous submission finished (waited above), so the buffer is not pending.
        unsafe {
            self.device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()).unwrap();
            self.device.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default()).unwrap();
        }
        cmd
    }

    pub fn submit(&mut self, slot: usize) {
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmds[slot])];
        let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds)];
        // SAFETY: the slot's buffer is recording (begin); its fence is unsignalled and unused (created
        // so, or reset by wait); single-threaded, so the queue is externally synchronized.
        unsafe {
            self.device.end_command_buffer(self.cmds[slot]).unwrap();
            self.device.queue_submit2(self.queue, &submit, self.fences[slot]).unwrap();
        }
        self.submitted[slot] = true;
    }

    pub fn wait(&mut self, slot: usize) {
        if std::mem::take(&mut self.submitted[slot]) {
            // SAFETY: the fence is this host's and was submitted with the slot's frame.
            unsafe {
                self.device.wait_for_fences(&[self.fences[slot]], true, u64::MAX).unwrap();
                self.device.reset_fences(&[self.fences[slot]]).unwrap();
            }
        }
    }

    pub fn wait_all(&mut self) {
        (0..self.cmds.len()).for_each(|s| self.wait(s));
    }

    pub fn destroy(mut self) {
        self.wait_all();
        // SAFETY: every submitted slot was waited for (wait_all), so nothing uses the fences or the
        // pool's buffers; the device is still live (the caller destroys the host before the context).
        unsafe {
            self.fences.iter().for_each(|&f| self.device.destroy_fence(f, None));
            self.device.destroy_command_pool(self.pool, None);
        }
    }
}
