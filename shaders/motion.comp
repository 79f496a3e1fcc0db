#version 460
// motion: completes a temporal upscaler's inputs after every pass that draws a surface and before
// the energy wave (crates/hadou/src/passes/motion.rs). Per pixel, the motion in pixels from this
// frame to the previous one, both unjittered (common/motion.glsl):
//   - an instance's pixel keeps what the raster wrote (its vertices' previous positions);
//   - a metaball's: the hit point moved by its group's transforms and, inside the group, by the
//     field-weighted motion of the balls whose support holds it (exact for balls moving together);
//   - any other (the sky, the game's depth): a still point at that distance, or the direction at
//     infinity, seen by the previous camera.
// The composition mask is 1 on translucent surfaces; the reactive mask is cleared (the energy
// wave writes its glow's share).
#include "common/frame.glsl"
#include "common/camera.glsl"
#include "common/motion.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 1, std430) readonly buffer Materials { MaterialData materials[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D distance_image;
layout(set = 0, binding = 3, rg32ui) uniform readonly uimage2D ids;
layout(set = 0, binding = 4, rg32f) uniform image2D motion;
layout(set = 0, binding = 5, r32f) uniform writeonly image2D reactive;
layout(set = 0, binding = 6, r32f) uniform writeonly image2D composition;
layout(set = 0, binding = 7, std140) uniform MotionBlock { MotionUniforms m; };
// Keep in sync with MotionGroup and MotionBall in crates/hadou/src/passes/motion.rs.
struct MotionGroup {
    mat4 to_object;      // this frame's world → object
    mat4 prev_to_world;  // the previous frame's object → world
    uvec4 info;          // x: first ball, y: balls (0: none known, e.g. the game's), z: kernel
};
struct MotionBall {
    vec4 centre_radius;  // this frame's object-space centre, R
    vec4 q_prev;         // x: q, yzw: the previous frame's centre (a game's DeviceBall, copied as is)
};
layout(set = 0, binding = 8, std430) readonly buffer Groups { MotionGroup groups[]; };
layout(set = 0, binding = 9, std430) readonly buffer Balls { MotionBall balls[]; };

// f(r′) of effects::metaballs::Kernel::f (0: Wyvill6, 1: Murakami4).
float kernel_f(uint kernel, float rp) {
    if (rp >= 1.0) return 0.0;
    if (kernel == 0u) return ((-4.0 / 9.0 * rp + 17.0 / 9.0) * rp - 22.0 / 9.0) * rp + 1.0;
    return (1.0 - rp) * (1.0 - rp);
}

// Where world point `p` on group g's surface was in the previous frame.
vec3 metaball_previous(uint g, vec3 p) {
    MotionGroup group = groups[g];
    vec3 o = (group.to_object * vec4(p, 1.0)).xyz;
    vec3 moved = vec3(0.0);
    float weight = 0.0;
    for (uint i = group.info.x; i < group.info.x + group.info.y; ++i) {
        MotionBall b = balls[i];
        vec3 w = o - b.centre_radius.xyz;
        float f = abs(b.q_prev.x) * kernel_f(group.info.z, dot(w, w) / (b.centre_radius.w * b.centre_radius.w));
        moved += f * (b.q_prev.yzw - b.centre_radius.xyz);
        weight += f;
    }
    vec3 before = weight > 0.0 ? o + moved / weight : o;
    return (group.prev_to_world * vec4(before, 1.0)).xyz;
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    uvec2 size = frame.counts.yz;
    if (p.x >= size.x || p.y >= size.y) return;
    ivec2 pix = ivec2(p);
    uvec2 id = imageLoad(ids, pix).xy;
    bool instance = id.x >= 1u && id.x <= m.counts.x;
    bool translucent = instance && materials[id.y].kind.x == MATERIAL_TRANSLUCENT;
    imageStore(composition, pix, vec4(translucent ? 1.0 : 0.0, 0.0, 0.0, 0.0));
    imageStore(reactive, pix, vec4(0.0));
    if (instance) return;  // the raster's
    vec3 u = camera_pixel_ray(p, size, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
    float t = imageLoad(distance_image, pix).r;
    vec4 now;
    vec4 before;
    if (isinf(t)) {
        // Nothing at any distance: the direction itself, as far as the camera sees.
        now = m.view_proj * vec4(u, 0.0);
        before = m.prev_view_proj * vec4(u, 0.0);
    } else {
        vec3 q = frame.camera_pos.xyz + t * u;
        vec3 q_before = id.x > m.counts.x ? metaball_previous(id.x - m.counts.x - 1u, q) : q;
        now = m.view_proj * vec4(q, 1.0);
        before = m.prev_view_proj * vec4(q_before, 1.0);
    }
    vec2 fsize = vec2(size);
    vec2 moved = motion_pixel(before, fsize) - motion_pixel(now, fsize);
    // A point behind the previous camera (w ≤ 0) has no pixel there: no motion rather than NaN.
    bool seen = now.w > 0.0 && before.w > 0.0;
    imageStore(motion, pix, vec4(seen && !any(isnan(moved)) && !any(isinf(moved)) ? moved : vec2(0.0), 0.0, 0.0));
}
