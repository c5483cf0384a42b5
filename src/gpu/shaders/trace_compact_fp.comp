// The footprints of trace_fp.comp compacted as trace_compact.comp compacts the photons (the same
// places: record i belongs to photon i): path k's records fslots[k * bounces ...] go to
// out[base + place] for the places below `remaining`.
#version 450
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
#include "common.glsl"
#include "footprint.glsl"

layout(std430, set = 0, binding = 0) readonly restrict buffer FpSlots { Footprint fslots[]; };
layout(std430, set = 0, binding = 1) readonly restrict buffer Scan { uint scan[]; };
layout(std430, set = 0, binding = 2) writeonly restrict buffer Out { Footprint outf[]; };

layout(push_constant) uniform Push {
    uint npaths, bounces, base, remaining;
} pc;

void main() {
    const uint k = linear_group() * 64u + gl_LocalInvocationID.x;
    if (k >= pc.npaths) return;
    const uint s = scan[k], n = scan[k + 1u] - s;
    for (uint j = 0u; j < n && s + j < pc.remaining; j++) outf[pc.base + s + j] = fslots[k * pc.bounces + j];
}
