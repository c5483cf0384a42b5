// GPU tiled, pass 3 (gpu_tiled.c): per chunk of pc.chunk photons (one invocation, photons in
// order), the photons each list gets from it: counts[list * nchunks + chunk]. Only this invocation
// writes its chunk's column: no atomics, and the scan over (list, chunk) gives every chunk's
// offset in each list, so that tl_copy writes each list in photon order (est_tiled.c's chunks).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 5) buffer Counts { uint counts[]; };
layout(std430, binding = 6) buffer Counters { uint counters[8]; }; // [6, 7]: lists tested (64-bit)
uint g_chunk, g_tested;
void visit(uint t, uint j) {
    counts[t * pc.nchunks + g_chunk]++;
    g_tested++;
}
#include "tl_lists.glsl"
void main() {
    g_chunk = linear_group() * 64u + gl_LocalInvocationID.x;
    if (g_chunk >= pc.nchunks) return;
    g_tested = 0u;
    uint j1 = min(pc.n, (g_chunk + 1u) * pc.chunk);
    for (uint j = g_chunk * pc.chunk; j < j1; j++) for_each_list(j, to_view(vec3(ph[j].px, ph[j].py, ph[j].pz)));
    uint old = atomicAdd(counters[6], g_tested);
    if (old + g_tested < old) atomicAdd(counters[7], 1u);
}
