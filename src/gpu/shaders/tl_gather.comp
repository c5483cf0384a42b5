// GPU tiled, pass 6 (gpu_tiled.c): per view sample, its list (its tile's; a mirror-seen sample's
// cell's) through gather.glsl's contribution test and sums, in list order (photon order), as
// est_tiled.c tiled_estimate / gather_one. An 8 x 8 workgroup; with tiles a multiple of 8 pixels
// the tile's list goes through shared memory (Mara et al.'s per-tile gather).
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
shared Photon batch[64]; // a tile's photons, 64 at a time (the paper's per-tile gather)

void add64(uint k, uint v) {
    uint old = atomicAdd(counters[2u * k], v);
    if (old + v < old) atomicAdd(counters[2u * k + 1u], 1u);
}

// The list of list t: [k0, k1)
void list_range(uint t, out uint k0, out uint k1) {
    k0 = t == 0u ? 0u : offs[t * pc.nchunks - 1u];
    k1 = offs[(t + 1u) * pc.nchunks - 1u];
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    if (lid < 2u) wg_count[lid] = 0u;
    barrier();
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    bool inside = x < pc.width && y < pc.height;
    uint i = inside ? y * pc.width + x : 0u;
    ViewSample v = vs[i];
    bool valid = inside && (v.flags & VS_VALID) != 0u, primary = (v.flags & 2u) != 0u;
    bool lambert = (v.flags & VS_LAMBERT) != 0u;
    Acc a = Acc(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u);
    uint reads = 0u;
    // Tiles a multiple of 8 pixels: the workgroup lies in one tile; its photons are loaded into
    // shared memory 64 at a time and every primary sample of the workgroup reads them from there.
    bool shared_path = pc.T % 8u == 0u;
    if (shared_path) {
        uint t = (gl_WorkGroupID.y * 8u / pc.T) * pc.ntx + gl_WorkGroupID.x * 8u / pc.T;
        uint k0, k1;
        list_range(t, k0, k1);
        bool mine = valid && primary;
        for (uint b = k0; b < k1; b += 64u) {
            if (b + lid < k1) batch[lid] = ph[ids[b + lid]];
            barrier();
            uint m = min(64u, k1 - b);
            if (mine)
                for (uint e = 0u; e < m; e++) gather(v, lambert, pc.r2, pc.kernel, batch[e], a);
            barrier();
        }
        if (mine) reads = k1 - k0;
    }
    // The other samples: their own tile's (or mirror cell's) list from global memory.
    if (valid && !(shared_path && primary)) {
        uint t = primary ? (y / pc.T) * pc.ntx + x / pc.T : pc.ntiles + cell_of[i];
        uint k0, k1;
        list_range(t, k0, k1);
        for (uint k = k0; k < k1; k++) gather(v, lambert, pc.r2, pc.kernel, ph[ids[k]], a);
        reads = k1 - k0;
    }
    uint contributing = 0u;
    if (inside) {
        vec3 o = vec3(0.0);
        if (valid) {
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
