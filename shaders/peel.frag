#version 460
// peel: every fragment is one crossing of a texel centre's light ray with a peel instance's
// surface; appended to the texel's list (crates/hadou/src/passes/peel.rs). No depth test: all are kept, up to
// PEEL_K per texel; the count goes on, so a reader knows the list overflowed.
#include "common/peel.glsl"

layout(set = 0, binding = 1, r32ui) uniform uimage2D peel_counts;
layout(set = 0, binding = 2, rg32ui) uniform writeonly uimage2D peel_lists;
// Keep in sync with STAT_* in crates/hadou/src/passes/peel.rs.
layout(set = 0, binding = 3, std430) buffer Stats { uint stats[]; };
#define STAT_OVERFLOWED 0
#define STAT_TEXELS 1
#define STAT_MAX 2

layout(location = 0) in float v_z;
layout(location = 1) flat in uint v_instance;
layout(location = 2) flat in uint v_mirrored;

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    uint k = imageAtomicAdd(peel_counts, texel, 1u);
    // Faces toward the light wind clockwise in the light's framebuffer (its frame is left-handed,
    // see light_id.rs), i.e. not front-facing for Vulkan's counter-clockwise front face.
    bool entering = gl_FrontFacing == (v_mirrored != 0u);
    if (k < PEEL_K) {
        uint id = (v_instance + 1u) | (entering ? PEEL_ENTERING : 0u);
        imageStore(peel_lists, peel_entry(texel, k), uvec4(floatBitsToUint(v_z), id, 0u, 0u));
    } else if (k == PEEL_K) {
        atomicAdd(stats[STAT_OVERFLOWED], 1u);  // once per overflowing texel
    }
    // Per texel, the last fragment's count is the list's length: the frame's longest list. Only
    // lists more than half full report it, so the usual 2 to 4 crossings of a texel cost no atomic
    // on one global word per fragment.
    if (k >= PEEL_K / 2u) atomicMax(stats[STAT_MAX], k + 1u);
    if (k == 0u) atomicAdd(stats[STAT_TEXELS], 1u);  // texels with any crossing
}
