//! Metaballs (seed 000) in f64: the field, its gradient, the seed's ray cast (support-sphere
//! intervals, the one-sphere fast path, Bernstein coefficients and Bézier clipping) and an
//! independent root check. The f32 twin of the GPU code is `metaballs_f32.rs` (and
//! `shaders/common/metaballs.glsl`).
//!
//! # Model
//! A group: threshold T > 0, a kernel, balls {centre cᵢ, support radius Rᵢ > 0, coefficient qᵢ
//! (any sign)} in the group's object space, and a transform M (seed 002; a non-uniform scale makes
//! the balls ellipsoids). With r′ = ‖x − cᵢ‖²/Rᵢ² the surface is F(x) = Σ qᵢ f(r′ᵢ) = T, where f
//! vanishes for r′ ≥ 1 and, on [0, 1],
//! - `wyvill6` (seed eq. 10/11): f(r′) = −4/9 r′³ + 17/9 r′² − 22/9 r′ + 1 (degree 6 in r);
//! - `murakami4` (seed eq. 9): f(r′) = (1 − r′)² (degree 4 in r).
//!
//! Both fall monotonically from 1 at the centre to 0 (with zero slope) at the support sphere, so
//! the field is C¹ along any ray. Inside (F > T) is where the density exceeds the threshold; the
//! normal is −∇F/‖−∇F‖ (seed eq. 5), pointing out of the blob.
//!
//! # Along a ray (object space, unit direction, parameter t′)
//! A ball's support sphere cuts the ray in the chord [t_c − h, t_c + h] with h² = D = Rᵢ² − ρ²
//! (ρ the ray's distance to cᵢ, computed as ‖(cᵢ − o) × d‖, never as a difference of squares).
//! With s ∈ [0, 1] along the chord, r′(s) = 4a s² − 4a s + 1 with **a = D/Rᵢ²** (seed eq. 16; the
//! seed prints D/Rᵢ, but r′ is dimensionless: a = 1 for a chord through the centre, where
//! r′(½) = 1 − a = 0). Substituted into the kernel this is a polynomial of degree 6 in s whose
//! Bernstein coefficients are (seed eq. 19) d₀ = d₁ = d₅ = d₆ = 0, d₂ = d₄ = 16a²/27,
//! d₃ = 8(8a + 5)a²/45; for `murakami4` (seed eq. 20, degree 4: d₂ = 8a²/3) degree-elevated to 6:
//! d₂ = d₄ = 16a²/15, d₃ = 8a²/5, so one clipping routine serves both kernels.
//!
//! # The cast (seed section 2.3)
//! The world ray is taken to object space (`Transform::ray_to_object`, t = t′/‖M⁻¹d‖). The support
//! sphere entries and exits inside [t′_min, t′_max] are sorted; between consecutive ones the set
//! of balls whose support covers the interval is constant, and the field is one polynomial:
//! - no ball: F = 0 < T, no surface;
//! - one ball: the surface is a sphere of radius ρ*·Rᵢ about cᵢ, with ρ*² the root of qᵢ f(r′) = T
//!   in (0, 1) ([`iso_radius`]; ρ* = ½ for wyvill6, q = 1, T = 0.5 — the seed's R/2). A stable
//!   quadratic gives the first crossing inside the interval;
//! - several: each ball's chord coefficients are restricted to the interval by de Casteljau (twice:
//!   [0, s_b], then the right part at s_a/s_b), scaled by qᵢ, summed, and T is subtracted (the
//!   seed's "initialize d to −T"); then Bézier clipping ([`first_root`]).
//!
//! The first interval with a root gives the hit, so roots come nearest first. A camera inside the
//! surface (F > T at t_min) gets the first crossing, the exit, whose normal faces away from it.
//!
//! # Bézier clipping ([`first_root`])
//! The control polygon (k/6, d_k) lies around the curve; the curve can cross zero only where the
//! polygon's convex hull does, [lo, hi] = the hull of the crossings of all control-point pairs of
//! opposite sign. The curve is clipped to [lo, hi] (de Casteljau); when that shrinks the width by
//! less than 30% (hi − lo > 0.7), it is split at its midpoint and the right half pushed on a stack
//! (no recursion), so the left half, and with it the nearest root, is searched first. A part whose
//! control points all share one strict sign holds no root and is dropped. With the noise floor
//! φ = [`FLAT_C`]·ε·S (S = the interval's coefficient scale, max_k Σᵢ|qᵢ d_k| + T: rounding the
//! coefficients leaves errors of a few ε·S), it stops when
//! - the width in α (the interval's parameter) is at most [`ALPHA_TOL`] = 2⁻⁴⁴: the root is the
//!   middle (the t′ error is then at most 2⁻⁴⁵ × the interval length ≤ 2⁻⁴⁴·Rᵢ);
//! - every control point is within φ of zero: the curve is indistinguishable from zero here (a
//!   double root: a tangent ray); the middle is reported with `flat_root` set;
//! - a one-signed part has an end value within φ of zero: that end is the root (`flat_root`). A
//!   root on the edge between two parts (or two intervals) must not fall between them when their
//!   separately rounded end values disagree in sign;
//! - [`MAX_CLIP_ITERATIONS`] clip steps per interval (never reached in the tests): the middle of
//!   the current part, with `flat_root` set.
//!
//! Measured (`tests/metaballs_math.rs`, 20,000 random rays on 400 random groups): 4.5 clip steps
//! per hit on average, at most 8, with every root within 1.6e-14 (relative) of the independent
//! check; a tangent ray (exact double root) stops on the flatness rule after 17 steps, 2e-9 from
//! the true root (≈ √ε, as a double root allows); 10⁻⁶ off tangency, 11 steps.
//!
//! # Normals (seed eq. 25, Horner eq. 26)
//! ∇F = Σ 2qᵢ/Rᵢ² · f′(r′ᵢ) · (x − cᵢ), f′ by Horner; world normal M⁻ᵀ(−∇F), renormalized.

