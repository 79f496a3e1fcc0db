#version 460
// tonemap: exposure, ACES filmic (Narkowicz 2015 fit), sRGB encoding. CPU twin: crates/hadou/src/effects/tonemap.rs.
// AUTO_EXPOSURE: the factor comes from exposure.comp's measurement of this frame, moved from the
// adapted luminance of earlier frames by params.weight (common/exposure.glsl).
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D hdr;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D ldr;

// Shared with exposure.comp (crates/hadou/src/passes/tonemap.rs `Params`).
layout(push_constant) uniform Params {
    // Fixed exposure: exposure / pre-exposure, what the HDR value is multiplied by.
    float exposure;
    uint width;
    uint height;
    // AUTO_EXPOSURE: log2 of the frame's pre-exposure (HDR = scene-linear × 2^pre_log2), the
    // adapted log2 luminance of earlier frames, and how far this frame moves from it to its own
    // measurement (1: its own, as a headless frame).
    float pre_log2;
    float history;
    float weight;
} params;

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
    float l = adapted_log2(params.history, measured.log2_average, params.weight);
    float exposure = auto_factor(l, params.pre_log2);
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
