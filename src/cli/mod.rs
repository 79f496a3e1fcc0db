//! Command-line parsing and dispatch.

mod bake;
mod bless;
mod compare;
mod golden;
mod golden_case;
mod profile;
mod profile_ab;
mod profile_diff;
mod progress;
mod render;
mod report;
mod view;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(name = "hadou", version, about = "Game-effect runtime on Vulkan: render and profile scenes")]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render one frame of a scene to PNG, plus AOVs as OpenEXR.
    Render(render::RenderArgs),
    /// Time a scene's passes over many frames.
    Profile(profile::ProfileArgs),
    /// List the Vulkan devices and which one hadou would use.
    Devices,
    /// Bake thickness LUTs (translucency, seed 003) for an OBJ or a scene's translucent meshes.
    Bake(bake::BakeArgs),
    /// Speed against error for every effect, measured on this device: report.md, CSV, PNG plots.
    Report(report::ReportArgs),
    /// Open a window on a scene: orbit/fly camera, pass toggles, hot reload, screenshots.
    View(view::ViewArgs),
    /// Compare two PNGs (FLIP) or OpenEXRs (abs/rel error): exit 0 same, 1 different, 2 error.
    Compare(compare::CompareArgs),
    /// Render every scene of a folder and compare with stored references (golden images).
    Test(golden::TestArgs),
    /// Compare two `profile --json` files per pass, noise-aware: exit 1 on a regression.
    ProfileDiff(profile_diff::ProfileDiffArgs),
}

impl Cli {
    /// The exit code of an error: 2 for the commands whose 1 means "different", else 1.
    pub fn error_code(&self) -> ExitCode {
        match self.command {
            Command::Compare(_) | Command::Test(_) | Command::ProfileDiff(_) => ExitCode::from(2),
            Command::Profile(ref p) if p.is_ab() => ExitCode::from(2),
            _ => ExitCode::FAILURE,
        }
    }
}

/// Runs the command; `Ok` carries its exit code (compare, test and profile-diff say 1 for
/// "different").
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Render(args) => render::run(args).map(|()| ExitCode::SUCCESS),
        Command::Profile(args) => profile::run(args),
        Command::Bake(args) => bake::run(args).map(|()| ExitCode::SUCCESS),
        Command::Report(args) => report::run(args).map(|()| ExitCode::SUCCESS),
        Command::View(args) => view::run(args).map(|()| ExitCode::SUCCESS),
        Command::Compare(args) => compare::run(args),
        Command::Test(args) => golden::run(args),
        Command::ProfileDiff(args) => profile_diff::run(args),
        Command::Devices => {
            let runtime = hadou::Runtime::new(&hadou::RuntimeOptions::from_env())?;
            let info = runtime.device_info();
            println!("{} ({}), Vulkan {}, driver {}", info.name, info.kind, info.api_version, info.driver);
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// Parses `WxH`.
fn parse_size(text: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = text.split_once(['x', 'X']).context("expected WIDTHxHEIGHT, e.g. 512x512")?;
    let w: u32 = w.trim().parse().with_context(|| format!("width `{w}` is not a positive integer"))?;
    let h: u32 = h.trim().parse().with_context(|| format!("height `{h}` is not a positive integer"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        bail!("size {w}x{h}: each side must be in 1..=16384");
    }
    Ok((w, h))
}

/// Loads the scene and picks the size: `--size` or the scene's `[render] size`.
fn load(scene: &Path, size: Option<&str>) -> anyhow::Result<(hadou::scene::Scene, (u32, u32))> {
    let size = size.map(parse_size).transpose().context("--size")?;
    let scene = hadou::builtin::load(scene)?;
    let size = size.unwrap_or((scene.render.width, scene.render.height));
    Ok((scene, size))
}

/// The files a scene command reads: the scene, its OBJ meshes, its glTF files and their buffer
/// files (outputs may not replace them).
pub(crate) fn scene_inputs(path: &Path, scene: &hadou::scene::Scene) -> Vec<PathBuf> {
    use hadou::scene::mesh::MeshSpec;
    let mut inputs = vec![path.to_path_buf()];
    let mut gltf_files: Vec<&Path> = Vec::new();
    for m in &scene.meshes {
        match &m.spec {
            MeshSpec::Obj { path } => inputs.push(path.clone()),
            MeshSpec::Gltf { path, .. } if !gltf_files.contains(&path.as_path()) => {
                gltf_files.push(path);
                inputs.extend(hadou::scene::gltf::referenced_files(path));
            }
            _ => {}
        }
    }
    inputs
}

/// Refuses, before any work, outputs that are not regular files, that name an input or each
/// other, or whose folder takes no new file (see `hadou::output`).
fn check_outputs(outputs: &[&Path], inputs: &[PathBuf]) -> anyhow::Result<()> {
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    Ok(hadou::output::check_outputs(outputs, &inputs)?)
}

/// Destroys the runtime and fails when validation (on with `HADOU_VALIDATION=1`) reported any
/// error or warning, objects still alive at vkDestroyDevice included. Called before any output
/// is committed, so a run the layer objects to writes nothing.
fn finish_validated(runtime: hadou::Runtime) -> anyhow::Result<()> {
    let log = runtime.validation_log();
    drop(runtime);
    let counts = log.counts();
    if counts.errors > 0 || counts.warnings > 0 {
        bail!(
            "validation reported {} errors and {} warnings; nothing written:\n{}",
            counts.errors,
            counts.warnings,
            log.messages().join("\n")
        );
    }
    Ok(())
}

/// `text` with what a terminal would act on written out instead: control characters (C0, DEL,
/// C1: escape sequences, carriage returns) and the bidirectional overrides that reorder what
/// follows them, each as `\u{…}`. For file names and messages naming them (a scene may be called
/// `\x1b]0;…\x07.toml`).
pub(crate) fn escape_controls(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}') {
            out.push_str(&format!("\\u{{{:x}}}", c as u32));
        } else {
            out.push(c);
        }
    }
    out
}