pub mod device;
mod effect;
pub mod file;
pub mod motion;

pub use effect::{MetaballGroups, Metaballs};

use glam::DVec3;

pub use super::metaballs_trace::CastMethod;
use crate::scene::transform::{ObjectRay, Transform};

/// The density kernel f of every ball in a group.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Kernel {
    /// Wyvill et al. 1986, degree 6 in r (seed eq. 10), the default.
    #[default]
    Wyvill6,
    /// Murakami et al. 1987, degree 4 in r (seed eq. 9).
    Murakami4,
}

/// One metaball, in the group's object space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    pub centre: DVec3,
    /// Support radius R > 0: the ball's density is 0 beyond it.
    pub radius: f64,
    /// Density coefficient q (negative carves).
    pub q: f64,
}

/// One metaball group at one time: what the pass and its references cast rays against.
#[derive(Clone, Debug, PartialEq)]
pub struct MetaballGroupParams {
    /// T > 0.
    pub threshold: f64,
    pub kernel: Kernel,
    pub balls: Vec<Ball>,
    /// Object → world.
    pub transform: Transform,
    /// How the pass casts rays against it (the references here always clip exactly).
    pub method: CastMethod,
}

/// The first crossing of the surface along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetaHit {
    /// World distance along the (unit) world direction.
    pub t: f64,
    /// World unit normal −∇F mapped by M⁻ᵀ: out of the blob (away from the camera when it is inside).
    pub normal: DVec3,
    /// Bézier-clipping steps spent on the whole cast (0 when only the sphere path ran).
    pub iterations: u32,
    /// The root was accepted because the curve was flat within the noise floor (a double root).
    pub flat_root: bool,
}

/// Stop clipping when the candidate part is at most this wide in α ∈ [0, 1] (2⁻⁴⁴).
pub const ALPHA_TOL: f64 = 5.684341886080802e-14;
/// A part whose control points all lie within FLAT_C·ε_f64·S of zero is a (double) root.
pub const FLAT_C: f64 = 64.0;
/// Clip steps per interval before giving up (reports the current middle).
pub const MAX_CLIP_ITERATIONS: u32 = 4096;
/// Split a clipped part in two when it kept more than this fraction of its width (seed: 70%).
pub const SPLIT_RATIO: f64 = 0.7;

impl Kernel {
    /// The names the scene file uses, in `Kernel` order.
    pub const NAMES: [&'static str; 2] = ["wyvill6", "murakami4"];

    pub fn name(self) -> &'static str {
        Self::NAMES[self.gpu_id() as usize]
    }

    pub fn from_name(name: &str) -> Option<Kernel> {
        match name {
            "wyvill6" => Some(Kernel::Wyvill6),
            "murakami4" => Some(Kernel::Murakami4),
            _ => None,
        }
    }

    /// The kernel's id in the GPU structs (`MB_KERNEL_*` in metaballs.glsl).
    pub fn gpu_id(self) -> u32 {
        match self {
            Kernel::Wyvill6 => 0,
            Kernel::Murakami4 => 1,
        }
    }

    /// f(r′), r′ = r²: 0 for r′ ≥ 1.
    pub fn f(self, rp: f64) -> f64 {
        if rp >= 1.0 {
            return 0.0;
        }
        match self {
            Kernel::Wyvill6 => ((-4.0 / 9.0 * rp + 17.0 / 9.0) * rp - 22.0 / 9.0) * rp + 1.0,
            Kernel::Murakami4 => (1.0 - rp) * (1.0 - rp),
        }
    }

