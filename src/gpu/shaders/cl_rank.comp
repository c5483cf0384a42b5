// GPU cluster-trivial lists (gpu_cluster.c): each pair's photon placed in photon order within its
// entry's range, by its rank among the range's indices (one invocation a pair, as the hashgrid's
// hg_rank): the result is a pure function of each range's contents, so every list, and every sum
// over one, is the same whatever order cl_group's atomics ran in. Nothing is sorted in place (an
// in-place sort by one invocation was left partly done by lavapipe under CPU load: docs/gpu.md).
// Costs the sum over entries of their squared sizes.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Pairs { uint pairs[]; };
layout(std430, binding = 1) readonly buffer Start { uint start[]; };
layout(std430, binding = 2) readonly buffer Index { uint idx[]; };     // cl_group's order
layout(std430, binding = 3) writeonly buffer Ranked { uint ranked[]; }; // photon order in each entry
void main() {
    uint p = linear_group() * 64u + gl_LocalInvocationID.x;
    if (p >= pc.npairs) return;
    uint e = pairs[2u * p], v = pairs[2u * p + 1u];
    uint s0 = start[e], s1 = start[e + 1u], r = 0u;
    for (uint i = s0; i < s1; i++) r += idx[i] < v ? 1u : 0u;
    ranked[s0 + r] = v;
}
