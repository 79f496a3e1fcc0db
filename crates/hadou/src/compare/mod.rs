//! `hadou compare`: whether two images differ beyond a tolerance, and where.
//!
//! - PNG (tonemapped colour): FLIP (NVIDIA's perceptual difference, through the `nv-flip` crate)
//!   on RGB, its mean gated by `flip`; alpha, if either file has it, compared as an absolute
//!   difference in 0..1 (a missing alpha is opaque: an RGBA file and the same picture saved as RGB
//!   are the same; grey is compared as RGB).
//! - OpenEXR (AOVs, any layers and channels): per value absolute error |a − b| and relative
//!   error |a − b| / max(|a|, |b|). A value fails when both exceed their thresholds (either one
//!   within tolerance is enough, as numpy's `allclose`); +inf = +inf and −inf = −inf are equal,
//!   an infinity against anything else fails, and a NaN in either file fails the comparison.
//!   The images differ when more than `pixels` (a fraction) of the pixels fail, or on any NaN.
//!
//! A size mismatch, a PNG against an OpenEXR, EXR channels that differ and an unreadable file are
//! errors, not differences, and so is an image larger than the pixel budget
//! ([`DEFAULT_MAX_PIXELS`]), found from its header before anything is decoded.

mod hdr;
mod ldr;
mod load;

use std::path::{Path, PathBuf};

pub use load::{
    decode, decode_with, load, load_with, Channel, HdrImage, LdrImage, Loaded, PixelBudget,
    DEFAULT_MAX_PIXELS,
};

/// The tolerances of one comparison; every default is 0 (bit-exact).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerance {
    /// Largest mean FLIP (0..1) of a PNG pair.
    #[serde(default)]
    pub flip: f64,
    /// Absolute error an EXR value (or a PNG alpha, in 0..1) may have.
    #[serde(default)]
    pub abs: f64,
    /// Relative error an EXR value may have.
    #[serde(default)]
    pub rel: f64,
    /// Fraction of EXR pixels that may fail.
    #[serde(default)]
    pub pixels: f64,
}

impl Tolerance {
    /// Sets one threshold from `NAME=VALUE` (flip, abs, rel, pixels; VALUE may end in `%`).
    pub fn set(&mut self, text: &str) -> Result<(), String> {
        let (name, value) =
            text.split_once('=').ok_or_else(|| format!("`{text}`: expected NAME=VALUE, e.g. flip=0.01"))?;
        let value = parse_fraction(value).map_err(|e| format!("`{text}`: {e}"))?;
        match name.trim() {
            "flip" => self.flip = value,
            "abs" => self.abs = value,
            "rel" => self.rel = value,
            "pixels" => self.pixels = value,
            other => return Err(format!("unknown metric `{other}` (expected flip, abs, rel or pixels)")),
        }
        Ok(())
    }

    /// Checks every threshold is a finite number ≥ 0.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [("flip", self.flip), ("abs", self.abs), ("rel", self.rel), ("pixels", self.pixels)]
        {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("threshold {name} = {v}: expected a finite number ≥ 0"));
            }
        }
        Ok(())
    }
}

/// `0.05` or `5%`.
pub fn parse_fraction(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let (number, scale) = match t.strip_suffix('%') {
        Some(n) => (n, 0.01),
        None => (t, 1.0),
    };
    let v: f64 = number.trim().parse().map_err(|_| format!("`{t}` is not a number (e.g. 0.05 or 5%)"))?;
    if !(v.is_finite() && v >= 0.0) {
        return Err(format!("`{t}`: expected a finite number ≥ 0"));
    }
    Ok(v * scale)
}

/// What a comparison found.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Whether the pair is within tolerance.
    pub same: bool,
    /// The measurements, as `name value` pairs in print order.
    pub metrics: Vec<(&'static str, f64)>,
    /// Why it differs (empty when the same).
    pub reasons: Vec<String>,
    /// The per-pixel difference as RGB8 (magma colour map), width × height.
    pub heatmap: Vec<u8>,
    /// Width of the images.
    pub width: u32,
    /// Height of the images.
    pub height: u32,
}

impl Comparison {
    /// One line: verdict, the files, the metrics and why.
    pub fn summary(&self, a: &Path, b: &Path) -> String {
        let verdict = if self.same { "same" } else { "different" };
        let metrics: Vec<String> = self.metrics.iter().map(|(k, v)| format!("{k} {}", fmt(*v))).collect();
        let mut line = format!("{verdict}: {} vs {}: {}", a.display(), b.display(), metrics.join(", "));
        if !self.reasons.is_empty() {
            line += &format!(" ({})", self.reasons.join("; "));
        }
        line
    }

    /// The value of metric `name`.
    pub fn metric(&self, name: &str) -> Option<f64> {
        self.metrics.iter().find(|(k, _)| *k == name).map(|(_, v)| *v)
    }
}

fn fmt(v: f64) -> String {
    if v == 0.0 || v.fract() == 0.0 && v.abs() < 1e9 {
        format!("{v}")
    } else {
        format!("{v:.6e}")
    }
}

/// Why a comparison could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CompareError {
    /// A file that cannot be read or decoded.
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong, and what was expected.
        message: String,
    },
    /// Two readable files that cannot be compared (size, channels, format).
    #[error("{} and {}: {message}", a.display(), b.display())]
    Mismatch {
        /// The first file.
        a: PathBuf,
        /// The second file.
        b: PathBuf,
        /// What differs.
        message: String,
    },
}

/// Compares the images in files `a` and `b` (both PNG or both OpenEXR) within the default pixel
/// budget.
pub fn compare_files(a: &Path, b: &Path, tol: &Tolerance) -> Result<Comparison, CompareError> {
    compare_files_with(a, b, tol, &PixelBudget::default())
}

/// Compares the images in files `a` and `b`, each checked against `budget` before decoding.
pub fn compare_files_with(
    a: &Path,
    b: &Path,
    tol: &Tolerance,
    budget: &PixelBudget,
) -> Result<Comparison, CompareError> {
    compare_loaded((a, &load_with(a, budget)?), (b, &load_with(b, budget)?), tol)
}

/// Compares two decoded images; the paths name them in errors.
pub fn compare_loaded(
    a: (&Path, &Loaded),
    b: (&Path, &Loaded),
    tol: &Tolerance,
) -> Result<Comparison, CompareError> {
    let mismatch = |message: String| CompareError::Mismatch { a: a.0.into(), b: b.0.into(), message };
    match (a.1, b.1) {
        (Loaded::Ldr(x), Loaded::Ldr(y)) => ldr::compare(x, y, tol).map_err(mismatch),
        (Loaded::Hdr(x), Loaded::Hdr(y)) => hdr::compare(x, y, tol).map_err(mismatch),
        (x, y) => {
            Err(mismatch(format!("{} against {}: both must be PNG or both OpenEXR", x.kind(), y.kind())))
        }
    }
}

/// Maps values in 0..1 to RGB8 with FLIP's magma colour map.
fn magma(values: &[f32]) -> Vec<u8> {
    let lut = nv_flip::magma_lut().to_vec();
    let mut out = Vec::with_capacity(values.len() * 3);
    for v in values {
        let i = if v.is_finite() { (v.clamp(0.0, 1.0) * 255.0).round() as usize } else { 255 };
        out.extend_from_slice(&lut[i * 3..i * 3 + 3]);
    }
    out
}
