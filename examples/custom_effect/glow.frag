#version 460
// Sky glow (examples/custom_effect/glow.rs): where the pixel sees no surface (distance +inf), the
// radiance colour · max(û·s, 0)² towards the unit direction s, added to hadou's HDR image by the
// pipeline's additive blend. A full-screen fragment pass: an effect need not be compute.
// CPU twin: glow.rs, `Glow::radiance` (f64).
#include "common/frame.glsl"
#include "common/camera.glsl"

layout(set = 0, binding = 0, r32f) uniform readonly image2D distance_image;
layout(set = 0, binding = 1, std140) uniform FrameBlock { FrameUniforms frame; };

// GlowParams in glow.rs (size checked when the pipeline is made).
layout(push_constant) uniform GlowParams {
    vec4 color;      // rgb: pre-exposed radiance at û = s
    vec4 direction;  // xyz: s, unit
} glow;

layout(location = 0) out vec4 out_color;

void main() {
    uvec2 p = uvec2(gl_FragCoord.xy);
    vec3 u = camera_pixel_ray(p, frame.counts.yz, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
    float c = max(dot(u, glow.direction.xyz), 0.0);
    bool sky = isinf(imageLoad(distance_image, ivec2(p)).r);
    // Alpha 0: the blend keeps the image's alpha (Blend::Add).
    out_color = vec4(sky ? glow.color.rgb * (c * c) : vec3(0.0), 0.0);
}
