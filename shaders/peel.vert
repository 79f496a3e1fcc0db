#version 460
// peel: the instances drawn with thickness = "peel" seen from the first directional light, with
// light_id's orthographic view (effects::translucency::LightView), one draw per run of them.
// gl_InstanceIndex is the instance's slot in the scene's instance table.
#include "common/frame.glsl"
#include "common/translucency.glsl"

layout(location = 0) in vec3 in_position;

layout(set = 0, binding = 0, std430) readonly buffer Instances { InstanceData instances[]; };

// LightViewData in crates/hadou/src/passes/translucency.rs (size checked at pipeline creation).
layout(push_constant) uniform Push { LightViewData view; } push;

layout(location = 0) out float v_z;
layout(location = 1) flat out uint v_instance;
layout(location = 2) flat out uint v_mirrored;

void main() {
    InstanceData inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(in_position, 1.0);
    vec3 l = light_project(push.view, world.xyz);
    v_z = l.z;
    v_instance = inst.ids.x;
    // A mirroring transform turns the winding, so the facing test below turns with it.
    v_mirrored = determinant(mat3(inst.model)) < 0.0 ? 1u : 0u;
    gl_Position = vec4(l.xy, l.z / (2.0 * push.view.centre.w), 1.0);
}
