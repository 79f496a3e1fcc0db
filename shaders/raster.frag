#version 460
// raster: Lambert + ambient under the scene's directional lights, plus emission and the
// G-buffer. The base colour is the material's albedo, times the vertex colour with
// VERTEX_ATTRIBUTES; a fragment whose alpha is below the material's cutoff (alphaMode MASK) is
// not drawn. Without them (TOML materials, meshes without attributes) the colour is the albedo
// itself, nothing is discarded (alpha ≥ 0 = cutoff) and the emission added is exactly 0.
#include "common/frame.glsl"

layout(set = 0, binding = 0, std140) uniform FrameBlock { FrameUniforms frame; };

layout(location = 0) in vec3 v_world;
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

void main() {
    vec4 base = v_albedo;
#ifdef VERTEX_ATTRIBUTES
    base *= v_color;
#endif
    if (base.a < v_emission.a) discard;
    vec3 to_camera = frame.camera_pos.xyz - v_world;
    vec3 n = normalize(v_normal);
    // Shade the side the camera sees (open meshes, mirrored instances): no culling, no winding assumption.
    if (dot(n, to_camera) < 0.0) n = -n;
    vec3 light = frame.ambient.rgb;
    // A do-while: lavapipe runs a for loop's body once more, masked, to find it done.
    uint i = 0u;
    do {
        vec3 add = max(dot(n, -frame.lights[i].direction.xyz), 0.0) * frame.lights[i].radiance.rgb;
        light += i < frame.counts.x ? add : vec3(0.0);
        ++i;
    } while (i < frame.counts.x);
    out_hdr = vec4(base.rgb * light + v_emission.rgb, 1.0);
    out_normal = vec4(n, 1.0);
    out_ids = v_ids;
    out_distance = length(to_camera);
}
