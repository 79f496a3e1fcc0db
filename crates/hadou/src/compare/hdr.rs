//! OpenEXR pairs: absolute and relative error per value, with the infinity and NaN rules of
//! the module documentation.

use super::load::HdrImage;
use super::{magma, Comparison, Tolerance};

/// How one pair of values compares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pair {
    /// Finite (or the same infinity): the absolute and relative error.
    Error {
        /// |a − b|.
        abs: f64,
        /// |a − b| / max(|a|, |b|); 0 when both are 0.
        rel: f64,
    },
    /// An infinity against a different value.
    InfMismatch,
    /// A NaN on either side.
    Nan,
}

/// Compares two values by the rules above.
pub fn pair(a: f32, b: f32) -> Pair {
    if a.is_nan() || b.is_nan() {
        return Pair::Nan;
    }
    if a.is_infinite() || b.is_infinite() {
        return if a == b { Pair::Error { abs: 0.0, rel: 0.0 } } else { Pair::InfMismatch };
    }
    let (a, b) = (a as f64, b as f64);
    let abs = (a - b).abs();
    let scale = a.abs().max(b.abs());
    Pair::Error { abs, rel: if scale == 0.0 { 0.0 } else { abs / scale } }
}

pub fn compare(a: &HdrImage, b: &HdrImage, tol: &Tolerance) -> Result<Comparison, String> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!("sizes differ: {}x{} and {}x{}", a.width, a.height, b.width, b.height));
    }
    let names = |i: &HdrImage| i.channels.iter().map(|c| c.name.clone()).collect::<Vec<_>>().join(", ");
    if names(a) != names(b) {
        return Err(format!("channels differ: [{}] and [{}]", names(a), names(b)));
    }
    let pixels = a.width as usize * a.height as usize;
    // Per pixel: the worst relative error over its channels (the heat map), and whether it fails.
    let mut heat = vec![0.0f32; pixels];
    let mut failed = vec![false; pixels];
    let (mut max_abs, mut max_rel, mut nans, mut infs) = (0.0f64, 0.0f64, 0usize, 0usize);
    for (ca, cb) in a.channels.iter().zip(&b.channels) {
        if ca.values.len() != pixels || cb.values.len() != pixels {
            return Err(format!(
                "channel {} is subsampled; only full-resolution channels are compared",
                ca.name
            ));
        }
        for (i, (&x, &y)) in ca.values.iter().zip(&cb.values).enumerate() {
            match pair(x, y) {
                Pair::Error { abs, rel } => {
                    max_abs = max_abs.max(abs);
                    max_rel = max_rel.max(rel);
                    heat[i] = heat[i].max(rel.min(1.0) as f32);
                    failed[i] |= abs > tol.abs && rel > tol.rel;
                }
                Pair::InfMismatch => {
                    infs += 1;
                    heat[i] = 1.0;
                    failed[i] = true;
                }
                Pair::Nan => {
                    nans += 1;
                    heat[i] = 1.0;
                    failed[i] = true;
                }
            }
        }
    }
    let failing = failed.iter().filter(|&&f| f).count();
    let fraction = failing as f64 / pixels.max(1) as f64;
    let mut reasons = Vec::new();
    if nans > 0 {
        reasons.push(format!("{nans} NaN values (a NaN always fails)"));
    }
    if fraction > tol.pixels {
        reasons.push(format!(
            "{failing} of {pixels} pixels outside abs {} / rel {} (fraction {fraction:.6} > pixels threshold {})",
            tol.abs, tol.rel, tol.pixels
        ));
    }
    Ok(Comparison {
        same: reasons.is_empty(),
        metrics: vec![
            ("abs_max", max_abs),
            ("rel_max", max_rel),
            ("pixels_failing", failing as f64),
            ("inf_mismatches", infs as f64),
            ("nans", nans as f64),
        ],
        reasons,
        heatmap: magma(&heat),
        width: a.width,
        height: a.height,
    })
}
