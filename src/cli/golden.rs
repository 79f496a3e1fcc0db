//! `hadou test DIR [--refs REFS] [--bless] [--junit FILE] [--out DIR]`: every scene `DIR/*.toml`
//! rendered and compared with its references `REFS/NAME.png` and `REFS/NAME.AOV.exr` under the
//! sidecar `REFS/NAME.test.toml` (size, time, AOVs, tolerance; see `golden_case`). Exit 0 when
//! every scene passes (or is skipped), 1 when one differs or lacks a reference, 2 on an error.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use hadou::compare::{compare_loaded, decode, Comparison};
use hadou::output::{self, OutputSet};
use hadou::{FrameRequest, Runtime, RuntimeOptions};

use super::golden_case::{Case, Outcome, Sidecar};

#[derive(Args, Debug)]
pub struct TestArgs {
    /// Folder of scene files (`*.toml`; `*.test.toml` sidecars are not scenes).
    dir: PathBuf,
    /// Folder of the references and sidecars (default: DIR/references).
    #[arg(long)]
    refs: Option<PathBuf>,
    /// Write the renders as the new references instead of comparing.
    #[arg(long)]
    bless: bool,
    /// Write a JUnit XML report (what CI systems read).
    #[arg(long, value_name = "FILE.xml")]
    junit: Option<PathBuf>,
    /// For each scene that differs, write its render and heat maps here.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// The scenes of `dir`, sorted by name.
fn scenes(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("cannot read the folder {}", dir.display()))?;
    let mut out = Vec::new();
    for entry in entries {
        let path = entry.with_context(|| format!("cannot read the folder {}", dir.display()))?.path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        if name.ends_with(".toml") && !name.ends_with(".test.toml") && path.is_file() {
            out.push(path);
        }
    }
    out.sort();
    if out.is_empty() {
        bail!("{}: no scene files (*.toml)", dir.display());
    }
    Ok(out)
}

pub fn run(args: TestArgs) -> anyhow::Result<ExitCode> {
    let refs = args.refs.clone().unwrap_or_else(|| args.dir.join("references"));
    let mut cases: Vec<Case> = scenes(&args.dir)?.into_iter().map(|s| Case::new(s, &refs)).collect();
    // Sidecars first: a malformed one is an error before the GPU starts.
    for case in &mut cases {
        case.sidecar = Sidecar::read(&case.sidecar_path)?;
    }
    let outputs: Vec<PathBuf> = args.junit.iter().cloned().collect();
    super::check_outputs(&outputs.iter().map(PathBuf::as_path).collect::<Vec<_>>(), &[])?;
    let mut runtime: Option<Runtime> = None;
    let mut blessed = OutputSet::default();
    let started = Instant::now();
    for case in &mut cases {
        if let Some(why) = case.sidecar.skip.clone() {
            case.outcome = Outcome::Skipped(why);
            continue;
        }
        let t = Instant::now();
        if runtime.is_none() {
            runtime = Some(Runtime::new(&RuntimeOptions::from_env())?);
        }
        let rt = runtime.as_mut().context("no runtime")?;
        case.outcome = match run_case(rt, case, &args, &mut blessed) {
            Ok(outcome) => outcome,
            Err(e) => Outcome::Error(format!("{e:#}")),
        };
        case.seconds = t.elapsed().as_secs_f64();
    }
    // Objects still alive at vkDestroyDevice are reported only then: a leak fails the run (and
    // blesses nothing), as a message during a scene fails that scene.
    if let Some(rt) = runtime.take() {
        super::finish_validated(rt)?;
    }
    if args.bless && !cases.iter().any(|c| matches!(c.outcome, Outcome::Error(_))) {
        blessed.commit()?;
    }
    let table = super::golden_case::table(&cases, args.bless);
    print!("{table}");
    if let Some(path) = &args.junit {
        let xml = super::golden_case::junit(&cases, &args.dir, started.elapsed().as_secs_f64());
        output::write_atomically(path, xml.as_bytes())?;
    }
    let errors = cases.iter().any(|c| matches!(c.outcome, Outcome::Error(_)));
    let failed = cases.iter().any(|c| matches!(c.outcome, Outcome::Failed(_)));
    Ok(ExitCode::from(if errors {
        2
    } else if failed {
        1
    } else {
        0
    }))
}

