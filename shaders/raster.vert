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

// The position relative to the camera, as the lights' positions are (one varying: on lavapipe a
// varying costs per fragment; docs/PERFORMANCE.md, "Positions relative to the camera").
layout(location = 0) out vec3 v_relative;
layout(location = 1) out vec3 v_normal;
layout(location = 2) flat out uvec2 v_ids;   // the G-buffer ids: instance id + 1, material id
layout(location = 3) flat out vec4 v_albedo; // a: the base colour's alpha
layout(location = 4) flat out vec4 v_emission; // rgb: emission; a: alpha cutoff
#ifdef VERTEX_ATTRIBUTES
layout(location = 5) out vec4 v_color;
layout(location = 6) out vec4 v_texcoords;
#endif
#ifdef MOTION
// A temporal upscaler's motion (common/motion.glsl): the vertex now and in the previous frame (its
// mesh's previous positions, its instance's previous model matrix, the previous camera),
// unjittered, both relative to the camera (MotionFrame::models: this frame's model matrix, then
// the previous frame's, T(−camera)·M composed in f64: far from the origin a world position in f32
// would be rounded to ε of its size, the motion with it).
layout(location = 7) in vec3 in_prev_position;
layout(set = 0, binding = 3, std140) uniform MotionBlock { MotionUniforms motion; };
layout(set = 0, binding = 4, std430) readonly buffer MotionModels { mat4 motion_models[]; };
layout(location = 7) out vec4 v_clip;
layout(location = 8) out vec4 v_prev_clip;
#endif

void main() {
    InstanceData inst = instances[gl_InstanceIndex];
    // Relative to the camera, what frame.view_proj takes: the f32 translation and camera position
    // are each within half an ulp of their f64 values, so near each other their difference is
    // exact in f32 (Sterbenz), and what f32 rounded off both is added after. Far from the origin a
    // world position in f32 is rounded to ε of its size (10⁻² of a unit at 10⁵), and the
    // coverage and distance with it. `precise`: kept as written (no reassociation).
    precise vec3 offset = (inst.model[3].xyz - frame.camera_pos.xyz) + (inst.normal_matrix[3].xyz - frame.camera_low.xyz);
    vec3 relative = mat3(inst.model) * in_position + offset;
    v_relative = relative;
    v_normal = mat3(inst.normal_matrix) * in_normal;
    v_ids = uvec2(inst.ids.x + 1u, inst.ids.y);
    v_albedo = materials[inst.ids.y].albedo;
    v_emission = materials[inst.ids.y].emission;
#ifdef VERTEX_ATTRIBUTES
    v_color = in_color;
    v_texcoords = in_texcoords;
#endif
#ifdef MOTION
    v_clip = motion.view_proj * (motion_models[2 * gl_InstanceIndex] * vec4(in_position, 1.0));
    v_prev_clip = motion.prev_view_proj * (motion_models[2 * gl_InstanceIndex + 1] * vec4(in_prev_position, 1.0));
#endif
    gl_Position = frame.view_proj * vec4(relative, 1.0);
}
