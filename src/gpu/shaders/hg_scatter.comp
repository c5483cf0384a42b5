// GPU hashgrid build 3/5: each photon's index into its bucket's range (atomic cursor: the order
// within a bucket varies from run to run until hg_rank puts it back in photon order).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "hashgrid.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer BucketOf { uint bucket_of[]; };
layout(std430, binding = 1) readonly buffer Start { uint start[]; };
layout(std430, binding = 2) buffer Cursor { uint cursor[]; }; // zeroed
layout(std430, binding = 3) writeonly buffer Index { uint idx[]; };
void main() {
    uint j = linear_group() * 64u + gl_LocalInvocationID.x;
    if (j >= pc.n) return;
    uint b = bucket_of[j];
    idx[start[b] + atomicAdd(cursor[b], 1u)] = j;
}
