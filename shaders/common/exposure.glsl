// The automatic exposure's constants, shared by exposure.comp (the measurement), tonemap.comp
// and composite.frag (AUTO_EXPOSURE). CPU twin: crates/hadou/src/effects/tonemap.rs.
#ifndef HADOU_EXPOSURE_GLSL
#define HADOU_EXPOSURE_GLSL

const uint EXPOSURE_BINS = 256u;
const float EXPOSURE_LOG2_MIN = -20.0;
const float EXPOSURE_BINS_PER_STOP = 8.0;
const float PERCENTILE_LO = 0.8;
const float PERCENTILE_HI = 0.983;
const vec3 LUMINANCE = vec3(0.2126, 0.7152, 0.0722);
// The measurement reads at most EXPOSURE_SAMPLES_SIDE² pixels: every s-th of each row and column,
// s = ceil(max(width, height) / EXPOSURE_SAMPLES_SIDE), from s / 2 (one workgroup reads them all;
// reading all of a 1080p frame cost 60 ms on lavapipe).
const uint EXPOSURE_SAMPLES_SIDE = 256u;

uint exposure_step(uint width, uint height) {
    return max(1u, (max(width, height) + EXPOSURE_SAMPLES_SIDE - 1u) / EXPOSURE_SAMPLES_SIDE);
}

uint exposure_bin(float y) {
    // NaN, 0 and negatives in the first bin (!(y > 0) is true for NaN); +inf in the last.
    if (!(y > 0.0)) return 0u;
    float b = floor((log2(y) - EXPOSURE_LOG2_MIN) * EXPOSURE_BINS_PER_STOP);
    return uint(clamp(b, 0.0, float(EXPOSURE_BINS - 1u)));
}

float exposure_bin_centre(uint b) {
    return (float(b) + 0.5) / EXPOSURE_BINS_PER_STOP + EXPOSURE_LOG2_MIN;
}

// The tonemap's factor for the adapted log2 luminance l: exposure 1 / (9.6 · 2^l) (EV100 =
// l + 3, exposure = 1 / (1.2 · 2^EV100)) over the pre-exposure 2^pre_log2, its exponent kept
// within f32.
float auto_factor(float l, float pre_log2) {
    return exp2(clamp(-(l + pre_log2), -126.0, 126.0)) / 9.6;
}

// The adapted log2 luminance this frame uses: h + (m − h)·w, exactly m for w = 1 and exactly h
// when m = h (a still scene stays still).
float adapted_log2(float history, float measured, float weight) {
    return history + (measured - history) * weight;
}

#endif
