// Pixel rays for compute passes. Keep in sync with Camera::ray_frame / Camera::pixel_ray in
// crates/hadou/src/scene/camera.rs: right and up are scaled by the lens (tan(fov/2)·aspect and tan(fov/2) when
// symmetric), their w the lens's ndc offset (−shift: off-centre frusta, jitter); row 0 is the top.
#ifndef HADOU_CAMERA_GLSL
#define HADOU_CAMERA_GLSL

// The unit view ray through the centre of pixel p of a size.x × size.y image.
vec3 camera_pixel_ray(uvec2 p, uvec2 size, vec4 right, vec4 up, vec3 forward) {
    float ndc_x = 2.0 * (float(p.x) + 0.5) / float(size.x) - 1.0 + right.w;
    float ndc_y = 1.0 - 2.0 * (float(p.y) + 0.5) / float(size.y) + up.w;
    return normalize(forward + ndc_x * right.xyz + ndc_y * up.xyz);
}

#endif
