// One pass of the stable radix sort (gpu_sort.c): 8 bits of each (key, value) pair's key or value.
// A workgroup takes a block of 256 pairs, one an invocation; each invocation sets its bit in its
// digit's 256-bit mask (shared memory), so that a pair's rank among the block's pairs of the same
// digit is the number of bits set before its own: a stable order, whatever order the invocations
// run in. mode 0 writes each digit's count in the block (hist, digit-major: hist[digit * nblocks +
// block]); after the exclusive scan of hist, mode 1 writes each pair at its digit's offset for the
// block plus its rank. Input: interleaved (key, value) words (pc.interleaved) or two arrays.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
layout(local_size_x = 256) in;
layout(push_constant) uniform Push {
    uint n, shift, nblocks, mode, from_value, interleaved, pad0, pad1;
} pc;
layout(std430, binding = 0) readonly buffer KeysIn { uint kin[]; }; // or the interleaved pairs
layout(std430, binding = 1) readonly buffer ValuesIn { uint vin[]; };
layout(std430, binding = 2) buffer Hist { uint hist[]; };
layout(std430, binding = 3) writeonly buffer KeysOut { uint kout[]; };
layout(std430, binding = 4) writeonly buffer ValuesOut { uint vout[]; };
shared uint mask[256 * 8];
void main() {
    uint b = linear_group(), t = gl_LocalInvocationID.x;
    if (b >= pc.nblocks) return; // the whole workgroup: no barrier is left waiting
    for (uint w = 0u; w < 8u; w++) mask[t * 8u + w] = 0u;
    barrier();
    uint i = b * 256u + t, k = 0u, v = 0u, d = 0u;
    bool live = i < pc.n;
    if (live) {
        if (pc.interleaved != 0u) {
            k = kin[2u * i];
            v = kin[2u * i + 1u];
        } else {
            k = kin[i];
            v = vin[i];
        }
        d = ((pc.from_value != 0u ? v : k) >> pc.shift) & 255u;
        atomicOr(mask[d * 8u + (t >> 5u)], 1u << (t & 31u));
    }
    barrier();
    if (pc.mode == 0u) {
        uint c = 0u;
        for (uint w = 0u; w < 8u; w++) c += uint(bitCount(mask[t * 8u + w]));
        hist[t * pc.nblocks + b] = c;
        return;
    }
    if (!live) return;
    uint wt = t >> 5u, r = uint(bitCount(mask[d * 8u + wt] & ((1u << (t & 31u)) - 1u)));
    for (uint w = 0u; w < wt; w++) r += uint(bitCount(mask[d * 8u + w]));
    uint o = hist[d * pc.nblocks + b] + r;
    kout[o] = k;
    vout[o] = v;
}
