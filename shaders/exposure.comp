#version 460
// exposure: the automatic exposure's measurement (issue 26). One workgroup reads the (sampled)
// pre-exposed HDR frame into a histogram of log2 luminance (256 bins of 1/8 stop from 2^-20), one
// for every pixel and one for the pixels that show a surface (ids.x != 0), and writes the log2
// of the scene's average luminance: the mean bin centre between the 80th and 98.3rd percentiles
// of the surfaces (of every pixel when no surface is seen), minus log2 of the pre-exposure. Integer
// atomics only: the same frame gives the same bits. tonemap.comp (AUTO_EXPOSURE) reads it in the
// same frame. CPU twin: crates/hadou/src/effects/tonemap.rs (`measure`, `histogram_log2_average`).
layout(local_size_x = 256) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D hdr;
layout(set = 0, binding = 2, rg32ui) uniform readonly uimage2D ids;
layout(set = 0, binding = 3) buffer Measured {
    float log2_average;
    uint pixels;
    uint surfaces;
    uint unused;
} measured;

// Push constants as tonemap.comp's (crates/hadou/src/passes/tonemap.rs `Params`).
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

shared uint all_bins[EXPOSURE_BINS];
shared uint surface_bins[EXPOSURE_BINS];

void main() {
    uint i = gl_LocalInvocationIndex;
    all_bins[i] = 0u;
    surface_bins[i] = 0u;
    barrier();
    // The pixels measured: every s-th of each row and column (common/exposure.glsl).
    uint s = exposure_step(params.width, params.height);
    uint first = s / 2u;
    uint cols = (params.width - first + s - 1u) / s;
    uint rows = (params.height - first + s - 1u) / s;
    uint n = cols * rows;
    for (uint p = i; p < n; p += EXPOSURE_BINS) {
        ivec2 q = ivec2(first + (p % cols) * s, first + (p / cols) * s);
        uint b = exposure_bin(dot(imageLoad(hdr, q).rgb, LUMINANCE));
        atomicAdd(all_bins[b], 1u);
        if (imageLoad(ids, q).x != 0u) atomicAdd(surface_bins[b], 1u);
    }
    barrier();
    if (i != 0u) return;
    uint surfaces = 0u;
    for (uint b = 0u; b < EXPOSURE_BINS; b++) surfaces += surface_bins[b];
    float total = float(surfaces > 0u ? surfaces : n);
    float lo = PERCENTILE_LO * total;
    float hi = PERCENTILE_HI * total;
    float below = 0.0, sum = 0.0, weight = 0.0;
    for (uint b = 0u; b < EXPOSURE_BINS; b++) {
        float above = below + float(surfaces > 0u ? surface_bins[b] : all_bins[b]);
        float wb = max(min(above, hi) - max(below, lo), 0.0);
        sum += wb * exposure_bin_centre(b);
        weight += wb;
        below = above;
    }
    float average = weight > 0.0 ? sum / weight : EXPOSURE_LOG2_MIN;
    measured.log2_average = average - params.pre_log2;
    measured.pixels = n;
    measured.surfaces = surfaces;
    measured.unused = 0u;
}