    /// df/dr′ (seed eq. 21 in Horner form, eq. 26): 0 for r′ ≥ 1.
    pub fn df(self, rp: f64) -> f64 {
        if rp >= 1.0 {
            return 0.0;
        }
        match self {
            Kernel::Wyvill6 => (-4.0 / 3.0 * rp + 34.0 / 9.0) * rp - 22.0 / 9.0,
            Kernel::Murakami4 => -2.0 * (1.0 - rp),
        }
    }

    /// Bernstein coefficients (degree 6) of f(r′(s)) along a support chord s ∈ [0, 1] with
    /// a = D/R² (seed eq. 19; eq. 20 degree-elevated for murakami4).
    pub fn chord_bernstein(self, a: f64) -> [f64; 7] {
        let a2 = a * a;
        let (d2, d3) = match self {
            Kernel::Wyvill6 => (16.0 / 27.0 * a2, 8.0 * (8.0 * a + 5.0) * a2 / 45.0),
            Kernel::Murakami4 => (16.0 / 15.0 * a2, 8.0 / 5.0 * a2),
        };
        [0.0, 0.0, d2, d3, d2, 0.0, 0.0]
    }

    /// γ = max over r ∈ [0, 1] of |d f(r²)/dr|: bounds ‖∇(q f)‖ by |q|·γ/R.
    pub fn max_slope(self) -> f64 {
        match self {
            Kernel::Wyvill6 => 1.583_429_747_740_170_6,
            Kernel::Murakami4 => 1.539_600_717_839_002,
        }
    }
}

/// ρ* such that a lone ball's surface is the sphere of radius ρ*·R about its centre: the root of
/// q·f(ρ²) = T in (0, 1). `None` when the lone ball has no surface (T/q ≥ 1 or q ≤ 0; T > 0).
pub fn iso_radius(kernel: Kernel, q: f64, threshold: f64) -> Option<f64> {
    let v = threshold / q;
    if !(v > 0.0 && v < 1.0) {
        return None;
    }
    let x = match kernel {
        // (1 − x)² = v.
        Kernel::Murakami4 => 1.0 - v.sqrt(),
        // f is strictly decreasing on [0, 1] (f′ < 0 on [0, 1)): bisection to adjacent floats.
        Kernel::Wyvill6 => {
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if kernel.f(mid) > v {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            if (kernel.f(lo) - v).abs() <= (kernel.f(hi) - v).abs() {
                lo
            } else {
                hi
            }
        }
    };
    Some(x.sqrt())
}

/// F(p) = Σ qᵢ f(‖p − cᵢ‖²/Rᵢ²) at an object-space point (the threshold not subtracted).
pub fn field(group: &MetaballGroupParams, p_object: DVec3) -> f64 {
    group
        .balls
        .iter()
        .map(|b| b.q * group.kernel.f((p_object - b.centre).length_squared() / sq(b.radius)))
        .sum()
}

/// ∇F at an object-space point (seed eq. 25: Σ 2qᵢ/Rᵢ² f′(r′ᵢ)(p − cᵢ)).
pub fn gradient(group: &MetaballGroupParams, p_object: DVec3) -> DVec3 {
    gradient_of(group, group.balls.iter(), p_object)
}

pub(crate) fn gradient_of<'a>(
    group: &MetaballGroupParams,
    balls: impl Iterator<Item = &'a Ball>,
    p: DVec3,
) -> DVec3 {
    balls.fold(DVec3::ZERO, |acc, b| {
        let d = p - b.centre;
        let r2 = sq(b.radius);
        acc + d * (2.0 * b.q / r2 * group.kernel.df(d.length_squared() / r2))
    })
}

fn sq(x: f64) -> f64 {
    x * x
}

/// A ball whose support sphere the object-space ray crosses.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayBall {
    /// Index into `balls`.
    pub index: usize,
    /// Chord ends, object-space t′.
    pub enter: f64,
    pub exit: f64,
    /// a = D/R² (seed eq. 16).
    pub a: f64,
}

/// The balls whose support chord overlaps (t0, t1), in ball order.
pub(crate) fn ray_balls(group: &MetaballGroupParams, ray: &ObjectRay, t0: f64, t1: f64) -> Vec<RayBall> {
    let mut out = Vec::new();
    for (index, b) in group.balls.iter().enumerate() {
        let w = b.centre - ray.origin;
        let tc = w.dot(ray.dir);
        let h2 = w.cross(ray.dir).length_squared();
        let d = sq(b.radius) - h2;
        if d.is_nan() || d <= 0.0 {
            continue;
        }
        let half = d.sqrt();
        let (enter, exit) = (tc - half, tc + half);
        if exit <= t0 || enter >= t1 {
            continue;
        }
        out.push(RayBall { index, enter, exit, a: d / sq(b.radius) });
    }
    out
}

