// The energy wave (seed 004): closed-form integral of its density along a pixel ray, and the
// ray-march baseline. Keep in sync with src/effects/energy_wave_f32.rs, its f32 CPU twin line for
// line (the struct's size and offsets are asserted there); the model, the closed form and the
// clamp rule are documented in src/effects/energy_wave.rs.
//
// Model: E(P) = a·k(|P − M|) + b·k(dist(P, segment [M, M + ℓD])), k(r) = 1/√(r² + ε²).
// wave_line_integral returns H = ∫₀ᴸ E(O + s·u) ds for the camera O the Wave was built for
// (every field is camera-relative, computed in f64 on the CPU and rounded once).
//
// Clamp (ε = 0 singularities), per term (the sphere term; the line term with all its pieces):
// S = the largest end distance √(ξ² + h² + ε²) over the term's pieces of nonzero length (L when
// all are 0), F = max(2^-20·S, 2^-60), d = the smallest distance (without ε) the ray reaches on
// those pieces; the term is integrated with the core radius ε_F = √(max(ε², F² − d²)), so every
// distance on every piece is ≥ F. Nothing changes when √(d² + ε²) ≥ F. The f64 reference applies
// the same rule: the result is finite, ≥ 0, and matches the CPU even there.
//
// Precision: the per-pixel quantities that cancel (u·D, D × u, |D × u|², R·(D × u), R × (D × u),
// the 4D wedge behind h, ξ at the piece ends, the split points) are double-floats (vec2: hi, lo)
// built with error-free transformations that need only Vulkan's correctly rounded add, sub and
// mul: their variables are `precise` (SPIR-V NoContraction), which forbids fusing them into
// FMAs and the reassociations that would cancel them (c − (c − a) → a). No fma() is relied on
// (Vulkan allows it to be unfused). Denormals may be flushed; that only costs accuracy on scenes
// with lengths below ~1e-25. Valid for lengths below 1e18 (squares must stay finite).
#ifndef HADOU_ENERGY_WAVE_GLSL
#define HADOU_ENERGY_WAVE_GLSL

// One wave seen from the camera (std430, 64 bytes). Keep in sync with GpuWave in
// src/effects/energy_wave_f32.rs. O − M = q0·D + R × D, O − T = (q0 − ℓ)·D + R × D.
struct Wave {
    vec4 dir;       // xyz: D (unit); w: q0 = (O − M)·D
    vec4 rperp;     // xyz: R = D × (O − M); w: q0 − ℓ (0 when the beam is endless)
    vec4 strength;  // x: a, y: b, z: ε (core radius), w: 0
    uvec4 flags;    // x: 1 when the beam length is finite
};

const float HADOU_SPLITTER = 4097.0;                 // 2^12 + 1: Veltkamp's split
const float WAVE_CLAMP_RATIO = 9.5367431640625e-7;   // 2^-20
const float WAVE_CLAMP_MIN = 8.673617379884035e-19;  // 2^-60
const float WAVE_PARALLEL_MIN = 8.673617379884035e-19;  // 2^-60
const float WAVE_LINEAR_TAU = 2.44140625e-4;         // 2^-12
const float HADOU_BIG = 3.0e38;
const float WAVE_MAX_LENGTH = 1.0e18;                // L is clamped here: squares stay finite

// log1p(x) for x > −1. Mesa lowers asinh without log1p and Vulkan allows log an absolute error
// of 2^-21 in [0.5, 2]: for −0.5 ≤ x ≤ 1 use 2·atanh(z), z = x/(2 + x), |z| ≤ 1/3, as the odd
// series to z^15/15 (the first omitted term is < 1.5e-9 relative); log only outside, where it
// has a relative (3 ulp) bound.
float hadou_log1p(float x) {
    if (x > 1.0 || x < -0.5) {
        return log(1.0 + x);
    }
    float z = x / (2.0 + x);
    float z2 = z * z;
    float p = 1.0 / 15.0;
    p = p * z2 + 1.0 / 13.0;
    p = p * z2 + 1.0 / 11.0;
    p = p * z2 + 1.0 / 9.0;
    p = p * z2 + 1.0 / 7.0;
    p = p * z2 + 1.0 / 5.0;
    p = p * z2 + 1.0 / 3.0;
    p = p * z2 + 1.0;
    return 2.0 * z * p;
}

