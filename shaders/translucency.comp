#version 460
// translucency (seed 003): for each pixel whose surface is a translucent instance, the thickness d
// of material the light crossed to reach it, and HDR += w · L · albedo · exp(-σ·d) per channel,
// w = max(n·l, 0) the exit weight (effects::translucency::exit_weight: no transmitted light on
// faces the light reaches directly, whose light the raster's Lambert term already counts).
//   TSM: d = z(P) - z(entry), the light-space distances of the shaded point P and of the first
//        surface the light reaches on the same instance (cavities and gaps count as material).
//   LUT: d = |P - entry| times the inside fraction the instance's thickness field decodes along
//        entry -> P in object space (lut_inside_fraction); entry lies on P's own light ray, so
//        |M(b - a)| = z(P) - z(entry).
//   pairs: d = |P - entry| times the fraction the seed's pair table gives for the surface voxels
//        of entry and P (pair_inside_fraction, WITH_PAIRS: the scene's tables hold a pair table).
// Fallbacks are documented in crates/hadou/src/passes/translucency.rs. CPU twin: crates/hadou/src/effects/translucency.rs.
// Dispatched over `rect` only (the pixels that can show a translucent instance: lavapipe runs the
// whole shader for every 8-lane group, taken branches or not). WITH_LUT (an instance reads a
// LUT) and WITH_PEEL (one reads peel lists) compile those paths in only where the scene has them,
// for the same reason; with FILL_ONLY defined, the variant
// that writes +inf thickness over the whole frame first when `rect` is not all of it.
#include "common/camera.glsl"
#include "common/frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// The fields, LutRecords and TranslucentInstances as texel buffers: inside a branch, on lavapipe,
// a storage-buffer load is a loop over the lanes (crates/hadou-gpu/src/texel_buffer.rs).
layout(set = 0, binding = 7) uniform usamplerBuffer field_texels;
layout(set = 0, binding = 8) uniform usamplerBuffer lut_texels;
layout(set = 0, binding = 9) uniform usamplerBuffer translucent_texels;
uint field_word(uint i) { return texelFetch(field_texels, int(i)).x; }
#ifdef WITH_LUT
#define HADOU_TRANSLUCENCY_FIELD
#endif
#include "common/translucency.glsl"

// Keep in sync with TranslucencyParams in crates/hadou/src/passes/translucency.rs. The camera's ray frame and
// position and the frame's size (counts.yz) are the frame's uniforms (binding 12).
struct TranslucencyParams {
    vec4 radiance;  // rgb: the first light's colour × intensity; w: 1 when the scene has a light
    LightViewData view;
    uvec4 dims;     // light map size, scene instances
    uvec4 lut;      // unused
    uvec4 rect;     // the pixels [x, z) × [y, w) that can show a translucent instance (dispatch origin)
};

layout(set = 0, binding = 0, std140) uniform ParamsBlock { TranslucencyParams params; };
layout(set = 0, binding = 1, rg32ui) uniform readonly uimage2D ids_image;
layout(set = 0, binding = 2, r32f) uniform readonly image2D distance_image;
layout(set = 0, binding = 3, rgba16f) uniform image2D hdr;
layout(set = 0, binding = 4, r32ui) uniform readonly uimage2D light_ids;
layout(set = 0, binding = 5, r32f) uniform readonly image2D light_z;
layout(set = 0, binding = 6, r32f) uniform writeonly image2D thickness_image;
layout(set = 0, binding = 10, std430) readonly buffer Materials { MaterialData materials[]; };
layout(set = 0, binding = 11, rgba16f) uniform readonly image2D normal_image;
layout(set = 0, binding = 12, std140) uniform FrameBlock { FrameUniforms frame; };

const float HALF_MAX = 65504.0;

#ifdef WITH_PEEL
layout(set = 0, binding = 13, r32ui) uniform readonly uimage2D peel_counts;
layout(set = 0, binding = 14, rg32ui) uniform readonly uimage2D peel_lists;
#include "common/translucency_peel.glsl"
#endif

#ifdef WITH_PAIRS
// The pair tables (effects::thickness_pairs), R8_UNORM, read by texelFetch.
layout(set = 0, binding = 15) uniform sampler2D pair_table;
#include "common/translucency_pairs.glsl"
#endif

// The texel of the light map nearest to `centre` that holds `instance` (the centre first, then its
// 4 and then its diagonal neighbours), or (-1, -1).
ivec2 own_texel(ivec2 centre, uint instance) {
    const ivec2 order[9] = ivec2[9](ivec2(0, 0), ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1),
                                    ivec2(1, 1), ivec2(-1, 1), ivec2(1, -1), ivec2(-1, -1));
    int last = int(params.dims.x) - 1;
    for (int k = 0; k < 9; ++k) {
        ivec2 t = clamp(centre + order[k], ivec2(0), ivec2(last));
        if (imageLoad(light_ids, t).x == instance + 1u) return t;
    }
    return ivec2(-1);
}

