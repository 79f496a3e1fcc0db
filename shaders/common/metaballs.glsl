// Metaballs (seed 000): ray cast of one metaball group by support-sphere intervals, the lone-ball
// sphere path and Bézier clipping of the summed Bernstein coefficients.
// CPU twins: src/effects/metaballs.rs (f64 reference, the math in its module docs) and
// src/effects/metaballs_f32.rs (this arithmetic, line by line: keep the two in sync).
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
// in any order, but only balls of the group passed to metaball_cast.
#ifndef HADOU_METABALLS_STRUCTS
#define HADOU_METABALLS_STRUCTS

// Keep in sync with GpuMetaGroup in src/effects/metaballs_f32.rs (224 bytes, std430; asserted there).
struct MetaGroup {
    mat4 to_object;      // M⁻¹: world → the group's object space
    mat4 to_world;       // M: object → world (not needed by the cast; for culling and binning)
    mat4 normal_matrix;  // M⁻ᵀ in the upper 3×3: object normal → world normal
    vec4 params;         // x: threshold T > 0, yzw: 0
    uvec4 info;          // x: kernel (MB_KERNEL_*), y: first ball, z: ball count, w: material index
};

// Keep in sync with GpuMetaBall in src/effects/metaballs_f32.rs (32 bytes, std430; asserted there).
struct MetaBall {
    vec4 centre_radius;  // xyz: object-space centre c, w: support radius R > 0
    vec4 coeffs;         // x: q, y: ρ*·R, the lone ball's isosurface radius (0: none),
                         // z: |q|·γ/R (bound on ‖∇(q f)‖, γ the kernel's max slope), w: 0
};

// What metaball_cast returns. Keep in sync with MetaHitF32 in src/effects/metaballs_f32.rs.
struct MetaHit {
    vec3 normal;      // world unit normal −∇F (out of the blob); valid with MB_HIT
    float t;          // world distance along dir: the hit with MB_HIT, the searched range with MB_OVERFLOW
    uint flags;       // MB_HIT | MB_TANGENT | MB_OVERFLOW | MB_NOT_CONVERGED
    uint iterations;  // Bézier-clipping steps spent
};

#define MB_KERNEL_WYVILL6 0u
#define MB_KERNEL_MURAKAMI4 1u

#define MB_HIT 1u            // t and normal are set
#define MB_TANGENT 2u        // the ray passed within δ of the threshold (near miss or double root)
#define MB_OVERFLOW 4u       // more than MB_MAX_RAY_BALLS supports on the ray and no hit before the
                             // entry of the nearest dropped ball: t is that distance (the ray is
                             // known to miss up to it); casting again with t_min = t continues
#define MB_NOT_CONVERGED 8u  // MB_MAX_ITERATIONS clip steps spent: reported as a miss

// Support spheres kept per ray (the nearest by entry; see MB_OVERFLOW).
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

#endif  // HADOU_METABALLS_STRUCTS

#if defined(MB_BALL) && defined(MB_INDEX) && !defined(HADOU_METABALLS_CAST)
#define HADOU_METABALLS_CAST

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
// that at u0/u1.
void mb_restrict(inout float c[7], float u0, float u1) {
    if (u1 < 1.0) {
        for (int k = 1; k <= 6; ++k) {
            for (int j = 6; j >= k; --j) c[j] = c[j - 1] * (1.0 - u1) + c[j] * u1;
        }
    }
    if (u0 > 0.0) {
        float v = u1 > 0.0 ? min(u0 / u1, 1.0) : 0.0;
        for (int k = 1; k <= 6; ++k) {
            for (int j = 0; j <= 6 - k; ++j) c[j] = c[j] * (1.0 - v) + c[j + 1] * v;
        }
    }
}

// [lo, hi] where the convex hull of the control polygon (k/6, c_k) meets the axis; lo > hi when
// it does not.
vec2 mb_hull_crossing(float c[7]) {
    float lo = 2.0;
    float hi = -1.0;
    for (int i = 0; i < 7; ++i) {
        if (c[i] == 0.0) {
            lo = min(lo, float(i) / 6.0);
            hi = max(hi, float(i) / 6.0);
        }
        for (int j = i + 1; j < 7; ++j) {
            if ((c[i] < 0.0 && c[j] > 0.0) || (c[i] > 0.0 && c[j] < 0.0)) {
                float x = (float(i) + float(j - i) * (c[i] / (c[i] - c[j]))) / 6.0;
                lo = min(lo, x);
                hi = max(hi, x);
            }
        }
    }
    return vec2(clamp(lo, 0.0, 1.0), clamp(hi, 0.0, 1.0));
}

// The band half-width δ = MB_BAND_C·ε·(S + X·G) of an interval: S its coefficient scale
// (max_k Σ|q d_k| + T), G = Σ|q|γ/R over its balls, X the object-space coordinate scale.
float mb_delta(float S, float X, float G) {
    return MB_BAND_C * MB_EPS * (S + X * G);
}

