#version 460
// energy_wave_interp: the tiles energy_wave_classify listed as smooth, (8/T)² per 8×8 workgroup:
// every wave's H interpolated bilinearly from the tile's corners (within the wave's tolerance,
// crates/hadou/src/effects/energy_wave/tolerance.rs), then written as energy_wave.comp writes it.
#include "common/energy_wave_tiles.glsl"
#include "common/frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

struct WaveStyle {
    vec4 emission;  // rgb: colour × intensity; w: cutoff
    uvec4 method;
    vec4 adaptive;
};

layout(set = 0, binding = 1, rgba16f) uniform image2D hdr;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D energy;
layout(set = 0, binding = 4, std430) readonly buffer Styles { WaveStyle styles[]; };
layout(set = 0, binding = 5, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 6, std430) readonly buffer Corners { float corners[]; };
layout(set = 0, binding = 7, std430) readonly buffer Lists { uint tiles[]; };
layout(set = 0, binding = 8, std430) readonly buffer State { uint state[8]; };

layout(push_constant) uniform EnergyWaveParams {
    uvec4 counts;  // x: waves, y: tiles_x, z: tiles_y, w: the tile size T
} params;

const float HALF_MAX = 65504.0;

float corner_at(uvec2 c, uint k) {
    return corners[(c.y * (params.counts.y + 1u) + c.x) * (params.counts.x + 1u) + k];
}

void main() {
    uint size_t = params.counts.w;
    uint slot = wave_list_slot(size_t);
    bool listed = slot < state[3];
    uint tile = tiles[min(slot, max(state[3], 1u) - 1u)];
    uvec2 t = uvec2(tile % params.counts.y, tile / params.counts.y);
    uvec2 offset = wave_tile_offset(size_t);
    uvec2 p = t * size_t + offset;
    uvec2 size = frame.counts.yz;
    bool inside = listed && p.x < size.x && p.y < size.y;
    float fx = float(offset.x) / float(size_t);
    float fy = float(offset.y) / float(size_t);
    float total = 0.0;
    vec3 emitted = vec3(0.0);
    for (uint i = 0u; i < params.counts.x; ++i) {
        float c0 = corner_at(t, 1u + i);
        float c1 = corner_at(t + uvec2(1u, 0u), 1u + i);
        float c2 = corner_at(t + uvec2(0u, 1u), 1u + i);
        float c3 = corner_at(t + uvec2(1u), 1u + i);
        float top = c0 + (c1 - c0) * fx;
        float bottom = c2 + (c3 - c2) * fx;
        float H = top + (bottom - top) * fy;
        WaveStyle style = styles[i];
        total += H;
        emitted += style.emission.rgb * max(H - style.emission.w, 0.0);
    }
    if (inside) {
        ivec2 pix = ivec2(p);
        imageStore(energy, pix, vec4(total, 0.0, 0.0, 0.0));
        vec4 c = imageLoad(hdr, pix);
        imageStore(hdr, pix, vec4(min(c.rgb + emitted, vec3(HALF_MAX)), c.a));
    }
}
