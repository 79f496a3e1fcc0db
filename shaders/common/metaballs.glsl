// Metaballs (seed 000): ray cast of one metaball group by support-sphere intervals, the lone-ball
// sphere path and Bézier clipping of the summed Bernstein coefficients; or, for the
// speed-against-error comparison, sphere tracing (mb_trace_slots).
// CPU twins: crates/hadou/src/effects/metaballs.rs (f64 reference, the math in its module docs),
// crates/hadou/src/effects/metaballs_trace.rs (the sphere tracer in f64) and crates/hadou/src/effects/metaballs_f32.rs
// (this arithmetic, line by line: keep the two in sync).
//
// Include it twice: the first time gives the structs (so the caller can declare its buffers of
// them), the second time, once the caller has defined how to read those buffers, the functions:
//
//   #include "common/metaballs.glsl"          // MetaGroup, MetaBall, MetaHit, MB_* constants
//   layout(set = 0, binding = 1, std430) readonly buffer Balls { MetaBall balls[]; };
//   layout(set = 0, binding = 2, std430) readonly buffer Lists { uint ball_list[]; };
//   #define MB_BALL(i) balls[i]               // a MetaBall: ball i (a global index)
//   #define MB_INDEX(k) ball_list[k]          // a uint: entry k of the pixel's/tile's ball list
//   #include "common/metaballs.glsl"          // metaball_cast and its helpers
//
// For a group's whole range: #define MB_INDEX(k) (k) and pass list_begin = info.y,
// list_count = info.z. A list may hold any superset of the balls whose support the ray crosses,
// in any order, but only balls of the group passed to metaball_cast. metaball_cast fills the chord
// slots (mb_chord_t, mb_shape, mb_iso, mb_meta) itself; shaders/metaballs.comp fills them per
// subgroup (mb_fill_slot) and calls mb_clip_slots / mb_trace_slots directly.
#ifndef HADOU_METABALLS_STRUCTS
#define HADOU_METABALLS_STRUCTS

// Keep in sync with GpuMetaGroup in crates/hadou/src/effects/metaballs_f32.rs (224 bytes, std430; asserted there).
struct MetaGroup {
    // World coordinates here are relative to the camera (world − camera position, composed on the
    // host in f64: no f32 product cancels far from the origin), so a pixel's ray starts at 0.
    mat4 to_object;      // M⁻¹: world → the group's object space
    mat4 to_world;       // M: object → world (not needed by the cast; for culling and binning)
    mat4 normal_matrix;  // M⁻ᵀ in the upper 3×3: object normal → world normal
    vec4 params;         // x: threshold T > 0, y: Bézier-clipping tolerance (world distance; 0: the
                         // default MB_ALPHA_TOL), z: sphere-tracing steps (method sphere_trace), w: 0
    uvec4 info;          // x: kernel (MB_KERNEL_*), y: first ball, z: ball count, w: material index
};

// Keep in sync with GpuMetaBall in crates/hadou/src/effects/metaballs_f32.rs (32 bytes, std430; asserted there).
struct MetaBall {
    vec4 centre_radius;  // xyz: object-space centre c, w: support radius R > 0
    vec4 coeffs;         // x: q, y: ρ*·R, the lone ball's isosurface radius (0: none),
                         // z: |q|·γ/R (bound on ‖∇(q f)‖, γ the kernel's max slope), w: 0
};

// What metaball_cast returns. Keep in sync with MetaHitF32 in crates/hadou/src/effects/metaballs_f32.rs.
struct MetaHit {
    vec3 normal;      // world unit normal −∇F (out of the blob); valid with MB_HIT
    float t;          // world distance along dir: the hit with MB_HIT
    uint flags;       // MB_HIT | MB_TANGENT | MB_STREAMED | MB_NOT_CONVERGED
    uint iterations;  // Bézier-clipping steps spent
};

#define MB_KERNEL_WYVILL6 0u
#define MB_KERNEL_MURAKAMI4 1u

#define MB_HIT 1u            // t and normal are set
#define MB_TANGENT 2u        // the ray passed within δ of the threshold (near miss or double root)
#define MB_STREAMED 4u       // more than MB_MAX_RAY_BALLS supports contain one point before the
                             // answer: from there the cast went on by mb_clip_stream (Bézier
                             // clipping whatever the method)
#define MB_NOT_CONVERGED 8u  // MB_MAX_ITERATIONS clip steps spent: reported as a miss

// Support spheres kept per ray (the nearest by entry; see MB_STREAMED).
#define MB_MAX_RAY_BALLS 32
// Clip steps per cast; the tests measure 3.5 per hit on average, at most 8, and 7 on a tangent ray.
#define MB_MAX_ITERATIONS 256u
// Subdivision stack: every pushed half is wider than MB_ALPHA_TOL/2 and at most half the one
// below it, so at most log2(1/MB_ALPHA_TOL) = 22 entries are ever live.
#define MB_STACK_SIZE 24

const float MB_ALPHA_TOL = 2.384185791015625e-7;  // 2^-22: stop when the part is this narrow in α
const float MB_SPLIT_RATIO = 0.7;                 // split when a clip keeps > 70% of the width
const float MB_EPS = 1.1920928955078125e-7;       // 2^-23, f32 epsilon
const float MB_BAND_C = 16.0;                     // δ = MB_BAND_C·ε·(S + X·G), see mb_delta and
                                                  // the calibration in metaballs_f32.rs
const float MB_FLAT_C = 16.0;                     // a part within MB_FLAT_C·ε·S of zero is a root
const float MB_TRACE_MIN_STEP = 9.765625e-4;      // 2^-10: sphere tracing's least step, × T/L
#define MB_TRACE_BISECT 16                        // bisections of a sphere-tracing bracket
// Walks per chord end a streamed cast may spend (mb_clip_stream): two per piece, and one per
// doubling of the window between two chord ends (at most ~280 across the f32 range).
#define MB_STREAM_WALKS 300u

// ‖c − o‖ − R of a ball, less a margin for the f32 arithmetic: a lower bound of the distance t′
// at which a ray from o (object space) enters its support.
float mb_entry_key(MetaBall ball, vec3 o) {
    float key = length(ball.centre_radius.xyz - o) - ball.centre_radius.w;
    return key - 1e-5 * (abs(key) + 2.0 * ball.centre_radius.w);
}

#endif  // HADOU_METABALLS_STRUCTS

#if defined(MB_BALL) && defined(MB_INDEX) && !defined(HADOU_METABALLS_CAST)
#define HADOU_METABALLS_CAST

// Loops here test their exit at the end of the body (do-while): lavapipe runs a `for` or `while`
// loop's test at the top of the next pass, so its last pass runs the whole body once more with
// every lane masked off (measured on the metaballs pass: see docs/PERFORMANCE.md). A body must
// then be right for a lane with nothing left to do, hence the `some` guards (MB_NEXT_BIT).
// MB_NEXT_BIT(m, j, some): j = the lowest set bit of m (0 if none, with some = false), cleared.
#define MB_NEXT_BIT(m, j, some)  \
    bool some = (m) != 0u;       \
    int j = max(findLSB(m), 0);  \
    (m) &= (m) - 1u
// 0: skip the MB_TANGENT tests of the lone-ball graze and of shallow roots (a caller that never
// reads the flag, like metaballs.comp, saves their code: lavapipe runs it for every lane). The
// hit, its t and its normal are the same either way.
#ifndef MB_TANGENT_FLAGS
#define MB_TANGENT_FLAGS 1
#endif

