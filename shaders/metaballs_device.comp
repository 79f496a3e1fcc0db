#version 460
// metaballs_device: completes the balls a game wrote on the GPU (crates/hadou/src/effects/metaballs/device.rs),
// copied as they are into the frame's ball table (crates/hadou/src/passes/metaballs_device.rs): per ball
// the lone ball's isosurface radius ρ*·R (the root of q·f(ρ²) = T, as effects::metaballs::iso_radius
// solves it in f64: closed form for Murakami4, bisection to adjacent floats for Wyvill6, here in
// f32) and the slope bound |q|·γ/R. A ball with a value that is not finite or R ≤ 0 becomes a ball
// of q = 0 (it adds nothing anywhere) and is counted (STAT_INVALID): nothing non-finite reaches
// the casts. With MB_PREVIOUS (motion vectors on) each ball's previous centre, its record's q.yzw
// when the group's records carry them (range.w = 1), goes into the table of previous centres
// that shaders/common/metaballs_motion.glsl reads. One invocation per ball of one group (a dispatch per
// group).
layout(local_size_x = 64) in;

layout(set = 0, binding = 10, std430) buffer Stats { uint stats[]; };
// The frame's ball table: two vec4 per ball (centre, R; q, ρ*·R, |q|·γ/R, 0), as GpuMetaBall.
layout(set = 0, binding = 24, std430) buffer Balls { vec4 balls[]; };
#ifdef MB_PREVIOUS
layout(set = 0, binding = 27, std430) writeonly buffer Previous { vec4 previous[]; };
#endif

// Keep in sync with DeviceBallParams in crates/hadou/src/passes/metaballs_device.rs.
layout(push_constant) uniform DeviceBallParams {
    uvec4 range;  // x: the group's first ball in the table, y: its count, z: kernel (MB_KERNEL_*),
                  // w: 1 when the records' q.yzw are the balls' previous centres
    vec4 values;  // x: T, y: the kernel's slope bound γ
} params;

#define STAT_INVALID 5
#define KERNEL_WYVILL6 0u

// f(r′) of effects::metaballs::Kernel::f.
float kernel_f(uint kernel, float rp) {
    if (rp >= 1.0) return 0.0;
    if (kernel == KERNEL_WYVILL6) return ((-4.0 / 9.0 * rp + 17.0 / 9.0) * rp - 22.0 / 9.0) * rp + 1.0;
    return (1.0 - rp) * (1.0 - rp);
}

// ρ* (0 when the lone ball has no surface: T/q outside (0, 1)).
float iso_radius(uint kernel, float q, float T) {
    float v = T / q;
    if (!(v > 0.0 && v < 1.0)) return 0.0;
    float x = 1.0 - sqrt(v);
    if (kernel == KERNEL_WYVILL6) {
        float lo = 0.0;
        float hi = 1.0;
        for (uint i = 0u; i < 160u; ++i) {
            float mid = 0.5 * (lo + hi);
            if (mid <= lo || mid >= hi) break;
            if (kernel_f(kernel, mid) > v) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        x = abs(kernel_f(kernel, lo) - v) <= abs(kernel_f(kernel, hi) - v) ? lo : hi;
    }
    return sqrt(x);
}

bool finite(vec4 v) { return !any(isnan(v)) && !any(isinf(v)); }

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= params.range.y) return;
    uint i = 2u * (params.range.x + k);
    vec4 centre_radius = balls[i];
    vec4 record_q = balls[i + 1u];
    float q = record_q.x;
#ifdef MB_PREVIOUS
    // A ball with no valid centre then weighs nothing (q = 0, below): any value serves.
    if (params.range.w != 0u) previous[params.range.x + k] = vec4(record_q.yzw, 0.0);
#endif
    float R = centre_radius.w;
    // R² and |q|·γ/R must stay finite too.
    bool valid = finite(centre_radius) && !isnan(q) && !isinf(q) && R > 0.0 && !isinf(R * R)
        && !isinf(abs(q) * params.values.y / R);
    if (!valid) {
        atomicAdd(stats[STAT_INVALID], 1u);
        balls[i] = vec4(0.0, 0.0, 0.0, 1.0);
        balls[i + 1u] = vec4(0.0);
        return;
    }
    float iso = iso_radius(params.range.z, q, params.values.x) * R;
    balls[i + 1u] = vec4(q, iso, abs(q) * params.values.y / R, 0.0);
}
