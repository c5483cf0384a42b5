// GPU bounds3d / bounds25d, pass 2 (gpu_bounds.c): per chunk of pc.chunk photons (one invocation,
// photons in order), the photons each bin gets from it: counts[bin * nchunks + chunk], no atomics
// (as tl_count.comp; the scan gives each chunk's offset in each bin).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 5) buffer Counts { uint counts[]; };
layout(std430, binding = 6) buffer Counters { uint counters[8]; }; // [6, 7]: photon copies (64-bit)
uint g_chunk, g_copies;
void visit(uint t, uint j) {
    counts[t * pc.nchunks + g_chunk]++;
    g_copies++;
}
#include "bd_lists.glsl"
void main() {
    g_chunk = linear_group() * 64u + gl_LocalInvocationID.x;
    if (g_chunk >= pc.nchunks) return;
    g_copies = 0u;
    uint j1 = min(pc.n, (g_chunk + 1u) * pc.chunk);
    for (uint j = g_chunk * pc.chunk; j < j1; j++) for_each_bin(j);
    uint old = atomicAdd(counters[6], g_copies);
    if (old + g_copies < old) atomicAdd(counters[7], 1u);
}
