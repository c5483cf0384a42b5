// Adds each block's offset (the scanned block totals) to the block's exclusive sums (gpu_hashgrid.c).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "hashgrid.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) buffer Data { uint data[]; };
layout(std430, binding = 1) readonly buffer Sums { uint sums[]; };
void main() {
    uint i = linear_group() * 256u + gl_LocalInvocationID.x;
    if (i < pc.n) data[i] += sums[i / 1024u];
}
