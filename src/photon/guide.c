/* View-importance photon emission: the guide's tables and the cells the camera sees (guide.h). */
#include "guide.h"

#include <stdlib.h>
#include <string.h>

#include "core/core.h"

/* ------------------------------------------------------------- view grid */

static int grid_insert(pgi__view_grid *g, uint64_t k) {
    for (size_t i = pgi__view_grid_hash(k) & g->mask;; i = (i + 1) & g->mask) {
        if (g->keys[i] == k) return 0;
        if (g->keys[i] == 0) {
            g->keys[i] = k;
            g->count++;
            return 1;
        }
    }
}

static int grid_grow(pgi__view_grid *g) {
    size_t cap = 2 * (g->mask + 1);
    uint64_t *old = g->keys, *nk = calloc(cap, sizeof *nk);
    if (!nk) return 0;
    size_t n = g->mask + 1;
    g->keys = nk;
    g->mask = cap - 1;
    g->count = 0;
    for (size_t i = 0; i < n; i++)
        if (old[i]) grid_insert(g, old[i]);
    free(old);
    return 1;
}

/* Inserts k, growing the table first when it would pass half full; 0 when out of memory. */
static int grid_add(pgi__view_grid *g, uint64_t k) {
    if (2 * (g->count + 1) > g->mask + 1 && !grid_grow(g)) return 0;
    grid_insert(g, k);
    return 1;
}

/* Empties the grid (keeping its table between frames) and places its cells. */
static pgi_status grid_reset(pgi__view_grid *g, const float bmin[3], float h) {
    if (!(h > 0.f)) return pgi__fail(PGI_ERR_INVALID_ARG, "view grid cell %g is not positive", (double)h);
    if (!g->keys) {
        g->keys = calloc(1u << 16, sizeof *g->keys);
        if (!g->keys) return pgi__fail(PGI_ERR_OOM, "%s", "out of memory for the view grid");
        g->mask = (1u << 16) - 1;
    } else {
        memset(g->keys, 0, (g->mask + 1) * sizeof *g->keys);
    }
    g->count = 0;
    g->h = h;
    g->inv_h = 1.f / h;
    memcpy(g->origin, bmin, sizeof g->origin);
    return PGI_OK;
}

pgi_status pgi__view_grid_build(pgi__view_grid *g, const pgi_view_samples *vs, const float bmin[3], float h) {
    pgi_status st = grid_reset(g, bmin, h);
    if (st) return st;
    uint64_t last = 0;
    for (size_t i = 0; i < vs->count; i++) {
        if (!(vs->flags[i] & PGI_VS_VALID)) continue;
        uint64_t k = pgi__view_grid_key(g, v3_load(vs->pos + 3 * i), v3_load(vs->ngeo + 3 * i));
        if (k == last) continue; /* neighbouring pixels mostly share a cell */
        last = k;
        if (!grid_add(g, k)) return pgi__fail(PGI_ERR_OOM, "%s", "out of memory for the view grid");
    }
    return PGI_OK;
}

pgi_status pgi__view_grid_build_near(pgi__view_grid *g, const pgi_view_samples *vs, const float bmin[3], float h,
                                     float r) {
    pgi_status st = grid_reset(g, bmin, h);
    if (st) return st;
    int last[6] = {-1, -1, -1, -1, -1, -1};
    for (size_t i = 0; i < vs->count; i++) {
        if (!(vs->flags[i] & PGI_VS_VALID)) continue;
        const float *p = vs->pos + 3 * i;
        int box[6]; /* lowest cells, then highest, of the sample's box of half-width r */
        for (int a = 0; a < 3; a++) {
            box[a] = pgi__view_grid_cell(g, p[a] - r, a);
            box[3 + a] = pgi__view_grid_cell(g, p[a] + r, a);
        }
        if (memcmp(box, last, sizeof box) == 0) continue; /* neighbouring pixels mostly mark the same cells */
        memcpy(last, box, sizeof box);
        for (int x = box[0]; x <= box[3]; x++)
            for (int y = box[1]; y <= box[4]; y++)
                for (int z = box[2]; z <= box[5]; z++)
                    if (!grid_add(g, pgi__view_grid_cell_key(x, y, z, 0)))
                        return pgi__fail(PGI_ERR_OOM, "%s", "out of memory for the view grid");
    }
    return PGI_OK;
}

