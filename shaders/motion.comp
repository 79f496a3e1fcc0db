#version 460
// motion: completes a temporal upscaler's inputs after every pass that draws a surface and before
// the energy wave (crates/hadou/src/passes/motion.rs). Per pixel, the motion in pixels from this
// frame to the previous one, both unjittered (common/motion.glsl):
//   - an instance's pixel keeps what the raster wrote (its vertices' previous positions);
//   - an effect's surface (ids above the instances', a metaball's): what its pass wrote
//     (shaders/common/metaballs_motion.glsl walks the balls of the pixel's tile);
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
    // The raster's, or an effect's surface's, written by its pass.
    if (id.x != 0u) return;
    vec3 u = camera_pixel_ray(p, size, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
    float t = imageLoad(distance_image, pix).r;
    vec4 now;
    vec4 before;
    if (isinf(t)) {
        // Nothing at any distance: the direction itself, as far as the camera sees.
        now = m.view_proj * vec4(u, 0.0);
        before = m.prev_view_proj * vec4(u, 0.0);
    } else {
        // The game's depth: a still point (relative to the camera, as m's matrices take it).
        vec3 q = t * u;
        now = m.view_proj * vec4(q, 1.0);
        before = m.prev_view_proj * vec4(q, 1.0);
    }
    vec2 fsize = vec2(size);
    vec2 moved = motion_pixel(before, fsize) - motion_pixel(now, fsize);
    // A point behind the previous camera (w ≤ 0) has no pixel there: no motion rather than NaN.
    bool seen = now.w > 0.0 && before.w > 0.0;
    imageStore(motion, pix, vec4(seen && !any(isnan(moved)) && !any(isinf(moved)) ? moved : vec2(0.0), 0.0, 0.0));
}
