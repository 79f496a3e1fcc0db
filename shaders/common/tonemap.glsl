// The tonemap curve and the sRGB encoding, once: tonemap.comp (headless) and composite.frag
// (embedded) both use them. CPU twin: crates/hadou/src/effects/tonemap.rs.
#ifndef HADOU_TONEMAP_GLSL
#define HADOU_TONEMAP_GLSL

// crates/hadou/src/effects/tonemap.rs ACES_WHITE: aces(64) = 1, and 64² cannot overflow.
const float ACES_WHITE = 64.0;

// ACES filmic (Narkowicz 2015 fit).
vec3 aces(vec3 x) {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 srgb_encode(vec3 c) {
    vec3 lo = c * 12.92;
    vec3 hi = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
    return mix(hi, lo, lessThanEqual(c, vec3(0.0031308)));
}

#endif