// wyvill6 f(r') = ((K3·r' + K2)·r' + K1)·r' + 1 and f'(r') = (3K3·r' + 2K2)·r' + K1.
const float MB_W6_K3 = -0.44444445;  // -4/9
const float MB_W6_K2 = 1.8888888;    // 17/9
const float MB_W6_K1 = -2.4444444;   // -22/9
const float MB_W6_D2 = -1.3333334;   // -4/3
const float MB_W6_D1 = 3.7777777;    // 34/9
// Bernstein coefficients along a chord: wyvill6 d2 = d4 = 16/27 a², d3 = 8(8a+5)a²/45;
// murakami4 (degree-elevated) d2 = d4 = 16/15 a², d3 = 8/5 a².
const float MB_W6_B2 = 0.5925926;    // 16/27
const float MB_W6_B3 = 0.17777778;   // 8/45
const float MB_M4_B2 = 1.0666667;    // 16/15
const float MB_M4_B3 = 1.6;          // 8/5
// wyvill6 f = (1 − r′)²·(MB_W6_M0 + MB_W6_M1·(1 − r′)) (mb_piece_bernstein), and its weights.
const float MB_W6_M0 = 0.5555556;    // 5/9
const float MB_W6_M1 = 0.44444445;   // 4/9
const float MB_THIRD = 0.33333334;
const float MB_TWO_THIRDS = 0.6666667;
const float MB_15TH = 0.06666667;
const float MB_EIGHT_15THS = 0.53333336;

float mb_kernel(uint kernel, float rp) {
    if (rp >= 1.0) return 0.0;
    if (kernel == MB_KERNEL_WYVILL6) return ((MB_W6_K3 * rp + MB_W6_K2) * rp + MB_W6_K1) * rp + 1.0;
    return (1.0 - rp) * (1.0 - rp);
}

// df/dr' by Horner (seed eq. 26).
float mb_kernel_deriv(uint kernel, float rp) {
    if (rp >= 1.0) return 0.0;
    if (kernel == MB_KERNEL_WYVILL6) return (MB_W6_D2 * rp + MB_W6_D1) * rp + MB_W6_K1;
    return -2.0 * (1.0 - rp);
}

// q·f along a support chord s ∈ [0, 1] as 7 Bernstein coefficients, a = D/R² (seed eq. 19).
void mb_chord_bernstein(uint kernel, float a, float q, out float d[7]) {
    float a2 = a * a;
    float d2 = kernel == MB_KERNEL_WYVILL6 ? MB_W6_B2 * a2 : MB_M4_B2 * a2;
    float d3 = kernel == MB_KERNEL_WYVILL6 ? MB_W6_B3 * (8.0 * a + 5.0) * a2 : MB_M4_B3 * a2;
    d[0] = 0.0;
    d[1] = 0.0;
    d[2] = q * d2;
    d[3] = q * d3;
    d[4] = q * d2;
    d[5] = 0.0;
    d[6] = 0.0;
}

// The same curve over [u0, u1] ⊂ [0, 1]: de Casteljau's left part at u1, then the right part of
// that at u0/u1. Written out step by step: on lavapipe an array indexed by a loop counter lives in
// memory and every access is a per-lane gather or scatter, while constant indices keep it in
// registers (measured: 0.66× the pass time of the two nested loops).
#define MB_LEFT(j) c[j] = c[j - 1] * w1 + c[j] * u1;
#define MB_RIGHT(j) c[j] = c[j] * w0 + c[j + 1] * v;
void mb_restrict(inout float c[7], float u0, float u1) {
    if (u1 < 1.0) {
        float w1 = 1.0 - u1;
        MB_LEFT(6) MB_LEFT(5) MB_LEFT(4) MB_LEFT(3) MB_LEFT(2) MB_LEFT(1)
        MB_LEFT(6) MB_LEFT(5) MB_LEFT(4) MB_LEFT(3) MB_LEFT(2)
        MB_LEFT(6) MB_LEFT(5) MB_LEFT(4) MB_LEFT(3)
        MB_LEFT(6) MB_LEFT(5) MB_LEFT(4)
        MB_LEFT(6) MB_LEFT(5)
        MB_LEFT(6)
    }
    if (u0 > 0.0) {
        float v = u1 > 0.0 ? min(u0 / u1, 1.0) : 0.0;
        float w0 = 1.0 - v;
        MB_RIGHT(0) MB_RIGHT(1) MB_RIGHT(2) MB_RIGHT(3) MB_RIGHT(4) MB_RIGHT(5)
        MB_RIGHT(0) MB_RIGHT(1) MB_RIGHT(2) MB_RIGHT(3) MB_RIGHT(4)
        MB_RIGHT(0) MB_RIGHT(1) MB_RIGHT(2) MB_RIGHT(3)
        MB_RIGHT(0) MB_RIGHT(1) MB_RIGHT(2)
        MB_RIGHT(0) MB_RIGHT(1)
        MB_RIGHT(0)
    }
}

// [lo, hi] where the convex hull of the control polygon (k/6, c_k) meets the axis; lo > hi when
// it does not: every control point on the axis and every crossing of a segment between two
// points of opposite signs (all pairs, written out for constant indices as in mb_restrict).
#define MB_ON_AXIS(i) if (c[i] == 0.0) { lo = min(lo, float(i) / 6.0); hi = max(hi, float(i) / 6.0); }
#define MB_CROSS(i, j)                                                           \
    if ((c[i] < 0.0 && c[j] > 0.0) || (c[i] > 0.0 && c[j] < 0.0)) {              \
        float x = (float(i) + float(j - i) * (c[i] / (c[i] - c[j]))) / 6.0;     \
        lo = min(lo, x);                                                         \
        hi = max(hi, x);                                                         \
    }
vec2 mb_hull_crossing(float c[7]) {
    float lo = 2.0;
    float hi = -1.0;
    MB_ON_AXIS(0) MB_CROSS(0, 1) MB_CROSS(0, 2) MB_CROSS(0, 3) MB_CROSS(0, 4) MB_CROSS(0, 5) MB_CROSS(0, 6)
    MB_ON_AXIS(1) MB_CROSS(1, 2) MB_CROSS(1, 3) MB_CROSS(1, 4) MB_CROSS(1, 5) MB_CROSS(1, 6)
    MB_ON_AXIS(2) MB_CROSS(2, 3) MB_CROSS(2, 4) MB_CROSS(2, 5) MB_CROSS(2, 6)
    MB_ON_AXIS(3) MB_CROSS(3, 4) MB_CROSS(3, 5) MB_CROSS(3, 6)
    MB_ON_AXIS(4) MB_CROSS(4, 5) MB_CROSS(4, 6)
    MB_ON_AXIS(5) MB_CROSS(5, 6)
    MB_ON_AXIS(6)
    return vec2(clamp(lo, 0.0, 1.0), clamp(hi, 0.0, 1.0));
}

// The band half-width δ = MB_BAND_C·ε·(S + X·G) of an interval: S its coefficient scale
// (max_k Σ|q d_k| + T), G = Σ|q|γ/R over its balls, X the object-space coordinate scale.
float mb_delta(float S, float X, float G) {
    return MB_BAND_C * MB_EPS * (S + X * G);
}

