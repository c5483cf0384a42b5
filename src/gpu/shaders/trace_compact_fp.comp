// The footprints of trace_fp.comp compacted as trace_compact.comp compacts the photons (the same
// places: record i belongs to photon i): path k's records fslots[k * bounces ...] go to
// out[base + place] for the places below `remaining`, each counted in the histogram of the radius
// before the clamp (the slot's pad0; PGI_FOOTPRINT_BINS bins of r_max / 14, the last one open, as
// the CPU tracer's footprint_hist), pad0 cleared.
#version 450
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
#include "common.glsl"
#include "footprint.glsl"

layout(std430, set = 0, binding = 0) readonly restrict buffer FpSlots { Footprint fslots[]; };
layout(std430, set = 0, binding = 1) readonly restrict buffer Scan { uint scan[]; };
layout(std430, set = 0, binding = 2) writeonly restrict buffer Out { Footprint outf[]; };
layout(std430, set = 0, binding = 3) restrict buffer Hist { uint hist[]; };

#define BINS 21 // PGI_FOOTPRINT_BINS

layout(push_constant) uniform Push {
    uint npaths, bounces, base, remaining;
    float bin_w; // r_max / 14 (the CPU's float: a radius of exactly r_max falls in its bin)
} pc;

void main() {
    const uint k = linear_group() * 64u + gl_LocalInvocationID.x;
    if (k >= pc.npaths) return;
    const uint s = scan[k], n = scan[k + 1u] - s;
    for (uint j = 0u; j < n && s + j < pc.remaining; j++) {
        Footprint f = fslots[k * pc.bounces + j];
        const float qb = f.pad0 / pc.bin_w;
        const int bin = qb < float(BINS - 1) ? int(qb) : BINS - 1;
        atomicAdd(hist[max(bin, 0)], 1u);
        f.pad0 = 0.0;
        outf[pc.base + s + j] = f;
    }
}
