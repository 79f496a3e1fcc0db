// The seed's own thickness LUT (seed 003 §3.2; crates/hadou/src/effects/thickness_pairs.rs, its f64 twin
// `PairTable::inside_fraction`): the surface voxels standing for the light's entry a and the shaded
// point b, and the thickness between their centroids from the N×N R8 table. Needs, before it is
// included: `uint field_word(uint i)` (the fields' words: each grid voxel's surface voxel, then
// each surface voxel's coordinates) and `sampler2D pair_table` (the tables stacked by rows).
#ifndef HADOU_TRANSLUCENCY_PAIRS_GLSL
#define HADOU_TRANSLUCENCY_PAIRS_GLSL

#define NO_SURFACE 0xffffffffu

// The surface voxel of the voxel holding p (floor, clamped to the grid; `SurfaceVoxels::surface_of`).
uint pair_surface(LutRecord r, vec3 p) {
    vec3 last = vec3(r.dims.xyz) - 1.0;
    ivec3 v = ivec3(clamp(floor((p - r.origin.xyz) / r.origin.w), vec3(0.0), last));
    ivec3 d = ivec3(r.dims.xyz);
    return field_word(r.dims.w + uint(v.x + d.x * (v.y + d.y * v.z)));
}

// Surface voxel k's centroid (coordinates packed x | y << 10 | z << 20 from word `first` on).
vec3 pair_centroid(LutRecord r, uint first, uint k) {
    uint w = field_word(first + k);
    uvec3 c = uvec3(w & 1023u, (w >> 10) & 1023u, w >> 20);
    return r.origin.xyz + (vec3(c) + 0.5) * r.origin.w;
}

// The inside fraction of a -> b: the pair's thickness over its centroids' distance, capped at 1;
// 1 when both ends stand in one surface voxel or one has none (TSM's distance is kept there).
// `raw` is the record's third texel as uints: y its first table row, z its first coordinate word
// (bit patterns, never read as floats).
float pair_inside_fraction(LutRecord r, uvec4 raw, vec3 a, vec3 b) {
    uint i = pair_surface(r, a);
    uint j = pair_surface(r, b);
    if (i == NO_SURFACE || j == NO_SURFACE || i == j) return 1.0;
    float d = texelFetch(pair_table, ivec2(int(j), int(raw.y + i)), 0).r * r.scale.x;
    float len = length(pair_centroid(r, raw.z, j) - pair_centroid(r, raw.z, i));
    return clamp(d / len, 0.0, 1.0);
}

#endif
