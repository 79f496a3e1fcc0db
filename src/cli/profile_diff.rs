//! `hadou profile-diff base.json new.json [--threshold 5%]`: per row (each pass's GPU time, the
//! GPU frame) the ratio of medians new / base with its bootstrap interval; exit 1 when a row is
//! slower beyond the threshold (see `hadou_cli::profile_diff`), 2 on an error. A gated row the gate
//! cannot judge (missing from the candidate, too few timed frames, a median of 0) is an error,
//! and so is an input that is not a regular file or holds a sample that is not a time: a broken
//! candidate never passes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;
use hadou_cli::profile_diff::{diff, GateOptions, RunSamples, Verdict, MAX_RESAMPLES};
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
    /// Bootstrap resamples (100 to 100000).
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
        if self.resamples > MAX_RESAMPLES {
            bail!(
                "--resamples {}: expected at most {MAX_RESAMPLES} (more only refines digits below the \
                 sampling error, and the time grows with them)",
                self.resamples
            );
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
        // The type is checked before opening: a FIFO would block, a device might never end.
        let meta = std::fs::metadata(path).with_context(|| format!("cannot read {}", path.display()))?;
        if !meta.is_file() {
            bail!(
                "cannot read {}: not a regular file (expected a `hadou profile --json` file)",
                path.display()
            );
        }
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
        if samples.is_empty() {
            bail!("{}: /samples has no rows (expected one per pass, e.g. \"gpu raster\")", path.display());
        }
        for (name, series) in &samples {
            if let Some((run, frame, value)) = series.first_bad() {
                let pointer = format!("/samples/{}/runs/{run}/{frame}", pointer_token(name));
                bail!(
                    "{}: {pointer}: {value} is not a frame time (expected a finite number of ms, 0 or more)",
                    path.display()
                );
            }
        }
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

/// A JSON object key as a JSON pointer token (RFC 6901: `~` is `~0`, `/` is `~1`).
fn pointer_token(key: &str) -> String {
    key.replace('~', "~0").replace('/', "~1")
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
    let gate = gate(&base_samples, &new_samples, &opts, args.gate.include_cpu);
    print!("{}", gate.table);
    if !gate.unjudged.is_empty() {
        bail!(
            "the gate cannot judge {} of {} against {}: {}",
            plural(gate.unjudged.len(), "gated row"),
            args.new.display(),
            args.base.display(),
            gate.unjudged.join("; ")
        );
    }
    Ok(if gate.slower.is_empty() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

fn plural(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// What the gate found: its table, the gated rows slower beyond the threshold and the gated rows
/// it could not judge (each with why). It passes only when both lists are empty.
pub struct Gate {
    pub table: String,
    pub slower: Vec<String>,
    pub unjudged: Vec<String>,
}

/// Compares every row. Gated rows are the GPU rows (and the CPU rows with `include_cpu`) of the
/// base: each must be in the candidate with enough timed frames on both sides (a renamed or
/// missing pass, an empty run, too few frames cannot pass). A row only in the candidate has no
/// baseline and is listed, not gated.
pub fn gate(
    base: &BTreeMap<String, RunSamples>,
    new: &BTreeMap<String, RunSamples>,
    opts: &GateOptions,
    include_cpu: bool,
) -> Gate {
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
    let mut unjudged = Vec::new();
    // GPU rows first (passes, then the frame), then the CPU rows.
    let mut names: Vec<&String> = base.keys().chain(new.keys()).collect();
    names.sort_by_key(|n| (!n.starts_with("gpu "), *n == "gpu frame", n.to_string()));
    names.dedup();
    for name in names {
        let gated = name.starts_with("gpu ") || include_cpu;
        let mut cannot = |why: String, out: &mut String| {
            let mark = if gated { "CANNOT JUDGE: " } else { "(not gated) " };
            *out += &format!("{name:<24} {mark}{why}\n");
            if gated {
                unjudged.push(format!("{name}: {why}"));
            }
        };
        let (b, n) = match (base.get(name), new.get(name)) {
            (Some(b), Some(n)) => (b, n),
            (Some(_), None) => {
                cannot("only in base (missing or renamed in the candidate)".into(), &mut out);
                continue;
            }
            (None, _) => {
                out += &format!("{name:<24} only in new (no baseline: not gated)\n");
                continue;
            }
        };
        let d = match diff(&b.timed(), &n.timed(), opts) {
            Ok(d) => d,
            Err(e) => {
                cannot(e.to_string(), &mut out);
                continue;
            }
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
    let gated_in_base = base.keys().filter(|n| n.starts_with("gpu ") || include_cpu).count();
    if gated_in_base == 0 {
        let what = if include_cpu {
            "rows"
        } else {
            "`gpu …` rows (the CPU rows are gated only with --include-cpu)"
        };
        unjudged.push(format!("the base has no {what}"));
    }
    if !unjudged.is_empty() {
        out += &format!(
            "gate: ERROR: cannot judge {} (a gate that cannot compare does not pass)\n",
            plural(unjudged.len(), "gated row")
        );
    } else if slower.is_empty() {
        out += "gate: pass (no row slower beyond the threshold)\n";
    }
    if !slower.is_empty() {
        out += &format!("gate: FAIL: {} slower beyond the threshold: {}\n", slower.len(), slower.join(", "));
    }
    Gate { table: out, slower, unjudged }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pointer_tokens_are_escaped() {
        assert_eq!(pointer_token("gpu a/b~c"), "gpu a~1b~0c");
    }
}
