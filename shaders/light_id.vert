#version 460
// light_id: the translucent instances seen from the first directional light (orthographic view
// fitted to their bounding sphere). One draw per run of translucent instances; gl_InstanceIndex
// is the instance's slot in the scene's instance table.
#include "common/frame.glsl"
#include "common/translucency.glsl"

layout(location = 0) in vec3 in_position;

layout(set = 0, binding = 0, std430) readonly buffer Instances { InstanceData instances[]; };

// LightViewData in crates/hadou/src/passes/translucency.rs (size checked at pipeline creation).
layout(push_constant) uniform Push { LightViewData view; } push;

layout(location = 0) out vec3 v_world;
layout(location = 1) flat out uint v_instance;

void main() {
    InstanceData inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(in_position, 1.0);
    v_world = world.xyz;
    v_instance = inst.ids.x;
    vec3 l = light_project(push.view, world.xyz);
    // Depth in [0, 1]: 0 where the light enters the fitted sphere (LESS keeps the first surface).
    gl_Position = vec4(l.xy, l.z / (2.0 * push.view.centre.w), 1.0);
}
