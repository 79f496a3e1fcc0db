#version 460
// energy_wave: per pixel, H = ∫₀ᴸ E(O + s·u) ds for each wave, L = the view distance to the first
// surface (or the camera's far distance). Adds colour × intensity × H to HDR, writes Σ H to energy.
// CPU twins: src/effects/energy_wave.rs (f64), src/effects/energy_wave_f32.rs (this arithmetic).
#include "common/energy_wave.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// Keep in sync with WaveStyle in src/passes/energy_wave.rs.
struct WaveStyle {
    vec4 emission;  // rgb: colour × intensity
    uvec4 method;   // x: 0 analytic, 1 raymarch; y: steps; z: jitter
};

layout(set = 0, binding = 0, r32f) uniform readonly image2D distance_image;
layout(set = 0, binding = 1, rgba16f) uniform image2D hdr;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D energy;
layout(set = 0, binding = 3, std430) readonly buffer Waves { Wave waves[]; };
layout(set = 0, binding = 4, std430) readonly buffer Styles { WaveStyle styles[]; };

// Keep in sync with RayParams in src/passes/energy_wave.rs.
layout(push_constant) uniform RayParams {
    vec4 right;    // right × tan(fov/2) × aspect
    vec4 up;       // up × tan(fov/2)
    vec4 forward;
    uvec4 dims;    // width, height, wave count
    vec4 far;      // x: far distance
} params;

// Largest finite RGBA16F value: emission is clamped so HDR never holds Inf.
const float HALF_MAX = 65504.0;

// A per-pixel offset in [0, 1) for jittered ray marching (PCG hash).
float pixel_jitter(uvec2 p, uint wave) {
    uint v = p.x * 1973u + p.y * 9277u + wave * 26699u + 1u;
    v = v * 747796405u + 2891336453u;
    v = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
    v = (v >> 22u) ^ v;
    return float(v >> 8u) * (1.0 / 16777216.0);
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= params.dims.x || p.y >= params.dims.y) return;
    // The ray through the pixel centre, as Camera::pixel_ray builds it.
    float ndc_x = 2.0 * (float(p.x) + 0.5) / float(params.dims.x) - 1.0;
    float ndc_y = 1.0 - 2.0 * (float(p.y) + 0.5) / float(params.dims.y);
    vec3 u = normalize(params.forward.xyz + ndc_x * params.right.xyz + ndc_y * params.up.xyz);
    float L = min(imageLoad(distance_image, ivec2(p)).r, params.far.x);
    L = max(L, 0.0);

    float total = 0.0;
    vec3 emitted = vec3(0.0);
    for (uint i = 0u; i < params.dims.z; ++i) {
        WaveStyle style = styles[i];
        float H = style.method.x == 0u
            ? wave_line_integral(waves[i], u, L)
            : wave_raymarch(waves[i], u, L, style.method.y, style.method.z != 0u ? pixel_jitter(p, i) : 0.5);
        total += H;
        emitted += style.emission.rgb * H;
    }
    imageStore(energy, ivec2(p), vec4(total, 0.0, 0.0, 0.0));
    vec4 c = imageLoad(hdr, ivec2(p));
    imageStore(hdr, ivec2(p), vec4(min(c.rgb + emitted, vec3(HALF_MAX)), c.a));
}
