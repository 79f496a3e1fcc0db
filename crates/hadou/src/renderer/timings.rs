//! What a finished frame reports: its per-pass GPU times and the device's counters.

use crate::frame::{FrameStats, PassTiming};

/// Per-pass GPU times of one finished frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameTimings {
    /// `RecordedFrame::frame` of the frame these belong to.
    pub frame: u64,
    /// Each timed scope (the passes, depth import, composite, read-back) in recording order.
    pub passes: Vec<PassTiming>,
    /// From the first scope's start to the last one's end.
    pub gpu_frame_ms: f64,
}

/// A frame known to have finished, with what was read of it.
#[derive(Clone, Debug)]
pub(crate) struct FinishedFrame {
    pub frame: u64,
    pub stats: FrameStats,
}

impl FinishedFrame {
    pub fn timings(&self) -> FrameTimings {
        FrameTimings {
            frame: self.frame,
            passes: self.stats.passes.clone(),
            gpu_frame_ms: self.stats.gpu_frame_ms,
        }
    }
}