// The smallest root α ∈ [0, 1] of the Bernstein polynomial `base` by Bézier clipping, or -1.
// Clipping stops at a part narrower than MB_ALPHA_TOL, or at one at most alpha_tol wide (the
// group's tolerance) whose end values differ in sign, and returns its middle.
// Parts are searched left half first, from an explicit stack. `flat_floor` (MB_FLAT_C·ε·S) is
// the noise rounding leaves in the coefficients; below it a value is indistinguishable from 0:
// - a part whose control points all lie within it is a root (its middle);
// - a part whose control points share one sign holds no root, unless an end value is within it:
//   then that end is the root (a root on a part's edge must not fall between two parts whose
//   rounded end values disagree in sign);
// - a dropped part whose interior control points come within δ of zero from below is a near
//   miss and flags MB_TANGENT.
float mb_first_root(float base[7], float flat_floor, float delta, float alpha_tol, inout uint iterations,
                    inout uint flags) {
    vec2 stack[MB_STACK_SIZE];
    int sp = 0;
    float a = 0.0;
    float b = 1.0;
    float c[7] = base;
    bool narrow = false;  // the part is at most alpha_tol wide (a coarser tolerance than the default)
    // Every pass pops a part, returns, or spends a clip step; pops never outnumber pushes. Each
    // pass ends in one restriction (lavapipe runs every branch's code for the whole SIMD group,
    // so one call at the end costs a third of one per branch): from `base` to [a, b] after a pop,
    // else from the clipped part to the kept share [u0, u1] of it.
    for (uint guard = 0u; guard < 2u * MB_MAX_ITERATIONS + 2u; ++guard) {
        bool all_pos = true;
        bool all_neg = true;
        float largest = 0.0;
        float inner_max = -3.402823466e38;
        for (int k = 0; k < 7; ++k) {
            all_pos = all_pos && c[k] > 0.0;
            all_neg = all_neg && c[k] < 0.0;
            largest = max(largest, abs(c[k]));
            if (k > 0 && k < 6) inner_max = max(inner_max, c[k]);
        }
        if (largest <= flat_floor) return 0.5 * (a + b);
        // A narrow part whose ends differ in sign holds a root within half its width. (One whose
        // ends agree may hold none: the hull can cross the axis above a curve that does not.)
        if (narrow && !(c[0] > 0.0 && c[6] > 0.0) && !(c[0] < 0.0 && c[6] < 0.0)) return 0.5 * (a + b);
        bool pop = all_pos || all_neg;
        float u0 = a;
        float u1 = b;
        if (pop) {
            if (abs(c[0]) <= flat_floor) return a;
            if (abs(c[6]) <= flat_floor) return b;
            if (all_neg && inner_max >= -delta) flags |= MB_TANGENT;
            if (sp == 0) return -1.0;
            --sp;
            a = stack[sp].x;
            b = stack[sp].y;
            u0 = a;
            u1 = b;
            narrow = false;
        } else {
            if (iterations >= MB_MAX_ITERATIONS) {
                flags |= MB_NOT_CONVERGED;
                return -1.0;
            }
            vec2 h = mb_hull_crossing(c);
            iterations += 1u;
            float na = a + h.x * (b - a);
            float nb = a + h.y * (b - a);
            if (nb - na <= MB_ALPHA_TOL) return 0.5 * (na + nb);
            narrow = nb - na <= alpha_tol;
            a = na;
            b = nb;
            u0 = h.x;
            u1 = h.y;
            if (h.y - h.x > MB_SPLIT_RATIO && !narrow) {
                if (sp < MB_STACK_SIZE) {
                    float m = 0.5 * (a + b);
                    stack[sp] = vec2(m, b);
                    ++sp;
                    u1 = h.x + 0.5 * (h.y - h.x);
                    b = m;
                } else {
                    flags |= MB_NOT_CONVERGED;  // unreachable (see MB_STACK_SIZE)
                    return -1.0;
                }
            }
        }
        if (pop) c = base;
        mb_restrict(c, u0, u1);
    }
    flags |= MB_NOT_CONVERGED;
    return -1.0;
}

// Whether the root α of `base` is shallow: an extremum of g within δ of zero may lie beside it.
// Near a root g ≈ s·(α' − α) + ½κ(α' − α)², whose extremum −s²/(2κ) is within δ of zero when
// s² ≤ 2κδ; s = g'(α) from the end leg of the part on the longer side of α, κ ≤ M2 =
// 30·max|Δ²c| (the second derivative's Bernstein bound), all per unit α.
bool mb_shallow_root(float base[7], float alpha, float delta) {
    float c[7] = base;
    float m2 = 0.0;
    for (int k = 0; k < 5; ++k) m2 = max(m2, abs(c[k + 2] - 2.0 * c[k + 1] + c[k]));
    m2 *= 30.0;
    float s;
    if (alpha < 0.5) {
        mb_restrict(c, alpha, 1.0);
        s = 6.0 * (c[1] - c[0]) / (1.0 - alpha);
    } else {
        mb_restrict(c, 0.0, alpha);
        s = 6.0 * (c[6] - c[5]) / alpha;
    }
    return s * s <= 2.0 * m2 * delta;
}

// The ray's support chords, in slots 0 … slots−1 (object-space t′; a slot's bit in the cast's
// `mask` says it belongs to this ray). No sorting: the sweep finds the next chord end by a scan.
// On lavapipe every access to these arrays by a non-constant index (uniform or not) is a per-lane
// gather or scatter, one per component, so a slot holds only what the cast reads of its ball,
// computed once when it is filled, in arrays split by who reads them: the sweep's scan reads
// `mb_chord_t`, the field bound and the Bernstein coefficients `mb_shape`, the lone-ball path
// `mb_iso`. The normal reads the ball itself through its id (once per hit). (Measured: 0.73× the
// pass time of slots holding their ball's copy, MetaBall mb_ball[], read back in every part.)
vec2 mb_chord_t[MB_MAX_RAY_BALLS];  // x: chord entry, y: chord exit
vec2 mb_shape[MB_MAX_RAY_BALLS];    // x: a = D/R² (seed eq. 16), D = (half the chord)²; y: q
vec2 mb_iso[MB_MAX_RAY_BALLS];      // the near and far t′ where the ray crosses the ball's lone
                                    // isosurface sphere (seed section 2.1); MB_NO_ISO when it does not
vec2 mb_meta[MB_MAX_RAY_BALLS];     // x: |q|·γ/R (coeffs.z); y: the ball's id (uintBitsToFloat)

const float MB_NO_ISO = -3.402823466e38;

// a = D/R² (seed eq. 16) of a chord, D = (half its length)².
float mb_chord_a(vec2 chord, float R) {
    float half_chord = 0.5 * (chord.y - chord.x);
    return half_chord * half_chord / (R * R);
}

// The near and far t′ of the ray o + t′·d (d unit) on the lone isosurface sphere of radius rr
// about o + w (tc = w·d, h2 = |w × d|²), or MB_NO_ISO twice: the nearer root from the product of
// the two, so neither cancels.
vec2 mb_iso_sphere(vec3 w, float tc, float h2, float rr) {
    float disc = rr * rr - h2;
    if (!(rr > 0.0 && disc >= 0.0)) return vec2(MB_NO_ISO);
    float root = sqrt(disc);
    float wl = length(w);
    float prod = (wl - rr) * (wl + rr);
    float near_t;
    float far_t;
    if (tc > 0.0) {
        far_t = tc + root;
        near_t = prod / far_t;
    } else {
        near_t = tc - root;
        far_t = near_t != 0.0 ? prod / near_t : tc + root;
    }
    return vec2(near_t, far_t);
}

// Fills slot j with the chord [en, ex] of `ball` (global index id; w = centre − o, tc = w·d,
// h2 = |w × d|² as the chord was computed from).
void mb_fill_slot(uint j, MetaBall ball, uint id, vec3 w, float tc, float h2, float en, float ex) {
    vec2 chord = vec2(en, ex);
    mb_chord_t[j] = chord;
    mb_shape[j] = vec2(mb_chord_a(chord, ball.centre_radius.w), ball.coeffs.x);
    mb_iso[j] = mb_iso_sphere(w, tc, h2, ball.coeffs.y);
    mb_meta[j] = vec2(ball.coeffs.z, uintBitsToFloat(id));
}

// Fills slot j from ball `id` when its support chord crosses (t0, t1); false when it does not.
bool mb_chord(uint j, uint id, vec3 o, vec3 d, float t0, float t1) {
    MetaBall ball = MB_BALL(id);
    vec3 w = ball.centre_radius.xyz - o;
    float tc = dot(w, d);
    vec3 cr = cross(w, d);
    float h2 = dot(cr, cr);
    float R = ball.centre_radius.w;
    float D = R * R - h2;
    if (!(D > 0.0)) return false;
    float half_chord = sqrt(D);
    float en = tc - half_chord;
    float ex = tc + half_chord;
    if (ex <= t0 || en >= t1) return false;
    mb_fill_slot(j, ball, id, w, tc, h2, en, ex);
    return true;
}

