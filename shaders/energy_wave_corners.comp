#version 460
// energy_wave_corners: the exact H of every wave at the corners of the T×T-pixel tiles (pixel
// centres (T·i, T·j); a corner past the image's edge uses the ray of that pixel and the depth of
// the nearest pixel inside), and the view distance there. The first step of the energy wave with
// a tolerance (crates/hadou/src/passes/energy_wave.rs); the corners are the same computation as
// the exact pass's pixel there, so a corner pixel interpolates to exactly that value.
#include "common/camera.glsl"
#include "common/energy_wave.glsl"
#include "common/energy_wave_tiles.glsl"
#include "common/frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, r32f) uniform readonly image2D distance_image;
layout(set = 0, binding = 3, std430) readonly buffer Waves { Wave waves[]; };
layout(set = 0, binding = 5, std140) uniform FrameBlock { FrameUniforms frame; };
// Per corner (row-major over (tiles_x + 1) × (tiles_y + 1)): L, then H of each wave.
layout(set = 0, binding = 6, std430) writeonly buffer Corners { float corners[]; };

layout(push_constant) uniform EnergyWaveParams {
    uvec4 counts;  // x: waves, y: tiles_x, z: tiles_y, w: the tile size T
    uvec4 flags;   // x: 1 when something reads `energy` after the pass (else it is not written)
} params;

void main() {
    uvec2 c = gl_GlobalInvocationID.xy;
    uvec2 grid = params.counts.yz + 1u;
    if (c.x >= grid.x || c.y >= grid.y) {
        return;
    }
    uvec2 size = frame.counts.yz;
    uvec2 p = c * params.counts.w;
    vec3 u = camera_pixel_ray(p, size, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
    float L = min(imageLoad(distance_image, ivec2(min(p, size - 1u))).r, frame.ray_forward.w);
    L = max(L, 0.0);
    uint n = params.counts.x;
    uint base = (c.y * grid.x + c.x) * (n + 1u);
    corners[base] = L;
    for (uint i = 0u; i < n; ++i) {
        corners[base + 1u + i] = wave_line_integral(waves[i], u, L);
    }
}
