// The mirror-seen samples' cells a photon reaches (spec_cells.h PGI__FOR_EACH_SPEC_CELL, on the
// grid tl_cells.comp builds), shared by GPU tiled's and the bounds estimators' lists. The including
// shader declares visit(t, j) (t: the list, the tiles' first, then a list per cell) and binds the
// grid at binding 3 and the cells' boxes at binding 4.
#ifndef PGIS_CELLS_GLSL
#define PGIS_CELLS_GLSL

layout(std430, binding = 3) readonly buffer Grid { CellGrid grid; };
layout(std430, binding = 4) readonly buffer CellBox { float cell_box[]; }; // 6 a cell: lo, hi

// spec_cells.h pgi__spec_cell_coord
int spec_coord(float v, int a) {
    precise float f = floor((v - grid.o[a]) * grid.inv_h);
    return f < 0.0 ? 0 : (f > float(grid.dim[a] - 1) ? grid.dim[a] - 1 : int(f));
}

// Every cell whose box of samples the sphere (view-space centre c, padded radius rr) reaches:
// visit(pc.ntiles + cell, j), cells in index order.
void visit_cells(uint j, vec3 c, float rr) {
    if (grid.n == 0u) return;
    int i0[3], i1[3];
    for (int a = 0; a < 3; a++) {
        if (c[a] + rr < grid.lo[a] || c[a] - rr > grid.hi[a]) return;
        i0[a] = spec_coord(c[a] - rr, a);
        i1[a] = spec_coord(c[a] + rr, a);
    }
    for (int ix = i0[0]; ix <= i1[0]; ix++)
        for (int iy = i0[1]; iy <= i1[1]; iy++)
            for (int iz = i0[2]; iz <= i1[2]; iz++) {
                uint k = uint(ix + grid.dim[0] * (iy + grid.dim[1] * iz)); // an empty cell's box is empty
                vec3 lo = vec3(cell_box[6u * k], cell_box[6u * k + 1u], cell_box[6u * k + 2u]);
                vec3 hi = vec3(cell_box[6u * k + 3u], cell_box[6u * k + 4u], cell_box[6u * k + 5u]);
                if (box_d2(lo, hi, c) <= rr * rr) visit(pc.ntiles + k, j);
            }
}

#endif