// The object-space ray of a world ray (seed 002): o + t′·d with t′ = t·ts.
struct MetaRay {
    vec3 o;
    vec3 d;
    float ts;
};

MetaRay mb_object_ray(MetaGroup g, vec3 origin, vec3 dir) {
    MetaRay r;
    r.o = (g.to_object * vec4(origin, 1.0)).xyz;
    vec3 dv = (g.to_object * vec4(dir, 0.0)).xyz;
    r.ts = length(dv);
    r.d = dv / r.ts;
    return r;
}

// The hit at object-space t_found with the field's gradient there (object space): the normal
// −∇F mapped by M⁻ᵀ.
void mb_finish_grad(inout MetaHit hit, MetaGroup g, MetaRay r, vec3 dir, vec3 grad, float t_found) {
    vec3 nw = mat3(g.normal_matrix) * -grad;
    float len = length(nw);
    hit.normal = len > 0.0 ? nw / len : -dir;
    hit.t = t_found / r.ts;
    hit.flags |= MB_HIT;
}

// The hit at object-space t_found: the normal from the gradient (seed eq. 25) over the balls of
// the slots in `set` (those whose support contains the point; any others add nothing), mapped
// by M⁻ᵀ.
void mb_finish(inout MetaHit hit, MetaGroup g, MetaRay r, vec3 dir, uint set, float t_found) {
    uint kernel = g.info.x;
    vec3 p = r.o + r.d * t_found;
    vec3 grad = vec3(0.0);
    uint m = set;
    do {  // over the bits of m (MB_NEXT_BIT)
        MB_NEXT_BIT(m, j, some);
        if (some) {
            MetaBall ball = MB_BALL(floatBitsToUint(mb_meta[j].y));
            vec3 w = p - ball.centre_radius.xyz;
            float inv_r2 = 1.0 / (ball.centre_radius.w * ball.centre_radius.w);
            grad += w * (2.0 * ball.coeffs.x * inv_r2 * mb_kernel_deriv(kernel, dot(w, w) * inv_r2));
        }
    } while (m != 0u);
    mb_finish_grad(hit, g, r, dir, grad, t_found);
}

// An upper bound of F on [t_cur, t_next] ⊂ the chords of `live`: Σ max(q, 0)·f(r′_min), r′_min
// the least r′ = 1 − a·(1 − s²) of each chord on the interval (s ∈ [−1, 1] across the chord).
// Where it stays below T (by δ, so near misses still reach the clipping and its MB_TANGENT
// test) the interval holds no root and its Bernstein coefficients are never built.
float mb_field_bound(uint kernel, uint live, float t_cur, float t_next) {
    float B = 0.0;
    uint m = live;
    do {
        MB_NEXT_BIT(m, j, some);
        vec2 ct = mb_chord_t[j];
        vec2 shape = mb_shape[j];
        float half_chord = 0.5 * (ct.y - ct.x);
        float mid = ct.x + half_chord;
        float s0 = (t_cur - mid) / half_chord;
        float s1 = (t_next - mid) / half_chord;
        float s2 = s0 <= 0.0 && s1 >= 0.0 ? 0.0 : min(s0 * s0, s1 * s1);
        if (some) B += max(shape.y, 0.0) * mb_kernel(kernel, 1.0 - shape.x * (1.0 - s2));
    } while (m != 0u);
    return B;
}

// Bézier clipping over the slots' chords (seed section 2): the first crossing of F = T with
// t′ ∈ [t0, t_end]; a miss leaves hit.t as it was. On lavapipe both sides of every branch run
// for the whole SIMD group and a loop body runs at least once, so the sweep (cheap: the lone-ball
// sphere and the bound above) only stops at an interval that needs clipping, and the clipping
// (the bulk of the code) runs once per such interval, outside the sweep.
MetaHit mb_clip_slots(MetaGroup g, MetaRay r, vec3 dir, uint slots, uint mask, float t0, float t_end,
                      MetaHit hit) {
    uint kernel = g.info.x;
    float T = g.params.x;
    float X = length(r.o);
    float t_cur = t0;
    float t_found = 0.0;
    bool found = false;
    bool more = true;  // an interval left to clip
    uint sweep = 0u;   // intervals visited: at most 2·MB_MAX_RAY_BALLS + 1 in all
    uint live = 0u;    // the chords containing the interval [t_cur, t_next] (at the end: the hit's)
    do {
        // Sweep the intervals between chord ends, nearest first (seed section 2.3), to the next
        // one that needs clipping.
        float t_next = t_end;
        bool clip = false;
        bool step = !found && t_cur < t_end && sweep < uint(2 * MB_MAX_RAY_BALLS + 1);
        do {
            if (step) {
                ++sweep;
                live = 0u;
                t_next = t_end;
                uint j = 0u;
                do {
                    if (j < slots) {
                        float en = mb_chord_t[j].x;
                        float ex = mb_chord_t[j].y;
                        bool mine = (mask & (1u << j)) != 0u;
                        if (mine && en <= t_cur && ex > t_cur) live |= 1u << j;
                        if (mine && ex > t_cur) t_next = min(t_next, en > t_cur ? en : ex);
                    }
                    ++j;
                } while (j < slots);
                int count = bitCount(live);
                if (count == 1) {
                    // A lone ball: its isosurface is a sphere of radius ρ*R (seed section 2.1),
                    // crossed where the slot says.
                    int lone = findLSB(live);
                    vec2 iso = mb_iso[lone];
                    if (iso.x >= t_cur && iso.x <= t_next) {
                        t_found = iso.x;
                        found = true;
                    } else if (iso.y >= t_cur && iso.y <= t_next) {
                        t_found = iso.y;
                        found = true;
                    }
#if MB_TANGENT_FLAGS
                    MetaBall ball = MB_BALL(floatBitsToUint(mb_meta[lone].y));
                    vec3 w = ball.centre_radius.xyz - r.o;
                    float tc = dot(w, r.d);
                    vec3 cr = cross(w, r.d);
                    float h2 = dot(cr, cr);
                    if (tc >= t_cur && tc <= t_next) {
                        // The field's maximum on this ray is at the closest approach: within δ of
                        // T is a graze (a near miss, or a hit on the silhouette).
                        float R = ball.centre_radius.w;
                        float gmax = ball.coeffs.x * mb_kernel(kernel, h2 / (R * R)) - T;
                        float delta = mb_delta(abs(ball.coeffs.x) + T, X + t_next, ball.coeffs.z);
                        if (abs(gmax) <= delta) hit.flags |= MB_TANGENT;
                    }
#endif
                } else if (count >= 2) {
                    float B = mb_field_bound(kernel, live, t_cur, t_next);
                    // δ of the interval with B + T standing in for its coefficient scale S, and G
                    // the largest single |q|γ/R (both underestimates: the skip is the stricter
                    // for it).
                    clip = B >= T - mb_delta(B + T, X + t_next, 0.0);
                }
                if (!found && !clip) t_cur = t_next;
            }
            step = step && !clip && !found && t_cur < t_end && sweep < uint(2 * MB_MAX_RAY_BALLS + 1);
        } while (step);
        more = clip && !found;
        if (more) {
            // Several balls: Σ q·f as one Bernstein polynomial over the interval, minus T (seed 2.2).
            float c[7];
            float scale[7];
            for (int k = 0; k < 7; ++k) {
                c[k] = -T;
                scale[k] = 0.0;
            }
            float G = 0.0;
            uint m = live;
            do {
                MB_NEXT_BIT(m, j, some);
                vec2 ct = mb_chord_t[j];
                vec2 shape = mb_shape[j];
                float chord = ct.y - ct.x;
                float sa = some ? clamp((t_cur - ct.x) / chord, 0.0, 1.0) : 0.0;
                float sb = some ? clamp((t_next - ct.x) / chord, 0.0, 1.0) : 1.0;
                float dj[7];
                mb_chord_bernstein(kernel, shape.x, some ? shape.y : 0.0, dj);
                mb_restrict(dj, sa, sb);
                for (int k = 0; k < 7; ++k) {
                    c[k] += dj[k];
                    scale[k] += abs(dj[k]);
                }
                G += some ? mb_meta[j].x : 0.0;
            } while (m != 0u);
            float S = 0.0;
            for (int k = 0; k < 7; ++k) S = max(S, scale[k]);
            float delta = mb_delta(S + T, X + t_next, G);
            // The group's tolerance (world units; 0: MB_ALPHA_TOL alone) as a width in α.
            float tol = g.params.y;
            float alpha_tol = tol > 0.0 ? max(MB_ALPHA_TOL, tol * r.ts / (t_next - t_cur)) : MB_ALPHA_TOL;
            float alpha = mb_first_root(c, MB_FLAT_C * MB_EPS * (S + T), delta, alpha_tol, hit.iterations,
                                        hit.flags);
            if ((hit.flags & MB_NOT_CONVERGED) != 0u) {
                more = false;
            } else if (alpha >= 0.0) {
                if (MB_TANGENT_FLAGS != 0 && mb_shallow_root(c, alpha, delta)) hit.flags |= MB_TANGENT;
                t_found = t_cur + alpha * (t_next - t_cur);
                found = true;
                more = false;
            } else {
                t_cur = t_next;
            }
        }
    } while (more);
    if ((hit.flags & MB_NOT_CONVERGED) != 0u) return hit;
    if (found) mb_finish(hit, g, r, dir, live, t_found);
    return hit;
}

