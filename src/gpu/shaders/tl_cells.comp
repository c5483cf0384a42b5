// GPU tiled, the mirror-seen samples' cells (gpu_tiled.c; spec_cells.h's grouping, on the device):
// samples reached through mirrors or glass lie anywhere in the scene, so they are grouped by where
// they are, in view space, rather than by tile.
//   mode 0  the box of the valid samples without PGI_VS_PRIMARY (atomic min of ordered bits, the
//           high corner's complemented, so that every word starts at ~0u: the same whatever the
//           order; NaN skipped)
//   mode 1  (one invocation) the grid over that box: cells of edge h = max(2r x 1.001, extent /
//           (G - 1)), at most G a side, dense (an empty cell has an empty box)
//   mode 2  each such sample's cell (cell_of) and its cell's box (as mode 0)
//   mode 3  each cell's box as floats (tl_lists.glsl CellBox; empty: lo +inf, hi -inf)
// Only min/max and integer arithmetic: the cells are a function of the samples alone.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Samples { uint vsw[]; }; // gather.glsl ViewSample: 16 words
// [0..2] low, [3..5] high (complemented) of the samples, ordered bits; then per cell k: [6 + 6k ..]
layout(std430, binding = 1) buffer Ord { uint ord[]; };
layout(std430, binding = 2) buffer Grid { CellGrid grid; };
layout(std430, binding = 3) writeonly buffer CellBox { float cell_box[]; };
layout(std430, binding = 4) writeonly buffer CellOf { uint cell_of[]; };

uint f2ord(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float ord2f(uint u) { return uintBitsToFloat((u & 0x80000000u) != 0u ? u & 0x7fffffffu : ~u); }

int coord(float v, int a) {
    precise float f = floor((v - grid.o[a]) * grid.inv_h);
    return f < 0.0 ? 0 : (f > float(grid.dim[a] - 1) ? grid.dim[a] - 1 : int(f));
}

void main() {
    uint i = linear_group() * 64u + gl_LocalInvocationID.x;
    if (pc.mode == 1u) {
        if (i != 0u) return;
        bool any = ord[0] != 0xffffffffu;
        float ext = 0.0;
        for (int a = 0; a < 3; a++) {
            grid.lo[a] = any ? ord2f(ord[a]) : 0.0;
            grid.hi[a] = any ? ord2f(~ord[3 + a]) : 0.0;
            grid.o[a] = grid.lo[a];
            ext = max(ext, grid.hi[a] - grid.lo[a]);
        }
        precise float h = max(2.0 * pc.r * 1.001, ext / float(pc.G - 1u));
        if (!(h > 0.0) || isinf(h)) h = 1.0;
        grid.inv_h = 1.0 / h;
        uint n = 1u;
        for (int a = 0; a < 3; a++) {
            precise float f = floor((grid.hi[a] - grid.o[a]) * grid.inv_h);
            int d = f >= 0.0 && f < float(pc.G) ? int(f) + 1 : int(pc.G);
            grid.dim[a] = d;
            n *= uint(d);
        }
        grid.n = any ? n : 0u;
        return;
    }
    if (pc.mode == 3u) {
        if (i >= pc.G * pc.G * pc.G) return;
        for (int a = 0; a < 3; a++) {
            uint lo = ord[6u + 6u * i + uint(a)], hi = ord[6u + 6u * i + 3u + uint(a)];
            bool empty = i >= grid.n || lo == 0xffffffffu;
            cell_box[6u * i + uint(a)] = empty ? uintBitsToFloat(0x7f800000u) : ord2f(lo);
            cell_box[6u * i + 3u + uint(a)] = empty ? uintBitsToFloat(0xff800000u) : ord2f(~hi);
        }
        return;
    }
    if (i >= pc.width * pc.height) return;
    if ((vsw[16u * i + 13u] & 3u) != 1u) return; // PGI_VS_VALID without PGI_VS_PRIMARY
    vec3 q = to_view(vec3(uintBitsToFloat(vsw[16u * i]), uintBitsToFloat(vsw[16u * i + 1u]),
                          uintBitsToFloat(vsw[16u * i + 2u])));
    if (pc.mode == 0u) {
        for (int a = 0; a < 3; a++)
            if (q[a] == q[a]) {
                atomicMin(ord[a], f2ord(q[a]));
                atomicMin(ord[3 + a], ~f2ord(q[a]));
            }
        return;
    }
    uint k = uint(coord(q.x, 0) + grid.dim[0] * (coord(q.y, 1) + grid.dim[1] * coord(q.z, 2)));
    cell_of[i] = k;
    for (int a = 0; a < 3; a++)
        if (q[a] == q[a]) {
            atomicMin(ord[6u + 6u * k + uint(a)], f2ord(q[a]));
            atomicMin(ord[6u + 6u * k + 3u + uint(a)], ~f2ord(q[a]));
        }
}