void pgi__view_grid_free(pgi__view_grid *g) {
    free(g->keys);
    memset(g, 0, sizeof *g);
}

/* ----------------------------------------------------------------- guide */

pgi_status pgi__guide_init(pgi__guide *g, const float *light_cdf, size_t nl, int nthreads, int keep) {
    const int groups = nl <= PGI__GUIDE_GROUPS ? (int)nl : PGI__GUIDE_GROUPS;
    const int nbins = groups * PGI__GUIDE_RES * PGI__GUIDE_RES;
    float gb[PGI__GUIDE_GROUPS + 1];
    gb[0] = 0.f;
    for (int i = 1; i <= groups; i++) gb[i] = nl <= PGI__GUIDE_GROUPS ? light_cdf[i - 1] : (float)i / (float)groups;
    gb[groups] = 1.f;
    g->carried = 0;
    if (keep && g->paths && g->nbins == nbins && g->groups == groups && g->nthreads >= nthreads &&
        memcmp(g->gb, gb, (size_t)(groups + 1) * sizeof *gb) == 0) {
        double n = 0;
        for (int b = 0; b < nbins; b++) n += g->paths[b];
        g->carried = n > 0;
        if (g->carried) { /* the evidence and q stay; the batch counters start at zero */
            memset(g->tcount, 0, (size_t)g->nthreads * 3 * (size_t)nbins * sizeof *g->tcount);
            return PGI_OK;
        }
    }
    if (g->nbins != nbins || g->nthreads < nthreads) {
        pgi__guide_free(g);
        g->cdf = malloc((size_t)nbins * sizeof *g->cdf);
        g->q = malloc((size_t)nbins * sizeof *g->q);
        g->paths = malloc((size_t)nbins * 3 * sizeof *g->paths);
        g->tcount = malloc((size_t)nthreads * 3 * (size_t)nbins * sizeof *g->tcount);
        if (!g->cdf || !g->q || !g->paths || !g->tcount) {
            pgi__guide_free(g);
            return pgi__fail(PGI_ERR_OOM, "%s", "out of memory for the emission guide");
        }
        g->nbins = nbins;
        g->nthreads = nthreads;
    }
    g->stored = g->paths + nbins;
    g->useful = g->paths + 2 * nbins;
    g->groups = groups;
    memcpy(g->gb, gb, (size_t)(groups + 1) * sizeof *gb);
    memset(g->paths, 0, (size_t)nbins * 3 * sizeof *g->paths);
    memset(g->tcount, 0, (size_t)g->nthreads * 3 * (size_t)nbins * sizeof *g->tcount);
    g->on = 0;
    g->gain = 1.0;
    g->useful_uniform = 0.0;
    return PGI_OK;
}

size_t pgi__guide_bytes(const pgi__guide *g) {
    const size_t n = (size_t)g->nbins;
    return n * (sizeof *g->cdf + sizeof *g->q + 3 * sizeof *g->paths) + (size_t)g->nthreads * 3 * n * sizeof *g->tcount;
}

void pgi__guide_free(pgi__guide *g) {
    free(g->cdf);
    free(g->q);
    free(g->paths);
    free(g->tcount);
    memset(g, 0, sizeof *g);
}

void pgi__guide_totals(const pgi__guide *g, double *stored, double *useful) {
    double s = 0, u = 0;
    for (int b = 0; b < g->nbins; b++) {
        s += g->stored[b];
        u += g->useful[b];
    }
    *stored = s;
    *useful = u;
}

