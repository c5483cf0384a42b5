// GPU bvh (gpu_pbvh.c), the photons' order: est_bvh.c's Morton codes on the device.
//   mode 0  the photons' box (a workgroup's min / max in shared memory, then one atomic each; NaN
//           skipped: the result does not depend on the order)
//   mode 1  each photon's (30-bit Morton code of its cell in 1024^3 over the box, index) pair,
//           est_bvh.c quant10 / expand_bits operation for operation
//   mode 2  the photons copied in the sorted order (binding 2: the sorted indices); with per-photon
//           footprints (pc.fp) each flux times footprint_weight (est_bvh.c's packing) and its shape
//           (pbvh.glsl FP_*) into shp[] in the same order
//   mode 3  T_auto's footprint area: each workgroup's sum of pi r^2 as two floats (hi, lo: a
//           compensated sum in the photons' order) into pairs[2 * workgroup] (gpu_pbvh.c sums them)
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "pbvh.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) buffer Box { uint box[8]; }; // [0..2] low (min), [3..5] high (max), ordered bits
layout(std430, binding = 2) buffer Pairs { uint pairs[]; };
layout(std430, binding = 3) writeonly buffer Sorted { Photon outp[]; };
layout(std430, binding = 4) readonly buffer Footprints { Footprint fps[]; }; // photon order
layout(std430, binding = 5) writeonly buffer Shapes { float shp[]; };       // sorted order
shared uint wbox[6];
shared float warea[256];

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
    if (pc.mode == 3u) {
        uint t = gl_LocalInvocationID.x;
        precise float a = i < pc.n ? 3.14159265358979323846 * fps[i].r * fps[i].r : 0.0;
        warea[t] = a;
        barrier();
        if (t != 0u) return;
        precise float hi = 0.0, lo = 0.0;
        for (uint k = 0u; k < 256u; k++) { // TwoSum (Knuth)
            precise float x = warea[k], s = hi + x, bb = s - hi, err = (hi - (s - bb)) + (x - bb);
            hi = s;
            lo += err;
        }
        pairs[2u * linear_group()] = floatBitsToUint(hi);
        pairs[2u * linear_group() + 1u] = floatBitsToUint(lo);
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
        uint j = pairs[i];
        Photon q = ph[j];
        if (pc.fp != FP_FIXED) {
            Footprint f = fps[j];
            float w = footprint_weight(f.r);
            precise float fr = q.fr * w, fg = q.fg * w, fb = q.fb * w;
            q.fr = fr;
            q.fg = fg;
            q.fb = fb;
            if (pc.fp == FP_SPHERE) {
                shp[i] = f.r;
            } else {
                float inv[9];
                ellipsoid_inverse(f, inv);
                vec3 h = ellipsoid_extent(f);
                for (uint k = 0u; k < 9u; k++) shp[ELL_FLOATS * i + k] = inv[k];
                for (uint k = 0u; k < 3u; k++) shp[ELL_FLOATS * i + 9u + k] = h[k];
            }
        }
        outp[i] = q;
    }
}