// 1: the caller's list is sorted by mb_entry_key (for the ray's origin), so the streamed walks
// below stop at the first entry past their window; 0: they read the whole list.
#ifndef MB_LIST_SORTED
#define MB_LIST_SORTED 0
#endif

// The support chord [en, ex] of `ball` on the ray and its a = D/R², computed as mb_chord does;
// false when the ray misses the support.
bool mb_ball_chord(MetaBall ball, MetaRay r, out vec2 ct, out float a) {
    vec3 w = ball.centre_radius.xyz - r.o;
    float tc = dot(w, r.d);
    vec3 cr = cross(w, r.d);
    float h2 = dot(cr, cr);
    float R = ball.centre_radius.w;
    float D = R * R - h2;
    float half_chord = sqrt(max(D, 0.0));
    ct = vec2(tc - half_chord, tc + half_chord);
    a = mb_chord_a(ct, R);
    return D > 0.0;
}

// The streamed walks below take MB_STREAM_UNROLL balls of the list per loop iteration, each by
// a call (inlined, no loop): lavapipe (Mesa's gallivm) ends every loop of a SIMD group once all
// its loops together have iterated 65,535 times, and a crowded cast walks a long list many
// times (a dense fluid's tile runs hold ~2,000 balls: ~33,000 iterations one ball at a time).
// The pass detects a spent limit and counts it (metaballs.comp, `loops_cut`).
#define MB_STREAM_UNROLL 8u
#define MB_STREAM_BLOCK(step) \
    { const int i = 0; step; } { const int i = 1; step; } { const int i = 2; step; } { const int i = 3; step; } \
    { const int i = 4; step; } { const int i = 5; step; } { const int i = 6; step; } { const int i = 7; step; }

// Walk 1, one chord [ct.x, ct.y] (a, q; `meets`: the ray crosses the support): the next chord end
// after t_cur (t_next) and the field bound (B) over [t_cur, t_hi].
void mb_bound_step(uint kernel, bool meets, vec2 ct, float a, float q, float t_cur, float t_hi, inout float t_next,
                   inout float B) {
    if (meets && ct.y > t_cur && ct.x < t_hi) {
        t_next = min(t_next, ct.x > t_cur ? ct.x : ct.y);
        float half_chord = 0.5 * (ct.y - ct.x);
        float mid = ct.x + half_chord;
        float s0 = (max(t_cur, ct.x) - mid) / half_chord;
        float s1 = (min(t_hi, ct.y) - mid) / half_chord;
        float s2 = s0 <= 0.0 && s1 >= 0.0 ? 0.0 : min(s0 * s0, s1 * s1);
        B += max(q, 0.0) * mb_kernel(kernel, 1.0 - a * (1.0 - s2));
    }
}

// q·f over the part [t0, t1] of the chord [ct.x, ct.y] (a = D/R²) that holds it, as 7 Bernstein
// coefficients: mb_chord_bernstein's polynomial restricted to the part, built from the product
// form 1 − r′ = 4a·(t − entry)(exit − t)/chord² (both factors ≥ 0 on the chord: no cancellation)
// and multiplied out in the Bernstein basis: wyvill6 f = (1 − r′)²·(5/9 + 4/9·(1 − r′)),
// murakami4 f = (1 − r′)². Half the arithmetic of mb_restrict's two de Casteljau passes.
void mb_piece_bernstein(uint kernel, vec2 ct, float a, float q, float t0, float t1, out float d[7]) {
    float inv = 1.0 / (ct.y - ct.x);
    float u0 = (t0 - ct.x) * inv;
    float u1 = (t1 - ct.x) * inv;
    float v0 = (ct.y - t0) * inv;
    float v1 = (ct.y - t1) * inv;
    float a4 = 4.0 * a;
    // 1 − r′ (degree 2), its square (degree 4), and q·(5/9 + 4/9·(1 − r′)) or q (degree 2).
    float p0 = a4 * (u0 * v0);
    float p1 = a4 * (0.5 * (u0 * v1 + u1 * v0));
    float p2 = a4 * (u1 * v1);
    float s0 = p0 * p0;
    float s1 = p0 * p1;
    float s2 = (p0 * p2 + 2.0 * (p1 * p1)) * MB_THIRD;
    float s3 = p1 * p2;
    float s4 = p2 * p2;
    bool w6 = kernel == MB_KERNEL_WYVILL6;
    float m0 = q * (w6 ? MB_W6_M0 + MB_W6_M1 * p0 : 1.0);
    float m1 = q * (w6 ? MB_W6_M0 + MB_W6_M1 * p1 : 1.0);
    float m2 = q * (w6 ? MB_W6_M0 + MB_W6_M1 * p2 : 1.0);
    // The product of degrees 4 and 2: d_k = Σ C(4,i)·C(2,j)/C(6,k)·s_i·m_j over i + j = k.
    d[0] = s0 * m0;
    d[1] = (s1 * m0) * MB_TWO_THIRDS + (s0 * m1) * MB_THIRD;
    d[2] = (s2 * m0) * 0.4 + (s1 * m1) * MB_EIGHT_15THS + (s0 * m2) * MB_15TH;
    d[3] = (s3 * m0) * 0.2 + (s2 * m1) * 0.6 + (s1 * m2) * 0.2;
    d[4] = (s4 * m0) * MB_15TH + (s3 * m1) * MB_EIGHT_15THS + (s2 * m2) * 0.4;
    d[5] = (s4 * m1) * MB_THIRD + (s3 * m2) * MB_TWO_THIRDS;
    d[6] = s4 * m2;
}

// Walk 2, one chord (as mb_bound_step; g_term its |q|γ/R): its share of the piece [t_cur, t_hi]
// (Bernstein coefficients c, their magnitudes `scale`, and G), when the chord contains t_cur (and
// so the piece: no chord ends inside one).
void mb_piece_step(uint kernel, bool meets, vec2 ct, float a, float q, float g_term, float t_cur, float t_hi,
                   inout float c[7], inout float scale[7], inout float G) {
    if (meets && ct.x <= t_cur && ct.y > t_cur) {
        float dj[7];
        mb_piece_bernstein(kernel, ct, a, q, t_cur, t_hi, dj);
        for (int j = 0; j < 7; ++j) {
            c[j] += dj[j];
            scale[j] += abs(dj[j]);
        }
        G += g_term;
    }
}

