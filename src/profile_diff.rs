//! The frame-time regression gate: is a pass slower in `new` than in `base`, beyond noise?
//!
//! The statistic is the ratio of medians new / base with a percentile bootstrap confidence
//! interval. Frames of one run are not independent (a run drifts as a whole on a shared
//! machine), so resampling respects that: with two or more runs per side (`hadou profile
//! --ab`), whole runs are resampled and then frames within them (a two-stage cluster bootstrap,
//! which carries the run-to-run spread into the interval); with one run, blocks of ⌈n^⅓⌉
//! consecutive frames (a circular block bootstrap, for the frame-to-frame correlation). A pass
//! is flagged only when the whole interval lies beyond the threshold: slower when its lower end
//! exceeds 1 + t, faster when its upper end is below 1 − t.

use serde::{Deserialize, Serialize};

/// splitmix64: a small, fixed, seedable generator (results must repeat for a given seed).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator started at `seed`.
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in 0..n (n > 0); the modulo bias is below 2⁻⁴⁰ for the n used here.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A standard normal variate (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u = 1.0 - self.unit();
        let v = self.unit();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// Raw per-frame samples of one series, grouped by run; `None` where a frame was untimed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunSamples {
    /// One list per run, in frame order, in milliseconds.
    pub runs: Vec<Vec<Option<f64>>>,
}

impl RunSamples {
    /// The timed frames of each run; runs with none are dropped.
    pub fn timed(&self) -> Vec<Vec<f64>> {
        self.runs
            .iter()
            .map(|r| r.iter().flatten().copied().filter(|v| v.is_finite()).collect::<Vec<f64>>())
            .filter(|r| !r.is_empty())
            .collect()
    }
}

/// How the gate is run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GateOptions {
    /// Relative change that matters, e.g. 0.05.
    pub threshold: f64,
    /// Two-sided confidence of the interval, e.g. 0.95.
    pub confidence: f64,
    /// Bootstrap resamples.
    pub resamples: usize,
    /// The bootstrap's seed (a run repeats exactly).
    pub seed: u64,
}

impl Default for GateOptions {
    fn default() -> Self {
        GateOptions { threshold: 0.05, confidence: 0.95, resamples: 2000, seed: 0x0068_6164_6f75_3136 }
    }
}

/// What the gate says of one series.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Verdict {
    /// The interval lies above 1 + threshold.
    Slower,
    /// The interval lies below 1 − threshold.
    Faster,
    /// The interval reaches inside ±threshold: no change the samples can show.
    WithinNoise,
}

/// One series compared.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SeriesDiff {
    /// Median of base, ms.
    pub base_median: f64,
    /// Median of new, ms.
    pub new_median: f64,
    /// new / base medians.
    pub ratio: f64,
    /// Lower end of the interval of the ratio.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// The call.
    pub verdict: Verdict,
}

/// The median (mean of the two middle values for an even count); sorts part of `v`.
pub fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    let (lower, mid, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    let mid = *mid;
    if n % 2 == 1 {
        mid
    } else {
        let below = lower.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (below + mid)
    }
}

/// One bootstrap resample of a side into `out`.
fn resample(runs: &[Vec<f64>], rng: &mut Rng, out: &mut Vec<f64>) {
    out.clear();
    if runs.len() >= 2 {
        for _ in 0..runs.len() {
            let run = &runs[rng.below(runs.len())];
            for _ in 0..run.len() {
                out.push(run[rng.below(run.len())]);
            }
        }
    } else {
        let run = &runs[0];
        let n = run.len();
        let block = (n as f64).cbrt().ceil().max(1.0) as usize;
        while out.len() < n {
            let start = rng.below(n);
            for k in 0..block.min(n - out.len()) {
                out.push(run[(start + k) % n]);
            }
        }
    }
}

/// Compares two sides' runs (each non-empty, every run non-empty). None when a side is empty or
/// a median is not positive (no ratio).
pub fn diff(base: &[Vec<f64>], new: &[Vec<f64>], opts: &GateOptions) -> Option<SeriesDiff> {
    if base.is_empty() || new.is_empty() || base.iter().chain(new).any(Vec::is_empty) {
        return None;
    }
    let base_median = median(&mut base.concat());
    let new_median = median(&mut new.concat());
    if !(base_median > 0.0 && new_median > 0.0) {
        return None;
    }
    let mut rng = Rng::new(opts.seed);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let mut ratios: Vec<f64> = (0..opts.resamples.max(1))
        .map(|_| {
            resample(base, &mut rng, &mut a);
            resample(new, &mut rng, &mut b);
            median(&mut b) / median(&mut a)
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let tail = (1.0 - opts.confidence) / 2.0;
    let at = |q: f64| ratios[((q * ratios.len() as f64).floor() as usize).min(ratios.len() - 1)];
    let (lo, hi) = (at(tail), at(1.0 - tail));
    let verdict = if lo > 1.0 + opts.threshold {
        Verdict::Slower
    } else if hi < 1.0 - opts.threshold {
        Verdict::Faster
    } else {
        Verdict::WithinNoise
    };
    Some(SeriesDiff { base_median, new_median, ratio: new_median / base_median, lo, hi, verdict })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut [7.0]), 7.0);
    }

    #[test]
    fn the_same_seed_gives_the_same_interval() {
        let mut rng = Rng::new(1);
        let a: Vec<f64> = (0..50).map(|_| 1.0 + 0.1 * rng.unit()).collect();
        let b: Vec<f64> = (0..50).map(|_| 1.0 + 0.1 * rng.unit()).collect();
        let o = GateOptions::default();
        let first = diff(std::slice::from_ref(&a), std::slice::from_ref(&b), &o);
        assert_eq!(first, diff(&[a], &[b], &o));
    }
}
