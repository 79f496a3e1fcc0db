#version 460
// metaballs: per pixel, the world view ray cast against every metaball group binned to the
// pixel's 8×8 tile, depth-tested against the raster (t_max = the `distance` target, t_min = the
// near plane along the ray). The nearest surface writes HDR colour (Lambert + Blinn-Phong under
// the scene's directional lights and ambient), distance, normal (toward the camera) and ids.
// Binning and buffer layouts: crates/hadou/src/passes/metaballs.rs. Cast: shaders/common/metaballs.glsl;
// CPU twins crates/hadou/src/effects/metaballs.rs (f64) and crates/hadou/src/effects/metaballs_f32.rs (its arithmetic).
//
// Per group present in the tile, each pixel first gathers its candidates: the balls of the
// tile's run whose support its ray enters in [from, stop), as support chords in the cast's slots
// (mb_fill_slot). The subgroup (always inside one tile, so sharing the run) walks the run
// together in chunks of 8: each lane tests one ball against a cone around the subgroup's rays,
// and the balls some ray may meet are then read by every lane, one at a time. A ball some lane
// needs takes the next slot for the whole subgroup (slot indices stay uniform), each lane marking
// its own in a bit mask; at most MB_MAX_RAY_BALLS slots per round. The run is sorted by a lower
// bound of the entry distance, so the walk stops once every lane's `stop` lies before the next
// ball. The cast (mb_clip_slots or mb_trace_slots) then runs on the pixel's chords only, with no
// second pass over the balls and no sorting. A pixel whose cast of a group is crowded (a point
// inside more supports than the slots hold) leaves that group to the second dispatch
// (MB_STREAM_PASS, indirect, over the tiles listed here), which casts it streamed from the run.
// With MB_MOTION (motion vectors on) the dispatch where a pixel's hit is final also writes its
// motion (common/metaballs_motion.glsl).
//
// Lavapipe (Mesa 22.3) runs both sides of every branch for the whole 8-lane SIMD group, every
// loop body at least once, and a `for`/`while` body once more (masked) to find the loop done;
// inside a branch or a loop a storage-buffer load is a loop over the lanes, where a texel fetch
// is a gather; an array indexed by anything but a constant lives in memory, each access a
// per-lane gather or scatter. The code is shaped by that: loops are few, uniform and do-while,
// buffers are texel buffers, small arrays are indexed by constants. Measured variants:
// docs/PERFORMANCE.md.
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_vote : require
#include "common/camera.glsl"
#include "common/frame.glsl"
#include "common/metaballs.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, r32f) uniform image2D distance_image;
layout(set = 0, binding = 1, rgba16f) uniform image2D hdr;
layout(set = 0, binding = 2, rgba16f) uniform image2D normal_image;
layout(set = 0, binding = 3, rg32ui) uniform uimage2D ids;
layout(set = 0, binding = 4, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 5, std430) readonly buffer Materials { MaterialData materials[]; };
// Keep in sync with the STAT_* indices in crates/hadou/src/passes/metaballs.rs.
layout(set = 0, binding = 10, std430) buffer Stats { uint stats[]; };
// Keep in sync with `PendingRecord` and `StreamDispatch` in crates/hadou/src/passes/metaballs.rs. Per pixel of
// each active tile (tile · 64 + lane): the runs whose cast is crowded (x: runs 0–31 by bit, y:
// 32–63, z: the first crowded run from 64 on, every later run streamed too; 0xffffffff: none) and
// w: bit 31 set when the rounds found a hit, its clipping steps below.
layout(set = 0, binding = 11, std430) buffer Pending { uvec4 pending_runs[]; };
// The streamed dispatch (vkCmdDispatchIndirect): x, y, z, then the count of tiles with a crowded
// pixel and their indices. x = min(count, 65535): a workgroup takes every x-th tile.
layout(set = 0, binding = 12, std430) buffer StreamDispatch { uint stream[]; };

// Which casts this pipeline holds (the pass defines them from the scene's methods, so a method
// the scene does not use costs nothing).
#ifndef MB_WITH_CLIP
#define MB_WITH_CLIP 1
#endif
#ifndef MB_WITH_TRACE
#define MB_WITH_TRACE 1
#endif
#include "common/metaballs_tiles.glsl"

