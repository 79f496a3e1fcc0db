//! A frame slot: what one frame in flight owns — its descriptor pool, its upload ring and its
//! timestamp queries. A slot is written only when its previous frame has finished.

use crate::frame::{pass_timings, FrameStats, Scope};
use crate::gpu::memory::MemoryLocation;

use crate::gpu::memory::{Buffer, Memory};
use crate::gpu::pipeline::DescriptorPool;
use crate::gpu::ring::UploadRing;
use crate::gpu::timestamps::TimestampPool;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::passes::Pass;

/// Two timestamps per scope: a frame has a handful of passes, the import, composite and read-back.
const QUERIES_PER_FRAME: u32 = 64;
/// Descriptor sets one frame allocates at most (one per pass).
const SETS_PER_FRAME: u32 = 32;

pub(super) struct Slot {
    pub pool: DescriptorPool,
    pub ring: UploadRing,
    pub timestamps: TimestampPool,
    /// The frame's timestamps, copied there by the GPU at the end of the frame (host-visible).
    ticks: Buffer,
    pub scopes: Vec<Scope>,
    /// The frame recorded in this slot and not yet reported finished.
    pending: Option<u64>,
}

impl Slot {
    pub fn new(ctx: &GpuContext, index: usize) -> GpuResult<Slot> {
        let pool = DescriptorPool::new(ctx, &format!("frame slot {index} descriptors"), SETS_PER_FRAME)?;
        let mut timestamps = TimestampPool::new(ctx, QUERIES_PER_FRAME)?;
        // Queries start undefined: reset before the first use.
        timestamps.host_reset(ctx);
        let ring = UploadRing::new(ctx, &format!("frame slot {index} ring"));
        let usage = vk::BufferUsageFlags::TRANSFER_DST;
        let name = format!("frame slot {index} timestamps");
        let size = 8 * u64::from(QUERIES_PER_FRAME);
        let ticks = Memory::new(ctx)?.create_buffer(ctx, &name, size, usage, MemoryLocation::GpuToCpu)?;
        Ok(Slot { pool, ring, timestamps, ticks, scopes: Vec::new(), pending: None })
    }

    /// Starts recording `frame` here; the slot's previous frame has finished and was reported.
    pub fn begin(&mut self, ctx: &GpuContext, frame: u64) -> GpuResult<()> {
        self.pool.reset(ctx)?;
        self.ring.reset();
        self.timestamps.host_reset(ctx);
        self.scopes.clear();
        self.pending = Some(frame);
        Ok(())
    }

    /// Records the copy of the frame's timestamps so far (after its last scope).
    pub fn record_timestamp_copy(&self, ctx: &GpuContext, cmd: vk::CommandBuffer) {
        self.timestamps.record_copy(ctx, cmd, self.ticks.raw);
    }

    /// The frame recorded last will not be submitted.
    pub fn abandon(&mut self) {
        self.pending = None;
    }

    /// If this slot's frame is `through` or older: adds what it measured (the timestamps the GPU
    /// copied into the slot's buffer: the frame is known finished) and what its passes counted to
    /// `stats`, the frame's, and returns the frame. A frame's later views follow its first in
    /// `stats.passes` (their scopes named "view N/...") and its GPU time.
    pub fn finish(
        &mut self,
        slot: usize,
        view: usize,
        through: u64,
        passes: &[&dyn Pass],
        stats: &mut FrameStats,
    ) -> Option<u64> {
        let frame = self.pending.filter(|&f| f <= through)?;
        self.pending = None;
        // The frame finished, so the GPU's copy of its timestamps is in the buffer: no driver call.
        let ticks = self.timestamps.ticks_ns(self.ticks.mapped().unwrap_or_default());
        let (timings, gpu_frame_ms) = pass_timings(&self.scopes, &ticks);
        let before = stats.gpu_frame_ms;
        stats.passes.extend(timings.into_iter().map(|mut t| {
            if view > 0 {
                t.name = format!("view {view}/{}", t.name);
            }
            t.start_ms += before;
            t
        }));
        stats.gpu_frame_ms += gpu_frame_ms;
        passes.iter().for_each(|p| p.finished(slot, stats));
        Some(frame)
    }
}