// The smallest root α ∈ [0, 1] of the Bernstein polynomial `base` by Bézier clipping, or -1.
// Parts are searched left half first, from an explicit stack. `flat_floor` (MB_FLAT_C·ε·S) is
// the noise rounding leaves in the coefficients; below it a value is indistinguishable from 0:
// - a part whose control points all lie within it is a root (its middle);
// - a part whose control points share one sign holds no root, unless an end value is within it:
//   then that end is the root (a root on a part's edge must not fall between two parts whose
//   rounded end values disagree in sign);
// - a dropped part whose interior control points come within δ of zero from below is a near
//   miss and flags MB_TANGENT.
float mb_first_root(float base[7], float flat_floor, float delta, inout uint iterations, inout uint flags) {
    vec2 stack[MB_STACK_SIZE];
    int sp = 0;
    float a = 0.0;
    float b = 1.0;
    float c[7] = base;
    // Every pass pops a part, returns, or spends a clip step; pops never outnumber pushes.
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
        if (all_pos || all_neg) {
            if (abs(c[0]) <= flat_floor) return a;
            if (abs(c[6]) <= flat_floor) return b;
            if (all_neg && inner_max >= -delta) flags |= MB_TANGENT;
            if (sp == 0) return -1.0;
            --sp;
            a = stack[sp].x;
            b = stack[sp].y;
            c = base;
            mb_restrict(c, a, b);
            continue;
        }
        if (iterations >= MB_MAX_ITERATIONS) {
            flags |= MB_NOT_CONVERGED;
            return -1.0;
        }
        vec2 h = mb_hull_crossing(c);
        iterations += 1u;
        float na = a + h.x * (b - a);
        float nb = a + h.y * (b - a);
        if (nb - na <= MB_ALPHA_TOL) return 0.5 * (na + nb);
        mb_restrict(c, h.x, h.y);
        a = na;
        b = nb;
        if (h.y - h.x > MB_SPLIT_RATIO) {
            if (sp < MB_STACK_SIZE) {
                float m = 0.5 * (a + b);
                stack[sp] = vec2(m, b);
                ++sp;
                mb_restrict(c, 0.0, 0.5);
                b = m;
            } else {
                flags |= MB_NOT_CONVERGED;  // unreachable (see MB_STACK_SIZE)
                return -1.0;
            }
        }
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

// The first crossing of the group's surface F = T along the world ray origin + t·dir (dir unit),
// t ∈ [t_min, t_max] (world distances along the ray: t_max from the depth buffer is the ray
// distance to the raster surface, i.e. the view depth / dot(dir, forward)), against the balls
// MB_INDEX(list_begin) … MB_INDEX(list_begin + list_count − 1).
MetaHit metaball_cast(vec3 origin, vec3 dir, MetaGroup g, uint list_begin, uint list_count,
                      float t_min, float t_max) {
    MetaHit hit;
    hit.normal = -dir;
    hit.t = t_max;
    hit.flags = 0u;
    hit.iterations = 0u;
    uint kernel = g.info.x;
    float T = g.params.x;
    // Seed 002: the ray in object space, t' = t·‖M⁻¹d‖.
    vec3 o = (g.to_object * vec4(origin, 1.0)).xyz;
    vec3 dv = (g.to_object * vec4(dir, 0.0)).xyz;
    float ts = length(dv);
    vec3 d = dv / ts;
    float t0 = t_min * ts;
    float t1 = t_max * ts;
    if (!(t1 >= t0)) return hit;
    float X = length(o);

    // The support chords crossing (t0, t1), sorted by entry; the nearest MB_MAX_RAY_BALLS kept.
    float enter_t[MB_MAX_RAY_BALLS];
    float exit_t[MB_MAX_RAY_BALLS];
    float chord_a[MB_MAX_RAY_BALLS];
    uint ball_id[MB_MAX_RAY_BALLS];
    int n = 0;
    float t_limit = t1;
    for (uint k = 0u; k < list_count; ++k) {
        uint id = MB_INDEX(list_begin + k);
        MetaBall ball = MB_BALL(id);
        vec3 w = ball.centre_radius.xyz - o;
        float tc = dot(w, d);
        vec3 cr = cross(w, d);
        float R = ball.centre_radius.w;
        float D = R * R - dot(cr, cr);
        if (!(D > 0.0)) continue;
        float half_chord = sqrt(D);
        float en = tc - half_chord;
        float ex = tc + half_chord;
        if (ex <= t0 || en >= t1) continue;
        if (n == MB_MAX_RAY_BALLS) {
            if (en >= enter_t[n - 1]) {
                t_limit = min(t_limit, en);
                continue;
            }
            t_limit = min(t_limit, enter_t[n - 1]);
            n -= 1;
        }
        int j = n;
        while (j > 0 && enter_t[j - 1] > en) {
            enter_t[j] = enter_t[j - 1];
            exit_t[j] = exit_t[j - 1];
            chord_a[j] = chord_a[j - 1];
            ball_id[j] = ball_id[j - 1];
            --j;
        }
        enter_t[j] = en;
        exit_t[j] = ex;
        chord_a[j] = D / (R * R);
        ball_id[j] = id;
        ++n;
    }
    float t_end = min(t1, t_limit);

    // Sweep the intervals between chord ends, nearest first (seed section 2.3).
    uint live = 0u;
    int next = 0;
    float t_cur = t0;
    float t_found = 0.0;
    bool found = false;
    for (int step = 0; step < 2 * MB_MAX_RAY_BALLS + 1; ++step) {
        while (next < n && enter_t[next] <= t_cur) {
            live |= 1u << uint(next);
            ++next;
        }
        uint m = live;
        while (m != 0u) {
            int j = findLSB(m);
            m &= m - 1u;
            if (exit_t[j] <= t_cur) live &= ~(1u << uint(j));
        }
        if (t_cur >= t_end) break;
        float t_next = t_end;
        if (next < n) t_next = min(t_next, enter_t[next]);
        m = live;
        while (m != 0u) {
            int j = findLSB(m);
            m &= m - 1u;
            t_next = min(t_next, exit_t[j]);
        }
        int count = bitCount(live);
        if (count == 1) {
            // A lone ball: its isosurface is a sphere of radius ρ*R (seed section 2.1).
            int j = findLSB(live);
            MetaBall ball = MB_BALL(ball_id[j]);
            vec3 w = ball.centre_radius.xyz - o;
            float tc = dot(w, d);
            vec3 cr = cross(w, d);
            float h2 = dot(cr, cr);
            float rr = ball.coeffs.y;
            float disc = rr * rr - h2;
            if (rr > 0.0 && disc >= 0.0) {
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
                if (near_t >= t_cur && near_t <= t_next) {
                    t_found = near_t;
                    found = true;
                } else if (far_t >= t_cur && far_t <= t_next) {
                    t_found = far_t;
                    found = true;
                }
            }
            if (tc >= t_cur && tc <= t_next) {
                // The field's maximum on this ray is at the closest approach: within δ of T is a
                // graze (a near miss, or a hit on the silhouette).
                float R = ball.centre_radius.w;
                float gmax = ball.coeffs.x * mb_kernel(kernel, h2 / (R * R)) - T;
                float delta = mb_delta(abs(ball.coeffs.x) + T, X + t_next, ball.coeffs.z);
                if (abs(gmax) <= delta) hit.flags |= MB_TANGENT;
            }
        } else if (count >= 2) {
            // Several: Σ q·f as one Bernstein polynomial over the interval, minus T (seed 2.2).
            float c[7];
            float scale[7];
            for (int k = 0; k < 7; ++k) {
                c[k] = -T;
                scale[k] = 0.0;
            }
            float G = 0.0;
            m = live;
            while (m != 0u) {
                int j = findLSB(m);
                m &= m - 1u;
                MetaBall ball = MB_BALL(ball_id[j]);
                float chord = exit_t[j] - enter_t[j];
                float sa = clamp((t_cur - enter_t[j]) / chord, 0.0, 1.0);
                float sb = clamp((t_next - enter_t[j]) / chord, 0.0, 1.0);
                float dj[7];
                mb_chord_bernstein(kernel, chord_a[j], ball.coeffs.x, dj);
                mb_restrict(dj, sa, sb);
                for (int k = 0; k < 7; ++k) {
                    c[k] += dj[k];
                    scale[k] += abs(dj[k]);
                }
                G += ball.coeffs.z;
            }
            float S = 0.0;
            for (int k = 0; k < 7; ++k) S = max(S, scale[k]);
            float delta = mb_delta(S + T, X + t_next, G);
            float alpha = mb_first_root(c, MB_FLAT_C * MB_EPS * (S + T), delta, hit.iterations, hit.flags);
            if ((hit.flags & MB_NOT_CONVERGED) != 0u) return hit;
            if (alpha >= 0.0) {
                if (mb_shallow_root(c, alpha, delta)) hit.flags |= MB_TANGENT;
                t_found = t_cur + alpha * (t_next - t_cur);
                found = true;
            }
        }
        if (found) break;
        t_cur = t_next;
    }
    if (!found) {
        if (t_limit < t1) {
            // Known to miss up to t_limit only: report it, so a caller may cast again from there.
            hit.flags |= MB_OVERFLOW;
            hit.t = t_limit / ts;
        }
        return hit;
    }

    // The normal from the gradient (seed eq. 25) over the ray's balls, mapped by M⁻ᵀ.
    vec3 p = o + d * t_found;
    vec3 grad = vec3(0.0);
    for (int j = 0; j < n; ++j) {
        MetaBall ball = MB_BALL(ball_id[j]);
        vec3 w = p - ball.centre_radius.xyz;
        float inv_r2 = 1.0 / (ball.centre_radius.w * ball.centre_radius.w);
        grad += w * (2.0 * ball.coeffs.x * inv_r2 * mb_kernel_deriv(kernel, dot(w, w) * inv_r2));
    }
    vec3 nw = mat3(g.normal_matrix) * -grad;
    float len = length(nw);
    hit.normal = len > 0.0 ? nw / len : -dir;
    hit.t = t_found / ts;
    hit.flags |= MB_HIT;
    return hit;
}

#endif  // HADOU_METABALLS_CAST
