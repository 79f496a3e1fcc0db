//! A rendered metaball frame against the f64 reference, per pixel: the one comparison the GPU
//! tests (tests/gpu_metaballs.rs), the benchmark and `hadou report` use.
//!
//! Per pixel the reference is the nearest exact hit over the scene's groups
//! ([`crate::effects::metaballs::cast`], Bézier clipping in f64, whatever method the group renders with) on the
//! pixel's ray from the near plane to the raster's own distance (t_max of the pass). Pixels where
//! some group's ray is in the tangency band ([`tangency`], see metaballs_f32.rs) are counted and
//! left out: there f32 may legitimately differ. Elsewhere a pixel is a GPU metaball hit when its
//! distance differs from the raster-only distance, and hit/miss, depth and normal are compared.

use glam::DVec3;

use super::metaballs::{cast, MetaballGroupParams};
use super::metaballs_f32::tangency;
use crate::aov::AovImage;
use crate::scene::Scene;

/// The images compared: all the same size.
#[derive(Clone, Copy, Debug)]
pub struct MetaballFrame<'a> {
    /// The frame's `depth` AOV (ray distance, +inf where nothing was hit).
    pub depth: &'a AovImage,
    /// The `depth` AOV of the same scene without its metaballs (and waves): the pass's t_max.
    pub raster_depth: &'a AovImage,
    /// The frame's `normal` AOV, if normals are to be compared.
    pub normal: Option<&'a AovImage>,
}

/// One hit/miss disagreement outside the band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mismatch {
    pub x: u32,
    pub y: u32,
    pub gpu_depth: f32,
    pub raster_depth: f32,
    /// The reference hit distance, `None` for a miss.
    pub reference: Option<f64>,
}

/// The comparison's counts and worst errors.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MetaballErrorStats {
    pub pixels: usize,
    /// Pixels the GPU shows a metaball on (band included, NaN depths not).
    pub gpu_hits: usize,
    /// Pixels the reference hits a metaball on.
    pub ref_hits: usize,
    /// Pixels in the tangency band of some group: left out of what follows.
    pub band: usize,
    /// Pixels with a NaN depth (never acceptable).
    pub nan_depth: usize,
    /// Hit/miss disagreements outside the band.
    pub mismatched: usize,
    /// `mismatched` in percent of the pixels outside the band.
    pub mismatch_percent: f64,
    /// |t_gpu − t_ref|/t_ref over the hits both agree on: the largest and the 99th percentile.
    pub depth_max_rel: f64,
    pub depth_p99_rel: f64,
    /// The largest angle between GPU and reference normals on those hits (0 without normals).
    pub normal_max_deg: f64,
    /// The first [`MAX_LISTED`] mismatches, for diagnostics.
    pub mismatches: Vec<Mismatch>,
}

/// Mismatches listed in [`MetaballErrorStats::mismatches`].
pub const MAX_LISTED: usize = 20;

/// What the reference says about one pixel's ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelReference {
    /// The nearest hit over the groups: world distance and normal.
    pub hit: Option<(f64, DVec3)>,
    /// Some group's ray is in the tangency band over [t_min, t_max].
    pub band: bool,
}

/// The nearest f64 metaball hit over `groups` on a world ray, and whether it is in the band.
pub fn pixel_reference(
    groups: &[MetaballGroupParams],
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
) -> PixelReference {
    let mut hit: Option<(f64, DVec3)> = None;
    let mut band = false;
    for g in groups {
        if let Some(h) = cast(g, o, d, t_min, t_max) {
            if hit.is_none_or(|(t, _)| h.t < t) {
                hit = Some((h.t, h.normal));
            }
        }
        band |= tangency(g, o, d, t_min, t_max).in_band();
    }
    PixelReference { hit, band }
}

/// Per-pixel outcome, gathered from the worker threads.
enum Outcome {
    Band { gpu_hit: bool, ref_hit: bool },
    Nan,
    Mismatch(Mismatch),
    Agree { gpu_hit: bool, ref_hit: bool, depth_rel: Option<f64>, normal_deg: f64 },
}

