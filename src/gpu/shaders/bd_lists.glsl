// GPU bounds3d / bounds25d: the bins a photon goes into (est_bounds.c FOR_EACH_BIN), for bd_count and
// bd_copy: the tiles with valid primary samples (tl_bounds.comp's flag) under its shape's rectangle
// in increasing order, then the mirror-seen samples' cells its padded sphere reaches. The including
// shader defines visit(t, j) and binds the shapes (0), the tiles' boxes (1), the parameters (2), the
// cell grid (3) and the cells' boxes (4).
#ifndef PGIS_BD_LISTS_GLSL
#define PGIS_BD_LISTS_GLSL

#define BD_SHAPES_BINDING 0
#define BD_PARAMS_BINDING 2
#include "bounds.glsl"
layout(std430, binding = 1) readonly buffer Bounds { vec4 bounds[]; };
void visit(uint t, uint j);
#include "cells.glsl"

void for_each_bin(uint j) {
    const uint base = j * prm.stride;
    if (shp[base + 7u] != 0.0) {
        const int T = int(pc.T), W = int(pc.width), H = int(pc.height);
        const int tx0 = clip_lo(shp[base], 0) / T, tx1 = clip_hi(shp[base + 1u], W - 1) / T;
        const int ty0 = clip_lo(shp[base + 2u], 0) / T, ty1 = clip_hi(shp[base + 3u], H - 1) / T;
        for (int ty = ty0; ty <= ty1; ty++)
            for (int tx = tx0; tx <= tx1; tx++) {
                uint t = uint(ty) * pc.ntx + uint(tx);
                if (bounds[2u * t].w != 0.0) visit(t, j);
            }
    }
    visit_cells(j, vec3(shp[base + 8u], shp[base + 9u], shp[base + 10u]), shp[base + 11u]);
}

#endif
