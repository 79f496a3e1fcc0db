#version 460
// tonemap: exposure, ACES filmic (Narkowicz 2015 fit), sRGB encoding. CPU twin: src/effects/tonemap.rs.
// AUTO_EXPOSURE: the factor comes from exposure.comp's measurement of this frame, moved from the
// adapted luminance of earlier frames by params.weight (common/exposure.glsl).
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D hdr;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D ldr;

#include "common/exposure.glsl"
#include "common/tonemap.glsl"

#ifdef AUTO_EXPOSURE
layout(set = 0, binding = 3) readonly buffer Measured {
    float log2_average;
    uint pixels;
    uint surfaces;
    uint unused;
} measured;
#endif

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= params.width || p.y >= params.height) return;
#ifdef AUTO_EXPOSURE
    // h + (m − h)·w: exactly m for w = 1, exactly h when m = h (a still scene stays still).
    float l = params.history + (measured.log2_average - params.history) * params.weight;
    float exposure = auto_factor(l);
#else
    float exposure = params.exposure;
#endif
    vec3 c = imageLoad(hdr, ivec2(p)).rgb * exposure;
    // Never let a NaN or negative value reach the output (NaN first: clamp(NaN) is undefined).
    // Clamp at ACES_WHITE before the curve: aces is 1.0 from x ≈ 7.24 on, and its x² would
    // overflow (inf/inf = NaN, black) for x ≥ 1.8e19 or +inf (RGBA16F past 65504).
    if (any(isnan(c))) c = vec3(0.0);
    c = clamp(c, vec3(0.0), vec3(ACES_WHITE));
    imageStore(ldr, ivec2(p), vec4(srgb_encode(aces(c)), 1.0));
}
