//! The f32 CPU twin of `shaders/common/energy_wave.glsl`, line for line (keep in sync with it):
//! the GPU's closed-form ray integral of the energy wave, its ray-march baseline and the shared
//! struct [`GpuWave`]. The model, the closed form and the clamp rule are documented in
//! [`crate::effects::energy_wave`]; this file documents what is specific to f32.
//!
//! # Where the precision comes from
//! - Per frame, the camera is described in the frame of the beam: q₀ = (O − M)·D, q₀ − ℓ and
//!   R = D × (O − M), computed in f64 on the CPU and rounded to f32 once ([`gpu_wave`]). Each is
//!   accurate relative to itself, so a camera 1e5 units away, or inside the beam far from M, loses
//!   nothing to differences of large coordinates, and the distances to M, to the axis and to T
//!   are built from the same numbers (continuous across the plane crossings).
//! - Per pixel, the quantities that cancel are double-floats (hi + lo f32 pairs) built with
//!   error-free transformations (Knuth's two-sum, Dekker's product with Veltkamp's split). No FMA
//!   is needed, so the GLSL relies only on Vulkan's correctly rounded add/sub/mul and marks them
//!   `precise`. They are u_D = u·D, c = D × u, |c|², R·c, R × c, the 4D wedge q·c − u_D·R behind
//!   h, ξ(s) = (A + s·B)/m at the piece ends, and the split points s where q = 0 or q = ℓ (one
//!   Newton step on the residual). A ray passing 1e-7·|O − M| from M then has h, ξ and its split
//!   points to f32 precision; a plain f32 cross product would leave an absolute error of
//!   ~2⁻²⁴·|O − M| in h (6 % of h at 1e-6·|O − M|), and an f32 split point can land half an ulp of s
//!   away from the crossing, which is comparable to the clamp floor of a ray grazing M.
//! - Nothing else needs more than f32: ρ = √(ξ² + H²) is a sum of squares, and the logarithms
//!   take arguments without cancellation.
//! - Measured (tests/energy_wave_math.rs, and the GLSL on lavapipe): hard rays agree with the f64
//!   closed form on the same f32 inputs to ≤ 5e-7 relative.
//!
//! # log1p
//! Mesa lowers GLSL `asinh` without log1p and Vulkan allows `log` an absolute error of 2⁻²¹ in
//! [0.5, 2], so [`log1p_f32`] evaluates log1p(x) = 2·atanh(z), z = x/(2 + x), as the odd series
//! 2·(z + z³/3 + … + z¹⁵/15) for −0.5 ≤ x ≤ 1 (|z| ≤ 1/3), and `log(1 + x)` only outside, where
//! `log` has a relative bound (3 ulp) and 1 + x rounds by at most half an ulp (relative to the
//! result ≥ ln 2). Eight terms: the first omitted one, z¹⁷/17, relative to the sum is at most
//! (1/3)¹⁶/17·9/8 = 1.5e-9 ≈ 2⁻²⁴/40; seven would leave 3.6e-8 ≈ 0.6 ulp.
//!
//! # Thresholds (f32)
//! - Linear form when m·Δs ≤ 2⁻¹²·(ρ_a + ρ_b): its relative error is below (2⁻¹²)² = 2⁻²⁴ (the
//!   f64 reference uses 2⁻²⁶); above it the log1p forms are accurate for any m > 0 (no underflow:
//!   the argument is at least ~2⁻¹³).
//! - |v| ≤ 2⁻⁶⁰ counts as parallel (B = |v|² then stays a normal f32). With f32 inputs the exact
//!   |D × u| is either 0 or at least ~2⁻⁴⁹ when the components are O(1), so this only catches
//!   exact zeros and pathological tiny components.
//! - The clamp's floors 2⁻²⁰·S and 2⁻⁶⁰ as in f64: every distance stays ≥ 2⁻⁶⁰, whose square is a
//!   normal f32; every division is by a distance, by m after checking m·Δs > 0, or by a
//!   denominator checked positive, so the result is finite and ≥ 0 for finite inputs with lengths
//!   below 1e18 (L is clamped to 1e18, so an infinite far plane is fine).

