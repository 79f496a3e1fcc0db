//! The f32 twin of `shaders/common/metaballs.glsl`: the GPU structs (std430, asserted sizes), their
//! packing from a [`MetaballGroupParams`], [`cast_f32`] (the shader's `metaball_cast` line by line,
//! Bézier clipping with the group's tolerance or sphere tracing with its steps)
//! and the tangency band that says where an f32 answer may legitimately differ from the f64 one.
//!
//! # The tangency band
//! Along a ray, g(t) = F − T is the field minus the threshold (g > 0 inside). The f32 cast
//! evaluates g with an error of a few ε_f32 times two scales:
//! - S = max_k Σᵢ|qᵢ d_k| + T, the coefficient scale of the interval (rounding of the summed
//!   Bernstein coefficients; the sum of magnitudes, since with negative q the terms cancel);
//! - X·G, with X = ‖o′ − a‖ + t′ (the object-space coordinate scale as the f32 cast holds it,
//!   from the group's anchor a ([`anchor`]): the camera and the point reached) and G = Σᵢ|qᵢ|γ/Rᵢ ≥ ‖∇F‖ (γ the kernel's max slope): rounding positions by ε·X moves g by up
//!   to ε·X·G. (On the camera's scale this term dominates: X/R ≈ 10–100 in typical scenes.)
//!
//! With δ = [`BAND_C`]·ε_f32·(S + X·G) evaluated on the interval at hand, a ray is **in the band**
//! when g comes within δ of zero at a point where it is stationary before (or just after) the
//! answer: some critical point t* of g (g′(t*) = 0) in [t_min, t_hit] or the first one after
//! t_hit, or t_min itself, or t_max when the ray misses. There a perturbation of g by δ can create
//! or remove a (double) root, so the f32 hit/miss or depth may differ from the f64 one; elsewhere
//! every root is simple and separated from zero-touching extrema by more than δ, and the tests
//! require agreement (hit/miss, depth ≤ 1e-4 relative, normal ≤ 0.5°). [`tangency`] measures the
//! margin min |g(t*)|/(S + X·G) in f64, independently of the clipping code (power-basis pieces and
//! the derivative cascade); `Tangency::in_band` compares it with BAND_C·ε_f32.
//!
//! Calibration (`tests/metaballs_math.rs`, rays 10⁻¹ … 10⁻¹⁰ off ~400 silhouettes of random
//! groups): every f32/f64 disagreement had a margin ≤ 1.28·ε_f32, so BAND_C = 16 leaves a factor
//! of 12 for the device's own rounding (fused multiply-adds, division and square root within the
//! Vulkan ULP bounds). With S alone as the scale (the coefficients only, no X·G) disagreements
//! reached 28·ε with cameras 6–25 units away, growing with the distance: positions, not
//! coefficients, dominate the f32 error.
//!
//! The shader computes the same δ per interval and raises `MB_TANGENT` (a conservative hint for
//! shading, e.g. to anti-alias silhouettes) when
//! - a part dropped by the clipping comes within δ of zero from below at an interior control
//!   point (a near miss before the answer);
//! - the root found is shallow: its slope s satisfies s² ≤ 2·M2·δ, M2 the Bernstein bound on g″,
//!   so an extremum within δ of zero may lie beside it (a graze or a double root);
//! - a lone ball's field maximum on the ray, q·f(ρ²/R²) − T at the closest approach, is within δ.
//!
//! (The last two tests are compiled out of the metaballs pass, `MB_TANGENT_FLAGS 0`: it never
//! reads the flag. This twin, like `metaball_cast`'s default, raises it.)
//!
//! In the tests MB_TANGENT is raised on 99.9% of in-band rays and on ~1–3% of rays outside it.
//! The f64 [`tangency`] is what tests use to exclude and count pixels.
//!
//! # Caps (the shader's fixed-size arrays; each reports instead of looping or guessing)
//! - [`MB_MAX_RAY_BALLS`] = 32 supports per ray in slots, the nearest by entry: a miss before the
//!   entry of the nearest ball left out casts again from there; where more than 32 supports
//!   contain one point, the rest of the ray is streamed from the list ([`MB_STREAMED`],
//!   `stream::clip_stream`): it gathers the ray's chords 128 at a time (`MB_CACHE_BALLS`, each
//!   round up to the entry of the first one left out), and where more than 128 contain one point
//!   it walks the list itself, holding nothing per ball, so it has no cap;
//! - [`MB_MAX_ITERATIONS`] = 256 clip steps per cast (measured: ≤ 8 on simple roots, ~7–17 on
//!   double roots): beyond, [`MB_NOT_CONVERGED`] and a miss;
//! - [`MB_STACK_SIZE`] = 24 pending halves, provably enough: each pushed half is wider than
//!   MB_ALPHA_TOL/2 and at most half as wide as the one below it, so at most
//!   log2(1/MB_ALPHA_TOL) = 22 are ever pending.

use bytemuck::{Pod, Zeroable};
use glam::{DMat4, DVec3, Mat3, Mat4, Vec3};

mod stream;

use super::metaballs::{
    coefficient_scale, derivative, eval_poly, field_pieces, interval_bernstein, iso_radius, ray_balls,
    roots_in_unit, CastMethod, MetaballGroupParams,
};

