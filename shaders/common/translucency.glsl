// Structs and lookups shared by light_id.vert/.frag and translucency.comp. Keep in sync with
// crates/hadou/src/passes/translucency.rs (LutRecord, TranslucentInstance, LightViewData; sizes asserted there)
// and crates/hadou/src/effects/translucency.rs (the light view's math).
#ifndef HADOU_TRANSLUCENCY_GLSL
#define HADOU_TRANSLUCENCY_GLSL

#define NO_LUT 0xffffffffu

// One baked thickness field (a mesh at a voxel resolution; effects::thickness_lut).
struct LutRecord {
    vec4 origin;    // xyz: object-space position of corner (0, 0, 0); w: voxel edge h
    uvec4 dims;     // xyz: grid voxels (corners: dims + 1); w: its first word in `fields`
    vec4 scale;     // x: object units per unit of a stored value; y: object units per tau step
};

// Per scene instance (scene order, the G-buffer's instance id).
struct TranslucentInstance {
    mat4 model;
    mat4 inverse_model;
    uvec4 info;     // x: LutRecord index or NO_LUT; y: 1 when the instance's material is translucent
};

// The light's orthographic view (effects::translucency::LightView).
struct LightViewData {
    vec4 centre;    // xyz: C; w: R
    vec4 right;     // xyz
    vec4 up;        // xyz
    vec4 dir;       // xyz: the unit direction the light travels
};

// (x, y) in [-1, 1] across the map, z: the light-space distance in [0, 2R].
vec3 light_project(LightViewData v, vec3 p) {
    vec3 d = p - v.centre.xyz;
    return vec3(dot(d, v.right.xyz) / v.centre.w, dot(d, v.up.xyz) / v.centre.w, dot(d, v.dir.xyz) + v.centre.w);
}

// The records from texel buffers of uints (16-byte texels, floats by uintBitsToFloat; see
// crates/hadou-gpu/src/texel_buffer.rs): a LutRecord is 3 texels, a TranslucentInstance 9.
LutRecord lut_record_at(usamplerBuffer records, uint i) {
    int t = int(3u * i);
    LutRecord r;
    r.origin = uintBitsToFloat(texelFetch(records, t));
    r.dims = texelFetch(records, t + 1);
    r.scale = uintBitsToFloat(texelFetch(records, t + 2));
    return r;
}

TranslucentInstance translucent_instance_at(usamplerBuffer instances, uint i) {
    int t = int(9u * i);
    TranslucentInstance ti;
    for (int k = 0; k < 4; ++k) {
        ti.model[k] = uintBitsToFloat(texelFetch(instances, t + k));
        ti.inverse_model[k] = uintBitsToFloat(texelFetch(instances, t + 4 + k));
    }
    ti.info = texelFetch(instances, t + 8);
    return ti;
}

#ifdef HADOU_TRANSLUCENCY_FIELD
// Needs `uint field_word(uint i)` (word i of the fields) defined before this file is included with
// HADOU_TRANSLUCENCY_FIELD. CPU twin: crates/hadou/src/effects/thickness_lut/march.rs (same steps, same order).

// Keep in sync with effects::thickness_lut (MAX_STEP_VOXELS, FIELD_LIPSCHITZ, MAX_MARCH_STEPS).
const float LUT_MAX_STEP_VOXELS = 0.5;
const float LUT_FIELD_LIPSCHITZ = 2.0;
const int LUT_MAX_MARCH_STEPS = 1024;

// The stored value of corner c (x fastest), sign-extended from its byte.
float lut_corner(LutRecord r, uvec3 c) {
    uint k = c.x + (r.dims.x + 1u) * (c.y + (r.dims.y + 1u) * c.z);
    uint w = field_word(r.dims.w + (k >> 2u));
    return float(bitfieldExtract(int(w), int((k & 3u) * 8u), 8));
}

// tau of the cell holding object point p (ThicknessLut::tau_at): bytes after the field's words.
float lut_tau(LutRecord r, vec3 p) {
    vec3 g = (p - r.origin.xyz) / r.origin.w;
    g = vec3(isnan(g.x) ? 0.0 : g.x, isnan(g.y) ? 0.0 : g.y, isnan(g.z) ? 0.0 : g.z);
    uvec3 c = uvec3(min(max(g, vec3(0.0)), vec3(r.dims.xyz - 1u)));
    uint corners = (r.dims.x + 1u) * (r.dims.y + 1u) * (r.dims.z + 1u);
    uint k = c.x + r.dims.x * (c.y + r.dims.y * c.z);
    uint w = field_word(r.dims.w + ((corners + 3u) >> 2u) + (k >> 2u));
    return float(bitfieldExtract(w, int((k & 3u) * 8u), 8)) * r.scale.y;
}

