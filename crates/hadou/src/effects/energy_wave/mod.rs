//! The energy wave (seed 004) in f64: the density, its closed-form integral along a ray, an
//! independent adaptive quadrature of the same integral, and the ray-marching baseline. The f32
//! twin of the GPU code is `energy_wave_f32.rs` (and `shaders/common/energy_wave.glsl`).
//!
//! # Model
//! One wave: origin M, unit direction D, sphere strength a, line strength b, core radius ε ≥ 0 and
//! beam length ℓ > 0 (ℓ = ∞ allowed). With k(r) = 1/√(r² + ε²),
//!
//! E(P) = a·k(|P − M|) + b·k(dist(P, segment [M, M + ℓD])).
//!
//! With ℓ = ∞ and ε = 0 this is the seed's E = S + C: the cylinder term on the D side of the plane
//! I through M, b/|P − M| behind it (the seed's eq. 5 reads R(t) = Qt + S). Past the tip
//! T = M + ℓD the line term is b·k(|P − T|). For a ray P(s) = O + s·u the integral is
//! H = ∫₀ᴸ E(O + s·u) ds; `u` need not be exactly unit (the formulas use m = |u|), so an f32
//! direction is integrated exactly as given.
//!
//! # Closed form
//! Everything is written in the frame of the beam: a point P has the axial coordinate
//! q = (P − M)·D and the perpendicular offset p⊥ = D × (P − M) (|p⊥| = distance to the axis).
//! Along the ray both are linear, q(s) = q₀ + s·u_D and p⊥(s) = R + s·c, with the camera's
//! q₀ = (O − M)·D and R = D × (O − M) and the ray's u_D = u·D and c = D × u. Then
//! |P − M|² = q² + |p⊥|², |P − T|² = (q − ℓ)² + |p⊥|² and the distance to the beam is |p⊥| on
//! 0 ≤ q ≤ ℓ, so the three distances share one description and stay continuous across the plane
//! crossings even for rounded inputs.
//!
//! [0, L] is split where the ray crosses the planes q = 0 and q = ℓ. Every piece is
//! ∫ ds/√(|P₀ + s·V|² + ε²) for a line P₀ + s·V: (q₀, R) + s·(u_D, c) in 4D for M, (q₀ − ℓ, R) +
//! s·(u_D, c) for T, R + s·c for the axis. With m = |V|, ξ(s) = (P₀·V + s·|V|²)/m (signed progress
//! past the closest approach), h = |P₀ ∧ V|/m (closest-approach distance; in 3D |P₀ × V|/m),
//! H = √(h² + ε²) and ρ = √(ξ² + H²): ∫ = (asinh(ξ_b/H) − asinh(ξ_a/H))/m, evaluated without
//! cancellation:
//! - both ends ξ ≥ 0: log1p(m·Δs·(1 + (ξ_a + ξ_b)/(ρ_a + ρ_b))/(ξ_a + ρ_a))/m (H cancels; it tends
//!   to Δs/ρ as m → 0); both ends ξ ≤ 0: the mirror image;
//! - ξ_a < 0 < ξ_b: (asinh(ξ_b/H) + asinh(−ξ_a/H))/m, each as log1p(x + x²/(1 + √(1 + x²)));
//! - m·Δs ≤ τ·(ρ_a + ρ_b) (m = 0 included: a ray parallel to D, for the axis): the linear form
//!   2Δs/(ρ_a + ρ_b), whose relative error is below τ² (τ = 2⁻²⁶ here, 2⁻¹² in f32).
//!
//! The distances are never differences of squares: ρ is a sum of squares of ξ and H, and h comes
//! from a wedge (cross) product (DESIGN.md, "Energy wave").
//!
//! # Clamp (ε = 0 singularities)
//! A ray through M, through T or along the axis diverges when ε = 0. Rule, applied per term (the
//! sphere term; the line term with all its pieces): let S be the largest end distance
//! ρ = √(ξ² + h² + ε²) over the term's pieces of nonzero length (S = L when all are 0, which
//! needs a ray along the axis with ε = 0), F = max(2⁻²⁰·S, 2⁻⁶⁰), and d the smallest distance
//! (without ε) the ray reaches on those pieces: √(ξ*² + h²) per piece, ξ* = 0 when its closest
//! approach lies inside it, else the ξ of its nearer end. The term is integrated with the core
//! radius ε_F = √(max(ε², F² − d²)), so every distance on every piece (ρ_a, ρ_b, and H where the
//! closest approach is inside) is at least F; nothing changes when √(d² + ε²) ≥ F. One ε_F per
//! term keeps the clamped integrand continuous across the plane crossings, and d (unlike the
//! pieces' h) is continuous when a crossing moves past a clip end. The result is always finite;
//! a ray exactly along the axis with ε = 0 and the camera on it gives b·Δs/F for that piece. The
//! f32 twin and the GLSL apply the same rule, so CPU and GPU agree even there.
//!
//! # Valid range
//! Finite inputs, L ≥ 0 (anything else integrates to 0; L above 1e18, +∞ included, counts as
//! 1e18), lengths below 1e18 (their squares must stay finite in f32 on the GPU).

