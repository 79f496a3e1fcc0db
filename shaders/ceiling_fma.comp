#version 460
// ceiling_fma: the device's arithmetic ceiling for `hadou report`. Each invocation steps 2
// independent vec4 FMA chains 256 times per loop round, written out (the loop's own test and, on
// lavapipe, its lane masking are paid once per 512 FMAs): 2 chains × 256 steps × 4 components ×
// 2 = 4096 FLOP per round. Two vec4 chains are 8 independent FMAs per step, enough to hide an
// FMA's latency; more would not fit a CPU's 16 vector registers on lavapipe (it holds each vec4
// component of 8 invocations in one register) and spill (measured: 8 chains ran at half the
// rate). On a GPU the many invocations hide latency instead. The chains' sum is stored so the
// compiler cannot drop the work. Keep the count in sync with FLOP_PER_ROUND in
// src/report/ceilings.rs.
//
// ADD_CHAIN: each step also adds a vec4 chain a = a + c1 (c1 changes every step, so nothing
// folds): 256 × 4 more FLOP per round. Devices whose adds have pipes of their own beside the FMA
// pipes (AMD Zen's FADD pipes, which lavapipe runs on) retire more FLOP per cycle with the mix
// than with FMAs alone, so a pass of adds and FMAs could read above an FMA-only "ceiling"; the
// report takes the better of the two kernels.

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) writeonly buffer Sink { vec4 sink[]; };

layout(push_constant) uniform Params {
    uint iterations;
    float seed;   // 0 at run time; unknown to the compiler, so nothing is folded
} params;

#ifdef ADD_CHAIN
#define STEP c0 = fma(c0, m, k); c1 = fma(c1, m, k); a0 = a0 + c1;
#else
#define STEP c0 = fma(c0, m, k); c1 = fma(c1, m, k);
#endif
#define STEP16 STEP STEP STEP STEP STEP STEP STEP STEP STEP STEP STEP STEP STEP STEP STEP STEP
#define STEP256 \
    STEP16 STEP16 STEP16 STEP16 STEP16 STEP16 STEP16 STEP16 \
    STEP16 STEP16 STEP16 STEP16 STEP16 STEP16 STEP16 STEP16

void main() {
    uint id = gl_GlobalInvocationID.x;
    vec4 base = vec4(float(id & 1023u) * 1.0e-6 + params.seed);
    vec4 c0 = base, c1 = base + 0.5, a0 = base;
    // |m| < 1 keeps both chains bounded (they converge to k / (1 − m)): no Inf, no denormals.
    // Scalars splatted: one register each on lavapipe.
    vec4 m = vec4(0.999 + params.seed);
    vec4 k = vec4(1.0e-3 + params.seed);
    uint i = 0u;
    do {
        STEP256
        ++i;
    } while (i < params.iterations);
#ifdef ADD_CHAIN
    sink[id] = c0 + c1 + a0;
#else
    sink[id] = c0 + c1;
#endif
}
