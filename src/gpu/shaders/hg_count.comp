// GPU hashgrid build 1/3 (gpu_hashgrid.c): each photon's bucket as a (bucket, photon) pair for the sort
// (gpu_sort.h), and the photons per bucket.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "hashgrid.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) buffer Count { uint count[]; }; // buckets + 1, zeroed
layout(std430, binding = 2) writeonly buffer Pairs { uint pairs[]; }; // (bucket, photon) a photon
void main() {
    uint j = linear_group() * 64u + gl_LocalInvocationID.x;
    if (j >= pc.n) return;
    Photon q = ph[j];
    ivec3 c = ivec3(cell_coord(q.px, pc.inv_cell), cell_coord(q.py, pc.inv_cell), cell_coord(q.pz, pc.inv_cell));
    uint b = cell_bucket(c, pc.mask);
    pairs[2u * j] = b;
    pairs[2u * j + 1u] = j;
    atomicAdd(count[b], 1u);
}
