// Lavapipe (Mesa's gallivm) ends every loop of a SIMD group, silently, once all its loops
// together have iterated 65,535 times in one invocation of the shader: a walk may then have
// stopped short. A loop that must run n + 2 times (n from a buffer: a count the compiler cannot
// know, so it stays a loop) tells. No such limit on other devices. Used by the metaballs' casts
// and their binning's fill, which count what it cut.
#ifndef HADOU_LOOP_BUDGET_GLSL
#define HADOU_LOOP_BUDGET_GLSL

bool loops_cut(uint n) {
    uint loops = 0u;
    uint wanted = n + 2u;
    do {
        ++loops;
    } while (loops < wanted);
    return loops != wanted;
}

#endif
