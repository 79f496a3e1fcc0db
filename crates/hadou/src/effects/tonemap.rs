//! CPU twin of shaders/tonemap.comp in f64: exposure, ACES filmic (Narkowicz 2015), sRGB encoding;
//! and the exposure itself: EV100, pre-exposure, and the automatic exposure measured from a frame
//! (shaders/exposure.comp). Definitions: Lagarde & de Rousiers, "Moving Frostbite to PBR" (2014),
//! §4.2 and §5.1; docs/scene-format.md, "Exposure and light units".

use glam::DVec3;

use crate::scene::model::{ExposureMode, Scene};

/// Exposed HDR values are clamped to this before the curve. `aces(x)` reaches 1 (and is clamped
/// there) from x ≈ 7.24 on (0.08x² − 0.56x − 0.14 ≥ 0), so clamping at 64 changes no output, while
/// it keeps the curve's x² (4096) far from f32's overflow: without it, x ≥ 1.8e19 (or +inf, an
/// RGBA16F value past 65504) gives inf/inf = NaN, and a lit surface turns black.
pub const ACES_WHITE: f64 = 64.0;

/// ACES filmic approximation, clamped to [0, 1].
pub fn aces(x: f64) -> f64 {
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// The sRGB transfer function (IEC 61966-2-1).
pub fn srgb_encode(c: f64) -> f64 {
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Exposure applied, NaN made 0, then clamped to [0, `ACES_WHITE`]: what reaches the curve. The
/// NaN test comes first because a clamp of NaN is undefined in GLSL.
pub fn exposed(linear: f64, exposure: f64) -> f64 {
    let c = linear * exposure;
    if c.is_nan() {
        0.0
    } else {
        c.clamp(0.0, ACES_WHITE)
    }
}

/// One linear HDR channel to its 8-bit sRGB code, as the GPU stores it (round to nearest). Safe
/// for any input: +inf and any huge finite value give 255, NaN gives 0.
pub fn tonemap_channel(linear: f64, exposure: f64) -> f64 {
    srgb_encode(aces(exposed(linear, exposure))) * 255.0
}

/// The exposure of a camera at `ev100` (EV at ISO 100): the luminance that saturates it is
/// L_max = 78/(S·q) · N²/t = 1.2 · 2^EV100 cd/m² (S = 100, q = 0.65), and exposure = 1 / L_max.
pub fn ev100_exposure(ev100: f64) -> f64 {
    1.0 / (1.2 * ev100.exp2())
}

/// The EV100 a reflected-light meter (K = 12.5) gives for an average luminance `avg` (cd/m²):
/// log2(avg · S / K), S = 100.
pub fn ev100_from_luminance(avg: f64) -> f64 {
    (avg * 100.0 / 12.5).log2()
}

/// The automatic exposure for a frame whose measured average luminance is 2^`log2_avg`:
/// `ev100_exposure(ev100_from_luminance(avg))` = 1 / (9.6 · avg).
pub fn auto_exposure(log2_avg: f64) -> f64 {
    ev100_exposure(log2_avg + 3.0)
}

/// Rec. 709 luminance weights (linear RGB → Y).
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// The measurement's histogram (shaders/exposure.comp): `HISTOGRAM_BINS` bins of log2 of the
/// pre-exposed luminance, 1/8 stop each, from `HISTOGRAM_LOG2_MIN` (lower values, zero and NaN
/// in the first bin, higher ones and +inf in the last).
pub const HISTOGRAM_BINS: usize = 256;
/// Lower end of the histogram, in log2 of the pre-exposed luminance (2⁻²⁰, below f16's normals).
pub const HISTOGRAM_LOG2_MIN: f64 = -20.0;
/// Bins per stop.
pub const HISTOGRAM_BINS_PER_STOP: f64 = 8.0;
/// The average is taken over the pixels between these fractions of the sorted luminances: the
/// darkest 80% (shadowed faces, a dark ground, a black sky) and the brightest 1.7% (highlights)
/// do not move the exposure, so a sunlit surface covering a fifth of what is measured is exposed
/// for (the percentiles of Unreal's histogram exposure).
pub const PERCENTILES: (f64, f64) = (0.8, 0.983);
/// Time constant of the adaptation between frames that follow each other (view, embedded), in
/// seconds: a frame moves 1 − e^(−Δt/τ) of the way from the adapted luminance to its own.
pub const ADAPTATION_SECONDS: f64 = 0.5;

/// The histogram bin of a pre-exposed luminance `y`, as shaders/exposure.comp computes it.
pub fn histogram_bin(y: f64) -> usize {
    if y.is_nan() || y <= 0.0 {
        return 0;
    }
    let b = ((y.log2() - HISTOGRAM_LOG2_MIN) * HISTOGRAM_BINS_PER_STOP).floor();
    b.clamp(0.0, (HISTOGRAM_BINS - 1) as f64) as usize
}

/// The measured log2 of the scene's average luminance from a histogram (counts per bin) of the
/// pre-exposed luminances: the mean of the bin centres between the `PERCENTILES`, each bin
/// weighted by how many of its pixels lie between them, minus log2 of the pre-exposure.
pub fn histogram_log2_average(bins: &[u32], pre_exposure_log2: f64) -> f64 {
    let total: f64 = bins.iter().map(|&c| c as f64).sum();
    let (lo, hi) = (PERCENTILES.0 * total, PERCENTILES.1 * total);
    let (mut sum, mut weight, mut below) = (0.0, 0.0, 0.0);
    for (i, &c) in bins.iter().enumerate() {
        let above = below + c as f64;
        let w = (above.min(hi) - below.max(lo)).max(0.0);
        sum += w * bin_centre(i);
        weight += w;
        below = above;
    }
    let avg = if weight > 0.0 { sum / weight } else { HISTOGRAM_LOG2_MIN };
    avg - pre_exposure_log2
}

/// log2 of the pre-exposed luminance at the centre of bin `i`.
pub fn bin_centre(i: usize) -> f64 {
    (i as f64 + 0.5) / HISTOGRAM_BINS_PER_STOP + HISTOGRAM_LOG2_MIN
}

/// The measurement reads at most `SAMPLES_SIDE`² pixels (shaders/common/exposure.glsl).
pub const SAMPLES_SIDE: usize = 256;

/// The pixels the measurement reads of a width × height frame, row-major indices: every s-th of
/// each row and column from s / 2, s = ⌈max(width, height) / SAMPLES_SIDE⌉.
pub fn measured_pixels(width: usize, height: usize) -> impl Iterator<Item = usize> {
    let s = width.max(height).div_ceil(SAMPLES_SIDE).max(1);
    let first = s / 2;
    (first..height).step_by(s).flat_map(move |y| (first..width).step_by(s).map(move |x| y * width + x))
}

/// The measured log2 average of a frame `width` pixels wide from its pre-exposed HDR colours
/// (`hdr`, linear RGB, row-major) and whether each pixel shows a surface: the surfaces' pixels when
/// there are any, else all (of those `measured_pixels` reads).
pub fn measure(hdr: &[[f64; 3]], surface: &[bool], width: usize, pre_exposure_log2: f64) -> f64 {
    let mut bins = [vec![0u32; HISTOGRAM_BINS], vec![0u32; HISTOGRAM_BINS]];
    let height = hdr.len().checked_div(width).unwrap_or(0);
    for (c, &s) in measured_pixels(width, height).map(|i| (&hdr[i], &surface[i])) {
        let y = c[0] * LUMINANCE[0] + c[1] * LUMINANCE[1] + c[2] * LUMINANCE[2];
        let b = histogram_bin(y);
        bins[0][b] += 1;
        if s {
            bins[1][b] += 1;
        }
    }
    let any_surface = bins[1].iter().any(|&c| c > 0);
    histogram_log2_average(if any_surface { &bins[1] } else { &bins[0] }, pre_exposure_log2)
}

/// The brightest a lit surface of `scene` can be, per channel, before exposure: ambient plus
/// every light's colour × intensity (albedo ≤ 1, n·l ≤ 1), plus the brightest material emission.
/// A point or spot light counts with its luminance on a white surface facing it at
/// `nearest_surface_distance` (`Light::radiance` / d², window and cone ≤ 1).
pub fn lit_max(scene: &Scene) -> f64 {
    lit_max_with(scene, &mesh_bounds(scene))
}

/// The object-space bounds of each of the scene's meshes (every vertex read).
pub fn mesh_bounds(scene: &Scene) -> Vec<(DVec3, DVec3)> {
    scene.meshes.iter().map(|m| m.mesh.bounds()).collect()
}

/// `lit_max` with the meshes' bounds known (`mesh_bounds`: the renderer keeps them, so a frame
/// does not read every vertex again).
pub fn lit_max_with(scene: &Scene, mesh_bounds: &[(DVec3, DVec3)]) -> f64 {
    let local: Vec<&crate::scene::Light> = scene.lights.iter().filter(|l| l.is_local()).collect();
    let boxes = if local.is_empty() { Vec::new() } else { instance_boxes(scene, mesh_bounds) };
    let lit = scene.lights.iter().fold(scene.render.ambient, |sum, l| {
        if l.is_local() {
            let d = nearest_surface_distance(&boxes, l.position);
            sum + l.radiance() / (d * d)
        } else {
            sum + l.color * l.intensity
        }
    });
    let emission = scene.materials.iter().map(|m| m.surface.emission.max_element()).fold(0.0, f64::max);
    lit.max_element() + emission
}

/// The world-space bounding boxes of the scene's instances (each mesh's box, its 8 corners
/// transformed).
fn instance_boxes(scene: &Scene, mesh_bounds: &[(DVec3, DVec3)]) -> Vec<(DVec3, DVec3)> {
    scene
        .instances
        .iter()
        .map(|inst| {
            let (lo, hi) = mesh_bounds[inst.mesh];
            (0..8).fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(a, b), k| {
                let pick = |bit: usize, x: f64, y: f64| if k & bit == 0 { x } else { y };
                let c = DVec3::new(pick(1, lo.x, hi.x), pick(2, lo.y, hi.y), pick(4, lo.z, hi.z));
                let w = inst.transform.transform_point(c);
                (a.min(w), b.max(w))
            })
        })
        .collect()
}

/// The fraction of the farthest box corner's distance below which `nearest_surface_distance` does
/// not go: surfaces closer to a light than 1% of the scene's extent around it are a small part of
/// the view, and the brightest of them may be capped at the HDR target's largest value (the
/// raster's cap; at the pre-exposures chosen here such a value is past the curve's white anyway).
pub const NEAREST_SURFACE_FRACTION: f64 = 0.01;

/// The distance from a point or spot light at `p` to the nearest surface it can light, estimated
/// from the instances' world boxes `boxes`: the distance to the nearest box's surface (from
/// outside, to the box; from inside, to its nearest face: a room's walls), but at least
/// `NEAREST_SURFACE_FRACTION` of the distance to the farthest box corner, and > 0. Without
/// instances, 1 (nothing is lit but metaballs, whose colour is capped at the HDR maximum).
pub fn nearest_surface_distance(boxes: &[(DVec3, DVec3)], p: DVec3) -> f64 {
    if boxes.is_empty() {
        return 1.0;
    }
    let (mut near, mut far) = (f64::INFINITY, 0.0f64);
    for &(lo, hi) in boxes {
        let outside = (lo - p).max(p - hi).max(DVec3::ZERO);
        let d = if outside == DVec3::ZERO { (p - lo).min(hi - p).min_element() } else { outside.length() };
        near = near.min(d);
        far = far.max((p - lo).abs().max((p - hi).abs()).length());
    }
    let d = near.max(NEAREST_SURFACE_FRACTION * far);
    if d > 0.0 && d.is_finite() {
        d
    } else {
        1.0
    }
}

/// The largest value a lit surface may reach in the HDR target after pre-exposure: 16× below
/// RGBA16F's largest (65504) leaves room for the specular highlights and the waves' glow.
pub const PRE_EXPOSED_MAX: f64 = 4096.0;

/// The pre-exposure p of a frame of `scene`: every radiance written into the HDR target (lights,
/// ambient, background, the waves' glow) is multiplied by p on the host, and the tonemap by
/// exposure / p, so what reaches the curve is the scene-linear colour × exposure whatever p is,
/// while the HDR target holds values near 1 instead of lux.
///
/// - A linear `exposure` whose lit surfaces fit the HDR target (every scene written before
///   physical units): p = 1, the frame as it always was, bit for bit.
/// - Otherwise a power of two, so scaling is exact: the one nearest the exposure (`exposure_ev100`,
///   a linear exposure), or 1 / `lit_max` (`"auto"`, whose exposure is not known before the
///   frame; with point or spot lights `PRE_EXPOSED_MAX` / `lit_max`), and never so large that a lit surface (`lit_max`) or the background passes
///   `PRE_EXPOSED_MAX`.
///
/// The renderer computes it once per frame (`FrameContext::pre_exposure`).
pub fn pre_exposure(scene: &Scene) -> f64 {
    pre_exposure_with(scene, &mesh_bounds(scene))
}

/// `pre_exposure` with the meshes' bounds known (`mesh_bounds`), as the renderer computes it
/// each frame.
pub fn pre_exposure_with(scene: &Scene, mesh_bounds: &[(DVec3, DVec3)]) -> f64 {
    let lit = lit_max_with(scene, mesh_bounds);
    let peak = lit.max(scene.render.background.max_element());
    let r = &scene.render;
    if r.exposure_mode == ExposureMode::Linear && peak <= crate::scene::file::MAX_HDR {
        return 1.0;
    }
    let nominal = match r.exposure_mode {
        ExposureMode::Linear | ExposureMode::Ev100(_) => r.exposure,
        // With point or spot lights `lit` is a hot spot at the nearest surface, far brighter than
        // the rest (1/d²): the largest p the cap allows keeps the dim surfaces far from f16's
        // subnormals (below 2⁻¹⁴) instead of centring the hot spot on 1.
        ExposureMode::Auto if lit > 0.0 && scene.lights.iter().any(|l| l.is_local()) => PRE_EXPOSED_MAX / lit,
        ExposureMode::Auto if lit > 0.0 => 1.0 / lit,
        ExposureMode::Auto => 1.0,
    };
    let mut log2 = nominal.log2().round();
    if peak > 0.0 {
        log2 = log2.min((PRE_EXPOSED_MAX / peak).log2().floor());
    }
    // f64 holds 2^±1000; what is multiplied by p is cast to f32 only after.
    log2.clamp(-1000.0, 1000.0).exp2()
}

/// The factor the tonemap multiplies the pre-exposed HDR value by for a fixed exposure:
/// exposure / p (p = `pre_exposure(scene)`), kept within f32 (the push constant). For `"auto"`
/// where no measurement is made (`estimated_log2_luminance`), the exposure estimated from the
/// lights.
pub fn tonemap_factor(scene: &Scene, pre_exposure: f64) -> f64 {
    let exposure = match scene.render.exposure_mode {
        ExposureMode::Auto => auto_exposure(estimated_log2_luminance(scene)),
        _ => scene.render.exposure,
    };
    (exposure / pre_exposure).min(f32::MAX as f64)
}

/// The average luminance an automatic exposure assumes before (or without) measuring a frame:
/// a surface of albedo 0.5 lit by every light at 60° (a quarter of `lit_max`), log2.
pub fn estimated_log2_luminance(scene: &Scene) -> f64 {
    let lit = lit_max(scene);
    if lit > 0.0 {
        (0.25 * lit).log2()
    } else {
        0.0
    }
}

/// The adapted log2 luminance after a frame measured `measured` Δt = `dt` seconds after the
/// adapted value `adapted` (None: the first frame, which takes its own measurement). The form
/// a + (m − a)·w keeps a when m = a exactly, so a still scene's frames stay bit-identical.
pub fn adapt(adapted: Option<f64>, measured: f64, dt: f64) -> f64 {
    match adapted {
        None => measured,
        Some(a) => a + (measured - a) * adaptation_weight(dt),
    }
}

/// How far a frame Δt seconds after the last adapted one moves toward its own measurement:
/// 1 − e^(−Δt/τ), 1 for Δt = ∞; Δt ≤ 0 (or NaN) keeps the adapted value.
pub fn adaptation_weight(dt: f64) -> f64 {
    if dt.is_nan() || dt <= 0.0 {
        0.0
    } else {
        1.0 - (-dt / ADAPTATION_SECONDS).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curve_endpoints() {
        assert_eq!(tonemap_channel(0.0, 1.0), 0.0);
        assert!((tonemap_channel(1e6, 1.0) - 255.0).abs() < 1e-9);
        assert_eq!(tonemap_channel(f64::NAN, 1.0), 0.0);
        assert_eq!(tonemap_channel(-3.0, 1.0), 0.0);
        // Monotone.
        let mut last = -1.0;
        for i in 0..1000 {
            let v = tonemap_channel(i as f64 * 0.01, 1.0);
            assert!(v >= last);
            last = v;
        }
    }

    /// The curve's limit written so that nothing overflows: numerator and denominator divided by
    /// x², in f64. The reference the twin is compared with for huge inputs.
    fn aces_reference(x: f64) -> f64 {
        if x <= 1.0 {
            return aces(x);
        }
        ((2.51 + 0.03 / x) / (2.43 + 0.59 / x + 0.14 / (x * x))).clamp(0.0, 1.0)
    }

    /// The shader's sequence in f32 (tonemap.comp, composite.frag): exposure, NaN guard, clamp,
    /// curve. Any f32 HDR value, any f32 exposure: finite, and white where the input is huge.
    fn tonemap_f32(linear: f32, exposure: f32) -> f32 {
        let c = linear * exposure;
        let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, ACES_WHITE as f32) };
        let a = ((c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14)).clamp(0.0, 1.0);
        let s = if a <= 0.0031308 { a * 12.92 } else { 1.055 * a.powf(1.0 / 2.4) - 0.055 };
        s * 255.0
    }

    #[test]
    fn huge_inputs_saturate_to_white_like_the_f64_reference() {
        // 65504: RGBA16F's largest; +inf: what a bigger value becomes in the HDR target.
        let hdr = [8.0, 100.0, 65504.0, 1e19, 1e30, f32::MAX as f64, f64::INFINITY];
        let exposures = [1.0, 1e20, f32::MAX as f64];
        for &x in &hdr {
            for &e in &exposures {
                let reference = srgb_encode(aces_reference(x * e)) * 255.0;
                let twin = tonemap_channel(x, e);
                let gpu = tonemap_f32(x as f32, e as f32) as f64;
                // Every x·e here is ≥ 8 > 7.25: both curves clamp to exactly 1, so the same sRGB.
                assert_eq!(twin, reference, "{x} × {e}: twin vs f64 reference");
                // In f32 too x·e (inf included) is clamped to 64, the curve to exactly 1, and
                // 1^(1/2.4) = 1; 1.055 − 0.055 rounds each constant and the difference (≤ 1.2·2⁻²⁴
                // + 2⁻²⁴ of 1), ·255 adds half an ulp of 255 (2⁻¹⁷): ≤ 255·3·2⁻²⁴ + 2⁻¹⁷ ≈ 5.3e-5.
                let bound = 255.0 * 3.0 * 2f64.powi(-24) + 2f64.powi(-17);
                assert!(
                    (gpu - reference).abs() <= bound,
                    "{x} × {e}: f32 {gpu} vs f64 reference {reference}"
                );
                assert_eq!(twin.round(), 255.0, "{x} × {e}");
            }
        }
        // Below the clamp the twin is the plain curve, and the clamp changes nothing at it.
        assert_eq!(aces(ACES_WHITE), 1.0);
        assert_eq!(aces(7.25), 1.0);
        assert!(aces(7.2) < 1.0);
        for x in [0.001, 0.18, 1.0, 4.0, 7.0, 50.0] {
            assert_eq!(tonemap_channel(x, 1.0), srgb_encode(aces_reference(x)) * 255.0);
        }
    }
}