// `!(x > y)` on purpose: false for NaN as well, like the GLSL it mirrors.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod effect;
pub mod file;
pub mod tolerance;

pub use effect::{EnergyWave, Waves};

use glam::DVec3;

/// One energy wave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveParams {
    /// M: the sphere centre and the start of the beam.
    pub origin: DVec3,
    /// D: unit direction of the beam.
    pub direction: DVec3,
    /// Sphere strength a ≥ 0.
    pub a: f64,
    /// Line strength b ≥ 0.
    pub b: f64,
    /// Core radius ε ≥ 0 of k(r) = 1/√(r² + ε²).
    pub core: f64,
    /// Beam length ℓ > 0; `f64::INFINITY` for an endless beam.
    pub length: f64,
}

/// The clamp's relative floor, 2⁻²⁰ (see the module docs).
pub const CLAMP_RATIO: f64 = 9.5367431640625e-7;
/// The clamp's absolute floor, 2⁻⁶⁰ world units: keeps every square a normal f32.
pub const CLAMP_MIN: f64 = 8.673617379884035e-19;
/// |v| at or below this (2⁻⁶⁰) counts as 0: the piece's distance is constant.
const PARALLEL_MIN: f64 = 8.673617379884035e-19;
/// Linear form when m·Δs ≤ τ·(ρ_a + ρ_b): relative error below τ² = 2⁻⁵².
const LINEAR_TAU: f64 = 1.4901161193847656e-8;
/// L is clamped to this (as on the GPU, where squares must stay finite in f32).
pub const MAX_LENGTH: f64 = 1e18;

/// Everything a ray integral needs about one wave and one camera, camera-relative, in the frame
/// of the beam. The f32 twin rounds exactly these numbers once
/// ([`crate::effects::energy_wave_f32::gpu_wave`]); a frame widened back from them is the fair f64
/// reference for the GPU. O − M = q₀·D + R × D and O − T = (q₀ − ℓ)·D + R × D.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveFrame {
    /// D.
    pub d: DVec3,
    /// q₀ = (O − M)·D, the camera's axial coordinate.
    pub q0: f64,
    /// R = D × (O − M): the camera's offset from the axis, turned a quarter about D.
    pub r: DVec3,
    /// q₀ − ℓ = (O − T)·D (zero when the beam is endless).
    pub qt: f64,
    pub a: f64,
    pub b: f64,
    pub core: f64,
    /// ℓ < ∞.
    pub finite: bool,
}

/// The camera-relative quantities of `w` seen from `camera`, in f64.
pub fn frame(w: &WaveParams, camera: DVec3) -> WaveFrame {
    let om = camera - w.origin;
    let q0 = om.dot(w.direction);
    let finite = w.length.is_finite();
    WaveFrame {
        d: w.direction,
        q0,
        r: w.direction.cross(om),
        qt: if finite { q0 - w.length } else { 0.0 },
        a: w.a,
        b: w.b,
        core: w.core,
        finite,
    }
}

/// E(p) with separate core radii for the two terms (the clamp's effective cores), M-relative.
fn density_rel(w: &WaveParams, pm: DVec3, core_sphere: f64, core_line: f64) -> f64 {
    let q = pm.dot(w.direction);
    let line = if q <= 0.0 {
        pm.length()
    } else if q >= w.length {
        (pm - w.length * w.direction).length()
    } else {
        (pm - q * w.direction).length()
    };
    w.a / (pm.length_squared() + core_sphere * core_sphere).sqrt()
        + w.b / (line * line + core_line * core_line).sqrt()
}

