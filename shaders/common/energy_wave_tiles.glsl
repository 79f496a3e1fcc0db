// The energy wave with a tolerance: the bound on the error of interpolating H bilinearly over a
// T×T-pixel tile from its corners. f32 twin of crates/hadou/src/effects/energy_wave/tolerance.rs
// (f64), where the argument is written out; this follows it line for line, with margins for f32:
// every angle that should be small is inflated and every one that should be large deflated by
// 2^-9 relative (Vulkan allows atan 4096 ulp ≈ 2^-11) plus 2^-22 absolute, sin and asin are
// replaced by bounds that need no transcendental (sin g ≥ g − g³/6 for g ≥ 0, asin x ≤ x/√(1 − x²),
// asin x ≥ x), and the sum is inflated by 2^-8 for its own rounding. NaN or ∞ anywhere (lengths
// near f32's range) makes the tile exact: the comparison with the tolerance fails.
#ifndef HADOU_ENERGY_WAVE_TILES_GLSL
#define HADOU_ENERGY_WAVE_TILES_GLSL

#include "common/energy_wave.glsl"

// Workgroups per row of the indirect dispatch over the exact tiles' list.
#define WAVE_TILES_PER_ROW 64u

// The pass defines WAVE_TILE (4 or 8) for the shaders over tiles; energy_wave_interp.comp
// defaults to 8 so the file compiles on its own (the viewer's shader check).
#ifdef WAVE_TILE
// The passes over tiles run 8×8 workgroups (lavapipe pays per workgroup: with 4×4 ones the tile
// path at 512² and 1e-4, nearly every tile exact, cost 2.6× the exact pass). With T = 8 a
// workgroup is one tile, the same for all its invocations, so lavapipe loads the tile's values
// once; with T = 4 it covers 2×2 tiles.
#define WAVE_TILES_PER_GROUP ((8 / WAVE_TILE) * (8 / WAVE_TILE))

// The tile of this invocation in a dispatch over the whole frame.
uvec2 wave_frame_tile() {
#if WAVE_TILE == 8
    return gl_WorkGroupID.xy;
#else
    return gl_GlobalInvocationID.xy / uint(WAVE_TILE);
#endif
}

// The slot of this invocation's tile in a dispatch over a list.
uint wave_list_slot() {
    uint group = gl_WorkGroupID.y * WAVE_TILES_PER_ROW + gl_WorkGroupID.x;
#if WAVE_TILE == 8
    return group;
#else
    uvec2 q = gl_LocalInvocationID.xy / uint(WAVE_TILE);
    return group * uint(WAVE_TILES_PER_GROUP) + q.y * uint(8 / WAVE_TILE) + q.x;
#endif
}

// This invocation's pixel offset in its tile.
uvec2 wave_tile_offset() {
    return gl_LocalInvocationID.xy % uint(WAVE_TILE);
}
#endif

// A tile index split into (x, y) without an integer division (lavapipe runs a vector division
// lane by lane): a float division (the +0.5 keeps the quotient 0.5/tiles_x from an integer;
// Vulkan allows it 2.5 ulp, so on grids of millions of tiles it can be one row off), then that
// row corrected with integer products.
uvec2 wave_tile_xy(uint tile, uint tiles_x) {
    uint y = uint((float(tile) + 0.5) / float(tiles_x));
    y = y * tiles_x > tile ? y - 1u : ((y + 1u) * tiles_x <= tile ? y + 1u : y);
    return uvec2(tile - y * tiles_x, y);
}

const float WAVE_ANGLE_GROW = 1.001953125;    // 1 + 2^-9
const float WAVE_ANGLE_SHRINK = 0.998046875;  // 1 − 2^-9
const float WAVE_ANGLE_ABS = 2.384185791015625e-7;  // 2^-22
const float WAVE_HALF_PI = 1.5707963267948966;

// The angle between two nonzero vectors, as computed (callers add the margins).
float wave_angle(vec3 a, vec3 b) {
    return atan(length(cross(a, b)), dot(a, b));
}

