//! A progress line on stderr for long commands (`bake`, `report`): a bar, the percentage and what
//! is being done, redrawn in place at most every 100 ms on a terminal, a new line every 2 s
//! otherwise (logs, CI); 100 % exactly once.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::Instant;

pub struct Progress {
    label: String,
    terminal: bool,
    /// When the line was last drawn, and whether 100 % has been shown.
    state: Mutex<(Option<Instant>, bool)>,
}

const BAR: usize = 24;

impl Progress {
    pub fn new(label: String) -> Progress {
        Progress { label, terminal: std::io::stderr().is_terminal(), state: Mutex::new((None, false)) }
    }

    /// Shows `done` of `total` with `detail` after the percentage. `force` draws even when the
    /// last line is recent (a new step a person wants to see named).
    pub fn show(&self, done: usize, total: usize, detail: &str, force: bool) {
        let Ok(mut state) = self.state.lock() else { return };
        let (last, finished) = &mut *state;
        let period = if self.terminal { 100 } else { 2000 };
        let due = force || last.is_none_or(|t| t.elapsed().as_millis() >= period);
        if *finished || (!due && done < total) {
            return;
        }
        *last = Some(Instant::now());
        *finished = done >= total;
        let fraction = if total == 0 { 1.0 } else { (done as f64 / total as f64).min(1.0) };
        let filled = (fraction * BAR as f64).round() as usize;
        let bar = format!("[{}{}]", "#".repeat(filled), " ".repeat(BAR - filled));
        let mut err = std::io::stderr().lock();
        // On a terminal: rewrite the line, clearing what a longer earlier line left.
        let (start, end) = if self.terminal { ("\r\x1b[2K", "") } else { ("", "\n") };
        let _ = write!(err, "{start}{}: {bar} {:5.1}% {detail}{end}", self.label, fraction * 100.0);
        let _ = err.flush();
    }

    /// Ends the line on a terminal.
    pub fn finish(&self) {
        if self.terminal {
            let _ = writeln!(std::io::stderr());
        }
    }
}
