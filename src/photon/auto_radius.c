/* The automatic gather radius (auto_radius.h). */
#include "auto_radius.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/core.h"

/* Photons a gather disk should hold at the quantile, and the quantile of the view samples'
 * K-th-neighbour distances: 3 in 4 of the samples the camera sees gather at least K. K grows with
 * the photon count N as N^(2/3), the mean-square-error optimum of a 2-D density estimate (bias ~
 * r^2, variance ~ 1 / (N r^2), so r ~ N^(-1/6)): AUTO_K at AUTO_K_AT photons, within
 * [AUTO_K_MIN, AUTO_K_MAX]. Tuned on Sibenik and the Cornell box against converged references
 * (docs/radius.md). */
#define AUTO_K 32
#define AUTO_K_AT 200000.0
#define AUTO_K_MIN 16
#define AUTO_K_MAX 256
#define AUTO_QUANTILE 0.75f
/* Above this many photons, every s-th photon stands for s of them (and K/s is sought among them),
 * s at most K / AUTO_K_SUB so that at least AUTO_K_SUB are still sought. */
#define AUTO_PHOTONS 262144
#define AUTO_K_SUB 32
/* The cost cap: the radius shrinks until the mean photons a query gathers is at most
 * max(AUTO_MEAN_CAP, AUTO_MEAN_CAP_K x K) (K grows with the photons, and a quantile of K-th
 * distances already means somewhat more than K on average); each query counts at most
 * AUTO_TERM_CAP_K x K, so that one caustic does not decide the frame's radius. */
#define AUTO_MEAN_CAP 400.0
#define AUTO_MEAN_CAP_K 8.0
#define AUTO_TERM_CAP_K 64.0
/* The clamp, as fractions of the scene's diagonal. */
#define AUTO_LO 1e-4f
#define AUTO_HI 0.05f

typedef struct grid {
    float cell, inv, org[3]; /* cell edge, its inverse, where cell 0 starts */
    uint32_t mask;           /* buckets - 1 */
    uint32_t *start;         /* buckets + 1 offsets into idx */
    uint32_t *idx;           /* photon indices, bucket by bucket, in photon order */
    int32_t *cx, *cy, *cz;   /* each photon's cell */
} grid;

/* Bricks of 4 x 2 x 2 cells share a hash and take 16 consecutive buckets: a query visits a brick's
 * cells close together, and their offsets (64 bytes) and photon indices are then in the same cache
 * lines. */
static inline uint32_t cell_hash(int32_t x, int32_t y, int32_t z, uint32_t mask) {
    uint32_t h = (uint32_t)(x >> 2) * 73856093u ^ (uint32_t)(y >> 1) * 19349663u ^ (uint32_t)(z >> 1) * 83492791u;
    return (h << 4 | ((uint32_t)z & 1u) << 3 | ((uint32_t)y & 1u) << 2 | ((uint32_t)x & 3u)) & mask;
}

/* The cell of coordinate v along an axis whose cells start at o: counted from the photons' box,
 * so that the index stays small (|v - o| is at most the scene's extent, the cell at least 1e-4 of
 * its diagonal); clamped all the same, for a query far outside it. */
static inline int32_t cell_of(float v, float o, float inv) {
    float c = floorf((v - o) * inv);
    return c < -1e6f ? -1000000 : c > 1e6f ? 1000000 : (int32_t)c;
}

static void grid_free(grid *g) {
    free(g->start);
    free(g->idx);
    free(g->cx);
    free(g->cy);
    free(g->cz);
    memset(g, 0, sizeof *g);
}

/* Counting sort of the photons into hashed cells of edge `cell`: the photons' cells and buckets in
 * parallel (each photon's alone), then the counts and the placing in photon order, sequential (the
 * order, and so everything after, is the same for any thread count). */