/// E(P). Unclamped: +∞ on M or on the segment when ε = 0.
pub fn density(w: &WaveParams, p: DVec3) -> f64 {
    density_rel(w, p - w.origin, w.core, w.core)
}

/// The two terms of H before their strengths, and the core radii the clamp used for them
/// (equal to ε unless the clamp acted).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineIntegral {
    /// ∫ k(|P − M|) ds.
    pub sphere: f64,
    /// ∫ k(dist(P, segment)) ds.
    pub line: f64,
    /// ε_F of the sphere term.
    pub sphere_core: f64,
    /// ε_F of the line term.
    pub line_core: f64,
}

/// A line P₀ + s·V seen from its centre: ξ(s) = (A + s·B)/m, closest distance h.
#[derive(Clone, Copy, Debug)]
struct Centre {
    a: f64,
    b: f64,
    m: f64,
    h: f64,
}

/// The 4D line (q, R) + s·(u_D, c): centre M with q = q₀, T with q = q₀ − ℓ, the axis with
/// q = u_D = 0.
fn centre(q: f64, r: DVec3, ud: f64, c: DVec3) -> Centre {
    let b = ud * ud + c.dot(c);
    let m = b.sqrt();
    if !(m > PARALLEL_MIN) {
        return Centre { a: 0.0, b: 0.0, m: 0.0, h: (q * q + r.dot(r)).sqrt() };
    }
    // |P₀ ∧ V|² = |q·c − u_D·R|² + |R × c|².
    let (w1, w2) = (q * c - ud * r, r.cross(c));
    Centre { a: q * ud + r.dot(c), b, m, h: (w1.dot(w1) + w2.dot(w2)).sqrt() / m }
}

fn xi(c: &Centre, s: f64) -> f64 {
    if c.m > 0.0 {
        (c.a + s * c.b) / c.m
    } else {
        0.0
    }
}

/// One piece [s0, s1] of a term with ξ at its ends.
#[derive(Clone, Copy, Debug)]
struct Piece {
    s0: f64,
    s1: f64,
    xa: f64,
    xb: f64,
    m: f64,
    h: f64,
}

const EMPTY: Piece = Piece { s0: 0.0, s1: 0.0, xa: 0.0, xb: 0.0, m: 0.0, h: 0.0 };

fn piece(c: &Centre, s0: f64, s1: f64) -> Piece {
    if s1 > s0 {
        Piece { s0, s1, xa: xi(c, s0), xb: xi(c, s1), m: c.m, h: c.h }
    } else {
        EMPTY
    }
}

fn asinh_pos(x: f64) -> f64 {
    (x + x * x / (1.0 + (1.0 + x * x).sqrt())).ln_1p()
}

/// ∫ ds/√(ξ(s)² + hh²) over one piece, hh = √(h² + ε_F²). The clamp makes every distance on
/// the piece, ρ_a, ρ_b and hh where the closest approach is inside, at least F > 0.
fn piece_integral(p: &Piece, hh: f64) -> f64 {
    let ds = p.s1 - p.s0;
    let ra = (p.xa * p.xa + hh * hh).sqrt();
    let rb = (p.xb * p.xb + hh * hh).sqrt();
    if p.m * ds <= LINEAR_TAU * (ra + rb) {
        return 2.0 * ds / (ra + rb);
    }
    let v = if p.xa >= 0.0 {
        (p.m * ds * (1.0 + (p.xa + p.xb) / (ra + rb)) / (p.xa + ra)).ln_1p()
    } else if p.xb <= 0.0 {
        (p.m * ds * (1.0 - (p.xa + p.xb) / (ra + rb)) / (rb - p.xb)).ln_1p()
    } else {
        asinh_pos(p.xb / hh) + asinh_pos(-p.xa / hh)
    };
    v / p.m
}