float thickness_at(vec3 P, uint instance, uint mode) {
    vec3 lp = light_project(params.view, P);
    float size = float(params.dims.x);
    ivec2 centre = clamp(ivec2(floor((lp.xy * 0.5 + 0.5) * size)), ivec2(0), ivec2(params.dims.x - 1u));
#ifdef WITH_PEEL
    // peel (common/translucency_peel.glsl); an overflowed list falls back to TSM below.
    if (mode == THICKNESS_PEEL) {
        float d = peel_thickness(centre, instance + 1u, lp.z);
        if (d >= 0.0) return d;
        mode = THICKNESS_TSM;
    }
#endif
    ivec2 t = own_texel(centre, instance);
    if (t.x < 0) {
        // The light reaches P first through another instance: TSM's distance from that surface
        // (everything between counts); through none (a light silhouette texel): no material.
        bool other = imageLoad(light_ids, centre).x != 0u;
        return other ? max(lp.z - imageLoad(light_z, centre).r, 0.0) : 0.0;
    }
    float tsm = max(lp.z - imageLoad(light_z, t).r, 0.0);
    TranslucentInstance ti = translucent_instance_at(translucent_texels, instance);
#ifdef WITH_PAIRS
    // effects::thickness_pairs: the same path a -> b, the cavities from the pair's table entry.
    if (mode == THICKNESS_PAIRS && ti.info.x != NO_LUT && ti.info.z != 0u && tsm > 0.0) {
        LutRecord r = lut_record_at(lut_texels, ti.info.x);
        uvec4 raw = texelFetch(lut_texels, int(3u * ti.info.x + 2u));
        vec3 b = (ti.inverse_model * vec4(P, 1.0)).xyz;
        vec3 a = (ti.inverse_model * vec4(P - params.view.dir.xyz * tsm, 1.0)).xyz;
        return tsm * pair_inside_fraction(r, raw, a, b);
    }
#endif
#ifdef WITH_LUT
    if (mode == THICKNESS_TSM || ti.info.x == NO_LUT || ti.info.z != 0u || !(tsm > 0.0)) return tsm;
    // effects::translucency::lut_thickness: the path from the light's entry a (on P's own light
    // ray) to b = P, less the gaps the field decodes between them.
    LutRecord r = lut_record_at(lut_texels, ti.info.x);
    vec3 b = (ti.inverse_model * vec4(P, 1.0)).xyz;
    vec3 a = (ti.inverse_model * vec4(P - params.view.dir.xyz * tsm, 1.0)).xyz;
    return tsm * lut_inside_fraction(r, a, b);
#else
    // Built without the field's march (no instance of the scene reads a LUT): TSM's distance.
    return tsm;
#endif
}

#ifdef FILL_ONLY
// The pixels outside `rect`: no translucent surface there (run over the whole frame first).
void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= frame.counts.y || p.y >= frame.counts.z) return;
    imageStore(thickness_image, ivec2(p), vec4(uintBitsToFloat(0x7f800000u), 0.0, 0.0, 0.0));
}
#else
void main() {
    uvec2 p = gl_GlobalInvocationID.xy + params.rect.xy;
    if (p.x >= params.rect.z || p.y >= params.rect.w) return;
    uvec2 ids = imageLoad(ids_image, ivec2(p)).xy;
    float d = uintBitsToFloat(0x7f800000u);  // +inf: no translucent surface
    // Instance ids past the scene's instances (metaball groups) have no light map entry.
    if (ids.x != 0u && ids.x <= params.dims.y && params.radiance.w != 0.0) {
        uint instance = ids.x - 1u;
        MaterialData mat = materials[ids.y];
        if (mat.kind.x == MATERIAL_TRANSLUCENT && translucent_instance_at(translucent_texels, instance).info.y != 0u) {
            // The pixel ray as Camera::pixel_ray builds it, to the raster's distance.
            vec3 u =
                camera_pixel_ray(p, frame.counts.yz, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
            vec3 P = frame.camera_pos.xyz + u * imageLoad(distance_image, ivec2(p)).r;
            d = thickness_at(P, instance, mat.kind.y);
            float w = max(dot(imageLoad(normal_image, ivec2(p)).xyz, params.view.dir.xyz), 0.0);
            vec3 light = w * params.radiance.rgb * mat.albedo.rgb * exp(-mat.sigma.rgb * d);
            vec4 c = imageLoad(hdr, ivec2(p));
            imageStore(hdr, ivec2(p), vec4(min(c.rgb + light, vec3(HALF_MAX)), c.a));
        }
    }
    imageStore(thickness_image, ivec2(p), vec4(d, 0.0, 0.0, 0.0));
}
#endif