static pgi_status grid_build(const pgi_photons *ph, float cell, const float org[3], int threads, grid *g) {
    const size_t n = ph->count;
    /* a bucket a photon or more: a query's empty cells then mostly fall in empty buckets (a
     * collision is an unpredictable branch on a photon's cell, read from far away; half the buckets
     * were 1.05x slower on Sibenik) */
    uint32_t buckets = 1024;
    while (buckets < n && buckets < (1u << 27)) buckets <<= 1;
    g->cell = cell;
    g->inv = 1.f / cell;
    memcpy(g->org, org, sizeof g->org);
    g->mask = buckets - 1;
    g->start = calloc((size_t)buckets + 1, sizeof *g->start);
    g->idx = malloc(n * sizeof *g->idx);
    g->cx = malloc(n * sizeof *g->cx);
    g->cy = malloc(n * sizeof *g->cy);
    g->cz = malloc(n * sizeof *g->cz);
    uint32_t *bk = malloc(n * sizeof *bk); /* each photon's bucket */
    if (!g->start || !g->idx || !g->cx || !g->cy || !g->cz || !bk) {
        free(bk);
        grid_free(g);
        return pgi__fail(PGI_ERR_OOM, "automatic radius: out of memory for a grid of %zu photons", n);
    }
    const long long np = (long long)n;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads)) if (np > 65536)
    for (long long i = 0; i < np; i++) {
        g->cx[i] = cell_of(ph->px[i], g->org[0], g->inv);
        g->cy[i] = cell_of(ph->py[i], g->org[1], g->inv);
        g->cz[i] = cell_of(ph->pz[i], g->org[2], g->inv);
        bk[i] = cell_hash(g->cx[i], g->cy[i], g->cz[i], g->mask);
    }
    for (size_t i = 0; i < n; i++) g->start[bk[i]]++;
    /* start[b] becomes the end of bucket b, then, filled from the last photon back, its beginning */
    for (uint32_t b = 1; b < buckets; b++) g->start[b] += g->start[b - 1];
    g->start[buckets] = (uint32_t)n;
    for (size_t i = n; i-- > 0;) g->idx[--g->start[bk[i]]] = (uint32_t)i;
    free(bk);
    return PGI_OK;
}

/* Rings of cells around a query: ring 1 is the 3x3x3 block around the query's cell, ring J > 1
 * the cells at Chebyshev distance J from it. After rings 1..J every photon within J cells of the
 * query has been seen, so a K-th distance of at most J * cell is exact. */
#define AUTO_RINGS 4

/* Max-heap of the K smallest squared distances seen. */
typedef struct kheap {
    float v[AUTO_K_MAX];
    int n, k;
} kheap;

static inline void kheap_push(kheap *h, float d2) {
    if (h->n < h->k) {
        int i = h->n++;
        while (i > 0 && h->v[(i - 1) / 2] < d2) {
            h->v[i] = h->v[(i - 1) / 2];
            i = (i - 1) / 2;
        }
        h->v[i] = d2;
    } else if (d2 < h->v[0]) {
        int i = 0;
        for (;;) {
            int l = 2 * i + 1, r = l + 1, m = i;
            float big = d2;
            if (l < h->k && h->v[l] > big) m = l, big = h->v[l];
            if (r < h->k && h->v[r] > big) m = r;
            if (m == i) break;
            h->v[i] = h->v[m];
            i = m;
        }
        h->v[i] = d2;
    }
}

/* Distance from coordinate v to cell c's interval along an axis (cells start at o, edge `cell`),
 * widened by m: a photon that cell_of puts in cell c lies within m of the interval. */
static inline double axis_gap(double v, double o, double cell, int32_t c, double m) {
    const double lo = o + (double)c * cell - m, hi = o + (double)(c + 1) * cell + m;
    return v < lo ? lo - v : v > hi ? v - hi : 0.0;
}

typedef struct query {
    const float *p, *n; /* the sample's position and normal */
    int32_t c[3];       /* its cell */
    int prune;          /* its cell is not clamped */
    /* squared axis_gap to the cells c[a] - AUTO_RINGS .. c[a] + AUTO_RINGS along each axis, once a
     * query rather than 3 a cell (the same doubles, so the same cells are skipped) */
    double gap2[3][2 * AUTO_RINGS + 1];
} query;

static void query_init(const grid *g, const float *p, const float *n, query *q) {
    q->p = p;
    q->n = n;
    const double cell = (double)g->cell;
    /* cell_of's products are within a few float roundings (~6e-8 relative) of the exact ones */
    const double m = 1e-3 * cell + 1e-5 * (fabs((double)p[0] - g->org[0]) + fabs((double)p[1] - g->org[1]) +
                                           fabs((double)p[2] - g->org[2]) + 8.0 * cell);
    for (int a = 0; a < 3; a++) {
        q->c[a] = cell_of(p[a], g->org[a], g->inv);
        for (int d = -AUTO_RINGS; d <= AUTO_RINGS; d++) {
            const double gap = axis_gap(p[a], g->org[a], cell, q->c[a] + d, m);
            q->gap2[a][d + AUTO_RINGS] = gap * gap;
        }
    }
    q->prune = abs(q->c[0]) < 900000 && abs(q->c[1]) < 900000 && abs(q->c[2]) < 900000;
}

