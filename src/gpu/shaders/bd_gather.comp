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
shared uint batch_j[64]; // a tile's bin, 64 photons at a time: index, rectangle, depth range
shared vec4 batch_r[64];
shared vec2 batch_z[64];
shared uint keep_bits[2][2]; // kept entries of a batch: bit e of word e / 32, two pairs in turn

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
    if (lid < 4u) keep_bits[lid >> 1u][lid & 1u] = 0u;
    barrier();
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    bool inside = x < pc.width && y < pc.height;
    uint i = inside ? y * pc.width + x : 0u;
    ViewSample v = vs[i];
    bool valid = inside && (v.flags & VS_VALID) != 0u, primary = (v.flags & 2u) != 0u;
    bool lambert = (v.flags & VS_LAMBERT) != 0u;
    Acc a = Acc(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u);
    uint reads = 0u, covered = 0u;
    const float z = valid ? to_view(vec3(v.px, v.py, v.pz)).z : 0.0, X = float(x), Y = float(y);
    const bool depth = prm.mode3d == 0u, mine = valid && primary;
    // Tiles a multiple of 8 pixels: the workgroup's 8 x 8 block lies in one tile. Its bin goes through
    // shared memory 64 photons at a time; those whose rectangle reaches the block are kept, in bin
    // order (photon order), and each pixel tests only those: a photon costs the blocks its bound
    // touches rather than its tile's every pixel.
    const bool shared_path = pc.T % 8u == 0u;
    if (shared_path) {
        uint k0, k1;
        bin_range((gl_WorkGroupID.y * 8u / pc.T) * pc.ntx + gl_WorkGroupID.x * 8u / pc.T, k0, k1);
        const float bx0 = float(gl_WorkGroupID.x * 8u), by0 = float(gl_WorkGroupID.y * 8u);
        const float bx1 = bx0 + 7.0, by1 = by0 + 7.0;
        for (uint b = k0, par = 0u; b < k1; b += 64u, par ^= 1u) {
            // this batch's kept set: bits of keep_bits[par] (the other pair, read by the last
            // batch before its closing barrier, is cleared for the next)
            if (lid < 2u) keep_bits[par ^ 1u][lid] = 0u;
            if (b + lid < k1) {
                uint j = ids[b + lid], base = j * prm.stride;
                vec4 rc = vec4(shp[base], shp[base + 1u], shp[base + 2u], shp[base + 3u]);
                batch_j[lid] = j;
                batch_r[lid] = rc;
                batch_z[lid] = vec2(shp[base + 4u], shp[base + 5u]);
                if (rc.x <= bx1 && rc.y >= bx0 && rc.z <= by1 && rc.w >= by0)
                    atomicOr(keep_bits[par][lid >> 5u], 1u << (lid & 31u));
            }
            barrier();
            uvec2 bits = uvec2(keep_bits[par][0], keep_bits[par][1]);
            if (mine)
                for (uint h = 0u; h < 2u; h++)
                    for (uint w = bits[h]; w != 0u; w &= w - 1u) { // the kept entries, in bin order
                        uint e = 32u * h + uint(findLSB(w));
                        vec4 rc = batch_r[e];
                        if (!(rc.x <= X && X <= rc.y && rc.z <= Y && Y <= rc.w)) continue;
                        uint j = batch_j[e];
                        if (!shape_covers(j * prm.stride, X, Y)) continue;
                        covered++;
                        if (depth && !(z >= batch_z[e].x && z <= batch_z[e].y)) continue;
                        reads++;
                        gather(v, lambert, pc.r2, pc.kernel, ph[j], a);
                    }
            barrier();
        }
    } else if (mine) {
        uint k0, k1;
        bin_range((y / pc.T) * pc.ntx + x / pc.T, k0, k1);
        for (uint k = k0; k < k1; k++) {
            uint j = ids[k], base = j * prm.stride;
            if (!(shp[base] <= X && X <= shp[base + 1u]) || !shape_covers(base, X, Y)) continue;
            covered++;
            if (depth && !(z >= shp[base + 4u] && z <= shp[base + 5u])) continue;
            reads++;
            gather(v, lambert, pc.r2, pc.kernel, ph[j], a);
        }
    }
    if (valid && !primary) {
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