/// One term (its pieces share the clamp): the integral of k and the core radius used.
fn term(pieces: &[Piece; 3], core: f64, l: f64) -> (f64, f64) {
    let e2 = core * core;
    let mut smax2 = 0.0f64;
    let mut dmin2 = f64::MAX;
    for p in pieces.iter().filter(|p| p.s1 > p.s0) {
        let h2 = p.h * p.h;
        smax2 = smax2.max(p.xa * p.xa + h2 + e2).max(p.xb * p.xb + h2 + e2);
        // ξ of the piece's point nearest its centre: 0 when the closest approach is inside.
        let xn = if p.xa > 0.0 {
            p.xa
        } else if p.xb < 0.0 {
            -p.xb
        } else {
            0.0
        };
        dmin2 = dmin2.min(xn * xn + h2);
    }
    if dmin2 == f64::MAX {
        return (0.0, core);
    }
    let scale = if smax2 > 0.0 { smax2.sqrt() } else { l };
    let fl = (CLAMP_RATIO * scale).max(CLAMP_MIN);
    let core2 = e2.max(fl * fl - dmin2);
    let mut sum = 0.0;
    for p in pieces.iter().filter(|p| p.s1 > p.s0) {
        sum += piece_integral(p, (p.h * p.h + core2).sqrt());
    }
    (sum, core2.sqrt())
}

/// clamp(num/den, 0, L) for den ≥ 0, without dividing when the answer is an end.
fn crossing(num: f64, den: f64, l: f64) -> f64 {
    if num <= 0.0 {
        0.0
    } else if num >= l * den {
        l
    } else {
        (num / den).min(l)
    }
}

/// The line term's pieces along [0, L]: behind M (q < 0), along the beam, past the tip.
fn line_spans(f: &WaveFrame, ud: f64, l: f64) -> [(f64, f64); 3] {
    if ud >= 0.0 {
        let s0 = crossing(-f.q0, ud, l);
        let s1 = if f.finite { crossing(-f.qt, ud, l).max(s0) } else { l };
        [(0.0, s0), (s0, s1), (s1, l)]
    } else {
        let s1 = if f.finite { crossing(f.qt, -ud, l) } else { 0.0 };
        let s0 = crossing(f.q0, -ud, l).max(s1);
        [(s0, l), (s1, s0), (0.0, s1)]
    }
}

/// The closed form's two terms (see the module docs), from a frame.
pub fn line_integral_parts(f: &WaveFrame, u: DVec3, l: f64) -> LineIntegral {
    if !(l > 0.0) {
        return LineIntegral { sphere: 0.0, line: 0.0, sphere_core: f.core, line_core: f.core };
    }
    let l = l.min(MAX_LENGTH);
    let (ud, c) = (u.dot(f.d), f.d.cross(u));
    let cm = centre(f.q0, f.r, ud, c);
    let (sphere, sphere_core) = term(&[piece(&cm, 0.0, l), EMPTY, EMPTY], f.core, l);
    let [behind, beam, tip] = line_spans(f, ud, l);
    let pb = piece(&cm, behind.0, behind.1);
    let pc = if beam.1 > beam.0 { piece(&centre(0.0, f.r, 0.0, c), beam.0, beam.1) } else { EMPTY };
    let pt = if tip.1 > tip.0 { piece(&centre(f.qt, f.r, ud, c), tip.0, tip.1) } else { EMPTY };
    let (line, line_core) = term(&[pb, pc, pt], f.core, l);
    LineIntegral { sphere, line, sphere_core, line_core }
}

/// H = ∫₀ᴸ E(O + s·u) ds in closed form, from a frame.
pub fn line_integral_frame(f: &WaveFrame, u: DVec3, l: f64) -> f64 {
    let p = line_integral_parts(f, u, l);
    f.a * p.sphere + f.b * p.line
}

/// H = ∫₀ᴸ E(origin + s·u) ds in closed form (the f64 reference of `wave_line_integral`).
pub fn line_integral(w: &WaveParams, origin: DVec3, u: DVec3, l: f64) -> f64 {
    line_integral_frame(&frame(w, origin), u, l)
}

// Gauss–Kronrod 7/15 (QUADPACK qk15): Kronrod abscissae, Kronrod weights, Gauss weights of the
// abscissae 1, 3, 5, 7 (QUADPACK's digits, kept).
#[allow(clippy::excessive_precision)]
const XGK: [f64; 8] = [
    0.991455371120812639206854697526329,
    0.949107912342758524526189684047851,
    0.864864423359769072789712788640926,
    0.741531185599394439863864773280788,
    0.586087235467691130294144845693013,
    0.405845151377397166906606412076961,
    0.207784955007898467600689403773245,
    0.0,
];
#[allow(clippy::excessive_precision)]
const WGK: [f64; 8] = [
    0.022935322010529224963732008058970,
    0.063092092629978553290700663189204,
    0.104790010322250183839876322541518,
    0.140653259715525918745189590510238,
    0.169004726639267902826583426598550,
    0.190350578064785409913256402421014,
    0.204432940075298892414161999234649,
    0.209482141084727828012999174891714,
];
#[allow(clippy::excessive_precision)]
const WG: [f64; 4] = [
    0.129484966168869693270611432679082,
    0.279705391489276667901467771423780,
    0.381830050505118944950369775488975,
    0.417959183673469387755102040816327,
];

