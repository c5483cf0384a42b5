// The cluster family's inputs on the device (gpu_cluster.c): the photons in the order of their cell
// in a 32^3 grid over their box (Morton order, photon order within a cell: neighbouring splat
// invocations walk the same nodes, and a node's list reads nearby records), and the view samples'
// depths as an array.
//   mode 0  the photons' box: a workgroup's min / max in shared memory, then one atomic each
//           (NaN skipped; min/max only: the result does not depend on the order)
//   mode 1  each photon's (cell key, index) pair, in index order: gpu_sort.c's stable sort by the
//           key alone then orders them by (cell, index)
//   mode 2  the photons copied in the sorted order (binding 2: the sorted indices)
//   mode 3  the depth of each view sample from the frame's PixelExtra (binding 0 read as floats,
//           12 a pixel, the depth the fourth; binding 3: depth[])
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) buffer Box { uint box[8]; }; // [0..2] low (f2ord, min), [3..5] high (max)
layout(std430, binding = 2) buffer Pairs { uint pairs[]; };
layout(std430, binding = 3) writeonly buffer Out { Photon outp[]; };
layout(std430, binding = 0) readonly buffer Extra { float extra[]; };
layout(std430, binding = 3) writeonly buffer Depth { float depth[]; };
shared uint wbox[6];

uint spread3_5(uint v) {
    uint o = 0u;
    for (uint b = 0u; b < 5u; b++) o |= (v >> b & 1u) << (3u * b);
    return o;
}

void main() {
    uint i = linear_group() * 256u + gl_LocalInvocationID.x;
    if (pc.mode == 0u) {
        uint t = gl_LocalInvocationID.x;
        if (t < 6u) wbox[t] = t < 3u ? 0xffffffffu : 0u;
        barrier();
        if (i < pc.n) {
            vec3 p = vec3(ph[i].px, ph[i].py, ph[i].pz);
            for (int d = 0; d < 3; d++)
                if (p[d] == p[d]) {
                    atomicMin(wbox[d], f2ord(p[d]));
                    atomicMax(wbox[3 + d], f2ord(p[d]));
                }
        }
        barrier();
        if (t < 3u) atomicMin(box[t], wbox[t]);
        else if (t < 6u) atomicMax(box[t], wbox[t]);
        return;
    }
    if (i >= pc.n) return;
    if (pc.mode == 1u) {
        vec3 p = vec3(ph[i].px, ph[i].py, ph[i].pz);
        uint key = 0u;
        const float cells = 32.0;
        for (int d = 0; d < 3; d++) {
            float lo = ord2f(box[d]), hi = ord2f(box[3 + d]);
            float inv = hi > lo && !isinf(hi - lo) ? cells / (hi - lo) : 0.0;
            float f = (p[d] - lo) * inv;
            uint c = f >= 1.0 ? (f < cells ? uint(f) : 31u) : 0u; // NaN: 0
            key |= spread3_5(c) << uint(2 - d);
        }
        pairs[2u * i] = key;
        pairs[2u * i + 1u] = i;
    } else if (pc.mode == 2u) {
        outp[i] = ph[pairs[i]];
    } else {
        depth[i] = extra[12u * i + 3u];
    }
}