/// One metaball group. Keep in sync with `MetaGroup` in shaders/common/metaballs.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuMetaGroup {
    /// M⁻¹ (world → object; world relative to `gpu_group`'s origin: the camera's position in the
    /// passes), column-major.
    pub to_object: [[f32; 4]; 4],
    /// M (object → world, relative to the same origin).
    pub to_world: [[f32; 4]; 4],
    /// M⁻ᵀ in the upper 3×3 (object normal → world normal).
    pub normal_matrix: [[f32; 4]; 4],
    /// x: threshold T, y: Bézier-clipping tolerance (world distance; 0: the default), z: sphere-tracing
    /// steps, w: 0.
    pub params: [f32; 4],
    /// x: kernel id (`Kernel::gpu_id`), y: first ball, z: ball count, w: material index.
    pub info: [u32; 4],
}

/// One ball. Keep in sync with `MetaBall` in shaders/common/metaballs.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuMetaBall {
    /// xyz: object-space centre, w: support radius R.
    pub centre_radius: [f32; 4],
    /// x: q, y: ρ*·R (the lone ball's isosurface radius, 0 when it has none), z: |q|·γ/R, w: 0.
    pub coeffs: [f32; 4],
}

const _: () = {
    assert!(std::mem::size_of::<GpuMetaGroup>() == 224);
    assert!(std::mem::offset_of!(GpuMetaGroup, to_world) == 64);
    assert!(std::mem::offset_of!(GpuMetaGroup, normal_matrix) == 128);
    assert!(std::mem::offset_of!(GpuMetaGroup, params) == 192);
    assert!(std::mem::offset_of!(GpuMetaGroup, info) == 208);
    assert!(std::mem::size_of::<GpuMetaBall>() == 32);
    assert!(std::mem::offset_of!(GpuMetaBall, coeffs) == 16);
};

/// `MB_HIT`: t and normal are set.
pub const MB_HIT: u32 = 1;
/// `MB_TANGENT`: the ray passed within δ of the threshold (a near miss or a double root).
pub const MB_TANGENT: u32 = 2;
/// `MB_STREAMED`: more than [`MB_MAX_RAY_BALLS`] supports contain one point before the answer:
/// from there the cast went on streamed from the list (Bézier clipping whatever the method).
pub const MB_STREAMED: u32 = 4;
/// `MB_NOT_CONVERGED`: [`MB_MAX_ITERATIONS`] clip steps spent; reported as a miss.
pub const MB_NOT_CONVERGED: u32 = 8;

pub const MB_MAX_RAY_BALLS: usize = 32;
pub const MB_MAX_ITERATIONS: u32 = 256;
pub const MB_STACK_SIZE: usize = 24;
/// 2⁻²²: the t′ error of a root is at most 2⁻²³ × its interval.
pub const MB_ALPHA_TOL: f32 = 2.384_185_8e-7;
pub const MB_SPLIT_RATIO: f32 = 0.7;
pub const MB_EPS: f32 = f32::EPSILON;
/// δ = BAND_C·ε_f32·(S + X·G) (module docs).
pub const BAND_C: f64 = 16.0;
const MB_BAND_C: f32 = BAND_C as f32;
/// A part within MB_FLAT_C·ε·S of zero is accepted as a (double) root.
pub const MB_FLAT_C: f32 = 16.0;
const MB_TRACE_MIN_STEP: f32 = super::metaballs_trace::TRACE_MIN_STEP as f32;
const MB_TRACE_BISECT: u32 = super::metaballs_trace::TRACE_BISECT;

const MB_KERNEL_WYVILL6: u32 = 0;
const MB_W6_K3: f32 = -0.444_444_45;
const MB_W6_K2: f32 = 1.888_888_8;
const MB_W6_K1: f32 = -2.444_444_4;
const MB_W6_D2: f32 = -1.333_333_4;
const MB_W6_D1: f32 = 3.777_777_7;
const MB_W6_B2: f32 = 0.592_592_6;
const MB_W6_B3: f32 = 0.177_777_78;
const MB_M4_B2: f32 = 1.066_666_7;
const MB_M4_B3: f32 = 1.6;

/// What `metaball_cast` returns. Keep in sync with `MetaHit` in shaders/common/metaballs.glsl.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetaHitF32 {
    /// World unit normal (valid with `MB_HIT`).
    pub normal: Vec3,
    /// World distance: the hit with `MB_HIT`.
    pub t: f32,
    pub flags: u32,
    pub iterations: u32,
}

impl MetaHitF32 {
    pub fn hit(&self) -> bool {
        self.flags & MB_HIT != 0
    }
    pub fn tangent(&self) -> bool {
        self.flags & MB_TANGENT != 0
    }
}

fn mat(m: DMat4) -> [[f32; 4]; 4] {
    m.as_mat4().to_cols_array_2d()
}

/// Where a group's balls are placed from on the GPU (`gpu_balls_cached`, `gpu_group`): its first
/// ball's centre (object space; 0 without balls). Balls given in world coordinates far from the
/// origin (a game's particles, 10⁴ units out) would otherwise be rounded there in f32, 10⁻³ of a
/// unit at 10⁴; relative to a ball of their own they keep ε of the group's size.
pub fn anchor(group: &MetaballGroupParams) -> DVec3 {
    group.balls.first().map_or(DVec3::ZERO, |b| b.centre)
}

/// Where the frame's ball table places a group's balls from: [`anchor`] for the host's balls,
/// 0 for a game's records (`from_game`: copied on the device as written).
pub fn table_anchor(group: &MetaballGroupParams, from_game: bool) -> DVec3 {
    if from_game {
        DVec3::ZERO
    } else {
        anchor(group)
    }
}

