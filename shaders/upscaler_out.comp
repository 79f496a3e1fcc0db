#version 460
// upscaler_out: a temporal upscaler's inputs written into the game's own images (embedding,
// crates/hadou/src/passes/upscaler_out.rs), so its FSR / DLSS / TAA reads them on the GPU: hadou's
// motion where hadou drew a surface (ids.x != 0; elsewhere the game's own motion is kept), and the
// larger of the game's and hadou's reactive and composition masks everywhere. The image formats
// are the pass's defines (MOTION_FORMAT; REACTIVE_FORMAT and COMPOSITION_FORMAT when given).
layout(local_size_x = 8, local_size_y = 8) in;

#ifndef MOTION_FORMAT
#define MOTION_FORMAT rg32f
#endif

layout(set = 0, binding = 0, rg32ui) uniform readonly uimage2D ids;
layout(set = 0, binding = 1, rg32f) uniform readonly image2D motion;
layout(set = 0, binding = 2, r32f) uniform readonly image2D reactive;
layout(set = 0, binding = 3, r32f) uniform readonly image2D composition;
layout(set = 0, binding = 4, MOTION_FORMAT) uniform image2D game_motion;
#ifdef REACTIVE_FORMAT
layout(set = 0, binding = 5, REACTIVE_FORMAT) uniform image2D game_reactive;
#endif
#ifdef COMPOSITION_FORMAT
layout(set = 0, binding = 6, COMPOSITION_FORMAT) uniform image2D game_composition;
#endif

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(motion);
    if (p.x >= size.x || p.y >= size.y) return;
    if (imageLoad(ids, p).x != 0u) imageStore(game_motion, p, imageLoad(motion, p));
#ifdef REACTIVE_FORMAT
    imageStore(game_reactive, p, vec4(max(imageLoad(game_reactive, p).r, imageLoad(reactive, p).r), 0.0, 0.0, 0.0));
#endif
#ifdef COMPOSITION_FORMAT
    float c = max(imageLoad(game_composition, p).r, imageLoad(composition, p).r);
    imageStore(game_composition, p, vec4(c, 0.0, 0.0, 0.0));
#endif
}
