//! A ring of timestamp pools, one per frame that may be in flight: a frame's per-pass GPU times
//! are read when the GPU has written them (polled, never waited for).

use crate::frame::{pass_timings, PassTiming, Scope};
use crate::gpu::timestamps::TimestampPool;
use crate::gpu::{GpuContext, GpuResult};

/// Per-pass GPU times of one finished frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameTimings {
    /// `RecordedFrame::frame` of the frame these belong to.
    pub frame: u64,
    pub passes: Vec<PassTiming>,
    /// From the first scope's start to the last one's end.
    pub gpu_frame_ms: f64,
}

struct Slot {
    pool: TimestampPool,
    scopes: Vec<Scope>,
    /// The frame whose timestamps this pool holds or awaits; None when free.
    pending: Option<u64>,
}

pub struct TimingRing {
    slots: Vec<Slot>,
    /// The slot the frame being recorded writes into.
    current: Option<usize>,
    latest: Option<FrameTimings>,
}

/// Two timestamps per scope; a frame has at most 6 passes, the import, composite and read-back.
const QUERIES_PER_FRAME: u32 = 64;

impl TimingRing {
    pub fn new(ctx: &GpuContext, frames: usize) -> GpuResult<Self> {
        let mut ring = TimingRing { slots: Vec::new(), current: None, latest: None };
        for _ in 0..frames {
            match TimestampPool::new(ctx, QUERIES_PER_FRAME) {
                Ok(mut pool) => {
                    // Queries start undefined: reset before the first use.
                    pool.host_reset(ctx);
                    ring.slots.push(Slot { pool, scopes: Vec::new(), pending: None });
                }
                Err(e) => {
                    ring.destroy(ctx);
                    return Err(e);
                }
            }
        }
        Ok(ring)
    }

    /// Starts frame `frame`: takes a free pool (reset on the host), or none when every pool
    /// still awaits an unfinished frame (this frame then goes untimed rather than stalling).
    pub fn begin(&mut self, ctx: &GpuContext, frame: u64) -> GpuResult<bool> {
        self.poll(ctx)?;
        self.current = self.slots.iter().position(|s| s.pending.is_none());
        if let Some(i) = self.current {
            let slot = &mut self.slots[i];
            slot.pool.host_reset(ctx);
            slot.scopes.clear();
            slot.pending = Some(frame);
        }
        Ok(self.current.is_some())
    }

    /// The pool of the frame being recorded, if it is timed.
    pub fn pool(&mut self) -> Option<&mut TimestampPool> {
        let i = self.current?;
        Some(&mut self.slots[i].pool)
    }

    /// Adds scopes of the frame being recorded.
    pub fn push_scopes(&mut self, scopes: &[Scope]) {
        if let Some(i) = self.current {
            self.slots[i].scopes.extend_from_slice(scopes);
        }
    }

    /// Collects every pending frame whose timestamps are all written, newest wins.
    pub fn poll(&mut self, ctx: &GpuContext) -> GpuResult<()> {
        for slot in &mut self.slots {
            let Some(frame) = slot.pending else { continue };
            if let Some(ticks) = slot.pool.try_read_ns(ctx)? {
                let (passes, gpu_frame_ms) = pass_timings(&slot.scopes, &ticks);
                slot.pending = None;
                if self.latest.as_ref().is_none_or(|l| l.frame < frame) {
                    self.latest = Some(FrameTimings { frame, passes, gpu_frame_ms });
                }
            }
        }
        Ok(())
    }

    pub fn latest(&self) -> Option<&FrameTimings> {
        self.latest.as_ref()
    }

    /// Forgets the frame being recorded (its command buffer will not be submitted).
    pub fn abandon_current(&mut self, ctx: &GpuContext) {
        if let Some(i) = self.current.take() {
            self.slots[i].pending = None;
            self.slots[i].pool.host_reset(ctx);
        }
    }

    pub fn destroy(&mut self, ctx: &GpuContext) {
        for slot in self.slots.drain(..) {
            slot.pool.destroy(ctx);
        }
    }
}
