#version 460
// metaballs_bin: the metaballs pass's tile lists, built on the device each frame (the host's twin
// and the layouts: crates/hadou/src/passes/metaballs_bin.rs). One stage per pipeline, picked by
// MB_BIN_STAGE, each dispatch followed by a barrier:
//   0 bounds: per ball its tile rectangle (sphere_tiles in f32, padded wider) and its sort key
//     (group, entry key, index), or a sentinel when no pixel ray can reach it; per group the
//     visible count and whether RUN_LONE_BOUND is lost (a q < 0, a support near the camera);
//   1, 5 sort: bitonic, in blocks of 512 in shared memory (1) and across blocks (5, one step a
//     dispatch). Every key is distinct, so the order is the same on any device: group, then entry
//     key, then index, as the CPU twin sorts them;
//   3 scan: one workgroup sums the bounds' difference grid into the tiles' counts (2D prefix)
//     and turns them into offsets (a tile's runs sit at its entries' offset:
//     a tile has no more runs than entries), the header index of each tile holding any ball
//     (row-major) and the pass's dispatch. Past the entry capacity (the host grows it from the
//     totals it reads back) it writes instead lists every tile shares, one run per group over the
//     group's visible balls in sorted order (exact, only slower), and fill writes nothing;
//   4 fill: one 8×8 workgroup per 8×8 block of tiles walks each group's sorted balls in chunks
//     of 64; each ball marks its place in the chunk in the bit masks of the tiles it meets, and
//     each tile appends its marked balls in bit order (the sorted order): entries, runs, header.
// So within a run the order is always the entry key's (ties by index): each pixel sums its balls
// in the same order as the CPU-built lists did, and the image is the same bit for bit.
#include "common/frame.glsl"

#ifndef MB_BIN_STAGE
#define MB_BIN_STAGE 0
#endif
#if MB_BIN_STAGE == 4
layout(local_size_x = 64) in;
#else
layout(local_size_x = 256) in;
#endif

layout(set = 0, binding = 4, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 6) uniform usamplerBuffer group_texels;
layout(set = 0, binding = 7) uniform usamplerBuffer ball_texels;
layout(set = 0, binding = 10, std430) buffer Stats { uint stats[]; };
// Keep in sync with `BinGroup` in crates/hadou/src/passes/metaballs_bin.rs.
struct BinGroup {
    vec4 origin;  // xyz: the camera in the group's object space; w: the world radius scale
    uvec4 info;   // x: first ball, y: ball count, z: RUN_* flags the host knows (RUN_TRACE)
};
layout(set = 0, binding = 14, std430) readonly buffer BinGroups { BinGroup bin_groups[]; };
// Sort keys, (hi, lo) one 64-bit number: the group (15 bits), the entry key's ordered bits (32),
// the ball's index (17); (NONE, NONE) for a ball no ray reaches and for the padding.
layout(set = 0, binding = 15, std430) buffer Elements { uvec2 elements[]; };
#define GROUP_SHIFT 17u
#define INDEX_MASK 0x1ffffu
layout(set = 0, binding = 16, std430) buffer Rects { uvec2 rects[]; };
layout(set = 0, binding = 17, std430) buffer Counts { uvec2 counts[]; };
layout(set = 0, binding = 18, std430) buffer Offsets { uvec4 offsets[]; };
layout(set = 0, binding = 19, std430) buffer Headers { uvec4 headers[]; };
layout(set = 0, binding = 20, std430) buffer Runs { uvec4 runs[]; };
layout(set = 0, binding = 21, std430) buffer Entries { uint entries[]; };
// Keep in sync with BIN_* in crates/hadou/src/passes/metaballs_bin.rs: the main dispatch's
// arguments (x, y, z), then the totals, then per group its lone flag and visible count.
layout(set = 0, binding = 22, std430) buffer BinState { uint state[]; };
// The tiles' counts as a 2D difference grid, (tiles per row + 1) × (tile rows + 1), zeroed by the
// host: each visible ball adds ±1 at its rectangle's four corners (bounds), the scan's 2D prefix
// sum gives every tile its count.
layout(set = 0, binding = 23, std430) buffer Diff { uint diff[]; };
#define BIN_OVERFLOW 3
#define BIN_ENTRIES 4
#define BIN_RUNS 5
#define BIN_ACTIVE 6
#define BIN_VISIBLE 7
#define BIN_CUT 8
#define BIN_GROUPS 12

