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
//! - A double-float sum that is rounded at once (the components of R × c and of the wedge, the
//!   numerators of ξ, the Newton residual) takes 3 ops instead of a renormalizing add:
//!   (x.hi + y.hi) + (x.lo + y.lo) is exact in its first addition when it cancels (Sterbenz) and
//!   otherwise rounds at least half the larger operand, so it keeps ~2⁻²³ of the result plus
//!   2⁻⁴⁶ of the operands, as exact as the operands themselves. A piece's length s₁ − s₀ of two
//!   double-float split points is rounded the same way.
//! - Nothing else needs more than f32: ρ = √(ξ² + H²) is a sum of squares, and the logarithms
//!   take arguments without cancellation.
//! - Measured (tests/energy_wave_math.rs, and the GLSL on lavapipe): hard rays agree with the f64
//!   closed form on the same f32 inputs to ≤ 5e-7 relative.
//!
//! # log1p
//! Mesa lowers GLSL `asinh` without log1p and Vulkan allows `log` an absolute error of 2⁻²¹ in
//! [0.5, 2], so [`log1p_f32`] uses no `log` at all, and no branch (the GPU would run both sides,
//! see "Cost"): u = 1 + x rounded and its rounding error err = x − (u − 1), exact (Fast2Sum's
//! error term for |x| ≤ 1; for x > 1, u − 1 is exact below 2²⁴ and Sterbenz makes the difference
//! exact); u = 2ᵏ·f with f in [√½, √2) read from the bits; then
//! log1p(x) = k·ln 2 + 2·atanh(z) + err/u, z = (f − 1)/(f + 1) (f − 1 exact by Sterbenz),
//! |z| ≤ 0.1716, atanh as the odd series z + z³/3 + … + z⁹/9: the first omitted term, z¹¹/11,
//! is below 2.0e-9 relative, and the dropped −(err/u)²/2 below 2⁻⁴⁹. k·ln 2 is split so that
//! k·LN2_HI is exact. Measured: ≤ 2.7e-7 relative (2.2 ulp) over [−0.99, 1e30] (20 million
//! random f32 arguments and the sweep of the test below).
//!
//! # One log1p per piece
//! A piece's three cases (both ends ≥ 0, both ≤ 0 mirrored onto ≥ 0, and ξ_a < 0 < ξ_b) differ
//! only in the argument of one log1p: the straddling case asinh(ξ_b/hh) + asinh(−ξ_a/hh) is
//! log1p(y_a + y_b + y_a·y_b) with y = e^asinh(x/hh) − 1 = x·(hh + ρ + x)/(hh·(hh + ρ)) for
//! x = −ξ_a, ξ_b ≥ 0: a sum of products of nonnegative terms, so its relative error is that of
//! the y's, and log1p's relative error is at most its argument's. The clamp keeps x/hh ≤ 2²⁰
//! (hh ≥ F ≥ 2⁻²⁰·S ≥ 2⁻²⁰·|ξ| when the closest approach is inside), so y_a·y_b ≤ 2⁴³.
//!
//! # Cost
//! The GLSL is one straight path with selects. On lavapipe (Mesa 22.3) every `if` becomes an
//! execution mask and both sides run for every group of 8 invocations, even when no lane takes
//! one of them (measured: a never-taken branch around the whole integral costs as much as
//! running it), and a `for` loop runs its body once more, masked, on its last test. So a cheap
//! plain-f32 path for "easy" rays, with the double-float path as a fallback, would be paid on top
//! of the exact path, never instead of it. Nor would it be cheap in accuracy: h = |p × u| in plain
//! f32 has an absolute error of a few 2⁻²⁴·|O − M| (measured on 20 000 rays per ratio, relative
//! to h: worst 8e-7 at h = 2⁻⁴·|O − M|, 1.2e-5 at 2⁻⁸, 4.7e-5 at 2⁻¹⁰), and H inherits up to
//! all of it, where the twin is held to 1e-5 and measures ≤ 5e-7. What the straight path saves:
//! the sphere term has its one piece (not three), two plane crossings are computed instead of
//! four, ξ(0) = A/m needs no double-float work, each piece takes one log1p of the branch-free
//! kind above (the first version evaluated both branches of log1p, `log` and the series, four
//! times per piece, six pieces per pixel), and the point centres share |V|² and |V|. The
//! pass's `main` (shaders/energy_wave.comp) reads the first wave in uniform control flow and
//! loops over waves with a do-while. Measured at 512×512 on lavapipe: 44 → 8 ms per frame.
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

