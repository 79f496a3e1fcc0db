#version 460
// light_id: per texel, the instance id + 1 of the first translucent surface the light reaches (0
// where none), and its light-space distance (TSM's depth).
#include "common/frame.glsl"
#include "common/translucency.glsl"

layout(push_constant) uniform Push { LightViewData view; } push;

layout(location = 0) in vec3 v_world;
layout(location = 1) flat in uint v_instance;

layout(location = 0) out uint out_id;
layout(location = 1) out float out_z;

void main() {
    out_id = v_instance + 1u;
    out_z = light_project(push.view, v_world).z;
}
