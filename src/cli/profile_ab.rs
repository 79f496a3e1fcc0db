//! `hadou profile SCENE --ab OTHER_BINARY [--rounds R]`: this binary and another profile the
//! same scene in alternating runs (ABBA order: A B, B A, A B, …), so that the machine's drift
//! falls on both alike; the pooled runs are compared by the regression gate (new = OTHER).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};

use anyhow::{bail, Context};
use hadou::output::OutputSet;
use hadou_cli::profile_diff::RunSamples;

use super::profile::ProfileArgs;
use super::profile_diff::{gate, ProfileFile};

/// Runs one side's `profile` once, into `json`.
fn run_once(binary: &Path, args: &ProfileArgs, json: &Path) -> anyhow::Result<()> {
    let mut cmd = Command::new(binary);
    cmd.arg("profile").arg(&args.scene);
    if let Some(size) = &args.size {
        cmd.args(["--size", size]);
    }
    cmd.args(["--frames", &args.frames.to_string(), "--warmup", &args.warmup.to_string()]);
    cmd.args(["--dt", &args.dt.to_string()]).arg("--json").arg(json);
    if let Some(ms) = args.budget_ms {
        cmd.args(["--budget-ms", &ms.to_string()]);
    }
    let out = cmd
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("cannot run {} (expected a hadou binary)", binary.display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = err.lines().rev().take(3).collect::<Vec<_>>().into_iter().rev().collect();
        bail!("{} profile failed ({}): {}", binary.display(), out.status, tail.join(" / "));
    }
    Ok(())
}

/// One side's runs pooled, as a `profile --json`-shaped file with raw samples only.
struct Side {
    first: Option<ProfileFile>,
    samples: BTreeMap<String, RunSamples>,
}

impl Side {
    fn add(&mut self, path: &Path) -> anyhow::Result<()> {
        let (file, samples) = ProfileFile::read(path)?;
        for (name, s) in samples {
            self.samples.entry(name).or_default().runs.extend(s.runs);
        }
        self.first.get_or_insert(file);
        Ok(())
    }

    fn json(&self, binary: &Path, args: &ProfileArgs) -> anyhow::Result<String> {
        let f = self.first.as_ref().context("no run finished")?;
        let value = serde_json::json!({
            "scene": f.scene, "width": f.width, "height": f.height, "build_profile": f.build_profile,
            "device": f.device, "binary": binary.display().to_string(), "rounds": args.rounds,
            "frames": args.frames, "warmup": args.warmup, "samples": self.samples,
        });
        serde_json::to_string_pretty(&value).context("serializing the pooled samples")
    }
}

pub fn run(args: &ProfileArgs, other: &Path) -> anyhow::Result<ExitCode> {
    let opts = args.gate.options()?;
    if args.rounds == 0 {
        bail!("--rounds must be at least 1");
    }
    let (scene, _) = super::load(&args.scene, args.size.as_deref())?;
    let outputs: Vec<&Path> = args.json.iter().chain(&args.json_other).map(PathBuf::as_path).collect();
    super::check_outputs(&outputs, &super::scene_inputs(&args.scene, &scene))?;
    let this = std::env::current_exe().context("cannot find this binary's path")?;
    let dir = std::env::temp_dir().join(format!("hadou-ab-{}", std::process::id()));
    // Registered: SIGINT/SIGTERM removes it with the runs' files.
    hadou::output::interrupt::create_temporary_dir(&dir)
        .with_context(|| format!("cannot create {}", dir.display()))?;
    let result = rounds(args, &this, other, &dir);
    hadou::output::interrupt::remove_temporary(&dir);
    let (a, b) = result?;
    let mut set = OutputSet::default();
    if let Some(path) = &args.json {
        set.stage(path, a.json(&this, args)?.as_bytes())?;
    }
    if let Some(path) = &args.json_other {
        set.stage(path, b.json(other, args)?.as_bytes())?;
    }
    set.commit()?;
    println!(
        "A/B: {} (base: {}) against {} (new), {} rounds of {} frames each, interleaved",
        args.scene.display(),
        this.display(),
        other.display(),
        args.rounds,
        args.frames
    );
    let gate = gate(&a.samples, &b.samples, &opts, args.gate.include_cpu);
    print!("{}", gate.table);
    // A row the gate cannot judge (a pass missing from one side, too few frames) is an error
    // (exit 2), as in profile-diff, not "slower".
    if !gate.unjudged.is_empty() {
        anyhow::bail!("the gate cannot judge {}: {}", other.display(), gate.unjudged.join("; "));
    }
    Ok(if gate.slower.is_empty() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

fn rounds(args: &ProfileArgs, this: &Path, other: &Path, dir: &Path) -> anyhow::Result<(Side, Side)> {
    let mut a = Side { first: None, samples: BTreeMap::new() };
    let mut b = Side { first: None, samples: BTreeMap::new() };
    for round in 0..args.rounds {
        // ABBA: the side that runs first alternates, so a trend over time cancels.
        let a_first = round % 2 == 0;
        for step in 0..2 {
            let is_a = (step == 0) == a_first;
            let (binary, side) = if is_a { (this, &mut a) } else { (other, &mut b) };
            let json = dir.join(format!("{}-{round}.json", if is_a { "a" } else { "b" }));
            eprintln!("round {}/{}: {}", round + 1, args.rounds, binary.display());
            run_once(binary, args, &json)?;
            side.add(&json)?;
        }
    }
    Ok((a, b))
}
