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
    /// The timed frames of each run; runs with none are dropped. A bad value (negative or not
    /// finite) is kept for `diff` to refuse; `first_bad` finds it with its place in the file.
    pub fn timed(&self) -> Vec<Vec<f64>> {
        self.runs
            .iter()
            .map(|r| r.iter().flatten().copied().collect::<Vec<f64>>())
            .filter(|r| !r.is_empty())
            .collect()
    }

    /// The first sample that is not a time, as (run, frame, value): negative or not finite.
    pub fn first_bad(&self) -> Option<(usize, usize, f64)> {
        self.runs.iter().enumerate().find_map(|(r, run)| {
            run.iter().enumerate().find_map(|(f, v)| v.filter(|v| !is_time(*v)).map(|v| (r, f, v)))
        })
    }

    /// How many frames are timed, over all runs.
    pub fn timed_count(&self) -> usize {
        self.runs.iter().map(|r| r.iter().flatten().count()).sum()
    }
}

/// A frame time: finite and not negative (0 is a pass too short for the timer).
fn is_time(v: f64) -> bool {
    v.is_finite() && v >= 0.0
}

/// The most bootstrap resamples a gate may ask for. The ends of the interval are quantiles of
/// the resampled ratios; their Monte Carlo error, as a tail probability, is √(p(1 − p)/B): 0.35
/// points at the default B = 2000 and p = 2.5 %, 0.05 points at 100,000, far below the
/// sampling error of any frame-time series, so more resamples only refine digits that mean
/// nothing. The cost is linear in B (times the frames of both sides, per row): 100,000
/// resamples of a 10-row `--ab` file of 6 runs × 60 frames a side take 6 s in a debug build
/// (measured on this project's 2-core machine), so 10⁸ would take 1.6 hours, and `usize::MAX`
/// cannot even be counted.
pub const MAX_RESAMPLES: usize = 100_000;

/// The fewest resamples: below 100 the 2.5 % tail holds fewer than 3 ratios.
pub const MIN_RESAMPLES: usize = 100;

/// The fewest timed frames a side of a row needs for an interval at `confidence`:
/// ⌈1 + log₂(1 / (1 − confidence))⌉, 6 at 95 %. Why: with n samples the widest interval order
/// statistics give for a median, [min, max], misses it with probability 2 · 2⁻ⁿ, so below that
/// n no interval at the asked confidence exists, whatever the method; a bootstrap interval from
/// fewer samples is an artefact of the resampling (one sample resamples to itself, a zero-width
/// interval: any difference at all is "significant").
pub fn min_samples(confidence: f64) -> usize {
    let n = 1.0 + (1.0 / (1.0 - confidence)).log2();
    if n.is_finite() {
        (n.ceil() as usize).max(2)
    } else {
        usize::MAX
    }
}

/// Which side of a comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The baseline.
    Base,
    /// The candidate.
    New,
}

impl std::fmt::Display for Side {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Side::Base => "base",
            Side::New => "new",
        })
    }
}

/// Why two series cannot be compared: the gate cannot judge them, which is never a pass.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DiffError {
    /// `GateOptions` out of range.
    #[error("{0}")]
    Options(String),
    /// A side has too few timed frames for an interval (see `min_samples`).
    #[error("{side} has {timed} timed frame(s), fewer than the {min} an interval at confidence {confidence} needs")]
    TooFewSamples { side: Side, timed: usize, min: usize, confidence: f64 },
    /// A sample that is not a time.
    #[error("{side} run {run} frame {frame} is {value} ms (expected a finite time, 0 or more)")]
    BadSample { side: Side, run: usize, frame: usize, value: f64 },
    /// A median of 0: no ratio.
    #[error("the {side} median is 0 ms: no ratio can be formed")]
    ZeroMedian { side: Side },
}

