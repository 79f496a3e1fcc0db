// The energy wave (seed 004): closed-form integral of its density along a pixel ray, and the
// ray-march baseline. Keep in sync with crates/hadou/src/effects/energy_wave_f32.rs, its f32 CPU twin line for
// line (the struct's size and offsets are asserted there); the model, the closed form and the
// clamp rule are documented in crates/hadou/src/effects/energy_wave.rs.
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
//
// Cost: the code is written as one straight path with selects, because that is what a SIMD
// device runs anyway: lavapipe (Mesa 22.3's gallivm) turns every `if` into execution masks and
// runs both sides for every group of 8 invocations, even when no lane takes one of them, so a
// branch only ever adds the cost of its untaken side (measured: a never-taken branch around the
// whole integral costs as much as running it). Hence: one log1p per piece (the three cases pick
// their argument, not their code), the sphere term with its one piece, two plane crossings (not
// four), no double-float work on the constant end s = 0, and a log1p with no second branch.
// A cheaper plain-f32 path for "easy" rays would be paid on top of this one, never instead of it
// (and would cost accuracy: see "Cost" in crates/hadou/src/effects/energy_wave_f32.rs).
#ifndef HADOU_ENERGY_WAVE_GLSL
#define HADOU_ENERGY_WAVE_GLSL

// One wave seen from the camera (std430, 64 bytes). Keep in sync with GpuWave in
// crates/hadou/src/effects/energy_wave_f32.rs. O − M = q0·D + R × D, O − T = (q0 − ℓ)·D + R × D.
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
const float HADOU_SQRT2 = 1.41421353816986083984375; // √2 rounded to f32 (just below √2)
const float HADOU_LN2_HI = 0.693145751953125;        // ln 2 to 16 bits: k·LN2_HI is exact
const float HADOU_LN2_LO = 1.428606765330187e-6;     // ln 2 − LN2_HI