// A lower bound of the distance t′ at which a ray from o enters the support of entry k of the run
// (or of any later one: the run is sorted by this key).
float chunk_key(uvec4 run, uint k, vec3 o) { return mb_entry_key(load_ball(entries(run.y + k)), o); }

#define MB_BALL(i) load_ball(i)
#define MB_INDEX(k) entries(k)
#define MB_LIST_SORTED 1
#define MB_TANGENT_FLAGS 0  // this pass never reads MB_TANGENT
#include "common/metaballs.glsl"
#ifdef MB_MOTION
// With motion vectors on: each final hit's motion (metaball_motion).
#include "common/metaballs_motion.glsl"
#endif

// Keep in sync with MetaballParams in crates/hadou/src/passes/metaballs.rs. The camera's ray frame, the far
// distance (ray_forward.w) and the frame's size (counts.yz) are the frame's uniforms.
layout(push_constant) uniform MetaballParams {
    uvec4 counts;  // x: 0, y: instance id of group 0 (scene instances)
    vec4 near;     // x: the camera's near distance (a view depth; not in FrameUniforms)
} params;

#define STAT_DROPPED 0         // pixels whose search could not finish (MB_NOT_CONVERGED:
                               // clipping did not converge or sphere tracing ran out of
                               // steps; or lavapipe's loop limit cut them, see main):
                               // a surface may be missing there
#define STAT_HITS 1            // pixels where a metaball is the nearest surface
#define STAT_ITERATIONS 2      // Σ Bézier-clipping steps of those hits' casts (sphere
                               // tracing: march steps)
#define STAT_MAX_ITERATIONS 3
#define STAT_STREAMED 4        // casts streamed from the run (mb_clip_stream): a ball
                               // containing `from` found no slot (more than MB_MAX_RAY_BALLS
                               // supports there, or the subgroup's other rays filled them), or
                               // a crowded group's long run skipped its rounds (RUN_CROWDED)

// Keep in sync with RUN_LONE_BOUND in crates/hadou/src/passes/metaballs.rs: all q ≥ 0 and F = 0 on the near
// plane, so F > T at a point well inside one ball's lone isosurface sphere bounds the first hit.
#define RUN_LONE_BOUND 1u
// Keep in sync with RUN_TRACE in crates/hadou/src/passes/metaballs.rs: the group is sphere-traced.
#define RUN_TRACE 2u
// Keep in sync with RUN_CROWDED in crates/hadou/src/passes/metaballs.rs: the group's supports
// overlap deeper than the slots hold, so its runs go to the streamed cast without slot rounds.
#define RUN_CROWDED 4u

const float HALF_MAX = 65504.0;
// A crowded group's runs of at least this many balls (eight rounds of 32 slots) are cast
// streamed without slot rounds (main, below; measured on the dense fluid at 256²: 0.8× the pass
// time of keeping every run's rounds; streaming every run of the group was no faster).
// docs/PERFORMANCE.md, "The dense fluid 5× faster".
const uint STREAM_RUN = 256u;
// Blinn-Phong: a white highlight of this strength and exponent on every metaball material.
const float SPECULAR = 0.25;
const float SHININESS = 48.0;

// Keep in sync with TILES_PER_ROW in crates/hadou/src/passes/metaballs.rs.
#define TILES_PER_ROW 8192u

// The shading and outputs of a metaball hit at pixel p (ray u).
void store_hit(uvec2 p, vec3 u, MetaHit best, uint best_group) {
    vec3 n = best.normal;
    // Toward the camera, like the raster's normals (the camera may be inside the blob).
    if (dot(n, u) > 0.0) n = -n;
    MetaGroup g = load_group(best_group);
    MaterialData mat = materials[g.info.w];
    vec3 v = -u;
    vec3 diffuse = frame.ambient.rgb;
    vec3 specular = vec3(0.0);
    vec3 at = best.t * u;  // relative to the camera, as the lights' positions are
    uint i = 0u;
    do {  // a do-while: see shaders/common/metaballs.glsl on loops
        vec3 l;
        vec3 arriving = light_arriving(frame.lights[i], at, l);
        float nl = dot(n, l);
        if (i < frame.counts.x && nl > 0.0) {
            diffuse += nl * arriving;
            vec3 hv = normalize(l + v);
            specular += SPECULAR * pow(max(dot(n, hv), 0.0), SHININESS) * arriving;
        }
        ++i;
    } while (i < frame.counts.x);
    vec3 color = min(mat.albedo.rgb * diffuse + specular, vec3(HALF_MAX));
    imageStore(hdr, ivec2(p), vec4(color, 1.0));
    imageStore(distance_image, ivec2(p), vec4(best.t, 0.0, 0.0, 0.0));
    imageStore(normal_image, ivec2(p), vec4(n, 1.0));
    imageStore(ids, ivec2(p), uvec4(params.counts.y + best_group + 1u, g.info.w, 0u, 0u));
}

