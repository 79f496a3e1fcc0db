//! `hadou report [--quick] [--out DIR] [--size WxH ...] [--frames N] [--update-docs FILE]`:
//! speed against error for every effect, measured in one run (src/report/).

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;
use hadou::{Runtime, RuntimeOptions};
use hadou_cli::report::output::Staging;
use hadou_cli::report::{docs, ReportOptions};

#[derive(Args, Debug)]
pub struct ReportArgs {
    /// A CI-sized run: small images, few frames, fewer variants (the report says so).
    #[arg(long)]
    quick: bool,
    /// Folder for report.md, the CSV files and the plots; replaced as a whole once all is written.
    #[arg(long, default_value = "report")]
    out: PathBuf,
    /// Sizes of the frame section (repeatable; default 512x512 and 1920x1080, quick: 128x128 and
    /// 240x135).
    #[arg(long)]
    size: Vec<String>,
    /// Frames measured per variant (default 20, quick: 3).
    #[arg(long)]
    frames: Option<usize>,
    /// Rewrite the `<!-- report:ID -->` blocks of this markdown file (docs/PERFORMANCE.md) with
    /// this run's tables.
    #[arg(long)]
    update_docs: Option<PathBuf>,
}

pub fn run(args: ReportArgs) -> anyhow::Result<()> {
    let mut opts = ReportOptions::new(args.quick);
    if !args.size.is_empty() {
        opts.frame_sizes =
            args.size.iter().map(|s| super::parse_size(s)).collect::<Result<_, _>>().context("--size")?;
    }
    if let Some(frames) = args.frames {
        if frames == 0 {
            bail!("--frames must be at least 1");
        }
        // The sections count `warmup + frames`: that sum must not wrap.
        if frames.checked_add(opts.warmup).is_none() {
            bail!("--frames {frames}: too many frames to count");
        }
        opts.frames = frames;
    }
    // Everything that can be checked is checked before minutes of measuring; the file is read
    // again at the end, so edits made meanwhile are kept.
    if let Some(path) = &args.update_docs {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("--update-docs {}", path.display()))?;
        docs::check(&text).map_err(|e| anyhow::anyhow!("{}:{e}", path.display()))?;
    }
    let staging = Staging::create(&args.out)?;
    let mut runtime = Runtime::new(&RuntimeOptions::from_env())?;
    let command: Vec<String> = std::env::args().skip(1).collect();
    let command = format!("hadou {}", command.join(" "));
    let progress = super::progress::bar("report", opts.step_count() as u64);
    let mut show = |label: &str, done: usize, total: usize| {
        progress.set_length(total as u64);
        progress.set_position(done as u64);
        progress.set_message(label.to_string());
    };
    let report = hadou_cli::report::run(&mut runtime, &opts, &command, &mut show)?;
    progress.finish();
    super::finish_validated(runtime)?;
    let written = staging.write(&report)?;
    let out = staging.commit()?;
    println!("report written to {} ({} files)", out.display(), written.len());
    if let Some(path) = &args.update_docs {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("--update-docs {}", path.display()))?;
        let (new, ids) =
            docs::update_blocks(&text, &report).map_err(|e| anyhow::anyhow!("{}:{e}", path.display()))?;
        hadou::output::write_atomically(path, new.as_bytes())?;
        println!("{}: rewrote {} block(s): {}", path.display(), ids.len(), ids.join(", "));
    }
    Ok(())
}