/// A file name as text: its UTF-8 parts through `escape_controls`, any other byte as `\xNN`.
pub(crate) fn escape_os(name: &std::ffi::OsStr) -> String {
    let mut out = String::new();
    for chunk in name.as_encoded_bytes().utf8_chunks() {
        out += &escape_controls(chunk.valid());
        for b in chunk.invalid() {
            out += &format!("\\x{b:02x}");
        }
    }
    out
}

/// The error and its causes joined by ": ", as `{:#}` does, but a cause whose text the message
/// already ends with is left out: errors that print their source (e.g. an io::Error) would
/// otherwise state the OS text twice. What `main` prints after `error: `.
pub(crate) fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.ends_with(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

/// The error as `message` gives it, control characters escaped: a file name cannot write to the
/// terminal.
pub(crate) fn escaped_error(e: anyhow::Error) -> anyhow::Error {
    anyhow::Error::msg(escape_controls(&message(&e)))
}

/// Parses `--max-pixels`: a whole number ≥ 1.
fn parse_max_pixels(text: &str) -> Result<u64, String> {
    match text.trim().replace('_', "").parse::<u64>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("`{text}`: expected a whole number of pixels ≥ 1, e.g. 16777216")),
    }
}

#[cfg(test)]
mod escape_tests {
    use super::*;

    #[test]
    fn control_characters_and_odd_bytes_are_written_out() {
        assert_eq!(
            escape_controls("a\x1b[31mb\u{9b}c\r\u{202e}d é"),
            "a\\u{1b}[31mb\\u{9b}c\\u{d}\\u{202e}d é"
        );
        use std::os::unix::ffi::OsStrExt;
        let name = std::ffi::OsStr::from_bytes(b"x\xff\x07.toml");
        assert_eq!(escape_os(name), "x\\xff\\u{7}.toml");
        let e = escaped_error(anyhow::anyhow!("in\x1bner").context("out\x07er"));
        assert_eq!(e.to_string(), "out\\u{7}er: in\\u{1b}ner");
    }
}
