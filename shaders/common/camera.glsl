// Pixel rays for compute passes. Keep in sync with Camera::ray_frame / Camera::pixel_ray in
// src/scene/camera.rs: right is scaled by tan(fov/2)·aspect, up by tan(fov/2); row 0 is the top.
#ifndef HADOU_CAMERA_GLSL
#define HADOU_CAMERA_GLSL

// The unit view ray through the centre of pixel p of a size.x × size.y image.
vec3 camera_pixel_ray(uvec2 p, uvec2 size, vec3 right, vec3 up, vec3 forward) {
    float ndc_x = 2.0 * (float(p.x) + 0.5) / float(size.x) - 1.0;
    float ndc_y = 1.0 - 2.0 * (float(p.y) + 0.5) / float(size.y);
    return normalize(forward + ndc_x * right + ndc_y * up);
}

#endif
