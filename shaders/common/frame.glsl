// Structs shared with Rust: crates/hadou/src/passes/gpu_structs.rs. Their sizes are checked against this
// layout whenever they are bound (crates/hadou-gpu/src/reflect.rs), offsets asserted there.
#ifndef HADOU_FRAME_GLSL
#define HADOU_FRAME_GLSL

#define MAX_LIGHTS 8

struct Light {
    vec4 direction;   // xyz: unit direction a directional light travels, a spot light's axis
    vec4 radiance;    // rgb: colour × intensity (point, spot: × candela / pi); w: 1 / range^2 (0: none)
    vec4 position;    // xyz: a point or spot light's position relative to the camera; w: 1 for
                      // them, 0 directional
    vec4 cone;        // x, y: the spot cone's scale and offset of cos(theta); point: 0, 1
};

struct FrameUniforms {
    mat4 view_proj;   // takes positions relative to the camera (world − camera; composed in f64)
    vec4 camera_pos;  // xyz: the camera's position in f32 (camera_low: what f32 rounded off)
    vec4 ambient;     // rgb
    vec4 background;  // rgb
    uvec4 counts;     // x: lights, y: width, z: height, w: instances
    Light lights[MAX_LIGHTS];
    // The camera's ray frame for camera_pixel_ray (common/camera.glsl): right and up scaled by
    // the lens, w their ndc offsets; ray_forward.w is the camera's far distance.
    vec4 ray_right;
    vec4 ray_up;
    vec4 ray_forward;
    vec4 camera_low;  // xyz: the camera's position − camera_pos.xyz
};

// Twin: Light and LOCAL_LIGHT_* in crates/hadou/src/scene/model.rs, effects::shading::LocalLight.
#define LOCAL_LIGHT_D2_MIN 1e-30
#define LOCAL_LIGHT_MAX 1e30

// The radiance of `light` arriving at surface point `world` (to be multiplied by max(n.l, 0)), and
// in `l` the unit vector from the point toward the light. A directional light: -direction and its
// radiance, as they are. A point or spot light (glTF KHR_lights_punctual): the inverse square with
// d^2 floored at LOCAL_LIGHT_D2_MIN (at the light itself l = 0: no light, no NaN), glTF's range
// window clamp(1 - (d/range)^4, 0, 1) and its spot attenuation clamp(cos(theta)*scale + offset,
// 0, 1)^2, the product capped at LOCAL_LIGHT_MAX (finite in any sum and times any albedo).
// `at`: the surface point relative to the camera, as the lights' positions are (world − camera:
// far from the origin both keep ε of their distance from the camera).
vec3 light_arriving(Light light, vec3 at, out vec3 l) {
    if (light.position.w == 0.0) {
        l = -light.direction.xyz;
        return light.radiance.rgb;
    }
    vec3 v = light.position.xyz - at;
    float d2 = max(dot(v, v), LOCAL_LIGHT_D2_MIN);
    l = v * inversesqrt(d2);
    float t = d2 * light.radiance.w;
    float window = clamp(1.0 - t * t, 0.0, 1.0);
    float cone = clamp(dot(light.direction.xyz, -l) * light.cone.x + light.cone.y, 0.0, 1.0);
    return min(light.radiance.rgb * (window * cone * cone / d2), vec3(LOCAL_LIGHT_MAX));
}

struct InstanceData {
    mat4 model;
    mat4 normal_matrix;  // M^-T in the upper 3x3; [3].xyz: the translation − model[3].xyz
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
