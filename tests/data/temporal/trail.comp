#version 460
// A temporal test effect (tests/temporal_effect.rs): an exponential moving average per pixel,
// trail = weight · trail of the previous frame + (1 − weight) · level · (x + 1), reading the
// image's previous frame (Target::Previous) and writing this frame's (Target::Custom).
#include "common/frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, r32f) uniform readonly image2D previous;
layout(set = 0, binding = 1, r32f) uniform writeonly image2D current;
layout(set = 0, binding = 2, std140) uniform FrameBlock { FrameUniforms frame; };

layout(push_constant) uniform TrailParams {
    vec4 p;  // x: weight, y: level
} t;

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= frame.counts.y || p.y >= frame.counts.z) return;
    float x = t.p.y * float(p.x + 1u);
    float before = imageLoad(previous, ivec2(p)).r;
    imageStore(current, ivec2(p), vec4(t.p.x * before + (1.0 - t.p.x) * x, 0.0, 0.0, 0.0));
}