impl GateOptions {
    /// Checks the options are in range (see `MAX_RESAMPLES`).
    pub fn check(&self) -> Result<(), DiffError> {
        let bad = |m: String| Err(DiffError::Options(m));
        if !(self.threshold.is_finite() && self.threshold >= 0.0) {
            return bad(format!("threshold {}: expected a finite fraction, 0 or more", self.threshold));
        }
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return bad(format!(
                "confidence {}: expected a number between 0 and 1, e.g. 0.95",
                self.confidence
            ));
        }
        if !(MIN_RESAMPLES..=MAX_RESAMPLES).contains(&self.resamples) {
            return bad(format!(
                "resamples {}: expected {MIN_RESAMPLES} to {MAX_RESAMPLES} (more only refines digits \
                 below the sampling error, and the time grows with them)",
                self.resamples
            ));
        }
        Ok(())
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

/// Compares two sides' runs. An error when the options are out of range, a sample is not a time
/// (negative or not finite), a side has fewer timed frames than `min_samples` or a median is 0:
/// what the samples cannot show is never reported as "within noise".
pub fn diff(base: &[Vec<f64>], new: &[Vec<f64>], opts: &GateOptions) -> Result<SeriesDiff, DiffError> {
    opts.check()?;
    let min = min_samples(opts.confidence);
    for (side, runs) in [(Side::Base, base), (Side::New, new)] {
        for (run, frames) in runs.iter().enumerate() {
            if let Some((frame, &value)) = frames.iter().enumerate().find(|(_, v)| !is_time(**v)) {
                return Err(DiffError::BadSample { side, run, frame, value });
            }
        }
        let timed: usize = runs.iter().map(Vec::len).sum();
        if timed < min {
            return Err(DiffError::TooFewSamples { side, timed, min, confidence: opts.confidence });
        }
    }
    // Empty runs hold nothing to resample.
    let base: Vec<Vec<f64>> = base.iter().filter(|r| !r.is_empty()).cloned().collect();
    let new: Vec<Vec<f64>> = new.iter().filter(|r| !r.is_empty()).cloned().collect();
    let (base, new) = (base.as_slice(), new.as_slice());
    let base_median = median(&mut base.concat());
    let new_median = median(&mut new.concat());
    for (side, m) in [(Side::Base, base_median), (Side::New, new_median)] {
        if m <= 0.0 {
            return Err(DiffError::ZeroMedian { side });
        }
    }
    let mut rng = Rng::new(opts.seed);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let mut ratios: Vec<f64> = (0..opts.resamples)
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
    Ok(SeriesDiff { base_median, new_median, ratio: new_median / base_median, lo, hi, verdict })
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

    #[test]
    fn the_minimum_sample_count_is_the_order_statistics_bound() {
        // [min, max] of n samples misses the median with probability 2 · 2⁻ⁿ.
        for c in [0.5, 0.8, 0.9, 0.95, 0.99, 0.999] {
            let n = min_samples(c);
            assert!(1.0 - 2.0 * 0.5f64.powi(n as i32) >= c, "{c}: {n}");
            assert!(1.0 - 2.0 * 0.5f64.powi(n as i32 - 1) < c, "{c}: {n}");
        }
        assert_eq!(min_samples(0.95), 6);
    }

    #[test]
    fn what_the_samples_cannot_show_is_an_error() {
        let o = GateOptions::default();
        let ok: Vec<f64> = (0..20).map(|i| 1.0 + 0.01 * i as f64).collect();
        let few = diff(std::slice::from_ref(&ok), &[vec![1.5]], &o).unwrap_err();
        assert_eq!(few, DiffError::TooFewSamples { side: Side::New, timed: 1, min: 6, confidence: 0.95 });
        assert!(matches!(diff(&[], std::slice::from_ref(&ok), &o), Err(DiffError::TooFewSamples { .. })));
        let mut bad = ok.clone();
        bad[3] = -1.0;
        let e = diff(std::slice::from_ref(&ok), &[bad.clone()], &o).unwrap_err();
        assert_eq!(e, DiffError::BadSample { side: Side::New, run: 0, frame: 3, value: -1.0 });
        bad[3] = f64::NAN;
        assert!(matches!(diff(&[bad], std::slice::from_ref(&ok), &o), Err(DiffError::BadSample { .. })));
        let zeros = vec![0.0; 20];
        assert_eq!(
            diff(&[zeros], std::slice::from_ref(&ok), &o),
            Err(DiffError::ZeroMedian { side: Side::Base })
        );
        for resamples in [0, 99, MAX_RESAMPLES + 1, usize::MAX] {
            let o = GateOptions { resamples, ..o };
            let one = std::slice::from_ref(&ok);
            assert!(matches!(diff(one, one, &o), Err(DiffError::Options(_))));
        }
    }
}
