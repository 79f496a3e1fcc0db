//! `hadou test DIR [--refs REFS] [--bless] [--junit FILE] [--out DIR]`: every scene of DIR — a
//! `*.toml`, `*.gltf` or `*.glb` file — rendered and compared with its references `REFS/NAME.png`
//! and `REFS/NAME.AOV.exr` (NAME the file's stem, whatever its format) under the sidecar
//! `REFS/NAME.test.toml` (size, time, AOVs, tolerance; see `golden_case`). Exit 0 when
//! every scene passes (or is skipped), 1 when one differs or lacks a reference, 2 on an error.
//!
//! Its outputs follow `render`'s rules (`hadou::output`), checked before the GPU starts: the
//! JUnit report, the files `--out` may write and, with `--bless`, the references are never an
//! input (a scene, a file it reads, a sidecar, a reference compared against) nor a special file.
//! `--bless` replaces all references or none. Nothing named like a scene in DIR is passed over in
//! silence: one that is not a regular file is an error row, two scenes of one name (`level.toml`
//! and `level.glb` would share `level.png`) are error rows, and look-alikes (`*.TOML`, a stray
//! `*.test.toml`) are named on stderr as not tested.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use hadou::compare::{compare_loaded, decode_with, load_with, Comparison, PixelBudget, DEFAULT_MAX_PIXELS};
use hadou::output::{self, OutputSet};
use hadou::{FrameRequest, Runtime, RuntimeOptions};

use super::golden_case::{Case, Outcome, Sidecar};

#[derive(Args, Debug)]
pub struct TestArgs {
    /// Folder of scene files (`*.toml`, `*.gltf`, `*.glb`; `*.test.toml` sidecars are not scenes).
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
    /// The largest image rendered or compared, in pixels (width × height); a reference whose
    /// header claims more is an error before it is decoded.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_PIXELS, value_parser = super::parse_max_pixels)]
    max_pixels: u64,
}

/// What `DIR` holds: the scene entries (`*.toml` but `*.test.toml`, `*.gltf`, `*.glb`), each with
/// why it cannot be rendered when it is not a regular file, and the entries that look like scenes
/// but are not tested (said on stderr, not skipped silently).
struct Listing {
    scenes: Vec<(PathBuf, Option<String>)>,
    notes: Vec<String>,
}

/// The scenes of `dir`, sorted by name. Every `*.toml` is a scene, whatever bytes its name holds,
/// and so is every glTF file (`.gltf` or `.glb` in any case, as every other command reads them:
/// `scene::gltf::is_gltf`); one that is not a regular file (a directory, FIFO, symlink to nothing)
/// is listed with why, to be reported as an error rather than left out. References are named
/// after the scene's file stem, whatever its format: scenes sharing a stem are errors.
fn scenes(dir: &Path, refs: &Path) -> anyhow::Result<Listing> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("cannot read the folder {}", dir.display()))?;
    let refs_here = std::fs::canonicalize(refs).ok() == std::fs::canonicalize(dir).ok();
    let mut listing = Listing { scenes: Vec::new(), notes: Vec::new() };
    let mut sidecars = Vec::new();
    for entry in entries {
        let path = entry.with_context(|| format!("cannot read the folder {}", dir.display()))?.path();
        let file = path.file_name().unwrap_or_default();
        let bytes = file.as_encoded_bytes();
        let shown = super::escape_os(file);
        if bytes.ends_with(b".test.toml") {
            sidecars.push((path.clone(), shown));
        } else if bytes.ends_with(b".toml") || is_gltf_name(bytes) {
            let problem = match std::fs::metadata(&path) {
                Ok(m) if m.is_file() => None,
                Ok(m) => Some(format!(
                    "{}: is {}, not a regular file (expected a scene file)",
                    path.display(),
                    super::golden_case::file_kind(m.file_type())
                )),
                Err(_) if std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_symlink()) => {
                    Some(format!("{}: is a symlink to nothing (expected a scene file)", path.display()))
                }
                Err(e) => Some(format!("{}: cannot read: {e}", path.display())),
            };
            listing.scenes.push((path, problem));
        } else {
            let lower = String::from_utf8_lossy(bytes).to_lowercase();
            if lower.ends_with(".toml") {
                listing.notes.push(format!("{shown}: not tested (scenes end in `.toml`, in lower case)"));
            }
        }
    }
    listing.scenes.sort();
    shared_names(&mut listing.scenes, refs);
    // A `*.test.toml` in DIR is a sidecar only when DIR is the references folder and its scene is
    // here; any other is said, not silently passed over.
    for (path, shown) in sidecars {
        let stem = path.file_name().unwrap_or_default().as_encoded_bytes();
        let stem = &stem[..stem.len() - b".test.toml".len()];
        let has_scene =
            listing.scenes.iter().any(|(s, _)| s.file_stem().is_some_and(|x| x.as_encoded_bytes() == stem));
        if !(refs_here && has_scene) {
            listing.notes.push(format!(
                "{shown}: not tested (a `.test.toml` file is a sidecar, not a scene; {})",
                if refs_here {
                    "no scene of this name is here"
                } else {
                    "sidecars go in the references folder"
                }
            ));
        }
    }
    listing.notes.sort();
    if listing.scenes.is_empty() {
        bail!("{}: no scene files (*.toml, *.gltf, *.glb)", dir.display());
    }
    Ok(listing)
}

