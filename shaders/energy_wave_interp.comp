#version 460
// energy_wave_interp: every pixel of the tiles energy_wave_classify marked smooth: each wave's H
// interpolated bilinearly from the tile's corners (within the wave's tolerance,
// crates/hadou/src/effects/energy_wave/tolerance.rs), then written as energy_wave.comp writes it.
// Dispatched over the whole frame in 8×8 workgroups (WAVE_TILE: 4 or 8, a variant per size; with
// 8 the tile's flag and corners are the same for the whole workgroup, which lavapipe then loads
// once instead of gathering them lane by lane); the pixels of exact tiles skip their stores.
// (Over a list of the smooth tiles the tile path was slower: docs/PERFORMANCE.md.)
#ifndef WAVE_TILE
#define WAVE_TILE 8
#endif
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
#ifdef REACTIVE
// A temporal upscaler's reactive mask: the share of the pixel's luminance the glow added.
layout(set = 0, binding = 9, r32f) uniform writeonly image2D reactive;
#endif
layout(set = 0, binding = 4, std430) readonly buffer Styles { WaveStyle styles[]; };
layout(set = 0, binding = 5, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 6, std430) readonly buffer Corners { float corners[]; };
// Per tile, 1 when it is interpolated (then the exact tiles' list, not read here).
layout(set = 0, binding = 7, std430) readonly buffer Lists { uint tiles[]; };

layout(push_constant) uniform EnergyWaveParams {
    uvec4 counts;  // x: waves, y: tiles_x, z: tiles_y, w: the tile size T
    uvec4 flags;   // x: 1 when something reads `energy` after the pass (else it is not written)
} params;

const float HALF_MAX = 65504.0;

void main() {
    uvec2 size = frame.counts.yz;
    // Invocations past the image's edge (the dispatch's last workgroups) stay in the grid.
    uvec2 t = min(wave_frame_tile(), params.counts.yz - 1u);
    uvec2 p = gl_GlobalInvocationID.xy;
    bool listed = tiles[t.y * params.counts.y + t.x] != 0u;
    bool inside = listed && p.x < size.x && p.y < size.y;
    uvec2 offset = p % uint(WAVE_TILE);
    float fx = float(offset.x) * (1.0 / float(WAVE_TILE));
    float fy = float(offset.y) * (1.0 / float(WAVE_TILE));
    // Laid out as energy_wave.comp is for lavapipe: the first wave's values read before any loop
    // or branch, the loop a do-while (here it measured no faster than a plain loop: the pass is
    // bound by its image stores).
    uint n = params.counts.x;
    uvec4 at = (uvec4(t.y, t.y, t.y + 1u, t.y + 1u) * (params.counts.y + 1u) + uvec4(t.x, t.x + 1u, t.x, t.x + 1u))
               * (n + 1u) + 1u;
    vec4 c = vec4(corners[at.x], corners[at.y], corners[at.z], corners[at.w]);
    WaveStyle style0 = styles[0];
    float total = 0.0;
    vec3 emitted = vec3(0.0);
    uint i = 0u;
    do {
        WaveStyle style = style0;
        if (i > 0u) {
            c = vec4(corners[at.x + i], corners[at.y + i], corners[at.z + i], corners[at.w + i]);
            style = styles[i];
        }
        float top = c.x + (c.y - c.x) * fx;
        float bottom = c.z + (c.w - c.z) * fx;
        float H = top + (bottom - top) * fy;
        total += H;
        emitted += style.emission.rgb * max(H - style.emission.w, 0.0);
        ++i;
    } while (i < n);
    if (inside) {
        ivec2 pix = ivec2(p);
        // Uniform across the dispatch: a frame whose `energy` nobody reads skips the store.
        if (params.flags.x != 0u) {
            imageStore(energy, pix, vec4(total, 0.0, 0.0, 0.0));
        }
        vec4 c = imageLoad(hdr, pix);
        vec3 lit = min(c.rgb + emitted, vec3(HALF_MAX));
        imageStore(hdr, pix, vec4(lit, c.a));
#ifdef REACTIVE
        const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);
        float all_light = dot(lit, LUMA);
        float share = all_light > 0.0 ? clamp(dot(lit - c.rgb, LUMA) / all_light, 0.0, 1.0) : 0.0;
        imageStore(reactive, pix, vec4(share, 0.0, 0.0, 0.0));
#endif
    }
}
