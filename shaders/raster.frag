#version 460
// raster: Lambert + ambient under the scene's lights (directional, point, spot: light_arriving
// in common/frame.glsl), plus emission and the
// G-buffer. The base colour is the material's albedo, times the vertex colour with
// VERTEX_ATTRIBUTES; a fragment whose alpha is below the material's cutoff (alphaMode MASK) is
// not drawn. Without them (TOML materials, meshes without attributes) the colour is the albedo
// itself, nothing is discarded (alpha ≥ 0 = cutoff) and the emission added is exactly 0.
// MATERIAL_TEXTURES (with VERTEX_ATTRIBUTES; crates/hadou/src/scene_textures.rs): the base colour is also
// multiplied by the base-colour texture and the emission by the emissive texture, each sampled
// at its coordinate set mapped by KHR_texture_transform; both are sampled before the mask's
// discard (implicit derivatives need every fragment of the quad).
#include "common/frame.glsl"
#ifdef MOTION
#include "common/motion.glsl"
#endif

layout(set = 0, binding = 0, std140) uniform FrameBlock { FrameUniforms frame; };

const float HALF_MAX = 65504.0;

layout(location = 0) in vec3 v_relative;  // relative to the camera (raster.vert)
layout(location = 1) in vec3 v_normal;
layout(location = 2) flat in uvec2 v_ids;
layout(location = 3) flat in vec4 v_albedo;
layout(location = 4) flat in vec4 v_emission;
#ifdef VERTEX_ATTRIBUTES
layout(location = 5) in vec4 v_color;
layout(location = 6) in vec4 v_texcoords;
#endif

layout(location = 0) out vec4 out_hdr;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out uvec2 out_ids;
layout(location = 3) out float out_distance;
#ifdef MOTION
// Interpolated clip coordinates: exact at the fragment (clip is linear in the object's position).
layout(location = 7) in vec4 v_clip;
layout(location = 8) in vec4 v_prev_clip;
layout(location = 4) out vec2 out_motion;
#endif

#ifdef MATERIAL_TEXTURES
struct TexturePush {
    vec4 base_u;
    vec4 base_v;
    vec4 emissive_u;
    vec4 emissive_v;
    uvec4 flags;
};
layout(set = 1, binding = 0) uniform sampler2D base_texture;
layout(set = 1, binding = 1) uniform sampler2D emissive_texture;
// TexturePush (crates/hadou/src/scene_textures.rs): each texture's 2x3 coordinate map as its two rows;
// flags x, y: base, emissive present; z, w: their coordinate sets.
layout(push_constant) uniform TexturePushBlock { TexturePush textures; };

vec2 mapped(vec4 row_u, vec4 row_v, uint set) {
    vec3 uv = vec3(set == 0u ? v_texcoords.xy : v_texcoords.zw, 1.0);
    return vec2(dot(row_u.xyz, uv), dot(row_v.xyz, uv));
}
#endif

void main() {
    vec4 base = v_albedo;
#ifdef VERTEX_ATTRIBUTES
    base *= v_color;
#endif
    vec3 emission = v_emission.rgb;
#ifdef MATERIAL_TEXTURES
    vec4 base_texel = texture(base_texture, mapped(textures.base_u, textures.base_v, textures.flags.z));
    vec4 emissive_texel =
        texture(emissive_texture, mapped(textures.emissive_u, textures.emissive_v, textures.flags.w));
    if (textures.flags.x != 0u) base *= base_texel;
    if (textures.flags.y != 0u) emission *= emissive_texel.rgb;
#endif
    if (base.a < v_emission.a) discard;
    vec3 to_camera = -v_relative;
    vec3 n = normalize(v_normal);
    // Shade the side the camera sees (open meshes, mirrored instances): no culling, no winding assumption.
    if (dot(n, to_camera) < 0.0) n = -n;
    vec3 light = frame.ambient.rgb;
    // A do-while: lavapipe runs a for loop's body once more, masked, to find it done.
    uint i = 0u;
    do {
        vec3 l;
        vec3 arriving = light_arriving(frame.lights[i], v_relative, l);
        vec3 add = max(dot(n, l), 0.0) * arriving;
        light += i < frame.counts.x ? add : vec3(0.0);
        ++i;
    } while (i < frame.counts.x);
    // Capped at RGBA16F's largest (a point light next to a surface): never +inf in the target.
    out_hdr = vec4(min(base.rgb * light + emission, vec3(HALF_MAX)), 1.0);
    out_normal = vec4(n, 1.0);
    out_ids = v_ids;
    out_distance = length(to_camera);
#ifdef MOTION
    vec2 size = vec2(frame.counts.yz);
    out_motion = motion_pixel(v_prev_clip, size) - motion_pixel(v_clip, size);
#endif
}
