/* View samples seen through mirrors and glass, grouped by where they are.
 *
 * A sample reached through a specular bounce (no PGI_VS_PRIMARY) lies
 * anywhere in the reflected or refracted scene, not in its pixel's frustum: a
 * curved mirror shows the whole scene in a few pixels. Screen-space bounds
 * (tiles, clusters keyed by tile and depth) then span the whole scene and
 * catch nearly every photon. Here such samples get bounds of their own: a
 * uniform grid in view space with cells of edge h >= 2r, hashed (only the
 * occupied cells exist), each occupied cell holding its samples in pixel
 * order and their tight box. A photon looks up the (at most 2 x 2 x 2) cells
 * its sphere can touch, so it reaches only the specular-seen samples near it.
 *
 * The cells are found in pixel order, so the layout does not depend on the
 * thread count. When the samples would occupy more than `max_cells` cells,
 * the edge doubles until they fit. */
#ifndef PGI__EST_SPEC_CELLS_H
#define PGI__EST_SPEC_CELLS_H

#include "buf.h"
#include "screen.h"

typedef struct pgi__spec_cells {
    uint32_t n;                 /* occupied cells */
    uint32_t nsamples;          /* specular-seen samples */
    float o[3], h, inv_h;       /* grid origin (box of the samples' low corner), cell edge */
    int dim[3];                 /* cells a side (the grid's extent) */
    float lo[3], hi[3];         /* box of every specular-seen sample (empty when n == 0) */
    PGI__BUF(uint32_t, start);  /* n + 1: cell k holds sample[start[k] .. start[k+1]) */
    PGI__BUF(uint32_t, sample); /* pixel indices, cell by cell, pixel order inside a cell */
    PGI__BUF(float, box);       /* 6 per cell: lo xyz, hi xyz (view space) */
    PGI__BUF(uint64_t, hkey);   /* open-addressing table: packed cell coordinates + 1 (0: empty) */
    PGI__BUF(uint32_t, hval);   /* the cell's index */
    uint32_t hmask;
    PGI__BUF(float, q);        /* build scratch: view-space positions */
    PGI__BUF(uint32_t, pix);   /* build scratch: pixel index per sample */
    PGI__BUF(uint32_t, scell); /* build scratch: cell per sample */
    PGI__BUF(uint32_t, cur);   /* build scratch: write cursor per cell */
} pgi__spec_cells;

/* The cell budget of an estimator with ntiles screen tiles: at most 8192 cells
 * (or as many as tiles), about 256 bytes of per-chunk counters each. On
 * cornell-mirrors at 5M photons, 1024 cells read 1.45x the photons of 8192;
 * unbounded cells cost 4 GB. */
static inline uint32_t pgi__spec_cells_cap(int ntiles) { return (uint32_t)(ntiles > 8192 ? ntiles : 8192); }

/* Lists the valid samples of vs without PGI_VS_PRIMARY in pixel order (pix,
 * room for all of them) with their view-space positions (q, 3 a sample) and
 * box [lo, hi]; returns how many. Shared with the cluster family's build. */
size_t pgi__spec_samples(const pgi_view_samples *vs, const pgi__view_xf *x, uint32_t *pix, float *q, float lo[3],
                         float hi[3], int threads);

/* Groups the valid samples without PGI_VS_PRIMARY of vs; r is the gather
 * radius. */
pgi_status pgi__spec_cells_build(pgi__spec_cells *sc, const pgi_view_samples *vs, const pgi__view_xf *x, float r,
                                 uint32_t max_cells, int threads);
void pgi__spec_cells_free(pgi__spec_cells *sc);
/* Bytes held (for the stats). */
size_t pgi__spec_cells_bytes(const pgi__spec_cells *sc);

/* The cell coordinate along axis a of view-space value v, clamped to the grid. */
static inline int pgi__spec_cell_coord(const pgi__spec_cells *sc, float v, int a) {
    float f = floorf((v - sc->o[a]) * sc->inv_h);
    return f < 0.f ? 0 : (f > (float)(sc->dim[a] - 1) ? sc->dim[a] - 1 : (int)f);
}

static inline uint64_t pgi__spec_cell_key(int ix, int iy, int iz) {
    return ((uint64_t)ix << 42 | (uint64_t)iy << 21 | (uint64_t)iz) + 1;
}

static inline uint32_t pgi__spec_cell_find(const pgi__spec_cells *sc, uint64_t key) {
    uint32_t hsh = (uint32_t)((key * 0x9E3779B97F4A7C15ull) >> 32) & sc->hmask;
    for (;;) {
        uint64_t k = sc->hkey[hsh];
        if (k == key) return sc->hval[hsh];
        if (k == 0) return UINT32_MAX;
        hsh = (hsh + 1) & sc->hmask;
    }
}

/* Whether the sphere (c, padded radius rr) reaches the box of cell k. */
static inline int pgi__spec_cell_near(const pgi__spec_cells *sc, uint32_t k, pgi__v3 c, float rr) {
    const float *b = sc->box + 6 * (size_t)k;
    return pgi__box_d2(b, b + 3, c) <= rr * rr;
}

/* The cells the sphere (view-space centre C_, radius RR_, already padded for
 * rounding) may touch: BODY runs with `k_` the cell index, in increasing
 * cell-coordinate order. */
#define PGI__FOR_EACH_SPEC_CELL(SC_, C_, RR_, BODY)                                                                    \
    do {                                                                                                               \
        const pgi__spec_cells *sc_ = (SC_);                                                                            \
        if (!sc_->n) break;                                                                                            \
        float cc_[3] = {(C_).x, (C_).y, (C_).z};                                                                       \
        int i0_[3], i1_[3], out_ = 0;                                                                                  \
        for (int a_ = 0; a_ < 3; a_++) {                                                                               \
            if (cc_[a_] + (RR_) < sc_->lo[a_] || cc_[a_] - (RR_) > sc_->hi[a_]) out_ = 1;                              \
            i0_[a_] = pgi__spec_cell_coord(sc_, cc_[a_] - (RR_), a_);                                                  \
            i1_[a_] = pgi__spec_cell_coord(sc_, cc_[a_] + (RR_), a_);                                                  \
        }                                                                                                              \
        if (out_) break;                                                                                               \
        for (int ix_ = i0_[0]; ix_ <= i1_[0]; ix_++)                                                                   \
            for (int iy_ = i0_[1]; iy_ <= i1_[1]; iy_++)                                                               \
                for (int iz_ = i0_[2]; iz_ <= i1_[2]; iz_++) {                                                         \
                    uint32_t k_ = pgi__spec_cell_find(sc_, pgi__spec_cell_key(ix_, iy_, iz_));                         \
                    if (k_ != UINT32_MAX && pgi__spec_cell_near(sc_, k_, (C_), (RR_))) { BODY; }                       \
                }                                                                                                      \
    } while (0)

#endif