// asinh(x) for x ≥ 0 as log1p(x + x²/(1 + √(1 + x²))).
float hadou_asinh_pos(float x) {
    return hadou_log1p(x + x * x / (1.0 + sqrt(1.0 + x * x)));
}

// ---- double-float arithmetic: vec2(hi, lo), value hi + lo --------------------------------------

// a + b exactly (Knuth).
vec2 hadou_two_sum(float a, float b) {
    precise float s = a + b;
    precise float bb = s - a;
    precise float e = (a - (s - bb)) + (b - bb);
    return vec2(s, e);
}

// a + b exactly when |a| ≥ |b| (Dekker).
vec2 hadou_fast_two_sum(float a, float b) {
    precise float s = a + b;
    precise float e = b - (s - a);
    return vec2(s, e);
}

// a = hi + lo with 12-bit halves (Veltkamp).
vec2 hadou_split(float a) {
    precise float c = HADOU_SPLITTER * a;
    precise float hi = c - (c - a);
    precise float lo = a - hi;
    return vec2(hi, lo);
}

// a·b exactly (Dekker), barring overflow (|a|, |b| < 2^115) and underflow of the error term.
vec2 hadou_two_prod(float a, float b) {
    precise float p = a * b;
    vec2 sa = hadou_split(a);
    vec2 sb = hadou_split(b);
    precise float e = ((sa.x * sb.x - p) + sa.x * sb.y + sa.y * sb.x) + sa.y * sb.y;
    return vec2(p, e);
}

vec2 hadou_df_add(vec2 x, vec2 y) {
    vec2 s = hadou_two_sum(x.x, y.x);
    precise float lo = s.y + (x.y + y.y);
    return hadou_fast_two_sum(s.x, lo);
}

vec2 hadou_df_neg(vec2 x) {
    return -x;
}

// a·y for a float a and a double-float y.
vec2 hadou_df_mul(float a, vec2 y) {
    vec2 p = hadou_two_prod(a, y.x);
    precise float lo = p.y + a * y.y;
    return vec2(p.x, lo);
}

// x·y for two double-floats (the lo·lo term dropped).
vec2 hadou_df_mul_df(vec2 x, vec2 y) {
    vec2 p = hadou_two_prod(x.x, y.x);
    precise float lo = p.y + (x.x * y.y + x.y * y.x);
    return vec2(p.x, lo);
}

// x².
vec2 hadou_df_sqr(vec2 x) {
    vec2 p = hadou_two_prod(x.x, x.x);
    precise float lo = p.y + 2.0 * x.x * x.y;
    return vec2(p.x, lo);
}

// a·b − c·d.
vec2 hadou_df_diff_prod(float a, float b, float c, float d) {
    return hadou_df_add(hadou_two_prod(a, b), hadou_df_neg(hadou_two_prod(c, d)));
}

vec2 hadou_df_dot(vec3 a, vec3 b) {
    return hadou_df_add(hadou_df_add(hadou_two_prod(a.x, b.x), hadou_two_prod(a.y, b.y)),
                        hadou_two_prod(a.z, b.z));
}

float hadou_df_round(vec2 x) {
    precise float r = x.x + x.y;
    return r;
}

// The larger of two double-floats.
vec2 hadou_df_max(vec2 a, vec2 b) {
    if (hadou_df_round(hadou_df_add(a, hadou_df_neg(b))) >= 0.0) {
        return a;
    }
    return b;
}

