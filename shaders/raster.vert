#version 460
// raster: instanced draws, one per mesh; gl_InstanceIndex includes the draw's firstInstance.
// The instance's and its material's data are read here, once per vertex, and handed to the
// fragments as flat varyings: on lavapipe a fragment shader runs under a coverage mask, where a
// storage-buffer load is a loop over the lanes (src/gpu/texel_buffer.rs), per fragment.
#include "common/frame.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;

layout(set = 0, binding = 0, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 1, std430) readonly buffer Instances { InstanceData instances[]; };
layout(set = 0, binding = 2, std430) readonly buffer Materials { MaterialData materials[]; };

layout(location = 0) out vec3 v_world;
layout(location = 1) out vec3 v_normal;
layout(location = 2) flat out uvec2 v_ids;   // the G-buffer ids: instance id + 1, material id
layout(location = 3) flat out vec3 v_albedo;

void main() {
    InstanceData inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(in_position, 1.0);
    v_world = world.xyz;
    v_normal = mat3(inst.normal_matrix) * in_normal;
    v_ids = uvec2(inst.ids.x + 1u, inst.ids.y);
    v_albedo = materials[inst.ids.y].albedo.rgb;
    gl_Position = frame.view_proj * world;
}
