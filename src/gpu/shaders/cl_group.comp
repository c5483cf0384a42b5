// GPU cluster-trivial lists (gpu_cluster.c): the splat's (entry, photon) pairs grouped by entry.
// mode 0: photons per entry (atomic counts); mode 1: each pair's photon into its entry's range (an
// atomic cursor: the order within a range varies from run to run until cl_rank puts it back in
// photon order, so that every sum over a list is made in photon order).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Pairs { uint pairs[]; };
layout(std430, binding = 1) buffer Start { uint start[]; }; // mode 0: counts (zeroed); mode 1: starts
layout(std430, binding = 2) buffer Cursor { uint cursor[]; }; // zeroed
layout(std430, binding = 3) writeonly buffer Index { uint idx[]; };
void main() {
    uint p = linear_group() * 64u + gl_LocalInvocationID.x;
    if (p >= pc.npairs) return;
    uint e = pairs[2u * p];
    if (pc.mode == 0u) atomicAdd(start[e], 1u);
    else idx[start[e] + atomicAdd(cursor[e], 1u)] = pairs[2u * p + 1u];
}
