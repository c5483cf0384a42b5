// Photon tracing on the GPU, after trace.comp and the scan of its counts (gpu_trace.c): path k's
// photons are slots[k * bounces ...], their place in the batch scan[k] .. scan[k + 1] (exclusive
// sums, scan[npaths] the batch's total). Photons whose place is below `remaining` (the photons
// still wanted) go to out[base + place]: the batch's first paths in path order, the last one cut
// after the photon that fills the buffer. The path that fills it (its photons reach `remaining`)
// writes its index to result[0] (one path does: the places are unique).
#version 450
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
#include "common.glsl"

#include "photon.glsl"
layout(std430, set = 0, binding = 0) readonly restrict buffer Slots { Photon slots[]; };
layout(std430, set = 0, binding = 1) readonly restrict buffer Scan { uint scan[]; };
layout(std430, set = 0, binding = 2) writeonly restrict buffer Out { Photon outp[]; };
layout(std430, set = 0, binding = 3) writeonly restrict buffer Result { uint result[]; };

layout(push_constant) uniform Push {
    uint npaths, bounces, base, remaining;
} pc;

void main() {
    const uint k = linear_group() * 64u + gl_LocalInvocationID.x;
    if (k >= pc.npaths) return;
    const uint s = scan[k], n = scan[k + 1u] - s;
    for (uint j = 0u; j < n && s + j < pc.remaining; j++) outp[pc.base + s + j] = slots[k * pc.bounces + j];
    if (n > 0u && s < pc.remaining && s + n >= pc.remaining) result[0] = k;
}
