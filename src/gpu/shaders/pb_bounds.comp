// GPU bvh (gpu_pbvh.c): the nodes' boxes. A photon's box is its footprint's, as est_bvh.c's: a
// sphere's p -+ r (the fixed radius or its own; rounding is monotone: a photon that passes d^2 < r^2
// lies in it as computed), an ellipsoid's p -+ (h + pad), h its half extents, the pad covering the
// containment test's rounding. A node's box is the
// union over its range of sorted photons, taken from precomputed unions of aligned blocks:
//   mode 0  each block of 64 photons' box
//   mode 1  each block of 4096 photons' box (from its 64-blocks)
//   mode 2  each internal node's box: its range's photons up to a 64-aligned index, 64-blocks up to
//           a 4096-aligned one, 4096-blocks, then 64-blocks and photons to its end (at most about
//           250 unions + n / 4096 a node)
// Min and max only, every node independently: no atomics, the same boxes in any order.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "pbvh.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; }; // sorted
layout(std430, binding = 1) buffer Nodes { Node nodes[]; };
// 6 floats a block (lo, hi): the 64-blocks, then (from pc.mode's block count) the 4096-blocks
layout(std430, binding = 2) buffer Blocks { float blk[]; };
layout(std430, binding = 3) readonly buffer Shapes { float shp[]; }; // sorted (pbvh.glsl FP_*)

vec3 lo, hi;

void add_photon(uint k) {
    vec3 p = vec3(ph[k].px, ph[k].py, ph[k].pz);
    precise vec3 a, b;
    if (pc.fp == FP_ELLIPSOID) {
        uint o = ELL_FLOATS * k + 9u;
        vec3 h = vec3(shp[o], shp[o + 1u], shp[o + 2u]);
        precise vec3 pad = 1e-3 * h + 1e-6 * abs(p);
        a = p - h - pad;
        b = p + h + pad;
    } else {
        float r = pc.fp == FP_SPHERE ? shp[k] : pc.r;
        a = p - vec3(r);
        b = p + vec3(r);
    }
    lo = min(lo, a);
    hi = max(hi, b);
}

void add_block(uint b) {
    lo = min(lo, vec3(blk[6u * b], blk[6u * b + 1u], blk[6u * b + 2u]));
    hi = max(hi, vec3(blk[6u * b + 3u], blk[6u * b + 4u], blk[6u * b + 5u]));
}

void main() {
    uint id = linear_group() * 64u + gl_LocalInvocationID.x;
    const uint nb64 = (pc.n + 63u) / 64u, nb4k = (pc.n + 4095u) / 4096u;
    lo = vec3(uintBitsToFloat(0x7f800000u));
    hi = vec3(uintBitsToFloat(0xff800000u));
    uint out_block;
    if (pc.mode == 0u) {
        if (id >= nb64) return;
        for (uint k = 64u * id; k < min(pc.n, 64u * id + 64u); k++) add_photon(k);
        out_block = id;
    } else if (pc.mode == 1u) {
        if (id >= nb4k) return;
        for (uint b = 64u * id; b < min(nb64, 64u * id + 64u); b++) add_block(b);
        out_block = nb64 + id;
    } else {
        if (id + 1u >= pc.n) return;
        uint k = nodes[id].first, end = nodes[id].last + 1u;
        for (; k < end && (k & 63u) != 0u; k++) add_photon(k);
        for (; k + 64u <= end && (k & 4095u) != 0u; k += 64u) add_block(k / 64u);
        for (; k + 4096u <= end; k += 4096u) add_block(nb64 + k / 4096u);
        for (; k + 64u <= end; k += 64u) add_block(k / 64u);
        for (; k < end; k++) add_photon(k);
        nodes[id].lox = lo.x;
        nodes[id].loy = lo.y;
        nodes[id].loz = lo.z;
        nodes[id].hix = hi.x;
        nodes[id].hiy = hi.y;
        nodes[id].hiz = hi.z;
        return;
    }
    blk[6u * out_block] = lo.x;
    blk[6u * out_block + 1u] = lo.y;
    blk[6u * out_block + 2u] = lo.z;
    blk[6u * out_block + 3u] = hi.x;
    blk[6u * out_block + 4u] = hi.y;
    blk[6u * out_block + 5u] = hi.z;
}
