//! Per-pass GPU times averaged over about half a second, for the window title.

use std::time::{Duration, Instant};

use hadou::FrameStats;

pub const REFRESH: Duration = Duration::from_millis(500);
/// Characters of an error shown in the title.
const ERROR_CHARS: usize = 160;

/// Sums of each pass's GPU ms since the last refresh, in pass order.
#[derive(Debug)]
pub struct PassTimes {
    sums: Vec<(String, f64)>,
    frames: u32,
    since: Instant,
    shown: String,
}

impl PassTimes {
    pub fn new(now: Instant) -> Self {
        PassTimes { sums: Vec::new(), frames: 0, since: now, shown: String::new() }
    }

    pub fn add(&mut self, stats: &FrameStats) {
        for pass in &stats.passes {
            match self.sums.iter_mut().find(|(n, _)| *n == pass.name) {
                Some((_, sum)) => *sum += pass.gpu_ms,
                None => self.sums.push((pass.name.clone(), pass.gpu_ms)),
            }
        }
        self.frames += 1;
    }

    /// The averages text, recomputed when `REFRESH` has passed since the last time (else the
    /// previous text), so the title does not flicker every frame.
    pub fn text(&mut self, now: Instant) -> &str {
        let elapsed = now.duration_since(self.since);
        if elapsed >= REFRESH && self.frames > 0 {
            let n = self.frames as f64;
            let passes: Vec<String> =
                self.sums.iter().map(|(name, sum)| format!("{name} {:.2}", sum / n)).collect();
            let fps = n / elapsed.as_secs_f64();
            self.shown = format!("{} ms | {fps:.1} fps", passes.join(" · "));
            self.sums.clear();
            self.frames = 0;
            self.since = now;
        }
        &self.shown
    }
}

/// The whole title: scene, timings, state and the current error if any.
pub fn title(scene: &str, times: &str, state: &str, error: Option<&str>) -> String {
    let mut t = format!("hadou view {scene} | {times} | {state}");
    if let Some(e) = error {
        // The title is one line: the error's lines joined and cut short; the whole is on stderr.
        let line: Vec<&str> = e.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
        let line = line.join(" ");
        t.push_str(" | ERROR: ");
        t.extend(line.chars().take(ERROR_CHARS));
        if line.chars().count() > ERROR_CHARS {
            t.push('…');
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use hadou::PassTiming;

    fn stats(raster: f64, wave: f64) -> FrameStats {
        let pass = |name: &str, gpu_ms| PassTiming { name: name.into(), start_ms: 0.0, gpu_ms };
        FrameStats { passes: vec![pass("raster", raster), pass("energy_wave", wave)], ..Default::default() }
    }

    #[test]
    fn averages_per_pass_and_refreshes_twice_a_second() {
        let t0 = Instant::now();
        let mut times = PassTimes::new(t0);
        times.add(&stats(1.0, 3.0));
        times.add(&stats(2.0, 5.0));
        assert_eq!(times.text(t0 + Duration::from_millis(100)), "", "not yet");
        assert_eq!(
            times.text(t0 + Duration::from_millis(500)),
            "raster 1.50 · energy_wave 4.00 ms | 4.0 fps"
        );
        times.add(&stats(9.0, 9.0));
        assert_eq!(
            times.text(t0 + Duration::from_millis(600)),
            "raster 1.50 · energy_wave 4.00 ms | 4.0 fps"
        );
        assert!(times
            .text(t0 + Duration::from_millis(1000))
            .starts_with("raster 9.00 · energy_wave 9.00 ms"));
    }

    #[test]
    fn the_title_shows_the_error_on_one_line() {
        let t = title("a.toml", "x", "running", Some("shader a.comp: error:\n  a.comp:3: syntax\n"));
        assert!(t.ends_with("| ERROR: shader a.comp: error: a.comp:3: syntax"), "{t}");
        let long = "x".repeat(500);
        let t = title("a.toml", "x", "running", Some(&long));
        assert!(t.ends_with(&format!("{}…", "x".repeat(ERROR_CHARS))), "{t}");
    }
}
