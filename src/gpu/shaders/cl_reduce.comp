// GPU cluster build 1/3 (gpu_cluster.c): the frame's near depth (the smallest positive primary
// depth, cluster_build.c scan_samples) and the world-space box of the samples seen through mirrors
// or glass (their clustering grid). Min/max only: the result does not depend on the order.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 1) readonly buffer Depth { float depth[]; };
// [0] near (float bits, min), [1..3] box low (f2ord, min), [4..6] box high (f2ord, max)
layout(std430, binding = 2) buffer Frame { uint frame[8]; };
void main() {
    uint i = linear_group() * 64u + gl_LocalInvocationID.x;
    if (i >= pc.width * pc.height) return;
    uint f = vs[i].flags;
    if ((f & VS_VALID) == 0u) return;
    if ((f & VS_PRIMARY) != 0u) {
        float z = depth[i];
        if (z > 0.0) atomicMin(frame[0], floatBitsToUint(z));
        return;
    }
    vec3 p = vec3(vs[i].px, vs[i].py, vs[i].pz);
    for (int d = 0; d < 3; d++)
        if (p[d] == p[d]) {
            atomicMin(frame[1 + d], f2ord(p[d]));
            atomicMax(frame[4 + d], f2ord(p[d]));
        }
}
