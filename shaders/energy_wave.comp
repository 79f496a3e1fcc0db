#version 460
// energy_wave: per pixel, H = ∫₀ᴸ E(O + s·u) ds for each wave, L = the view distance to the first
// surface (or the camera's far distance). Adds colour × intensity × max(H − cutoff, 0) to HDR,
// writes Σ H to energy.
// CPU twins: crates/hadou/src/effects/energy_wave.rs (f64), crates/hadou/src/effects/energy_wave_f32.rs (this arithmetic).
#include "common/camera.glsl"
#include "common/energy_wave.glsl"
#include "common/frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// WaveStyle in crates/hadou/src/passes/energy_wave.rs (size checked when bound: gpu::reflect).
struct WaveStyle {
    vec4 emission;  // rgb: colour × intensity; w: cutoff (H below it emits nothing)
    uvec4 method;   // x: 0 analytic, 1 raymarch; y: steps; z: jitter
    vec4 adaptive;  // x: the tolerance (read by energy_wave_classify.comp)
};

layout(set = 0, binding = 0, r32f) uniform readonly image2D distance_image;
layout(set = 0, binding = 1, rgba16f) uniform image2D hdr;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D energy;
#ifdef REACTIVE
// A temporal upscaler's reactive mask: the share of the pixel's luminance the glow added.
layout(set = 0, binding = 9, r32f) uniform writeonly image2D reactive;
#endif
layout(set = 0, binding = 3, std430) readonly buffer Waves { Wave waves[]; };
layout(set = 0, binding = 4, std430) readonly buffer Styles { WaveStyle styles[]; };
// The camera's ray frame (ray_right, ray_up, ray_forward; ray_forward.w: the far distance) and
// the frame's size (counts.yz).
layout(set = 0, binding = 5, std140) uniform FrameBlock { FrameUniforms frame; };

// EnergyWaveParams in crates/hadou/src/passes/energy_wave.rs (size checked at pipeline creation).
layout(push_constant) uniform EnergyWaveParams {
    uvec4 counts;  // x: wave count; with TILE_LIST y, z: tiles_x, tiles_y, w: the tile size T
    uvec4 flags;   // x: 1 when something reads `energy` after the pass (else it is not written)
} params;

#ifdef TILE_LIST
// With a tolerance: only the tiles energy_wave_classify.comp listed as exact, (8/T)² per 8×8
// workgroup (WAVE_TILE: a variant per size), WAVE_TILES_PER_ROW workgroups per row of the
// indirect dispatch.
#include "common/energy_wave_tiles.glsl"
layout(set = 0, binding = 7, std430) readonly buffer Lists { uint tiles[]; };
layout(set = 0, binding = 8, std430) readonly buffer State { uint state[8]; };

uvec2 pixel_of_invocation(out bool listed) {
    uint slot = wave_list_slot();
    uint count = state[7];
    listed = slot < count;
    uint tile = tiles[params.counts.y * params.counts.z + min(slot, max(count, 1u) - 1u)];
    return wave_tile_xy(tile, params.counts.y) * uint(WAVE_TILE) + wave_tile_offset();
}
#else
uvec2 pixel_of_invocation(out bool listed) {
    listed = true;
    return gl_GlobalInvocationID.xy;
}
#endif

// Largest finite RGBA16F value: emission is clamped so HDR never holds Inf.
const float HALF_MAX = 65504.0;

// A per-pixel offset in [0, 1) for jittered ray marching (PCG hash).
float pixel_jitter(uvec2 p, uint wave) {
    uint v = p.x * 1973u + p.y * 9277u + wave * 26699u + 1u;
    v = v * 747796405u + 2891336453u;
    v = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
    v = (v >> 22u) ^ v;
    return float(v >> 8u) * (1.0 / 16777216.0);
}

void main() {
    // How this is laid out is about lavapipe (Mesa 22.3), where it was measured at 512×512:
    // - Every field of the first wave is read here, before any branch or loop: in uniform control
    //   flow lavapipe loads a buffer value once per group of 8 invocations, inside a branch or a
    //   loop it loads it lane by lane (that alone cost ~40 % of this pass). Further waves are
    //   read in the loop. Invocations past the image edge compute the clamped pixel and only
    //   skip the stores, so no early return puts the rest of the shader under a mask.
    // - The loop over waves is a do-while: a `for` loop tests its exit at the top of the next
    //   iteration, so its last pass runs the whole body once more with every lane masked off
    //   (lavapipe executes masked code; this doubled the cost of one wave). A scene with no
    //   wave never runs this pass, and one whose waves all have a = b = 0 binds one zeroed wave
    //   with a count of 0: `live` keeps the result right then.
    Wave wave0 = waves[0];
    WaveStyle style0 = styles[0];
    bool listed;
    uvec2 p = pixel_of_invocation(listed);
    uvec2 size = frame.counts.yz;
    bool inside = listed && p.x < size.x && p.y < size.y;
    ivec2 pix = ivec2(min(p, size - 1u));
    // The ray through the pixel centre, as Camera::pixel_ray builds it.
    vec3 u = camera_pixel_ray(pix, size, frame.ray_right, frame.ray_up, frame.ray_forward.xyz);
    float L = min(imageLoad(distance_image, pix).r, frame.ray_forward.w);
    L = max(L, 0.0);

    float total = 0.0;
    vec3 emitted = vec3(0.0);
    uint i = 0u;
    do {
        Wave wave = wave0;
        WaveStyle style = style0;
        if (i > 0u) {
            wave = waves[i];
            style = styles[i];
        }
        float H = style.method.x == 0u
            ? wave_line_integral(wave, u, L)
            : wave_raymarch(wave, u, L, style.method.y, style.method.z != 0u ? pixel_jitter(p, i) : 0.5);
        bool live = i < params.counts.x;
        total += live ? H : 0.0;
        emitted += live ? style.emission.rgb * max(H - style.emission.w, 0.0) : vec3(0.0);
        ++i;
    } while (i < params.counts.x);
    if (inside) {
        // Uniform across the dispatch: a frame whose `energy` nobody reads skips the store.
        if (params.flags.x != 0u) {
            imageStore(energy, pix, vec4(total, 0.0, 0.0, 0.0));
        }
        vec4 c = imageLoad(hdr, pix);
        vec3 lit = min(c.rgb + emitted, vec3(HALF_MAX));
        imageStore(hdr, pix, vec4(lit, c.a));
#ifdef REACTIVE
        const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);
        float all_light = dot(lit, LUMA);
        float share = all_light > 0.0 ? clamp(dot(lit - c.rgb, LUMA) / all_light, 0.0, 1.0) : 0.0;
        imageStore(reactive, pix, vec4(share, 0.0, 0.0, 0.0));
#endif
    }
}