// Counters: one atomic per subgroup. `hit`: this pixel's final answer is a hit (`iterations`
// its steps).
void count(bool hit, uint iterations, uint dropped, uint streamed) {
    uint hit_count = subgroupAdd(hit ? 1u : 0u);
    uint iter_sum = subgroupAdd(hit ? iterations : 0u);
    uint iter_max = subgroupMax(hit ? iterations : 0u);
    uint drop_sum = subgroupAdd(dropped);
    uint stream_sum = subgroupAdd(streamed);
    if (subgroupElect()) {
        if (drop_sum != 0u) atomicAdd(stats[STAT_DROPPED], drop_sum);
        if (stream_sum != 0u) atomicAdd(stats[STAT_STREAMED], stream_sum);
        if (hit_count != 0u) {
            atomicAdd(stats[STAT_HITS], hit_count);
            atomicAdd(stats[STAT_ITERATIONS], iter_sum);
            atomicMax(stats[STAT_MAX_ITERATIONS], iter_max);
        }
    }
}

#ifdef MB_STREAM_PASS
// The crowded groups of the tiles listed by the first dispatch, each cast streamed from its run
// over [near, the nearest hit so far] (the `distance` the rounds left), in run order. Runs 0–63 by
// bit; from the first crowded run past them, every later run is streamed (exact for any group,
// only slower), so no count of groups is too many.
void main() {
    uint lane = gl_LocalInvocationIndex;
    for (uint w = gl_WorkGroupID.x; w < stream[3]; w += gl_NumWorkGroups.x) {
        uint tile = stream[4u + w];
        uvec4 header = tiles(tile);
        uvec2 p = tile_pixel(header, lane);
        bool inside = p.x < frame.counts.y && p.y < frame.counts.z;
        uvec4 record = uvec4(0u, 0u, 0xffffffffu, 0u);
        if (inside) record = pending_runs[64u * tile + lane];
        uint pending_lo = record.x;
        uint pending_hi = record.y;
        uint pending_rest = record.z;
        bool was_hit = (record.w & 0x80000000u) != 0u;
        bool pending = pending_lo != 0u || pending_hi != 0u || pending_rest < header.y;
        bool crowded = pending;  // this pixel's hit is counted here, not by the rounds
        vec3 u = camera_pixel_ray(p, frame.counts.yz, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
        vec3 origin = vec3(0.0);  // the camera: the groups' world is relative to it
        float t_min = params.near.x / dot(u, frame.ray_forward.xyz);
        float t_max = -1.0;
        if (pending) t_max = min(imageLoad(distance_image, ivec2(p)).r, frame.ray_forward.w);
        bool found = false;
        MetaHit best;
        best.iterations = record.w & 0x7fffffffu;
        uint best_group = 0u;
        uint dropped = 0u;
        if (subgroupAny(pending)) {
            do {
                uint r = 0u;
                bool some = true;
                if (pending_lo != 0u) {
                    r = uint(findLSB(pending_lo));
                    pending_lo &= pending_lo - 1u;
                } else if (pending_hi != 0u) {
                    r = 32u + uint(findLSB(pending_hi));
                    pending_hi &= pending_hi - 1u;
                } else if (pending_rest < header.y) {
                    r = pending_rest;
                    pending_rest += 1u;
                } else {
                    some = false;
                }
                uvec4 run = run_at(header.x + r);
                MetaGroup g = load_group(run.x);
                MetaRay mr = mb_object_ray(g, origin, u);
                MetaHit h;
                h.normal = -u;
                h.t = t_max;
                h.flags = 0u;
                h.iterations = 0u;
                if (some && t_max >= t_min) {
                    h = mb_clip_stream(g, mr, u, run.y, run.z, t_min * mr.ts, t_max * mr.ts, h);
                    if ((h.flags & MB_HIT) != 0u) {
                        best = h;
                        best_group = run.x;
                        found = true;
                        t_max = h.t;
                    } else if ((h.flags & MB_NOT_CONVERGED) != 0u) {
                        dropped += 1u;
                    }
                }
                pending = pending_lo != 0u || pending_hi != 0u || pending_rest < header.y;
            } while (subgroupAny(pending));
        }
        if (found) store_hit(p, u, best, best_group);
#ifdef MB_MOTION
        // The final hit: this pass's, or the rounds' (its group in `ids`, its distance stored).
        uint final_group = best_group;
        float final_t = best.t;
        if (!found && was_hit) {
            final_group = imageLoad(ids, ivec2(p)).x - params.counts.y - 1u;
            final_t = imageLoad(distance_image, ivec2(p)).r;
        }
        metaball_motion(p, u, final_t, final_group, header, inside && crowded && (found || was_hit));
#endif
        if (loops_cut(header.y) && crowded) dropped += 1u;
        count(crowded && (found || was_hit), best.iterations, dropped, 0u);
    }
}
#else
shared uint tile_pending;

// Run r of the tile goes to the streamed dispatch: runs 0–63 by bit, the first from 64 on by index
// (every later run is streamed too).
void mark_pending(uint r, inout uint lo, inout uint hi, inout uint rest) {
    if (r < 32u) {
        lo |= 1u << r;
    } else if (r < 64u) {
        hi |= 1u << (r - 32u);
    } else {
        rest = min(rest, r);
    }
}

void main() {
    // One 8×8 workgroup per active tile (a tile holding any ball): every subgroup shares its
    // tile, so the loops over the tile's runs and balls are uniform.
    uint tile = gl_WorkGroupID.y * TILES_PER_ROW + gl_WorkGroupID.x;
    uint active_tiles = bin_state[BIN_ACTIVE];
    uvec4 header = uvec4(0u);
    if (tile < active_tiles) header = tiles(tile);
    uint lane = gl_LocalInvocationIndex;
    uvec2 p = tile_pixel(header, lane);
    bool inside = tile < active_tiles && p.x < frame.counts.y && p.y < frame.counts.z;
    uint dropped = 0u;
    uint streamed = 0u;
    // Runs (groups of the tile) whose cast is crowded, streamed after the rounds (below).
    uint pending_lo = 0u;
    uint pending_hi = 0u;
    uint pending_rest = 0xffffffffu;
    bool found = false;
    MetaHit best;
    uint best_group = 0u;
    // The ray through the pixel centre, as Camera::pixel_ray and energy_wave.comp build it.
    vec3 u = camera_pixel_ray(p, frame.counts.yz, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
    vec3 origin = vec3(0.0);  // the camera: the groups' world is relative to it
    // t_max: the raster's distance (+inf where nothing was hit), at most the far distance;
    // t_min: the near plane, measured along this ray.
    float t_max = -1.0;
    if (inside && header.y != 0u) t_max = min(imageLoad(distance_image, ivec2(p)).r, frame.ray_forward.w);
    float t_min = params.near.x / dot(u, frame.ray_forward.xyz);

    for (uint r = 0u; r < header.y; ++r) {
        uvec4 run = run_at(header.x + r);
        MetaGroup g = load_group(run.x);
        // The ray in the group's object space, as metaball_cast computes it.
        vec3 o = (g.to_object * vec4(origin, 1.0)).xyz;
        vec3 dv = (g.to_object * vec4(u, 0.0)).xyz;
        float ts = length(dv);
        vec3 d = dv / ts;
        // The subgroup's rays as one cone about `axis` (object space), for culling balls.
        vec3 axis = normalize(subgroupAdd(d));
        float cos_half = min(subgroupMin(dot(axis, d)), 1.0);
        float sin_half = sqrt(max(1.0 - cos_half * cos_half, 0.0));

        float from = t_min;
        bool live = inside && t_max >= t_min;
        bool lone_bound = (run.w & RUN_LONE_BOUND) != 0u;
        bool stuck = false;  // no step forward: stream the rest
        // A crowded group's long runs would end their rounds crowded on most rays: straight to
        // the streamed cast (exact either way). Its short runs (a silhouette's tiles) keep their
        // rounds: streaming them too measured no faster.
        if ((run.w & RUN_CROWDED) != 0u && run.z >= STREAM_RUN && live) {
            live = false;
            streamed += 1u;
            mark_pending(r, pending_lo, pending_hi, pending_rest);
        }
        // Each round casts [from, stop): a miss moves `from` to the entry of the first ball left
        // out (past at least one more of this lane's balls); where that is no step forward, the
        // next cast streams the rest. So a lane needs at most run.z + 1 rounds; the guard only
        // bounds what that argument missed, and counts it.
        uint round = 0u;
        do {
            if (round > 2u * run.z + 64u) {
                if (live) dropped += 1u;
                break;
            }
            float t0 = from * ts;
            float t1 = t_max * ts;
            uint slots = 0u;  // subgroup-uniform
            uint mask = 0u;   // this lane's slots
            float limit = t1;            // entry of the first ball left out (object space)
            float bound = t1;            // a point inside the surface (RUN_LONE_BOUND)
            float stop = limit;          // min(limit, bound): no ball entering later matters
            // The chunks of 8 balls, while some lane may still need one: the chunk's first key
            // (‖c − o‖ − R, sorted) bounds the entry of every ball in it and after it.
            uint base = 0u;
            bool walk = subgroupAny(live && chunk_key(run, base, o) < stop);
            do {
                // Each lane tests one ball of the chunk against the subgroup's cone (every lane
                // stays in the walk to do so: the loops are uniform).
                uint k = base + gl_SubgroupInvocationID;
                bool seen = false;
                if (k < run.z) {
                    vec4 mine = load_ball(entries(run.y + k)).centre_radius;
                    // Sphere-cone test, the radius padded for the f32 arithmetic.
                    vec3 w = mine.xyz - o;
                    float dist = length(w);
                    float R = mine.w * 1.001 + 1e-6 * dist;
                    float sin_s = R / dist;
                    float cos_s = sqrt(max(1.0 - sin_s * sin_s, 0.0));
                    seen = !(sin_s < 1.0) || dot(axis, w) >= dist * (cos_half * cos_s - sin_half * sin_s);
                }
                uvec4 ballot = subgroupBallot(walk && seen);
                uint word = 0u;
                do {
                    uint bits = ballot[word];
                    do {
                        bool some = bits != 0u;
                        uint j = word * 32u + uint(max(findLSB(bits), 0));
                        bits &= bits - 1u;
                        // Every lane reads the ball at the same (uniform) index.
                        uint ball_id = entries(run.y + min(base + j, run.z - 1u));
                        MetaBall bj = load_ball(ball_id);
                        vec4 ball = bj.centre_radius;
                        float rr = bj.coeffs.y;
                        // The support chord, as metaball_cast computes it.
                        vec3 w = ball.xyz - o;
                        float tc = dot(w, d);
                        vec3 cr = cross(w, d);
                        float h2 = dot(cr, cr);
                        float D = ball.w * ball.w - h2;
                        float half_chord = sqrt(max(D, 0.0));
                        float en = tc - half_chord;
                        float ex = tc + half_chord;
                        bool want = some && live && D > 0.0 && ex > t0 && en < stop;
                        // Well inside the lone isosurface sphere at t_c: F > T there.
                        if (want && lone_bound && tc > t0 && h2 < 0.998 * rr * rr) {
                            bound = min(bound, tc);
                            stop = min(stop, bound);
                        }
                        if (subgroupAny(want)) {
                            if (slots < uint(MB_MAX_RAY_BALLS)) {
                                mb_fill_slot(slots, bj, ball_id, w, tc, h2, en, ex);
                                if (want) mask |= 1u << slots;
                                ++slots;
                            } else if (want) {
                                limit = min(limit, en);
                                stop = min(stop, limit);
                            }
                        }
                    } while (bits != 0u);
                    ++word;
                } while (word * 32u < gl_SubgroupSize);
                base += gl_SubgroupSize;
                walk = base < run.z && subgroupAny(live && chunk_key(run, min(base, run.z - 1u), o) < stop);
            } while (walk);
            if (live) {
                bool cut = limit < min(t1, bound);
                // A ball containing `from` came after MB_MAX_RAY_BALLS others (some lanes' balls
                // filled the slots): no step forward. This group is cast streamed from its run
                // after all the tile's groups (below); its slot cast here is discarded.
                bool crowded = stuck || (cut && !(limit > t0));
                if (crowded) {
                    streamed += 1u;
                    mark_pending(r, pending_lo, pending_hi, pending_rest);
                }
                float t_end = stop < t1 ? stop / ts : t_max;
                MetaHit h;
                h.normal = -u;
                h.t = t_end;
                h.flags = 0u;
                h.iterations = 0u;
                MetaRay mr;
                mr.o = o;
                mr.d = d;
                mr.ts = ts;
                MetaHit h0 = h;
#if MB_WITH_CLIP && MB_WITH_TRACE
                if ((run.w & RUN_TRACE) != 0u) {
                    h = mb_trace_slots(g, mr, u, slots, mask, t0, t_end * ts, h0);
                } else {
                    h = mb_clip_slots(g, mr, u, slots, mask, t0, t_end * ts, h0);
                }
#elif MB_WITH_TRACE
                h = mb_trace_slots(g, mr, u, slots, mask, t0, t_end * ts, h0);
#else
                h = mb_clip_slots(g, mr, u, slots, mask, t0, t_end * ts, h0);
#endif
                if (crowded) {
                    live = false;
                } else if ((h.flags & MB_HIT) != 0u) {
                    best = h;
                    best_group = run.x;
                    found = true;
                    t_max = h.t;  // later groups must be nearer
                    live = false;
                } else if ((h.flags & MB_NOT_CONVERGED) != 0u) {
                    dropped += 1u;
                    live = false;
                } else if (cut) {
                    // Go on from where the search stopped; where rounding leaves no step
                    // forward (the window's end within an ulp of `from` in world units), the
                    // next round streams.
                    float next = t_end;
                    if (next > from) {
                        from = next;
                    } else {
                        stuck = true;
                    }
                } else if (bound < t1) {
                    // The bound promised a hit, which only a graze within the tangency band
                    // can miss: search again without it.
                    lone_bound = false;
                } else {
                    live = false;
                }
            }
            ++round;
        } while (subgroupAny(live));
    }

    // The crowded groups are cast streamed in a second dispatch over the tiles that hold a
    // crowded pixel (main below, MB_STREAM_PASS): lavapipe runs a branch's code for the whole SIMD
    // group even when no lane takes it, so here the long streamed cast would cost every tile, and
    // its own dispatch starts a fresh loop budget (loops_cut).
    bool pending = pending_lo != 0u || pending_hi != 0u || pending_rest < header.y;
    if (lane == 0u) tile_pending = 0u;
    barrier();
    if (pending) tile_pending = 1u;
    barrier();
    if (lane == 0u && tile_pending != 0u) {
        uint k = atomicAdd(stream[3], 1u);
        stream[4u + k] = tile;
        atomicMax(stream[0], min(k + 1u, 65535u));
    }
    if (inside && tile_pending != 0u) {
        uint mark = found ? (0x80000000u | min(best.iterations, 0x7fffffffu)) : 0u;
        pending_runs[64u * tile + lane] = uvec4(pending_lo, pending_hi, pending ? pending_rest : 0xffffffffu, mark);
    }

    if (found) store_hit(p, u, best, best_group);
#ifdef MB_MOTION
    // A pending pixel's hit is final only after the streamed dispatch, which writes its motion.
    metaball_motion(p, u, best.t, best_group, header, inside && found && !pending);
#endif
    if (loops_cut(header.y) && inside) dropped += 1u;
    // A pending pixel's hit is counted by the stream pass, which knows the final answer.
    count(found && !pending, best.iterations, dropped, streamed);
}
#endif