// Keep in sync with BinParams in crates/hadou/src/passes/metaballs_bin.rs.
layout(push_constant) uniform BinParams {
    uvec4 sizes;  // x: balls, y: groups, z: sort length (a power of two ≥ balls), w: tiles
    uvec4 caps;   // x: entry capacity, y: run capacity, z: tiles per row, w: tile rows
    vec4 camera;  // x: near distance, y: near reach (RUN_LONE_BOUND), z, w: 0
    uvec4 sort;   // the sort's step: x: merge width k (0: the blocks' whole sort), y: j
} params;

#define STAT_DROPPED 0
#define RUN_LONE_BOUND 1u
#define TILE 8u
#define TILES_PER_ROW 8192u
#define NONE 0xffffffffu

uvec4 group_info(uint g) { return texelFetch(group_texels, int(14u * g + 13u)); }

uint group_of(uint ball) {
    // The last group whose first ball is ≤ ball (groups are in ball order).
    uint lo = 0u;
    uint hi = params.sizes.y;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (group_info(mid).y <= ball) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

#if MB_BIN_STAGE == 0
// The tiles (x0, y0, x1, y1) a sphere (its centre relative to the camera) may cover, or false:
// Camera::sphere_tiles's argument (crates/hadou/src/passes/metaballs.rs) in f32, padded so that
// it is never narrower than the f64 rectangle (a wider one only lists balls no ray of the tile
// meets: they fill no slot).
bool sphere_tiles(vec3 centre, float radius, out uvec4 rect) {
    uvec2 size = frame.counts.yz;
    uvec2 tiles = (size + TILE - 1u) / TILE;
    rect = uvec4(0u, 0u, tiles - 1u);
    float near = params.camera.x;
    float far = frame.ray_forward.w;
    float sx = length(frame.ray_right.xyz);
    float sy = length(frame.ray_up.xyz);
    vec3 right = frame.ray_right.xyz / sx;
    vec3 up = frame.ray_up.xyz / sy;
    vec3 forward = frame.ray_forward.xyz;
    vec3 v = centre;  // the groups' world is relative to the camera (MetaGroup)
    float dist = length(v);
    float r = radius * (1.0 + 1e-4) + 1e-5 * (dist + radius);
    float z = dot(v, forward);
    if (!(z + r >= near * (1.0 - 1e-4)) || z - r > far * (1.0 + 1e-4)) return false;
    if (z - r <= near * (1.0 + 1e-3)) return true;  // reaches the near plane: the whole screen
    float x = dot(v, right);
    float y = dot(v, up);
    float den = z * z - r * r;
    // f32 error of the slopes (cancellation in x·z − r·disc), added to both ends.
    float disc_x = sqrt(max(x * x + z * z - r * r, 0.0));
    float disc_y = sqrt(max(y * y + z * z - r * r, 0.0));
    float ex = 4e-6 * (abs(x) * z + r * disc_x + x * x + z * z) / den;
    float ey = 4e-6 * (abs(y) * z + r * disc_y + y * y + z * z) / den;
    vec2 k0 = vec2((x * z - r * disc_x) / den - ex, (y * z - r * disc_y) / den - ey);
    vec2 k1 = vec2((x * z + r * disc_x) / den + ex, (y * z + r * disc_y) / den + ey);
    vec2 scale = vec2(sx, sy);
    vec2 shift = vec2(frame.ray_right.w, frame.ray_up.w);
    vec2 lo = k0 / scale - shift;
    vec2 hi = k1 / scale - shift;
    vec2 fsize = vec2(size);
    float x0 = (lo.x + 1.0) * 0.5 * fsize.x - 2.5;
    float x1 = (hi.x + 1.0) * 0.5 * fsize.x + 1.5;
    float y0 = (1.0 - hi.y) * 0.5 * fsize.y - 2.5;
    float y1 = (1.0 - lo.y) * 0.5 * fsize.y + 1.5;
    if (!(x1 >= 0.0 && y1 >= 0.0 && x0 < fsize.x && y0 < fsize.y)) return false;  // NaN too
    vec2 a = clamp(floor(vec2(x0, y0)), vec2(0.0), fsize - 1.0);
    vec2 b = clamp(ceil(vec2(x1, y1)), vec2(0.0), fsize - 1.0);
    rect = uvec4(min(uvec2(a) / TILE, tiles - 1u), min(uvec2(b) / TILE, tiles - 1u));
    return true;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= params.sizes.z) return;
    if (i >= params.sizes.x) {
        elements[i] = uvec2(NONE);  // padding: sorts last
        return;
    }
    uint g = group_of(i);
    BinGroup bg = bin_groups[g];
    vec4 ball = uintBitsToFloat(texelFetch(ball_texels, int(2u * i)));
    float q = uintBitsToFloat(texelFetch(ball_texels, int(2u * i + 1u)).x);
    int base = int(14u * g);
    mat4 to_world;
    for (int k = 0; k < 4; ++k) to_world[k] = uintBitsToFloat(texelFetch(group_texels, base + 4 + k));
    vec3 centre = (to_world * vec4(ball.xyz, 1.0)).xyz;  // relative to the camera (MetaGroup)
    float radius = ball.w * bg.origin.w;
    uvec4 rect;
    bool visible = sphere_tiles(centre, radius, rect);
    // RUN_LONE_BOUND (GroupBins::new): every q ≥ 0 and every support clear of the near plane.
    if (q < 0.0 || !(length(centre) - radius > params.camera.y)) {
        atomicOr(state[BIN_GROUPS + 2u * g], 1u);
    }
    if (visible) {
        atomicAdd(state[BIN_VISIBLE], 1u);
        atomicAdd(state[BIN_GROUPS + 2u * g + 1u], 1u);
        // The entry key ‖c − o‖ − R (object space) as ordered bits: unsigned order = float order.
        // `precise`: no fused multiply-add, so the host's twin (bin_key) computes the same bits.
        precise vec3 w = ball.xyz - bg.origin.xyz;
        precise float key = sqrt(w.x * w.x + w.y * w.y + w.z * w.z) - ball.w;
        uint bits = floatBitsToUint(key);
        bits = (bits & 0x80000000u) != 0u ? ~bits : (bits | 0x80000000u);
        elements[i] = uvec2((g << GROUP_SHIFT) | (bits >> 15u), ((bits & 0x7fffu) << GROUP_SHIFT) | i);
        rects[i] = uvec2(rect.x | (rect.y << 16u), rect.z | (rect.w << 16u));
        uint row = params.caps.z + 1u;
        atomicAdd(diff[rect.y * row + rect.x], 1u);
        atomicAdd(diff[rect.y * row + rect.z + 1u], 0xffffffffu);  // −1, wrapping
        atomicAdd(diff[(rect.w + 1u) * row + rect.x], 0xffffffffu);
        atomicAdd(diff[(rect.w + 1u) * row + rect.z + 1u], 1u);
    } else {
        elements[i] = uvec2(NONE);
    }
}

