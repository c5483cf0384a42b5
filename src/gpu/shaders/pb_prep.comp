// GPU bvh (gpu_pbvh.c), the photons' order: est_bvh.c's Morton codes on the device.
//   mode 0  the photons' box (a workgroup's min / max in shared memory, then one atomic each; NaN
//           skipped: the result does not depend on the order)
//   mode 1  each photon's (30-bit Morton code of its cell in 1024^3 over the box, index) pair,
//           est_bvh.c quant10 / expand_bits operation for operation
//   mode 2  the photons copied in the sorted order (binding 2: the sorted indices)
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "pbvh.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) buffer Box { uint box[8]; }; // [0..2] low (min), [3..5] high (max), ordered bits
layout(std430, binding = 2) buffer Pairs { uint pairs[]; };
layout(std430, binding = 3) writeonly buffer Sorted { Photon outp[]; };
shared uint wbox[6];

uint expand_bits(uint x) {
    x = (x * 0x00010001u) & 0xFF0000FFu;
    x = (x * 0x00000101u) & 0x0F00F00Fu;
    x = (x * 0x00000011u) & 0xC30C30C3u;
    x = (x * 0x00000005u) & 0x49249249u;
    return x;
}

uint quant10(float x, float lo, float scale) {
    precise float q = (x - lo) * scale;
    if (!(q > 0.0)) return 0u; // also NaN
    if (q > 1023.0) return 1023u;
    return uint(q);
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
        float lo[3], sc[3];
        for (int d = 0; d < 3; d++) {
            lo[d] = ord2f(box[d]);
            precise float e = ord2f(box[3 + d]) - lo[d];
            sc[d] = e > 0.0 ? 1024.0 / e : 0.0;
        }
        uint key = (expand_bits(quant10(ph[i].px, lo[0], sc[0])) << 2u) |
                   (expand_bits(quant10(ph[i].py, lo[1], sc[1])) << 1u) | expand_bits(quant10(ph[i].pz, lo[2], sc[2]));
        pairs[2u * i] = key;
        pairs[2u * i + 1u] = i;
    } else {
        outp[i] = ph[pairs[i]];
    }
}
