//! Frame-time statistics for `hadou profile`: percentiles per pass, a JSON summary and a Chrome
//! trace (Perfetto opens it).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::profile_diff::RunSamples;
use hadou::gpu::DeviceInfo;
use hadou::FrameStats;

/// min / p50 / p95 / p99 / max of a series, in milliseconds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub min: f64,
    pub p50: f64,
    pub p95: f64,
    pub p99: f64,
    pub max: f64,
    pub mean: f64,
}

impl Summary {
    /// Nearest-rank percentiles; None for an empty series.
    pub fn of(values: &[f64]) -> Option<Summary> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(|a, b| a.total_cmp(b));
        let rank = |p: f64| v[((p / 100.0 * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        Some(Summary {
            min: v[0],
            p50: rank(50.0),
            p95: rank(95.0),
            p99: rank(99.0),
            max: v[v.len() - 1],
            mean: v.iter().sum::<f64>() / v.len() as f64,
        })
    }
}

/// The whole profile: what ran where, and the summaries.
#[derive(Clone, Debug, Serialize)]
pub struct ProfileReport {
    pub scene: String,
    pub device: DeviceInfo,
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    pub warmup: usize,
    pub build_profile: &'static str,
    /// GPU time per pass, in pass order.
    pub passes: BTreeMap<String, Summary>,
    pub pass_order: Vec<String>,
    pub gpu_frame: Option<Summary>,
    pub cpu_record: Option<Summary>,
    pub cpu_submit_wait: Option<Summary>,
    pub cpu_frame: Option<Summary>,
    /// Every frame's value of every row, in frame order (`null` where a frame was untimed), keyed
    /// by the table's row label ("gpu raster", "gpu frame", "cpu frame", …): what
    /// `hadou profile-diff` compares.
    pub samples: BTreeMap<String, RunSamples>,
}

/// A frame row of the table: its label and how to read it from a frame.
type FrameRow = (&'static str, fn(&FrameStats) -> f64);

pub fn build_profile_name() -> &'static str {
    if cfg!(debug_assertions) {
        "debug"
    } else {
        "release"
    }
}

impl ProfileReport {
    pub fn new(
        scene: String,
        device: DeviceInfo,
        size: (u32, u32),
        warmup: usize,
        frames: &[FrameStats],
    ) -> Self {
        let mut pass_order: Vec<String> = Vec::new();
        let mut per_pass: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        for f in frames {
            for p in &f.passes {
                if !pass_order.contains(&p.name) {
                    pass_order.push(p.name.clone());
                }
                per_pass.entry(p.name.clone()).or_default().push(p.gpu_ms);
            }
        }
        let series = |get: fn(&FrameStats) -> f64| Summary::of(&frames.iter().map(get).collect::<Vec<_>>());
        let mut samples = BTreeMap::new();
        for name in &pass_order {
            let per_frame =
                frames.iter().map(|f| f.passes.iter().find(|p| &p.name == name).map(|p| p.gpu_ms)).collect();
            samples.insert(format!("gpu {name}"), RunSamples { runs: vec![per_frame] });
        }
        let rows: [FrameRow; 4] = [
            ("gpu frame", |f| f.gpu_frame_ms),
            ("cpu record", |f| f.cpu_record_ms),
            ("cpu submit+wait", |f| f.cpu_submit_wait_ms),
            ("cpu frame", |f| f.cpu_frame_ms),
        ];
        for (label, get) in rows {
            // An untimed frame (no query pool free) has no passes and no GPU frame time.
            let untimed = |f: &FrameStats| label == "gpu frame" && f.passes.is_empty();
            let per_frame = frames.iter().map(|f| (!untimed(f)).then(|| get(f))).collect();
            samples.insert(label.to_string(), RunSamples { runs: vec![per_frame] });
        }
        ProfileReport {
            scene,
            device,
            width: size.0,
            height: size.1,
            frames: frames.len(),
            warmup,
            build_profile: build_profile_name(),
            passes: per_pass.iter().filter_map(|(k, v)| Some((k.clone(), Summary::of(v)?))).collect(),
            pass_order,
            gpu_frame: series(|f| f.gpu_frame_ms),
            cpu_record: series(|f| f.cpu_record_ms),
            cpu_submit_wait: series(|f| f.cpu_submit_wait_ms),
            cpu_frame: series(|f| f.cpu_frame_ms),
            samples,
        }
    }

    /// A fixed-width table: one row per pass, then the frame rows.
    pub fn table(&self) -> String {
        let mut out = format!(
            "{} on {} ({}), {}x{}, {} frames after {} warm-up, {} build\n",
            self.scene,
            self.device.name,
            self.device.driver,
            self.width,
            self.height,
            self.frames,
            self.warmup,
            self.build_profile
        );
        out += &format!("{:<24} {:>9} {:>9} {:>9} {:>9} {:>9}\n", "ms", "min", "p50", "p95", "p99", "max");
        let mut row = |label: &str, s: Option<&Summary>| {
            if let Some(s) = s {
                out += &format!(
                    "{:<24} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3}\n",
                    label, s.min, s.p50, s.p95, s.p99, s.max
                );
            }
        };
        for name in &self.pass_order {
            row(&format!("gpu {name}"), self.passes.get(name));
        }
        row("gpu frame", self.gpu_frame.as_ref());
        row("cpu record", self.cpu_record.as_ref());
        row("cpu submit+wait", self.cpu_submit_wait.as_ref());
        row("cpu frame", self.cpu_frame.as_ref());
        out
    }
}

#[derive(Serialize)]
struct TraceEvent<'a> {
    name: &'a str,
    cat: &'a str,
    ph: &'static str,
    ts: f64,
    dur: f64,
    pid: u32,
    tid: u32,
}

/// Chrome trace JSON: CPU frames on one track, GPU passes on another. `starts_ms` is each frame's
/// CPU start since the run began; GPU passes are placed from the frame's submit on.
pub fn chrome_trace(frames: &[FrameStats], starts_ms: &[f64]) -> String {
    let mut events = Vec::new();
    for (f, &start) in frames.iter().zip(starts_ms) {
        events.push(TraceEvent {
            name: "frame",
            cat: "cpu",
            ph: "X",
            ts: start * 1e3,
            dur: f.cpu_frame_ms * 1e3,
            pid: 1,
            tid: 1,
        });
        events.push(TraceEvent {
            name: "record",
            cat: "cpu",
            ph: "X",
            ts: start * 1e3,
            dur: f.cpu_record_ms * 1e3,
            pid: 1,
            tid: 1,
        });
        let gpu_start = start + f.cpu_record_ms;
        for p in &f.passes {
            events.push(TraceEvent {
                name: &p.name,
                cat: "gpu",
                ph: "X",
                ts: (gpu_start + p.start_ms) * 1e3,
                dur: p.gpu_ms * 1e3,
                pid: 1,
                tid: 2,
            });
        }
    }
    let threads = serde_json::json!([
        {"name": "thread_name", "ph": "M", "pid": 1, "tid": 1, "args": {"name": "CPU"}},
        {"name": "thread_name", "ph": "M", "pid": 1, "tid": 2, "args": {"name": "GPU"}},
    ]);
    let mut all = serde_json::to_value(&events).unwrap_or_default();
    if let (Some(list), Some(meta)) = (all.as_array_mut(), threads.as_array()) {
        list.extend(meta.iter().cloned());
    }
    serde_json::json!({ "traceEvents": all, "displayTimeUnit": "ms" }).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<f64> = (1..=100).map(|i| i as f64).collect();
        let s = Summary::of(&v).unwrap();
        assert_eq!((s.min, s.p50, s.p95, s.p99, s.max), (1.0, 50.0, 95.0, 99.0, 100.0));
        let one = Summary::of(&[3.0]).unwrap();
        assert_eq!((one.p50, one.p99), (3.0, 3.0));
        assert!(Summary::of(&[]).is_none());
        assert!(Summary::of(&[f64::NAN]).is_none());
    }
}