#elif MB_BIN_STAGE == 1 || MB_BIN_STAGE == 5
// Bitonic sort of the sort length (a power of two), keys (hi, lo) as one 64-bit unsigned number.
// Stage 1 (local): one workgroup per block of 512 elements, in shared memory: the whole sort of
// the block (sort.x = 0) or, for a merge of width sort.x ≥ 1024, its steps j = 256 … 1. Stage 5
// (global): one step (sort.x, sort.y) with j ≥ 512, one compare-exchange per invocation.
bool after(uvec2 a, uvec2 b) { return a.x != b.x ? a.x > b.x : a.y > b.y; }

#if MB_BIN_STAGE == 1
shared uvec2 block_keys[512];

void step(uint base, uint k, uint j, uint p) {
    uint l = 2u * j * (p / j) + p % j;
    uint r = l + j;
    bool up = ((base + l) & k) == 0u;
    uvec2 a = block_keys[l];
    uvec2 b = block_keys[r];
    if (after(a, b) == up) {
        block_keys[l] = b;
        block_keys[r] = a;
    }
}

void main() {
    uint n = min(params.sizes.z, 512u);
    uint base = gl_WorkGroupID.x * 512u;
    uint p = gl_LocalInvocationID.x;
    bool mine = p < n / 2u;
    if (mine) {
        block_keys[p] = elements[base + p];
        block_keys[p + n / 2u] = elements[base + p + n / 2u];
    }
    barrier();
    if (params.sort.x == 0u) {
        for (uint k = 2u; k <= n; k <<= 1u) {
            for (uint j = k >> 1u; j > 0u; j >>= 1u) {
                if (mine) step(base, k, j, p);
                barrier();
            }
        }
    } else {
        for (uint j = 256u; j > 0u; j >>= 1u) {
            if (mine) step(base, params.sort.x, j, p);
            barrier();
        }
    }
    if (mine) {
        elements[base + p] = block_keys[p];
        elements[base + p + n / 2u] = block_keys[p + n / 2u];
    }
}
#else
void main() {
    uint p = gl_GlobalInvocationID.x;
    if (p >= params.sizes.z / 2u) return;
    uint k = params.sort.x;
    uint j = params.sort.y;
    uint l = 2u * j * (p / j) + p % j;
    uint r = l + j;
    bool up = (l & k) == 0u;
    uvec2 a = elements[l];
    uvec2 b = elements[r];
    if (after(a, b) == up) {
        elements[l] = b;
        elements[r] = a;
    }
}
#endif

