// The peel thickness (crates/hadou/src/passes/peel.rs; CPU twin effects::peel::peel_thickness), included by
// translucency.comp with WITH_PEEL after binding `peel_counts` and `peel_lists`.
#include "common/peel.glsl"

// The material of instance `id` (instance + 1) on texel's light ray between the light and
// light-space depth zp: its crossings sorted by depth (insertion sort; at most PEEL_K), summed
// where the winding number (entering +1, leaving -1) is > 0. -1 when the list overflowed.
float peel_thickness(ivec2 texel, uint id, float zp) {
    uint n = imageLoad(peel_counts, texel).x;
    if (n > PEEL_K) return -1.0;
    float z[PEEL_K];
    bool in_[PEEL_K];
    uint m = 0u;
    for (uint k = 0u; k < n; ++k) {
        uvec2 e = imageLoad(peel_lists, peel_entry(texel, k)).xy;
        if ((e.y & ~PEEL_ENTERING) != id) continue;
        float zk = uintBitsToFloat(e.x);
        bool ek = (e.y & PEEL_ENTERING) != 0u;
        // Ties: leaving before entering, as MeshBvh::crossings orders a touching pair.
        uint j = m;
        while (j > 0u && (z[j - 1u] > zk || (z[j - 1u] == zk && in_[j - 1u] && !ek))) {
            z[j] = z[j - 1u];
            in_[j] = in_[j - 1u];
            --j;
        }
        z[j] = zk;
        in_[j] = ek;
        ++m;
    }
    int winding = 0;
    float from = 0.0;
    float d = 0.0;
    for (uint k = 0u; k < m; ++k) {
        if (z[k] >= zp) break;
        if (winding > 0) d += z[k] - from;
        winding += in_[k] ? 1 : -1;
        from = z[k];
    }
    if (winding > 0) d += zp - from;
    return d;
}
