//! `hadou profile-diff base.json new.json [--threshold 5%]`: per row (each pass's GPU time, the
//! GPU frame) the ratio of medians new / base with its bootstrap interval; exit 1 when a row is
//! slower beyond the threshold (see `hadou::profile_diff`), 2 on an error.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;
use hadou::profile_diff::{diff, GateOptions, RunSamples, Verdict};
use serde::Deserialize;

#[derive(Args, Debug)]
pub struct ProfileDiffArgs {
    /// The baseline: `hadou profile --json` output.
    base: PathBuf,
    /// The candidate, measured the same way.
    new: PathBuf,
    #[command(flatten)]
    gate: GateArgs,
}

/// The gate's options, shared with `profile --ab`.
#[derive(Args, Debug, Clone)]
pub struct GateArgs {
    /// A row fails when its whole interval lies above 1 + THRESHOLD (e.g. 5% or 0.05).
    #[arg(long, default_value = "5%")]
    threshold: String,
    /// Two-sided confidence of the interval.
    #[arg(long, default_value_t = 0.95)]
    confidence: f64,
    /// Bootstrap resamples.
    #[arg(long, default_value_t = 2000)]
    resamples: usize,
    /// Bootstrap seed (the same inputs and seed give the same intervals).
    #[arg(long, default_value_t = GateOptions::default().seed)]
    seed: u64,
    /// Gate the CPU rows too (on lavapipe they include the GPU's work and the host's noise).
    #[arg(long)]
    pub include_cpu: bool,
}

impl GateArgs {
    pub fn options(&self) -> anyhow::Result<GateOptions> {
        let threshold = hadou::compare::parse_fraction(&self.threshold)
            .map_err(anyhow::Error::msg)
            .context("--threshold")?;
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            bail!("--confidence {}: expected a number between 0 and 1, e.g. 0.95", self.confidence);
        }
        if self.resamples < 100 {
            bail!("--resamples {}: expected at least 100", self.resamples);
        }
        Ok(GateOptions { threshold, confidence: self.confidence, resamples: self.resamples, seed: self.seed })
    }
}

/// The part of a `profile --json` file the gate reads.
#[derive(Deserialize, Debug)]
pub struct ProfileFile {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    #[serde(default)]
    pub build_profile: String,
    #[serde(default)]
    pub device: serde_json::Value,
    pub samples: Option<BTreeMap<String, RunSamples>>,
}

impl ProfileFile {
    pub fn read(path: &Path) -> anyhow::Result<(ProfileFile, BTreeMap<String, RunSamples>)> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        let mut file: ProfileFile = serde_json::from_str(&text).with_context(|| {
            format!(
                "{}: not a `hadou profile --json` file (expected scene, width, height, samples)",
                path.display()
            )
        })?;
        let samples = file.samples.take().with_context(|| {
            format!(
                "{}: no raw per-frame samples (written by an older hadou? run `hadou profile --json` again)",
                path.display()
            )
        })?;
        Ok((file, samples))
    }

    fn describe(&self, samples: &BTreeMap<String, RunSamples>) -> String {
        let runs = samples.values().map(|s| s.runs.len()).max().unwrap_or(0);
        let frames: usize = samples.values().map(|s| s.runs.iter().map(Vec::len).sum()).max().unwrap_or(0);
        let device = self.device.get("name").and_then(|n| n.as_str()).unwrap_or("?");
        format!(
            "{} {}x{} on {device}, {} build, {runs} run(s), {frames} frames",
            self.scene, self.width, self.height, self.build_profile
        )
    }
}

pub fn run(args: ProfileDiffArgs) -> anyhow::Result<ExitCode> {
    let opts = args.gate.options()?;
    let (base, base_samples) = ProfileFile::read(&args.base)?;
    let (new, new_samples) = ProfileFile::read(&args.new)?;
    println!("base: {}: {}", args.base.display(), base.describe(&base_samples));
    println!("new:  {}: {}", args.new.display(), new.describe(&new_samples));
    if (base.scene.as_str(), base.width, base.height) != (new.scene.as_str(), new.width, new.height)
        || base.build_profile != new.build_profile
    {
        println!("note: the two files measured different scenes, sizes or builds");
    }
    let (table, slower) = gate_table(&base_samples, &new_samples, &opts, args.gate.include_cpu);
    print!("{table}");
    Ok(if slower { ExitCode::from(1) } else { ExitCode::SUCCESS })
}

/// The comparison table and whether any gated row is slower beyond the threshold.
pub fn gate_table(
    base: &BTreeMap<String, RunSamples>,
    new: &BTreeMap<String, RunSamples>,
    opts: &GateOptions,
    include_cpu: bool,
) -> (String, bool) {
    let pct = |r: f64| format!("{:+.1}%", (r - 1.0) * 100.0);
    let mut out = format!(
        "{:<24} {:>9} {:>9} {:>8}  {:<22} verdict (threshold ±{:.1}%, {:.0}% interval)\n",
        "row (ms, p50)",
        "base",
        "new",
        "change",
        "interval",
        opts.threshold * 100.0,
        opts.confidence * 100.0
    );
    let mut slower = Vec::new();
    // GPU rows first (passes, then the frame), then the CPU rows.
    let mut names: Vec<&String> = base.keys().chain(new.keys()).collect();
    names.sort_by_key(|n| (!n.starts_with("gpu "), *n == "gpu frame", n.to_string()));
    names.dedup();
    for name in names {
        let gated = name.starts_with("gpu ") || include_cpu;
        let (Some(b), Some(n)) = (base.get(name), new.get(name)) else {
            let side = if base.contains_key(name) { "only in base" } else { "only in new" };
            out += &format!("{name:<24} {side}\n");
            continue;
        };
        let Some(d) = diff(&b.timed(), &n.timed(), opts) else {
            out += &format!("{name:<24} no timed frames on one side\n");
            continue;
        };
        let verdict = match d.verdict {
            Verdict::Slower if gated => {
                slower.push(format!("{name} {} ({} … {})", pct(d.ratio), pct(d.lo), pct(d.hi)));
                "SLOWER"
            }
            Verdict::Slower => "slower (not gated)",
            Verdict::Faster => "faster",
            Verdict::WithinNoise => "within noise",
        };
        out += &format!(
            "{name:<24} {:>9.3} {:>9.3} {:>8}  {:<22} {verdict}\n",
            d.base_median,
            d.new_median,
            pct(d.ratio),
            format!("[{} … {}]", pct(d.lo), pct(d.hi))
        );
    }
    if slower.is_empty() {
        out += "gate: pass (no row slower beyond the threshold)\n";
    } else {
        out += &format!("gate: FAIL: {} slower beyond the threshold: {}\n", slower.len(), slower.join(", "));
    }
    (out, !slower.is_empty())
}