float hadou_dot3(vec3 a, vec3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// ---- the closed form ---------------------------------------------------------------------------

// The ray in the frame of the beam, shared by its three centres: u_D = u·D, c = D × u, |c|², R·c
// as double-floats, and |R × c|² (from a double-float R × c).
struct WaveRay {
    vec2 ud;
    vec2 cx;
    vec2 cy;
    vec2 cz;
    vec2 cc;
    vec2 rc;
    float rxc2;
};

WaveRay wave_ray(Wave g, vec3 u) {
    vec3 d = g.dir.xyz;
    vec3 r = g.rperp.xyz;
    WaveRay ray;
    ray.ud = hadou_df_dot(u, d);
    ray.cx = hadou_df_diff_prod(d.y, u.z, d.z, u.y);
    ray.cy = hadou_df_diff_prod(d.z, u.x, d.x, u.z);
    ray.cz = hadou_df_diff_prod(d.x, u.y, d.y, u.x);
    ray.cc = hadou_df_add(hadou_df_add(hadou_df_sqr(ray.cx), hadou_df_sqr(ray.cy)), hadou_df_sqr(ray.cz));
    ray.rc = hadou_df_add(hadou_df_add(hadou_df_mul(r.x, ray.cx), hadou_df_mul(r.y, ray.cy)),
                          hadou_df_mul(r.z, ray.cz));
    vec3 x = vec3(
        hadou_df_round(hadou_df_add(hadou_df_mul(r.y, ray.cz), hadou_df_neg(hadou_df_mul(r.z, ray.cy)))),
        hadou_df_round(hadou_df_add(hadou_df_mul(r.z, ray.cx), hadou_df_neg(hadou_df_mul(r.x, ray.cz)))),
        hadou_df_round(hadou_df_add(hadou_df_mul(r.x, ray.cy), hadou_df_neg(hadou_df_mul(r.y, ray.cx)))));
    ray.rxc2 = hadou_dot3(x, x);
    return ray;
}

// A line P0 + s·V seen from its centre: ξ(s) = (A + s·B)/m (A = P0·V, B = |V|² as
// double-floats), closest distance h.
struct WaveCentre {
    vec2 A;
    vec2 B;
    float m;
    float h;
};

// The centre M (q = q0) or T (q = q0 − ℓ): the 4D line (q, R) + s·(u_D, c).
WaveCentre wave_centre_point(WaveRay ray, float q, vec3 r) {
    WaveCentre c;
    c.B = hadou_df_add(hadou_df_sqr(ray.ud), ray.cc);
    c.m = sqrt(hadou_df_round(c.B));
    if (!(c.m > WAVE_PARALLEL_MIN)) {
        c.A = vec2(0.0);
        c.B = vec2(0.0);
        c.m = 0.0;
        c.h = sqrt(q * q + hadou_dot3(r, r));
        return c;
    }
    c.A = hadou_df_add(hadou_df_mul(q, ray.ud), ray.rc);
    // |P0 ∧ V|² = |q·c − u_D·R|² + |R × c|².
    vec3 w = vec3(
        hadou_df_round(hadou_df_add(hadou_df_mul(q, ray.cx), hadou_df_neg(hadou_df_mul(r.x, ray.ud)))),
        hadou_df_round(hadou_df_add(hadou_df_mul(q, ray.cy), hadou_df_neg(hadou_df_mul(r.y, ray.ud)))),
        hadou_df_round(hadou_df_add(hadou_df_mul(q, ray.cz), hadou_df_neg(hadou_df_mul(r.z, ray.ud)))));
    c.h = sqrt(hadou_dot3(w, w) + ray.rxc2) / c.m;
    return c;
}

// The axis: the 3D line R + s·c (|R + s·c| = distance to the axis).
WaveCentre wave_centre_axis(WaveRay ray, vec3 r) {
    WaveCentre c;
    c.m = sqrt(hadou_df_round(ray.cc));
    if (!(c.m > WAVE_PARALLEL_MIN)) {
        c.A = vec2(0.0);
        c.B = vec2(0.0);
        c.m = 0.0;
        c.h = sqrt(hadou_dot3(r, r));
        return c;
    }
    c.A = ray.rc;
    c.B = ray.cc;
    c.h = sqrt(ray.rxc2) / c.m;
    return c;
}

// ξ(s) = (A + s·B)/m, the sum in double-float.
float wave_xi(WaveCentre c, vec2 s) {
    if (c.m == 0.0) {
        return 0.0;
    }
    vec2 t = hadou_df_mul_df(s, c.B);
    return hadou_df_round(hadou_df_add(c.A, t)) / c.m;
}

// One piece of a term: its length and ξ at its ends (empty when ds ≤ 0).
struct WavePiece {
    float ds;
    float xa;
    float xb;
    float m;
    float h;
};

WavePiece wave_piece_empty() {
    return WavePiece(0.0, 0.0, 0.0, 0.0, 0.0);
}

// The piece [s0, s1] (double-float ends) of the line seen from c.
WavePiece wave_piece(WaveCentre c, vec2 s0, vec2 s1) {
    WavePiece p = wave_piece_empty();
    float ds = hadou_df_round(hadou_df_add(s1, hadou_df_neg(s0)));
    if (ds > 0.0) {
        p.ds = ds;
        p.xa = wave_xi(c, s0);
        p.xb = wave_xi(c, s1);
        p.m = c.m;
        p.h = c.h;
    }
    return p;
}

// ∫ ds/√(ξ(s)² + hh²) over one piece, hh = √(h² + ε_F²): ρa, ρb (and hh where the closest
// approach is inside) are at least F ≥ 2^-60, so no division here is by 0.
float wave_piece_integral(WavePiece p, float hh) {
    float ds = p.ds;
    float ra = sqrt(p.xa * p.xa + hh * hh);
    float rb = sqrt(p.xb * p.xb + hh * hh);
    if (p.m * ds <= WAVE_LINEAR_TAU * (ra + rb)) {
        return 2.0 * ds / (ra + rb);
    }
    float v;
    if (p.xa >= 0.0) {
        v = hadou_log1p(p.m * ds * (1.0 + (p.xa + p.xb) / (ra + rb)) / (p.xa + ra));
    } else if (p.xb <= 0.0) {
        v = hadou_log1p(p.m * ds * (1.0 - (p.xa + p.xb) / (ra + rb)) / (rb - p.xb));
    } else {
        v = hadou_asinh_pos(p.xb / hh) + hadou_asinh_pos(-p.xa / hh);
    }
    return v / p.m;
}

// Accumulates one piece into the clamp's S² (smax2) and d² (dmin2).
void wave_term_scan(WavePiece p, float e2, inout float smax2, inout float dmin2) {
    if (p.ds > 0.0) {
        float h2 = p.h * p.h;
        smax2 = max(max(smax2, p.xa * p.xa + h2 + e2), p.xb * p.xb + h2 + e2);
        float xn = 0.0;
        if (p.xa > 0.0) {
            xn = p.xa;
        } else if (p.xb < 0.0) {
            xn = -p.xb;
        }
        dmin2 = min(dmin2, xn * xn + h2);
    }
}

// One term: its pieces share the clamp.
float wave_term(WavePiece p0, WavePiece p1, WavePiece p2, float eps, float L) {
    float e2 = eps * eps;
    float smax2 = 0.0;
    float dmin2 = HADOU_BIG;
    wave_term_scan(p0, e2, smax2, dmin2);
    wave_term_scan(p1, e2, smax2, dmin2);
    wave_term_scan(p2, e2, smax2, dmin2);
    if (dmin2 == HADOU_BIG) {
        return 0.0;
    }
    float scale = smax2 > 0.0 ? sqrt(smax2) : L;
    float fl = max(WAVE_CLAMP_RATIO * scale, WAVE_CLAMP_MIN);
    float core2 = max(e2, fl * fl - dmin2);
    float sum = 0.0;
    if (p0.ds > 0.0) {
        sum += wave_piece_integral(p0, sqrt(p0.h * p0.h + core2));
    }
    if (p1.ds > 0.0) {
        sum += wave_piece_integral(p1, sqrt(p1.h * p1.h + core2));
    }
    if (p2.ds > 0.0) {
        sum += wave_piece_integral(p2, sqrt(p2.h * p2.h + core2));
    }
    return sum;
}

// clamp(num/den, 0, L) as a double-float, for a double-float den ≥ 0, dividing only when the
// answer is inside (a den flushed to 0 gives L, never inf or NaN). One Newton step on the
// residual puts the split where q = 0 (or q = ℓ) to ~2^-48 relative.
vec2 wave_crossing(float num, vec2 den, float L) {
    if (num <= 0.0) {
        return vec2(0.0);
    }
    // num ≥ L·den, decided on the exact residual.
    if (hadou_df_round(hadou_df_add(vec2(num, 0.0), hadou_df_neg(hadou_df_mul(L, den)))) >= 0.0) {
        return vec2(L, 0.0);
    }
    float s = num / den.x;
    if (!(s < HADOU_BIG)) {
        return vec2(L, 0.0);
    }
    vec2 r = hadou_df_add(vec2(num, 0.0), hadou_df_neg(hadou_df_mul(s, den)));
    vec2 t = hadou_fast_two_sum(s, hadou_df_round(r) / den.x);
    if (t.x > L || (t.x == L && t.y > 0.0)) {
        return vec2(L, 0.0);
    }
    return t;
}

// H = ∫₀ᴸ E(O + s·u) ds in closed form. u is used exactly as given (unit or not); L ≤ 0 (or NaN)
// gives 0, L above 1e18 (or +inf) counts as 1e18. Finite and ≥ 0 for finite wave parameters.
float wave_line_integral(Wave w, vec3 u, float L) {
    if (!(L > 0.0)) {
        return 0.0;
    }
    L = min(L, WAVE_MAX_LENGTH);
    vec3 r = w.rperp.xyz;
    float q0 = w.dir.w;
    float qt = w.rperp.w;
    float eps = w.strength.z;
    bool finite = w.flags.x != 0u;
    WaveRay ray = wave_ray(w, u);
    // The sphere term: one piece, centre M.
    WaveCentre cm = wave_centre_point(ray, q0, r);
    vec2 zero = vec2(0.0);
    vec2 end = vec2(L, 0.0);
    float sphere = wave_term(wave_piece(cm, zero, end), wave_piece_empty(), wave_piece_empty(), eps, L);
    // The line term: behind M (q < 0), along the beam, past the tip (q > ℓ); split points as
    // double-floats.
    vec2 b0, b1, c0, c1, t0, t1;
    if (ray.ud.x >= 0.0) {
        vec2 s0 = wave_crossing(-q0, ray.ud, L);
        vec2 s1 = finite ? hadou_df_max(wave_crossing(-qt, ray.ud, L), s0) : end;
        b0 = zero; b1 = s0; c0 = s0; c1 = s1; t0 = s1; t1 = end;
    } else {
        vec2 s1 = finite ? wave_crossing(qt, hadou_df_neg(ray.ud), L) : zero;
        vec2 s0 = hadou_df_max(wave_crossing(q0, hadou_df_neg(ray.ud), L), s1);
        b0 = s0; b1 = end; c0 = s1; c1 = s0; t0 = zero; t1 = s1;
    }
    WavePiece pb = wave_piece(cm, b0, b1);
    WavePiece pc = wave_piece_empty();
    if (hadou_df_round(hadou_df_add(c1, hadou_df_neg(c0))) > 0.0) {
        pc = wave_piece(wave_centre_axis(ray, r), c0, c1);
    }
    WavePiece pt = wave_piece_empty();
    if (hadou_df_round(hadou_df_add(t1, hadou_df_neg(t0))) > 0.0) {
        pt = wave_piece(wave_centre_point(ray, qt, r), t0, t1);
    }
    float line = wave_term(pb, pc, pt, eps, L);
    return w.strength.x * sphere + w.strength.y * line;
}

// ---- the ray-march baseline --------------------------------------------------------------------

// E at O + s·u with distances floored at fl (plain f32).
float wave_density_at(Wave g, vec3 c, float ud, float s, float fl) {
    float e2 = g.strength.z * g.strength.z;
    float q = g.dir.w + s * ud;
    vec3 r = g.rperp.xyz;
    vec3 pc = vec3(r.x + s * c.x, r.y + s * c.y, r.z + s * c.z);
    float r2 = hadou_dot3(pc, pc);
    float rm = max(sqrt(q * q + r2 + e2), fl);
    float qt = g.rperp.w + s * ud;
    float dl2 = r2;
    if (q <= 0.0) {
        dl2 = q * q + r2;
    } else if (g.flags.x != 0u && qt >= 0.0) {
        dl2 = qt * qt + r2;
    }
    float rl = max(sqrt(dl2 + e2), fl);
    return g.strength.x / rm + g.strength.y / rl;
}

// steps samples at s_i = (i + offset)·L/N, each weighted L/N (offset 0.5: the midpoint rule),
// distances floored at max(2^-20·L/N, 2^-60).
float wave_raymarch(Wave w, vec3 u, float L, uint steps, float offset) {
    if (!(L > 0.0) || steps == 0u) {
        return 0.0;
    }
    float ds = min(L, WAVE_MAX_LENGTH) / float(steps);
    float fl = max(WAVE_CLAMP_RATIO * ds, WAVE_CLAMP_MIN);
    vec3 d = w.dir.xyz;
    vec3 c = vec3(d.y * u.z - d.z * u.y, d.z * u.x - d.x * u.z, d.x * u.y - d.y * u.x);
    float ud = hadou_dot3(u, d);
    float sum = 0.0;
    for (uint i = 0u; i < steps; ++i) {
        sum += wave_density_at(w, c, ud, (float(i) + offset) * ds, fl);
    }
    return sum * ds;
}

#endif