// Ball `index` of the list and its chord (`meets`: the ray crosses its support). False past the
// list's end or, sorted, past `walk_end` (so are all later balls).
bool mb_list_chord(MetaRay r, uint index, bool listed, float walk_end, out MetaBall ball, out bool meets,
                   out vec2 ct, out float a) {
    ball = MetaBall(vec4(0.0), vec4(0.0));
    meets = false;
    ct = vec2(0.0);
    a = 0.0;
    if (!listed) return false;
    ball = MB_BALL(MB_INDEX(index));
    if (MB_LIST_SORTED != 0 && mb_entry_key(ball, r.o) >= walk_end) return false;
    meets = mb_ball_chord(ball, r, ct, a);
    return true;
}

// Walk 1 over the list, one ball. False as mb_list_chord, past the window.
bool mb_stream_bound(uint kernel, MetaRay r, uint index, bool listed, float t_cur, float t_hi,
                     inout float t_next, inout float B) {
    MetaBall ball;
    bool meets;
    vec2 ct;
    float a;
    if (!mb_list_chord(r, index, listed, t_hi, ball, meets, ct, a)) return false;
    mb_bound_step(kernel, meets, ct, a, ball.coeffs.x, t_cur, t_hi, t_next, B);
    return true;
}

// Walk 2 over the list, one ball. False as mb_list_chord, past the piece.
bool mb_stream_piece(uint kernel, MetaRay r, uint index, bool listed, float t_cur, float t_hi,
                     inout float c[7], inout float scale[7], inout float G) {
    MetaBall ball;
    bool meets;
    vec2 ct;
    float a;
    if (!mb_list_chord(r, index, listed, t_hi, ball, meets, ct, a)) return false;
    mb_piece_step(kernel, meets, ct, a, ball.coeffs.x, ball.coeffs.z, t_cur, t_hi, c, scale, G);
    return true;
}

// The normal's walk, one ball: its share of ∇F at p (t_found along the ray). False past the
// list's end or, sorted, past t_found.
bool mb_stream_grad(uint kernel, MetaRay r, uint index, bool listed, vec3 p, float t_found, inout vec3 grad) {
    if (!listed) return false;
    MetaBall ball = MB_BALL(MB_INDEX(index));
    if (MB_LIST_SORTED != 0 && mb_entry_key(ball, r.o) > t_found) return false;
    vec3 w = p - ball.centre_radius.xyz;
    float inv_r2 = 1.0 / (ball.centre_radius.w * ball.centre_radius.w);
    grad += w * (2.0 * ball.coeffs.x * inv_r2 * mb_kernel_deriv(kernel, dot(w, w) * inv_r2));
    return true;
}

// The ray's chords a streamed cast keeps (mb_clip_stream): the first MB_CACHE_BALLS of the list
// meeting the round's span, in list order. Per invocation (private), so a chord's walk reads a
// few floats instead of a ball and its chord's arithmetic, and walks only the ray's own chords
// instead of the whole run up to the window. Its size is a cost, not a cap: a fuller cache means
// fewer rounds but longer walks, and more chords than it holds on one point walk the list. 128
// measured best on the dense fluid at 256² (docs/PERFORMANCE.md, "Crowded supports").
#ifndef MB_CACHE_BALLS
#define MB_CACHE_BALLS 128
#endif
vec4 mb_cache_chord[MB_CACHE_BALLS];  // entry, exit, a, q
vec2 mb_cache_meta[MB_CACHE_BALLS];   // |q|γ/R (coeffs.z), the ball's id (uintBitsToFloat)
float mb_cache_key[MB_CACHE_BALLS];   // mb_entry_key: with MB_LIST_SORTED, ascending

// The gather, one ball: its chord into the cache when it meets [t_cur, limit) and the cache has
// room, else `limit` drops to its entry (the round then ends there). False as mb_stream_bound,
// past `limit`.
bool mb_cache_gather(MetaRay r, uint index, bool listed, float t_cur, inout float limit, inout uint n) {
    if (!listed) return false;
    uint id = MB_INDEX(index);
    MetaBall ball = MB_BALL(id);
    float key = mb_entry_key(ball, r.o);
    if (MB_LIST_SORTED != 0 && key >= limit) return false;
    vec2 ct;
    float a;
    if (mb_ball_chord(ball, r, ct, a) && ct.y > t_cur && ct.x < limit) {
        if (n < uint(MB_CACHE_BALLS)) {
            mb_cache_chord[n] = vec4(ct, a, ball.coeffs.x);
            mb_cache_key[n] = key;
            mb_cache_meta[n] = vec2(ball.coeffs.z, uintBitsToFloat(id));
            ++n;
        } else {
            limit = min(limit, ct.x);
        }
    }
    return true;
}

// After walk 1: the window [t_cur, t_hi] holds no root when the bound B stays under T by more
// than the band; then the next window starts at its end, twice as wide (true). Else the window
// shrinks to its first piece [t_cur, t_next] (false).
bool mb_window_skip(float B, float T, float X, float t_next, float t_end, inout float t_cur, inout float t_hi) {
    if (B < T - mb_delta(B + T, X + t_hi, 0.0)) {
        float width = t_hi - t_cur;
        t_cur = t_hi;
        t_hi = min(t_cur + 2.0 * width, t_end);
        return true;
    }
    t_hi = min(t_hi, t_next);
    return false;
}

// After walk 2: clips the piece [t_cur, t_hi] (its coefficients c − T, magnitudes, G) exactly as
// mb_clip_slots clips an interval (same δ, floors, tolerance, and MB_MAX_ITERATIONS per piece;
// MB_TANGENT from the clipping only). True with t_found at a root; else, without one, the next
// window is twice the larger of the piece and an eighth of the window that held it (`window`).
bool mb_piece_clip(MetaGroup g, MetaRay r, float c[7], float scale[7], float G, float X, float t_end, float window,
                   inout float t_cur, inout float t_hi, inout MetaHit hit, inout float t_found) {
    float T = g.params.x;
    float S = 0.0;
    for (int i = 0; i < 7; ++i) S = max(S, scale[i]);
    float delta = mb_delta(S + T, X + t_hi, G);
    float tol = g.params.y;
    float alpha_tol = tol > 0.0 ? max(MB_ALPHA_TOL, tol * r.ts / (t_hi - t_cur)) : MB_ALPHA_TOL;
    uint steps = 0u;
    float alpha = mb_first_root(c, MB_FLAT_C * MB_EPS * (S + T), delta, alpha_tol, steps, hit.flags);
    hit.iterations += steps;
    if ((hit.flags & MB_NOT_CONVERGED) != 0u) return false;
    if (alpha >= 0.0) {
        if (MB_TANGENT_FLAGS != 0 && mb_shallow_root(c, alpha, delta)) hit.flags |= MB_TANGENT;
        t_found = t_cur + alpha * (t_hi - t_cur);
        return true;
    }
    float width = max(t_hi - t_cur, 0.125 * window);
    t_cur = t_hi;
    t_hi = min(t_cur + 2.0 * width, t_end);
    return false;
}

