// GPU hashgrid build 3/3 (after the scan and the sort): the photons copied in bucket order (a cell's photons are contiguous).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "hashgrid.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) readonly buffer Index { uint idx[]; };
layout(std430, binding = 2) writeonly buffer Sorted { Photon sorted[]; };
void main() {
    uint i = linear_group() * 64u + gl_LocalInvocationID.x;
    if (i >= pc.n) return;
    sorted[i] = ph[idx[i]];
}
