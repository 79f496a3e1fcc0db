// A temporal upscaler's motion for the pixels whose nearest surface is a metaball (with motion
// vectors on: shaders/metaballs.comp compiled with MB_MOTION; its data:
// crates/hadou/src/passes/metaballs_motion.rs). The casts call metaball_motion where a pixel's
// hit is final: the first dispatch for a pixel with no crowded run, the streamed dispatch for
// the others. The hit point is carried back in its group's object space by the field-weighted
// motion of the balls whose support holds it, Σ |q|·f(r′)·(c_before − c) / Σ |q|·f(r′) (exact for
// balls moving together), then to the world by the group's previous transform; the motion is in
// pixels from the point now to the point before, both unjittered, as shaders/motion.comp gives
// every pixel with no id. Only the balls of the tile's run of that group can hold the point (a
// run lists every ball whose support reaches the tile's rays), so a pixel walks what can reach
// it, not its whole group. CPU twin (f64): crates/hadou/src/effects/metaballs/motion.rs.
// Include after common/camera.glsl, common/frame.glsl, common/metaballs_tiles.glsl and the cast's
// half of common/metaballs.glsl (mb_kernel, f(r′) of effects::metaballs::Kernel::f).
#ifndef HADOU_METABALLS_MOTION_GLSL
#define HADOU_METABALLS_MOTION_GLSL
#include "common/motion.glsl"

// Written where a metaball is the pixel's surface; the raster wrote its instances', and the
// upscaler's `motion` pass writes every pixel with no id.
layout(set = 0, binding = 25, rg32f) uniform image2D motion;
layout(set = 0, binding = 26, std140) uniform MotionBlock { MotionUniforms m; };
// Per ball of the table, its object-space centre in the previous frame (xyz).
layout(set = 0, binding = 27, std430) readonly buffer Previous { vec4 previous[]; };
// Per group, 5 texels (MotionGroup in crates/hadou/src/passes/metaballs_motion.rs): the previous
// frame's object → world relative to this frame's camera (4 columns), then x: 1 when the balls'
// previous centres are known (else the group moves by its transforms only). A texel buffer: on
// lavapipe a gather, where a storage-buffer load at a per-lane index is a loop over the lanes.
layout(set = 0, binding = 28) uniform usamplerBuffer motion_group_texels;

// Writes the motion of pixel p (ray u) where `mine`: its surface is group g's at distance t, in
// the tile of `header`. Every lane runs it (the loops are uniform); the others only walk nothing.
void metaball_motion(uvec2 p, vec3 u, float t, uint g, uvec4 header, bool mine) {
    // The tile's run of that group: a tile has one run per group present in it (uniform loops,
    // do-while: see shaders/common/metaballs.glsl on loops).
    uvec4 run = uvec4(0u);
    uint r = 0u;
    do {
        uvec4 candidate = run_at(header.x + min(r, max(header.y, 1u) - 1u));
        if (mine && r < header.y && candidate.x == g) run = candidate;
        ++r;
    } while (r < header.y);
    MetaGroup group = load_group(g);
    mat4 prev_to_world;
    for (int c = 0; c < 4; ++c) prev_to_world[c] = uintBitsToFloat(texelFetch(motion_group_texels, int(5u * g) + c));
    bool known = texelFetch(motion_group_texels, int(5u * g) + 4).x != 0u;
    // Relative to the camera, as the group's matrices and the motion's take positions.
    vec3 q = t * u;
    vec3 o = (group.to_object * vec4(q, 1.0)).xyz;
    uint kernel = group.info.x;
    uint count = mine && known ? run.z : 0u;
    // The run is sorted by mb_entry_key, a lower bound of the distance at which a ray from the
    // camera enters a support: a ball whose support holds the point has a key below the point's
    // distance from the camera (object space; padded by the f32 rounding of that length), so
    // the walk ends at the first ball past it.
    vec3 eye = group.to_object[3].xyz;
    float reach = length(o - eye) * (1.0 + 1e-5);
    vec3 moved = vec3(0.0);
    float weight = 0.0;
    // Eight balls per iteration: lavapipe ends a SIMD group's loops after 65,535 iterations in
    // all (the casts' loops_cut tells), and a run may hold every ball of the frame.
    uint base = 0u;
    bool more = true;
    do {
        for (uint j = 0u; j < 8u; ++j) {
            uint k = base + j;
            uint ball_id = entries(run.y + min(k, max(count, 1u) - 1u));
            MetaBall b = load_ball(ball_id);
            vec3 w = o - b.centre_radius.xyz;
            float R = b.centre_radius.w;
            float f = abs(b.coeffs.x) * mb_kernel(kernel, dot(w, w) / (R * R));
            if (k < count && f > 0.0) {
                moved += f * (previous[ball_id].xyz - b.centre_radius.xyz);
                weight += f;
            }
        }
        base += 8u;
        uint next = entries(run.y + min(base, max(count, 1u) - 1u));
        more = base < count && mb_entry_key(load_ball(next), eye) < reach;
    } while (more);
    vec3 back = weight > 0.0 ? o + moved / weight : o;
    vec3 q_before = (prev_to_world * vec4(back, 1.0)).xyz;
    vec4 now = m.view_proj * vec4(q, 1.0);
    vec4 before = m.prev_view_proj * vec4(q_before, 1.0);
    vec2 fsize = vec2(frame.counts.yz);
    vec2 shift = motion_pixel(before, fsize) - motion_pixel(now, fsize);
    // A point behind the previous camera (w ≤ 0) has no pixel there: no motion rather than NaN.
    bool seen = now.w > 0.0 && before.w > 0.0 && !any(isnan(shift)) && !any(isinf(shift));
    if (mine) imageStore(motion, ivec2(p), vec4(seen ? shift : vec2(0.0), 0.0, 0.0));
}

#endif
