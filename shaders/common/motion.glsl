// A temporal upscaler's motion (crates/hadou/src/passes/motion.rs): pixels from where a point is
// seen this frame to where it was seen in the previous one, both without the jitter.
#ifndef HADOU_MOTION_GLSL
#define HADOU_MOTION_GLSL

// Keep in sync with MotionUniforms in crates/hadou/src/passes/motion.rs.
struct MotionUniforms {
    // Both take positions relative to the camera (world − camera position; composed on the host
    // in f64, so that no f32 product cancels far from the origin) and directions as they are.
    mat4 view_proj;       // this frame's, unjittered
    mat4 prev_view_proj;  // the previous frame's, unjittered
    uvec4 counts;         // x: instances (ids above them are effects' surfaces), y, z, w: 0
};

// Clip coordinates to framebuffer pixels (x right, y down): the rasterizer's viewport mapping.
vec2 motion_pixel(vec4 clip, vec2 size) {
    return (clip.xy / clip.w * 0.5 + 0.5) * size;
}

#endif