void pgi__guide_collect(pgi__guide *g) {
    const size_t n = (size_t)g->nbins;
    for (int t = 0; t < g->nthreads; t++) {
        uint32_t *c = g->tcount + (size_t)t * 3 * n;
        for (size_t b = 0; b < 3 * n; b++) g->paths[b] += c[b]; /* paths, stored, useful are contiguous */
        memset(c, 0, 3 * n * sizeof *c);
    }
}

/* The uniform density's share of q: exploration, and a bound (1 / MIX) on a path's weight. Measured
 * on two-rooms (docs/emission.md): 0.25 and 0.1 steer more photons into view but their heavier
 * weights cost more than that gains. */
#define MIX 0.5
/* Prior strength, in paths: a bin with little evidence looks like the average bin (the pilot gives
 * a bin a few dozen paths; a weaker prior lets their noise into the weights). */
#define PRIOR 16.0

/* Photons (stored, or stored in view) per path of a bin: its counts with PRIOR paths at the
 * average rate `bar`. */
static inline double rate(double photons, double paths, double bar) {
    return (photons + PRIOR * bar) / (paths + PRIOR);
}

void pgi__guide_update(pgi__guide *g, double min_gain) {
    const int n = g->nbins;
    double N = 0, S = 0, U = 0;
    pgi__guide_totals(g, &S, &U);
    for (int b = 0; b < n; b++) N += g->paths[b];
    g->on = 0;
    g->gain = g->value = 1.0;
    g->useful_uniform = S > 0 ? U / S : 0.0;
    g->yield = g->yield_uniform = N > 0 ? S / N : 0.0;
    if (!(U >= 32.0) || !(S > U)) return; /* too little evidence, or every photon lands in view */
    const double ebar = U / N, sbar = S / N;
    /* useful (e) and stored (s) photons a path from each bin, expected under uniform emission */
    double ue = 0, us = 0;
    for (int b = 0; b < n; b++) {
        const double V = pgi__guide_volume(g, b);
        ue += V * rate(g->useful[b], g->paths[b], ebar);
        us += V * rate(g->stored[b], g->paths[b], sbar);
    }
    /* q ~ MIX V + (1 - MIX) V e / ue, and the same expectations under q */
    double acc = 0, qe = 0, qs = 0;
    for (int b = 0; b < n; b++) {
        const double V = pgi__guide_volume(g, b), e = rate(g->useful[b], g->paths[b], ebar);
        const double q = MIX * V + (1.0 - MIX) * V * e / ue;
        qe += q * e;
        qs += q * rate(g->stored[b], g->paths[b], sbar);
        acc += q;
        g->cdf[b] = (float)acc;
    }
    for (int b = 0; b < n; b++) g->cdf[b] = (float)(g->cdf[b] / acc);
    g->cdf[n - 1] = 1.f;
    /* The weights use the probability each bin really has: pgi__cdf_pick takes the first bin with
       u < cdf[b], and u is one of 2^24 grid values. */
    for (int b = 0; b < n; b++) {
        const double lo = b ? ceil((double)g->cdf[b - 1] * 16777216.0) : 0.0;
        g->q[b] = (ceil((double)g->cdf[b] * 16777216.0) - lo) / 16777216.0;
    }
    g->useful_uniform = ue / us;
    g->gain = (qe / qs) / (ue / us);
    g->yield = qs / acc;
    g->yield_uniform = us;
    /* A frame of a given number of stored photons costs 1/yield paths a photon, plus about
       PGI__GUIDE_BETA paths' worth of estimator work a photon: steering pays when its photons in view
       per unit of that cost beat uniform emission's (a scene whose paths mostly store nothing, a sky
       over a closed building, gains by the paths saved even when the in-view fraction barely moves). */
    g->value = g->gain * (1.0 / us + PGI__GUIDE_BETA) / (1.0 / g->yield + PGI__GUIDE_BETA);
    g->on = g->value >= min_gain;
}