/// The interval [ta, tb] of the ray split by support-sphere entries and exits, with the
/// indices (into the `RayBall` list) of the balls covering it. Calls `visit` nearest first until
/// it returns `Some`.
pub(crate) fn sweep<T>(
    rb: &[RayBall],
    t0: f64,
    t1: f64,
    mut visit: impl FnMut(f64, f64, &[usize]) -> Option<T>,
) -> Option<T> {
    // (t, entry?, ray-ball index), only those strictly inside (t0, t1).
    let mut events: Vec<(f64, bool, usize)> = Vec::with_capacity(2 * rb.len());
    let mut active: Vec<usize> = Vec::new();
    for (k, b) in rb.iter().enumerate() {
        if b.enter > t0 {
            events.push((b.enter, true, k));
        } else {
            active.push(k);
        }
        if b.exit < t1 {
            events.push((b.exit, false, k));
        }
    }
    events.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut t_cur = t0;
    for &(t_new, entry, k) in events.iter().chain(std::iter::once(&(t1, false, usize::MAX))) {
        if t_new > t_cur && !active.is_empty() {
            if let Some(found) = visit(t_cur, t_new, &active) {
                return Some(found);
            }
        }
        t_cur = t_cur.max(t_new);
        if k == usize::MAX {
            break;
        }
        if entry {
            active.push(k);
        } else if let Some(pos) = active.iter().position(|&j| j == k) {
            active.swap_remove(pos);
        }
    }
    None
}

/// The Bernstein coefficients of ball `b`'s density q·f along the ray interval [ta, tb] (degree 6,
/// α ∈ [0, 1] over the interval): the chord's coefficients restricted by de Casteljau.
pub(crate) fn interval_bernstein(kernel: Kernel, q: f64, b: &RayBall, ta: f64, tb: f64) -> [f64; 7] {
    let chord = b.exit - b.enter;
    let sa = ((ta - b.enter) / chord).clamp(0.0, 1.0);
    let sb = ((tb - b.enter) / chord).clamp(0.0, 1.0);
    let mut d = kernel.chord_bernstein(b.a);
    for x in &mut d {
        *x *= q;
    }
    restrict(&d, sa, sb)
}

/// The control points of the same curve over [u0, u1] ⊂ [0, 1]: de Casteljau's left part at u1,
/// then the right part of that at u0/u1.
pub fn restrict(c: &[f64; 7], u0: f64, u1: f64) -> [f64; 7] {
    let mut c = *c;
    if u1 < 1.0 {
        for k in 1..=6 {
            for j in (k..=6).rev() {
                c[j] = c[j - 1] * (1.0 - u1) + c[j] * u1;
            }
        }
    }
    if u0 > 0.0 {
        let v = if u1 > 0.0 { (u0 / u1).min(1.0) } else { 0.0 };
        for k in 1..=6 {
            for j in 0..=6 - k {
                c[j] = c[j] * (1.0 - v) + c[j + 1] * v;
            }
        }
    }
    c
}

/// Where the convex hull of the control polygon (k/6, c_k) meets the axis: [lo, hi], or `None`
/// when it does not.
pub fn hull_crossing(c: &[f64; 7]) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..7 {
        if c[i] == 0.0 {
            lo = lo.min(i as f64 / 6.0);
            hi = hi.max(i as f64 / 6.0);
        }
        for j in i + 1..7 {
            if (c[i] < 0.0 && c[j] > 0.0) || (c[i] > 0.0 && c[j] < 0.0) {
                let x = (i as f64 + (j - i) as f64 * (c[i] / (c[i] - c[j]))) / 6.0;
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    }
    (lo <= hi).then(|| (lo.clamp(0.0, 1.0), hi.clamp(0.0, 1.0)))
}

/// A root found by [`first_root`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipRoot {
    /// Position in the interval, α ∈ [0, 1].
    pub alpha: f64,
    /// Accepted by the flatness rule (or the iteration cap), not by width.
    pub flat: bool,
}

/// The smallest root in [0, 1] of the degree-6 Bernstein polynomial `base` by Bézier clipping
/// (module docs). `flat_floor` is the noise floor below which the curve counts as zero; clip
/// steps are added to `iterations`.
pub fn first_root(base: &[f64; 7], flat_floor: f64, iterations: &mut u32) -> Option<ClipRoot> {
    let mut stack: Vec<(f64, f64)> = Vec::new();
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let mut c = *base;
    let mut steps = 0u32;
    loop {
        if c.iter().all(|x| x.abs() <= flat_floor) {
            return Some(ClipRoot { alpha: 0.5 * (a + b), flat: true });
        }
        if c.iter().all(|&x| x > 0.0) || c.iter().all(|&x| x < 0.0) {
            // One sign: no root, unless an end is zero within the noise (a root on the edge of
            // two parts must not fall between them when their rounded ends disagree in sign).
            if c[0].abs() <= flat_floor {
                return Some(ClipRoot { alpha: a, flat: true });
            }
            if c[6].abs() <= flat_floor {
                return Some(ClipRoot { alpha: b, flat: true });
            }
            (a, b) = stack.pop()?;
            c = restrict(base, a, b);
            continue;
        }
        // Mixed signs (or a zero): the hull meets the axis.
        let (lo, hi) = hull_crossing(&c).unwrap_or((0.0, 1.0));
        steps += 1;
        *iterations += 1;
        let (na, nb) = (a + lo * (b - a), a + hi * (b - a));
        if nb - na <= ALPHA_TOL || steps >= MAX_CLIP_ITERATIONS {
            return Some(ClipRoot { alpha: 0.5 * (na + nb), flat: steps >= MAX_CLIP_ITERATIONS });
        }
        c = restrict(&c, lo, hi);
        (a, b) = (na, nb);
        if hi - lo > SPLIT_RATIO {
            let m = 0.5 * (a + b);
            stack.push((m, b));
            c = restrict(&c, 0.0, 0.5);
            b = m;
        }
    }
}