/// One wave as the GPU reads it (std430; its size is checked against `struct Wave` in
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

crate::gpu::layout::gpu_layout!(GpuWave as "Wave" { dir, rperp, strength, flags });

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
const HADOU_SQRT2: f32 = std::f32::consts::SQRT_2; // √2 rounded to f32 (just below √2)
const HADOU_LN2_HI: f32 = 0.693_145_75; // ln 2 to 16 bits: k·LN2_HI is exact
const HADOU_LN2_LO: f32 = 1.428_606_8e-6; // ln 2 − LN2_HI

/// log1p(x) for −1 < x < 3e38 without `log` and without a branch (see the module docs). The
/// GLSL is `hadou_log1p`.
pub fn log1p_f32(x: f32) -> f32 {
    let u = 1.0 + x;
    let err = x - (u - 1.0);
    let bits = u.to_bits() as i32;
    let mut k = ((bits >> 23) & 255) - 127;
    let mut f = f32::from_bits(((bits & 8_388_607) | 1_065_353_216) as u32); // mantissa, in [1, 2)
    let high = f > HADOU_SQRT2;
    f = if high { 0.5 * f } else { f };
    k = if high { k + 1 } else { k };
    let z = (f - 1.0) / (f + 1.0);
    let z2 = z * z;
    let mut p = 1.0 / 9.0;
    p = p * z2 + 1.0 / 7.0;
    p = p * z2 + 1.0 / 5.0;
    p = p * z2 + 1.0 / 3.0;
    p = p * z2 + 1.0;
    let fk = k as f32;
    fk * HADOU_LN2_HI + (fk * HADOU_LN2_LO + (2.0 * z * p + err / u))
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

/// round(x + y) for double-floats with |lo| ≤ 2⁻²³·|hi| (sums, products): when x.hi + y.hi
/// cancels it is exact (Sterbenz), otherwise it is at least half the larger operand; either way
/// the result is good to ~2⁻²³ of itself plus 2⁻⁴⁶ of the operands, as exact as the operands
/// are (3 ops instead of a renormalizing `hadou_df_add` and the rounding).
fn hadou_df_add_round(x: Df, y: Df) -> f32 {
    (x[0] + y[0]) + (x[1] + y[1])
}

/// a ≥ b for normalized double-floats (|lo| ≤ half an ulp of hi, as `hadou_fast_two_sum`
/// returns): their order is the order of (hi, lo).
fn hadou_df_ge(a: Df, b: Df) -> bool {
    a[0] > b[0] || (a[0] == b[0] && a[1] >= b[1])
}

fn hadou_df_max(a: Df, b: Df) -> Df {
    if hadou_df_ge(a, b) {
        a
    } else {
        b
    }
}

/// b − a rounded, for normalized 0 ≤ a ≤ b: b.hi − a.hi is exact when a.hi ≥ b.hi/2 (Sterbenz)
/// and otherwise at least b.hi/2, so the result is good to ~2⁻²³ relative.
fn hadou_df_span(a: Df, b: Df) -> f32 {
    (b[0] - a[0]) + (b[1] - a[1])
}

fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn xyz(v: [f32; 4]) -> [f32; 3] {
    [v[0], v[1], v[2]]
}

/// The ray in the frame of the beam, shared by its three centres (GLSL: `WaveRay`): u_D = u·D,
/// c = D × u, |c|², R·c and the point centres' |V|² = u_D² + |c|² as double-floats, |V|, and
/// |R × c|² (from a double-float R × c).
#[derive(Clone, Copy, Debug)]
struct WaveRay {
    ud: Df,
    cx: Df,
    cy: Df,
    cz: Df,
    cc: Df,
    rc: Df,
    vv: Df,
    mv: f32,
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
    let vv = hadou_df_add(hadou_df_sqr(ud), cc);
    let mv = hadou_df_round(vv).sqrt();
    let x = [
        hadou_df_add_round(hadou_df_mul(r[1], cz), hadou_df_neg(hadou_df_mul(r[2], cy))),
        hadou_df_add_round(hadou_df_mul(r[2], cx), hadou_df_neg(hadou_df_mul(r[0], cz))),
        hadou_df_add_round(hadou_df_mul(r[0], cy), hadou_df_neg(hadou_df_mul(r[1], cx))),
    ];
    WaveRay { ud, cx, cy, cz, cc, rc, vv, mv, rxc2: dot3(x, x) }
}

/// A line P₀ + s·V seen from its centre: ξ(s) = (A + s·B)/m (A = P₀·V, B = |V|² as
/// double-floats), closest distance h; m = 0 when |V| ≤ 2⁻⁶⁰ (ξ = 0, h = |P₀|). GLSL:
/// `WaveCentre`.
#[derive(Clone, Copy, Debug)]
struct WaveCentre {
    a: Df,
    b: Df,
    m: f32,
    h: f32,
}

/// The centre M (q = q₀) or T (q = q₀ − ℓ): the 4D line (q, R) + s·(u_D, c).
fn wave_centre_point(ray: &WaveRay, q: f32, r: [f32; 3]) -> WaveCentre {
    if !(ray.mv > WAVE_PARALLEL_MIN) {
        return WaveCentre { a: [0.0, 0.0], b: [0.0, 0.0], m: 0.0, h: (q * q + dot3(r, r)).sqrt() };
    }
    // |P₀ ∧ V|² = |q·c − u_D·R|² + |R × c|².
    let w = [
        hadou_df_add_round(hadou_df_mul(q, ray.cx), hadou_df_neg(hadou_df_mul(r[0], ray.ud))),
        hadou_df_add_round(hadou_df_mul(q, ray.cy), hadou_df_neg(hadou_df_mul(r[1], ray.ud))),
        hadou_df_add_round(hadou_df_mul(q, ray.cz), hadou_df_neg(hadou_df_mul(r[2], ray.ud))),
    ];
    WaveCentre {
        a: hadou_df_add(hadou_df_mul(q, ray.ud), ray.rc),
        b: ray.vv,
        m: ray.mv,
        h: (dot3(w, w) + ray.rxc2).sqrt() / ray.mv,
    }
}

/// The axis: the 3D line R + s·c (|R + s·c| = distance to the axis).
fn wave_centre_axis(ray: &WaveRay, r: [f32; 3]) -> WaveCentre {
    let m = hadou_df_round(ray.cc).sqrt();
    if !(m > WAVE_PARALLEL_MIN) {
        return WaveCentre { a: [0.0, 0.0], b: [0.0, 0.0], m: 0.0, h: dot3(r, r).sqrt() };
    }
    WaveCentre { a: ray.rc, b: ray.cc, m, h: ray.rxc2.sqrt() / m }
}

/// ξ(s) = (A + s·B)/m, the sum in double-float (0 when m = 0: then A = B = 0 and the division
/// is by 1).
fn wave_xi(c: &WaveCentre, s: Df) -> f32 {
    hadou_df_add_round(c.a, hadou_df_mul_df(s, c.b)) / if c.m > 0.0 { c.m } else { 1.0 }
}

/// ξ(0) = A/m.
fn wave_xi0(c: &WaveCentre) -> f32 {
    hadou_df_round(c.a) / if c.m > 0.0 { c.m } else { 1.0 }
}

/// One piece of a term: its length (≤ 0: empty) and ξ at its ends, seen from a centre with m,
/// h. GLSL: `WavePiece`.
#[derive(Clone, Copy, Debug)]
struct WavePiece {
    ds: f32,
    xa: f32,
    xb: f32,
    m: f32,
    h: f32,
}

/// ∫ ds/√(ξ(s)² + hh²) over one nonempty piece, hh = √(h² + ε_F²), ρ = √(ξ² + hh²); the three
/// cases (see the module docs) pick one log1p argument. ρ_a, ρ_b (and hh where the closest
/// approach is inside) are at least F ≥ 2⁻⁶⁰, so no division whose result is used is by 0.
fn wave_piece_integral(p: &WavePiece, hh: f32) -> f32 {
    let h2 = hh * hh;
    let ra = (p.xa * p.xa + h2).sqrt();
    let rb = (p.xb * p.xb + h2).sqrt();
    let sr = ra + rb;
    let mds = p.m * p.ds;
    if mds <= WAVE_LINEAR_TAU * sr {
        return 2.0 * p.ds / sr;
    }
    let neg = p.xa < 0.0 && p.xb <= 0.0;
    let (xa, xb, r0) = if neg { (-p.xb, -p.xa, rb) } else { (p.xa, p.xb, ra) };
    let arg = if xa >= 0.0 {
        // Both ends on one side (the negative side mirrored onto the positive one).
        mds * (sr + xa + xb) / (sr * (xa + r0))
    } else {
        // ξ_a < 0 < ξ_b: y = e^asinh(x/hh) − 1 for x = −ξ_a and ξ_b, the sum of the two asinh as
        // one log1p of (1 + y_a)(1 + y_b) − 1.
        let (ha, hb) = (hh + ra, hh + rb);
        let ya = -p.xa * (ha - p.xa) / (hh * ha);
        let yb = p.xb * (hb + p.xb) / (hh * hb);
        ya + yb + ya * yb
    };
    log1p_f32(arg) / if p.m > 0.0 { p.m } else { 1.0 }
}

/// A piece's share of the clamp: S² (its larger end distance², with ε) and d² (its nearest
/// distance², without ε); neutral values for an empty piece.
fn wave_piece_smax2(p: &WavePiece, e2: f32) -> f32 {
    if p.ds > 0.0 {
        (p.xa * p.xa).max(p.xb * p.xb) + p.h * p.h + e2
    } else {
        0.0
    }
}

fn wave_piece_dmin2(p: &WavePiece) -> f32 {
    let xn = if p.xa > 0.0 {
        p.xa
    } else if p.xb < 0.0 {
        -p.xb
    } else {
        0.0
    };
    if p.ds > 0.0 {
        xn * xn + p.h * p.h
    } else {
        HADOU_BIG
    }
}

/// The clamp's ε_F² for a term (see `energy_wave`'s module docs) from its S² and d².
fn wave_core2(smax2: f32, dmin2: f32, e2: f32, l: f32) -> f32 {
    let scale = if smax2 > 0.0 { smax2.sqrt() } else { l };
    let fl = (WAVE_CLAMP_RATIO * scale).max(WAVE_CLAMP_MIN);
    e2.max(fl * fl - dmin2)
}

fn wave_piece_term(p: &WavePiece, core2: f32) -> f32 {
    if p.ds > 0.0 {
        wave_piece_integral(p, (p.h * p.h + core2).sqrt())
    } else {
        0.0
    }
}

/// The sphere term: one piece.
fn wave_term1(p: &WavePiece, eps: f32, l: f32) -> f32 {
    let e2 = eps * eps;
    let core2 = wave_core2(wave_piece_smax2(p, e2), wave_piece_dmin2(p), e2, l);
    wave_piece_term(p, core2)
}

/// The line term: its three pieces share the clamp.
fn wave_term3(p0: &WavePiece, p1: &WavePiece, p2: &WavePiece, eps: f32, l: f32) -> f32 {
    let e2 = eps * eps;
    let smax2 = wave_piece_smax2(p0, e2).max(wave_piece_smax2(p1, e2)).max(wave_piece_smax2(p2, e2));
    let dmin2 = wave_piece_dmin2(p0).min(wave_piece_dmin2(p1)).min(wave_piece_dmin2(p2));
    if dmin2 == HADOU_BIG {
        return 0.0;
    }
    let core2 = wave_core2(smax2, dmin2, e2, l);
    wave_piece_term(p0, core2) + wave_piece_term(p1, core2) + wave_piece_term(p2, core2)
}

/// clamp(num/den, 0, L) as a normalized double-float, for a double-float den ≥ 0: 0 when
/// num ≤ 0, else s = num/den refined by one Newton step on the exact residual num − s·den, L when
/// that reaches L or is not finite (den 0, or flushed to 0 on the GPU). The step puts the split
/// where q = 0 (or q = ℓ) to ~2⁻⁴⁶ relative: an f32 split point (off by up to half an ulp of s,
/// which can be comparable to the clamp floor F of a ray grazing M) would integrate the wrong
/// formula between the true and the rounded crossing. An out-of-range s is replaced by 2L
/// before the step, so the step stays finite (its inputs below 2¹¹⁵).
fn wave_crossing(num: f32, den: Df, l: f32) -> Df {
    if num <= 0.0 {
        return [0.0, 0.0];
    }
    let mut s = num / den[0];
    if !(s >= 0.0 && s < 2.0 * l) {
        s = 2.0 * l;
    }
    let r = hadou_df_add_round([num, 0.0], hadou_df_neg(hadou_df_mul(s, den)));
    let t = hadou_fast_two_sum(s, r / den[0]);
    if t[0] < l || (t[0] == l && t[1] <= 0.0) {
        t
    } else {
        [l, 0.0]
    }
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
    let zero: Df = [0.0, 0.0];
    let end: Df = [l, 0.0];
    let ray = wave_ray(g, u);
    // The sphere term: one piece, centre M.
    let cm = wave_centre_point(&ray, q0, r);
    let xm0 = wave_xi0(&cm);
    let xml = wave_xi(&cm, end);
    let sphere = wave_term1(&WavePiece { ds: l, xa: xm0, xb: xml, m: cm.m, h: cm.h }, eps, l);
    // The line term: behind M (q < 0), along the beam, past the tip (q > ℓ). sm, st: where the
    // ray crosses q = 0 and q = ℓ (double-floats). Along +D (u_D ≥ 0) the pieces are [0, sm],
    // [sm, st], [st, L]; against it [sm, L], [st, sm], [0, st].
    let fwd = ray.ud[0] >= 0.0;
    let aud = if fwd { ray.ud } else { hadou_df_neg(ray.ud) };
    let sg = if fwd { -1.0 } else { 1.0 };
    let mut sm = wave_crossing(sg * q0, aud, l);
    let mut st = if finite {
        wave_crossing(sg * qt, aud, l)
    } else if fwd {
        end
    } else {
        zero
    };
    let smax = hadou_df_max(sm, st);
    if fwd {
        st = smax;
    } else {
        sm = smax;
    }
    let xms = wave_xi(&cm, sm);
    let piece = |ds, xa, xb, c: &WaveCentre| WavePiece { ds, xa, xb, m: c.m, h: c.h };
    let pb = if fwd {
        piece(hadou_df_round(sm), xm0, xms, &cm)
    } else {
        piece(hadou_df_span(sm, end), xms, xml, &cm)
    };
    let ca = wave_centre_axis(&ray, r);
    let (xas, xat) = (wave_xi(&ca, sm), wave_xi(&ca, st));
    let pc = if fwd {
        piece(hadou_df_span(sm, st), xas, xat, &ca)
    } else {
        piece(hadou_df_span(st, sm), xat, xas, &ca)
    };
    let ct = wave_centre_point(&ray, qt, r);
    let xts = wave_xi(&ct, st);
    let pt = if fwd {
        piece(hadou_df_span(st, end), xts, wave_xi(&ct, end), &ct)
    } else {
        piece(hadou_df_round(st), wave_xi0(&ct), xts, &ct)
    };
    let line = wave_term3(&pb, &pc, &pt, eps, l);
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
