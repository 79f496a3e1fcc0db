#version 460
// depth_out: hadou's nearest surfaces written into the game's depth buffer, in the game's
// convention, so the game's later passes (particles, UI in the world) are hidden behind them.
// Where hadou drew a surface (its instances, metaballs: ids.x != 0) the view depth along the
// camera's forward axis is z = distance / |pixel ray direction| (the ray direction has forward
// component 1) and the stored value d = -A + B / z; elsewhere the fragment is discarded and the
// game's depth is kept. CPU twin (f64): crates/hadou/src/passes/depth_import.rs::store_depth.
#include "common/frame.glsl"
layout(set = 0, binding = 0, rg32ui) uniform readonly uimage2D ids;
layout(set = 0, binding = 1, r32f) uniform readonly image2D distance_image;
// The camera's ray frame and the frame's size (counts.yz).
layout(set = 0, binding = 2, std140) uniform FrameBlock { FrameUniforms frame; };

// Params in crates/hadou/src/passes/depth_out.rs.
layout(push_constant) uniform Params {
    // the game's projection: stored d = -A + B / z
    vec4 planes;
} params;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    if (imageLoad(ids, p).x == 0u) discard;
    float dist = imageLoad(distance_image, p).r;
    float ndc_x = 2.0 * (float(p.x) + 0.5) / float(frame.counts.y) - 1.0;
    float ndc_y = 1.0 - 2.0 * (float(p.y) + 0.5) / float(frame.counts.z);
    vec4 right = frame.ray_right, up = frame.ray_up;
    float ray_scale = length(frame.ray_forward.xyz + (ndc_x + right.w) * right.xyz + (ndc_y + up.w) * up.xyz);
    float z = dist / ray_scale;
    gl_FragDepth = clamp(-params.planes.x + params.planes.y / z, 0.0, 1.0);
}