/// The scale S of an interval's coefficients: max_k Σᵢ |qᵢ d_k| + T. Errors of a rounded
/// evaluation are relative to it (with negative q the sum of magnitudes, not the magnitude of
/// the sum, since terms of opposite sign cancel).
pub(crate) fn coefficient_scale(parts: &[[f64; 7]], threshold: f64) -> f64 {
    let mut s = [0.0f64; 7];
    for p in parts {
        for (acc, x) in s.iter_mut().zip(p) {
            *acc += x.abs();
        }
    }
    s.iter().fold(0.0f64, |m, &x| m.max(x)) + threshold
}

/// The nearest crossing of a lone ball's isosurface sphere (radius `rho`·R) inside [ta, tb].
fn sphere_root(ray: &ObjectRay, b: &Ball, iso: f64, ta: f64, tb: f64) -> Option<f64> {
    let w = b.centre - ray.origin;
    let tc = w.dot(ray.dir);
    let h2 = w.cross(ray.dir).length_squared();
    let rr = iso * b.radius;
    let disc = rr * rr - h2;
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let root = disc.sqrt();
    // Product of the roots, ‖w‖² − (ρ*R)², factored to avoid cancellation.
    let wl = w.length();
    let prod = (wl - rr) * (wl + rr);
    let (near, far) = if tc > 0.0 {
        let far = tc + root;
        (prod / far, far)
    } else {
        let near = tc - root;
        (near, if near != 0.0 { prod / near } else { tc + root })
    };
    [near, far].into_iter().find(|&t| t >= ta && t <= tb)
}