// The trilinear field at object point p, object units (ThicknessLut::field_at).
float lut_field(LutRecord r, vec3 p) {
    vec3 g = (p - r.origin.xyz) / r.origin.w;
    // NaN compares false: clamp of NaN is not defined, so pick 0 explicitly.
    g = vec3(isnan(g.x) ? 0.0 : g.x, isnan(g.y) ? 0.0 : g.y, isnan(g.z) ? 0.0 : g.z);
    vec3 hi = vec3(r.dims.xyz);
    g = clamp(g, vec3(0.0), hi);
    vec3 i = min(floor(g), hi - 1.0);
    vec3 f = g - i;
    uvec3 c = uvec3(i);
    float y0 = mix(mix(lut_corner(r, c), lut_corner(r, c + uvec3(1, 0, 0)), f.x),
                   mix(lut_corner(r, c + uvec3(0, 1, 0)), lut_corner(r, c + uvec3(1, 1, 0)), f.x), f.y);
    float y1 = mix(mix(lut_corner(r, c + uvec3(0, 0, 1)), lut_corner(r, c + uvec3(1, 0, 1)), f.x),
                   mix(lut_corner(r, c + uvec3(0, 1, 1)), lut_corner(r, c + uvec3(1, 1, 1)), f.x), f.y);
    return mix(y0, y1, f.z) * r.scale.x;
}

// The zero of the field between t0 and t1 on a -> b (opposite signs), one regula-falsi step.
float lut_crossing(LutRecord r, vec3 a, vec3 d, float t0, float f0, float t1, float f1) {
    float tm = t0 + (t1 - t0) * f0 / (f0 - f1);
    float fm = lut_field(r, a + d * tm);
    bool right = (fm > 0.0) == (f0 > 0.0);
    float ta = right ? tm : t0;
    float fa = right ? fm : f0;
    float tb = right ? t1 : tm;
    float fb = right ? f1 : fm;
    return fa == fb ? tm : ta + (tb - ta) * fa / (fa - fb);
}

// The fraction of the object-space segment a -> b inside the solid (ThicknessLut::inside_fraction):
// runs of a positive field are gaps, but for low ones (largest sample <= tau) joined to an end.
float lut_inside_fraction(LutRecord r, vec3 a, vec3 b) {
    vec3 d = b - a;
    float h = r.origin.w;
    float voxels = length(d) / h;
    if (!(voxels > 0.0)) return 1.0;
    float dt_min = LUT_MAX_STEP_VOXELS / voxels;
    float lipschitz = LUT_FIELD_LIPSCHITZ * h * voxels;
    float t0 = 0.0;
    float f0 = lut_field(r, a);
    float run_start = 0.0;
    float run_max = f0;
    float run_tau = lut_tau(r, a);
    // Low runs joined to an end by samples with |field| <= tau are end noise (march.rs).
    float gaps = 0.0;
    float pending = 0.0;
    bool zone_a = abs(f0) <= run_tau;
    for (int steps = 1; t0 < 1.0 && steps < LUT_MAX_MARCH_STEPS; ++steps) {
        float t1 = min(t0 + max(dt_min, abs(f0) / lipschitz), 1.0);
        float f1 = lut_field(r, a + d * t1);
        float tau1 = lut_tau(r, a + d * t1);
        if (f0 <= 0.0 && f1 > 0.0) {
            run_start = lut_crossing(r, a, d, t0, f0, t1, f1);
            run_max = f1;
            run_tau = tau1;
        } else if (f0 > 0.0 && f1 > 0.0) {
            run_max = max(run_max, f1);
            run_tau = max(run_tau, tau1);
        } else if (f0 > 0.0 && f1 <= 0.0) {
            float len = lut_crossing(r, a, d, t0, f0, t1, f1) - run_start;
            if (run_max > run_tau) {
                gaps += len;
            } else if (!zone_a) {
                pending += len;
            }
        }
        if (abs(f1) > tau1) {
            zone_a = false;
            gaps += pending;
            pending = 0.0;
        }
        t0 = t1;
        f0 = f1;
    }
    if (f0 > 0.0 && run_max > run_tau) gaps += t0 - run_start;
    return clamp(1.0 - gaps, 0.0, 1.0);
}
#endif


#endif
