//! Arithmetic (FLOP) and memory traffic (bytes) per pixel of the effect passes, counted by
//! reading their shaders, so a pass's time reads as a fraction of the device ceilings. These are
//! estimates (±30 %): one FLOP per f32 add, sub, mul, div, min/max, sqrt or comparison feeding a
//! select, two per FMA, transcendental functions as the few operations lavapipe lowers them to
//! (exp, log, pow ≈ 3); integer and address arithmetic is not counted. Bytes are image and buffer
//! texels read and written per pixel at their format's size; data every pixel shares (the wave's
//! parameters, a material) is cached and not counted.

use super::ceilings::Ceilings;
use super::table::{Cell, Fmt};

/// FLOP and bytes per pixel of one pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassCost {
    pub flop_per_px: f64,
    pub bytes_per_px: f64,
}

/// energy_wave, closed form, per wave (shaders/common/energy_wave.glsl). A double-float product
/// (`hadou_two_prod`: two Veltkamp splits of 4, the product, 8 for the error) is 17 FLOP, a
/// double-float add 11. `wave_ray`: the dot product u·D (3 products + 2 adds = 73), the cross
/// product u × D (3 differences of products, 141), |c|² (82), R·c (79), |v|² (31), R × c (129),
/// rounding and squares (7): ≈ 540. The closest-point terms (`wave_centre_point` ≈ 170,
/// `wave_centre_axis` ≈ 10), four ξ coordinates (≈ 25 each), three pieces of
/// `wave_piece_integral` with `hadou_log1p` (≈ 50 each), the core clamp (≈ 50), the pixel ray and
/// emission (≈ 20): about 1,000 FLOP. Bytes: distance R32F read (4), HDR RGBA16F read and write
/// (16), energy R32F write (4).
pub fn energy_analytic(waves: usize) -> PassCost {
    PassCost { flop_per_px: 1000.0 * waves as f64, bytes_per_px: 24.0 }
}

/// energy_wave ray-marched with `steps` samples (`wave_density_at`: the sample point 2, ray–
/// centre offset 6, its square 5, distance to M 5, to the axis ≈ 7, two divisions and the sum 4,
/// the loop's s and sum 3: ≈ 31 FLOP per step, ≈ 20 to set up). Bytes as the analytic pass.
pub fn energy_raymarch(waves: usize, steps: u32) -> PassCost {
    PassCost { flop_per_px: (20.0 + 31.0 * steps as f64) * waves as f64, bytes_per_px: 24.0 }
}

/// tonemap (shaders/tonemap.comp): exposure 3, clamps 6, ACES 30, sRGB encode with pow ≈ 30:
/// ≈ 70 FLOP; reads RGBA16F (8), writes RGBA8 (4).
pub fn tonemap() -> PassCost {
    PassCost { flop_per_px: 70.0, bytes_per_px: 12.0 }
}

/// translucency (shaders/translucency.comp) with `coverage` the fraction of pixels on a
/// translucent surface and `samples` the field samples per such pixel (0 for TSM; about two per
/// voxel of the light path for the LUT, fewer where long steps skip, plus one per crossing).
/// Every pixel reads its ids (8) and writes the thickness (4). A translucent pixel: pixel ray and
/// point ≈ 20, light projection ≈ 15, two inverse-model transforms ≈ 40, exp and colour ≈ 30:
/// ≈ 105 FLOP; reads distance (4), normal (8), HDR (8), light-map ids and depth (≈ 2 texels, 16),
/// writes HDR (8): ≈ 44 bytes. A field sample: cell and weights ≈ 20, 8 corner decodes ≈ 16,
/// 7 lerps ≈ 21, τ's cell ≈ 10: ≈ 67 FLOP; 8 corner words and a τ word: 36 bytes.
pub fn translucency(coverage: f64, samples: f64) -> PassCost {
    PassCost {
        flop_per_px: (105.0 + 67.0 * samples) * coverage,
        bytes_per_px: 12.0 + (44.0 + 36.0 * samples) * coverage,
    }
}

/// The cells "GFLOP/s", "% FMA ceiling", "GB/s", "% copy ceiling" for a pass of `pixels` that took
/// `ms`; missing cells without a cost or a time.
pub fn fraction_cells(cost: Option<PassCost>, pixels: f64, ms: f64, ceilings: &Ceilings) -> Vec<Cell> {
    let Some(cost) = cost.filter(|_| ms.is_finite() && ms > 0.0) else {
        return vec![Cell::Missing; 4];
    };
    let gflops = cost.flop_per_px * pixels / (ms * 1e-3) / 1e9;
    let gbps = cost.bytes_per_px * pixels / (ms * 1e-3) / 1e9;
    vec![
        Cell::Num(gflops, Fmt::Fixed(2)),
        Cell::Num(100.0 * gflops / ceilings.gflops, Fmt::Fixed(1)),
        Cell::Num(gbps, Fmt::Fixed(2)),
        Cell::Num(100.0 * gbps / ceilings.gbps, Fmt::Fixed(1)),
    ]
}

/// Column names matching `fraction_cells`.
pub const FRACTION_COLUMNS: [&str; 4] = ["GFLOP/s", "% of FMA ceiling", "GB/s", "% of copy ceiling"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fractions_of_the_ceilings() {
        let c = Ceilings { gflops: 100.0, gbps: 10.0 };
        // 1e6 pixels × 1000 FLOP in 20 ms = 50 GFLOP/s = 50 %; 24 bytes → 1.2 GB/s = 12 %.
        let cells = fraction_cells(Some(energy_analytic(1)), 1e6, 20.0, &c);
        let v: Vec<f64> = cells.iter().map(|c| c.value().unwrap()).collect();
        assert!((v[0] - 50.0).abs() < 1e-9 && (v[1] - 50.0).abs() < 1e-9);
        assert!((v[2] - 1.2).abs() < 1e-12 && (v[3] - 12.0).abs() < 1e-9);
        assert_eq!(fraction_cells(None, 1e6, 20.0, &c), vec![Cell::Missing; 4]);
        assert_eq!(fraction_cells(Some(tonemap()), 1e6, 0.0, &c), vec![Cell::Missing; 4]);
        assert_eq!(energy_raymarch(2, 10).flop_per_px, 2.0 * 330.0);
    }
}
