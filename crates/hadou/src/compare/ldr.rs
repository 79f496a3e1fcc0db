//! PNG pairs: FLIP on RGB (sRGB, 67 pixels per degree: FLIP's default viewing set-up), alpha as
//! an absolute difference. The two files may store the picture differently (RGBA and RGB, grey
//! and RGB, with or without alpha): both are compared as RGBA8, grey expanded to RGB and a missing
//! alpha taken as opaque, so an RGBA render and the same picture saved as RGB are the same image;
//! alpha counts only where either file has alpha that is not opaque.

use super::load::LdrImage;
use super::{magma, Comparison, Tolerance};

/// The FLIP error map of two RGB8 images of one size (row-major, 3 bytes a pixel).
pub fn flip_map(width: u32, height: u32, reference: &[u8], test: &[u8]) -> Vec<f32> {
    let r = nv_flip::FlipImageRgb8::with_data(width, height, reference);
    let t = nv_flip::FlipImageRgb8::with_data(width, height, test);
    nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec()
}

fn rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
}

pub fn compare(a: &LdrImage, b: &LdrImage, tol: &Tolerance) -> Result<Comparison, String> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!("sizes differ: {}x{} and {}x{}", a.width, a.height, b.width, b.height));
    }
    let map = flip_map(a.width, a.height, &rgb(&a.rgba), &rgb(&b.rgba));
    let n = map.len().max(1) as f64;
    let mean = map.iter().map(|&v| v as f64).sum::<f64>() / n;
    let max = map.iter().fold(0.0f32, |m, &v| m.max(v)) as f64;
    let differing = a.rgba.chunks_exact(4).zip(b.rgba.chunks_exact(4)).filter(|(p, q)| p != q).count();
    let alpha = a.rgba.iter().skip(3).step_by(4).zip(b.rgba.iter().skip(3).step_by(4));
    let alpha_abs = alpha.map(|(&x, &y)| x.abs_diff(y)).max().unwrap_or(0) as f64 / 255.0;
    let mut reasons = Vec::new();
    if mean > tol.flip {
        reasons.push(format!("mean FLIP {mean:.6} > threshold {}", tol.flip));
    }
    // A missing alpha reads as 255 (`LdrImage::rgba`): against an opaque RGBA image it is 0.
    let has_alpha = a.has_alpha || b.has_alpha;
    if has_alpha && alpha_abs > tol.abs {
        reasons.push(format!("alpha differs by {alpha_abs:.6} > abs threshold {}", tol.abs));
    }
    let mut metrics = vec![("flip_mean", mean), ("flip_max", max), ("pixels_differing", differing as f64)];
    if has_alpha {
        metrics.push(("alpha_abs", alpha_abs));
    }
    Ok(Comparison {
        same: reasons.is_empty(),
        metrics,
        reasons,
        heatmap: magma(&map),
        width: a.width,
        height: a.height,
    })
}
