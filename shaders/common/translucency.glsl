// Structs and lookups shared by light_id.vert/.frag and translucency.comp. Keep in sync with
// src/passes/translucency.rs (LutRecord, TranslucentInstance, LightViewData; sizes asserted there)
// and src/effects/translucency.rs (the light view's math).
#ifndef HADOU_TRANSLUCENCY_GLSL
#define HADOU_TRANSLUCENCY_GLSL

#define NO_LUT 0xffffffffu

// One baked thickness table (a mesh at a voxel resolution).
struct LutRecord {
    vec4 origin;    // xyz: object-space minimum corner of voxel (0, 0, 0); w: voxel edge h
    uvec4 dims;     // xyz: grid voxels; w: surface voxels N
    uvec4 offsets;  // x: first word of its nearest grid in `grid`; y: first texel of its table in the
                    // LUT image; z: its first surface-voxel centre in `centres`
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
// src/gpu/texel_buffer.rs): a LutRecord is 3 texels, a TranslucentInstance 9.
LutRecord lut_record_at(usamplerBuffer records, uint i) {
    int t = int(3u * i);
    LutRecord r;
    r.origin = uintBitsToFloat(texelFetch(records, t));
    r.dims = texelFetch(records, t + 1);
    r.offsets = texelFetch(records, t + 2);
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

#ifdef HADOU_TRANSLUCENCY_GRID
// Needs `uint grid_word(uint i)` (word i of the nearest grids) defined before this file is
// included with HADOU_TRANSLUCENCY_GRID.

// The (clamped) voxel containing object point p.
ivec3 voxel_of(LutRecord r, vec3 p) {
    vec3 g = floor((p - r.origin.xyz) / r.origin.w);
    // NaN compares false: clamp of NaN is not defined, so pick 0 explicitly.
    g = vec3(isnan(g.x) ? 0.0 : g.x, isnan(g.y) ? 0.0 : g.y, isnan(g.z) ? 0.0 : g.z);
    return ivec3(clamp(g, vec3(0.0), vec3(r.dims.xyz - 1u)));
}

// The nearest grid at the (clamped) voxel containing object point p (ThicknessLut::surface_voxel_at).
uint surface_voxel_at(LutRecord r, vec3 p) {
    ivec3 v = voxel_of(r, p);
    return grid_word(r.offsets.x + uint(v.x + int(r.dims.x) * (v.y + int(r.dims.y) * v.z)));
}
#endif

#ifdef HADOU_TRANSLUCENCY_CENTRES
// Also needs `vec4 centre_at(uint i)` (surface-voxel centre i) defined before the include.

// effects::translucency::END_SHIFTS, in voxel edges.
const float END_SHIFTS[4] = float[4](0.0, 0.5, 1.0, 1.5);

// effects::translucency::path_end_voxel: the nearest-grid lookups at object point p moved
// END_SHIFTS voxels along `inward` (at most half_len), keeping the surface voxel whose centre lies
// nearest, in world space (model: the instance's linear part), to the line through p along the
// world unit direction l. `first`: the lookup at p itself when known (else NO_LUT).
uint path_end_voxel(LutRecord r, mat3 model, vec3 p, vec3 inward, float half_len, vec3 l, uint first) {
    uint best = NO_LUT;
    float best_d2 = 0.0;
    for (int k = 0; k < 4; ++k) {
        uint id = (k == 0 && first != NO_LUT)
            ? first
            : surface_voxel_at(r, p + inward * min(END_SHIFTS[k] * r.origin.w, half_len));
        vec3 w = model * (centre_at(r.offsets.z + id).xyz - p);
        vec3 off = w - l * dot(w, l);
        float d2 = dot(off, off);
        if (best == NO_LUT || d2 < best_d2) {
            best = id;
            best_d2 = d2;
        }
    }
    return best;
}
#endif

// The texel index of pair (i, j) in a table of n surface voxels (thickness_lut::pair_index): the
// upper triangle row by row; exact in uint for n <= 46340.
uint lut_pair_index(uint i, uint j, uint n) {
    uint a = min(i, j);
    uint b = max(i, j);
    return a * n - (a * (a - 1u)) / 2u + (b - a);
}

#endif
