#version 460
// energy_wave_classify: one invocation per T×T-pixel tile decides whether the tile's pixels may
// be interpolated from its corners (every wave's error bound, common/energy_wave_tiles.glsl, at
// most τ/(1 + τ) of its smallest corner H) or must be evaluated exactly, and appends the tile to
// that list (the smooth ones are only marked: energy_wave_interp.comp runs over the whole frame);
// a list's dispatch grows by a row every WAVE_TILES_PER_ROW workgroups' tiles.
#include "common/camera.glsl"
#include "common/energy_wave.glsl"
#include "common/energy_wave_tiles.glsl"
#include "common/frame.glsl"

layout(local_size_x = 64) in;

struct WaveStyle {
    vec4 emission;
    uvec4 method;
    vec4 adaptive;  // x: the tolerance τ
};

layout(set = 0, binding = 0, r32f) uniform readonly image2D distance_image;
layout(set = 0, binding = 3, std430) readonly buffer Waves { Wave waves[]; };
layout(set = 0, binding = 4, std430) readonly buffer Styles { WaveStyle styles[]; };
layout(set = 0, binding = 5, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 6, std430) readonly buffer Corners { float corners[]; };
// Per tile, 1 when it is interpolated; the exact tiles' list from tiles_x·tiles_y.
layout(set = 0, binding = 7, std430) writeonly buffer Lists { uint tiles[]; };
// The interpolated tiles' count (word 3), the exact tiles' indirect dispatch (x =
// WAVE_TILES_PER_ROW, y = rows, z = 1) and count (word 7).
layout(set = 0, binding = 8, std430) buffer State { uint state[8]; };

layout(push_constant) uniform EnergyWaveParams {
    uvec4 counts;  // x: waves, y: tiles_x, z: tiles_y, w: the tile size T
    uvec4 flags;   // x: 1 when something reads `energy` after the pass (else it is not written)
} params;

float corner_at(uvec2 c, uint k) {
    return corners[(c.y * (params.counts.y + 1u) + c.x) * (params.counts.x + 1u) + k];
}

void main() {
    uint tile = gl_GlobalInvocationID.x;
    uint tiles_total = params.counts.y * params.counts.z;
    uint size_t = params.counts.w;
    if (tile >= tiles_total) {
        return;
    }
    uvec2 t = wave_tile_xy(tile, params.counts.y);
    uvec2 size = frame.counts.yz;
    float h = float(size_t);
    // The corners' L: (0, 0), (h, 0), (0, h), (h, h).
    vec4 cl = vec4(corner_at(t, 0u), corner_at(t + uvec2(1u, 0u), 0u), corner_at(t + uvec2(0u, 1u), 0u),
                   corner_at(t + uvec2(1u), 0u));
    // The largest |L − L̃| over the tile's pixels inside the image.
    float deviation = 0.0;
    uvec2 first = t * size_t;
    for (uint j = 0u; j < size_t; ++j) {
        for (uint i = 0u; i < size_t; ++i) {
            uvec2 p = first + uvec2(i, j);
            float fx = float(i) / h;
            float fy = float(j) / h;
            float top = cl.x + (cl.y - cl.x) * fx;
            float bottom = cl.z + (cl.w - cl.z) * fx;
            float lt = top + (bottom - top) * fy;
            float L = max(min(imageLoad(distance_image, ivec2(min(p, size - 1u))).r, frame.ray_forward.w), 0.0);
            bool inside = p.x < size.x && p.y < size.y;
            deviation = inside ? max(deviation, abs(L - lt)) : deviation;
        }
    }
    // The cone of the tile's rays: v = v0 + x·vx + y·vy.
    vec3 vx = frame.ray_right.xyz * (2.0 / float(size.x));
    vec3 vy = frame.ray_up.xyz * (-2.0 / float(size.y));
    vec3 vc = (frame.ray_forward.xyz + (2.0 * (float(first.x) + 0.5) / float(size.x) - 1.0 + frame.ray_right.w) * frame.ray_right.xyz
               + (1.0 - 2.0 * (float(first.y) + 0.5) / float(size.y) + frame.ray_up.w) * frame.ray_up.xyz)
              + (vx + vy) * (h * 0.5);
    vec3 uc = normalize(vc);
    float alpha = 0.0;
    for (uint k = 0u; k < 4u; ++k) {
        vec2 o = vec2(float(k & 1u), float(k >> 1u)) * h - h * 0.5;
        float chord = min(length(normalize(vc + o.x * vx + o.y * vy) - uc), 1.9);
        // 2·asin(chord/2) ≤ chord/√(1 − chord²/4).
        alpha = max(alpha, chord / sqrt(1.0 - 0.25 * chord * chord));
    }
    alpha = alpha * WAVE_ANGLE_GROW + WAVE_ANGLE_ABS;
    float vmin = length(vc) - 0.5 * h * (length(vx) + length(vy));
    vec2 theta1 = vec2(length(vx), length(vy)) / vmin * WAVE_ANGLE_GROW;
    vec2 theta2 = 1.1547005 * WAVE_ANGLE_GROW * theta1 * theta1;
    float l = min(max(max(cl.x, cl.y), max(cl.z, cl.w)), WAVE_MAX_LENGTH);
    vec2 slope = vec2(max(abs(cl.y - cl.x), abs(cl.w - cl.z)), max(abs(cl.z - cl.x), abs(cl.w - cl.y))) / h
                 * WAVE_ANGLE_GROW;
    bool smooth_tile = vmin > 0.0;
    for (uint i = 0u; i < params.counts.x; ++i) {
        float h_min = min(min(corner_at(t, 1u + i), corner_at(t + uvec2(1u, 0u), 1u + i)),
                          min(corner_at(t + uvec2(0u, 1u), 1u + i), corner_at(t + uvec2(1u), 1u + i)));
        float tol = styles[i].adaptive.x;
        float bound = wave_tile_bound(waves[i], h, uc, alpha, theta1, theta2, l, slope, deviation);
        smooth_tile = smooth_tile && tol > 0.0 && bound <= tol / (1.0 + tol) * h_min;
    }
    uint list = smooth_tile ? 0u : 4u;
    uint slot = atomicAdd(state[list + 3u], 1u);
    // (8/T)² tiles per workgroup of the exact tiles' dispatch: T is 4 or 8.
    uint per_row = size_t == 8u ? WAVE_TILES_PER_ROW : 4u * WAVE_TILES_PER_ROW;
    if (!smooth_tile && (slot & (per_row - 1u)) == 0u) {
        atomicAdd(state[5], 1u);
    }
    tiles[tile] = smooth_tile ? 1u : 0u;
    if (!smooth_tile) {
        tiles[tiles_total + slot] = tile;
    }
}