/* Pushes into h the squared distances of ring J's photons that the sample (p, n) would gather
 * (arriving from its side).
 *
 * Once h holds K distances, a cell whose box is farther than the K-th of them is skipped: its
 * photons could not enter h (kheap_push drops d2 >= h->v[0], and h->v[0] only falls), so h->v[0],
 * the one value used, is what the full scan gives (the K smallest of a set do not depend on the
 * order they come in). The box is widened by m, more than cell_of's rounding can move a photon out
 * of it, and the test has a relative margin over the float d2's rounding: exact, not a heuristic.
 * Most of a query's cells are in its outermost ring, and most of those are past the K-th
 * distance. */
static void scan_ring(const grid *g, const pgi_photons *ph, const query *q, int J, kheap *h) {
    const float *p = q->p, *n = q->n;
    for (int dz = -J; dz <= J; dz++)
        for (int dy = -J; dy <= J; dy++) {
            /* ring J's cells: a whole row where dy or dz is at +-J, else the row's two ends */
            const int whole = J == 1 || abs(dz) == J || abs(dy) == J;
            for (int dx = -J; dx <= J; dx += whole ? 1 : 2 * J) {
                const int32_t x = q->c[0] + dx, y = q->c[1] + dy, z = q->c[2] + dz;
                if (q->prune && h->n == h->k) {
                    const double d2 =
                        q->gap2[0][dx + AUTO_RINGS] + q->gap2[1][dy + AUTO_RINGS] + q->gap2[2][dz + AUTO_RINGS];
                    if (d2 * (1.0 - 1e-4) > (double)h->v[0]) continue;
                }
                const uint32_t b = cell_hash(x, y, z, g->mask);
                for (uint32_t k = g->start[b]; k < g->start[b + 1]; k++) {
                    const uint32_t j = g->idx[k];
                    if (g->cx[j] != x || g->cy[j] != y || g->cz[j] != z) continue; /* a hash collision */
                    if (!(n[0] * ph->dx[j] + n[1] * ph->dy[j] + n[2] * ph->dz[j] > 0.f)) continue;
                    float ex = ph->px[j] - p[0], ey = ph->py[j] - p[1], ez = ph->pz[j] - p[2];
                    kheap_push(h, ex * ex + ey * ey + ez * ez);
                }
            }
        }
}

/* Up to PGI__AUTO_QUERIES valid samples spread evenly over the pixels. */
static int pick_queries(const pgi_view_samples *vs, uint32_t *q) {
    int m = 0;
    const size_t n = vs->count;
    const size_t want = n < PGI__AUTO_QUERIES ? n : PGI__AUTO_QUERIES;
    for (size_t j = 0; j < want; j++) {
        size_t i = (size_t)(((double)j + 0.5) * (double)n / (double)want);
        if (i < n && (vs->flags[i] & PGI_VS_VALID)) q[m++] = (uint32_t)i;
    }
    return m;
}

/* The choice on photons `ph` (maybe a subsample), seeking the K-th neighbour among them; `Kfull`
 * is what it stands for among all photons (the cost estimate). */