/// (Kronrod estimate, |Kronrod − Gauss|) on [a, b].
fn gk15(f: &impl Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let fc = f(c);
    let mut k = WGK[7] * fc;
    let mut g = WG[3] * fc;
    for j in 0..7 {
        let (f1, f2) = (f(c - h * XGK[j]), f(c + h * XGK[j]));
        k += WGK[j] * (f1 + f2);
        if j % 2 == 1 {
            g += WG[j / 2] * (f1 + f2);
        }
    }
    (k * h, ((k - g) * h).abs())
}

/// An interval of the adaptive quadrature, ordered by its error estimate.
struct Part {
    a: f64,
    b: f64,
    value: f64,
    err: f64,
}

impl PartialEq for Part {
    fn eq(&self, other: &Self) -> bool {
        self.err == other.err
    }
}
impl Eq for Part {}
impl PartialOrd for Part {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Part {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.err.total_cmp(&other.err)
    }
}

/// Globally adaptive GK 7/15 over the breakpoints: bisects the interval with the largest error
/// estimate until the summed estimate is below `rel`·|total| (at most 100 000 bisections).
fn adaptive(f: &impl Fn(f64) -> f64, breaks: &[f64], rel: f64) -> f64 {
    let part = |a: f64, b: f64| {
        let (value, err) = gk15(f, a, b);
        Part { a, b, value, err }
    };
    let mut heap: std::collections::BinaryHeap<Part> =
        breaks.windows(2).filter(|w| w[1] > w[0]).map(|w| part(w[0], w[1])).collect();
    let mut done = 0.0; // intervals at f64 resolution, taken out of the heap
    let (mut total, mut err) =
        (heap.iter().map(|p| p.value).sum::<f64>(), heap.iter().map(|p| p.err).sum::<f64>());
    for _ in 0..100_000 {
        if err <= rel * total.abs() {
            // Confirm with fresh sums (the running ones drift).
            total = done + heap.iter().map(|p| p.value).sum::<f64>();
            err = heap.iter().map(|p| p.err).sum();
            if err <= rel * total.abs() {
                break;
            }
        }
        let Some(p) = heap.pop() else { break };
        let c = 0.5 * (p.a + p.b);
        if !(c > p.a && c < p.b) {
            done += p.value;
            err -= p.err;
            continue;
        }
        let (l, r) = (part(p.a, c), part(c, p.b));
        total += l.value + r.value - p.value;
        err += l.err + r.err - p.err;
        heap.push(l);
        heap.push(r);
    }
    done + heap.iter().map(|p| p.value).sum::<f64>()
}

/// Quadrature of the model with the given core radii per term.
fn quadrature_cores(
    w: &WaveParams,
    origin: DVec3,
    u: DVec3,
    l: f64,
    core_sphere: f64,
    core_line: f64,
) -> f64 {
    if !(l > 0.0) {
        return 0.0;
    }
    let om = origin - w.origin;
    let d = w.direction;
    let uu = u.dot(u);
    let mut breaks = vec![0.0, l, -om.dot(u) / uu];
    let (r, c) = (d.cross(om), d.cross(u));
    if c.dot(c) > 0.0 {
        breaks.push(-r.dot(c) / c.dot(c));
    }
    let (q0, ud) = (om.dot(d), u.dot(d));
    if ud != 0.0 {
        breaks.push(-q0 / ud);
        if w.length.is_finite() {
            breaks.push((w.length - q0) / ud);
            breaks.push(-(om - w.length * d).dot(u) / uu);
        }
    }
    breaks.retain(|s| s.is_finite() && *s >= 0.0 && *s <= l);
    breaks.sort_by(f64::total_cmp);
    breaks.dedup();
    let f = |s: f64| density_rel(w, om + s * u, core_sphere, core_line);
    adaptive(&f, &breaks, 1e-13)
}