// `!(x > y)` on purpose: false for NaN as well, like the GLSL it mirrors.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use super::energy_wave::{frame, WaveFrame, WaveParams};

/// One wave as the GPU reads it (std430; keep in sync with `struct Wave` in
/// shaders/common/energy_wave.glsl). Camera-relative: rebuild it when the camera or the wave
/// moves. O − M = q₀·D + R × D and O − T = (q₀ − ℓ)·D + R × D: the camera in the frame of the beam,
/// which (unlike O − M rounded per component) keeps a camera near the axis far from M, or near M
/// far from the axis, accurate in both coordinates.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuWave {
    /// xyz: D (unit); w: q₀ = (O − M)·D.
    pub dir: [f32; 4],
    /// xyz: R = D × (O − M); w: q₀ − ℓ (0 when the beam is endless).
    pub rperp: [f32; 4],
    /// x: a, y: b, z: ε (core radius); w: 0.
    pub strength: [f32; 4],
    /// x: 1 when the beam length is finite; yzw: 0.
    pub flags: [u32; 4],
}

const _: () = assert!(core::mem::size_of::<GpuWave>() == 64);
const _: () = assert!(core::mem::align_of::<GpuWave>() == 4);
const _: () = assert!(core::mem::offset_of!(GpuWave, dir) == 0);
const _: () = assert!(core::mem::offset_of!(GpuWave, rperp) == 16);
const _: () = assert!(core::mem::offset_of!(GpuWave, strength) == 32);
const _: () = assert!(core::mem::offset_of!(GpuWave, flags) == 48);

fn f4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

