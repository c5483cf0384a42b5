// GPU bvh (gpu_pbvh.c): internal node i of the binary radix tree over the n sorted Morton codes
// (Karras, "Maximizing Parallelism in the Construction of BVHs, Octrees, and k-d Trees", HPG 2012,
// §4): its range from the direction of the longer common prefix, its split where the range's codes
// first differ in their highest differing bit (est_bvh.c build_linear's split; equal codes are
// split by index). Each node is a function of the codes alone: no atomics, any order.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "pbvh.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 1) writeonly buffer Nodes { Node nodes[]; };

// common prefix length of codes i and j (index bits after equal codes); -1 out of range
int delta(int i, int j) {
    if (j < 0 || j >= int(pc.n)) return -1;
    uint a = keys[i], b = keys[j];
    if (a == b) return 32 + (31 - findMSB(uint(i ^ j)));
    return 31 - findMSB(a ^ b);
}

void main() {
    uint id = linear_group() * 64u + gl_LocalInvocationID.x;
    if (id + 1u >= pc.n) return; // n - 1 internal nodes
    int i = int(id);
    int d = delta(i, i + 1) - delta(i, i - 1) >= 0 ? 1 : -1;
    int dmin = delta(i, i - d);
    uint lmax = 2u;
    while (delta(i, i + int(lmax) * d) > dmin) lmax <<= 1u;
    uint l = 0u;
    for (uint t = lmax >> 1u; t >= 1u; t >>= 1u)
        if (delta(i, i + int(l + t) * d) > dmin) l += t;
    int j = i + int(l) * d;
    int dnode = delta(i, j);
    uint s = 0u;
    uint len = l;
    for (uint div = 2u;; div <<= 1u) {
        uint t = (len + div - 1u) / div;
        if (delta(i, i + int(s + t) * d) > dnode) s += t;
        if (t <= 1u) break;
    }
    int split = i + int(s) * d + min(d, 0);
    uint first = uint(min(i, j)), last = uint(max(i, j));
    uint left = uint(split) == first ? LEAF | uint(split) : uint(split);
    uint right = uint(split + 1) == last ? LEAF | uint(split + 1) : uint(split + 1);
    nodes[id].first = first;
    nodes[id].last = last;
    nodes[id].left = left;
    nodes[id].right = right;
}
