//! `--script`: a fixed sequence of viewer steps for tests and automation (no person at the
//! keyboard): `frames=N` (present N frames), `resize=WxH` (ask the window for that inner size and
//! wait until frames come out at it), `screenshot=PATH` (write the last presented frame),
//! `key=NAME` (press a key: space, period, 1, 2, 3, t, r, c, home, f12, p, escape),
//! `await_reload` (print `script: waiting for a reload` on stderr and present frames until a
//! changed scene or shader file has been handled, kept or rejected), `resize_events=off` (from
//! then on the swapchain is not told about resizes: only the driver's `VK_SUBOPTIMAL_KHR` /
//! `VK_ERROR_OUT_OF_DATE_KHR` can make it follow the window, which tests that path), `quit`.
//! Steps separated by `;` run after each presented frame.

use std::collections::VecDeque;
use std::path::PathBuf;

use super::keys::{action_by_name, Action};

/// Frames a `resize` may take to reach the asked size before the script fails.
pub const RESIZE_FRAME_BUDGET: u32 = 120;
/// Frames `await_reload` may take: only a guard against a script that waits forever (about
/// 4 minutes at the 842 frames/s measured at 96×64 on lavapipe), not a deadline for the edit — a
/// loaded machine may take seconds to make it, and the test driving the script has its own limit.
pub const RELOAD_FRAME_BUDGET: u32 = 200_000;

#[derive(Clone, Debug, PartialEq)]
enum Step {
    Frames(u32),
    Resize(u32, u32),
    WaitSize { width: u32, height: u32, frames_left: u32 },
    Screenshot(PathBuf),
    Key(Action),
    AwaitReload { announced: bool, frames_left: u32 },
    IgnoreResizeEvents,
    Quit,
}

/// What the viewer must do now.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    Resize(u32, u32),
    Screenshot(PathBuf),
    Key(Action),
    /// Print this on stderr (a test driving the viewer waits for it).
    Say(String),
    /// Stop telling the swapchain about window resizes.
    IgnoreResizeEvents,
    Quit,
}

#[derive(Debug)]
pub struct Script {
    steps: VecDeque<Step>,
    reloaded: bool,
}

