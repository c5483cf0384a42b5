// GPU cluster-trivial (gpu_cluster.c): each node's trivially accepted flux, summed over its sorted
// list of such photons (photon order: the same sum every run), and their count.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) readonly buffer Start { uint start[]; };
layout(std430, binding = 2) readonly buffer Index { uint idx[]; };
layout(std430, binding = 3) writeonly buffer Flux { vec4 flux[]; }; // rgb, count (uint bits)
void main() {
    uint id = linear_group() * 64u + gl_LocalInvocationID.x;
    if (id >= pc.nnodes) return;
    uint s0 = start[2u * id + 1u], s1 = start[2u * id + 2u];
    precise vec3 f = vec3(0.0);
    for (uint k = s0; k < s1; k++) {
        Photon q = ph[idx[k]];
        f += vec3(q.fr, q.fg, q.fb);
    }
    flux[id] = vec4(f, uintBitsToFloat(s1 - s0));
}
