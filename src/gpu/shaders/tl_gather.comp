// GPU tiled, pass 6 (gpu_tiled.c): per view sample, its list (its tile's; a mirror-seen sample's
// cell's) through gather.glsl's contribution test and sums, in list order (photon order), as
// est_tiled.c tiled_estimate / gather_one.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
#define GATHER_LOBES_DECLARE layout(std430, binding = 1) readonly buffer Lobes { Lobe lobes[]; };
#include "gather.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 2) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 3) readonly buffer Offsets { uint offs[]; };
layout(std430, binding = 4) readonly buffer Ids { uint ids[]; };
layout(std430, binding = 5) readonly buffer CellOf { uint cell_of[]; }; // mirror-seen sample: its cell
layout(std430, binding = 6) writeonly buffer Out { float out_rgb[]; };
// reads, contributing: (low, high) words of 64-bit sums
layout(std430, binding = 7) buffer Counters { uint counters[8]; };
shared uint wg_count[2];

void add64(uint k, uint v) {
    uint old = atomicAdd(counters[2u * k], v);
    if (old + v < old) atomicAdd(counters[2u * k + 1u], 1u);
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    if (lid < 2u) wg_count[lid] = 0u;
    barrier();
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    uint reads = 0u, contributing = 0u;
    if (x < pc.width && y < pc.height) {
        uint i = y * pc.width + x;
        ViewSample v = vs[i];
        vec3 o = vec3(0.0);
        if ((v.flags & VS_VALID) != 0u) {
            uint t = (v.flags & 2u) != 0u ? (y / pc.T) * pc.ntx + x / pc.T : pc.ntiles + cell_of[i];
            uint k0 = t == 0u ? 0u : offs[t * pc.nchunks - 1u], k1 = offs[(t + 1u) * pc.nchunks - 1u];
            bool lambert = (v.flags & VS_LAMBERT) != 0u;
            Acc a = Acc(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u);
            for (uint k = k0; k < k1; k++) gather(v, lambert, pc.r2, pc.kernel, ph[ids[k]], a);
            reads = k1 - k0;
            o = acc_finish(v, a, pc.r2, pc.scale);
            contributing = a.contributing;
        }
        out_rgb[3u * i] = o.x;
        out_rgb[3u * i + 1u] = o.y;
        out_rgb[3u * i + 2u] = o.z;
    }
    atomicAdd(wg_count[0], reads);
    atomicAdd(wg_count[1], contributing);
    barrier();
    if (lid < 2u) add64(lid, wg_count[lid]);
}
