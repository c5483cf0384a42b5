// GPU cluster-trivial lists (gpu_cluster.c): each entry's photon indices sorted (Shell sort with
// Ciura's gaps, one invocation an entry; the hashgrid's former per-bucket sort), so that every list
// is in photon order whatever order cl_group's atomics ran in: the same sums every run.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Start { uint start[]; };
layout(std430, binding = 1) buffer Index { uint idx[]; };
// One gapped insertion-sort pass over idx[s0, s1).
void pass_gap(uint s0, uint s1, uint gap) {
    for (uint i = s0 + gap; i < s1; i++) {
        uint v = idx[i], k = i;
        while (k >= s0 + gap && idx[k - gap] > v) {
            idx[k] = idx[k - gap];
            k -= gap;
        }
        idx[k] = v;
    }
}

void main() {
    uint e = linear_group() * 64u + gl_LocalInvocationID.x;
    if (e >= 2u * pc.nnodes) return;
    uint s0 = start[e], s1 = start[e + 1u], len = s1 - s0;
    if (len < 2u) return;
    // gaps above Ciura's table: x 2.25 from 701 while below the length, then back down
    uint g = 701u;
    while (g * 9u / 4u < len) g = g * 9u / 4u;
    for (; g > 701u; g = g * 4u / 9u) pass_gap(s0, s1, g);
    const uint gaps[8] = uint[8](701u, 301u, 132u, 57u, 23u, 10u, 4u, 1u);
    for (int i = 0; i < 8; i++)
        if (gaps[i] < len) pass_gap(s0, s1, gaps[i]);
}
