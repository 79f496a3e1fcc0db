//! `hadou profile SCENE [--size WxH] [--frames N] [--warmup K] [--json F] [--trace F]`
//! (`--ab OTHER_BINARY`: see `profile_ab`).

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use hadou::output::OutputSet;
use hadou::{FrameRequest, Runtime, RuntimeOptions};
use hadou_cli::profile::{chrome_trace, ProfileReport};

#[derive(Args, Debug)]
pub struct ProfileArgs {
    /// Scene file, or `builtin:NAME` (a scene of assets/scenes built into hadou, e.g. builtin:showcase).
    pub(super) scene: PathBuf,
    /// Image size WIDTHxHEIGHT (default: the scene's [render] size).
    #[arg(long)]
    pub(super) size: Option<String>,
    /// Frames measured.
    #[arg(long, default_value_t = 100)]
    pub(super) frames: usize,
    /// Frames rendered first and not measured (shader JIT, caches).
    #[arg(long, default_value_t = 5)]
    pub(super) warmup: usize,
    /// Scene time advanced per frame, seconds.
    #[arg(long, default_value_t = 1.0 / 60.0)]
    pub(super) dt: f64,
    /// Write the summary as JSON.
    #[arg(long)]
    pub(super) json: Option<PathBuf>,
    /// Write a Chrome trace (open in Perfetto).
    #[arg(long)]
    pub(super) trace: Option<PathBuf>,
    /// Another hadou binary: run `profile` on both in alternating runs and gate OTHER against
    /// this one (exit 1 when a pass is slower beyond --threshold).
    #[arg(long, value_name = "OTHER_BINARY")]
    pub(super) ab: Option<PathBuf>,
    /// With --ab: runs of each binary (alternating, ABBA).
    #[arg(long, default_value_t = 6)]
    pub(super) rounds: usize,
    /// With --ab: where to write the other binary's pooled samples (--json gets this one's).
    #[arg(long, value_name = "FILE")]
    pub(super) json_other: Option<PathBuf>,
    /// A GPU frame budget in ms: the effects' quality levels are fitted into it (hadou::budget;
    /// overrides the scene's `[render] budget_ms`); the levels it picked are printed.
    #[arg(long, value_name = "MS")]
    pub(super) budget_ms: Option<f64>,
    #[command(flatten)]
    pub(super) gate: super::profile_diff::GateArgs,
}

impl ProfileArgs {
    /// Whether this is an A/B run (whose exit 1 means "slower").
    pub fn is_ab(&self) -> bool {
        self.ab.is_some()
    }
}

pub fn run(args: ProfileArgs) -> anyhow::Result<ExitCode> {
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if let Some(other) = &args.ab {
        if args.trace.is_some() {
            bail!("--trace is not written with --ab (profile each binary alone for a trace)");
        }
        return super::profile_ab::run(&args, other);
    }
    if args.json_other.is_some() {
        bail!("--json-other needs --ab OTHER_BINARY");
    }
    if !args.dt.is_finite() {
        bail!("--dt must be finite");
    }
    let total = args.warmup.checked_add(args.frames).with_context(|| {
        format!("--warmup {} plus --frames {} is more frames than can be counted", args.warmup, args.frames)
    })?;
    // The per-frame records are reserved up front, so a count this machine cannot hold is an
    // error now rather than an abort later.
    let mut frames = Vec::new();
    let mut starts = Vec::new();
    frames.try_reserve_exact(args.frames).and_then(|()| starts.try_reserve_exact(args.frames)).map_err(
        |e| anyhow::anyhow!("--frames {}: cannot hold the timings of that many frames ({e})", args.frames),
    )?;
    let (scene, (width, height)) = super::load(&args.scene, args.size.as_deref())?;
    let outputs: Vec<&Path> = args.json.iter().chain(&args.trace).map(PathBuf::as_path).collect();
    super::check_outputs(&outputs, &super::scene_inputs(&args.scene, &scene))?;
    let mut runtime = Runtime::new(&RuntimeOptions::from_env())?;
    runtime.load_scene(scene)?;
    if let Some(ms) = args.budget_ms {
        runtime.renderer().set_frame_budget(Some(ms)).context("--budget-ms")?;
    }
    let mut request = FrameRequest::new(width, height);
    request.color = false;
    let run_start = Instant::now();
    let mut last_report = Instant::now();
    for i in 0..total {
        request.time = i as f64 * args.dt;
        let start = run_start.elapsed().as_secs_f64() * 1e3;
        let stats = runtime.render(&request)?.stats;
        if i >= args.warmup {
            frames.push(stats);
            starts.push(start);
        }
        if last_report.elapsed().as_secs_f64() > 1.0 || i + 1 == total {
            // Rewrite one line on a terminal; one line per report in a log.
            if std::io::stderr().is_terminal() {
                eprint!("\rframe {}/{total}", i + 1);
                let _ = std::io::stderr().flush();
            } else {
                eprintln!("frame {}/{total}", i + 1);
            }
            last_report = Instant::now();
        }
    }
    if std::io::stderr().is_terminal() {
        eprintln!();
    }
    let budget = runtime.renderer().budget_status();
    let report = ProfileReport::new(
        args.scene.display().to_string(),
        runtime.device_info().clone(),
        (width, height),
        args.warmup,
        &frames,
    );
    super::finish_validated(runtime)?;
    // Both files or neither.
    let mut set = OutputSet::default();
    if let Some(path) = &args.json {
        let json = serde_json::to_string_pretty(&report).context("serializing the report")?;
        set.stage(path, json.as_bytes())?;
    }
    if let Some(path) = &args.trace {
        set.stage(path, chrome_trace(&frames, &starts).as_bytes())?;
    }
    set.commit()?;
    print!("{}", report.table());
    // What the passes counted on the device (metaballs.dropped, peel.overflowed_texels, ...).
    let mut counters: Vec<(&str, u64)> = Vec::new();
    for (name, value) in frames.iter().flat_map(|f| f.counters.iter()) {
        match counters.iter_mut().find(|(n, _)| n == name) {
            Some((_, v)) => *v = (*v).max(*value),
            None => counters.push((name, *value)),
        }
    }
    if !counters.is_empty() {
        let shown: Vec<String> = counters.iter().map(|(n, v)| format!("{n} {v}")).collect();
        println!("counters (max over the frames): {}", shown.join(", "));
    }
    if let Some(b) = budget {
        println!("{}", budget_line(&b));
    }
    Ok(ExitCode::SUCCESS)
}

/// The frame budget after the run: the levels in use, with their predicted cost and error bound.
fn budget_line(b: &hadou::budget::BudgetStatus) -> String {
    let levels: Vec<String> = (b.effects.iter())
        .map(|e| {
            let l = &e.levels[e.chosen];
            format!("{} {} ({:.3} ms, error {:.2e})", e.name, l.name, l.predicted_ms, l.error)
        })
        .collect();
    format!(
        "budget {:.3} ms: predicted {:.3} ms ({}), other passes {:.3} ms; levels: {}",
        b.budget_ms,
        b.predicted_ms,
        if b.fits { "fits" } else { "does not fit at the cheapest levels" },
        b.fixed_ms,
        if levels.is_empty() { "no effect offers levels".to_string() } else { levels.join(", ") }
    )
}