#elif MB_BIN_STAGE == 4
// Per chunk of 64 sorted balls of one group: each marks, in the bit masks of the block's tiles its
// rectangle meets, its place in the chunk (atomicOr: any order gives the same masks); then each
// tile appends its marked balls in bit order, which is the sorted order.
shared uint masks[128];
shared uint chunk_index[64];  // the chunk's ball indices

#include "common/loop_budget.glsl"

void main() {
    if (state[BIN_OVERFLOW] != 0u) return;
    uvec2 tiles = uvec2(params.caps.z, params.caps.w);
    uvec2 block = gl_WorkGroupID.xy * 8u;
    uint lane = gl_LocalInvocationID.x;
    uvec2 tile = block + uvec2(lane % 8u, lane / 8u);
    bool mine = tile.x < tiles.x && tile.y < tiles.y;
    uint t = tile.y * tiles.x + tile.x;
    uvec2 last = min(block + 7u, tiles - 1u);
    uint count = 0u;
    uint run_count = 0u;
    uint group = NONE;
    uint run_start = 0u;
    uvec4 off = uvec4(0u);
    uint limit = 0u;
    if (mine) {
        off = offsets[t];
        limit = counts[t].x;
    }
    masks[2u * lane] = 0u;
    masks[2u * lane + 1u] = 0u;
    barrier();
    uint chunks = 0u;
    uint start = 0u;  // the group's first sort key
    // Group by group (their keys are contiguous), so a chunk holds one group and a tile's runs
    // change only between chunks.
    for (uint g = 0u; g < params.sizes.y; ++g) {
        uint visible = state[BIN_GROUPS + 2u * g + 1u];
        for (uint base = 0u; base < visible; base += 64u) {
            ++chunks;
            uint k = base + lane;
            if (k < visible) {
                uint index = elements[start + k].y & INDEX_MASK;
                uvec2 packed = rects[index];
                chunk_index[lane] = index;
                // The rectangle within the block.
                ivec2 lo = ivec2(max(uvec2(packed.x & 0xffffu, packed.x >> 16u), block)) - ivec2(block);
                ivec2 hi = ivec2(min(uvec2(packed.y & 0xffffu, packed.y >> 16u), last)) - ivec2(block);
                uint bit = 1u << (lane & 31u);
                uint word = lane >> 5u;
                // Rows of at most 8 tiles, written out (loops count against lavapipe's budget).
#define MB_MARK(u) if (lo.x + u <= hi.x) atomicOr(masks[2u * uint(y * 8 + lo.x + u) + word], bit)
                for (int y = lo.y; y <= hi.y; ++y) {
                    MB_MARK(0); MB_MARK(1); MB_MARK(2); MB_MARK(3);
                    MB_MARK(4); MB_MARK(5); MB_MARK(6); MB_MARK(7);
                }
            }
            barrier();
            uint m0 = masks[2u * lane];
            uint m1 = masks[2u * lane + 1u];
            masks[2u * lane] = 0u;
            masks[2u * lane + 1u] = 0u;
            if (mine && (m0 | m1) != 0u) {
                if (g != group) {
                    if (group != NONE) {
                        uint flags = bin_groups[group].info.z;
                        if (state[BIN_GROUPS + 2u * group] == 0u) flags |= RUN_LONE_BOUND;
                        runs[off.x + run_count - 1u] = uvec4(group, off.x + run_start, count - run_start, flags);
                    }
                    group = g;
                    run_start = count;
                    ++run_count;
                }
                // The marked balls in bit order, 8 per iteration (lavapipe's loop budget).
#define MB_NEXT(w, bits)                                                      \
    if (bits != 0u) {                                                         \
        uint j = uint(findLSB(bits));                                         \
        bits &= bits - 1u;                                                    \
        if (count < limit) entries[off.x + count] = chunk_index[32u * w + j]; \
        ++count;                                                              \
    }
                while (m0 != 0u) {
                    MB_NEXT(0u, m0) MB_NEXT(0u, m0) MB_NEXT(0u, m0) MB_NEXT(0u, m0)
                    MB_NEXT(0u, m0) MB_NEXT(0u, m0) MB_NEXT(0u, m0) MB_NEXT(0u, m0)
                }
                while (m1 != 0u) {
                    MB_NEXT(1u, m1) MB_NEXT(1u, m1) MB_NEXT(1u, m1) MB_NEXT(1u, m1)
                    MB_NEXT(1u, m1) MB_NEXT(1u, m1) MB_NEXT(1u, m1) MB_NEXT(1u, m1)
                }
            }
            barrier();
        }
        start += visible;
    }
    if (mine && group != NONE) {
        uint flags = bin_groups[group].info.z;
        if (state[BIN_GROUPS + 2u * group] == 0u) flags |= RUN_LONE_BOUND;
        runs[off.x + run_count - 1u] = uvec4(group, off.x + run_start, count - run_start, flags);
        headers[off.z] = uvec4(off.x, run_count, tile);
    }
    // Lavapipe's loop budget: a cut walk would have lost balls; say so (every pixel of the
    // block counts as dropped) rather than draw less.
    if (loops_cut(chunks + params.sizes.y) && lane == 0u) {
        atomicAdd(stats[STAT_DROPPED], 64u * 64u);
        atomicAdd(state[BIN_CUT], 1u);
    }
}

