// GPU cluster family lists (gpu_cluster.c): the number of the splat's (entry, photon) pairs of each
// entry (atomic counts: the same whatever order they ran in); their exclusive sum is each entry's
// list start, and gpu_sort.c's sort of the pairs by (entry, photon) fills the lists in photon order.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Pairs { uint pairs[]; };
layout(std430, binding = 1) buffer Start { uint start[]; }; // counts (zeroed)
void main() {
    uint p = linear_group() * 64u + gl_LocalInvocationID.x;
    if (p >= pc.npairs) return;
    atomicAdd(start[pairs[2u * p]], 1u);
}
