//! `hadou view SCENE`: an interactive window on a scene (keys in `keys.rs`, `--help`, README).

mod app;
mod camera_control;
mod gpu;
mod keys;
mod reload;
mod screenshot;
mod script;
mod title;
mod toggles;

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;

#[derive(Args, Debug)]
#[command(after_help = keys::HELP)]
pub struct ViewArgs {
    /// Scene file (TOML, see docs/scene-format.md), reloaded when it changes on disk, or
    /// `builtin:NAME` (e.g. builtin:showcase).
    scene: PathBuf,
    /// Initial window size WIDTHxHEIGHT (default: the scene's [render] size).
    #[arg(long)]
    size: Option<String>,
    /// Scene time to start at, in seconds.
    #[arg(long, default_value_t = 0.0)]
    time: f64,
    /// Start with time paused (Space resumes).
    #[arg(long)]
    paused: bool,
    /// For tests and automation: steps run after each presented frame, e.g.
    /// "frames=5;resize=320x200;frames=3;screenshot=shot.png;quit" (see src/cli/view/script.rs).
    /// Also read from HADOU_VIEW_SCRIPT when the option is not given.
    #[arg(long)]
    script: Option<String>,
}

pub fn run(args: ViewArgs) -> anyhow::Result<()> {
    let text = args.script.or_else(|| std::env::var("HADOU_VIEW_SCRIPT").ok().filter(|s| !s.is_empty()));
    let script = text.as_deref().map(script::Script::parse).transpose().map_err(anyhow::Error::msg)?;
    if !args.time.is_finite() {
        bail!("--time must be a finite number of seconds, got {}", args.time);
    }
    let (scene, size) = super::load(&args.scene, args.size.as_deref())?;
    let event_loop = winit::event_loop::EventLoop::new()
        .context("cannot open a window (is DISPLAY set? under CI run an X server such as Xvfb)")?;
    let proxy = event_loop.create_proxy();
    let wake: reload::Wake = std::sync::Arc::new(move || {
        let _ = proxy.send_event(()); // closed: the viewer is exiting
    });
    let mut app = app::App::new(args.scene.clone(), scene, size, script, wake);
    app.set_time(args.time, args.paused);
    event_loop.run_app(&mut app).context("window event loop")?;
    let (result, log) = app.finish();
    if let Some(log) = log {
        let counts = log.counts();
        if counts.errors > 0 || counts.warnings > 0 {
            for m in log.messages() {
                eprintln!("validation: {m}");
            }
            bail!("validation reported {} errors and {} warnings", counts.errors, counts.warnings);
        }
    }
    result
}