/// The group header for the GPU: its balls are `first_ball .. first_ball + balls.len()` of the
/// ball buffer, their centres relative to `anchor` (object space; [`anchor`], or 0 for balls as
/// given). Its matrices map that space to and from world coordinates relative to `origin` (world −
/// origin; the passes give the camera's position, so a ray starts at 0): composed here in f64, so
/// that no f32 product cancels coordinates far from the world's origin (a camera and a group 10⁵
/// units out would lose ~10⁻² of a unit to it). `DVec3::ZERO` for both: object and world space as
/// they are.
pub fn gpu_group(
    group: &MetaballGroupParams,
    first_ball: u32,
    material: u32,
    (origin, anchor): (DVec3, DVec3),
) -> GpuMetaGroup {
    let t = &group.transform;
    // Steps ≤ CastMethod::MAX_STEPS are exact in f32.
    let (tolerance, steps) = match group.method {
        CastMethod::Bezier { tolerance } => (tolerance, 0),
        CastMethod::SphereTrace { steps } => (0.0, steps),
    };
    GpuMetaGroup {
        to_object: mat(DMat4::from_translation(-anchor) * t.inverse * DMat4::from_translation(origin)),
        to_world: mat(DMat4::from_translation(-origin) * t.matrix * DMat4::from_translation(anchor)),
        normal_matrix: mat(DMat4::from_mat3(t.normal_matrix())),
        params: [group.threshold as f32, tolerance as f32, steps as f32, 0.0],
        info: [group.kernel.gpu_id(), first_ball, group.balls.len() as u32, material],
    }
}

/// The group's balls for the GPU, in order, centres as given (anchor 0); the lone-ball radius
/// ρ*·R is solved here in f64.
pub fn gpu_balls(group: &MetaballGroupParams) -> Vec<GpuMetaBall> {
    gpu_balls_cached(group, &mut IsoCache::default(), DVec3::ZERO)
}

/// The lone-ball radii ρ* of a group's balls by kernel and T/q, kept from frame to frame: solving
/// ρ* (a bisection) was most of the host's per-ball work, and a moving ball keeps its q.
#[derive(Clone, Debug, Default)]
pub struct IsoCache(Vec<(super::metaballs::Kernel, u64, Option<f64>)>);

impl IsoCache {
    fn rho(&mut self, i: usize, kernel: super::metaballs::Kernel, q: f64, threshold: f64) -> Option<f64> {
        let key = (threshold / q).to_bits();
        if self.0.len() <= i {
            self.0.resize(i + 1, (kernel, !key, None));
        }
        let slot = &mut self.0[i];
        if slot.0 != kernel || slot.1 != key {
            *slot = (kernel, key, iso_radius(kernel, q, threshold));
        }
        slot.2
    }
}

/// [`gpu_balls`], with ρ* from `cache` where the ball's kernel and T/q are as before, and the
/// centres relative to `anchor` (subtracted in f64; [`gpu_group`]'s).
pub fn gpu_balls_cached(
    group: &MetaballGroupParams,
    cache: &mut IsoCache,
    anchor: DVec3,
) -> Vec<GpuMetaBall> {
    let gamma = group.kernel.max_slope();
    group
        .balls
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let rho = cache.rho(i, group.kernel, b.q, group.threshold);
            let iso = rho.map_or(0.0, |rho| rho * b.radius);
            let c = b.centre - anchor;
            GpuMetaBall {
                centre_radius: [c.x as f32, c.y as f32, c.z as f32, b.radius as f32],
                coeffs: [b.q as f32, iso as f32, (b.q.abs() * gamma / b.radius) as f32, 0.0],
            }
        })
        .collect()
}

/// A world-space sphere bounding ball `i`'s support ellipsoid (for culling and binning): centre
/// M·c, radius R times M's largest singular value (bounded by the Frobenius norm).
pub fn world_bound(group: &MetaballGroupParams, i: usize) -> (DVec3, f64) {
    let m = glam::DMat3::from_mat4(group.transform.matrix);
    let b = &group.balls[i];
    let spectral = largest_singular_value(m);
    (group.transform.transform_point(b.centre), b.radius * spectral)
}

fn largest_singular_value(m: glam::DMat3) -> f64 {
    // Power iteration on MᵀM from the Frobenius bound down; 64 steps reach f64 accuracy for any
    // accepted transform (condition ≤ 1e6), and the result is then rounded up a little.
    let ata = m.transpose() * m;
    let mut v = DVec3::new(1.0, 0.7, 0.3).normalize();
    let mut lambda = 0.0;
    for _ in 0..64 {
        let w = ata * v;
        lambda = w.length();
        if lambda == 0.0 {
            return 0.0;
        }
        v = w / lambda;
    }
    (lambda.sqrt() * (1.0 + 1e-9)).min(crate::scene::transform::frobenius(m))
}

fn mb_kernel(kernel: u32, rp: f32) -> f32 {
    if rp >= 1.0 {
        return 0.0;
    }
    if kernel == MB_KERNEL_WYVILL6 {
        return ((MB_W6_K3 * rp + MB_W6_K2) * rp + MB_W6_K1) * rp + 1.0;
    }
    (1.0 - rp) * (1.0 - rp)
}

fn mb_kernel_deriv(kernel: u32, rp: f32) -> f32 {
    if rp >= 1.0 {
        return 0.0;
    }
    if kernel == MB_KERNEL_WYVILL6 {
        return (MB_W6_D2 * rp + MB_W6_D1) * rp + MB_W6_K1;
    }
    -2.0 * (1.0 - rp)
}

