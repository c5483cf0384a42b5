// GPU hashgrid build 4/5: sorts each bucket's photon indices (insertion sort, one invocation a
// bucket), so that the photons of a cell are summed in photon order: the same image every run.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "hashgrid.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Start { uint start[]; };
layout(std430, binding = 1) buffer Index { uint idx[]; };
void main() {
    uint b = linear_group() * 64u + gl_LocalInvocationID.x;
    if (b > pc.mask) return;
    uint s0 = start[b], s1 = start[b + 1u];
    for (uint i = s0 + 1u; i < s1; i++) {
        uint v = idx[i], k = i;
        while (k > s0 && idx[k - 1u] > v) {
            idx[k] = idx[k - 1u];
            k--;
        }
        idx[k] = v;
    }
}
