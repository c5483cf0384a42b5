// GPU bounds3d / bounds25d, pass 4 (gpu_bounds.c): per chunk, as bd_count, each photon's index into
// every bin it reaches at the chunk's next offset there: every bin in photon order, no atomics.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 5) buffer Offsets { uint offs[]; };
layout(std430, binding = 6) writeonly buffer Ids { uint ids[]; };
uint g_chunk;
void visit(uint t, uint j) {
    uint e = t * pc.nchunks + g_chunk;
    uint o = offs[e];
    offs[e] = o + 1u;
    ids[o] = j;
}
#include "bd_lists.glsl"
void main() {
    g_chunk = linear_group() * 64u + gl_LocalInvocationID.x;
    if (g_chunk >= pc.nchunks) return;
    uint j1 = min(pc.n, (g_chunk + 1u) * pc.chunk);
    for (uint j = g_chunk * pc.chunk; j < j1; j++) for_each_bin(j);
}
