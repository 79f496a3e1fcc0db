#version 460
// depth_import: the game's depth buffer → hadou's view-ray distance (R32F `distance`, every pixel:
// the energy wave reads it everywhere) and, with HADOU_DEPTH, its own reverse-Z depth over the
// rectangle where hadou's instances can be rasterized (a buffer copied into that rectangle of the
// D32 `depth`: lavapipe has no storage D32), so they are depth-tested against the game's scene.
// The depth is only read by the raster's depth test, which never reaches past its instances'
// screen bounds: storing it for every pixel and copying the whole image was about a quarter of
// this pass's cost at 640×360 (docs/PERFORMANCE.md, "Embedding"). CPU twin (f64):
// crates/hadou/src/passes/depth_import.rs::import_depth.
#include "common/frame.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D game_depth;
#ifdef HADOU_DEPTH
layout(set = 0, binding = 2, std430) writeonly buffer HadouDepth { float hadou_depth[]; };
#else
layout(set = 0, binding = 1, r32f) uniform writeonly image2D distance_image;
#endif
// The camera's ray frame (ray_forward.w: hadou's far) and the frame's size (counts.yz).
layout(set = 0, binding = 3, std140) uniform FrameBlock { FrameUniforms frame; };

// Params in crates/hadou/src/passes/depth_import.rs.
layout(push_constant) uniform Params {
    // x: 1 if the game's depth is reverse-Z (nearer is larger); HADOU_DEPTH: y the staging
    // buffer's row length (the rectangle's width rounded up to whole 8-pixel workgroups), zw the
    // rectangle's first column and row
    uvec4 dims;
    // the game's projection: stored d = -A + B / z; hadou's near
    vec4 planes;
} params;

void main() {
    uvec2 size = frame.counts.yz;
#ifdef HADOU_DEPTH
    // The dispatch covers the rectangle in whole workgroups; lanes past its edge read the edge
    // pixel and write the padding of the staging buffer: the buffer store needs no mask (on
    // lavapipe a masked storage-buffer store is a loop over the lanes), and the copy skips it.
    uvec2 g = gl_GlobalInvocationID.xy;
    uvec2 p = min(params.dims.zw + g, size - 1u);
#else
    uvec2 p = gl_GlobalInvocationID.xy;
    bool inside = p.x < size.x && p.y < size.y;
    p = min(p, size - 1u);
#endif
    float d = texelFetch(game_depth, ivec2(p), 0).r;
    float a = params.planes.x, b = params.planes.y;
    bool reversed = params.dims.x != 0u;
    // The far plane (the game's cleared depth) is sky: no surface, as in hadou's own raster.
    bool sky = reversed ? d <= 0.0 : d >= 1.0;
    // View depth along the camera's forward axis (the perspective projection inverted).
    float z = b / (d + a);
#ifdef HADOU_DEPTH
    float hn = params.planes.z, hf = frame.ray_forward.w;
    // Reverse-Z of hadou's own frustum; with an infinite far, near / z.
    float own = sky ? 0.0 : clamp(isinf(hf) ? hn / z : hn * (hf - z) / (z * (hf - hn)), 0.0, 1.0);
    hadou_depth[g.y * params.dims.y + g.x] = own;
#else
    float ndc_x = 2.0 * (float(p.x) + 0.5) / float(size.x) - 1.0;
    float ndc_y = 1.0 - 2.0 * (float(p.y) + 0.5) / float(size.y);
    // The pixel ray's direction has forward component 1, so distance = z · |direction|.
    vec4 right = frame.ray_right, up = frame.ray_up;
    float ray_scale = length(frame.ray_forward.xyz + (ndc_x + right.w) * right.xyz + (ndc_y + up.w) * up.xyz);
    float dist = sky ? uintBitsToFloat(0x7f800000u) : z * ray_scale;
    if (inside) imageStore(distance_image, ivec2(p), vec4(dist, 0.0, 0.0, 0.0));
#endif
}