/// H by adaptive Gauss–Kronrod 7/15 quadrature of [`density`], independent of the closed form:
/// split at the closest approaches to M, to the axis and to the tip, the plane crossings q = 0 and
/// q = ℓ, and the clip distance; target 1e-12 relative. Unclamped: diverges (returns a huge or
/// infinite value) where the closed form clamps.
pub fn line_integral_quadrature(w: &WaveParams, origin: DVec3, u: DVec3, l: f64) -> f64 {
    quadrature_cores(w, origin, u, l, w.core, w.core)
}

/// E along the ray from a frame, with the distance floored at `fl` (the ray-march twin).
fn density_frame(f: &WaveFrame, c: DVec3, ud: f64, s: f64, fl: f64) -> f64 {
    let (rm, rl) = sample_distances(f, c, ud, s, fl);
    f.a / rm + f.b / rl
}

/// A ray-march sample's two softened distances at s along the ray (c = D × u, ud = u·D), each
/// floored at `fl`: to M, √(|P − M|² + ε²), and to the beam, √(dist(P, beam)² + ε²).
pub fn sample_distances(f: &WaveFrame, c: DVec3, ud: f64, s: f64, fl: f64) -> (f64, f64) {
    let e2 = f.core * f.core;
    let q = f.q0 + s * ud;
    let pc = f.r + s * c;
    let r2 = pc.dot(pc);
    let rm = (q * q + r2 + e2).sqrt().max(fl);
    let qt = f.qt + s * ud;
    let dl2 = if q <= 0.0 {
        q * q + r2
    } else if f.finite && qt >= 0.0 {
        qt * qt + r2
    } else {
        r2
    };
    let rl = (dl2 + e2).sqrt().max(fl);
    (rm, rl)
}

/// The ray-march baseline from a frame: `steps` samples at s_i = (i + offset)·L/N, each weighted
/// L/N (offset 0.5: the midpoint rule). Distances are floored at max(2⁻²⁰·L/N, 2⁻⁶⁰) so a sample
/// exactly on a singularity stays finite.
pub fn raymarch_frame(f: &WaveFrame, u: DVec3, l: f64, steps: u32, offset: f64) -> f64 {
    if !(l > 0.0) || steps == 0 {
        return 0.0;
    }
    let ds = l.min(MAX_LENGTH) / steps as f64;
    let fl = (CLAMP_RATIO * ds).max(CLAMP_MIN);
    let c = f.d.cross(u);
    let ud = u.dot(f.d);
    let mut sum = 0.0;
    for i in 0..steps {
        sum += density_frame(f, c, ud, (i as f64 + offset) * ds, fl);
    }
    sum * ds
}

/// The f64 twin of the GPU ray-march baseline `wave_raymarch`.
pub fn raymarch(w: &WaveParams, origin: DVec3, u: DVec3, l: f64, steps: u32, offset: f64) -> f64 {
    raymarch_frame(&frame(w, origin), u, l, steps, offset)
}