/// Renders one scene and compares (or stages its references).
fn run_case(
    rt: &mut Runtime,
    case: &Case,
    args: &TestArgs,
    blessed: &mut OutputSet,
) -> anyhow::Result<Outcome> {
    let scene = hadou::scene::load_scene(&case.scene)?;
    let (width, height) = match &case.sidecar.size {
        Some(size) => {
            super::parse_size(size).with_context(|| format!("{}: size", case.sidecar_path.display()))?
        }
        None => (scene.render.width, scene.render.height),
    };
    let aovs = case.sidecar.aovs()?;
    let before = rt.validation_counts();
    rt.load_scene(scene)?;
    let request = FrameRequest { width, height, time: case.sidecar.time, color: true, aovs: aovs.clone() };
    let frame = rt.render(&request)?;
    let after = rt.validation_counts();
    if after.errors > before.errors || after.warnings > before.warnings {
        let messages = rt.validation_messages();
        bail!(
            "validation reported {} errors and {} warnings: {}",
            after.errors - before.errors,
            after.warnings - before.warnings,
            messages.last().map(String::as_str).unwrap_or("")
        );
    }
    // Each output as the bytes a file would hold: references and renders take the same path.
    let mut rendered = Vec::new();
    let png = case.reference_png();
    let color = frame.color.as_deref().context("the frame returned no colour")?;
    rendered.push((png.clone(), output::encode_png(&png, width, height, color)?));
    for aov in &aovs {
        let path = case.reference_aov(*aov);
        let image = frame.aov(*aov).context("the frame returned no AOV")?;
        rendered.push((path.clone(), output::encode_exr(&path, aov.name(), image)?));
    }
    if args.bless {
        for (path, bytes) in &rendered {
            blessed.stage(path, bytes)?;
        }
        return Ok(Outcome::Blessed(rendered.len()));
    }
    let mut problems = Vec::new();
    let mut details = Vec::new();
    for (reference, bytes) in &rendered {
        if !reference.exists() {
            problems.push(format!("no reference {} (make it with --bless)", reference.display()));
            continue;
        }
        let label = PathBuf::from(format!("{} (render of {})", reference.display(), case.name));
        let want = hadou::compare::load(reference)?;
        let got = decode(&label, bytes)?;
        let c = compare_loaded((reference, &want), (&label, &got), &case.sidecar.tolerance)?;
        let file = reference.file_name().unwrap_or_default().to_string_lossy().to_string();
        details.push(format!("{file}: {}", short(&c)));
        if !c.same {
            problems.push(format!("{file}: {}", c.reasons.join("; ")));
            if let Some(out) = &args.out {
                write_failure(out, &file, bytes, &c)?;
            }
        }
    }
    Ok(if problems.is_empty() {
        Outcome::Passed(details.join("; "))
    } else {
        Outcome::Failed(problems.join("; "))
    })
}

fn short(c: &Comparison) -> String {
    let m: Vec<String> = c.metrics.iter().take(2).map(|(k, v)| format!("{k} {v:.3e}")).collect();
    m.join(", ")
}

/// The render and its heat map beside each other in `out`, for a CI's artifacts.
fn write_failure(out: &Path, file: &str, bytes: &[u8], c: &Comparison) -> anyhow::Result<()> {
    output::write_atomically(&out.join(file), bytes)?;
    let stem = file.rsplit_once('.').map(|(s, _)| s).unwrap_or(file);
    super::compare::write_heatmap(&out.join(format!("{stem}.heat.png")), c)
}