// Bézier clipping by windows: the first crossing of F = T with t′ ∈ [t_cur, t_end] over `count`
// chords, walked from START by WALK_BOUND(k, i) and WALK_PIECE(k, i) (chord k + i; false past the
// last one the walk needs), block by block while WALK_ON(k). A first walk finds the next chord
// end t_next and the field bound (mb_field_bound's, over every chord meeting the window) on the
// window [t_cur, t_hi]: where it shows no root the window is skipped and the next one is twice as
// wide; otherwise a second walk sums the coefficients of the window's first piece
// [t_cur, min(t_hi, t_next)] — no chord end inside, so one polynomial (seed 2.2) — and clips it;
// the next window is twice the larger of that piece and an eighth of the window: near a root the
// chord ends crowd, and windows grown again from each short piece would take a walk per piece
// (lavapipe runs a walk for the whole SIMD group when one lane needs it, so the count of walks is
// the cost: measured 0.81× the pass time on the dense fluid). Every window ends at a chord end or
// is skipped, so a cast takes at most one piece per chord end and one walk per doubling across
// the f32 range between them, hence the guard (MB_STREAM_WALKS); past it, MB_NOT_CONVERGED. Sets
// `found` and t_found.
#define MB_CLIP_WINDOWS(count, START, WALK_BOUND, WALK_PIECE, WALK_ON)                            \
    {                                                                                      \
        float t_hi = t_end;                                                                \
        uint walks = 0u;                                                                   \
        uint max_walks = MB_STREAM_WALKS * (2u * min(count, 1u << 20) + 1u);               \
        while (!found && t_cur < t_end) {                                                  \
            if (walks >= max_walks) {                                                      \
                hit.flags |= MB_NOT_CONVERGED;                                             \
                break;                                                                     \
            }                                                                              \
            ++walks;                                                                       \
            float t_next = t_end;                                                          \
            float B = 0.0;                                                                 \
            uint k = START;                                                                \
            bool dead = true;                                                              \
            bool more = true;                                                              \
            do {                                                                           \
                MB_STREAM_BLOCK(more = WALK_BOUND(k, uint(i)))                             \
                k += MB_STREAM_UNROLL;                                                     \
                more = more && WALK_ON(k);                                                 \
            } while (more);                                                                \
            float window = t_hi - t_cur;                                                   \
            if (mb_window_skip(B, T, X, t_next, t_end, t_cur, t_hi)) continue;             \
            float c[7];                                                                    \
            float scale[7];                                                                \
            for (int i = 0; i < 7; ++i) {                                                  \
                c[i] = -T;                                                                 \
                scale[i] = 0.0;                                                            \
            }                                                                              \
            float G = 0.0;                                                                 \
            k = START;                                                                     \
            more = true;                                                                   \
            do {                                                                           \
                MB_STREAM_BLOCK(more = WALK_PIECE(k, uint(i)))                             \
                k += MB_STREAM_UNROLL;                                                     \
                more = more && WALK_ON(k);                                                 \
            } while (more);                                                                \
            found = mb_piece_clip(g, r, c, scale, G, X, t_end, window, t_cur, t_hi, hit, t_found); \
            if ((hit.flags & MB_NOT_CONVERGED) != 0u) break;                               \
        }                                                                                  \
    }

// The windows' walks over the list (every ball, its chord computed again each time).
#define MB_RUN_BOUND(k, i) \
    mb_stream_bound(kernel, r, list_begin + k + i, k + i < list_count, t_cur, t_hi, t_next, B)
#define MB_RUN_PIECE(k, i) \
    mb_stream_piece(kernel, r, list_begin + k + i, k + i < list_count, t_cur, t_hi, c, scale, G)
#define MB_RUN_ON(k) true
// … and over the cache (its first n chords), block by block while the block's first key (sorted:
// a lower bound of every later entry) lies before the window's end.
#define MB_CACHE_BOUND(k, i) mb_cache_bound(kernel, k + i, n, t_cur, t_hi, t_next, B, dead, first)
#define MB_CACHE_ON(k) mb_cache_on(k, n, t_hi)
#define MB_CACHE_PIECE(k, i) mb_cache_piece(kernel, k + i, n, t_cur, t_hi, c, scale, G)

// Chord j of the cache (j ≥ n: none) in walk 1; `first` moves past a prefix of chords that end
// before t_cur (no later window meets them: t_cur only grows).
bool mb_cache_bound(uint kernel, uint j, uint n, float t_cur, float t_hi, inout float t_next, inout float B,
                    inout bool dead, inout uint first) {
    vec4 ch = mb_cache_chord[min(j, uint(MB_CACHE_BALLS - 1))];
    mb_bound_step(kernel, j < n, ch.xy, ch.z, ch.w, t_cur, t_hi, t_next, B);
    dead = dead && j < n && !(ch.y > t_cur);
    if (dead) first = j + 1u;
    return j + 1u < n;
}

// Chord j of the cache in walk 2.
bool mb_cache_piece(uint kernel, uint j, uint n, float t_cur, float t_hi, inout float c[7], inout float scale[7],
                    inout float G) {
    uint s = min(j, uint(MB_CACHE_BALLS - 1));
    vec4 ch = mb_cache_chord[s];
    mb_piece_step(kernel, j < n, ch.xy, ch.z, ch.w, mb_cache_meta[s].x, t_cur, t_hi, c, scale, G);
    return j + 1u < n;
}

// Whether a walk of the cache goes on at chord k (the next block's first).
bool mb_cache_on(uint k, uint n, float t_hi) {
    return k < n && (MB_LIST_SORTED == 0 || mb_cache_key[min(k, uint(MB_CACHE_BALLS - 1))] < t_hi);
}

// Bézier clipping streamed from the list itself: the first crossing of F = T with t′ ∈ [t0, t_end]
// over every ball of MB_INDEX(list_begin) … MB_INDEX(list_begin + list_count − 1), however many
// supports overlap (the slots hold MB_MAX_RAY_BALLS; a point inside more than that is cast here).
// Rounds: a walk over the list gathers the chords meeting [t_cur, t_end) into the cache, up to
// MB_CACHE_BALLS of them; the round's span ends at the entry of the first chord left out (`limit`:
// every chord entering before it is cached), and the windows (MB_CLIP_WINDOWS) walk the cache over
// [t_cur, limit]. A miss goes on from `limit`, past at least one more entry. Where more than
// MB_CACHE_BALLS chords contain t_cur itself the rest of the ray is cast by windows walking the
// whole list (nothing stored per ball, so no count is too many; each walk recomputes the chords).
MetaHit mb_clip_stream(MetaGroup g, MetaRay r, vec3 dir, uint list_begin, uint list_count, float t0,
                       float t_end_ray, MetaHit hit) {
    uint kernel = g.info.x;
    float T = g.params.x;
    float X = length(r.o);
    float t_cur = t0;
    float t_found = 0.0;
    bool found = false;
    bool cached = true;
    uint n = 0u;
    do {
        n = 0u;
        float limit = t_end_ray;
        uint k = 0u;
        bool more = true;
        do {
            MB_STREAM_BLOCK(more = mb_cache_gather(r, list_begin + k + uint(i), k + uint(i) < list_count, t_cur,
                                                   limit, n))
            k += MB_STREAM_UNROLL;
        } while (more);
        if (!(limit > t_cur)) {
            cached = false;
            break;
        }
        float t_end = limit;
        uint first = 0u;
        MB_CLIP_WINDOWS(n, first, MB_CACHE_BOUND, MB_CACHE_PIECE, MB_CACHE_ON)
        if (found || (hit.flags & MB_NOT_CONVERGED) != 0u) break;
        t_cur = limit;
    } while (t_cur < t_end_ray);
    if (!cached) {
        float t_end = t_end_ray;
        MB_CLIP_WINDOWS(list_count, 0u, MB_RUN_BOUND, MB_RUN_PIECE, MB_RUN_ON)
    }
    if ((hit.flags & MB_NOT_CONVERGED) != 0u || !found) return hit;
    // The normal: ∇F over the balls whose support contains the point (others add nothing); every
    // such ball's chord contains t_found, so it is in the cache when the cache found it.
    vec3 p = r.o + r.d * t_found;
    vec3 grad = vec3(0.0);
    if (cached) {
        uint j = 0u;
        do {
            MetaBall ball = MB_BALL(floatBitsToUint(mb_cache_meta[min(j, uint(MB_CACHE_BALLS - 1))].y));
            vec3 w = p - ball.centre_radius.xyz;
            float inv_r2 = 1.0 / (ball.centre_radius.w * ball.centre_radius.w);
            if (j < n) grad += w * (2.0 * ball.coeffs.x * inv_r2 * mb_kernel_deriv(kernel, dot(w, w) * inv_r2));
            ++j;
        } while (j < n);
    } else {
        uint k = 0u;
        bool more = true;
        do {
            MB_STREAM_BLOCK(more = mb_stream_grad(kernel, r, list_begin + k + uint(i), k + uint(i) < list_count, p,
                                                  t_found, grad))
            k += MB_STREAM_UNROLL;
        } while (more);
    }
    mb_finish_grad(hit, g, r, dir, grad, t_found);
    return hit;
}

