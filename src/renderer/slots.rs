//! A frame slot: what one frame in flight owns — its descriptor pool, its upload ring and its
//! timestamp queries. A slot is written only when its previous frame has finished.

use super::timings::FinishedFrame;
use crate::frame::{pass_timings, FrameStats, Scope};
use crate::gpu::pipeline::DescriptorPool;
use crate::gpu::ring::UploadRing;
use crate::gpu::timestamps::TimestampPool;
use crate::gpu::{GpuContext, GpuResult};
use crate::passes::Pass;

/// Two timestamps per scope: a frame has a handful of passes, the import, composite and read-back.
const QUERIES_PER_FRAME: u32 = 64;
/// Descriptor sets one frame allocates at most (one per pass).
const SETS_PER_FRAME: u32 = 32;

pub(super) struct Slot {
    pub pool: DescriptorPool,
    pub ring: UploadRing,
    pub timestamps: TimestampPool,
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
        Ok(Slot { pool, ring, timestamps, scopes: Vec::new(), pending: None })
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

    /// The frame recorded last will not be submitted.
    pub fn abandon(&mut self) {
        self.pending = None;
    }

    /// If this slot's frame is `through` or older: what it measured (timestamps read without
    /// waiting: the frame is known finished) and what its passes counted.
    pub fn finish(
        &mut self,
        ctx: &GpuContext,
        slot: usize,
        through: u64,
        passes: &[Box<dyn Pass>],
    ) -> GpuResult<Option<FinishedFrame>> {
        let Some(frame) = self.pending.filter(|&f| f <= through) else { return Ok(None) };
        self.pending = None;
        let mut stats = FrameStats::default();
        // A frame the host said finished has all its timestamps; None only if it broke the contract.
        if let Some(ticks) = self.timestamps.try_read_ns(ctx)? {
            let (timings, gpu_frame_ms) = pass_timings(&self.scopes, &ticks);
            stats.passes = timings;
            stats.gpu_frame_ms = gpu_frame_ms;
        }
        passes.iter().for_each(|p| p.finished(slot, &mut stats));
        Ok(Some(FinishedFrame { frame, stats }))
    }
}
