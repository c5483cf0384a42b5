// Exclusive prefix sum in blocks of 1024 (gpu_hashgrid.c scan()): data[] becomes the exclusive sums
// within each block, sums[block] the block's total. Levels above scan the block totals.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "hashgrid.glsl"
layout(local_size_x = 512) in;
layout(std430, binding = 0) buffer Data { uint data[]; };
layout(std430, binding = 1) writeonly buffer Sums { uint sums[]; };
shared uint s[512];
void main() {
    uint lid = gl_LocalInvocationID.x, block = linear_group();
    uint i0 = block * 1024u + 2u * lid;
    uint a = i0 < pc.n ? data[i0] : 0u;
    uint b = i0 + 1u < pc.n ? data[i0 + 1u] : 0u;
    uint t = a + b;
    s[lid] = t;
    barrier();
    for (uint off = 1u; off < 512u; off <<= 1) {
        uint v = lid >= off ? s[lid - off] : 0u;
        barrier();
        s[lid] += v;
        barrier();
    }
    uint excl = s[lid] - t;
    if (i0 < pc.n) data[i0] = excl;
    if (i0 + 1u < pc.n) data[i0 + 1u] = excl + a;
    if (lid == 511u) sums[block] = s[511];
}
