#version 460
// composite: hadou's HDR result over the game's colour target, premultiplied alpha (the blend is
// src + (1 − src.a)·dst): α = 1 where hadou drew a surface (over), 0 elsewhere, where only the
// wave's glow remains (added). Tonemap as in tonemap.comp (CPU twin crates/hadou/src/effects/tonemap.rs).
// MODE (a define: one pipeline per target format, `composite::mode_for`) picks what is written:
// 0 tonemapped linear (an _SRGB target encodes), 1 tonemapped and sRGB-encoded (_UNORM), 2 linear
// HDR × exposure (float targets: the game tonemaps). A define, not a push constant: lavapipe runs
// both sides of every branch, so the pow() of an encode no target of that format needs was paid
// by every pixel (docs/PERFORMANCE.md, "Embedding").
// AUTO_EXPOSURE: the factor from exposure.comp's measurement of this frame (dispatched by the
// pass before it draws), moved from the adapted luminance of earlier frames (common/exposure.glsl).
layout(set = 0, binding = 0, rgba16f) uniform readonly image2D hdr;
layout(location = 0) out vec4 out_color;

// The pass always defines MODE; the default lets the file compile on its own (the viewer's
// shader check compiles every file without defines).
#ifndef MODE
#define MODE 0
#endif

layout(push_constant) uniform Params {
    float exposure;
    // AUTO_EXPOSURE: as tonemap.comp's.
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
    vec4 c = imageLoad(hdr, ivec2(gl_FragCoord.xy));
#ifdef AUTO_EXPOSURE
    float l = adapted_log2(params.history, measured.log2_average, params.weight);
    float exposure = auto_factor(l, params.pre_log2);
#else
    float exposure = params.exposure;
#endif
    // As tonemap.comp: NaN guard first (clamp(NaN) is undefined), then clamp at ACES_WHITE
    // before the curve, whose x² overflows for x ≥ 1.8e19 or +inf. Mode 2 stays linear.
    vec3 rgb = c.rgb * exposure;
    if (any(isnan(rgb))) rgb = vec3(0.0);
    rgb = max(rgb, vec3(0.0));
#if MODE != 2
    rgb = aces(min(rgb, vec3(ACES_WHITE)));
#endif
#if MODE == 1
    rgb = srgb_encode(rgb);
#endif
    float alpha = isnan(c.a) ? 0.0 : clamp(c.a, 0.0, 1.0);
    out_color = vec4(rgb, alpha);
}
