// GPU cluster-trivial radiance (gpu_cluster.c): an 8x8 tile of view samples a workgroup; each sample
// reads the lists of its root, supertile, tile and cluster (the nodes that contain it) through
// gather.glsl's contribution test and sums (as est_cluster.c cl_estimate with pgi__gather), then
// adds those nodes' trivially accepted flux and counts.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#define CL_WITH_GATHER
#include "cluster.glsl"
#define GATHER_LOBES_DECLARE layout(std430, binding = 1) readonly buffer Lobes { Lobe lobes[]; };
#include "gather.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 2) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 3) readonly buffer PixNode { uint pix_node[]; };
layout(std430, binding = 4) readonly buffer Start { uint start[]; };
layout(std430, binding = 5) readonly buffer Index { uint idx[]; };
layout(std430, binding = 6) readonly buffer Flux { vec4 flux[]; };
layout(std430, binding = 7) writeonly buffer Out { float out_rgb[]; };
// reads, contributing: (low, high) words of 64-bit sums
layout(std430, binding = 8) buffer Counters { uint counters[6]; };
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
            bool lambert = (v.flags & VS_LAMBERT) != 0u;
            Acc a = Acc(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u);
            const uint kind = (v.flags & VS_PRIMARY) != 0u ? 0u : 1u;
            uint up[3], ids[4];
            node_path(x, y, kind, up);
            ids[0] = up[0], ids[1] = up[1], ids[2] = up[2], ids[3] = pix_node[i];
            for (int l = 0; l < 4; l++) {
                uint s1 = start[2u * ids[l] + 1u];
                for (uint k = start[2u * ids[l]]; k < s1; k++) {
                    reads++;
                    gather(v, lambert, pc.r2, 0u, ph[idx[k]], a);
                }
            }
            for (int l = 0; l < 4; l++) {
                vec4 f = flux[ids[l]];
                precise float fr = a.fr + f.x, fg = a.fg + f.y, fb = a.fb + f.z;
                a.fr = fr, a.fg = fg, a.fb = fb;
                a.contributing += floatBitsToUint(f.w);
                reads += floatBitsToUint(f.w); // accepted as the node's sum: examined, not read one by one
            }
            o = acc_finish(v, a, pc.r2, 1.0);
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