// F along the ray at t′ from the slots (r′ = 1 − a·(1 − s²) on a chord, s ∈ [−1, 1] across it),
// with L = Σ|q|γ/R over the chords containing t′ (a Lipschitz bound of F along the ray until the
// next chord entry) and that next entry.
vec3 mb_trace_probe(uint kernel, uint slots, uint mask, float t) {
    float F = 0.0;
    float L = 0.0;
    float next_en = 3.402823466e38;
    uint j = 0u;
    do {
        bool mine = j < slots && (mask & (1u << j)) != 0u;
        float en = mb_chord_t[j].x;
        float ex = mb_chord_t[j].y;
        vec2 shape = mb_shape[j];
        float half_chord = 0.5 * (ex - en);
        float s = (t - (en + half_chord)) / half_chord;
        float v = shape.y * mb_kernel(kernel, 1.0 - shape.x * (1.0 - s * s));
        F += mine && en <= t && t <= ex ? v : 0.0;
        L += mine && en <= t && t < ex ? mb_meta[j].x : 0.0;
        if (mine && en > t) next_en = min(next_en, en);
        ++j;
    } while (j < slots);
    return vec3(F, L, next_en);
}

// The sphere-tracing baseline (CPU twin: crates/hadou/src/effects/metaballs_trace.rs): from t0, steps of
// |F − T|/L (never past a root: |F − T| changes by at most L per unit t′ until the next chord
// entry, which ends a step), at least MB_TRACE_MIN_STEP·T/L, at most g.params.z of them; a sign
// change of F − T brackets the root, refined by MB_TRACE_BISECT bisections. Out of steps before
// t_end: MB_NOT_CONVERGED. hit.iterations counts the march steps.
MetaHit mb_trace_slots(MetaGroup g, MetaRay r, vec3 dir, uint slots, uint mask, float t0, float t_end,
                       MetaHit hit) {
    uint kernel = g.info.x;
    float T = g.params.x;
    uint steps = uint(g.params.z);
    vec3 p = mb_trace_probe(kernel, slots, mask, t0);
    bool inside = p.x >= T;  // the sign F − T starts with (the camera may be inside)
    float t = t0;
    float t_prev = t0;
    bool bracket = false;
    uint k = 0u;
    do {
        float gap = inside ? p.x - T : T - p.x;
        if (gap <= 0.0) {
            bracket = true;
            break;
        }
        if (t >= t_end || k >= steps) break;
        float step = p.y > 0.0 ? max(gap, MB_TRACE_MIN_STEP * T) / p.y : t_end - t;
        t_prev = t;
        t = min(min(t + step, p.z), t_end);
        p = mb_trace_probe(kernel, slots, mask, t);
        ++k;
    } while (true);
    hit.iterations += k;
    if (!bracket) {
        if (t < t_end) hit.flags |= MB_NOT_CONVERGED;
        return hit;
    }
    float lo = t_prev;
    float hi = t;
    for (int i = 0; i < MB_TRACE_BISECT; ++i) {
        float mid = 0.5 * (lo + hi);
        bool in_mid = mb_trace_probe(kernel, slots, mask, mid).x >= T;
        if (in_mid == inside) lo = mid;
        else hi = mid;
    }
    mb_finish(hit, g, r, dir, mask, 0.5 * (lo + hi));
    return hit;
}

// The first crossing of the group's surface F = T along the world ray origin + t·dir (dir unit),
// t ∈ [t_min, t_max] (world distances along the ray: t_max from the depth buffer is the ray
// distance to the raster surface, i.e. the view depth / dot(dir, forward)), against the balls
// MB_INDEX(list_begin) … MB_INDEX(list_begin + list_count − 1), by Bézier clipping, or by
// sphere tracing when `trace` (the group's method).
MetaHit metaball_cast(vec3 origin, vec3 dir, MetaGroup g, uint list_begin, uint list_count,
                      float t_min, float t_max, bool trace) {
    MetaHit hit;
    hit.normal = -dir;
    hit.t = t_max;
    hit.flags = 0u;
    hit.iterations = 0u;
    MetaRay r = mb_object_ray(g, origin, dir);
    float t0 = t_min * r.ts;
    float t1 = t_max * r.ts;
    if (!(t1 >= t0)) return hit;

    // Rounds: the support chords crossing (t0, t1), the nearest MB_MAX_RAY_BALLS by entry kept,
    // cast up to the entry of the first ball left out (t_limit); a miss goes on from there. Where
    // more than MB_MAX_RAY_BALLS supports contain t0 itself, no slots hold them: the rest of the
    // ray is streamed. Every round passes at least one entry, hence the guard.
    uint rounds = 0u;
    do {
        uint n = 0u;
        float t_limit = t1;
        for (uint k = 0u; k < list_count; ++k) {
            uint j = min(n, uint(MB_MAX_RAY_BALLS - 1));
            if (n == uint(MB_MAX_RAY_BALLS)) {
                // Full: the slot with the latest entry is the candidate to replace.
                float latest = mb_chord_t[0].x;
                j = 0u;
                for (uint i = 1u; i < uint(MB_MAX_RAY_BALLS); ++i) {
                    if (mb_chord_t[i].x > latest) {
                        latest = mb_chord_t[i].x;
                        j = i;
                    }
                }
                vec2 chord0 = mb_chord_t[j];
                vec2 shape0 = mb_shape[j];
                vec2 iso0 = mb_iso[j];
                vec2 meta0 = mb_meta[j];
                if (!mb_chord(j, MB_INDEX(list_begin + k), r.o, r.d, t0, t1)) continue;
                if (mb_chord_t[j].x >= latest) {
                    t_limit = min(t_limit, mb_chord_t[j].x);
                    mb_chord_t[j] = chord0;
                    mb_shape[j] = shape0;
                    mb_iso[j] = iso0;
                    mb_meta[j] = meta0;
                } else {
                    t_limit = min(t_limit, latest);
                }
            } else if (mb_chord(j, MB_INDEX(list_begin + k), r.o, r.d, t0, t1)) {
                ++n;
            }
        }
        if (!(t_limit > t0)) {
            hit.flags |= MB_STREAMED;
            return mb_clip_stream(g, r, dir, list_begin, list_count, t0, t1, hit);
        }
        float t_end = min(t1, t_limit);
        uint mask = n >= 32u ? 0xffffffffu : (1u << n) - 1u;
        hit = trace ? mb_trace_slots(g, r, dir, n, mask, t0, t_end, hit) : mb_clip_slots(g, r, dir, n, mask, t0, t_end, hit);
        if ((hit.flags & (MB_HIT | MB_NOT_CONVERGED)) != 0u || !(t_limit < t1)) return hit;
        t0 = t_limit;
        ++rounds;
    } while (rounds <= list_count);
    hit.flags |= MB_NOT_CONVERGED;  // unreachable (see above)
    return hit;
}

#endif  // HADOU_METABALLS_CAST
