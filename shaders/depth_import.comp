#version 460
// depth_import: the game's depth buffer → hadou's view-ray distance (R32F `distance`) and its own
// reverse-Z depth (a buffer copied into the D32 `depth`), so hadou's instances are depth-tested
// against the game's scene and the energy wave stops at it. CPU twin (f64):
// crates/hadou/src/renderer/depth_import.rs::import_depth.
#include "common/camera.glsl"
#include "common/frame.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D game_depth;
layout(set = 0, binding = 1, r32f) uniform writeonly image2D distance_image;
layout(set = 0, binding = 2, std430) writeonly buffer HadouDepth { float hadou_depth[]; };
// The camera's ray frame (ray_forward.w: hadou's far) and the frame's size (counts.yz).
layout(set = 0, binding = 3, std140) uniform FrameBlock { FrameUniforms frame; };

// Params in crates/hadou/src/passes/depth_import.rs.
layout(push_constant) uniform Params {
    // 1 if the game's depth is reverse-Z (nearer is larger), the staging buffer's row length (the
    // width rounded up to whole 8-pixel workgroups)
    uvec4 dims;
    // the game's projection: stored d = -A + B / z; hadou's near
    vec4 planes;
} params;

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    uvec2 size = frame.counts.yz;
    bool inside = p.x < size.x && p.y < size.y;
    // Lanes past the edge read the edge pixel and write the padding of the staging buffer: the
    // buffer store needs no mask (on lavapipe a masked storage-buffer store is a loop over the
    // lanes), and the copy into `depth` skips the padding.
    ivec2 q = ivec2(min(p, size - 1u));
    float d = texelFetch(game_depth, q, 0).r;
    float a = params.planes.x, b = params.planes.y;
    bool reversed = params.dims.x != 0u;
    // The far plane (the game's cleared depth) is sky: no surface, as in hadou's own raster.
    bool sky = reversed ? d <= 0.0 : d >= 1.0;
    // View depth along the camera's forward axis (the perspective projection inverted).
    float z = b / (d + a);
    float ndc_x = 2.0 * (float(p.x) + 0.5) / float(size.x) - 1.0;
    float ndc_y = 1.0 - 2.0 * (float(p.y) + 0.5) / float(size.y);
    // The pixel ray's direction has forward component 1, so distance = z · |direction|.
    vec4 right = frame.ray_right, up = frame.ray_up;
    float ray_scale = length(frame.ray_forward.xyz + (ndc_x + right.w) * right.xyz + (ndc_y + up.w) * up.xyz);
    float dist = sky ? uintBitsToFloat(0x7f800000u) : z * ray_scale;
    float hn = params.planes.z, hf = frame.ray_forward.w;
    // Reverse-Z of hadou's own frustum; with an infinite far, near / z.
    float own = sky ? 0.0 : clamp(isinf(hf) ? hn / z : hn * (hf - z) / (z * (hf - hn)), 0.0, 1.0);
    if (inside) imageStore(distance_image, ivec2(p), vec4(dist, 0.0, 0.0, 0.0));
    hadou_depth[p.y * params.dims.y + p.x] = own;
}
