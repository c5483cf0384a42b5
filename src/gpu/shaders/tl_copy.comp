// GPU tiled, pass 5 (gpu_tiled.c): per chunk, as tl_count, each photon's index into every list it
// reaches at the chunk's next offset there (counts scanned: afterwards entry (list, chunk) holds the
// start of (list, chunk + 1), so list t ends at counts[(t + 1) * nchunks - 1]).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 5) buffer Offsets { uint offs[]; };
layout(std430, binding = 6) writeonly buffer Ids { uint ids[]; };
uint g_chunk;
void visit(uint t, uint j) {
    uint e = t * pc.nchunks + g_chunk;
    uint o = offs[e];
    offs[e] = o + 1u;
    ids[o] = j;
}
#include "tl_lists.glsl"
void main() {
    g_chunk = linear_group() * 64u + gl_LocalInvocationID.x;
    if (g_chunk >= pc.nchunks) return;
    uint j1 = min(pc.n, (g_chunk + 1u) * pc.chunk);
    for (uint j = g_chunk * pc.chunk; j < j1; j++) for_each_list(j, to_view(vec3(ph[j].px, ph[j].py, ph[j].pz)));
}