impl Script {
    pub fn parse(text: &str) -> Result<Script, String> {
        let mut steps = VecDeque::new();
        for (i, item) in text.split(';').map(str::trim).enumerate().filter(|(_, s)| !s.is_empty()) {
            let (name, value) =
                item.split_once('=').map(|(n, v)| (n.trim(), Some(v.trim()))).unwrap_or((item, None));
            let bad = |why: &str| format!("--script step {} `{item}`: {why}", i + 1);
            let step = match (name, value) {
                ("frames", Some(v)) => match v.parse::<u32>() {
                    Ok(n) if n > 0 => Step::Frames(n),
                    _ => return Err(bad("expected frames=N with N ≥ 1")),
                },
                ("resize", Some(v)) => {
                    let size =
                        v.split_once(['x', 'X']).and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)));
                    match size {
                        Some((w, h)) if w > 0 && h > 0 && w <= 16384 && h <= 16384 => Step::Resize(w, h),
                        _ => return Err(bad("expected resize=WIDTHxHEIGHT, each side in 1..=16384")),
                    }
                }
                ("screenshot", Some(v)) if !v.is_empty() => Step::Screenshot(PathBuf::from(v)),
                ("key", Some(v)) => Step::Key(action_by_name(v).ok_or_else(|| bad("unknown key name"))?),
                ("await_reload", None) => {
                    Step::AwaitReload { announced: false, frames_left: RELOAD_FRAME_BUDGET }
                }
                ("resize_events", Some("off")) => Step::IgnoreResizeEvents,
                ("quit", None) => Step::Quit,
                _ => {
                    return Err(bad(
                        "expected frames=N, resize=WxH, screenshot=PATH, key=NAME, await_reload, \
                         resize_events=off or quit",
                    ))
                }
            };
            steps.push_back(step);
        }
        if steps.back() != Some(&Step::Quit) {
            return Err("--script must end with `quit`".into());
        }
        Ok(Script { steps, reloaded: false })
    }

    /// A changed file was handled (reloaded, or rejected with the last good state kept).
    pub fn reload_happened(&mut self) {
        self.reloaded = true;
    }

    /// Advances after a frame was presented at `extent`; returns what to do now. Each `frames`
    /// or resize wait consumes the frame; the steps after it run at once, up to the next one.
    pub fn after_frame(&mut self, extent: (u32, u32)) -> Result<Vec<Command>, String> {
        let mut out = Vec::new();
        let mut frame_used = false;
        while let Some(step) = self.steps.front_mut() {
            match step {
                Step::Frames(n) => {
                    if frame_used {
                        break;
                    }
                    frame_used = true;
                    *n -= 1;
                    if *n == 0 {
                        self.steps.pop_front();
                    }
                }
                Step::Resize(w, h) => {
                    out.push(Command::Resize(*w, *h));
                    *step = Step::WaitSize { width: *w, height: *h, frames_left: RESIZE_FRAME_BUDGET };
                }
                Step::WaitSize { width, height, frames_left } => {
                    if frame_used {
                        break;
                    }
                    frame_used = true;
                    if extent == (*width, *height) {
                        self.steps.pop_front();
                    } else if *frames_left == 0 {
                        return Err(format!(
                            "--script: the window did not reach {width}x{height} within \
                             {RESIZE_FRAME_BUDGET} frames (frames are {}x{})",
                            extent.0, extent.1
                        ));
                    } else {
                        *frames_left -= 1;
                    }
                }
                Step::AwaitReload { announced, frames_left } => {
                    if !*announced {
                        *announced = true;
                        // Only reloads after the announcement count.
                        self.reloaded = false;
                        out.push(Command::Say("script: waiting for a reload".into()));
                        break;
                    }
                    if frame_used {
                        break;
                    }
                    frame_used = true;
                    if std::mem::take(&mut self.reloaded) {
                        self.steps.pop_front();
                    } else if *frames_left == 0 {
                        return Err(format!("--script: no reload within {RELOAD_FRAME_BUDGET} frames"));
                    } else {
                        *frames_left -= 1;
                    }
                }
                Step::Screenshot(path) => {
                    out.push(Command::Screenshot(std::mem::take(path)));
                    self.steps.pop_front();
                }
                Step::IgnoreResizeEvents => {
                    out.push(Command::IgnoreResizeEvents);
                    self.steps.pop_front();
                }
                Step::Key(a) => {
                    out.push(Command::Key(*a));
                    self.steps.pop_front();
                }
                Step::Quit => {
                    out.push(Command::Quit);
                    self.steps.pop_front();
                    break;
                }
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_frames_then_resizes_then_waits_for_the_size() {
        let mut s =
            Script::parse("frames=2; resize=320x200; frames=1; screenshot=a.png; key=t; quit").unwrap();
        assert_eq!(s.after_frame((640, 480)).unwrap(), vec![]);
        assert_eq!(s.after_frame((640, 480)).unwrap(), vec![Command::Resize(320, 200)]);
        assert_eq!(s.after_frame((640, 480)).unwrap(), vec![], "still the old size");
        assert_eq!(s.after_frame((320, 200)).unwrap(), vec![], "the size arrived; frames=1 is next");
        assert_eq!(
            s.after_frame((320, 200)).unwrap(),
            vec![Command::Screenshot("a.png".into()), Command::Key(Action::SwitchThickness), Command::Quit]
        );
    }

    #[test]
    fn a_resize_that_never_arrives_fails() {
        let mut s = Script::parse("resize=10x10;quit").unwrap();
        let mut result = Ok(vec![]);
        for _ in 0..=RESIZE_FRAME_BUDGET + 1 {
            result = s.after_frame((64, 64));
            if result.is_err() {
                break;
            }
        }
        assert!(result.unwrap_err().contains("did not reach 10x10"));
    }

    #[test]
    fn await_reload_announces_then_waits_for_a_reload_after_the_announcement() {
        let mut s = Script::parse("await_reload; quit").unwrap();
        s.reload_happened(); // before the announcement: does not count
        assert_eq!(s.after_frame((8, 8)).unwrap(), vec![Command::Say("script: waiting for a reload".into())]);
        assert_eq!(s.after_frame((8, 8)).unwrap(), vec![]);
        s.reload_happened();
        assert_eq!(s.after_frame((8, 8)).unwrap(), vec![Command::Quit]);
    }

    #[test]
    fn bad_scripts_are_refused() {
        for bad in
            ["frames=0;quit", "frames=2", "resize=10;quit", "key=zz;quit", "jump;quit", "screenshot=;quit"]
        {
            assert!(Script::parse(bad).is_err(), "{bad}");
        }
    }
}