/// A file name ending in `.gltf` or `.glb`, in any case (as `scene::gltf::is_gltf` reads it).
fn is_gltf_name(name: &[u8]) -> bool {
    let ends = |suffix: &[u8]| {
        name.len() > suffix.len() && name[name.len() - suffix.len()..].eq_ignore_ascii_case(suffix)
    };
    ends(b".gltf") || ends(b".glb")
}

/// Scenes whose file stems are equal (`level.toml`, `level.glb`, `level.gltf`) would share their
/// references and sidecar: each is an error naming the others, rather than one silently tested
/// against the other's images.
fn shared_names(scenes: &mut [(PathBuf, Option<String>)], refs: &Path) {
    let stems: Vec<std::ffi::OsString> =
        scenes.iter().map(|(p, _)| p.file_stem().unwrap_or_default().to_os_string()).collect();
    let names: Vec<String> =
        scenes.iter().map(|(p, _)| super::escape_os(p.file_name().unwrap_or_default())).collect();
    for (i, (path, problem)) in scenes.iter_mut().enumerate() {
        let others: Vec<&str> =
            (0..stems.len()).filter(|&j| j != i && stems[j] == stems[i]).map(|j| names[j].as_str()).collect();
        if others.is_empty() || problem.is_some() {
            continue;
        }
        let png = refs.join(super::golden_case::with_suffix(&stems[i], ".png"));
        *problem = Some(format!(
            "{}: shares its name with {} (expected one scene per name: both would be compared with {} and read the sidecar {}; rename one)",
            path.display(),
            others.join(", "),
            png.display(),
            refs.join(super::golden_case::with_suffix(&stems[i], ".test.toml")).display(),
        ));
    }
}

pub fn run(args: TestArgs) -> anyhow::Result<ExitCode> {
    // File names reach the terminal only escaped.
    run_escaped(args).map_err(super::escaped_error)
}

/// The render and heat map `--out` keeps for a reference that differs: `OUT/FILE` and
/// `OUT/STEM.heat.png`.
fn out_files(out: &Path, reference: &Path) -> (PathBuf, PathBuf) {
    let file = reference.file_name().unwrap_or_default();
    let stem = reference.file_stem().unwrap_or_default();
    (out.join(file), out.join(super::golden_case::with_suffix(stem, ".heat.png")))
}

/// Refuses, before the GPU starts, outputs that would replace an input or a special file: the
/// JUnit report, every file `--out` may write, and with `--bless` every reference. Inputs are
/// the scenes and the files they read, the sidecars, and (when not blessing) the references.
fn check_outputs(cases: &[Case], args: &TestArgs) -> anyhow::Result<()> {
    let mut inputs: Vec<PathBuf> = Vec::new();
    let mut outputs: Vec<PathBuf> = Vec::new();
    for case in cases {
        match &case.loaded {
            Some(Ok(scene)) => inputs.extend(super::scene_inputs(&case.scene, scene)),
            _ => inputs.push(case.scene.clone()),
        }
        inputs.push(case.sidecar_path.clone());
        let runs = matches!(case.loaded, Some(Ok(_)));
        if args.bless && runs {
            outputs.extend(case.references());
            continue;
        }
        inputs.extend(case.references());
        if let (Some(out), false) = (&args.out, args.bless) {
            for reference in case.references() {
                let (render, heat) = out_files(out, &reference);
                outputs.extend([render, heat]);
            }
        }
    }
    outputs.extend(args.junit.iter().cloned());
    let outputs: Vec<&Path> = outputs.iter().map(PathBuf::as_path).collect();
    super::check_outputs(&outputs, &inputs)
}

