// GPU tiled: the lists a photon goes into (est_tiled.c FOR_EACH_TILE), for tl_count and tl_copy.
// The including shader defines visit(t, j) (t: the list, tiles then cells; j: the photon) and the
// buffers Bounds (binding 1), Frame (2), Grid (3), CellBox (4).
#ifndef PGIS_TL_LISTS_GLSL
#define PGIS_TL_LISTS_GLSL

layout(std430, binding = 1) readonly buffer Bounds { vec4 bounds[]; };
layout(std430, binding = 2) readonly buffer Frame { vec4 frame[2]; };
void visit(uint t, uint j);
#include "cells.glsl"

// est_tiled.c overlaps: sphere (c, padded rr) vs tile t
bool tile_overlaps(uint t, vec3 c, float rr) {
    vec4 lo = bounds[2u * t];
    if (lo.w == 0.0 || box_d2(lo.xyz, bounds[2u * t + 1u].xyz, c) > rr * rr) return false;
    uint tx = t % pc.ntx, ty = t / pc.ntx;
    float W = float(pc.width), H = float(pc.height);
    precise float u0 = (2.0 * float(tx * pc.T) / W - 1.0) * pc.sx;
    precise float u1 = (2.0 * float((tx + 1u) * pc.T) / W - 1.0) * pc.sx;
    precise float v0 = (1.0 - 2.0 * float(ty * pc.T) / H) * pc.sy;
    precise float v1 = (1.0 - 2.0 * float((ty + 1u) * pc.T) / H) * pc.sy;
    precise float d0 = (c.x - u0 * c.z) / sqrt(1.0 + u0 * u0);
    precise float d1 = (u1 * c.z - c.x) / sqrt(1.0 + u1 * u1);
    precise float d2 = (c.y - v1 * c.z) / sqrt(1.0 + v1 * v1);
    precise float d3 = (v0 * c.z - c.y) / sqrt(1.0 + v0 * v0);
    return !(d0 < -rr || d1 < -rr || d2 < -rr || d3 < -rr);
}

void for_each_list(uint j, vec3 c) {
    const float r = pc.r;
    const float rr = pad_radius(c, r);
    if (box_d2(frame[0].xyz, frame[1].xyz, c) <= rr * rr) {
        int ntx = int(pc.ntx), nty = int(pc.nty);
        int tx0 = 0, tx1 = ntx - 1, ty0 = 0, ty1 = nty - 1;
        if (c.z - r > 1e-6 * abs(c.z)) {
            float u0, u1, w0, w1;
            silhouette(c.x, c.z, r, u0, u1);
            silhouette(c.y, c.z, r, w0, w1);
            float W = float(pc.width), H = float(pc.height), fT = float(pc.T);
            precise float px0 = (u0 / pc.sx + 1.0) * 0.5 * W - 1.0;
            precise float px1 = (u1 / pc.sx + 1.0) * 0.5 * W + 1.0;
            precise float py0 = (1.0 - w1 / pc.sy) * 0.5 * H - 1.0;
            precise float py1 = (1.0 - w0 / pc.sy) * 0.5 * H + 1.0;
            tx0 = px0 <= 0.0 ? 0 : (px0 >= W ? ntx : int(px0 / fT));
            tx1 = px1 < 0.0 ? -1 : (px1 >= W ? ntx - 1 : int(px1 / fT));
            ty0 = py0 <= 0.0 ? 0 : (py0 >= H ? nty : int(py0 / fT));
            ty1 = py1 < 0.0 ? -1 : (py1 >= H ? nty - 1 : int(py1 / fT));
        }
        for (int ty = ty0; ty <= ty1; ty++)
            for (int tx = tx0; tx <= tx1; tx++) {
                uint t = uint(ty * ntx + tx);
                if (tile_overlaps(t, c, rr)) visit(t, j);
            }
    }
    visit_cells(j, c, rr);
}

#endif
