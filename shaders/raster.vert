#version 460
// raster: instanced draws, one per mesh; gl_InstanceIndex includes the draw's firstInstance.
// The instance's and its material's data are read here, once per vertex, and handed to the
// fragments as flat varyings: on lavapipe a fragment shader runs under a coverage mask, where a
// storage-buffer load is a loop over the lanes (crates/hadou-gpu/src/texel_buffer.rs), per fragment.
// VERTEX_ATTRIBUTES (the pipeline for meshes with glTF vertex attributes, crates/hadou/src/passes/raster.rs):
// a second vertex binding with the vertex colour and both texture coordinate sets.
#include "common/frame.glsl"
#ifdef MOTION
#include "common/motion.glsl"
#endif

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
#ifdef VERTEX_ATTRIBUTES
layout(location = 2) in vec4 in_color;      // COLOR_0 (white when the mesh has none)
layout(location = 3) in vec4 in_texcoords;  // xy: TEXCOORD_0, zw: TEXCOORD_1
#endif

layout(set = 0, binding = 0, std140) uniform FrameBlock { FrameUniforms frame; };
layout(set = 0, binding = 1, std430) readonly buffer Instances { InstanceData instances[]; };
layout(set = 0, binding = 2, std430) readonly buffer Materials { MaterialData materials[]; };

layout(location = 0) out vec3 v_world;
layout(location = 1) out vec3 v_normal;
layout(location = 2) flat out uvec2 v_ids;   // the G-buffer ids: instance id + 1, material id
layout(location = 3) flat out vec4 v_albedo; // a: the base colour's alpha
layout(location = 4) flat out vec4 v_emission; // rgb: emission; a: alpha cutoff
#ifdef VERTEX_ATTRIBUTES
layout(location = 5) out vec4 v_color;
layout(location = 6) out vec4 v_texcoords;
#endif
#ifdef MOTION
// A temporal upscaler's motion (common/motion.glsl): the vertex in the previous frame (its mesh's
// previous positions, its instance's previous model matrix, the previous camera), unjittered.
layout(location = 7) in vec3 in_prev_position;
layout(set = 0, binding = 3, std140) uniform MotionBlock { MotionUniforms motion; };
layout(set = 0, binding = 4, std430) readonly buffer PrevModels { mat4 prev_models[]; };
layout(location = 7) out vec4 v_clip;
layout(location = 8) out vec4 v_prev_clip;
#endif

void main() {
    InstanceData inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(in_position, 1.0);
    v_world = world.xyz;
    v_normal = mat3(inst.normal_matrix) * in_normal;
    v_ids = uvec2(inst.ids.x + 1u, inst.ids.y);
    v_albedo = materials[inst.ids.y].albedo;
    v_emission = materials[inst.ids.y].emission;
#ifdef VERTEX_ATTRIBUTES
    v_color = in_color;
    v_texcoords = in_texcoords;
#endif
#ifdef MOTION
    v_clip = motion.view_proj * world;
    v_prev_clip = motion.prev_view_proj * (prev_models[gl_InstanceIndex] * vec4(in_prev_position, 1.0));
#endif
    gl_Position = frame.view_proj * world;
}
