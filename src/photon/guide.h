/* View-importance photon emission (docs/emission.md): photons are emitted preferentially along
 * the light paths whose photons land where the camera looks, with weights that keep the estimate
 * unbiased.
 *
 * The guide is a piecewise-constant density over the primary sample space of emission: the light
 * pick (grouped into at most PGI__GUIDE_GROUPS ranges of the light CDF, one per light when there
 * are few) times the two sample dimensions that steer the path most (the direction of a point or
 * spot light and of an area light's cosine lobe, the disk point of the sun and the sky). A bin's
 * probability mixes the uniform one (its volume V_b) with one proportional to V_b times the stored
 * photons per path of the bin that landed near a view sample. The tracer's first batch (the pilot)
 * is uniform and its evidence builds q; the paths after it follow q and carry the weight V_b / q_b
 * (at most 1 / MIX), and the pilot's photons are dropped: weighted by a q built from themselves
 * they would bias the estimate. Counts are integers, so the photons are the same for any thread
 * count. */
#ifndef PGI__GUIDE_H
#define PGI__GUIDE_H

#include "photongi/photongi.h"
#include "scene/scene_internal.h"

#define PGI__GUIDE_RES 8     /* bins along each steered dimension */
#define PGI__GUIDE_GROUPS 16 /* light-pick ranges */

/* Cells of the visible surfaces: a hash set of (cell, facing axis) keys of the view samples, the
 * test "does a photon land where the camera looks". */
typedef struct pgi__view_grid {
    uint64_t *keys; /* 0: empty */
    size_t mask;    /* capacity - 1 */
    size_t count;   /* distinct keys */
    float origin[3], inv_h, h;
} pgi__view_grid;

pgi_status pgi__view_grid_build(pgi__view_grid *g, const pgi_view_samples *vs, const float bmin[3], float h);
/* The conservative variant for view-culled storage: cells of size h >= 2 r, without facing; each
 * view sample marks every cell its box of half-width r touches, so a photon closer than r to any
 * view sample lies in a marked cell (pgi__view_grid_near). */
pgi_status pgi__view_grid_build_near(pgi__view_grid *g, const pgi_view_samples *vs, const float bmin[3], float h,
                                     float r);
void pgi__view_grid_free(pgi__view_grid *g);

/* Cell index of coordinate x along `axis` (20 bits, clamped). */
static inline int pgi__view_grid_cell(const pgi__view_grid *g, float x, int axis) {
    float v = (x - g->origin[axis]) * g->inv_h;
    return v < 0.f ? 0 : v > 1048575.f ? 1048575 : (int)v;
}

/* Key of cell (x, y, z) with facing code f (0..5; the conservative grid uses 0); never 0. */
static inline uint64_t pgi__view_grid_cell_key(int x, int y, int z, unsigned f) {
    return ((((uint64_t)x << 20 | (uint64_t)y) << 20 | (uint64_t)z) << 3 | f) + 1;
}

/* Key of a point on a surface of normal n: its cell, and the axis the surface faces most with its
 * sign (the two sides of a wall differ). */
static inline uint64_t pgi__view_grid_key(const pgi__view_grid *g, pgi__v3 p, pgi__v3 n) {
    float ax = fabsf(n.x), ay = fabsf(n.y), az = fabsf(n.z);
    unsigned f = ax >= ay && ax >= az ? (n.x < 0.f) : ay >= az ? 2u + (n.y < 0.f) : 4u + (n.z < 0.f);
    return pgi__view_grid_cell_key(pgi__view_grid_cell(g, p.x, 0), pgi__view_grid_cell(g, p.y, 1),
                                   pgi__view_grid_cell(g, p.z, 2), f);
}

static inline uint64_t pgi__view_grid_hash(uint64_t k) {
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    return k;
}

static inline int pgi__view_grid_find(const pgi__view_grid *g, uint64_t k) {
    for (size_t i = pgi__view_grid_hash(k) & g->mask;; i = (i + 1) & g->mask) {
        if (g->keys[i] == k) return 1;
        if (g->keys[i] == 0) return 0;
    }
}

static inline int pgi__view_grid_has(const pgi__view_grid *g, pgi__v3 p, pgi__v3 n) {
    return pgi__view_grid_find(g, pgi__view_grid_key(g, p, n));
}

/* Whether a photon at p may lie closer than r to a view sample (pgi__view_grid_build_near). */
static inline int pgi__view_grid_near(const pgi__view_grid *g, pgi__v3 p) {
    return pgi__view_grid_find(g,
                               pgi__view_grid_cell_key(pgi__view_grid_cell(g, p.x, 0), pgi__view_grid_cell(g, p.y, 1),
                                                       pgi__view_grid_cell(g, p.z, 2), 0));
}

/* Bytes the grid's table holds. */
static inline size_t pgi__view_grid_bytes(const pgi__view_grid *g) {
    return g->keys ? (g->mask + 1) * sizeof *g->keys : 0;
}