fn run_escaped(args: TestArgs) -> anyhow::Result<ExitCode> {
    let refs = args.refs.clone().unwrap_or_else(|| args.dir.join("references"));
    let budget = PixelBudget { max_pixels: args.max_pixels };
    let listing = scenes(&args.dir, &refs)?;
    for note in &listing.notes {
        eprintln!("hadou test: {note}");
    }
    let mut cases: Vec<Case> = Vec::new();
    for (scene, problem) in listing.scenes {
        let mut case = Case::new(scene, &refs);
        if let Some(why) = problem {
            case.outcome = Outcome::Error(why);
        }
        cases.push(case);
    }
    // Sidecars first: a malformed one is an error before the GPU starts.
    for case in cases.iter_mut().filter(|c| matches!(c.outcome, Outcome::NotRun)) {
        case.sidecar = Sidecar::read(&case.sidecar_path)?;
    }
    // Then the scenes (what they read are inputs no output may replace).
    for case in cases.iter_mut().filter(|c| matches!(c.outcome, Outcome::NotRun)) {
        if case.sidecar.skip.is_none() {
            case.loaded = Some(hadou::scene::load_scene(&case.scene).map_err(|e| format!("{e:#}")));
        }
    }
    check_outputs(&cases, &args)?;
    let mut runtime: Option<Runtime> = None;
    let mut blessed = OutputSet::default();
    let mut blessed_paths: Vec<PathBuf> = Vec::new();
    let started = Instant::now();
    for case in &mut cases {
        if !matches!(case.outcome, Outcome::NotRun) {
            continue;
        }
        if let Some(why) = case.sidecar.skip.clone() {
            case.outcome = Outcome::Skipped(why);
            continue;
        }
        let t = Instant::now();
        let scene = match case.loaded.take() {
            Some(Ok(scene)) => scene,
            Some(Err(e)) => {
                case.outcome = Outcome::Error(e);
                continue;
            }
            None => bail!("{}: the scene was not loaded", case.scene.display()),
        };
        if runtime.is_none() {
            runtime = Some(Runtime::new(&RuntimeOptions::from_env())?);
        }
        let rt = runtime.as_mut().context("no runtime")?;
        let mut ctx = Run { args: &args, budget: &budget, blessed: &mut blessed, paths: &mut blessed_paths };
        case.outcome = match run_case(rt, case, scene, &mut ctx) {
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
        // All or none: a rename that fails midway puts back those done before it.
        super::bless::commit(blessed, &blessed_paths)?;
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

/// What every scene of a run shares.
struct Run<'a> {
    args: &'a TestArgs,
    budget: &'a PixelBudget,
    blessed: &'a mut OutputSet,
    paths: &'a mut Vec<PathBuf>,
}

/// Renders one scene and compares (or stages its references).
fn run_case(
    rt: &mut Runtime,
    case: &Case,
    scene: hadou::scene::Scene,
    ctx: &mut Run,
) -> anyhow::Result<Outcome> {
    let (width, height) = match &case.sidecar.size {
        Some(size) => {
            super::parse_size(size).with_context(|| format!("{}: size", case.sidecar_path.display()))?
        }
        None => (scene.render.width, scene.render.height),
    };
    // Where the size came from, for errors it causes.
    let size_from = match case.sidecar.size {
        Some(_) => format!("{}: size", case.sidecar_path.display()),
        None => format!("{}: [render] size", case.scene.display()),
    };
    // A render the comparison could not decode is refused before it is made.
    ctx.budget.check(width as u64, height as u64).map_err(|e| anyhow::anyhow!("{size_from}: {e}"))?;
    let aovs = case.sidecar.aovs()?;
    let before = rt.validation_counts();
    rt.load_scene(scene)?;
    let request = FrameRequest { width, height, time: case.sidecar.time, color: true, aovs: aovs.clone() };
    let frame = rt.render(&request).map_err(|e| match e {
        // The sidecar asked for it: name the sidecar's key.
        hadou::Error::NotProduced { .. } => anyhow::anyhow!("{}: aovs: {e}", case.sidecar_path.display()),
        e => anyhow::Error::from(e),
    })?;
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
    if ctx.args.bless {
        for (path, bytes) in &rendered {
            ctx.blessed.stage(path, bytes)?;
            ctx.paths.push(path.clone());
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
        let want = load_with(reference, ctx.budget)?;
        let got = decode_with(&label, bytes, ctx.budget)?;
        let file = reference.file_name().unwrap_or_default().to_string_lossy().to_string();
        let c = match compare_loaded((reference, &want), (&label, &got), &case.sidecar.tolerance) {
            Ok(c) => c,
            // The render no longer has the reference's size or channels: it differs (a failure,
            // with the render kept for the artifacts), not a run that could not judge.
            Err(hadou::compare::CompareError::Mismatch { message, .. }) => {
                problems.push(format!("{file}: {message} ({size_from}: {width}x{height})"));
                if let Some(out) = &ctx.args.out {
                    output::write_atomically(&out_files(out, reference).0, bytes)?;
                }
                continue;
            }
            Err(e) => {
                return Err(e)
                    .with_context(|| format!("{size_from} {width}x{height} against {}", reference.display()))
            }
        };
        details.push(format!("{file}: {}", short(&c)));
        if !c.same {
            problems.push(format!("{file}: {}", c.reasons.join("; ")));
            if let Some(out) = &ctx.args.out {
                write_failure(out, reference, bytes, &c)?;
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
fn write_failure(out: &Path, reference: &Path, bytes: &[u8], c: &Comparison) -> anyhow::Result<()> {
    let (render, heat) = out_files(out, reference);
    output::write_atomically(&render, bytes)?;
    super::compare::write_heatmap(&heat, c)
}