fn mb_chord_bernstein(kernel: u32, a: f32, q: f32, d: &mut [f32; 7]) {
    let a2 = a * a;
    let d2 = if kernel == MB_KERNEL_WYVILL6 { MB_W6_B2 * a2 } else { MB_M4_B2 * a2 };
    let d3 = if kernel == MB_KERNEL_WYVILL6 { MB_W6_B3 * (8.0 * a + 5.0) * a2 } else { MB_M4_B3 * a2 };
    d[0] = 0.0;
    d[1] = 0.0;
    d[2] = q * d2;
    d[3] = q * d3;
    d[4] = q * d2;
    d[5] = 0.0;
    d[6] = 0.0;
}

fn mb_restrict(c: &mut [f32; 7], u0: f32, u1: f32) {
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
}

fn mb_hull_crossing(c: &[f32; 7]) -> (f32, f32) {
    let mut lo = 2.0f32;
    let mut hi = -1.0f32;
    for i in 0..7 {
        if c[i] == 0.0 {
            lo = lo.min(i as f32 / 6.0);
            hi = hi.max(i as f32 / 6.0);
        }
        for j in i + 1..7 {
            if (c[i] < 0.0 && c[j] > 0.0) || (c[i] > 0.0 && c[j] < 0.0) {
                let x = (i as f32 + (j - i) as f32 * (c[i] / (c[i] - c[j]))) / 6.0;
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    }
    (lo.clamp(0.0, 1.0), hi.clamp(0.0, 1.0))
}

fn mb_delta(s: f32, x: f32, g: f32) -> f32 {
    MB_BAND_C * MB_EPS * (s + x * g)
}

fn mb_first_root(
    base: &[f32; 7],
    flat_floor: f32,
    delta: f32,
    alpha_tol: f32,
    iterations: &mut u32,
    flags: &mut u32,
) -> f32 {
    let mut stack = [[0.0f32; 2]; MB_STACK_SIZE];
    let mut sp = 0usize;
    let mut a = 0.0f32;
    let mut b = 1.0f32;
    let mut c = *base;
    let mut narrow = false;
    for _guard in 0..2 * MB_MAX_ITERATIONS + 2 {
        let mut all_pos = true;
        let mut all_neg = true;
        let mut largest = 0.0f32;
        let mut inner_max = -3.402_823_5e38f32;
        for (k, &ck) in c.iter().enumerate() {
            all_pos = all_pos && ck > 0.0;
            all_neg = all_neg && ck < 0.0;
            largest = largest.max(ck.abs());
            if k > 0 && k < 6 {
                inner_max = inner_max.max(ck);
            }
        }
        if largest <= flat_floor {
            return 0.5 * (a + b);
        }
        if narrow && !(c[0] > 0.0 && c[6] > 0.0) && !(c[0] < 0.0 && c[6] < 0.0) {
            return 0.5 * (a + b);
        }
        let pop = all_pos || all_neg;
        let u0;
        let mut u1;
        if pop {
            if c[0].abs() <= flat_floor {
                return a;
            }
            if c[6].abs() <= flat_floor {
                return b;
            }
            if all_neg && inner_max >= -delta {
                *flags |= MB_TANGENT;
            }
            if sp == 0 {
                return -1.0;
            }
            sp -= 1;
            a = stack[sp][0];
            b = stack[sp][1];
            u0 = a;
            u1 = b;
            narrow = false;
        } else {
            if *iterations >= MB_MAX_ITERATIONS {
                *flags |= MB_NOT_CONVERGED;
                return -1.0;
            }
            let h = mb_hull_crossing(&c);
            *iterations += 1;
            let na = a + h.0 * (b - a);
            let nb = a + h.1 * (b - a);
            if nb - na <= MB_ALPHA_TOL {
                return 0.5 * (na + nb);
            }
            narrow = nb - na <= alpha_tol;
            a = na;
            b = nb;
            u0 = h.0;
            u1 = h.1;
            if h.1 - h.0 > MB_SPLIT_RATIO && !narrow {
                if sp < MB_STACK_SIZE {
                    let m = 0.5 * (a + b);
                    stack[sp] = [m, b];
                    sp += 1;
                    u1 = h.0 + 0.5 * (h.1 - h.0);
                    b = m;
                } else {
                    *flags |= MB_NOT_CONVERGED;
                    return -1.0;
                }
            }
        }
        if pop {
            c = *base;
        }
        mb_restrict(&mut c, u0, u1);
    }
    *flags |= MB_NOT_CONVERGED;
    -1.0
}

fn mb_shallow_root(base: &[f32; 7], alpha: f32, delta: f32) -> bool {
    let mut c = *base;
    let mut m2 = 0.0f32;
    for k in 0..5 {
        m2 = m2.max((c[k + 2] - 2.0 * c[k + 1] + c[k]).abs());
    }
    m2 *= 30.0;
    let s = if alpha < 0.5 {
        mb_restrict(&mut c, alpha, 1.0);
        6.0 * (c[1] - c[0]) / (1.0 - alpha)
    } else {
        mb_restrict(&mut c, 0.0, alpha);
        6.0 * (c[6] - c[5]) / alpha
    };
    s * s <= 2.0 * m2 * delta
}

fn v3(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

/// `MB_NO_ISO`: no lone isosurface crossing.
const MB_NO_ISO: f32 = -f32::MAX;

/// The ray's support chords (`mb_chord_t`, `mb_shape`, `mb_iso`, `mb_meta` of the shader): slot j
/// holds (entry, exit) in object-space t′, (a, q), the lone isosurface crossings (near, far) and
/// (|q|γ/R, ball id); `mask` says which slots belong to the ray.
struct Slots {
    chord: [[f32; 2]; MB_MAX_RAY_BALLS],
    shape: [[f32; 2]; MB_MAX_RAY_BALLS],
    iso: [[f32; 2]; MB_MAX_RAY_BALLS],
    meta: [(f32, u32); MB_MAX_RAY_BALLS],
}

impl Slots {
    fn new() -> Slots {
        let z = [[0.0; 2]; MB_MAX_RAY_BALLS];
        Slots { chord: z, shape: z, iso: z, meta: [(0.0, 0); MB_MAX_RAY_BALLS] }
    }

    /// Slot j's four parts, for putting back.
    fn get(&self, j: usize) -> ([f32; 2], [f32; 2], [f32; 2], (f32, u32)) {
        (self.chord[j], self.shape[j], self.iso[j], self.meta[j])
    }

    fn set(&mut self, j: usize, v: ([f32; 2], [f32; 2], [f32; 2], (f32, u32))) {
        (self.chord[j], self.shape[j], self.iso[j], self.meta[j]) = v;
    }
}

/// `mb_iso_sphere`: the near and far t′ on the lone isosurface sphere of radius rr, or MB_NO_ISO.
fn mb_iso_sphere(w: Vec3, tc: f32, h2: f32, rr: f32) -> [f32; 2] {
    let disc = rr * rr - h2;
    if !(rr > 0.0 && disc >= 0.0) {
        return [MB_NO_ISO; 2];
    }
    let root = disc.sqrt();
    let wl = w.length();
    let prod = (wl - rr) * (wl + rr);
    if tc > 0.0 {
        let far_t = tc + root;
        [prod / far_t, far_t]
    } else {
        let near_t = tc - root;
        [near_t, if near_t != 0.0 { prod / near_t } else { tc + root }]
    }
}

/// `mb_chord` (with `mb_fill_slot`): slot j from ball `id` when its chord crosses (t0, t1).
#[allow(clippy::too_many_arguments)]
fn mb_chord(
    slots: &mut Slots,
    j: usize,
    balls: &[GpuMetaBall],
    id: u32,
    o: Vec3,
    d: Vec3,
    t0: f32,
    t1: f32,
) -> bool {
    let ball = balls[id as usize];
    let w = v3(ball.centre_radius) - o;
    let tc = w.dot(d);
    let cr = w.cross(d);
    let h2 = cr.dot(cr);
    let r = ball.centre_radius[3];
    let dd = r * r - h2;
    if dd.is_nan() || dd <= 0.0 {
        return false;
    }
    let half_chord = dd.sqrt();
    let en = tc - half_chord;
    let ex = tc + half_chord;
    if ex <= t0 || en >= t1 {
        return false;
    }
    slots.chord[j] = [en, ex];
    slots.shape[j] = [mb_chord_a([en, ex], r), ball.coeffs[0]];
    slots.iso[j] = mb_iso_sphere(w, tc, h2, ball.coeffs[1]);
    slots.meta[j] = (ball.coeffs[2], id);
    true
}

/// `mb_chord_a`: a = D/R² from the chord's half length.
fn mb_chord_a(chord: [f32; 2], r: f32) -> f32 {
    let half_chord = 0.5 * (chord[1] - chord[0]);
    half_chord * half_chord / (r * r)
}

/// `mb_finish_grad`: the hit at object-space t_found with ∇F there.
fn finish_grad(hit: &mut MetaHitF32, g: &GpuMetaGroup, r: &MetaRay, dir: Vec3, grad: Vec3, t_found: f32) {
    let nw = Mat3::from_mat4(Mat4::from_cols_array_2d(&g.normal_matrix)) * -grad;
    let len = nw.length();
    hit.normal = if len > 0.0 { nw / len } else { -dir };
    hit.t = t_found / r.ts;
    hit.flags |= MB_HIT;
}

/// The object-space ray (`MetaRay`).
#[derive(Clone, Copy)]
struct MetaRay {
    o: Vec3,
    d: Vec3,
    ts: f32,
}

/// What the slot casts share: the group, the ball buffer and the slots.
struct Cast<'a> {
    g: &'a GpuMetaGroup,
    balls: &'a [GpuMetaBall],
    slots: Slots,
    n: usize,
    mask: u32,
    r: MetaRay,
    dir: Vec3,
}

impl Cast<'_> {
    /// The ball of slot j (`MB_BALL` through its id).
    fn ball(&self, j: usize) -> GpuMetaBall {
        self.balls[self.slots.meta[j].1 as usize]
    }

    fn mine(&self, j: usize) -> bool {
        self.mask & (1u32 << j) != 0
    }

    /// `mb_finish`: the gradient over the slots in `set`.
    fn finish(&self, hit: &mut MetaHitF32, set: u32, t_found: f32) {
        let kernel = self.g.info[0];
        let p = self.r.o + self.r.d * t_found;
        let mut grad = Vec3::ZERO;
        let mut m = set;
        while m != 0 {
            let j = m.trailing_zeros() as usize;
            m &= m - 1;
            let ball = self.ball(j);
            let w = p - v3(ball.centre_radius);
            let inv_r2 = 1.0 / (ball.centre_radius[3] * ball.centre_radius[3]);
            grad += w * (2.0 * ball.coeffs[0] * inv_r2 * mb_kernel_deriv(kernel, w.dot(w) * inv_r2));
        }
        finish_grad(hit, self.g, &self.r, self.dir, grad, t_found);
    }

    /// `mb_field_bound`: Σ max(q, 0)·f(r′_min) over the chords of `live` on [t_cur, t_next].
    fn field_bound(&self, live: u32, t_cur: f32, t_next: f32) -> f32 {
        let kernel = self.g.info[0];
        let mut bound = 0.0f32;
        let mut m = live;
        while m != 0 {
            let j = m.trailing_zeros() as usize;
            m &= m - 1;
            let ct = self.slots.chord[j];
            let [a, q] = self.slots.shape[j];
            let half_chord = 0.5 * (ct[1] - ct[0]);
            let mid = ct[0] + half_chord;
            let s0 = (t_cur - mid) / half_chord;
            let s1 = (t_next - mid) / half_chord;
            let s2 = if s0 <= 0.0 && s1 >= 0.0 { 0.0 } else { (s0 * s0).min(s1 * s1) };
            bound += q.max(0.0) * mb_kernel(kernel, 1.0 - a * (1.0 - s2));
        }
        bound
    }

    /// `mb_clip_slots`.
    fn clip(&self, t0: f32, t_end: f32, mut hit: MetaHitF32) -> MetaHitF32 {
        let kernel = self.g.info[0];
        let tt = self.g.params[0];
        let x = self.r.o.length();
        let (o, d) = (self.r.o, self.r.d);
        let mut t_cur = t0;
        let mut t_found = 0.0f32;
        let mut found = false;
        let mut sweep = 0usize;
        // The chords containing [t_cur, t_next] (at the end: the hit's).
        let mut live = 0u32;
        loop {
            let mut t_next = t_end;
            let mut clip = false;
            while !found && t_cur < t_end && sweep < 2 * MB_MAX_RAY_BALLS + 1 {
                sweep += 1;
                live = 0;
                t_next = t_end;
                for j in 0..self.n {
                    let [en, ex] = self.slots.chord[j];
                    let mine = self.mine(j);
                    if mine && en <= t_cur && ex > t_cur {
                        live |= 1u32 << j;
                    }
                    if mine && ex > t_cur {
                        t_next = t_next.min(if en > t_cur { en } else { ex });
                    }
                }
                let count = live.count_ones();
                if count == 1 {
                    let j = live.trailing_zeros() as usize;
                    let [near_t, far_t] = self.slots.iso[j];
                    if near_t >= t_cur && near_t <= t_next {
                        t_found = near_t;
                        found = true;
                    } else if far_t >= t_cur && far_t <= t_next {
                        t_found = far_t;
                        found = true;
                    }
                    let ball = self.ball(j);
                    let w = v3(ball.centre_radius) - o;
                    let tc = w.dot(d);
                    let cr = w.cross(d);
                    let h2 = cr.dot(cr);
                    if tc >= t_cur && tc <= t_next {
                        let r = ball.centre_radius[3];
                        let gmax = ball.coeffs[0] * mb_kernel(kernel, h2 / (r * r)) - tt;
                        let delta = mb_delta(ball.coeffs[0].abs() + tt, x + t_next, ball.coeffs[2]);
                        if gmax.abs() <= delta {
                            hit.flags |= MB_TANGENT;
                        }
                    }
                } else if count >= 2 {
                    let bound = self.field_bound(live, t_cur, t_next);
                    clip = bound >= tt - mb_delta(bound + tt, x + t_next, 0.0);
                }
                if !found && !clip {
                    t_cur = t_next;
                }
                if clip {
                    break;
                }
            }
            // `more` of the shader: an interval to clip.
            if !clip || found {
                break;
            }
            let mut c = [-tt; 7];
            let mut scale = [0.0f32; 7];
            let mut gsum = 0.0f32;
            let mut m = live;
            while m != 0 {
                let j = m.trailing_zeros() as usize;
                m &= m - 1;
                let ct = self.slots.chord[j];
                let [a, q] = self.slots.shape[j];
                let chord = ct[1] - ct[0];
                let sa = ((t_cur - ct[0]) / chord).clamp(0.0, 1.0);
                let sb = ((t_next - ct[0]) / chord).clamp(0.0, 1.0);
                let mut dj = [0.0f32; 7];
                mb_chord_bernstein(kernel, a, q, &mut dj);
                mb_restrict(&mut dj, sa, sb);
                for k in 0..7 {
                    c[k] += dj[k];
                    scale[k] += dj[k].abs();
                }
                gsum += self.slots.meta[j].0;
            }
            let mut s = 0.0f32;
            for &sk in &scale {
                s = s.max(sk);
            }
            let delta = mb_delta(s + tt, x + t_next, gsum);
            let tol = self.g.params[1];
            let alpha_tol =
                if tol > 0.0 { MB_ALPHA_TOL.max(tol * self.r.ts / (t_next - t_cur)) } else { MB_ALPHA_TOL };
            let floor = MB_FLAT_C * MB_EPS * (s + tt);
            let alpha = mb_first_root(&c, floor, delta, alpha_tol, &mut hit.iterations, &mut hit.flags);
            if hit.flags & MB_NOT_CONVERGED != 0 {
                return hit;
            }
            if alpha >= 0.0 {
                if mb_shallow_root(&c, alpha, delta) {
                    hit.flags |= MB_TANGENT;
                }
                t_found = t_cur + alpha * (t_next - t_cur);
                found = true;
                break;
            }
            t_cur = t_next;
        }
        if found {
            self.finish(&mut hit, live, t_found);
        }
        hit
    }

    /// `mb_trace_probe`: (F, L, next entry) at t′.
    fn probe(&self, t: f32) -> (f32, f32, f32) {
        let kernel = self.g.info[0];
        let (mut f, mut l, mut next_en) = (0.0f32, 0.0f32, f32::MAX);
        for j in 0..self.n {
            if !self.mine(j) {
                continue;
            }
            let [en, ex] = self.slots.chord[j];
            let [a, q] = self.slots.shape[j];
            let half_chord = 0.5 * (ex - en);
            let s = (t - (en + half_chord)) / half_chord;
            let v = q * mb_kernel(kernel, 1.0 - a * (1.0 - s * s));
            f += if en <= t && t <= ex { v } else { 0.0 };
            l += if en <= t && t < ex { self.slots.meta[j].0 } else { 0.0 };
            if en > t {
                next_en = next_en.min(en);
            }
        }
        (f, l, next_en)
    }

    /// `mb_trace_slots`.
    fn trace(&self, t0: f32, t_end: f32, mut hit: MetaHitF32) -> MetaHitF32 {
        let tt = self.g.params[0];
        let steps = self.g.params[2] as u32;
        let mut p = self.probe(t0);
        let inside = p.0 >= tt;
        let (mut t, mut t_prev) = (t0, t0);
        let mut bracket = false;
        let mut k = 0u32;
        loop {
            let gap = if inside { p.0 - tt } else { tt - p.0 };
            if gap <= 0.0 {
                bracket = true;
                break;
            }
            if t >= t_end || k >= steps {
                break;
            }
            let step = if p.1 > 0.0 { gap.max(MB_TRACE_MIN_STEP * tt) / p.1 } else { t_end - t };
            t_prev = t;
            t = (t + step).min(p.2).min(t_end);
            p = self.probe(t);
            k += 1;
        }
        hit.iterations += k;
        if !bracket {
            if t < t_end {
                hit.flags |= MB_NOT_CONVERGED;
            }
            return hit;
        }
        let (mut lo, mut hi) = (t_prev, t);
        for _ in 0..MB_TRACE_BISECT {
            let mid = 0.5 * (lo + hi);
            if (self.probe(mid).0 >= tt) == inside {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        self.finish(&mut hit, self.mask, 0.5 * (lo + hi));
        hit
    }
}

/// `metaball_cast` of shaders/common/metaballs.glsl in f32, line by line: the group's header,
/// the ball buffer, the pixel's list of ball indices (`MB_INDEX(k)` = `list[k]`), the world ray
/// (`dir` unit), [t_min, t_max] in world distances, and the method (`trace`: sphere tracing).
#[allow(clippy::too_many_arguments)]
pub fn cast_f32(
    g: &GpuMetaGroup,
    balls: &[GpuMetaBall],
    list: &[u32],
    origin: Vec3,
    dir: Vec3,
    t_min: f32,
    t_max: f32,
    trace: bool,
) -> MetaHitF32 {
    let mut hit = MetaHitF32 { normal: -dir, t: t_max, flags: 0, iterations: 0 };
    let to_object = Mat4::from_cols_array_2d(&g.to_object);
    let o = (to_object * origin.extend(1.0)).truncate();
    let dv = (to_object * dir.extend(0.0)).truncate();
    let ts = dv.length();
    let r = MetaRay { o, d: dv / ts, ts };
    let t0 = t_min * ts;
    let t1 = t_max * ts;
    if t0.is_nan() || t1.is_nan() || t1 < t0 {
        return hit;
    }

    // Rounds, as the shader's: up to the first ball left out; streamed where more than
    // MB_MAX_RAY_BALLS supports contain t0.
    let mut t0 = t0;
    for _ in 0..=list.len() {
        let mut slots = Slots::new();
        let mut n = 0usize;
        let mut t_limit = t1;
        for &id in list {
            let mut j = n.min(MB_MAX_RAY_BALLS - 1);
            if n == MB_MAX_RAY_BALLS {
                let mut latest = slots.chord[0][0];
                j = 0;
                for i in 1..MB_MAX_RAY_BALLS {
                    if slots.chord[i][0] > latest {
                        latest = slots.chord[i][0];
                        j = i;
                    }
                }
                let slot0 = slots.get(j);
                if !mb_chord(&mut slots, j, balls, id, r.o, r.d, t0, t1) {
                    continue;
                }
                if slots.chord[j][0] >= latest {
                    t_limit = t_limit.min(slots.chord[j][0]);
                    slots.set(j, slot0);
                } else {
                    t_limit = t_limit.min(latest);
                }
            } else if mb_chord(&mut slots, j, balls, id, r.o, r.d, t0, t1) {
                n += 1;
            }
        }
        // (NaN-safe as the shader's `!(t_limit > t0)`: t0 and t1 were checked above.)
        if t_limit <= t0 {
            hit.flags |= MB_STREAMED;
            return stream::clip_stream(g, balls, list, &r, dir, t0, t1, hit);
        }
        let t_end = t1.min(t_limit);
        let mask = if n >= 32 { u32::MAX } else { (1u32 << n) - 1 };
        let cast = Cast { g, balls, slots, n, mask, r, dir };
        hit = if trace { cast.trace(t0, t_end, hit) } else { cast.clip(t0, t_end, hit) };
        if hit.flags & (MB_HIT | MB_NOT_CONVERGED) != 0 || t_limit >= t1 {
            return hit;
        }
        t0 = t_limit;
    }
    hit.flags |= MB_NOT_CONVERGED;
    hit
}

/// A whole group packed once, for casting many rays on the CPU with [`cast_f32`].
#[derive(Clone, Debug)]
pub struct PackedGroup {
    pub header: GpuMetaGroup,
    pub balls: Vec<GpuMetaBall>,
    /// 0..n: every ball of the group.
    pub list: Vec<u32>,
    /// The group's method is sphere tracing.
    pub trace: bool,
}

impl PackedGroup {
    pub fn new(group: &MetaballGroupParams) -> PackedGroup {
        // Placed from its anchor, as the pass places them.
        let from = anchor(group);
        let balls = gpu_balls_cached(group, &mut IsoCache::default(), from);
        let list = (0..balls.len() as u32).collect();
        let trace = matches!(group.method, CastMethod::SphereTrace { .. });
        PackedGroup { header: gpu_group(group, 0, 0, (DVec3::ZERO, from)), balls, list, trace }
    }

    /// [`cast_f32`] with every ball of the group listed, by the group's method; the ray rounded
    /// to f32.
    pub fn cast(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> MetaHitF32 {
        cast_f32(
            &self.header,
            &self.balls,
            &self.list,
            origin.as_vec3(),
            dir.as_vec3(),
            t_min as f32,
            t_max as f32,
            self.trace,
        )
    }
}

/// Where a ray stands with respect to the tangency band (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tangency {
    /// min |g(t*)|/(S + X·G) over the candidate points (∞ when there are none): how far, in units
    /// of the f32 error scale divided by ε, the ray stays from touching the threshold.
    pub margin: f64,
}

impl Tangency {
    /// δ-close: margin ≤ BAND_C·ε_f32. An f32 cast may legitimately differ from f64 here.
    pub fn in_band(&self) -> bool {
        self.margin <= BAND_C * f64::from(f32::EPSILON)
    }
}

/// The tangency margin of a world ray (`dir` unit) over [t_min, t_max], in f64 and independent of
/// the clipping: g as power-basis pieces ([`field_pieces`]), its critical points by the derivative
/// cascade, the first hit from the same pieces.
pub fn tangency(group: &MetaballGroupParams, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> Tangency {
    let mut margin = f64::INFINITY;
    let Some((ray, t0, t1)) = super::metaballs::object_interval(group, origin, dir, t_min, t_max) else {
        return Tangency { margin };
    };
    let pieces = field_pieces(group, &ray, t0, t1);
    let t_hit = pieces.iter().find_map(|p| roots_in_unit(&p.poly).first().map(|&u| p.t0 + u * (p.t1 - p.t0)));
    let rb = ray_balls(group, &ray, t0, t1);
    // Positions as the f32 cast holds them: from the group's anchor (`gpu_group`).
    let x0 = (ray.origin - anchor(group)).length();
    let gamma = group.kernel.max_slope();
    for p in &pieces {
        let mut parts = Vec::with_capacity(p.balls.len());
        let mut g_sum = 0.0;
        for &i in &p.balls {
            let b = &group.balls[i];
            g_sum += b.q.abs() * gamma / b.radius;
            if let Some(r) = rb.iter().find(|r| r.index == i) {
                parts.push(interval_bernstein(group.kernel, b.q, r, p.t0, p.t1));
            }
        }
        let unit = coefficient_scale(&parts, group.threshold) + (x0 + p.t1) * g_sum;
        let mut consider = |u: f64| margin = margin.min(eval_poly(&p.poly, u).abs() / unit);
        if p.t0 == t0 {
            consider(0.0);
        }
        if t_hit.is_none() && p.t1 == t1 {
            consider(1.0);
        }
        for u in roots_in_unit(&derivative(&p.poly)) {
            consider(u);
            if t_hit.is_some_and(|th| p.t0 + u * (p.t1 - p.t0) > th) {
                return Tangency { margin };
            }
        }
    }
    Tangency { margin }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::metaballs::{Ball, Kernel};
    use crate::scene::transform::Transform;

    #[test]
    fn constants_are_the_nearest_f32() {
        assert_eq!(MB_W6_K3, -4.0f32 / 9.0);
        assert_eq!(MB_W6_K2, 17.0f32 / 9.0);
        assert_eq!(MB_W6_K1, -22.0f32 / 9.0);
        assert_eq!(MB_W6_D2, -4.0f32 / 3.0);
        assert_eq!(MB_W6_D1, 34.0f32 / 9.0);
        assert_eq!(MB_W6_B2, 16.0f32 / 27.0);
        assert_eq!(MB_W6_B3, 8.0f32 / 45.0);
        assert_eq!(MB_M4_B2, 16.0f32 / 15.0);
        assert_eq!(MB_ALPHA_TOL, 2.0f32.powi(-22));
        assert_eq!(Kernel::Wyvill6.gpu_id(), MB_KERNEL_WYVILL6);
    }

    #[test]
    fn single_ball_f32() {
        let g = MetaballGroupParams {
            threshold: 0.5,
            kernel: Kernel::Wyvill6,
            balls: vec![Ball { centre: DVec3::ZERO, radius: 2.0, q: 1.0 }],
            transform: Transform::IDENTITY,
            method: Default::default(),
        };
        let packed = PackedGroup::new(&g);
        let h = packed.cast(DVec3::new(0.0, 0.0, 10.0), -DVec3::Z, 0.0, 100.0);
        assert!(h.hit() && (h.t - 9.0).abs() < 1e-6, "{h:?}");
        assert_eq!(packed.balls[0].coeffs[1], 1.0);
    }

    #[test]
    fn world_bound_covers_scaled_support() {
        use crate::scene::transform::TransformOp;
        let t = Transform::from_ops(&[TransformOp::Scale(DVec3::new(3.0, 1.0, 0.5))]).unwrap();
        let g = MetaballGroupParams {
            threshold: 0.5,
            kernel: Kernel::Wyvill6,
            balls: vec![Ball { centre: DVec3::X, radius: 2.0, q: 1.0 }],
            transform: t,
            method: Default::default(),
        };
        let (c, r) = world_bound(&g, 0);
        assert!((c - DVec3::new(3.0, 0.0, 0.0)).length() < 1e-12);
        assert!((r - 6.0).abs() < 1e-6 && r >= 6.0, "{r}");
    }
}
