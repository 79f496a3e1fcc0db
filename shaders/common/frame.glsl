// Structs shared with Rust: src/passes/gpu_structs.rs. Their sizes are checked against this
// layout whenever they are bound (src/gpu/reflect.rs), offsets asserted there.
#ifndef HADOU_FRAME_GLSL
#define HADOU_FRAME_GLSL

#define MAX_LIGHTS 8

struct Light {
    vec4 direction;   // xyz: unit direction the light travels
    vec4 radiance;    // rgb: colour × intensity
};

struct FrameUniforms {
    mat4 view_proj;
    vec4 camera_pos;  // xyz
    vec4 ambient;     // rgb
    vec4 background;  // rgb
    uvec4 counts;     // x: lights, y: width, z: height, w: instances
    Light lights[MAX_LIGHTS];
    // The camera's ray frame for camera_pixel_ray (common/camera.glsl): right and up scaled by
    // the lens, w their ndc offsets; ray_forward.w is the camera's far distance.
    vec4 ray_right;
    vec4 ray_up;
    vec4 ray_forward;
};

struct InstanceData {
    mat4 model;
    mat4 normal_matrix;  // M^-T in the upper 3x3
    uvec4 ids;           // x: instance id (scene order), y: material id
};

#define MATERIAL_LAMBERT 0u
#define MATERIAL_TRANSLUCENT 1u
#define THICKNESS_LUT 0u
#define THICKNESS_TSM 1u
#define THICKNESS_PEEL 2u
#define THICKNESS_PAIRS 3u

struct MaterialData {
    vec4 albedo;         // rgb; a: the base colour's alpha
    uvec4 kind;          // x: MATERIAL_*; y (translucent): THICKNESS_*
    vec4 sigma;          // rgb (translucent): extinction per world unit
    vec4 emission;       // rgb: added to the shaded colour; a: alpha cutoff (0: opaque)
};

#endif
