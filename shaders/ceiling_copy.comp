#version 460
// ceiling_copy: the device's memory-bandwidth ceiling for `hadou report`. Each invocation copies
// 16 vec4s, strided by the invocation count so neighbouring invocations touch neighbouring
// memory; several per invocation so the per-invocation cost (large on lavapipe) does not hide the
// memory's. Buffers far larger than any cache; bytes moved = 2 × buffer size.
// Keep the 16 in sync with COPIES_PER_INVOCATION in src/report/ceilings.rs.

#define COPY1(k) dst[i + (k) * n] = src[i + (k) * n];
#define COPY4(k) COPY1(k) COPY1((k) + 1u) COPY1((k) + 2u) COPY1((k) + 3u)

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) readonly buffer Src { vec4 src[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Dst { vec4 dst[]; };

layout(push_constant) uniform Params {
    uint invocations;   // the dispatch's invocation count; each buffer holds COPIES × this vec4s
} params;

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint n = params.invocations;
    // Written out, not looped: lavapipe masks every loop round lane by lane.
    COPY4(0u) COPY4(4u) COPY4(8u) COPY4(12u)
}
