// GPU hashgrid build 4/5: each photon's place in its bucket in photon order: its rank among the
// bucket's indices (one invocation a photon, reading its bucket's indices; nothing written in
// place, so the result is a pure function of the bucket's contents: the same layout, and so the
// same sums and image, whatever order hg_scatter's atomics ran in). Costs the sum over buckets of
// their squared sizes; an in-place sort per bucket by one invocation left lavapipe's long-running
// invocations unfinished under CPU load.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "hashgrid.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Start { uint start[]; };
layout(std430, binding = 1) readonly buffer BucketOf { uint bucket_of[]; };
layout(std430, binding = 2) readonly buffer Index { uint idx[]; };     // hg_scatter's order
layout(std430, binding = 3) writeonly buffer Ranked { uint ranked[]; }; // photon order in each bucket
void main() {
    uint k = linear_group() * 64u + gl_LocalInvocationID.x;
    if (k >= pc.n) return;
    uint v = idx[k], b = bucket_of[v];
    uint s0 = start[b], s1 = start[b + 1u], r = 0u;
    for (uint i = s0; i < s1; i++) r += idx[i] < v ? 1u : 0u;
    ranked[s0 + r] = v;
}
