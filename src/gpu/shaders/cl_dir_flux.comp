// GPU directional (gpu_cluster.c, docs/gpu.md): each node's 8 view-space octant buckets (Moreau et
// al. 2016 §4.7), the flux of the photons deposited in it and their directions weighted by flux
// (r + g + b), summed over its sorted list (photon order: the same sums every run); 6 floats a
// bucket (PGI__DIR_BUCKET in C), as est_cluster.c's decide. The octant of a photon: the signs of its
// direction in view space (est_cluster.c load_photon).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) readonly buffer Start { uint start[]; };
layout(std430, binding = 2) readonly buffer Index { uint idx[]; };
layout(std430, binding = 3) readonly buffer Tab { float tab[]; }; // right, up, fwd (view axes), ...
layout(std430, binding = 4) writeonly buffer Buckets { float buckets[]; }; // 48 a node
void main() {
    uint id = linear_group() * 64u + gl_LocalInvocationID.x;
    if (id >= pc.nnodes) return;
    uint s0 = start[2u * id], s1 = start[2u * id + 1u];
    float b[48];
    for (int k = 0; k < 48; k++) b[k] = 0.0;
    const vec3 R = vec3(tab[0], tab[1], tab[2]), U = vec3(tab[3], tab[4], tab[5]), F = vec3(tab[6], tab[7], tab[8]);
    for (uint k = s0; k < s1; k++) {
        Photon q = ph[idx[k]];
        precise float vx = q.dx * R.x + q.dy * R.y + q.dz * R.z;
        precise float vy = q.dx * U.x + q.dy * U.y + q.dz * U.z;
        precise float vz = q.dx * F.x + q.dy * F.y + q.dz * F.z;
        uint o = (vx < 0.0 ? 1u : 0u) | (vy < 0.0 ? 2u : 0u) | (vz < 0.0 ? 4u : 0u);
        precise float lw = q.fr + q.fg + q.fb;
        precise float fr = b[6u * o] + q.fr, fg = b[6u * o + 1u] + q.fg, fb = b[6u * o + 2u] + q.fb;
        precise float mx = b[6u * o + 3u] + lw * q.dx, my = b[6u * o + 4u] + lw * q.dy,
                      mz = b[6u * o + 5u] + lw * q.dz;
        b[6u * o] = fr, b[6u * o + 1u] = fg, b[6u * o + 2u] = fb;
        b[6u * o + 3u] = mx, b[6u * o + 4u] = my, b[6u * o + 5u] = mz;
    }
    for (uint k = 0u; k < 48u; k++) buckets[48u * id + k] = b[k];
}