/// What a wave adds to HDR per unit of colour × intensity for an integral `h`: the energy above
/// its `cutoff` (`[[wave]] cutoff`; 0 gives `h` itself). The twin of the energy pass's emission.
pub fn emitted(h: f64, cutoff: f64) -> f64 {
    (h - cutoff).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::testing::Rng;

    fn wave(rng: &mut Rng) -> WaveParams {
        WaveParams {
            origin: DVec3::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0), rng.range(-5.0, 5.0)),
            direction: rng.unit(),
            a: rng.range(0.0, 10.0),
            b: rng.range(0.0, 10.0),
            core: if rng.next() < 0.3 { 0.0 } else { rng.range(0.0, 2.0) },
            length: if rng.next() < 0.5 { f64::INFINITY } else { rng.range(0.1, 30.0) },
        }
    }

    /// Closed form vs the quadrature of the (clamped) model: relative error.
    fn check(w: &WaveParams, o: DVec3, u: DVec3, l: f64) -> f64 {
        let f = frame(w, o);
        let p = line_integral_parts(&f, u, l);
        let closed = w.a * p.sphere + w.b * p.line;
        let quad = quadrature_cores(w, o, u, l, p.sphere_core, p.line_core);
        assert!(closed.is_finite() && closed >= 0.0, "{closed}");
        if quad == 0.0 {
            assert_eq!(closed, 0.0);
            return 0.0;
        }
        (closed - quad).abs() / quad
    }

    #[test]
    fn closed_form_matches_quadrature_on_random_rays() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut worst = 0.0f64;
        for _ in 0..3000 {
            let w = wave(&mut rng);
            let o = w.origin + rng.unit() * rng.range(0.0, 40.0);
            let u = rng.unit();
            let l = rng.range(0.0, 80.0);
            let e = check(&w, o, u, l);
            worst = worst.max(e);
            assert!(e <= 1e-10, "rel {e:e}: {w:?} o={o} u={u} l={l}");
        }
        eprintln!("random rays: worst closed-form vs quadrature {worst:.2e}");
    }

    /// Hard rays: closed form vs quadrature ≤ 1e-10 relative, worst per case printed. Where the
    /// clamp acts (ε = 0 and a ray within 2⁻²⁰·S of M or the axis), the quadrature integrates the
    /// clamped model (the effective cores `LineIntegral::*_core`); the quadrature also needs the
    /// closest approaches as breakpoints (peaks of width h down to 1e-7·|O − M|) and the plane
    /// crossings (kinks). A ray exactly along the axis with ε = 0 is infinite unclamped and is
    /// checked against its closed value in `ray_exactly_through_m_is_clamped_and_finite`.
    #[test]
    fn closed_form_matches_quadrature_on_hard_rays() {
        let mut rng = Rng(7);
        let mut table: std::collections::BTreeMap<String, f64> = Default::default();
        let mut record = |name: String, w: &WaveParams, o: DVec3, u: DVec3, l: f64| {
            let e = check(w, o, u, l);
            assert!(e <= 1e-10, "{name}: rel {e:e}: {w:?} o={o} u={u} l={l}");
            let worst = table.entry(name).or_insert(0.0);
            *worst = worst.max(e);
        };
        for i in 0..60 {
            let mut w = wave(&mut rng);
            w.core = [0.0, 1e-3, 0.5][i % 3];
            let dist = [1.0, 100.0, 1e4][(i / 3) % 3];
            let n = rng.unit();
            for k in 1..=7 {
                let o = w.origin + rng.unit() * dist;
                let v = (w.origin - o).normalize();
                let target = w.origin + (n - n.dot(v) * v).normalize() * (10f64.powi(-k) * dist);
                let l = 2.0 * dist * rng.range(0.3, 1.0);
                record(format!("near M, delta 1e-{k}"), &w, o, (target - o).normalize(), l);
            }
            let axis = [DVec3::X, DVec3::Y, DVec3::Z][i % 3];
            record("through M exactly".into(), &w, w.origin - axis * dist, axis, 2.0 * dist);
            record("camera at M".into(), &w, w.origin, rng.unit(), dist);
            let e1 = (n - n.dot(w.direction) * w.direction).normalize();
            for k in 0..=6 {
                // f64 itself resolves a perpendicular distance p only to ~1e-16·|P − M|: keep
                // |P − M| ≤ 1e5·p so that both sides are good to 1e-11.
                let perp = 10f64.powi(-k);
                let o = w.origin + e1 * perp + w.direction * rng.range(-1.0, 1.0) * (1e4 * perp).min(dist);
                let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
                let l = (1e5 * perp).min(dist);
                record(format!("(anti-)parallel to D, perp 1e-{k}"), &w, o, sign * w.direction, l);
            }
            let u = (-e1 + w.direction.cross(e1) * rng.range(-0.5, 0.5)).normalize();
            record("in the plane I".into(), &w, w.origin + e1 * dist, u, 2.0 * dist);
            let q = if w.length.is_finite() { w.length * 0.5 } else { dist };
            record(
                "camera inside the beam".into(),
                &w,
                w.origin + w.direction * q + e1 * 1e-3,
                rng.unit(),
                dist,
            );
            let o = w.origin + rng.unit() * dist;
            let u = rng.unit();
            let s = -(o - w.origin).dot(w.direction) / u.dot(w.direction);
            if s > 0.0 {
                record("clip at the plane I".into(), &w, o, u, s);
            }
            if w.length.is_finite() {
                let t = w.origin + w.length * w.direction;
                let o = t + rng.unit() * dist;
                record(
                    "beam tip inside the clip".into(),
                    &w,
                    o,
                    (t + e1 * 1e-3 * dist - o).normalize(),
                    2.0 * dist,
                );
            }
            let o = w.origin + rng.unit() * 1e5;
            let t = w.origin + w.direction * rng.range(0.0, 10.0) + rng.unit() * rng.range(0.01, 1.0);
            record("camera 1e5 from M".into(), &w, o, (t - o).normalize(), 2e5);
        }
        for (name, worst) in &table {
            eprintln!("closed form vs quadrature, {name:<36} worst {worst:.2e}");
        }
    }

    #[test]
    fn ray_exactly_through_m_is_clamped_and_finite() {
        let w = WaveParams {
            origin: DVec3::ZERO,
            direction: DVec3::Z,
            a: 1.0,
            b: 1.0,
            core: 0.0,
            length: f64::INFINITY,
        };
        let o = DVec3::new(-10.0, 0.0, 0.0);
        let p = line_integral_parts(&frame(&w, o), DVec3::X, 20.0);
        // h = 0: the sphere core becomes 2⁻²⁰·max(|O − M|, |P(L) − M|) = 2⁻²⁰·10.
        assert_eq!(p.sphere_core, CLAMP_RATIO * 10.0);
        // asinh(10/F)·2 with F = 2⁻²⁰·10.
        let expect = 2.0 * (2f64.powi(20)).asinh();
        assert!((p.sphere - expect).abs() < 1e-13 * expect, "{} {}", p.sphere, expect);
        assert!(p.line.is_finite() && p.line > 0.0);
        // Camera at M, L = 0: a point.
        assert_eq!(line_integral(&w, DVec3::ZERO, DVec3::X, 0.0), 0.0);
        // Along the axis with the camera on it: b·Δs/F with F = 2⁻²⁰·L.
        let p = line_integral_parts(&frame(&w, DVec3::ZERO), DVec3::Z, 5.0);
        assert!((p.line - 2f64.powi(20)).abs() < 1e-6, "{}", p.line);
    }

    #[test]
    fn density_is_continuous_and_matches_the_seed() {
        let w = WaveParams {
            origin: DVec3::new(1.0, 2.0, 3.0),
            direction: DVec3::new(0.0, 0.6, 0.8),
            a: 2.0,
            b: 3.0,
            core: 0.0,
            length: f64::INFINITY,
        };
        // On the D side: the seed's cylinder term b/√(|P−M|² − ((P−M)·D)²).
        let p = DVec3::new(2.0, 4.0, 7.0);
        let pm = p - w.origin;
        let seed = 2.0 / pm.length() + 3.0 / (pm.length_squared() - pm.dot(w.direction).powi(2)).sqrt();
        assert!((density(&w, p) - seed).abs() < 1e-14 * seed);
        // Behind the plane I: b/|P − M|.
        let p = DVec3::new(2.0, 0.0, 0.0);
        assert!((density(&w, p) - 5.0 / (p - w.origin).length()).abs() < 1e-14);
    }

    #[test]
    fn raymarch_converges_to_the_closed_form() {
        let w = WaveParams {
            origin: DVec3::new(0.5, -0.2, 0.1),
            direction: DVec3::new(1.0, 2.0, 2.0) / 3.0,
            a: 3.0,
            b: 2.0,
            core: 0.4,
            length: 4.0,
        };
        let o = DVec3::new(-3.0, -2.0, 1.0);
        let u = (DVec3::new(4.0, 3.0, 0.5) - o).normalize();
        let exact = line_integral(&w, o, u, 12.0);
        let direct: f64 =
            (0..64).map(|i| density(&w, o + (i as f64 + 0.5) * 12.0 / 64.0 * u)).sum::<f64>() * (12.0 / 64.0);
        assert!((raymarch(&w, o, u, 12.0, 64, 0.5) - direct).abs() < 1e-12 * direct);
        let mut last = f64::MAX;
        for n in [16u32, 64, 256, 1024, 4096] {
            let e = (raymarch(&w, o, u, 12.0, n, 0.5) - exact).abs() / exact;
            assert!(e < last / 10.0, "n = {n}: {e:e} vs {last:e}");
            last = e;
        }
        assert!(last < 1e-6, "{last:e}");
    }
}