fn d3(v: [f32; 4]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

/// The wave seen from `camera`: every camera-relative quantity in f64, rounded to f32 once.
pub fn gpu_wave(w: &WaveParams, camera: DVec3) -> GpuWave {
    let f = frame(w, camera);
    GpuWave {
        dir: f4(f.d, f.q0),
        rperp: f4(f.r, f.qt),
        strength: [f.a as f32, f.b as f32, f.core as f32, 0.0],
        flags: [f.finite as u32, 0, 0, 0],
    }
}

impl GpuWave {
    /// The exact f64 values of these f32 numbers: the fair f64 reference for the GPU integrates
    /// this frame ([`crate::effects::energy_wave::line_integral_frame`]) along the same f32 ray.
    pub fn to_frame(&self) -> WaveFrame {
        WaveFrame {
            d: d3(self.dir),
            q0: self.dir[3] as f64,
            r: d3(self.rperp),
            qt: self.rperp[3] as f64,
            a: self.strength[0] as f64,
            b: self.strength[1] as f64,
            core: self.strength[2] as f64,
            finite: self.flags[0] != 0,
        }
    }
}

// Constants (same values in the GLSL).
const HADOU_SPLITTER: f32 = 4097.0; // 2^12 + 1: Veltkamp's split of a 24-bit significand
const WAVE_CLAMP_RATIO: f32 = 9.536_743e-7; // 2^-20
const WAVE_CLAMP_MIN: f32 = 8.673_617e-19; // 2^-60
const WAVE_PARALLEL_MIN: f32 = 8.673_617e-19; // 2^-60
const WAVE_LINEAR_TAU: f32 = 2.441_406_3e-4; // 2^-12
const HADOU_BIG: f32 = 3.0e38;
const WAVE_MAX_LENGTH: f32 = 1.0e18; // L is clamped here: squares stay finite

/// log1p(x) for x > −1 without `log` near 1 (see the module docs). The GLSL is `hadou_log1p`.
pub fn log1p_f32(x: f32) -> f32 {
    // GLSL: x > 1.0 || x < -0.5
    if !(-0.5..=1.0).contains(&x) {
        return (1.0 + x).ln();
    }
    let z = x / (2.0 + x);
    let z2 = z * z;
    let mut p = 1.0 / 15.0;
    p = p * z2 + 1.0 / 13.0;
    p = p * z2 + 1.0 / 11.0;
    p = p * z2 + 1.0 / 9.0;
    p = p * z2 + 1.0 / 7.0;
    p = p * z2 + 1.0 / 5.0;
    p = p * z2 + 1.0 / 3.0;
    p = p * z2 + 1.0;
    2.0 * z * p
}

/// asinh(x) for x ≥ 0 as log1p(x + x²/(1 + √(1 + x²))).
fn hadou_asinh_pos(x: f32) -> f32 {
    log1p_f32(x + x * x / (1.0 + (1.0 + x * x).sqrt()))
}

// Double-float arithmetic: [hi, lo] with hi + lo the value (GLSL: vec2).
type Df = [f32; 2];

/// a + b exactly (Knuth).
fn hadou_two_sum(a: f32, b: f32) -> Df {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    [s, e]
}

/// a + b exactly when |a| ≥ |b| (Dekker).
fn hadou_fast_two_sum(a: f32, b: f32) -> Df {
    let s = a + b;
    let e = b - (s - a);
    [s, e]
}

/// a = hi + lo with 12-bit halves (Veltkamp).
fn hadou_split(a: f32) -> Df {
    let c = HADOU_SPLITTER * a;
    let hi = c - (c - a);
    let lo = a - hi;
    [hi, lo]
}

/// a·b exactly (Dekker), barring overflow (|a|, |b| < 2^115) and underflow of the error term.
fn hadou_two_prod(a: f32, b: f32) -> Df {
    let p = a * b;
    let sa = hadou_split(a);
    let sb = hadou_split(b);
    let e = ((sa[0] * sb[0] - p) + sa[0] * sb[1] + sa[1] * sb[0]) + sa[1] * sb[1];
    [p, e]
}

fn hadou_df_add(x: Df, y: Df) -> Df {
    let s = hadou_two_sum(x[0], y[0]);
    let lo = s[1] + (x[1] + y[1]);
    hadou_fast_two_sum(s[0], lo)
}

fn hadou_df_neg(x: Df) -> Df {
    [-x[0], -x[1]]
}

/// a·y for an f32 a and a double-float y.
fn hadou_df_mul(a: f32, y: Df) -> Df {
    let p = hadou_two_prod(a, y[0]);
    let lo = p[1] + a * y[1];
    [p[0], lo]
}

/// x·y for two double-floats (the lo·lo term dropped).
fn hadou_df_mul_df(x: Df, y: Df) -> Df {
    let p = hadou_two_prod(x[0], y[0]);
    let lo = p[1] + (x[0] * y[1] + x[1] * y[0]);
    [p[0], lo]
}

/// x².
fn hadou_df_sqr(x: Df) -> Df {
    let p = hadou_two_prod(x[0], x[0]);
    let lo = p[1] + 2.0 * x[0] * x[1];
    [p[0], lo]
}

/// a·b − c·d.
fn hadou_df_diff_prod(a: f32, b: f32, c: f32, d: f32) -> Df {
    hadou_df_add(hadou_two_prod(a, b), hadou_df_neg(hadou_two_prod(c, d)))
}

fn hadou_df_dot(a: [f32; 3], b: [f32; 3]) -> Df {
    hadou_df_add(
        hadou_df_add(hadou_two_prod(a[0], b[0]), hadou_two_prod(a[1], b[1])),
        hadou_two_prod(a[2], b[2]),
    )
}

fn hadou_df_round(x: Df) -> f32 {
    x[0] + x[1]
}

fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn xyz(v: [f32; 4]) -> [f32; 3] {
    [v[0], v[1], v[2]]
}

/// The ray in the frame of the beam, shared by its three centres (GLSL: `WaveRay`): u_D = u·D,
/// c = D × u, |c|², R·c as double-floats, and |R × c|² (from a double-float R × c).
#[derive(Clone, Copy, Debug)]
struct WaveRay {
    ud: Df,
    cx: Df,
    cy: Df,
    cz: Df,
    cc: Df,
    rc: Df,
    rxc2: f32,
}

fn wave_ray(g: &GpuWave, u: [f32; 3]) -> WaveRay {
    let d = xyz(g.dir);
    let r = xyz(g.rperp);
    let ud = hadou_df_dot(u, d);
    let cx = hadou_df_diff_prod(d[1], u[2], d[2], u[1]);
    let cy = hadou_df_diff_prod(d[2], u[0], d[0], u[2]);
    let cz = hadou_df_diff_prod(d[0], u[1], d[1], u[0]);
    let cc = hadou_df_add(hadou_df_add(hadou_df_sqr(cx), hadou_df_sqr(cy)), hadou_df_sqr(cz));
    let rc =
        hadou_df_add(hadou_df_add(hadou_df_mul(r[0], cx), hadou_df_mul(r[1], cy)), hadou_df_mul(r[2], cz));
    let x = [
        hadou_df_round(hadou_df_add(hadou_df_mul(r[1], cz), hadou_df_neg(hadou_df_mul(r[2], cy)))),
        hadou_df_round(hadou_df_add(hadou_df_mul(r[2], cx), hadou_df_neg(hadou_df_mul(r[0], cz)))),
        hadou_df_round(hadou_df_add(hadou_df_mul(r[0], cy), hadou_df_neg(hadou_df_mul(r[1], cx)))),
    ];
    WaveRay { ud, cx, cy, cz, cc, rc, rxc2: dot3(x, x) }
}

/// A line P₀ + s·V seen from its centre: ξ(s) = (A + s·B)/m (A = P₀·V, B = |V|² as
/// double-floats), closest distance h. GLSL: `WaveCentre`.
#[derive(Clone, Copy, Debug)]
struct WaveCentre {
    a: Df,
    b: Df,
    m: f32,
    h: f32,
}

/// The centre M (q = q₀) or T (q = q₀ − ℓ): the 4D line (q, R) + s·(u_D, c).
fn wave_centre_point(ray: &WaveRay, q: f32, r: [f32; 3]) -> WaveCentre {
    let b = hadou_df_add(hadou_df_sqr(ray.ud), ray.cc);
    let m = hadou_df_round(b).sqrt();
    if !(m > WAVE_PARALLEL_MIN) {
        return WaveCentre { a: [0.0, 0.0], b: [0.0, 0.0], m: 0.0, h: (q * q + dot3(r, r)).sqrt() };
    }
    let a = hadou_df_add(hadou_df_mul(q, ray.ud), ray.rc);
    // |P₀ ∧ V|² = |q·c − u_D·R|² + |R × c|².
    let w = [
        hadou_df_round(hadou_df_add(hadou_df_mul(q, ray.cx), hadou_df_neg(hadou_df_mul(r[0], ray.ud)))),
        hadou_df_round(hadou_df_add(hadou_df_mul(q, ray.cy), hadou_df_neg(hadou_df_mul(r[1], ray.ud)))),
        hadou_df_round(hadou_df_add(hadou_df_mul(q, ray.cz), hadou_df_neg(hadou_df_mul(r[2], ray.ud)))),
    ];
    WaveCentre { a, b, m, h: (dot3(w, w) + ray.rxc2).sqrt() / m }
}

/// The axis: the 3D line R + s·c (|R + s·c| = distance to the axis).
fn wave_centre_axis(ray: &WaveRay, r: [f32; 3]) -> WaveCentre {
    let m = hadou_df_round(ray.cc).sqrt();
    if !(m > WAVE_PARALLEL_MIN) {
        return WaveCentre { a: [0.0, 0.0], b: [0.0, 0.0], m: 0.0, h: dot3(r, r).sqrt() };
    }
    WaveCentre { a: ray.rc, b: ray.cc, m, h: ray.rxc2.sqrt() / m }
}

/// ξ(s) = (A + s·B)/m, the sum in double-float.
fn wave_xi(c: &WaveCentre, s: Df) -> f32 {
    if c.m == 0.0 {
        return 0.0;
    }
    let t = hadou_df_mul_df(s, c.b);
    hadou_df_round(hadou_df_add(c.a, t)) / c.m
}

/// One piece of a term: its length and ξ at its ends (empty when ds ≤ 0). GLSL: `WavePiece`.
#[derive(Clone, Copy, Debug)]
struct WavePiece {
    ds: f32,
    xa: f32,
    xb: f32,
    m: f32,
    h: f32,
}

fn wave_piece_empty() -> WavePiece {
    WavePiece { ds: 0.0, xa: 0.0, xb: 0.0, m: 0.0, h: 0.0 }
}

/// The piece [s0, s1] (double-float ends) of the line seen from `c`.
fn wave_piece(c: &WaveCentre, s0: Df, s1: Df) -> WavePiece {
    let mut p = wave_piece_empty();
    let ds = hadou_df_round(hadou_df_add(s1, hadou_df_neg(s0)));
    if ds > 0.0 {
        p.ds = ds;
        p.xa = wave_xi(c, s0);
        p.xb = wave_xi(c, s1);
        p.m = c.m;
        p.h = c.h;
    }
    p
}

/// ∫ ds/√(ξ(s)² + hh²) over one piece, hh = √(h² + ε_F²): ρ_a, ρ_b (and hh where the closest
/// approach is inside) are at least F ≥ 2⁻⁶⁰, so no division here is by 0.
fn wave_piece_integral(p: &WavePiece, hh: f32) -> f32 {
    let ds = p.ds;
    let ra = (p.xa * p.xa + hh * hh).sqrt();
    let rb = (p.xb * p.xb + hh * hh).sqrt();
    if p.m * ds <= WAVE_LINEAR_TAU * (ra + rb) {
        return 2.0 * ds / (ra + rb);
    }
    let v = if p.xa >= 0.0 {
        log1p_f32(p.m * ds * (1.0 + (p.xa + p.xb) / (ra + rb)) / (p.xa + ra))
    } else if p.xb <= 0.0 {
        log1p_f32(p.m * ds * (1.0 - (p.xa + p.xb) / (ra + rb)) / (rb - p.xb))
    } else {
        hadou_asinh_pos(p.xb / hh) + hadou_asinh_pos(-p.xa / hh)
    };
    v / p.m
}

/// One term: its pieces share the clamp (see `energy_wave`'s module docs).
fn wave_term(p0: &WavePiece, p1: &WavePiece, p2: &WavePiece, eps: f32, l: f32) -> f32 {
    let e2 = eps * eps;
    let mut smax2 = 0.0f32;
    let mut dmin2 = HADOU_BIG;
    for p in [p0, p1, p2] {
        if p.ds > 0.0 {
            let h2 = p.h * p.h;
            smax2 = smax2.max(p.xa * p.xa + h2 + e2).max(p.xb * p.xb + h2 + e2);
            let mut xn = 0.0f32;
            if p.xa > 0.0 {
                xn = p.xa;
            } else if p.xb < 0.0 {
                xn = -p.xb;
            }
            dmin2 = dmin2.min(xn * xn + h2);
        }
    }
    if dmin2 == HADOU_BIG {
        return 0.0;
    }
    let scale = if smax2 > 0.0 { smax2.sqrt() } else { l };
    let fl = (WAVE_CLAMP_RATIO * scale).max(WAVE_CLAMP_MIN);
    let core2 = e2.max(fl * fl - dmin2);
    let mut sum = 0.0f32;
    for p in [p0, p1, p2] {
        if p.ds > 0.0 {
            sum += wave_piece_integral(p, (p.h * p.h + core2).sqrt());
        }
    }
    sum
}

/// clamp(num/den, 0, L) as a double-float, for a double-float den ≥ 0, dividing only when the
/// answer is inside (a den flushed to 0 on the GPU gives L, never inf or NaN). One Newton step on
/// the residual num − s·den puts the split where q = 0 (or q = ℓ) to ~2⁻⁴⁸ relative: an f32 split
/// point (off by up to half an ulp of s, which can be comparable to the clamp floor F of a ray
/// grazing M) would integrate the wrong formula between the true and the rounded crossing.
fn wave_crossing(num: f32, den: Df, l: f32) -> Df {
    if num <= 0.0 {
        return [0.0, 0.0];
    }
    // num ≥ L·den, decided on the exact residual (a rounded product can hide a crossing just
    // before L).
    if hadou_df_round(hadou_df_add([num, 0.0], hadou_df_neg(hadou_df_mul(l, den)))) >= 0.0 {
        return [l, 0.0];
    }
    let s = num / den[0];
    if !(s < HADOU_BIG) {
        return [l, 0.0];
    }
    let r = hadou_df_add([num, 0.0], hadou_df_neg(hadou_df_mul(s, den)));
    let t = hadou_fast_two_sum(s, hadou_df_round(r) / den[0]);
    if t[0] > l || (t[0] == l && t[1] > 0.0) {
        return [l, 0.0];
    }
    t
}

/// The larger of two double-floats.
fn hadou_df_max(a: Df, b: Df) -> Df {
    if hadou_df_round(hadou_df_add(a, hadou_df_neg(b))) >= 0.0 {
        return a;
    }
    b
}

/// H = ∫₀ᴸ E(O + s·u) ds in closed form (GLSL: `wave_line_integral`). `u` is used exactly as
/// given (unit or not); L ≤ 0 (or NaN) gives 0, L above 1e18 (or +∞) counts as 1e18.
pub fn line_integral_f32(g: &GpuWave, u: [f32; 3], l: f32) -> f32 {
    if !(l > 0.0) {
        return 0.0;
    }
    let l = l.min(WAVE_MAX_LENGTH);
    let r = xyz(g.rperp);
    let q0 = g.dir[3];
    let qt = g.rperp[3];
    let eps = g.strength[2];
    let finite = g.flags[0] != 0;
    let ray = wave_ray(g, u);
    // The sphere term: one piece, centre M.
    let cm = wave_centre_point(&ray, q0, r);
    let zero: Df = [0.0, 0.0];
    let end: Df = [l, 0.0];
    let sphere = wave_term(&wave_piece(&cm, zero, end), &wave_piece_empty(), &wave_piece_empty(), eps, l);
    // The line term: behind M (q < 0), along the beam, past the tip (q > ℓ); split points as
    // double-floats.
    let (b0, b1, c0, c1, t0, t1);
    if ray.ud[0] >= 0.0 {
        let s0 = wave_crossing(-q0, ray.ud, l);
        let s1 = if finite { hadou_df_max(wave_crossing(-qt, ray.ud, l), s0) } else { end };
        (b0, b1, c0, c1, t0, t1) = (zero, s0, s0, s1, s1, end);
    } else {
        let s1 = if finite { wave_crossing(qt, hadou_df_neg(ray.ud), l) } else { zero };
        let s0 = hadou_df_max(wave_crossing(q0, hadou_df_neg(ray.ud), l), s1);
        (b0, b1, c0, c1, t0, t1) = (s0, end, s1, s0, zero, s1);
    }
    let pb = wave_piece(&cm, b0, b1);
    let mut pc = wave_piece_empty();
    if hadou_df_round(hadou_df_add(c1, hadou_df_neg(c0))) > 0.0 {
        pc = wave_piece(&wave_centre_axis(&ray, r), c0, c1);
    }
    let mut pt = wave_piece_empty();
    if hadou_df_round(hadou_df_add(t1, hadou_df_neg(t0))) > 0.0 {
        pt = wave_piece(&wave_centre_point(&ray, qt, r), t0, t1);
    }
    let line = wave_term(&pb, &pc, &pt, eps, l);
    g.strength[0] * sphere + g.strength[1] * line
}

fn cross3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// E at O + s·u with distances floored at `fl` (plain f32: the baseline).
fn wave_density_at(g: &GpuWave, c: [f32; 3], ud: f32, s: f32, fl: f32) -> f32 {
    let e2 = g.strength[2] * g.strength[2];
    let q = g.dir[3] + s * ud;
    let r = xyz(g.rperp);
    let pc = [r[0] + s * c[0], r[1] + s * c[1], r[2] + s * c[2]];
    let r2 = dot3(pc, pc);
    let rm = (q * q + r2 + e2).sqrt().max(fl);
    let qt = g.rperp[3] + s * ud;
    let mut dl2 = r2;
    if q <= 0.0 {
        dl2 = q * q + r2;
    } else if g.flags[0] != 0 && qt >= 0.0 {
        dl2 = qt * qt + r2;
    }
    let rl = (dl2 + e2).sqrt().max(fl);
    g.strength[0] / rm + g.strength[1] / rl
}

/// The ray-march baseline (GLSL: `wave_raymarch`): `steps` samples at s_i = (i + offset)·L/N,
/// each weighted L/N, distances floored at max(2⁻²⁰·L/N, 2⁻⁶⁰).
pub fn raymarch_f32(g: &GpuWave, u: [f32; 3], l: f32, steps: u32, offset: f32) -> f32 {
    if !(l > 0.0) || steps == 0 {
        return 0.0;
    }
    let ds = l.min(WAVE_MAX_LENGTH) / steps as f32;
    let fl = (WAVE_CLAMP_RATIO * ds).max(WAVE_CLAMP_MIN);
    let d = xyz(g.dir);
    let c = cross3(d, u);
    let ud = dot3(u, d);
    let mut sum = 0.0f32;
    for i in 0..steps {
        sum += wave_density_at(g, c, ud, (i as f32 + offset) * ds, fl);
    }
    sum * ds
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log1p_is_accurate() {
        let mut worst = 0.0f64;
        let mut x = 1e-30f32;
        while x < 1e30 {
            for v in [x, -x.min(0.99)] {
                let got = log1p_f32(v) as f64;
                let want = (v as f64).ln_1p();
                let e = ((got - want) / want).abs();
                worst = worst.max(e);
            }
            x *= 1.0137;
        }
        // A few ulps: the series and its division, or ln's own error outside [-0.5, 1].
        assert!(worst < 4.0 * f32::EPSILON as f64, "{worst:e}");
        assert_eq!(log1p_f32(0.0), 0.0);
    }

    #[test]
    fn error_free_transformations_are_exact() {
        let mut s = 0x1234_5678_u32;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            f32::from_bits((s & 0x007f_ffff) | 0x3f00_0000) * if s & 1 == 0 { 1.0 } else { -3.0 }
        };
        for _ in 0..100_000 {
            let (a, b) = (next(), next() * 1e3);
            let p = hadou_two_prod(a, b);
            assert_eq!(p[0] as f64 + p[1] as f64, a as f64 * b as f64);
            let t = hadou_two_sum(a, b);
            assert_eq!(t[0] as f64 + t[1] as f64, a as f64 + b as f64);
        }
    }

    #[test]
    fn gpu_wave_layout_and_round_trip() {
        let w = WaveParams {
            origin: DVec3::new(1.0, 2.0, 3.0),
            direction: DVec3::new(0.0, 0.6, 0.8),
            a: 2.0,
            b: 3.0,
            core: 0.25,
            length: 7.0,
        };
        let g = gpu_wave(&w, DVec3::new(-4.0, 5.0, 9.0));
        assert_eq!(bytemuck::bytes_of(&g).len(), 64);
        // O − M = (−5, 3, 6): q₀ = 6.6, R = D × (O − M) = (0.6·6 − 0.8·3, −0.8·5, 0.6·5).
        assert_eq!(g.dir, [0.0, 0.6, 0.8, 6.6]);
        assert_eq!(g.rperp, [1.2, -4.0, 3.0, (6.6f64 - 7.0) as f32]);
        assert_eq!(g.flags, [1, 0, 0, 0]);
        let f = g.to_frame();
        assert!(f.finite && f.core == 0.25 && f.q0 == 6.6f32 as f64);
        let inf = gpu_wave(&WaveParams { length: f64::INFINITY, ..w }, DVec3::ZERO);
        assert_eq!((inf.rperp[3], inf.flags), (0.0, [0; 4]));
    }
}