static pgi_status choose(const pgi_photons *ph, int K, int Kfull, const pgi_view_samples *vs, float diag, int threads,
                         float *radius, pgi_auto_radius_stats *out) {
    out->used = 1;
    out->quantile = AUTO_QUANTILE;
    out->lo = AUTO_LO * diag;
    out->hi = AUTO_HI * diag;
    out->mean_cap = fmax(AUTO_MEAN_CAP, AUTO_MEAN_CAP_K * (double)Kfull);
    *radius = 0.02f * diag;
    out->why = "no view sample or too few photons: 2% of the diagonal";
    uint32_t q[PGI__AUTO_QUERIES];
    const int m = pick_queries(vs, q);
    out->queries = m;
    if (m == 0 || ph->count < (size_t)K) return PGI_OK;

    /* First cell edge: the radius that would hold K photons if they were spread evenly over the
     * photons' bounding box's largest face; grown 4x while the quantile falls among the queries
     * that found fewer than K within 4 cells. */
    float bmin[3] = {INFINITY, INFINITY, INFINITY}, bmax[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < ph->count; i++) {
        const float p[3] = {ph->px[i], ph->py[i], ph->pz[i]};
        for (int a = 0; a < 3; a++) { /* not fminf, a libm call: 3 ms of 15 on Sibenik */
            bmin[a] = pgi_minf(p[a], bmin[a]);
            bmax[a] = pgi_maxf(p[a], bmax[a]);
        }
    }
    float ex = bmax[0] - bmin[0], ey = bmax[1] - bmin[1], ez = bmax[2] - bmin[2];
    float face = fmaxf(ex * ey, fmaxf(ey * ez, ex * ez));
    float cell = sqrtf(face * (float)K / (PGI__PI * (float)ph->count));
    cell = fminf(fmaxf(cell, out->lo), out->hi);
    float d[PGI__AUTO_QUERIES];
    const int qi = (int)(AUTO_QUANTILE * (float)(m - 1));
    grid g = {0};
    for (int attempt = 0;; attempt++) {
        pgi_status st = grid_build(ph, cell, bmin, threads, &g);
        if (st) return st;
#pragma omp parallel for schedule(dynamic, 16) num_threads(pgi__threads(threads))
        for (int j = 0; j < m; j++) {
            query qu;
            query_init(&g, vs->pos + 3 * (size_t)q[j], vs->nrm + 3 * (size_t)q[j], &qu);
            kheap h = {.n = 0, .k = K};
            d[j] = INFINITY;
            for (int J = 1; J <= AUTO_RINGS; J++) {
                scan_ring(&g, ph, &qu, J, &h);
                if (h.n == K && h.v[0] <= ((float)J * cell) * ((float)J * cell)) {
                    d[j] = sqrtf(h.v[0]);
                    break;
                }
            }
        }
        float sorted[PGI__AUTO_QUERIES];
        memcpy(sorted, d, (size_t)m * sizeof *d);
        qsort(sorted, (size_t)m, sizeof *sorted, pgi__cmp_float);
        if (isfinite(sorted[qi]) || cell >= out->hi || attempt == 3) {
            out->knn = sorted[qi];
            out->starved = 0;
            for (int j = 0; j < m; j++) out->starved += !isfinite(d[j]);
            break;
        }
        grid_free(&g);
        cell = fminf(4.f * cell, out->hi);
    }
    float r = isfinite(out->knn) ? out->knn : out->hi;
    out->why = !(r > out->lo)   ? "clamped to lo"
               : !(r < out->hi) ? "clamped to hi: the view sees few photons"
                                : "the k-th neighbour distance at the quantile";
    r = fminf(fmaxf(r, out->lo), out->hi);

    /* The cost cap: the mean number of photons a query gathers at r (bright parts of the view
     * hold many more than K), from each query's K-th distance as if the density were even within
     * it (K (r / d)^2; a starved query at most K (r / (rings * cell))^2); r shrinks by area when the
     * mean exceeds the cap. */
    double total = 0.0;
    const float reach = (float)AUTO_RINGS * g.cell;
    for (int j = 0; j < m; j++) {
        float dj = isfinite(d[j]) ? fmaxf(d[j], 1e-30f) : reach;
        total += fmin(AUTO_TERM_CAP_K * Kfull, (double)Kfull * ((double)r / dj) * ((double)r / dj));
    }
    out->mean_reads = total / m;
    if (out->mean_reads > out->mean_cap) {
        r = fmaxf(out->lo, r * (float)sqrt(out->mean_cap / out->mean_reads));
        out->why = "capped: gathers would read too many photons";
    }
    grid_free(&g);
    *radius = r;
    return PGI_OK;
}

pgi_status pgi__auto_radius_choose(const pgi_photons *ph, const pgi_view_samples *vs, float diag, int threads,
                                   float *radius, pgi_auto_radius_stats *out) {
    memset(out, 0, sizeof *out);
    int K = (int)lround(AUTO_K * pow((double)ph->count / AUTO_K_AT, 2.0 / 3.0));
    K = K < AUTO_K_MIN ? AUTO_K_MIN : K > AUTO_K_MAX ? AUTO_K_MAX : K;
    out->k = K;
    size_t stride = ph->count / AUTO_PHOTONS;
    if (stride > (size_t)(K / AUTO_K_SUB)) stride = (size_t)(K / AUTO_K_SUB);
    if (stride <= 1) return choose(ph, K, K, vs, diag, threads, radius, out);
    /* every stride-th photon, K / stride of them sought */
    const size_t ns = ph->count / stride;
    float *buf = malloc(6 * ns * sizeof *buf);
    if (!buf) return pgi__fail(PGI_ERR_OOM, "automatic radius: out of memory for %zu photons", ns);
    pgi_photons sub = {.count = ns, .capacity = ns};
    float **dst[6] = {&sub.px, &sub.py, &sub.pz, &sub.dx, &sub.dy, &sub.dz};
    const float *src[6] = {ph->px, ph->py, ph->pz, ph->dx, ph->dy, ph->dz};
    for (int a = 0; a < 6; a++) {
        *dst[a] = buf + (size_t)a * ns;
        for (size_t i = 0; i < ns; i++) (*dst[a])[i] = src[a][i * stride];
    }
    pgi_status st = choose(&sub, (int)lround((double)K / (double)stride), K, vs, diag, threads, radius, out);
    free(buf);
    return st;
}