// A lower bound on the smallest angle from the unit u to the directions of the arc from the unit
// a to the unit b (angle_to_arc in tolerance.rs).
float wave_angle_to_arc(vec3 u, vec3 a, vec3 b) {
    float ua = wave_angle(u, a);
    float ends = min(ua, wave_angle(u, b));
    vec3 n = cross(a, b);
    float sin_ab = length(n);
    float short_arc = max(ua - wave_angle(a, b) * WAVE_ANGLE_GROW, 0.0);
    vec3 nn = n / max(sin_ab, 1e-30);
    vec3 p = u - nn * dot(u, nn);
    bool within = dot(cross(a, p), nn) >= 0.0 && dot(cross(p, b), nn) >= 0.0;
    // asin(x) ≥ x: the angle to the arc's plane.
    float plane = min(abs(dot(u, nn)), 1.0);
    float general = within ? plane : ends;
    return sin_ab < 1e-3 ? min(short_arc, ends) : general;
}

// A lower bound on a term's distance along every ray of the tile (Profile in tolerance.rs):
// φ(s) ≥ max(d, k1·(s1 − s), k2·(s − s2)); k2 = 0: none past s2. Packed as vec4(s1, k1, s2, k2).
vec4 wave_profile_radial(float rho_min, float rho_max, bool bounded) {
    return vec4(rho_min, 1.0, bounded ? rho_max : rho_min, bounded ? 1.0 : 0.0);
}

// The distance to the beam's axis: |c|·|s − s*| − α·s for the centre ray (c = D × u_c,
// s* = −R·c/|c|²); valid = false when |c| ≤ α. s1 and s2 are moved apart by 2^-9 of |s*| (and the
// slopes' α is already inflated) for the f32 rounding of s*.
vec4 wave_profile_axis(vec3 r, vec3 c, float alpha, out bool valid) {
    float m = length(c);
    valid = m > alpha;
    float s_star = -dot(r, c) / max(m * m, 1e-30);
    float k1 = m + alpha;
    float k2 = max(m - alpha, 1e-30);
    float slack = abs(s_star) * 0.001953125;
    return vec4(m * s_star / k1 - slack, k1, m * s_star / k2 + slack, k2);
}

// (∫ s²·2(φ² + ε²)^-3/2, ∫ s·(φ² + ε²)⁻¹) over [0, L] for φ ≥ max(d, profile) (integrals in
// tolerance.rs), w = max(d, ε).
vec2 wave_profile_integrals(vec4 p, float d2, float w, float l) {
    float before = p.x - w / p.y;
    float a0 = clamp(before, 0.0, l);
    float a1 = p.w > 0.0 ? clamp(p.z + w / p.w, a0, l) : l;
    float span = a1 - a0;
    float hessian = span * (a1 * a1 + a1 * a0 + a0 * a0) / (3.0 * d2 * sqrt(d2));
    float gradient = span * (a1 + a0) / (2.0 * d2);
    bool b = before > 0.0;
    hessian += b ? p.x * p.x / (2.0 * p.y * w * w) : 0.0;
    gradient += b ? p.x / (p.y * w) : 0.0;
    bool c = p.w > 0.0 && a1 < l;
    // s = s2 + t/k2 from s = a1 (t0 = k2·(a1 − s2) ≥ w, s ≥ 0) to L (T = k2·(L − s2)), exactly.
    float k = p.w;
    float t0 = max(k * (a1 - p.z), w);
    float tt = max(k * (l - p.z), t0);
    float lg = log(tt / t0) * WAVE_ANGLE_GROW + WAVE_ANGLE_ABS;
    // The terms may cancel (s2 < 0): each one's rounding is covered by 2^-20 of their magnitudes.
    float h0 = p.z * p.z * (0.5 / (t0 * t0) - 0.5 / (tt * tt));
    float h1 = 2.0 * p.z / k * (1.0 / t0 - 1.0 / tt);
    float h2 = lg / (k * k);
    float g0 = p.z * (1.0 / t0 - 1.0 / tt);
    float g1 = lg / k;
    float slack = 9.5367431640625e-7;  // 2^-20
    hessian += c ? max(h0 + h1 + h2 + slack * (abs(h0) + abs(h1) + h2), 0.0) / k : 0.0;
    gradient += c ? max(g0 + g1 + slack * (abs(g0) + g1), 0.0) / k : 0.0;
    return vec2(2.0 * hessian, gradient);
}

