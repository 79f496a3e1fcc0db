//! The sphere-tracing baseline for metaballs (the speed-vs-error comparison with Bézier
//! clipping), in f64: the CPU twin of `mb_trace_slots` in shaders/common/metaballs.glsl.
//!
//! Along the object-space ray, F(t′) = Σ qᵢ f(r′ᵢ(t′)) over the support chords the ray crosses.
//! Between chord entries only the balls whose chord contains t′ contribute, and each changes by
//! at most |qᵢ|γ/Rᵢ per unit t′ (γ = [`crate::effects::metaballs::Kernel::max_slope`]), so L = Σ over those of |qᵢ|γ/Rᵢ is a
//! Lipschitz bound of F until the next entry. A step of |F − T|/L (capped at the next entry)
//! therefore never jumps over a root. Near a root the steps shrink geometrically, so a step is
//! at least [`TRACE_MIN_STEP`]·T/L: that one may cross the surface, which brackets the root
//! (F − T changes sign), refined by [`TRACE_BISECT`] bisections. It may also jump over a sliver
//! of surface thinner than that step, where F − T stays within L·TRACE_MIN_STEP·T/L =
//! TRACE_MIN_STEP·T of zero: a near-tangent ray. Out of steps before the end of the range, the
//! cast reports [`Trace::exhausted`] (the pass counts it as a dropped pixel).
//!
//! Error of a hit: the bracket is at most one least step wide (conservative steps never cross),
//! so the root is within TRACE_MIN_STEP·T/L·2^-TRACE_BISECT·½ of the answer (object space).

use glam::DVec3;

use super::metaballs::{gradient_of, ray_balls, MetaHit, MetaballGroupParams};

/// How the metaballs pass finds a ray's first root (per group: `method` in the scene file).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CastMethod {
    /// Bézier clipping (seed 000). `tolerance`: stop clipping when a part is at most this wide
    /// (world distance along the ray); 0 keeps the default, 2⁻²² of the interval.
    Bezier { tolerance: f64 },
    /// Sphere tracing with at most `steps` steps per cast, then bisection of the bracket.
    SphereTrace { steps: u32 },
}

impl Default for CastMethod {
    fn default() -> Self {
        CastMethod::Bezier { tolerance: 0.0 }
    }
}

impl CastMethod {
    /// The names the scene file uses.
    pub const NAMES: [&'static str; 2] = ["bezier", "sphere_trace"];
    /// Sphere-tracing steps when `steps` is not given.
    pub const DEFAULT_STEPS: u32 = 64;
    /// The most sphere-tracing steps a scene may ask for.
    pub const MAX_STEPS: u32 = 100_000;
}

/// The least step, × T/L (2⁻¹⁰). Keep in sync with MB_TRACE_MIN_STEP in the shader.
pub const TRACE_MIN_STEP: f64 = 1.0 / 1024.0;
/// Bisections of a bracket. Keep in sync with MB_TRACE_BISECT in the shader.
pub const TRACE_BISECT: u32 = 16;

/// What a sphere-traced cast found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trace {
    /// The hit (`iterations`: the march steps spent).
    pub hit: Option<MetaHit>,
    /// March steps spent.
    pub steps: u32,
    /// The steps ran out before the end of the range: the ray may hit beyond.
    pub exhausted: bool,
}

/// The first crossing of the group's surface along a world ray (`dir` unit) with
/// t ∈ [t_min, t_max] by sphere tracing with at most `steps` steps (module docs).
pub fn trace(
    group: &MetaballGroupParams,
    origin: DVec3,
    dir: DVec3,
    t_min: f64,
    t_max: f64,
    steps: u32,
) -> Trace {
    let mut out = Trace { hit: None, steps: 0, exhausted: false };
    let Some((ray, t0, t_end)) = super::metaballs::object_interval(group, origin, dir, t_min, t_max) else {
        return out;
    };
    let rb = ray_balls(group, &ray, t0, t_end);
    let gamma = group.kernel.max_slope();
    let threshold = group.threshold;
    // (F, L, next entry) at t′, as mb_trace_probe.
    let probe = |t: f64| {
        let (mut f, mut l, mut next_en) = (0.0, 0.0, f64::MAX);
        for r in &rb {
            let b = &group.balls[r.index];
            let half = 0.5 * (r.exit - r.enter);
            let s = (t - (r.enter + half)) / half;
            if r.enter <= t && t <= r.exit {
                f += b.q * group.kernel.f(1.0 - r.a * (1.0 - s * s));
            }
            if r.enter <= t && t < r.exit {
                l += b.q.abs() * gamma / b.radius;
            }
            if r.enter > t {
                next_en = next_en.min(r.enter);
            }
        }
        (f, l, next_en)
    };
    let mut p = probe(t0);
    let inside = p.0 >= threshold;
    let (mut t, mut t_prev) = (t0, t0);
    let mut bracket = false;
    loop {
        let gap = if inside { p.0 - threshold } else { threshold - p.0 };
        if gap <= 0.0 {
            bracket = true;
            break;
        }
        if t >= t_end || out.steps >= steps {
            break;
        }
        let step = if p.1 > 0.0 { gap.max(TRACE_MIN_STEP * threshold) / p.1 } else { t_end - t };
        t_prev = t;
        t = (t + step).min(p.2).min(t_end);
        p = probe(t);
        out.steps += 1;
    }
    if !bracket {
        out.exhausted = t < t_end;
        return out;
    }
    let (mut lo, mut hi) = (t_prev, t);
    for _ in 0..TRACE_BISECT {
        let mid = 0.5 * (lo + hi);
        if (probe(mid).0 >= threshold) == inside {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let t_obj = 0.5 * (lo + hi);
    let p = ray.origin + ray.dir * t_obj;
    let grad = gradient_of(group, rb.iter().map(|r| &group.balls[r.index]), p);
    let normal = (group.transform.normal_matrix() * -grad).try_normalize().unwrap_or(-dir);
    out.hit = Some(MetaHit { t: t_obj / ray.t_scale, normal, iterations: out.steps, flat_root: false });
    out
}
