// The peel pass's per-texel crossing lists (crates/hadou/src/passes/peel.rs): shared by peel.frag, which
// appends, and translucency.comp, which sums them. Keep in sync with PEEL_K and PEEL_TILE in
// crates/hadou/src/passes/peel.rs (checked there against this file's text by a test).
#ifndef HADOU_PEEL_GLSL
#define HADOU_PEEL_GLSL

// Crossings a texel's list holds; a texel with more has overflowed (its count says so).
#define PEEL_K 8u
// A texel's list is a PEEL_TILE_X × PEEL_TILE_Y block of the lists image.
#define PEEL_TILE_X 4u
#define PEEL_TILE_Y 2u
// Entry .y: instance id + 1 in the low 31 bits, this flag when the light enters the solid there.
#define PEEL_ENTERING 0x80000000u

ivec2 peel_entry(ivec2 texel, uint k) {
    return texel * ivec2(PEEL_TILE_X, PEEL_TILE_Y) + ivec2(k % PEEL_TILE_X, k / PEEL_TILE_X);
}

#endif
