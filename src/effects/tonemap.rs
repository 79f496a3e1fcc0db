//! CPU twin of shaders/tonemap.comp in f64: exposure, ACES filmic (Narkowicz 2015), sRGB encoding.

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
