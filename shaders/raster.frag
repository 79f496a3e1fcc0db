#version 460
// raster: Lambert + ambient under the scene's directional lights, plus the G-buffer.
#include "common/frame.glsl"

layout(set = 0, binding = 0, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 1, std430) readonly buffer Instances { InstanceData instances[]; };
layout(set = 0, binding = 2, std430) readonly buffer Materials { MaterialData materials[]; };

layout(location = 0) in vec3 v_world;
layout(location = 1) in vec3 v_normal;
layout(location = 2) flat in uint v_slot;

layout(location = 0) out vec4 out_hdr;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out uvec2 out_ids;
layout(location = 3) out float out_distance;

void main() {
    InstanceData inst = instances[v_slot];
    MaterialData mat = materials[inst.ids.y];
    vec3 to_camera = frame.camera_pos.xyz - v_world;
    vec3 n = normalize(v_normal);
    // Shade the side the camera sees (open meshes, mirrored instances): no culling, no winding assumption.
    if (dot(n, to_camera) < 0.0) n = -n;
    vec3 light = frame.ambient.rgb;
    for (uint i = 0u; i < frame.counts.x; ++i) {
        light += max(dot(n, -frame.lights[i].direction.xyz), 0.0) * frame.lights[i].radiance.rgb;
    }
    out_hdr = vec4(mat.albedo.rgb * light, 1.0);
    out_normal = vec4(n, 1.0);
    out_ids = uvec2(inst.ids.x + 1u, inst.ids.y);
    out_distance = length(to_camera);
}