// log1p(x) for −1 < x < 3e38 with no log() and no branch. Mesa lowers asinh without log1p and
// Vulkan allows log an absolute error of 2^-21 in [0.5, 2], so: u = 1 + x rounded, err = x − (u − 1)
// its rounding error (exact: Fast2Sum's error term for |x| ≤ 1; for x > 1, u − 1 is exact below
// 2^24 and Sterbenz makes the difference exact), u = 2^k·f with f in [√½, √2) from the bits,
// log1p(x) = k·ln 2 + 2·atanh(z) + err/u with z = (f − 1)/(f + 1) (f − 1 exact by Sterbenz),
// |z| ≤ 0.1716, atanh as the odd series to z^9/9: the first omitted term, z^11/11, is below
// 2.0e-9 relative. The neglected −(err/u)²/2 is below 2^-49. Measured worst relative error
// 2.7e-7 (2.2 ulp) over [−0.99, 1e30] (crates/hadou/src/effects/energy_wave_f32.rs's test holds it below
// 4·2^-23). Only nonnegative arguments reach it here.
float hadou_log1p(float x) {
    precise float u = 1.0 + x;
    precise float err = x - (u - 1.0);
    int bits = floatBitsToInt(u);
    int k = ((bits >> 23) & 255) - 127;
    float f = intBitsToFloat((bits & 8388607) | 1065353216);  // mantissa, in [1, 2)
    bool high = f > HADOU_SQRT2;
    f = high ? 0.5 * f : f;
    k = high ? k + 1 : k;
    float z = (f - 1.0) / (f + 1.0);
    float z2 = z * z;
    float p = 1.0 / 9.0;
    p = p * z2 + 1.0 / 7.0;
    p = p * z2 + 1.0 / 5.0;
    p = p * z2 + 1.0 / 3.0;
    p = p * z2 + 1.0;
    float fk = float(k);
    return fk * HADOU_LN2_HI + (fk * HADOU_LN2_LO + (2.0 * z * p + err / u));
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

// round(x + y) for double-floats with |lo| ≤ 2^-23·|hi| (sums, products): when x.hi + y.hi
// cancels it is exact (Sterbenz), otherwise it is at least half the larger operand; either way
// the result is good to ~2^-23 of itself plus 2^-46 of the operands, as exact as the operands
// are. 3 ops instead of a renormalizing hadou_df_add's 11 and the rounding.
float hadou_df_add_round(vec2 x, vec2 y) {
    precise float r = (x.x + y.x) + (x.y + y.y);
    return r;
}

// a ≥ b for normalized double-floats (|lo| ≤ half an ulp of hi, as hadou_fast_two_sum returns):
// their order is the order of (hi, lo).
bool hadou_df_ge(vec2 a, vec2 b) {
    return a.x > b.x || (a.x == b.x && a.y >= b.y);
}

vec2 hadou_df_max(vec2 a, vec2 b) {
    return hadou_df_ge(a, b) ? a : b;
}

// b − a rounded, for normalized 0 ≤ a ≤ b: b.x − a.x is exact when a.x ≥ b.x/2 (Sterbenz) and
// otherwise at least b.x/2, so the result is good to ~2^-23 relative (a df_add would be 11 ops).
float hadou_df_span(vec2 a, vec2 b) {
    precise float d = (b.x - a.x) + (b.y - a.y);
    return d;
}

float hadou_dot3(vec3 a, vec3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// ---- the closed form ---------------------------------------------------------------------------

// The ray in the frame of the beam, shared by its three centres: u_D = u·D, c = D × u, |c|², R·c
// and the point centres' |V|² = u_D² + |c|² as double-floats, |V|, and |R × c|² (from a
// double-float R × c).
struct WaveRay {
    vec2 ud;
    vec2 cx;
    vec2 cy;
    vec2 cz;
    vec2 cc;
    vec2 rc;
    vec2 vv;
    float mv;
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
    ray.vv = hadou_df_add(hadou_df_sqr(ray.ud), ray.cc);
    ray.mv = sqrt(hadou_df_round(ray.vv));
    vec3 x = vec3(
        hadou_df_add_round(hadou_df_mul(r.y, ray.cz), hadou_df_neg(hadou_df_mul(r.z, ray.cy))),
        hadou_df_add_round(hadou_df_mul(r.z, ray.cx), hadou_df_neg(hadou_df_mul(r.x, ray.cz))),
        hadou_df_add_round(hadou_df_mul(r.x, ray.cy), hadou_df_neg(hadou_df_mul(r.y, ray.cx))));
    ray.rxc2 = hadou_dot3(x, x);
    return ray;
}

// A line P0 + s·V seen from its centre: ξ(s) = (A + s·B)/m (A = P0·V, B = |V|² as
// double-floats), closest distance h; m = 0 when |V| ≤ 2^-60 (ξ = 0, h = |P0|).
struct WaveCentre {
    vec2 A;
    vec2 B;
    float m;
    float h;
};

// The centre M (q = q0) or T (q = q0 − ℓ): the 4D line (q, R) + s·(u_D, c).
WaveCentre wave_centre_point(WaveRay ray, float q, vec3 r) {
    bool moving = ray.mv > WAVE_PARALLEL_MIN;
    // |P0 ∧ V|² = |q·c − u_D·R|² + |R × c|².
    vec3 w = vec3(
        hadou_df_add_round(hadou_df_mul(q, ray.cx), hadou_df_neg(hadou_df_mul(r.x, ray.ud))),
        hadou_df_add_round(hadou_df_mul(q, ray.cy), hadou_df_neg(hadou_df_mul(r.y, ray.ud))),
        hadou_df_add_round(hadou_df_mul(q, ray.cz), hadou_df_neg(hadou_df_mul(r.z, ray.ud))));
    WaveCentre c;
    c.A = moving ? hadou_df_add(hadou_df_mul(q, ray.ud), ray.rc) : vec2(0.0);
    c.B = moving ? ray.vv : vec2(0.0);
    c.m = moving ? ray.mv : 0.0;
    c.h = moving ? sqrt(hadou_dot3(w, w) + ray.rxc2) / ray.mv : sqrt(q * q + hadou_dot3(r, r));
    return c;
}

// The axis: the 3D line R + s·c (|R + s·c| = distance to the axis).
WaveCentre wave_centre_axis(WaveRay ray, vec3 r) {
    float m = sqrt(hadou_df_round(ray.cc));
    bool moving = m > WAVE_PARALLEL_MIN;
    WaveCentre c;
    c.A = moving ? ray.rc : vec2(0.0);
    c.B = moving ? ray.cc : vec2(0.0);
    c.m = moving ? m : 0.0;
    c.h = moving ? sqrt(ray.rxc2) / m : sqrt(hadou_dot3(r, r));
    return c;
}

// ξ(s) = (A + s·B)/m, the sum in double-float (0 when m = 0: then A = B = 0 and the division is
// by 1).
float wave_xi(WaveCentre c, vec2 s) {
    return hadou_df_add_round(c.A, hadou_df_mul_df(s, c.B)) / (c.m > 0.0 ? c.m : 1.0);
}

// ξ(0) = A/m.
float wave_xi0(WaveCentre c) {
    return hadou_df_round(c.A) / (c.m > 0.0 ? c.m : 1.0);
}

// One piece of a term: its length (≤ 0: empty) and ξ at its ends, seen from a centre with m, h.
struct WavePiece {
    float ds;
    float xa;
    float xb;
    float m;
    float h;
};

// ∫ ds/√(ξ(s)² + hh²) over one nonempty piece, hh = √(h² + ε_F²), ρ = √(ξ² + hh²):
// - m·Δs ≤ 2^-12·(ρa + ρb): 2·Δs/(ρa + ρb) (relative error below 2^-24; m = 0 included);
// - both ends ≥ 0: log1p(m·Δs·(ρa + ρb + ξa + ξb)/((ρa + ρb)·(ξa + ρa)))/m, and both ≤ 0 its
//   mirror image (ξa, ξb) → (−ξb, −ξa);
// - ξa < 0 < ξb: asinh(ξb/hh) + asinh(−ξa/hh) = log((ξb + ρb)/hh) + log((ρa − ξa)/hh)
//   = log1p(ya + yb + ya·yb)/m with y = x·(hh + ρ + x)/(hh·(hh + ρ)) for x = ξb, −ξa ≥ 0
//   (y = e^asinh(x/hh) − 1, no cancellation; the clamp keeps x/hh ≤ 2^20, so ya·yb ≤ 2^43).
// Every argument is a sum and product of nonnegative terms, so one log1p (relative) serves all
// three. ρa, ρb (and hh where the closest approach is inside) are at least F ≥ 2^-60, so no
// division that is used is by 0; unused ones are discarded by the selects.
float wave_piece_integral(WavePiece p, float hh) {
    float h2 = hh * hh;
    float ra = sqrt(p.xa * p.xa + h2);
    float rb = sqrt(p.xb * p.xb + h2);
    float sr = ra + rb;
    float mds = p.m * p.ds;
    bool neg = p.xa < 0.0 && p.xb <= 0.0;
    float xa = neg ? -p.xb : p.xa;
    float xb = neg ? -p.xa : p.xb;
    float r0 = neg ? rb : ra;
    float same = mds * (sr + xa + xb) / (sr * (xa + r0));
    float ha = hh + ra;
    float hb = hh + rb;
    float ya = -p.xa * (ha - p.xa) / (hh * ha);
    float yb = p.xb * (hb + p.xb) / (hh * hb);
    float v = hadou_log1p(xa >= 0.0 ? same : ya + yb + ya * yb) / (p.m > 0.0 ? p.m : 1.0);
    return mds <= WAVE_LINEAR_TAU * sr ? 2.0 * p.ds / sr : v;
}

// A piece's share of the clamp: S² (the larger end distance², with ε) and d² (its nearest
// distance², without ε); neutral values for an empty piece.
float wave_piece_smax2(WavePiece p, float e2) {
    float h2 = p.h * p.h;
    return p.ds > 0.0 ? max(p.xa * p.xa, p.xb * p.xb) + h2 + e2 : 0.0;
}

float wave_piece_dmin2(WavePiece p) {
    float xn = p.xa > 0.0 ? p.xa : (p.xb < 0.0 ? -p.xb : 0.0);
    return p.ds > 0.0 ? xn * xn + p.h * p.h : HADOU_BIG;
}

// The clamp's ε_F² for a term (see the header) from its S² and d².
float wave_core2(float smax2, float dmin2, float e2, float L) {
    float scale = smax2 > 0.0 ? sqrt(smax2) : L;
    float fl = max(WAVE_CLAMP_RATIO * scale, WAVE_CLAMP_MIN);
    return max(e2, fl * fl - dmin2);
}

float wave_piece_term(WavePiece p, float core2) {
    return p.ds > 0.0 ? wave_piece_integral(p, sqrt(p.h * p.h + core2)) : 0.0;
}

// The sphere term: one piece.
float wave_term1(WavePiece p, float eps, float L) {
    float e2 = eps * eps;
    float core2 = wave_core2(wave_piece_smax2(p, e2), wave_piece_dmin2(p), e2, L);
    return wave_piece_term(p, core2);
}

// The line term: its three pieces share the clamp.
float wave_term3(WavePiece p0, WavePiece p1, WavePiece p2, float eps, float L) {
    float e2 = eps * eps;
    float smax2 = max(max(wave_piece_smax2(p0, e2), wave_piece_smax2(p1, e2)), wave_piece_smax2(p2, e2));
    float dmin2 = min(min(wave_piece_dmin2(p0), wave_piece_dmin2(p1)), wave_piece_dmin2(p2));
    float core2 = wave_core2(smax2, dmin2, e2, L);
    float sum = wave_piece_term(p0, core2) + wave_piece_term(p1, core2) + wave_piece_term(p2, core2);
    return dmin2 == HADOU_BIG ? 0.0 : sum;
}

// clamp(num/den, 0, L) as a normalized double-float, for a double-float den ≥ 0: 0 when
// num ≤ 0, else s = num/den refined by one Newton step on the exact residual num − s·den (puts
// the split where q = 0 or q = ℓ to ~2^-46 relative), L when that reaches L or is not finite (den
// 0 or flushed to 0). s is replaced by 2L before the step when it is out of range, so the step
// stays finite (its inputs below 2^115).
vec2 wave_crossing(float num, vec2 den, float L) {
    float s = num / den.x;
    s = s >= 0.0 && s < 2.0 * L ? s : 2.0 * L;
    float r = hadou_df_add_round(vec2(num, 0.0), hadou_df_neg(hadou_df_mul(s, den)));
    vec2 t = hadou_fast_two_sum(s, r / den.x);
    bool inside = t.x < L || (t.x == L && t.y <= 0.0);
    return num <= 0.0 ? vec2(0.0) : (inside ? t : vec2(L, 0.0));
}

// H = ∫₀ᴸ E(O + s·u) ds in closed form. u is used exactly as given (unit or not); L ≤ 0 (or NaN)
// gives 0, L above 1e18 (or +inf) counts as 1e18. Finite and ≥ 0 for finite wave parameters.
float wave_line_integral(Wave w, vec3 u, float L) {
    bool valid = L > 0.0;
    L = valid ? min(L, WAVE_MAX_LENGTH) : 1.0;
    vec3 r = w.rperp.xyz;
    float q0 = w.dir.w;
    float qt = w.rperp.w;
    float eps = w.strength.z;
    bool finite = w.flags.x != 0u;
    vec2 zero = vec2(0.0);
    vec2 end = vec2(L, 0.0);
    WaveRay ray = wave_ray(w, u);
    // The sphere term: one piece, centre M.
    WaveCentre cm = wave_centre_point(ray, q0, r);
    float xm0 = wave_xi0(cm);
    float xml = wave_xi(cm, end);
    float sphere = wave_term1(WavePiece(L, xm0, xml, cm.m, cm.h), eps, L);
    // The line term: behind M (q < 0), along the beam, past the tip (q > ℓ). sm, st: where the
    // ray crosses q = 0 and q = ℓ (double-floats). Along +D (u_D ≥ 0) the pieces are
    // [0, sm], [sm, st], [st, L]; against it [sm, L], [st, sm], [0, st].
    bool fwd = ray.ud.x >= 0.0;
    vec2 aud = fwd ? ray.ud : hadou_df_neg(ray.ud);
    float sg = fwd ? -1.0 : 1.0;
    vec2 sm = wave_crossing(sg * q0, aud, L);
    vec2 st = finite ? wave_crossing(sg * qt, aud, L) : (fwd ? end : zero);
    vec2 smax = hadou_df_max(sm, st);
    sm = fwd ? sm : smax;
    st = fwd ? smax : st;
    float xms = wave_xi(cm, sm);
    WavePiece pb = fwd ? WavePiece(hadou_df_round(sm), xm0, xms, cm.m, cm.h)
                       : WavePiece(hadou_df_span(sm, end), xms, xml, cm.m, cm.h);
    WaveCentre ca = wave_centre_axis(ray, r);
    float xas = wave_xi(ca, sm);
    float xat = wave_xi(ca, st);
    WavePiece pc = fwd ? WavePiece(hadou_df_span(sm, st), xas, xat, ca.m, ca.h)
                       : WavePiece(hadou_df_span(st, sm), xat, xas, ca.m, ca.h);
    WaveCentre ct = wave_centre_point(ray, qt, r);
    float xts = wave_xi(ct, st);
    WavePiece pt = fwd ? WavePiece(hadou_df_span(st, end), xts, wave_xi(ct, end), ct.m, ct.h)
                       : WavePiece(hadou_df_round(st), wave_xi0(ct), xts, ct.m, ct.h);
    float line = wave_term3(pb, pc, pt, eps, L);
    return valid ? w.strength.x * sphere + w.strength.y * line : 0.0;
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
