// GPU hashgrid gather (gpu_hashgrid.c): for each view sample, the cells its sphere overlaps (as
// est_hashgrid.c hg_estimate), each cell's bucket, the bucket's photons that lie in that cell
// (buckets hold several cells), each through gather.glsl's contribution test and sum.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "hashgrid.glsl"
#define GATHER_LOBES_DECLARE layout(std430, binding = 1) readonly buffer Lobes { Lobe lobes[]; };
#include "gather.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 2) readonly buffer Start { uint start[]; };
layout(std430, binding = 3) readonly buffer Sorted { Photon sorted[]; };
layout(std430, binding = 4) writeonly buffer Out { float out_rgb[]; };
// reads, contributing, cells visited: (low, high) words of 64-bit sums
layout(std430, binding = 5) buffer Counters { uint counters[6]; };
shared uint wg_count[3];

void add64(uint k, uint v) {
    uint old = atomicAdd(counters[2u * k], v);
    if (old + v < old) atomicAdd(counters[2u * k + 1u], 1u);
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    if (lid < 3u) wg_count[lid] = 0u;
    barrier();
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    uint reads = 0u, contributing = 0u, visited = 0u;
    if (x < pc.width && y < pc.height) {
        uint i = y * pc.width + x;
        ViewSample v = vs[i];
        vec3 o = vec3(0.0);
        if ((v.flags & VS_VALID) != 0u) {
            bool lambert = (v.flags & VS_LAMBERT) != 0u;
            Acc a = Acc(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u);
            const float r = pc.r, inv = pc.inv_cell;
            precise float xl = v.px - r, xh = v.px + r, yl = v.py - r, yh = v.py + r, zl = v.pz - r, zh = v.pz + r;
            int x0 = cell_coord(xl, inv), x1 = cell_coord(xh, inv);
            int y0 = cell_coord(yl, inv), y1 = cell_coord(yh, inv);
            int z0 = cell_coord(zl, inv), z1 = cell_coord(zh, inv);
            for (int cx = x0; cx <= x1; cx++)
                for (int cy = y0; cy <= y1; cy++)
                    for (int cz = z0; cz <= z1; cz++) {
                        ivec3 c = ivec3(cx, cy, cz);
                        uint b = cell_bucket(c, pc.mask);
                        visited++;
                        uint s1 = start[b + 1u];
                        for (uint k = start[b]; k < s1; k++) {
                            Photon q = sorted[k];
                            ivec3 qc = ivec3(cell_coord(q.px, inv), cell_coord(q.py, inv), cell_coord(q.pz, inv));
                            if (qc != c) continue; // another cell of the same bucket
                            reads++;
                            gather(v, lambert, pc.r2, pc.kernel, q, a);
                        }
                    }
            o = acc_finish(v, a, pc.r2, pc.scale);
            contributing = a.contributing;
        }
        out_rgb[3u * i] = o.x;
        out_rgb[3u * i + 1u] = o.y;
        out_rgb[3u * i + 2u] = o.z;
    }
    atomicAdd(wg_count[0], reads);
    atomicAdd(wg_count[1], contributing);
    atomicAdd(wg_count[2], visited);
    barrier();
    if (lid < 3u) add64(lid, wg_count[lid]);
}
