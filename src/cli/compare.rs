//! `hadou compare A B [--threshold NAME=VALUE …] [--heatmap FILE.png]`: exit 0 when the images
//! are the same within tolerance, 1 when they differ, 2 on an error (see `hadou::compare`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use hadou::compare::{compare_files_with, PixelBudget, Tolerance, DEFAULT_MAX_PIXELS};

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Reference image (PNG or OpenEXR).
    a: PathBuf,
    /// Image compared with it (same format, size and channels).
    b: PathBuf,
    /// NAME=VALUE, repeatable: flip (mean FLIP of a PNG, 0..1), abs and rel (EXR value errors;
    /// a value fails only when both are exceeded), pixels (fraction of EXR pixels that may
    /// fail). VALUE may end in %. Every threshold not given is 0 (bit-exact).
    #[arg(long = "threshold", value_name = "NAME=VALUE")]
    thresholds: Vec<String>,
    /// Write the per-pixel difference as a PNG: FLIP for PNGs, relative error (clamped to 1;
    /// NaN and infinity mismatches at 1) for EXRs, through the magma colour map.
    #[arg(long, value_name = "FILE.png")]
    heatmap: Option<PathBuf>,
    /// The largest image decoded, in pixels (width × height), checked from each file's header
    /// before decoding; larger is an error (exit 2).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_PIXELS, value_parser = super::parse_max_pixels)]
    max_pixels: u64,
}

/// Parses repeated `--threshold NAME=VALUE` into a tolerance.
pub fn tolerance(thresholds: &[String]) -> anyhow::Result<Tolerance> {
    let mut tol = Tolerance::default();
    for t in thresholds {
        tol.set(t).map_err(anyhow::Error::msg).context("--threshold")?;
    }
    Ok(tol)
}

pub fn run(args: CompareArgs) -> anyhow::Result<ExitCode> {
    // File names reach the terminal only escaped.
    run_escaped(args).map_err(super::escaped_error)
}

fn run_escaped(args: CompareArgs) -> anyhow::Result<ExitCode> {
    let tol = tolerance(&args.thresholds)?;
    if let Some(heat) = &args.heatmap {
        super::check_outputs(&[heat.as_path()], &[args.a.clone(), args.b.clone()])?;
    }
    let budget = PixelBudget { max_pixels: args.max_pixels };
    let result = compare_files_with(&args.a, &args.b, &tol, &budget)?;
    if let Some(heat) = &args.heatmap {
        write_heatmap(heat, &result)?;
    }
    println!("{}", super::escape_controls(&result.summary(&args.a, &args.b)));
    Ok(if result.same { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

/// Writes a comparison's heat map (RGB8) as an RGBA PNG, atomically.
pub fn write_heatmap(path: &Path, c: &hadou::compare::Comparison) -> anyhow::Result<()> {
    let rgba: Vec<u8> = c.heatmap.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect();
    hadou::output::write_png(path, c.width, c.height, &rgba)?;
    Ok(())
}
