#version 460
// light_id: per texel, (instance id + 1, surface voxel) of the first translucent surface the light
// reaches, and its light-space distance (TSM's depth).
#include "common/frame.glsl"

// The nearest grids, LutRecords and TranslucentInstances as texel buffers: in a fragment shader, on
// lavapipe, a storage-buffer load is a loop over the lanes (src/gpu/texel_buffer.rs).
layout(set = 0, binding = 1) uniform usamplerBuffer grid_texels;
layout(set = 0, binding = 2) uniform usamplerBuffer lut_texels;
layout(set = 0, binding = 3) uniform usamplerBuffer translucent_texels;
uint grid_word(uint i) { return texelFetch(grid_texels, int(i)).x; }
#define HADOU_TRANSLUCENCY_GRID
#include "common/translucency.glsl"

layout(push_constant) uniform Push { LightViewData view; } push;

// The shader writes no depth: test before shading, so hidden fragments skip the voxel search.
layout(early_fragment_tests) in;

layout(location = 0) in vec3 v_world;
layout(location = 1) in vec3 v_object;
layout(location = 2) flat in uint v_instance;

layout(location = 0) out uvec2 out_ids;
layout(location = 1) out float out_z;

void main() {
    uint lut = texelFetch(translucent_texels, int(9u * v_instance + 8u)).x;  // TranslucentInstance.info.x
    uint voxel = lut == NO_LUT ? NO_LUT : surface_voxel_at(lut_record_at(lut_texels, lut), v_object);
    out_ids = uvec2(v_instance + 1u, voxel);
    out_z = light_project(push.view, v_world).z;
}
