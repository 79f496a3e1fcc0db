//! `hadou render SCENE -o out.png [--size WxH] [--time T] [--aov NAME=FILE.exr …]`

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::Args;
use hadou::output::{self, OutputSet};
use hadou::{Aov, FrameRequest, Runtime, RuntimeOptions};

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file: TOML or a glTF 2.0 .gltf/.glb (see docs/scene-format.md), or `builtin:NAME`.
    scene: PathBuf,
    /// Output PNG (sRGB).
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    /// Image size WIDTHxHEIGHT (default: the scene's [render] size).
    #[arg(long)]
    size: Option<String>,
    /// Scene time in seconds.
    #[arg(long, default_value_t = 0.0)]
    time: f64,
    /// AOV to write as f32 OpenEXR: NAME=FILE.exr (depth, hdr, normal, energy, thickness).
    #[arg(long = "aov", value_name = "NAME=FILE.exr")]
    aovs: Vec<String>,
}

/// An AOV is written as OpenEXR only, and its file must say so: `--aov depth=d.png` is refused
/// rather than written as OpenEXR under a PNG name (which every image viewer would misread) or
/// squeezed into a PNG (AOVs are linear f32 values, `+inf` for the sky's depth and negative normal
/// components included, which 8 or 16 unsigned bits cannot hold). Checked after the outputs'
/// own checks, so a path that is a device or an input is refused for that first.
fn check_exr_name(aov: Aov, path: &Path) -> anyhow::Result<()> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        return Ok(());
    }
    bail!(
        "--aov {}={}: AOVs are written as f32 OpenEXR only (expected a file name ending in `.exr`, e.g. {}={})",
        aov.name(),
        path.display(),
        aov.name(),
        path.with_extension("exr").display()
    )
}

/// The colour image is an 8-bit sRGB PNG, and its file must say so: `-o out.exr` is refused
/// rather than a PNG written under an OpenEXR name (linear HDR colour is the `hdr` AOV).
fn check_png_name(path: &Path) -> anyhow::Result<()> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        return Ok(());
    }
    bail!(
        "-o {}: the colour image is written as an 8-bit sRGB PNG only (expected a file name ending in \
         `.png`, e.g. {}; linear HDR colour is the hdr AOV: --aov hdr=FILE.exr)",
        path.display(),
        path.with_extension("png").display()
    )
}

fn parse_aov(text: &str) -> anyhow::Result<(Aov, PathBuf)> {
    let (name, file) = text.split_once('=').context("expected NAME=FILE.exr")?;
    let Some(aov) = Aov::from_name(name) else {
        let names: Vec<_> = Aov::ALL.iter().chain(&Aov::UPSCALER).map(|a| a.name()).collect();
        bail!("unknown AOV `{name}` (expected one of: {})", names.join(", "));
    };
    if file.is_empty() {
        bail!("AOV `{name}` needs a file name after `=`");
    }
    Ok((aov, PathBuf::from(file)))
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    // Everything that can be checked is checked before the GPU starts or any file is written.
    if !args.time.is_finite() {
        bail!("--time must be a finite number of seconds, got {}", args.time);
    }
    let aovs = args
        .aovs
        .iter()
        .map(|a| parse_aov(a).with_context(|| format!("--aov {a}")))
        .collect::<Result<Vec<_>, _>>()?;
    let (scene, (width, height)) = super::load(&args.scene, args.size.as_deref())?;
    let outputs: Vec<&Path> =
        std::iter::once(args.output.as_path()).chain(aovs.iter().map(|(_, p)| p.as_path())).collect();
    super::check_outputs(&outputs, &super::scene_inputs(&args.scene, &scene))?;
    check_png_name(&args.output)?;
    for (aov, path) in &aovs {
        check_exr_name(*aov, path)?;
    }
    let progress = super::progress::spinner("render");
    progress.set_message("building the passes (a translucent mesh bakes its table once)");
    let mut runtime = Runtime::new(&RuntimeOptions::from_env())?;
    runtime.load_scene(scene)?;
    progress.set_message("rendering");
    let request = FrameRequest {
        width,
        height,
        time: args.time,
        color: true,
        aovs: aovs.iter().map(|(a, _)| *a).collect(),
    };
    let frame = runtime.render(&request)?;
    progress.finish_and_clear();
    let color = frame.color.as_deref().context("the frame returned no colour")?;
    // All outputs or none: a failed write replaces nothing.
    let mut set = OutputSet::default();
    set.stage(&args.output, &output::encode_png(&args.output, width, height, color)?)?;
    for (aov, path) in &aovs {
        let image = frame.aov(*aov).context("the frame returned no AOV")?;
        set.stage(path, &output::encode_exr(path, aov.name(), image)?)?;
    }
    super::finish_validated(runtime)?;
    set.commit()?;
    let mut wrote = vec![format!("{} ({width}x{height} PNG)", args.output.display())];
    wrote.extend(aovs.iter().map(|(aov, path)| format!("{} ({} AOV, OpenEXR)", path.display(), aov.name())));
    println!("wrote {}", super::escape_controls(&wrote.join(", ")));
    // One frame of a fresh runtime: its GPU times include compiling each pass's pipelines (lavapipe
    // JIT-compiles shaders at first use, about a second for the metaballs), not what a pass costs
    // a frame; `hadou profile` renders warm-up frames first and measures warm ones.
    let passes: Vec<String> =
        frame.stats.passes.iter().map(|p| format!("{} {:.3} ms", p.name, p.gpu_ms)).collect();
    println!(
        "gpu, first frame including pipeline compilation (warm frames: hadou profile): {}",
        passes.join(", ")
    );
    // What the passes counted on the device (metaballs.dropped, peel.overflowed_texels, ...).
    let counters: Vec<String> = frame.stats.counters.iter().map(|(n, v)| format!("{n} {v}")).collect();
    if !counters.is_empty() {
        println!("counters: {}", counters.join(", "));
    }
    Ok(())
}