/// Compares `frame` (rendered from `scene` at `time`) with the f64 reference on every pixel.
/// Errors when the images differ in size or lack channels.
pub fn compare_metaballs(
    scene: &Scene,
    time: f64,
    frame: MetaballFrame,
) -> Result<MetaballErrorStats, String> {
    let (w, h) = (frame.depth.width, frame.depth.height);
    let same = |a: &AovImage| a.width == w && a.height == h;
    if !same(frame.raster_depth) || frame.normal.is_some_and(|n| !same(n) || n.channels < 3) {
        return Err(format!(
            "metaball comparison: the images must all be {w}×{h} (normals with 3+ channels)"
        ));
    }
    let groups: Vec<MetaballGroupParams> = scene.metaballs().iter().map(|g| g.at(time)).collect();
    let cam = &scene.camera;
    let forward = cam.basis().forward;
    let pixel = |x: u32, y: u32| -> Outcome {
        let i = (y * w + x) as usize;
        let (depth, raster) = (frame.depth.data[i], frame.raster_depth.data[i]);
        if depth.is_nan() {
            return Outcome::Nan;
        }
        let (o, d) = cam.pixel_ray(x, y, w, h);
        let t_min = cam.near / d.dot(forward);
        let t_max = (raster as f64).min(cam.far);
        let r = pixel_reference(&groups, o, d, t_min, t_max);
        let gpu_hit = depth.to_bits() != raster.to_bits();
        if r.band {
            return Outcome::Band { gpu_hit, ref_hit: r.hit.is_some() };
        }
        if gpu_hit != r.hit.is_some() {
            let reference = r.hit.map(|(t, _)| t);
            return Outcome::Mismatch(Mismatch { x, y, gpu_depth: depth, raster_depth: raster, reference });
        }
        let (mut depth_rel, mut normal_deg) = (None, 0.0);
        if let Some((t, n)) = r.hit {
            depth_rel = Some((depth as f64 - t).abs() / t);
            if let Some(normal) = frame.normal {
                // The pass writes the normal facing the camera.
                let n = if n.dot(d) > 0.0 { -n } else { n };
                let g = DVec3::new(
                    normal.at(x, y, 0) as f64,
                    normal.at(x, y, 1) as f64,
                    normal.at(x, y, 2) as f64,
                );
                normal_deg = g.normalize().dot(n.normalize()).clamp(-1.0, 1.0).acos().to_degrees();
                if normal_deg.is_nan() {
                    normal_deg = 180.0;
                }
            }
        }
        Outcome::Agree { gpu_hit, ref_hit: r.hit.is_some(), depth_rel, normal_deg }
    };
    // Rows split over the machine's threads (the reference dominates the cost).
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(h.max(1) as usize);
    let rows_per = (h as usize).div_ceil(threads).max(1);
    let outcomes: Vec<Vec<Outcome>> = std::thread::scope(|s| {
        let pixel = &pixel;
        let workers: Vec<_> = (0..h as usize)
            .step_by(rows_per)
            .map(|y0| {
                s.spawn(move || {
                    let y1 = (y0 + rows_per).min(h as usize) as u32;
                    (y0 as u32..y1).flat_map(|y| (0..w).map(move |x| pixel(x, y))).collect::<Vec<_>>()
                })
            })
            .collect();
        workers.into_iter().map(|t| t.join().expect("comparison worker")).collect()
    });
    let mut stats = MetaballErrorStats { pixels: (w * h) as usize, ..Default::default() };
    let mut depth_errors = Vec::new();
    for outcome in outcomes.into_iter().flatten() {
        match outcome {
            Outcome::Band { gpu_hit, ref_hit } => {
                stats.band += 1;
                stats.gpu_hits += usize::from(gpu_hit);
                stats.ref_hits += usize::from(ref_hit);
            }
            Outcome::Nan => stats.nan_depth += 1,
            Outcome::Mismatch(m) => {
                stats.mismatched += 1;
                stats.gpu_hits += usize::from(m.reference.is_none());
                stats.ref_hits += usize::from(m.reference.is_some());
                if stats.mismatches.len() < MAX_LISTED {
                    stats.mismatches.push(m);
                }
            }
            Outcome::Agree { gpu_hit, ref_hit, depth_rel, normal_deg } => {
                stats.gpu_hits += usize::from(gpu_hit);
                stats.ref_hits += usize::from(ref_hit);
                depth_errors.extend(depth_rel);
                // Never NaN here (a NaN angle was made 180° above), so nothing is dropped.
                if normal_deg > stats.normal_max_deg {
                    stats.normal_max_deg = normal_deg;
                }
            }
        }
    }
    let outside = stats.pixels - stats.band;
    stats.mismatch_percent = if outside > 0 { 100.0 * stats.mismatched as f64 / outside as f64 } else { 0.0 };
    depth_errors.sort_by(f64::total_cmp);
    stats.depth_max_rel = depth_errors.last().copied().unwrap_or(0.0);
    if !depth_errors.is_empty() {
        let k = (0.99 * depth_errors.len() as f64).ceil() as usize;
        stats.depth_p99_rel = depth_errors[k.clamp(1, depth_errors.len()) - 1];
    }
    Ok(stats)
}
