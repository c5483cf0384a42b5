/* View samples seen through mirrors and glass, grouped by position (spec_cells.h). */
#include <string.h>

#include "spec_cells.h"

#define CELL_BITS 21 /* per axis, in the packed key */

size_t pgi__spec_samples(const pgi_view_samples *vs, const pgi__view_xf *x, uint32_t *pix, float *q, float lo[3],
                         float hi[3], int threads) {
    const size_t np = vs->count;
    size_t n = 0;
    for (size_t i = 0; i < np; i++)
        if ((vs->flags[i] & (PGI_VS_VALID | PGI_VS_PRIMARY)) == PGI_VS_VALID) pix[n++] = (uint32_t)i;
#pragma omp parallel for schedule(static) num_threads(threads)
    for (long long k = 0; k < (long long)n; k++) {
        const float *p = vs->pos + 3 * (size_t)pix[k];
        pgi__v3 v = pgi__to_view(x, p[0], p[1], p[2]);
        q[3 * k] = v.x, q[3 * k + 1] = v.y, q[3 * k + 2] = v.z;
    }
    for (int a = 0; a < 3; a++) lo[a] = INFINITY, hi[a] = -INFINITY;
    for (size_t k = 0; k < n; k++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fminf(lo[a], q[3 * k + a]);
            hi[a] = fmaxf(hi[a], q[3 * k + a]);
        }
    return n;
}

