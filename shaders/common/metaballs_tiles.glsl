// The metaballs pass's tables as its dispatches read them (shaders/metaballs.comp, the casts, and
// common/metaballs_motion.glsl, their motion vectors): the group headers, the balls and the tile
// lists, and the pixel each invocation of a tile's workgroup takes. Include it after the first
// `#include "common/metaballs.glsl"` (the structs). Layouts: crates/hadou/src/passes/metaballs.rs.
#ifndef HADOU_METABALLS_TILES_GLSL
#define HADOU_METABALLS_TILES_GLSL

// The group headers (MetaGroup, 14 texels each), the balls (MetaBall, 2 texels each), the tile
// lists and their entries, as texel buffers of uints (floats by uintBitsToFloat): on lavapipe a
// texel fetch is a branch-free gather, a storage-buffer load a loop over the lanes
// (crates/hadou-gpu/src/texel_buffer.rs).
layout(set = 0, binding = 6) uniform usamplerBuffer group_texels;
layout(set = 0, binding = 7) uniform usamplerBuffer ball_texels;
// Built on the device by shaders/metaballs_bin.comp (layouts: `TileLists` in
// crates/hadou/src/passes/metaballs.rs, its CPU twin): the headers of the tiles holding any ball
// (x: index of the tile's first run in `run_texels`, y: run count, z, w: the tile's column and
// row), then per tile its runs (x: group, y: first entry in `entries`, z: entry count, w: RUN_*
// flags), one per group present in the tile; each run's entries sorted by ‖c − o‖ − R (object
// space, o the camera).
layout(set = 0, binding = 8) uniform usamplerBuffer tile_texels;
layout(set = 0, binding = 9) uniform usamplerBuffer entry_texels;
layout(set = 0, binding = 13) uniform usamplerBuffer run_texels;
// Keep in sync with BIN_ACTIVE in crates/hadou/src/passes/metaballs_bin.rs: the tiles with headers.
layout(set = 0, binding = 22, std430) readonly buffer BinState { uint bin_state[]; };
#define BIN_ACTIVE 6

MetaBall load_ball(uint id) {
    MetaBall b;
    b.centre_radius = uintBitsToFloat(texelFetch(ball_texels, int(2u * id)));
    b.coeffs = uintBitsToFloat(texelFetch(ball_texels, int(2u * id + 1u)));
    return b;
}

MetaGroup load_group(uint i) {
    int base = int(14u * i);
    MetaGroup g;
    for (int k = 0; k < 4; ++k) {
        g.to_object[k] = uintBitsToFloat(texelFetch(group_texels, base + k));
        g.to_world[k] = uintBitsToFloat(texelFetch(group_texels, base + 4 + k));
        g.normal_matrix[k] = uintBitsToFloat(texelFetch(group_texels, base + 8 + k));
    }
    g.params = uintBitsToFloat(texelFetch(group_texels, base + 12));
    g.info = texelFetch(group_texels, base + 13);
    return g;
}

uvec4 tiles(uint i) { return texelFetch(tile_texels, int(i)); }
uvec4 run_at(uint i) { return texelFetch(run_texels, int(i)); }
uint entries(uint k) { return texelFetch(entry_texels, int(k)).x; }

// The pixel of `lane` (an invocation of an 8×8 workgroup) in active tile `header`: each 8
// consecutive invocations (lavapipe's SIMD group, the subgroup) take a 4×2 block of pixels (a
// compact block's rays are closer together than a row's, so its cone culls more balls and fewer
// chords are shared: measured 0.92–0.93× the pass time of 8×1 rows).
uvec2 tile_pixel(uvec4 header, uint lane) {
    uvec2 block = uvec2((lane & 3u) | ((lane >> 1u) & 4u), ((lane >> 2u) & 1u) | ((lane >> 3u) & 6u));
    return header.zw * 8u + block;
}

// loops_cut: the casts' streamed walks take 8 balls per iteration and run in their own dispatch to
// stay far below lavapipe's loop budget, and tell when they did not.
#include "common/loop_budget.glsl"

#endif
