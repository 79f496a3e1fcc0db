//! Progress bars on stderr for long commands (`bake`, `report`, `render`), drawn by `indicatif`:
//! redrawn in place on a terminal, and hidden when stderr is not one (logs, CI, pipes), where a
//! bar would only be noise.

use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressFinish, ProgressStyle};

/// indicatif draws nothing into a stderr that is not a terminal.
fn target() -> ProgressDrawTarget {
    ProgressDrawTarget::stderr()
}

/// A bar of `total` steps: `label: [####    ]  42% message`. `finish()` leaves it on the
/// terminal; dropped unfinished (an error) it is cleared, so the error stands alone.
pub fn bar(label: &str, total: u64) -> ProgressBar {
    let style = ProgressStyle::with_template("{prefix}: [{bar:24}] {percent:>3}% {msg}")
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("## ");
    let bar = ProgressBar::with_draw_target(Some(total), target())
        .with_style(style)
        .with_finish(ProgressFinish::AndClear);
    bar.set_prefix(label.to_string());
    bar
}

/// A spinner for steps of unknown length (`set_message` names each), ticking on its own every
/// 100 ms; cleared when dropped.
pub fn spinner(label: &str) -> ProgressBar {
    let style = ProgressStyle::with_template("{prefix}: {spinner} {msg} ({elapsed})")
        .unwrap_or_else(|_| ProgressStyle::default_spinner());
    let bar =
        ProgressBar::with_draw_target(None, target()).with_style(style).with_finish(ProgressFinish::AndClear);
    bar.set_prefix(label.to_string());
    bar.enable_steady_tick(Duration::from_millis(100));
    bar
}
