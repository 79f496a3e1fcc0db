#version 460
// light_id: per texel, (instance id + 1, surface voxel) of the first translucent surface the light
// reaches, and its light-space distance (TSM's depth).
#include "common/frame.glsl"

layout(set = 0, binding = 1, std430) readonly buffer Grid { uint grid[]; };
#define HADOU_TRANSLUCENCY_GRID
#include "common/translucency.glsl"

layout(set = 0, binding = 2, std430) readonly buffer Luts { LutRecord luts[]; };
layout(set = 0, binding = 3, std430) readonly buffer Translucent { TranslucentInstance translucent[]; };

layout(push_constant) uniform Push { LightViewData view; } push;

// The shader writes no depth: test before shading, so hidden fragments skip the voxel search.
layout(early_fragment_tests) in;

layout(location = 0) in vec3 v_world;
layout(location = 1) in vec3 v_object;
layout(location = 2) flat in uint v_instance;

layout(location = 0) out uvec2 out_ids;
layout(location = 1) out float out_z;

void main() {
    uint lut = translucent[v_instance].info.x;
    uint voxel = lut == NO_LUT ? NO_LUT : surface_voxel_at(luts[lut], v_object);
    out_ids = uvec2(v_instance + 1u, voxel);
    out_z = light_project(push.view, v_world).z;
}
