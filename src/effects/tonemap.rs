//! CPU twin of shaders/tonemap.comp in f64: exposure, ACES filmic (Narkowicz 2015), sRGB encoding.

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

/// One linear HDR channel to its 8-bit sRGB code, as the GPU stores it (round to nearest).
pub fn tonemap_channel(linear: f64, exposure: f64) -> f64 {
    let c = (linear * exposure).max(0.0);
    let c = if c.is_nan() { 0.0 } else { c };
    srgb_encode(aces(c)) * 255.0
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
}
