//! GPU timestamps: a begin/end pair per pass, read only once the frame is known to have finished.

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuResult, VkResultExt};
use super::resources::{Garbage, Releaser};

pub struct TimestampPool {
    pool: vk::QueryPool,
    capacity: u32,
    used: u32,
    period_ns: f64,
    valid_mask: u64,
    releaser: Releaser,
}

impl Drop for TimestampPool {
    fn drop(&mut self) {
        self.releaser.retire(Garbage::QueryPool(self.pool));
    }
}

impl TimestampPool {
    pub fn new(ctx: &GpuContext, capacity: u32) -> GpuResult<Self> {
        let info =
            vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(capacity);
        // SAFETY: valid device; destroyed in destroy().
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        ctx.name_object(pool, "pass timestamps");
        let bits = ctx.timestamp_valid_bits;
        let valid_mask = if bits >= 64 { u64::MAX } else { (1u64 << bits) - 1 };
        Ok(TimestampPool {
            pool,
            capacity,
            used: 0,
            period_ns: ctx.info.timestamp_period_ns as f64,
            valid_mask,
            releaser: ctx.releaser(),
        })
    }

    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Resets every query; recorded at the start of a frame.
    pub fn reset(&mut self, ctx: &GpuContext, cmd: vk::CommandBuffer) {
        // SAFETY: cmd is recording, outside a render pass.
        unsafe { ctx.device.cmd_reset_query_pool(cmd, self.pool, 0, self.capacity) };
        self.used = 0;
    }

    /// Writes a timestamp once all earlier commands finished; returns its index, or None when full.
    pub fn write(&mut self, ctx: &GpuContext, cmd: vk::CommandBuffer) -> Option<u32> {
        if self.used >= self.capacity {
            return None;
        }
        let index = self.used;
        // SAFETY: the query was reset this frame.
        unsafe {
            ctx.device.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, self.pool, index)
        };
        self.used += 1;
        Some(index)
    }

    /// Resets every query from the host (Vulkan 1.2 `hostQueryReset`): no command buffer needed,
    /// and a reset pool reads as "not available" at once, so a stale result is never taken for a new
    /// one. The caller guarantees no submitted command still writes these queries.
    pub fn host_reset(&mut self, ctx: &GpuContext) {
        // SAFETY: see above; the range is the whole pool.
        unsafe { ctx.device.reset_query_pool(self.pool, 0, self.capacity) };
        self.used = 0;
    }

    /// Records a copy of the timestamps written so far into `buffer` (8 bytes each, in order),
    /// made visible to the host: read it with `ticks_ns` once the frame is known finished. Lavapipe's
    /// `vkGetQueryPoolResults` waits for the whole device even without `WAIT`, so a frame path reads
    /// its timestamps from this buffer instead, without a driver call. The copy waits on the
    /// device for the queries (WAIT_BIT), never on the host.
    pub fn record_copy(&self, ctx: &GpuContext, cmd: vk::CommandBuffer, buffer: vk::Buffer) {
        use super::barriers::{cmd_barriers, memory_barrier};
        let copy = vk::PipelineStageFlags2::COPY;
        let write = vk::AccessFlags2::TRANSFER_WRITE;
        // An earlier copy into the same buffer (this frame's, or the slot's previous frame's).
        let before = memory_barrier(copy, write, copy, write);
        cmd_barriers(&ctx.device, cmd, &[], &[before]);
        if self.used > 0 {
            let flags = vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT;
            // SAFETY: recording outside a render pass; the buffer holds `capacity` u64s.
            unsafe {
                ctx.device.cmd_copy_query_pool_results(cmd, self.pool, 0, self.used, buffer, 0, 8, flags)
            };
        }
        let after = memory_barrier(copy, write, vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ);
        cmd_barriers(&ctx.device, cmd, &[], &[after]);
    }

    /// The timestamps `record_copy` put into `bytes` (the buffer's mapped contents), in nanoseconds.
    pub fn ticks_ns(&self, bytes: &[u8]) -> Vec<f64> {
        bytes
            .chunks_exact(8)
            .take(self.used as usize)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
            .map(|t| (t & self.valid_mask) as f64 * self.period_ns)
            .collect()
    }

    /// The written timestamps as nanoseconds if the GPU has written all of them, else None (for
    /// one-off measurements: on lavapipe this call waits for the device).
    pub fn try_read_ns(&self, ctx: &GpuContext) -> GpuResult<Option<Vec<f64>>> {
        if self.used == 0 {
            return Ok(Some(Vec::new()));
        }
        let mut ticks = vec![0u64; self.used as usize];
        // SAFETY: the queries were reset before they were written; without WAIT this only polls.
        let result = unsafe {
            ctx.device.get_query_pool_results(self.pool, 0, &mut ticks, vk::QueryResultFlags::TYPE_64)
        };
        match result {
            Ok(()) => Ok(Some(ticks.iter().map(|t| (t & self.valid_mask) as f64 * self.period_ns).collect())),
            Err(vk::Result::NOT_READY) => Ok(None),
            Err(e) => Err(e).vk("vkGetQueryPoolResults"),
        }
    }
}
