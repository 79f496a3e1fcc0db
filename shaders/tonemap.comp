#version 460
// tonemap: exposure, ACES filmic (Narkowicz 2015 fit), sRGB encoding. CPU twin: src/effects/tonemap.rs.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D hdr;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D ldr;

layout(push_constant) uniform Params {
    float exposure;
    uint width;
    uint height;
} params;

#include "common/tonemap.glsl"

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= params.width || p.y >= params.height) return;
    vec3 c = imageLoad(hdr, ivec2(p)).rgb * params.exposure;
    // Never let a NaN or negative value reach the output (NaN first: clamp(NaN) is undefined).
    // Clamp at ACES_WHITE before the curve: aces is 1.0 from x ≈ 7.24 on, and its x² would
    // overflow (inf/inf = NaN, black) for x ≥ 1.8e19 or +inf (RGBA16F past 65504).
    if (any(isnan(c))) c = vec3(0.0);
    c = clamp(c, vec3(0.0), vec3(ACES_WHITE));
    imageStore(ldr, ivec2(p), vec4(srgb_encode(aces(c)), 1.0));
}
