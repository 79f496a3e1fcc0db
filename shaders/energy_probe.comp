#version 460
// energy_probe: the energy-wave integral for rays given in a buffer instead of pixels, so tests
// can feed the GPU exact hard rays (through M, along D, ...) and compare with the f64 reference.
#include "common/energy_wave.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) readonly buffer Waves { Wave waves[]; };
layout(set = 0, binding = 1, std430) readonly buffer Rays { vec4 rays[]; };  // xyz: unit u, w: L
layout(set = 0, binding = 2, std430) writeonly buffer Results { float results[]; };  // [ray][wave]

layout(push_constant) uniform ProbeParams {
    uvec4 counts;  // rays, waves, method (0 analytic, 1 raymarch), steps
    vec4 offset;   // x: raymarch sample offset
} params;

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= params.counts.x) return;
    vec4 ray = rays[r];
    for (uint i = 0u; i < params.counts.y; ++i) {
        float H = params.counts.z == 0u
            ? wave_line_integral(waves[i], ray.xyz, ray.w)
            : wave_raymarch(waves[i], ray.xyz, ray.w, params.counts.w, params.offset.x);
        results[r * params.counts.y + i] = H;
    }
}
