// GPU bvh (gpu_pbvh.c): per view sample, est_bvh.c's query: from the root, every child whose box
// contains the sample's point, depth first, left before right, so the photons are gathered in
// their sorted order; a node of at most `leaf` photons is walked whole (the CPU's leaves), each
// photon through gather.glsl's contribution test and sums: within the fixed radius, or its own
// footprint (pbvh.glsl FP_*: d^2 < r_p^2, or inside its ellipsoid, then the same hemisphere test
// and sums with the flux already weighted by 1 / (pi r_p^2), finished with weight 1). Reads, contributing and nodes visited
// are counted per workgroup, then into 64-bit counters.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "pbvh.glsl"
#define GATHER_LOBES_DECLARE layout(std430, binding = 1) readonly buffer Lobes { Lobe lobes[]; };
#include "gather.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 2) readonly buffer Photons { Photon ph[]; }; // sorted
layout(std430, binding = 3) readonly buffer Nodes { Node nodes[]; };
layout(std430, binding = 4) writeonly buffer Out { float out_rgb[]; };
// [0, 1] reads, [2, 3] contributing, [4, 5] nodes visited (64-bit: low, high), [6] stack overflows
layout(std430, binding = 5) buffer Counters { uint counters[8]; };
layout(std430, binding = 6) readonly buffer Shapes { float shp[]; }; // sorted (pbvh.glsl FP_*)
shared uint wg_count[3];

#define STACK 64

void add64(uint k, uint v) {
    uint old = atomicAdd(counters[2u * k], v);
    if (old + v < old) atomicAdd(counters[2u * k + 1u], 1u);
}

// sorted photon k's contribution (est_bvh.c's three modes)
void gather_photon(ViewSample v, bool lambert, uint k, inout Acc a) {
    if (pc.fp == FP_FIXED) {
        gather(v, lambert, pc.r2, pc.kernel, ph[k], a);
    } else if (pc.fp == FP_SPHERE) {
        precise float r2 = shp[k] * shp[k];
        gather(v, lambert, r2, 0u, ph[k], a);
    } else {
        float inv[9];
        for (uint t = 0u; t < 9u; t++) inv[t] = shp[ELL_FLOATS * k + t];
        Photon q = ph[k];
        precise vec3 e = vec3(v.px - q.px, v.py - q.py, v.pz - q.pz);
        if (ellipsoid_contains(inv, e)) gather(v, lambert, uintBitsToFloat(0x7f800000u), 0u, q, a);
    }
}

bool contains(uint c, vec3 x) {
    Node nd = nodes[c];
    return x.x >= nd.lox && x.x <= nd.hix && x.y >= nd.loy && x.y <= nd.hiy && x.z >= nd.loz && x.z <= nd.hiz;
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    if (lid < 3u) wg_count[lid] = 0u;
    barrier();
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    bool inside = x < pc.width && y < pc.height;
    uint i = inside ? y * pc.width + x : 0u;
    ViewSample v = vs[i];
    bool valid = inside && (v.flags & VS_VALID) != 0u;
    bool lambert = (v.flags & VS_LAMBERT) != 0u;
    Acc a = Acc(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u);
    uint reads = 0u, visited = 0u;
    if (valid && pc.n > 0u) {
        vec3 p = vec3(v.px, v.py, v.pz);
        uint stack[STACK];
        int sp = 0;
        stack[sp++] = pc.n == 1u ? LEAF : 0u;
        while (sp > 0) {
            uint c = stack[--sp];
            if ((c & LEAF) != 0u) {
                gather_photon(v, lambert, c & ~LEAF, a);
                reads++;
                continue;
            }
            visited++;
            Node nd = nodes[c];
            if (nd.last - nd.first < pc.leaf) { // at most `leaf` photons: a leaf
                for (uint k = nd.first; k <= nd.last; k++) gather_photon(v, lambert, k, a);
                reads += nd.last - nd.first + 1u;
                continue;
            }
            // right first on the stack: the left subtree's photons are gathered first
            if (sp + 2 > STACK) {
                atomicAdd(counters[6], 1u);
                break;
            }
            if ((nd.right & LEAF) != 0u || contains(nd.right, p)) stack[sp++] = nd.right;
            if ((nd.left & LEAF) != 0u || contains(nd.left, p)) stack[sp++] = nd.left;
        }
    }
    uint contributing = 0u;
    if (inside) {
        vec3 o = vec3(0.0);
        if (valid) {
            o = pc.fp == FP_FIXED ? acc_finish(v, a, pc.r2, pc.scale) : acc_finish_w(v, a, 1.0);
            contributing = a.contributing;
        }
        out_rgb[3u * i] = o.x;
        out_rgb[3u * i + 1u] = o.y;
        out_rgb[3u * i + 2u] = o.z;
    }
    atomicAdd(wg_count[0], reads);
    atomicAdd(wg_count[1], contributing);
    atomicAdd(wg_count[2], visited);
    barrier();
    if (lid < 3u) add64(lid, wg_count[lid]);
}