pgi_status pgi__spec_cells_build(pgi__spec_cells *sc, const pgi_view_samples *vs, const pgi__view_xf *x, float r,
                                 uint32_t max_cells, int threads) {
    pgi_status st;
    const size_t np = vs->count;
    sc->n = 0;
    sc->nsamples = 0;
    for (int a = 0; a < 3; a++) sc->lo[a] = INFINITY, sc->hi[a] = -INFINITY;
    size_t ns = 0;
    for (size_t i = 0; i < np; i++) ns += (vs->flags[i] & (PGI_VS_VALID | PGI_VS_PRIMARY)) == PGI_VS_VALID;
    if (ns == 0) return PGI_OK;
    if (ns > UINT32_MAX / 2) return pgi__fail(PGI_ERR_UNSUPPORTED, "too many view samples");
    if (max_cells < 1) max_cells = 1;
    if ((st = pgi__buf_reserve(&sc->q_buf, 3 * ns, sizeof(float))) ||
        (st = pgi__buf_reserve(&sc->pix_buf, ns, sizeof(uint32_t))) ||
        (st = pgi__buf_reserve(&sc->scell_buf, ns, sizeof(uint32_t))) ||
        (st = pgi__buf_reserve(&sc->sample_buf, ns, sizeof(uint32_t))))
        return st;
    sc->nsamples = (uint32_t)pgi__spec_samples(vs, x, sc->pix, sc->q, sc->lo, sc->hi, threads);
    for (int a = 0; a < 3; a++)
        if (!(sc->lo[a] <= sc->hi[a]) || !isfinite(sc->lo[a]) || !isfinite(sc->hi[a]))
            return pgi__fail(PGI_ERR_INVALID_ARG, "view samples seen through mirrors have non-finite positions");
    /* Cells of edge >= 2r: a sphere touches at most two a side. Coarser when
     * the grid would need more than 2^21 cells a side. */
    float ext = 0.f;
    for (int a = 0; a < 3; a++) ext = fmaxf(ext, sc->hi[a] - sc->lo[a]);
    float h = fmaxf(2.f * r * 1.001f, ext / (float)((1 << CELL_BITS) - 2));
    if (!(h > 0.f)) h = 1.f;
    uint32_t hsize = 64;
    while (hsize < 2 * max_cells + 2) hsize *= 2;
    if ((st = pgi__buf_reserve(&sc->hkey_buf, hsize, sizeof(uint64_t))) ||
        (st = pgi__buf_reserve(&sc->hval_buf, hsize, sizeof(uint32_t))))
        return st;
    sc->hmask = hsize - 1;
    for (;;) {
        sc->h = h;
        sc->inv_h = 1.f / h;
        for (int a = 0; a < 3; a++) {
            sc->o[a] = sc->lo[a];
            float f = floorf((sc->hi[a] - sc->o[a]) * sc->inv_h);
            sc->dim[a] = (f < (float)((1 << CELL_BITS) - 1) ? (int)f : (1 << CELL_BITS) - 2) + 1;
        }
        memset(sc->hkey, 0, (size_t)hsize * sizeof(uint64_t));
        uint32_t n = 0;
        int full = 0;
        for (size_t k = 0; k < ns && !full; k++) {
            const float *q = sc->q + 3 * k;
            uint64_t key = pgi__spec_cell_key(pgi__spec_cell_coord(sc, q[0], 0), pgi__spec_cell_coord(sc, q[1], 1),
                                              pgi__spec_cell_coord(sc, q[2], 2));
            uint32_t hsh = (uint32_t)((key * 0x9E3779B97F4A7C15ull) >> 32) & sc->hmask;
            while (sc->hkey[hsh] != 0 && sc->hkey[hsh] != key) hsh = (hsh + 1) & sc->hmask;
            if (sc->hkey[hsh] == 0) {
                if (n == max_cells) {
                    full = 1;
                    break;
                }
                sc->hkey[hsh] = key;
                sc->hval[hsh] = n++;
            }
            sc->scell[k] = sc->hval[hsh];
        }
        if (!full) {
            sc->n = n;
            break;
        }
        h *= 2.f;
    }
    /* Samples cell by cell (a stable counting sort: pixel order inside a cell), and the cells' boxes. */
    const uint32_t n = sc->n;
    if ((st = pgi__buf_reserve(&sc->start_buf, (size_t)n + 1, sizeof(uint32_t))) ||
        (st = pgi__buf_reserve(&sc->box_buf, 6 * (size_t)n, sizeof(float))))
        return st;
    memset(sc->start, 0, ((size_t)n + 1) * sizeof(uint32_t));
    for (size_t k = 0; k < ns; k++) sc->start[sc->scell[k] + 1]++;
    for (uint32_t c = 0; c < n; c++) sc->start[c + 1] += sc->start[c];
    for (uint32_t c = 0; c < n; c++) {
        float *b = sc->box + 6 * (size_t)c;
        b[0] = b[1] = b[2] = INFINITY;
        b[3] = b[4] = b[5] = -INFINITY;
    }
    for (size_t k = 0; k < ns; k++) {
        float *b = sc->box + 6 * (size_t)sc->scell[k];
        for (int a = 0; a < 3; a++) {
            b[a] = fminf(b[a], sc->q[3 * k + a]);
            b[3 + a] = fmaxf(b[3 + a], sc->q[3 * k + a]);
        }
    }
    if ((st = pgi__buf_reserve(&sc->cur_buf, (size_t)n, sizeof(uint32_t)))) return st;
    memcpy(sc->cur, sc->start, (size_t)n * sizeof(uint32_t));
    for (size_t k = 0; k < ns; k++) sc->sample[sc->cur[sc->scell[k]]++] = sc->pix[k];
    return PGI_OK;
}

void pgi__spec_cells_free(pgi__spec_cells *sc) {
    pgi__buf *b[] = {&sc->start_buf, &sc->sample_buf, &sc->box_buf,   &sc->hkey_buf, &sc->hval_buf,
                     &sc->q_buf,     &sc->pix_buf,    &sc->scell_buf, &sc->cur_buf};
    for (size_t k = 0; k < sizeof b / sizeof b[0]; k++) pgi__buf_free(b[k]);
}

size_t pgi__spec_cells_bytes(const pgi__spec_cells *sc) {
    const pgi__buf *b[] = {&sc->start_buf, &sc->sample_buf, &sc->box_buf,   &sc->hkey_buf, &sc->hval_buf,
                           &sc->q_buf,     &sc->pix_buf,    &sc->scell_buf, &sc->cur_buf};
    size_t elem[] = {4, 4, 4, 8, 4, 4, 4, 4, 4}, sum = 0;
    for (size_t k = 0; k < sizeof b / sizeof b[0]; k++) sum += b[k]->cap * elem[k];
    return sum;
}