/// A world ray (`dir` unit) over world distances [t_min, t_max] in the group's object space:
/// the object ray and its parameter interval; None for an empty or NaN interval.
pub fn object_interval(
    group: &MetaballGroupParams,
    origin: DVec3,
    dir: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(ObjectRay, f64, f64)> {
    let ray = group.transform.ray_to_object(origin, dir);
    let (t0, t1) = (t_min * ray.t_scale, t_max * ray.t_scale);
    if t0.is_nan() || t1.is_nan() || t1 < t0 {
        return None;
    }
    Some((ray, t0, t1))
}

/// The first crossing of the group's surface along a world ray (`dir` unit) with
/// t ∈ [t_min, t_max] (world distances), by the seed's algorithm (module docs).
pub fn cast(
    group: &MetaballGroupParams,
    origin: DVec3,
    dir: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<MetaHit> {
    let (ray, t0, t1) = object_interval(group, origin, dir, t_min, t_max)?;
    let rb = ray_balls(group, &ray, t0, t1);
    let mut iterations = 0u32;
    let kernel = group.kernel;
    let found = sweep(&rb, t0, t1, |ta, tb, active| {
        if let [k] = active {
            let b = &group.balls[rb[*k].index];
            let iso = iso_radius(kernel, b.q, group.threshold)?;
            return sphere_root(&ray, b, iso, ta, tb).map(|t| (t, false));
        }
        let parts: Vec<[f64; 7]> = active
            .iter()
            .map(|&k| interval_bernstein(kernel, group.balls[rb[k].index].q, &rb[k], ta, tb))
            .collect();
        let mut sum = [-group.threshold; 7];
        for p in &parts {
            for (s, x) in sum.iter_mut().zip(p) {
                *s += x;
            }
        }
        let floor = FLAT_C * f64::EPSILON * coefficient_scale(&parts, group.threshold);
        let root = first_root(&sum, floor, &mut iterations)?;
        Some((ta + root.alpha * (tb - ta), root.flat))
    });
    let (t_obj, flat_root) = found?;
    let p = ray.origin + ray.dir * t_obj;
    let grad = gradient_of(group, rb.iter().map(|r| &group.balls[r.index]), p);
    let normal = group.transform.normal_matrix() * -grad;
    let normal = normal.try_normalize().unwrap_or(-dir);
    Some(MetaHit { t: t_obj / ray.t_scale, normal, iterations, flat_root })
}

// ---------------------------------------------------------------------------------------------
// The independent root check: the field along each interval as a power-basis polynomial in the
// interval's own parameter, built by composing the kernel with the quadratic r′(u) (no Bernstein
// form, no clipping), and real-root isolation by the derivative cascade (the polynomial is
// monotone between consecutive roots of its derivative; bisection there to adjacent floats).

/// The field minus T on one piece of the ray: g(t′) = Σ_j poly\[j\]·uʲ with t′ = t0 + u(t1 − t0).
#[derive(Clone, Debug)]
pub struct FieldPiece {
    /// Object-space interval.
    pub t0: f64,
    pub t1: f64,
    /// Power-basis coefficients in u ∈ [0, 1] (degree ≤ 6).
    pub poly: [f64; 7],
    /// Indices (into `balls`) of the balls whose support covers the piece.
    pub balls: Vec<usize>,
}

/// The pieces of g = F − T along an object-space ray on [t0, t1], split at every support-sphere
/// entry and exit (computed here directly from ‖o + t′d − c‖ = R), nearest first. Pieces with no
/// ball (g = −T) are left out.
pub fn field_pieces(group: &MetaballGroupParams, ray: &ObjectRay, t0: f64, t1: f64) -> Vec<FieldPiece> {
    let mut cuts = vec![t0, t1];
    for b in &group.balls {
        // ‖o − c‖² + 2t′(o − c)·d + t′² = R² (solved plainly: an independent derivation).
        let oc = ray.origin - b.centre;
        let bq = oc.dot(ray.dir);
        let disc = bq * bq - (oc.length_squared() - sq(b.radius));
        if disc > 0.0 {
            for t in [-bq - disc.sqrt(), -bq + disc.sqrt()] {
                if t > t0 && t < t1 {
                    cuts.push(t);
                }
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut out = Vec::new();
    for w in cuts.windows(2) {
        let (ta, tb) = (w[0], w[1]);
        if tb <= ta {
            continue;
        }
        let mid = ray.origin + ray.dir * (0.5 * (ta + tb));
        let len = tb - ta;
        let mut poly = [0.0f64; 7];
        poly[0] = -group.threshold;
        let mut balls = Vec::new();
        for (i, b) in group.balls.iter().enumerate() {
            if (mid - b.centre).length_squared() >= sq(b.radius) {
                continue;
            }
            balls.push(i);
            // r′(u) = (‖w0‖² + 2u·len·(w0·d) + u²·len²)/R², w0 = o + ta·d − c.
            let w0 = ray.origin + ray.dir * ta - b.centre;
            let r2 = sq(b.radius);
            let rp = [w0.length_squared() / r2, 2.0 * len * w0.dot(ray.dir) / r2, len * len / r2];
            let rp2 = mul(&rp, &rp);
            let rp3 = mul(&rp2, &rp);
            let k: [f64; 4] = match group.kernel {
                Kernel::Wyvill6 => [1.0, -22.0 / 9.0, 17.0 / 9.0, -4.0 / 9.0],
                Kernel::Murakami4 => [1.0, -2.0, 1.0, 0.0],
            };
            poly[0] += b.q * k[0];
            for j in 0..3 {
                poly[j] += b.q * k[1] * rp[j];
            }
            for j in 0..5 {
                poly[j] += b.q * k[2] * rp2[j];
            }
            for j in 0..7 {
                poly[j] += b.q * k[3] * rp3[j];
            }
        }
        if !balls.is_empty() {
            out.push(FieldPiece { t0: ta, t1: tb, poly, balls });
        }
    }
    out
}

fn mul<const A: usize, const B: usize>(x: &[f64; A], y: &[f64; B]) -> [f64; 7] {
    let mut out = [0.0; 7];
    for (i, a) in x.iter().enumerate() {
        for (j, b) in y.iter().enumerate() {
            if i + j < 7 {
                out[i + j] += a * b;
            }
        }
    }
    out
}

/// p(u) by Horner.
pub fn eval_poly(p: &[f64], u: f64) -> f64 {
    p.iter().rev().fold(0.0, |acc, &c| acc * u + c)
}

/// The derivative's coefficients.
pub fn derivative(p: &[f64]) -> Vec<f64> {
    p.iter().enumerate().skip(1).map(|(j, &c)| j as f64 * c).collect()
}

/// All real roots of `p` in [0, 1], sorted, by the derivative cascade: between consecutive
/// critical points p is monotone, so a sign change there is one root, found by bisection to
/// adjacent floats. A root where p touches zero without a sign change is found only when p is
/// exactly 0 at a critical point.
pub fn roots_in_unit(p: &[f64]) -> Vec<f64> {
    let deg = p.iter().rposition(|&c| c != 0.0).unwrap_or(0);
    let p = &p[..=deg];
    if deg == 0 {
        return Vec::new();
    }
    let mut knots = vec![0.0];
    knots.extend(roots_in_unit(&derivative(p)));
    knots.push(1.0);
    let mut out: Vec<f64> = Vec::new();
    let push = |x: f64, out: &mut Vec<f64>| {
        if out.last().is_none_or(|&l| x > l) {
            out.push(x);
        }
    };
    for w in knots.windows(2) {
        let (mut a, mut b) = (w[0], w[1]);
        let (fa, fb) = (eval_poly(p, a), eval_poly(p, b));
        if fa == 0.0 {
            push(a, &mut out);
            continue;
        }
        if fb == 0.0 {
            push(b, &mut out);
            continue;
        }
        if (fa < 0.0) == (fb < 0.0) {
            continue;
        }
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                break;
            }
            let fm = eval_poly(p, m);
            if fm == 0.0 {
                (a, b) = (m, m);
                break;
            }
            if (fm < 0.0) == (fa < 0.0) {
                a = m;
            } else {
                b = m;
            }
        }
        push(0.5 * (a + b), &mut out);
    }
    out
}

/// The independent check of [`cast`] (tests only): the first root of the power-basis pieces
/// ([`field_pieces`], [`roots_in_unit`]); the normal from [`gradient`] over all balls.
pub fn cast_reference(
    group: &MetaballGroupParams,
    origin: DVec3,
    dir: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<MetaHit> {
    let (ray, t0, t1) = object_interval(group, origin, dir, t_min, t_max)?;
    // g on the previous piece's end (−T across a gap with no ball): a sign change between it and
    // the next piece's start is a root on the boundary that rounding split between the two.
    let mut before: Option<(f64, f64)> = None;
    for piece in field_pieces(group, &ray, t0, t1) {
        let start = eval_poly(&piece.poly, 0.0);
        let prev = match before {
            Some((t_end, g_end)) if t_end == piece.t0 => g_end,
            Some(_) => -group.threshold,
            None => start,
        };
        let u = if (prev > 0.0 && start < 0.0) || (prev < 0.0 && start > 0.0) {
            Some(0.0)
        } else {
            roots_in_unit(&piece.poly).first().copied()
        };
        if let Some(u) = u {
            let t_obj = piece.t0 + u * (piece.t1 - piece.t0);
            let grad = gradient(group, ray.origin + ray.dir * t_obj);
            let normal = group.transform.transform_normal(-grad);
            let normal = if normal.is_finite() { normal } else { -dir };
            return Some(MetaHit { t: t_obj / ray.t_scale, normal, iterations: 0, flat_root: false });
        }
        before = Some((piece.t1, eval_poly(&piece.poly, 1.0)));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group(balls: &[(DVec3, f64, f64)]) -> MetaballGroupParams {
        MetaballGroupParams {
            threshold: 0.5,
            kernel: Kernel::Wyvill6,
            balls: balls.iter().map(|&(centre, radius, q)| Ball { centre, radius, q }).collect(),
            transform: Transform::IDENTITY,
            method: Default::default(),
        }
    }

    /// Seed eq. 17–19 and 20: the Bernstein form equals the kernel composed with r′(s).
    #[test]
    fn chord_bernstein_matches_the_kernel() {
        for kernel in [Kernel::Wyvill6, Kernel::Murakami4] {
            for a in [0.05, 0.3, 0.77, 1.0] {
                let d = kernel.chord_bernstein(a);
                for i in 0..=20 {
                    let s = i as f64 / 20.0;
                    let rp = 4.0 * a * s * s - 4.0 * a * s + 1.0;
                    let bern: f64 = (0..7)
                        .map(|k| d[k] * binom(6, k) * s.powi(k as i32) * (1.0 - s).powi(6 - k as i32))
                        .sum();
                    assert!(
                        (bern - kernel.f(rp)).abs() < 1e-14,
                        "{kernel:?} a={a} s={s}: {bern} vs {}",
                        kernel.f(rp)
                    );
                }
                // Seed: symmetric, maximum (4a + 5)a²/9 at s = ½ for wyvill6.
                if kernel == Kernel::Wyvill6 {
                    let mid: f64 = (0..7).map(|k| d[k] * binom(6, k) / 64.0).sum();
                    assert!((mid - (4.0 * a + 5.0) * a * a / 9.0).abs() < 1e-15);
                }
            }
        }
    }

    fn binom(n: usize, k: usize) -> f64 {
        (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
    }

    /// Seed section 2.1: d₀ = 1, d₁ = 5/27, d₂ = d₃ = 0 for f(r′) as a cubic Bézier, and the
    /// root r′ = 0.25 (r = R/2) for q = 1, T = 0.5.
    #[test]
    fn lone_ball_radius_is_half_the_support() {
        let rho = iso_radius(Kernel::Wyvill6, 1.0, 0.5).unwrap();
        assert!((rho - 0.5).abs() < 1e-15, "{rho}");
        let k = Kernel::Wyvill6;
        let cubic = |x: f64| {
            let d = [1.0, 5.0 / 27.0, 0.0, 0.0];
            d[0] * (1.0 - x).powi(3)
                + 3.0 * d[1] * x * (1.0 - x).powi(2)
                + 3.0 * d[2] * x * x * (1.0 - x)
                + d[3] * x.powi(3)
        };
        for i in 0..=10 {
            let x = i as f64 / 10.0;
            assert!((cubic(x) - k.f(x)).abs() < 1e-15);
        }
        // General q and T, both kernels: q·f(ρ²) = T.
        for kernel in [Kernel::Wyvill6, Kernel::Murakami4] {
            for (q, t) in [(1.0, 0.5), (2.0, 0.5), (1.0, 0.1), (0.7, 0.69), (3.0, 2.9)] {
                let rho = iso_radius(kernel, q, t).unwrap();
                assert!((q * kernel.f(rho * rho) - t).abs() < 1e-14, "{kernel:?} q={q} T={t}");
            }
            assert_eq!(iso_radius(kernel, 0.5, 0.5), None);
            assert_eq!(iso_radius(kernel, -1.0, 0.5), None);
        }
        let m = iso_radius(Kernel::Murakami4, 1.0, 0.5).unwrap();
        assert!((m * m - (1.0 - 0.5f64.sqrt())).abs() < 1e-15);
    }

    #[test]
    fn single_ball_hit_is_at_half_the_radius() {
        let g = group(&[(DVec3::ZERO, 2.0, 1.0)]);
        let hit = cast(&g, DVec3::new(0.0, 0.0, 10.0), -DVec3::Z, 0.0, 100.0).unwrap();
        assert!((hit.t - 9.0).abs() < 1e-14, "{}", hit.t);
        assert!((hit.normal - DVec3::Z).length() < 1e-14);
        assert_eq!(hit.iterations, 0);
    }

    #[test]
    fn restrict_and_hull() {
        let c = [1.0, -2.0, 0.5, 3.0, -1.0, 2.0, 0.25];
        let r = restrict(&c, 0.2, 0.7);
        let bern = |c: &[f64; 7], s: f64| -> f64 {
            (0..7).map(|k| c[k] * binom(6, k) * s.powi(k as i32) * (1.0 - s).powi(6 - k as i32)).sum()
        };
        for i in 0..=10 {
            let u = i as f64 / 10.0;
            assert!((bern(&r, u) - bern(&c, 0.2 + 0.5 * u)).abs() < 1e-13);
        }
        assert_eq!(hull_crossing(&[1.0; 7]), None);
        let (lo, hi) = hull_crossing(&[-1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0]).unwrap();
        // The hull's upper edge (0, −1)–(½, 1) and lower edge (⅓, −1)–(1, 1) cross at ¼ and ⅔.
        assert!((lo - 0.25).abs() < 1e-15 && (hi - 2.0 / 3.0).abs() < 1e-15, "{lo} {hi}");
    }

    #[test]
    fn two_balls_agree_with_reference() {
        // The seed's metaball.cfg pair, a ray along y offset in x.
        let g = group(&[(DVec3::ZERO, 2.0, 1.0), (DVec3::new(0.0, 4.0, 0.0), 2.0, 1.0)]);
        for x in [0.0, 0.3, 0.6, 0.9] {
            let o = DVec3::new(x, 2.0, 10.0);
            let d = -DVec3::Z;
            let a = cast(&g, o, d, 0.0, 100.0);
            let b = cast_reference(&g, o, d, 0.0, 100.0);
            match (a, b) {
                (Some(a), Some(b)) => assert!((a.t - b.t).abs() < 1e-11 * b.t, "x={x}: {} vs {}", a.t, b.t),
                (None, None) => {}
                _ => panic!("x={x}: {a:?} vs {b:?}"),
            }
        }
    }

    #[test]
    fn field_pieces_match_field() {
        let g = group(&[(DVec3::ZERO, 2.0, 1.0), (DVec3::new(0.5, 1.5, 0.0), 1.5, -0.7)]);
        let ray =
            g.transform.ray_to_object(DVec3::new(0.2, 0.7, 5.0), DVec3::new(0.05, 0.1, -1.0).normalize());
        for p in field_pieces(&g, &ray, 0.0, 20.0) {
            for i in 0..=8 {
                let u = i as f64 / 8.0;
                let t = p.t0 + u * (p.t1 - p.t0);
                let direct = field(&g, ray.origin + ray.dir * t) - g.threshold;
                assert!(
                    (eval_poly(&p.poly, u) - direct).abs() < 1e-13,
                    "{} vs {direct}",
                    eval_poly(&p.poly, u)
                );
            }
        }
    }
}