typedef struct pgi__guide {
    int groups, nbins;               /* groups * RES * RES bins */
    float gb[PGI__GUIDE_GROUPS + 1]; /* the groups' ranges of the light-pick number */
    int on;                          /* sample from q (else uniformly: the papers' emission) */
    float *cdf;                      /* of q over the bins */
    double *q;                       /* q_b: the probability the sampler really gives bin b (its share of
                                        the 2^24 values of pgi_rng_f below the float CDF) */
    /* evidence: paths traced, photons stored and stored near a view sample, per bin */
    double *paths, *stored, *useful;
    uint32_t *tcount; /* per thread: 3 * nbins counters of the batch */
    int nthreads;
    double gain;           /* predicted useful fraction of the stored photons under q over uniform's */
    double useful_uniform; /* useful fraction of stored photons with uniform emission (estimated) */
    double yield;          /* predicted stored photons per path under q */
    double yield_uniform;  /* ... and under uniform emission */
    double value;          /* predicted photons in view per unit of frame cost, q over uniform (PGI__GUIDE_BETA) */
    double in_view;        /* measured: fraction of the photons kept (steered, or all) that are in view */
    int carried;           /* pgi__guide_init kept the evidence of earlier frames (and it holds paths) */
} pgi__guide;

/* Lays out the bins for a light CDF (nl entries) and clears the evidence; with `keep`, the evidence
 * stays where the layout is the same as before (g->carried says it did and holds paths). */
pgi_status pgi__guide_init(pgi__guide *g, const float *light_cdf, size_t nl, int nthreads, int keep);
void pgi__guide_free(pgi__guide *g);
/* Bytes the guide holds. */
size_t pgi__guide_bytes(const pgi__guide *g);
/* Photons stored and stored in view, over all the evidence. */
void pgi__guide_totals(const pgi__guide *g, double *stored, double *useful);
/* Adds the per-thread counters of a batch to the evidence and zeroes them. */
void pgi__guide_collect(pgi__guide *g);
/* What a stored photon costs the rest of the frame (the estimator's build and gathers), in paths
 * traced: on Sibenik and the Cornell box about one (docs/emission.md, Auto). */
#define PGI__GUIDE_BETA 1.0
/* Rebuilds q from the evidence; g->on tells whether it is worth sampling from: its predicted value
 * (photons in view per unit of frame cost, over uniform emission's) at least `min_gain`. */
void pgi__guide_update(pgi__guide *g, double min_gain);

/* A bin's volume in the primary sample space: its probability under uniform emission. */
static inline double pgi__guide_volume(const pgi__guide *g, int b) {
    const int per = PGI__GUIDE_RES * PGI__GUIDE_RES, grp = b / per;
    return (double)(g->gb[grp + 1] - g->gb[grp]) / per;
}

/* Bin of uniform primary numbers (ul: light pick, a, b: the steered pair). */
static inline int pgi__guide_bin(const pgi__guide *g, float ul, float a, float b) {
    int lo = 0;
    while (lo + 1 < g->groups && ul >= g->gb[lo + 1]) lo++;
    int ia = (int)(a * PGI__GUIDE_RES), ib = (int)(b * PGI__GUIDE_RES);
    ia = ia < PGI__GUIDE_RES ? ia : PGI__GUIDE_RES - 1;
    ib = ib < PGI__GUIDE_RES ? ib : PGI__GUIDE_RES - 1;
    return (lo * PGI__GUIDE_RES + ia) * PGI__GUIDE_RES + ib;
}

/* Draws a bin from q with u and places three numbers in it (r0, r1, r2 uniform in [0,1)): the light
 * pick *ul and the steered pair *a, *b. Returns the bin. */
static inline int pgi__guide_sample(const pgi__guide *g, float u, float r0, float r1, float r2, float *ul, float *a,
                                    float *b) {
    float p;
    const int bin = (int)pgi__cdf_pick(g->cdf, (size_t)g->nbins, u, &p);
    const int grp = bin / (PGI__GUIDE_RES * PGI__GUIDE_RES), ia = bin / PGI__GUIDE_RES % PGI__GUIDE_RES,
              ib = bin % PGI__GUIDE_RES;
    const float inv = 1.f / PGI__GUIDE_RES;
    *ul = g->gb[grp] + r0 * (g->gb[grp + 1] - g->gb[grp]);
    if (!(*ul < g->gb[grp + 1])) *ul = nextafterf(g->gb[grp + 1], 0.f); /* stays in its light's range */
    /* in float, ia + r1 can round up to ia + 1: stay inside the bin */
    *a = fminf(((float)ia + r1) * inv, nextafterf((float)(ia + 1) * inv, 0.f));
    *b = fminf(((float)ib + r2) * inv, nextafterf((float)(ib + 1) * inv, 0.f));
    return bin;
}

#endif