// d = ρ_min·sin(clamp(β − α, 0, 90°)), with sin g ≥ g − g³/6 and β deflated.
float wave_cone_distance(float rho_min, float beta, float alpha) {
    float gap = clamp(beta * WAVE_ANGLE_SHRINK - WAVE_ANGLE_ABS - alpha, 0.0, WAVE_HALF_PI);
    return rho_min * (gap - gap * gap * gap * (1.0 / 6.0));
}

// One term's share of the bound (term_bounds in tolerance.rs): x: ∫ s²·2(φ² + ε²)^-3/2,
// y: ∫ s(φ² + ε²)⁻¹, z: (d² + ε²)⁻¹, w: (d² + ε²)^-½, over the better of two profiles (the
// second used when valid2).
vec4 wave_term_bound(float d, float eps, float l, vec4 p1, vec4 p2, bool valid2, out float d2) {
    d2 = d * d + eps * eps;
    float w = max(d, eps);
    vec2 i1 = wave_profile_integrals(p1, d2, w, l);
    vec2 i2 = valid2 ? wave_profile_integrals(p2, d2, w, l) : i1;
    return vec4(min(i1, i2), 1.0 / d2, 1.0 / sqrt(d2));
}

// The bound for one wave over one tile of side h (tile_error_bound in tolerance.rs), from its centre
// ray uc, cone half-angle alpha, |u_x|, |u_y| bounds theta1, |u_xx|, |u_yy| bounds theta2, the
// largest corner L, the depth slopes and the largest per-pixel depth deviation. 3e38 where the
// tile must be exact.
float wave_tile_bound(Wave w, float h, vec3 uc, float alpha, vec2 theta1, vec2 theta2, float l, vec2 slope,
                      float deviation) {
    vec3 dir = w.dir.xyz;
    vec3 r = w.rperp.xyz;
    float q0 = w.dir.w;
    float qt = w.rperp.w;
    bool finite = w.flags.x != 0u;
    float len = q0 - qt;
    // M − O = −(q0·D + R × D).
    vec3 m = -(q0 * dir + cross(r, dir));
    float rho_m = length(m);
    vec3 t = m + len * dir;
    float rho_t = finite ? length(t) : 0.0;
    float rho_line_min = (q0 >= 0.0 && (!finite || qt <= 0.0)) ? length(r) : (finite ? min(rho_m, rho_t) : rho_m);
    vec3 end_dir = finite ? t / max(rho_t, 1e-30) : dir;
    float eps = w.strength.z;
    float d_m = wave_cone_distance(rho_m, wave_angle(uc, m), alpha);
    float d_line = wave_cone_distance(rho_line_min, wave_angle_to_arc(uc, m / max(rho_m, 1e-30), end_dir), alpha);
    float s_bound = rho_m + (finite ? len : 0.0) + l;
    float f = max(WAVE_CLAMP_RATIO * 2.0 * s_bound, WAVE_CLAMP_MIN);
    float clamp2 = f * f;
    float d2m;
    float d2l;
    vec4 radial_m = wave_profile_radial(rho_m, rho_m, true);
    vec4 bm = wave_term_bound(d_m, eps, l, radial_m, radial_m, false, d2m);
    bool axis_valid;
    // R = D × (O − M): the camera's offset from the axis, as the closed form has it.
    vec4 axis = wave_profile_axis(r, cross(dir, uc), alpha, axis_valid);
    vec4 radial_line = wave_profile_radial(rho_line_min, max(rho_m, rho_t), finite);
    vec4 bl = wave_term_bound(d_line, eps, l, radial_line, axis, axis_valid, d2l);
    float a = w.strength.x;
    float b = w.strength.y;
    bool ok = rho_m > 0.0 && (a == 0.0 || d2m >= clamp2) && (b == 0.0 || d2l >= clamp2);
    vec2 depth = 2.0 * l * slope * theta1 + slope * slope;
    vec2 gm = theta1 * theta1 * bm.x + theta2 * bm.y + depth * bm.z;
    vec2 gl = theta1 * theta1 * bl.x + theta2 * bl.y + depth * bl.z;
    vec2 g = (a > 0.0 ? a * gm : vec2(0.0)) + (b > 0.0 ? b * gl : vec2(0.0));
    float e_max = (a > 0.0 ? a * bm.w : 0.0) + (b > 0.0 ? b * bl.w : 0.0);
    float bound = (h * h / 8.0 * (g.x + g.y) + deviation * e_max) * 1.00390625;
    return ok ? bound : HADOU_BIG;
}

#endif