#elif MB_BIN_STAGE == 3
shared uvec4 partial[256];
shared uvec4 carry;
shared uint shared_groups;

void main() {
    uint lane = gl_LocalInvocationID.x;
    uint n = params.sizes.w;
    // The tiles' counts: the difference grid summed along rows, then down columns.
    uint tiles_x = params.caps.z;
    uint tiles_y = params.caps.w;
    uint w = tiles_x + 1u;
    for (uint y = lane; y < tiles_y; y += 256u) {
        uint acc = 0u;
        for (uint x = 0u; x < tiles_x; ++x) {
            acc += diff[y * w + x];
            diff[y * w + x] = acc;
        }
    }
    memoryBarrierBuffer();
    barrier();
    for (uint x = lane; x < tiles_x; x += 256u) {
        uint acc = 0u;
        for (uint y = 0u; y < tiles_y; ++y) {
            acc += diff[y * w + x];
            counts[y * tiles_x + x] = uvec2(acc, 0u);
        }
    }
    memoryBarrierBuffer();
    if (lane == 0u) carry = uvec4(0u);
    barrier();
    for (uint base = 0u; base < n; base += 256u) {
        uint t = base + lane;
        uvec2 c = t < n ? counts[t] : uvec2(0u);
        uvec4 v = uvec4(c.x, 0u, c.x > 0u ? 1u : 0u, 0u);
        // Inclusive scan over the workgroup (Hillis-Steele in shared memory).
        partial[lane] = v;
        barrier();
        for (uint d = 1u; d < 256u; d <<= 1u) {
            uvec4 add = lane >= d ? partial[lane - d] : uvec4(0u);
            barrier();
            partial[lane] += add;
            barrier();
        }
        uvec4 before_me = carry + partial[lane] - v;
        if (t < n) offsets[t] = uvec4(before_me.x, before_me.y, v.z != 0u ? before_me.z : NONE, 0u);
        barrier();
        if (lane == 255u) carry += partial[255];
        barrier();
    }
    uvec4 total = carry;
    bool overflow = total.x > params.caps.x;
    uint active_tiles = overflow ? n : total.z;
    if (lane == 0u) {
        state[BIN_OVERFLOW] = overflow ? 1u : 0u;
        state[BIN_ENTRIES] = total.x;
        state[BIN_RUNS] = total.y;
        state[BIN_ACTIVE] = active_tiles;
        state[0] = min(active_tiles, TILES_PER_ROW);
        state[1] = (active_tiles + TILES_PER_ROW - 1u) / TILES_PER_ROW;
        state[2] = 1u;
    }
    if (!overflow) return;
    // Past the capacities: every tile shares one run per group over the group's visible balls in
    // sorted order (the elements are sorted by group first), exact and slower.
    uint visible = state[BIN_VISIBLE];
    for (uint k = lane; k < visible; k += 256u) entries[k] = elements[k].y & INDEX_MASK;
    uint groups = 0u;
    if (lane == 0u) {
        uint start = 0u;
        for (uint g = 0u; g < params.sizes.y; ++g) {
            uint count = state[BIN_GROUPS + 2u * g + 1u];
            if (count > 0u) {
                uint flags = bin_groups[g].info.z;
                if (state[BIN_GROUPS + 2u * g] == 0u) flags |= RUN_LONE_BOUND;
                runs[groups] = uvec4(g, start, count, flags);
                ++groups;
            }
            start += count;
        }
        shared_groups = groups;
    }
    barrier();
    groups = shared_groups;
    for (uint t = lane; t < n; t += 256u) headers[t] = uvec4(0u, groups, t % tiles_x, t / tiles_x);
}
#endif
