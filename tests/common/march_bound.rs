//! The error bound of an f32 ray march of the energy wave against f64 (tests/energy_wave_math.rs
//! for the f32 twin, tests/gpu_energy_wave.rs for the pass, each with its own `MarchUlps`).

use glam::DVec3;
use hadou::effects::energy_wave::{sample_distances, WaveFrame, CLAMP_MIN, CLAMP_RATIO, MAX_LENGTH};

/// Units in the last place of the f32 ray march, per sample (see [`raymarch_bound`]).
pub struct MarchUlps {
    /// Rounding of the sample's own arithmetic, relative to the sample.
    pub fixed: f64,
    /// Error of the sample's position per unit of s (s·u·per_s), relative to its distance r.
    pub per_s: f64,
    /// Error of the position per unit of |O − M| (inputs rounded after the reference's), over r.
    pub per_om: f64,
}

/// A first-order bound on the relative error of the f32 ray march (`raymarch_f32`, GLSL
/// `wave_raymarch`) against `raymarch_frame` in f64, from its operations (u = 2⁻²⁴ per op):
/// - a sample at s = (i + offset)·ds is off by ≤ 2u·s; c = D × u and u_D by ≤ 4u and 3u; so the
///   sample's coordinates q = q₀ + s·u_D and pc = R + s·c are off by ≤ u·(|q| + |pc|) + s·u·(3√2 + 7)
///   ≤ 2u·r + 12u·s, r either distance (M or the axis: 1-Lipschitz in those coordinates);
/// - the squares, dot product, sums, ε² and square root add ≤ 6u to r, the division and the sum of
///   the two terms 2u: a sample t_i is off by ≤ t_i·u·(10 + 12·s_i/r_i), r_i its smaller distance;
/// - the running sum rounds each partial sum S_k (≤ u·Σ S_k), the final ·ds and ds itself 2u.
///
/// Relative: u·([Σ t_i·(fixed + (per_s·s_i + per_om·|O − M|)/r_i) + Σ_k S_k]/S + 2); second-order
/// terms are below u² times the same sums.
pub fn raymarch_bound(f: &WaveFrame, u: DVec3, l: f64, steps: u32, offset: f64, k: &MarchUlps) -> f64 {
    if l.is_nan() || l <= 0.0 || steps == 0 {
        return 0.0;
    }
    let ulp = 2f64.powi(-24);
    let ds = l.min(MAX_LENGTH) / steps as f64;
    let floor = f64::max(CLAMP_RATIO * ds, CLAMP_MIN);
    let om = (f.q0 * f.q0 + f.r.length_squared()).sqrt();
    let (c, ud) = (f.d.cross(u), u.dot(f.d));
    let (mut sum, mut partials, mut weighted) = (0.0, 0.0, 0.0);
    for i in 0..steps {
        let s = (i as f64 + offset) * ds;
        let (rm, rl) = sample_distances(f, c, ud, s, floor);
        let t = f.a / rm + f.b / rl;
        weighted += t * (k.fixed + (k.per_s * s + k.per_om * om) / f64::min(rm, rl));
        sum += t;
        partials += sum;
    }
    if sum == 0.0 {
        return 0.0;
    }
    ulp * ((weighted + partials) / sum + 2.0)
}
