#version 460
// Height fog (examples/custom_effect): per pixel, the optical depth τ of an exponential height
// fog ρ(y) = density · exp(−falloff · (y − base_height)) along the view ray from the camera to
// the first surface (or the camera's far distance), T = exp(−τ), HDR ← HDR · T + colour · (1 − T),
// and T written to the effect's own image. Computed in log space so no input gives Inf − Inf or
// 0 · Inf. CPU twin: fog.rs, `Fog::transmittance` (f64).
#include "common/frame.glsl"
#include "common/camera.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, r32f) uniform readonly image2D distance_image;
layout(set = 0, binding = 1, rgba16f) uniform image2D hdr;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D transmittance;
layout(set = 0, binding = 3, std140) uniform FrameBlock { FrameUniforms frame; };

// FogParams in fog.rs (size checked when the pipeline is made).
layout(push_constant) uniform FogParams {
    vec4 color_log_density;  // rgb: fog colour; w: ln(density)
    vec4 shape;              // x: falloff k; y: base height
} fog;

// ln of D = ∫₀ᴸ exp(−k·u_y·t) dt = L · (1 − e^(−x)) / x, x = k·u_y·L (> 0 for L > 0).
float log_span(float x, float len, float k_uy) {
    if (abs(x) < 0.01) {
        // (1 − e^(−x)) / x = 1 − x/2 + x²/6 − x³/24 + O(x⁴/120): no cancellation near 0.
        return log(len) + log(1.0 - x * (0.5 - x * (1.0 / 6.0 - x / 24.0)));
    }
    if (x > 0.0) {
        return log(1.0 - exp(-x)) - log(k_uy);
    }
    // x < 0: e^(−x) may overflow; factor it out.
    return -x + log(1.0 - exp(x)) - log(-k_uy);
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    uvec2 size = frame.counts.yz;
    if (p.x >= size.x || p.y >= size.y) return;
    vec3 u = camera_pixel_ray(p, size, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
    float len = min(imageLoad(distance_image, ivec2(p)).r, frame.ray_forward.w);
    float k = fog.shape.x;
    float kh = k * (frame.camera_pos.y - fog.shape.y);
    float x = k * u.y * len;
    float ln_tau = fog.color_log_density.w - kh + log_span(x, len, k * u.y);
    float t = exp(-exp(ln_tau));
    vec4 c = imageLoad(hdr, ivec2(p));
    imageStore(hdr, ivec2(p), vec4(c.rgb * t + fog.color_log_density.rgb * (1.0 - t), c.a));
    imageStore(transmittance, ivec2(p), vec4(t));
}
