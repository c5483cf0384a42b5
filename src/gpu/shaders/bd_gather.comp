// GPU bounds3d / bounds25d, pass 5 (gpu_bounds.c): per view sample, as est_bounds.c b_estimate.
// A valid primary sample walks its tile's bin in photon order; each photon whose shape covers the
// pixel (bounds.glsl shape_covers: est_bounds.c row_span) and, for 2.5D, whose depth range holds the
// sample's view depth goes through gather.glsl's contribution test and sums. A mirror-seen sample
// tests every photon of its cell's bin. Every float sum is in photon order: no atomics.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
#define GATHER_LOBES_DECLARE layout(std430, binding = 1) readonly buffer Lobes { Lobe lobes[]; };
#include "gather.glsl"
#define BD_PARAMS_BINDING 8
#define BD_SHAPES_BINDING 9
#include "bounds.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 2) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 3) readonly buffer Offsets { uint offs[]; };
layout(std430, binding = 4) readonly buffer Ids { uint ids[]; };
layout(std430, binding = 5) readonly buffer CellOf { uint cell_of[]; }; // mirror-seen sample: its cell
layout(std430, binding = 6) writeonly buffer Out { float out_rgb[]; };
// reads, contributing, covered pixels: (low, high) words of 64-bit sums
layout(std430, binding = 7) buffer Counters { uint counters[8]; };
shared uint wg_count[3];

void add64(uint k, uint v) {
    uint old = atomicAdd(counters[2u * k], v);
    if (old + v < old) atomicAdd(counters[2u * k + 1u], 1u);
}

// bin t: [k0, k1)
void bin_range(uint t, out uint k0, out uint k1) {
    k0 = t == 0u ? 0u : offs[t * pc.nchunks - 1u];
    k1 = offs[(t + 1u) * pc.nchunks - 1u];
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    if (lid < 3u) wg_count[lid] = 0u;
    barrier();
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    bool inside = x < pc.width && y < pc.height;
    uint i = inside ? y * pc.width + x : 0u;
    ViewSample v = vs[i];
    bool valid = inside && (v.flags & VS_VALID) != 0u, primary = (v.flags & 2u) != 0u;
    bool lambert = (v.flags & VS_LAMBERT) != 0u;
    Acc a = Acc(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u);
    uint reads = 0u, covered = 0u;
    if (valid && primary) {
        uint k0, k1;
        bin_range((y / pc.T) * pc.ntx + x / pc.T, k0, k1);
        const float z = to_view(vec3(v.px, v.py, v.pz)).z, X = float(x), Y = float(y);
        const bool depth = prm.mode3d == 0u;
        for (uint k = k0; k < k1; k++) {
            uint j = ids[k], base = j * prm.stride;
            if (!shape_covers(base, X, Y)) continue;
            covered++;
            if (depth && !(z >= shp[base + 4u] && z <= shp[base + 5u])) continue;
            reads++;
            gather(v, lambert, pc.r2, pc.kernel, ph[j], a);
        }
    } else if (valid) {
        uint k0, k1;
        bin_range(pc.ntiles + cell_of[i], k0, k1);
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
    atomicAdd(wg_count[2], covered);
    barrier();
    if (lid < 3u) add64(lid, wg_count[lid]);
}
