#version 460
// raster: instanced draws, one per mesh; gl_InstanceIndex includes the draw's firstInstance.
#include "common/frame.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;

layout(set = 0, binding = 0, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 1, std430) readonly buffer Instances { InstanceData instances[]; };

layout(location = 0) out vec3 v_world;
layout(location = 1) out vec3 v_normal;
layout(location = 2) flat out uint v_slot;

void main() {
    InstanceData inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(in_position, 1.0);
    v_world = world.xyz;
    v_normal = mat3(inst.normal_matrix) * in_normal;
    v_slot = gl_InstanceIndex;
    gl_Position = frame.view_proj * world;
}
