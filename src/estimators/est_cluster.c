/* cluster, cluster-cone, cluster-trivial, directional: photon splatting into a
 * view-sample cluster hierarchy (Moreau et al., HPG 2016, §4.1-4.7; the
 * hierarchy of Sintorn et al. 2014). One implementation, four variants:
 *
 *   cluster          §4.1-4.4: photons go into the list of every node they
 *                    enclose and of every leaf they intersect; each view sample
 *                    reads the lists of the nodes that contain it.
 *   cluster-cone     §4.5: + a normal cone per node; a photon arriving from
 *                    below every surface in a node is dropped there.
 *   cluster-trivial  §4.6: + a photon that encloses an all-Lambertian node and
 *                    arrives from above every surface in it adds its flux to the
 *                    node's accumulator instead of its list.
 *   directional      §4.7: traversal stops at a fixed level; flux goes into 8
 *                    view-space octant buckets of that node; shading weights each
 *                    bucket by 2 max(0, cos); irradiance is blurred (depth- and
 *                    normal-aware) and multiplied by kd/pi. Approximate.
 *
 * Hierarchy (rebuilt each frame, §4.1): a cluster is a screen tile of T x T
 * pixels (default 8) x a view-depth slice k = floor(log(z/near) /
 * log(1 + 2 tan(fov_y/2) / tiles_y)) (Olsson et al. 2012), so clusters are
 * roughly cubical. Samples seen through mirrors/glass (no PGI_VS_PRIMARY) get
 * one extra top key bit: they form their own subtree, so their far-away
 * positions do not inflate the boxes of the primary clusters. The key bits of
 * tile x, tile y and slice are interleaved (the dimension with the most bits
 * left first), and the key is cut into 5-bit digits: 32 children a node, a
 * 32-bit child mask, key >> 5 = parent key. Unlike the paper's dense GPU
 * arrays, the tree is sparse: each tile's samples are sorted locally by
 * (mirror bit, slice), the resulting clusters are radix-sorted by key, the
 * leaves are the clusters in key order, and every level is the run list of the
 * key prefixes, stored breadth first; a node's children are contiguous (first
 * child index + mask), and every node covers one contiguous range of the
 * sorted samples. Boxes are view-space AABBs of the ACTUAL sample positions
 * (so mirror samples anywhere are bounded), cones bound the actual shading
 * normals; both are propagated bottom-up.
 *
 * Splatting (§4.3): a photon sphere traverses from the root with a small
 * stack of child masks. A node it cannot touch is skipped; an enclosed node or
 * an intersected leaf records the photon and stops. Load balance: a top pass
 * walks the photons (fixed chunks) down to the job level J (the first level
 * with >= 256 nodes) and emits (photon, node) jobs grouped by node; the
 * subtree passes then run one task per level-J node over its jobs. Lists are
 * arrays: count pass, prefix sum, fill pass. Every list is in photon-index
 * order and every accumulator is summed in a fixed order (top pass: per chunk,
 * then chunks in order; subtree pass: by the single task owning the subtree),
 * so the image is the same bytes for any thread count.
 *
 * Exactness: the radiance pass applies pgi__gather (d^2 < r^2, dot(n, w) > 0)
 * to every (photon, sample) pair it reads, so the culling tests only have to
 * be conservative: a node is skipped only when the sphere misses its box by a
 * margin covering float rounding, and a cone rejects only with an angular
 * margin. Trivial accept needs the opposite guarantee (every sample provably
 * passes both tests in float): the farthest box corner must lie inside r minus
 * the margin, the photon direction inside pi/2 - alpha - margin of the axis,
 * and every sample in the node Lambertian (the constant kernel is the only one
 * accepted, so the flux sum times kd/pi is exactly what gather computes). A
 * node with a non-Lambertian sample falls back to its list.
 *
 * Counters: reads = photon records read by the radiance pass (list entries x
 * samples); contributing = (photon, sample) pairs that contribute, including
 * the trivially accepted ones (they are never read per sample, so contributing
 * may exceed reads, as in the paper's Fig. 7); nodes_visited = node tests in
 * the traversals. directional: reads = contributing = bucket deposits. */
#include <omp.h>
#include <stdio.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "estimator_internal.h"

enum { V_CONE = 1, V_TRIVIAL = 2, V_DIR = 4 };

#define MAX_LEVELS 12
#define RADIX_BITS 13   /* at most; 2 passes up to 26 key bits (1080p with 8-pixel tiles) */
#define RADIX (1u << RADIX_BITS)
#define RADIX_CHUNKS 8   /* fixed (thread-count independent); few: the digit prefix sum walks chunks x digits */
#define NCHUNK_MAX 64
#define JOB_LEVEL_NODES 256

typedef struct cnode {
    float lo[3], hi[3];   /* view-space AABB of the samples */
    float ax, ay, az;     /* normal-cone axis (world space, unit up to rounding) */
    float rej, acc;       /* dot(axis, w_p) < rej: below every normal; > acc: above every normal */
    uint32_t mask;        /* child occupancy: bit i = child with key digit i */
    uint32_t first;       /* index of the first child; children are contiguous in digit order */
    uint32_t lambert;     /* every sample in the node is Lambertian */
    uint32_t parent;
    float alpha;          /* normal-cone half-angle (radians, rounded up); > pi: open cone */
} cnode;

typedef struct {
    pgi__est_common c;
    int variant, T, dir_up, blur;
    /* frame */
    int W, H, ntx, nty, L, J, D;
    pgi__view_xf x;
    float r;
    size_t nvalid, nnodes, nchunks, chunk;
    uint32_t lvl_off[MAX_LEVELS + 2];
    /* sort */
    PGI__BUF(uint64_t, keys);     /* sorted cluster keys */
    PGI__BUF(uint64_t, keys2);    /* per-tile sorted samples */
    PGI__BUF(uint64_t, spread);
    PGI__BUF(uint64_t, ck2);
    PGI__BUF(uint32_t, tcl);      /* per tile: cluster base */
    PGI__BUF(uint32_t, tn);       /* per tile: count */
    PGI__BUF(uint32_t, ci);       /* per cluster: index */
    PGI__BUF(uint32_t, ci2);
    PGI__BUF(uint32_t, cb);       /* per cluster: begin */
    PGI__BUF(uint32_t, cn);       /* per cluster: size */
    PGI__BUF(uint32_t, cs);       /* per cluster: start */
    PGI__BUF(uint32_t, order);
    PGI__BUF(uint32_t, hist);
    PGI__BUF(uint32_t, pix_cnt);
    /* hierarchy */
    PGI__BUF(cnode, nodes);
    PGI__BUF(uint32_t, sbeg);     /* nnodes + 1: node sample ranges [sbeg[i], send[i]) */
    PGI__BUF(uint32_t, send);
    PGI__BUF(uint64_t, nkey);
    /* splat */
    PGI__BUF(uint32_t, top_cnt);
    PGI__BUF(uint32_t, top_tcnt);
    PGI__BUF(uint32_t, job_start);
    PGI__BUF(uint32_t, jobs);
    PGI__BUF(uint32_t, top_ids);
    PGI__BUF(uint32_t, node_cnt);
    PGI__BUF(uint32_t, node_start);
    PGI__BUF(uint32_t, node_tcnt);
    PGI__BUF(uint32_t, cursor);
    PGI__BUF(float, top_flux);
    PGI__BUF(float, node_flux);
    PGI__BUF(float, buckets);
    PGI__BUF(pgi__packed_photon, lists);
    PGI__BUF(pgi__packed_photon, pk);     /* every photon packed */
    PGI__BUF(pgi__packed_photon, jobq);   /* the jobs' photons */
    size_t njobs, nlist, ntop_list;
    /* radiance */
    PGI__BUF(float, cum_flux);
    PGI__BUF(float, irr);
    PGI__BUF(uint32_t, cum_cnt);
    uint64_t deposits;
    struct sink *outs;   /* traversal records: one per top chunk / per thread */
    int nouts;
    PGI__BUF(uint32_t, task_rec);   /* per job-level node: thread, first and end record */
    float *sx0, *sy0, *sz0, *sx1, *sy1, *sz1, *cax, *cay, *caz, *crej;   /* SoA copies for child_hits (in soa) */
    PGI__BUF(float, soa);
    PGI__BUF(float, sam);   /* 6 x nvalid: sorted samples' world position (x NaN: not Lambertian) and normal */
    int splatted;   /* this frame has nodes and photons (lists/buckets are valid) */
} cl_state;

static pgi_status cl_create_variant(const pgi_estimator_desc *d, void **state, int variant, const char *name) {
    if (d->cluster_tile < 0 || d->cluster_tile > 256)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: cluster tile %d is out of range (1..256, 0 = default 8)", name,
                         d->cluster_tile);
    if (d->directional_level < -1 || d->directional_level > 16)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "%s: directional level %d is out of range (1..16 levels above the leaves, 0 = default 1, "
                         "-1 = leaves)",
                         name, d->directional_level);
    if (d->directional_blur < -1 || d->directional_blur > 64)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: directional blur %d is out of range (1..64, 0 = default 4, -1 = off)",
                         name, d->directional_blur);
    cl_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->c.desc = *d;
    s->variant = variant;
    s->T = d->cluster_tile > 0 ? d->cluster_tile : 8;
    s->dir_up = d->directional_level == 0 ? 1 : d->directional_level < 0 ? 0 : d->directional_level;
    s->blur = d->directional_blur == 0 ? 4 : d->directional_blur < 0 ? 0 : d->directional_blur;
    *state = s;
    return PGI_OK;
}

static pgi_status cluster_create(const pgi_estimator_desc *d, void **st) { return cl_create_variant(d, st, 0, "cluster"); }
static pgi_status cone_create(const pgi_estimator_desc *d, void **st) {
    return cl_create_variant(d, st, V_CONE, "cluster-cone");
}
static pgi_status trivial_create(const pgi_estimator_desc *d, void **st) {
    return cl_create_variant(d, st, V_CONE | V_TRIVIAL, "cluster-trivial");
}
static pgi_status dir_create(const pgi_estimator_desc *d, void **st) {
    return cl_create_variant(d, st, V_DIR, "directional");
}

#define ENSURE(field, n, type) pgi__buf_reserve(&s->field##_buf, (n), sizeof(type))

/* The branch-free inner loops (blur taps, radiance blocks) vectorise over
 * consecutive pixels / samples. GCC's -O3 unroll-and-jam would fuse two outer
 * iterations and leave the fused loop scalar, so it is turned off for them;
 * on x86-64 an AVX2 clone is picked at load time (no FMA: -ffp-contract=off
 * still holds, lanes are independent, so the results are bit-identical). */
#if defined(__GNUC__) && !defined(__clang__)
#if defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__)
#define PGI__HOT_LOOP __attribute__((optimize("no-loop-unroll-and-jam"), target_clones("avx2", "default")))
#else
#define PGI__HOT_LOOP __attribute__((optimize("no-loop-unroll-and-jam")))
#endif
#else
#define PGI__HOT_LOOP
#endif

/* ------------------------------------------------------------ build */

/* A monotone, continuous stand-in for log2 (exact at powers of two): slices
 * only need to be roughly cubical, and a libm log per pixel costs more than
 * the rest of the key. */
static inline float fast_log2(float x) {
    union { float f; uint32_t u; } v = {x};
    float e = (float)((int)((v.u >> 23) & 255) - 127);
    v.u = (v.u & 0x007fffffu) | 0x3f800000u;   /* mantissa in [1, 2) */
    float m = v.f - 1.f;
    return e + m * (1.3465f - 0.3465f * m);
}

/* View-depth slice (Olsson et al. 2012), monotone in z; NaN and huge depths
 * land in the last slice. */
static inline int slice_of(float z, float near, float log_near, float inv_step) {
    float k = z > near ? (fast_log2(z) - log_near) * inv_step : 0.f;
    if (!(k >= 0.f)) return k < 0.f ? 0 : 65535;
    return k < 65535.f ? (int)k : 65535;
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

static int bits_for(uint32_t n) {
    int b = 0;
    while (b < 31 && (1u << b) < n) b++;
    return b;
}

/* LSD radix sort of (key, value) pairs on the low `bits` bits, stable, over
 * fixed chunks (the result does not depend on the thread count). Returns 1
 * when the sorted data ended up in the second buffers. */
static int radix_sort(uint64_t *k0, uint32_t *v0, uint64_t *k1, uint32_t *v1, size_t n, int bits, uint32_t *hist) {
    const size_t nch = RADIX_CHUNKS, chunk = (n + nch - 1) / nch + 1;
    const int passes = (bits + RADIX_BITS - 1) / RADIX_BITS;
    const int digit = passes ? (bits + passes - 1) / passes : 0;   /* <= RADIX_BITS, balanced */
    const uint64_t dm = ((uint64_t)1 << digit) - 1;
    const uint32_t nb = (uint32_t)1 << digit;
    int swapped = 0;
    for (int pass = 0; pass < passes; pass++) {
        const int shift = pass * digit;
#pragma omp parallel for schedule(static) if (n >= 262144)
        for (long long ci = 0; ci < (long long)nch; ci++) {
            uint32_t *h = hist + (size_t)ci * nb;
            memset(h, 0, nb * sizeof *h);
            size_t a = (size_t)ci * chunk, b = a + chunk < n ? a + chunk : n;
            for (size_t i = a; i < b; i++) h[(k0[i] >> shift) & dm]++;
        }
        uint32_t sum = 0;
        for (uint32_t d = 0; d < nb; d++)
            for (size_t ci = 0; ci < nch; ci++) {
                uint32_t c = hist[ci * nb + d];
                hist[ci * nb + d] = sum;
                sum += c;
            }
#pragma omp parallel for schedule(static) if (n >= 262144)
        for (long long ci = 0; ci < (long long)nch; ci++) {
            uint32_t *h = hist + (size_t)ci * nb;
            size_t a = (size_t)ci * chunk, b = a + chunk < n ? a + chunk : n;
            for (size_t i = a; i < b; i++) {
                uint32_t o = h[(k0[i] >> shift) & dm]++;
                k1[o] = k0[i];
                v1[o] = v0[i];
            }
        }
        uint64_t *tk = k0; k0 = k1; k1 = tk;
        uint32_t *tv = v0; v0 = v1; v1 = tv;
        swapped ^= 1;
    }
    return swapped;
}

/* Cone thresholds for axis a and half-angle alpha (radians, already bounding
 * the normals): the margin m keeps every decision on the safe side of float
 * rounding (the dot products of unit vectors are off by < 1e-6). */
static void cone_thresholds(cnode *nd, double alpha) {
    const double m = 1e-4, eps = 1e-6;
    nd->alpha = nextafterf((float)alpha, INFINITY);
    if (alpha + m < 0.5 * 3.14159265358979323846) {
        double s = sin(alpha + m);
        nd->rej = (float)(-s - eps);
        nd->acc = (float)(s + eps);
    } else {
        nd->rej = -2.f;   /* never: the cone reaches past the tangent plane */
        nd->acc = 2.f;
    }
}

static inline double angle_to(double ax, double ay, double az, double bx, double by, double bz) {
    double la = sqrt(ax * ax + ay * ay + az * az), lb = sqrt(bx * bx + by * by + bz * bz);
    if (!(la > 0.0) || !(lb > 0.0)) return 3.14159265358979323846;
    double c = (ax * bx + ay * by + az * bz) / (la * lb);
    c = c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c;
    return acos(c);
}

/* Sets the axis to the normalised sum (sx, sy, sz); a vanishing sum gives an
 * open cone. Returns 0 when the cone is open. */
static int cone_axis(cnode *nd, double sx, double sy, double sz, double count) {
    double l = sqrt(sx * sx + sy * sy + sz * sz);
    if (!(l > 1e-6 * count)) {
        nd->ax = 0.f, nd->ay = 0.f, nd->az = 1.f;
        nd->rej = -2.f, nd->acc = 2.f, nd->alpha = 4.f;
        return 0;
    }
    nd->ax = (float)(sx / l), nd->ay = (float)(sy / l), nd->az = (float)(sz / l);
    return 1;
}

static inline void soa_store(cl_state *s, size_t ni, const cnode *nd) {
    s->sx0[ni] = nd->lo[0], s->sy0[ni] = nd->lo[1], s->sz0[ni] = nd->lo[2];
    s->sx1[ni] = nd->hi[0], s->sy1[ni] = nd->hi[1], s->sz1[ni] = nd->hi[2];
    s->cax[ni] = nd->ax, s->cay[ni] = nd->ay, s->caz[ni] = nd->az, s->crej[ni] = nd->rej;
}

static pgi_status cl_build_hierarchy(cl_state *s, const pgi_view_samples *vs, const pgi_camera *cam, double *t_sort) {
    const int W = vs->width, H = vs->height, T = s->T;
    pgi_status st;
    s->ntx = (W + T - 1) / T;
    s->nty = (H + T - 1) / T;
    /* Pixel chunks (rows) for compaction: fixed, at most 64. */
    const int rows_per = (H + NCHUNK_MAX - 1) / NCHUNK_MAX;
    const int npc = (H + rows_per - 1) / rows_per;
    if ((st = ENSURE(pix_cnt, (size_t)npc + 1, uint32_t)) ||
        (st = ENSURE(hist, (size_t)RADIX_CHUNKS * RADIX, uint32_t)))
        return st;
    /* One pass: valid counts per row chunk, near = smallest positive depth,
     * the largest depth (slices are monotone in depth, so it gives the slice
     * count), and whether any sample was seen through a mirror/glass. */
    float near = INFINITY, zmax = 0.f;
    int any_secondary = 0, any_nan = 0;
#pragma omp parallel for schedule(static) reduction(min : near) reduction(max : zmax) reduction(| : any_secondary, any_nan)
    for (int c = 0; c < npc; c++) {
        uint32_t cnt = 0;
        for (int y = c * rows_per; y < (c + 1) * rows_per && y < H; y++)
            for (int x = 0; x < W; x++) {
                size_t i = (size_t)y * W + (size_t)x;
                uint8_t f = vs->flags[i];
                if (!(f & PGI_VS_VALID)) continue;
                float z = vs->depth[i];
                if (z > 0.f && z < near) near = z;
                if (z > zmax) zmax = z;
                any_nan |= !(z == z);
                any_secondary |= !(f & PGI_VS_PRIMARY);
                cnt++;
            }
        s->pix_cnt[c] = cnt;
    }
    if (!(near < INFINITY)) near = 1.f;
    const float log_near = fast_log2(near);
    const float inv_step = (float)(1.0 / log2(1.0 + 2.0 * (double)cam->tan_half_fov_y / (double)s->nty));
    const int nslices_m1 = any_nan ? 65535 : slice_of(zmax, near, log_near, inv_step);
    size_t nvalid = 0;
    for (int c = 0; c < npc; c++) {
        uint32_t v = s->pix_cnt[c];
        s->pix_cnt[c] = (uint32_t)nvalid;
        nvalid += v;
    }
    s->nvalid = nvalid;
    /* Key layout: interleave (the dimension with the most bits left first). */
    int bd[3] = {bits_for((uint32_t)s->ntx), bits_for((uint32_t)s->nty), bits_for((uint32_t)nslices_m1 + 1)};
    int btot = bd[0] + bd[1] + bd[2];
    size_t dimn[3] = {(size_t)1 << bd[0], (size_t)1 << bd[1], (size_t)1 << bd[2]};
    if ((st = ENSURE(spread, dimn[0] + dimn[1] + dimn[2], uint64_t))) return st;
    uint64_t *sp[3] = {s->spread, s->spread + dimn[0], s->spread + dimn[0] + dimn[1]};
    {
        int left[3] = {bd[0], bd[1], bd[2]};
        int pos_of[3][32];
        for (int p = btot - 1; p >= 0; p--) {
            int d = 0;
            for (int k = 1; k < 3; k++)
                if (left[k] > left[d]) d = k;
            pos_of[d][--left[d]] = p;
        }
        for (int d = 0; d < 3; d++)
            for (size_t v = 0; v < dimn[d]; v++) {
                uint64_t kk = 0;
                for (int b = 0; b < bd[d]; b++)
                    if (v >> b & 1) kk |= (uint64_t)1 << pos_of[d][b];
                sp[d][v] = kk;
            }
    }
    const int bits = btot + (any_secondary ? 1 : 0);
    const uint64_t sec_bit = (uint64_t)1 << btot;
    int L = (bits + 4) / 5;
    if (L > MAX_LEVELS) return pgi__fail(PGI_ERR_UNSUPPORTED, "cluster: %d key bits exceed the hierarchy depth", bits);
    s->L = L;
    /* Per tile: its valid samples sorted by (mirror bit, slice), the part of
     * the key that varies inside a tile (the spread tables are monotone, so
     * this is key order); the runs are the tile's clusters. Then only the
     * clusters are radix-sorted by key, and the samples are copied into
     * cluster order: sorting 2M samples is replaced by ~64-sample local sorts. */
    const int ntiles = s->ntx * s->nty;
    const size_t tsz = (size_t)T * (size_t)T;
    if ((st = ENSURE(keys2, (size_t)ntiles * tsz + 1, uint64_t)) || (st = ENSURE(tcl, (size_t)ntiles + 1, uint32_t)) || (st = ENSURE(tn, (size_t)ntiles + 1, uint32_t)) ||
        (st = ENSURE(order, nvalid + 1, uint32_t)))
        return st;
#pragma omp parallel for schedule(dynamic, 16)
    for (int t = 0; t < ntiles; t++) {
        const int tx = t % s->ntx, ty = t / s->ntx;
        uint64_t *const out = s->keys2 + (size_t)t * tsz;
        uint64_t tmp[4096];   /* the keys in pixel order (tiles up to 64 x 64 pixels) */
        uint64_t *v = tsz <= 4096 ? tmp : out;
        uint32_t n = 0, smin = UINT32_MAX, smax = 0;
        for (int y = ty * T; y < (ty + 1) * T && y < H; y++)
            for (int x = tx * T; x < (tx + 1) * T && x < W; x++) {
                size_t i = (size_t)y * W + (size_t)x;
                uint8_t f = vs->flags[i];
                if (!(f & PGI_VS_VALID)) continue;
                uint64_t sl = (uint64_t)slice_of(vs->depth[i], near, log_near, inv_step);
                uint64_t sec = (f & PGI_VS_PRIMARY) ? 0u : 1u;
                uint64_t j = (uint64_t)((y - ty * T) * T + (x - tx * T));
                v[n++] = sec << 40 | sl << 20 | j;
                smin = (uint32_t)sl < smin ? (uint32_t)sl : smin;
                smax = (uint32_t)sl > smax ? (uint32_t)sl : smax;
            }
        /* Sort by (mirror bit, slice, pixel): the pixels come in increasing j,
         * so a stable counting sort over the tile's few slices gives the
         * sorted order; wide slice ranges (rare) use a comparison sort. */
        const uint32_t range = n ? smax - smin + 1 : 0;
        int sorted = n < 2;
        if (v == tmp && n > 1 && range > 1 && range <= 64) {
            sorted = 1;
            uint32_t cnt[129];
            memset(cnt, 0, sizeof cnt);
            for (uint32_t k = 0; k < n; k++)
                cnt[1 + (uint32_t)(v[k] >> 40) * range + ((uint32_t)(v[k] >> 20 & 0xFFFFFu) - smin)]++;
            for (uint32_t b = 1; b <= 2 * range; b++) cnt[b] += cnt[b - 1];
            for (uint32_t k = 0; k < n; k++)
                out[cnt[(uint32_t)(v[k] >> 40) * range + ((uint32_t)(v[k] >> 20 & 0xFFFFFu) - smin)]++] = v[k];
            v = out;
        }
        if (v != out) {
            for (uint32_t k = 0; k < n; k++) out[k] = v[k];
            v = out;
        }
        if (!sorted && range == 1) {
            /* one slice: only the mirror bit can reorder */
            int any_sec = 0;
            for (uint32_t k = 0; k < n; k++) any_sec |= (int)(v[k] >> 40);
            if (any_sec) qsort(v, n, sizeof *v, cmp_u64);
        } else if (!sorted && n <= 256) {
            for (uint32_t k = 1; k < n; k++) {   /* insertion sort: tiles are small */
                uint64_t e = v[k];
                uint32_t m = k;
                while (m > 0 && v[m - 1] > e) v[m] = v[m - 1], m--;
                v[m] = e;
            }
        } else if (!sorted) {
            qsort(v, n, sizeof *v, cmp_u64);
        }
        uint32_t nc = 0;
        for (uint32_t k = 0; k < n; k++) nc += k == 0 || (v[k] >> 20) != (v[k - 1] >> 20);
        s->tcl[t] = nc;
        s->tn[t] = n;
    }
    size_t nclus = 0;
    for (int t = 0; t < ntiles; t++) {
        uint32_t c = s->tcl[t];
        s->tcl[t] = (uint32_t)nclus;
        nclus += c;
    }
    s->tcl[ntiles] = (uint32_t)nclus;
    if ((st = ENSURE(keys, nclus + 1, uint64_t)) || (st = ENSURE(ck2, nclus + 1, uint64_t)) ||
        (st = ENSURE(ci, nclus + 1, uint32_t)) || (st = ENSURE(ci2, nclus + 1, uint32_t)) ||
        (st = ENSURE(cb, nclus + 1, uint32_t)) || (st = ENSURE(cn, nclus + 1, uint32_t)) ||
        (st = ENSURE(cs, nclus + 1, uint32_t)))
        return st;
#pragma omp parallel for schedule(dynamic, 16)
    for (int t = 0; t < ntiles; t++) {
        const int tx = t % s->ntx, ty = t / s->ntx;
        const uint64_t *v = s->keys2 + (size_t)t * tsz;
        const uint32_t n = s->tn[t];
        uint32_t c = s->tcl[t];
        for (uint32_t k = 0; k < n;) {
            const uint32_t k0 = k;
            while (k < n && (v[k] >> 20) == (v[k0] >> 20)) k++;
            const uint64_t sec = v[k0] >> 40, sl = (v[k0] >> 20) & 0xFFFFFu;
            s->keys[c] = sp[0][tx] | sp[1][ty] | sp[2][sl] | (sec ? sec_bit : 0);
            s->ci[c] = c;
            s->cb[c] = (uint32_t)((size_t)t * tsz + k0);
            s->cn[c] = k - k0;
            c++;
        }
    }
    if (radix_sort(s->keys, s->ci, s->ck2, s->ci2, nclus, bits, s->hist)) {
        pgi__buf tk = s->keys_buf; s->keys_buf = s->ck2_buf; s->ck2_buf = tk;
        pgi__buf tv = s->ci_buf; s->ci_buf = s->ci2_buf; s->ci2_buf = tv;
    }
    {
        size_t acc = 0;
        for (size_t i = 0; i < nclus; i++) {
            s->cs[i] = (uint32_t)acc;
            acc += s->cn[s->ci[i]];
        }
        s->cs[nclus] = (uint32_t)acc;
        PGI_ASSERT(acc == nvalid);
    }
#pragma omp parallel for schedule(dynamic, 256)
    for (long long i = 0; i < (long long)nclus; i++) {
        const int tsh = (T & (T - 1)) == 0 ? __builtin_ctz((unsigned)T) : -1;
        const uint32_t c = s->ci[i], t = (uint32_t)(s->cb[c] / tsz);
        const int tx = (int)(t % (uint32_t)s->ntx), ty = (int)(t / (uint32_t)s->ntx);
        const size_t base = (size_t)(ty * T) * W + (size_t)(tx * T);
        const uint64_t *kv = s->keys2 + s->cb[c];
        uint32_t *o = s->order + s->cs[i];
        if (tsh >= 0) {   /* power-of-two tiles (the default 8): no divisions */
            for (uint32_t j = 0; j < s->cn[c]; j++) {
                uint32_t lj = (uint32_t)(kv[j] & 0xFFFFFu);
                o[j] = (uint32_t)(base + (size_t)(lj >> tsh) * W + (lj & (uint32_t)(T - 1)));
            }
        } else {
            for (uint32_t j = 0; j < s->cn[c]; j++) {
                uint32_t lj = (uint32_t)(kv[j] & 0xFFFFFu);
                o[j] = (uint32_t)(base + (size_t)(lj / (uint32_t)T) * W + lj % (uint32_t)T);
            }
        }
    }
    *t_sort = pgi__now_ms();

    /* Levels: count the distinct key prefixes per level (one scan), then fill. */
    size_t cnt[MAX_LEVELS + 1] = {0};
    const uint64_t *K = s->keys;   /* sorted cluster keys, all distinct: one leaf each */
    for (size_t i = 0; i < nclus; i++) {
        if (i > 0 && K[i] == K[i - 1]) continue;
        for (int l = 0; l <= L; l++) {
            int sh = 5 * (L - l);
            if (i == 0 || (K[i] >> sh) != (K[i - 1] >> sh)) cnt[l]++;
        }
    }
    size_t nn = 0;
    for (int l = 0; l <= L; l++) {
        s->lvl_off[l] = (uint32_t)nn;
        nn += cnt[l];
    }
    s->lvl_off[L + 1] = (uint32_t)nn;
    s->nnodes = nn;
    if (nn > UINT32_MAX / 2) return pgi__fail(PGI_ERR_UNSUPPORTED, "cluster: too many nodes");
    if ((st = ENSURE(nodes, nn + 1, cnode)) || (st = ENSURE(sbeg, nn + 1, uint32_t)) ||
        (st = ENSURE(send, nn + 1, uint32_t)) || (st = ENSURE(nkey, nn + 1, uint64_t)))
        return st;
    {
        size_t cur[MAX_LEVELS + 1];
        for (int l = 0; l <= L; l++) cur[l] = s->lvl_off[l];
        for (size_t i = 0; i < nclus; i++) {
            if (i > 0 && K[i] == K[i - 1]) continue;
            int l0 = 0;
            if (i > 0) {
                while (l0 <= L && (K[i] >> 5 * (L - l0)) == (K[i - 1] >> 5 * (L - l0))) l0++;
            }
            for (int l = l0; l <= L; l++) {
                size_t idx = cur[l]++;
                cnode *nd = &s->nodes[idx];
                memset(nd, 0, sizeof *nd);
                s->nkey[idx] = K[i] >> 5 * (L - l);
                s->sbeg[idx] = s->cs[i];
                nd->parent = UINT32_MAX;
                if (l > 0) {
                    size_t p = cur[l - 1] - 1;
                    cnode *pn = &s->nodes[p];
                    if (!pn->mask) pn->first = (uint32_t)idx;
                    pn->mask |= 1u << (s->nkey[idx] & 31);
                    nd->parent = (uint32_t)p;
                }
            }
        }
        for (int l = 0; l <= L; l++)
            for (size_t idx = s->lvl_off[l]; idx < s->lvl_off[l + 1]; idx++)
                s->send[idx] = idx + 1 < s->lvl_off[l + 1] ? s->sbeg[idx + 1] : (uint32_t)nvalid;
    }
    /* Structure-of-arrays copies of boxes and cones for the child tests. */
    const size_t stride = nn + 16;
    if ((st = ENSURE(soa, 10 * stride, float))) return st;
    float **arr[10] = {&s->sx0, &s->sy0, &s->sz0, &s->sx1, &s->sy1, &s->sz1, &s->cax, &s->cay, &s->caz, &s->crej};
    for (int k = 0; k < 10; k++) *arr[k] = s->soa + (size_t)k * stride;
    /* Leaf boxes, cones, Lambert flags from the samples; the samples' position
     * and normal are copied in sorted order (SoA) for the radiance pass, which
     * then reads them sequentially instead of gathering tile rows again. */
    const uint32_t leaf0 = s->lvl_off[L], leaf1 = s->lvl_off[L + 1];
    if ((st = ENSURE(sam, 6 * nvalid + 16, float))) return st;
    memset(s->sam + 6 * nvalid, 0, 16 * sizeof(float));   /* padding read by the last radiance block */
    float *const S0 = s->sam, *const S1 = S0 + nvalid, *const S2 = S1 + nvalid, *const S3 = S2 + nvalid,
                 *const S4 = S3 + nvalid, *const S5 = S4 + nvalid;
#pragma omp parallel for schedule(dynamic, 64)
    for (long long li = leaf0; li < (long long)leaf1; li++) {
        if (li + 2 < (long long)leaf1)   /* tile rows two leaves ahead: gathers, not streams */
            for (uint32_t k = s->sbeg[li + 2]; k < s->send[li + 2]; k += 4) {
                __builtin_prefetch(vs->pos + 3 * (size_t)s->order[k]);
                __builtin_prefetch(vs->nrm + 3 * (size_t)s->order[k]);
                __builtin_prefetch(vs->flags + s->order[k]);
            }
        cnode *nd = &s->nodes[li];
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        double sx = 0, sy = 0, sz = 0;
        uint32_t lam = 1;
        for (uint32_t k = s->sbeg[li]; k < s->send[li]; k++) {
            uint32_t i = s->order[k];
            const float *p = vs->pos + 3 * (size_t)i, *n = vs->nrm + 3 * (size_t)i;
            pgi_v3 q = pgi__to_view(&s->x, p[0], p[1], p[2]);
            float qq[3] = {q.x, q.y, q.z};
            for (int d = 0; d < 3; d++) {
                lo[d] = pgi_minf(lo[d], qq[d]);
                hi[d] = pgi_maxf(hi[d], qq[d]);
            }
            sx += n[0], sy += n[1], sz += n[2];
            const int lk = (vs->flags[i] & PGI_VS_LAMBERT) != 0;
            lam &= (uint32_t)lk;
            if (!(s->variant & V_DIR)) S0[k] = lk ? p[0] : NAN, S1[k] = p[1], S2[k] = p[2];   /* directional: normals only */
            S3[k] = n[0], S4[k] = n[1], S5[k] = n[2];
        }
        memcpy(nd->lo, lo, sizeof lo);
        memcpy(nd->hi, hi, sizeof hi);
        nd->lambert = lam;
        nd->rej = -2.f, nd->acc = 2.f, nd->alpha = 4.f;   /* open unless the variant uses cones */
        if ((s->variant & V_CONE) && cone_axis(nd, sx, sy, sz, (double)(s->send[li] - s->sbeg[li]))) {
            /* The largest angle is the smallest cosine: one acos a leaf. The
             * float dot products of near-unit vectors are off by < 1e-6, so
             * acos(cmin - 1e-6) bounds every normal's angle from above. */
            const float ax = nd->ax, ay = nd->ay, az = nd->az;
            float cmin = 1.f;
            int bad = 0;
            for (uint32_t k = s->sbeg[li]; k < s->send[li]; k++) {
                float c = ax * S3[k] + ay * S4[k] + az * S5[k];
                bad |= !(c == c);   /* a NaN normal opens the cone */
                cmin = pgi_minf(cmin, c);
            }
            double cm = (double)cmin - 1e-6;
            cm = cm < -1.0 ? -1.0 : cm;
            if (!bad) cone_thresholds(nd, acos(cm) + 1e-5);
            else nd->rej = -2.f, nd->acc = 2.f, nd->alpha = 4.f;
        }
        soa_store(s, (size_t)li, nd);
    }
    /* Inner levels bottom-up: union of child boxes; cone = mean child axis,
     * half-angle = max(angle to child axis + child half-angle) (§4.5). Open
     * child cones (alpha > pi) make the parent open. */
    for (int l = L - 1; l >= 0; l--) {   /* nodes of one level are independent */
        const long long n0 = s->lvl_off[l], n1 = s->lvl_off[l + 1];
#pragma omp parallel for schedule(dynamic, 32) if (n1 - n0 >= 512)
        for (long long ni = n0; ni < n1; ni++) {
            cnode *nd = &s->nodes[ni];
            int nch = __builtin_popcount(nd->mask);
            float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
            double sx = 0, sy = 0, sz = 0;
            uint32_t lam = 1;
            int open = 0;
            for (int k = 0; k < nch; k++) {
                const cnode *ch = &s->nodes[nd->first + k];
                for (int d = 0; d < 3; d++) {
                    lo[d] = pgi_minf(lo[d], ch->lo[d]);
                    hi[d] = pgi_maxf(hi[d], ch->hi[d]);
                }
                lam &= ch->lambert;
                if (ch->alpha > 3.2f) open = 1;
                sx += ch->ax, sy += ch->ay, sz += ch->az;
            }
            memcpy(nd->lo, lo, sizeof lo);
            memcpy(nd->hi, hi, sizeof hi);
            nd->lambert = lam;
            if ((s->variant & V_CONE) && !open && cone_axis(nd, sx, sy, sz, (double)nch)) {
                double alpha = 0.0;
                for (int k = 0; k < nch; k++) {
                    const cnode *ch = &s->nodes[nd->first + k];
                    double a = angle_to(nd->ax, nd->ay, nd->az, ch->ax, ch->ay, ch->az) + (double)ch->alpha;
                    if (a > alpha) alpha = a;
                }
                cone_thresholds(nd, alpha + 1e-5);
            } else {
                nd->rej = -2.f, nd->acc = 2.f, nd->alpha = 4.f;
            }
            soa_store(s, (size_t)ni, nd);
        }
    }
    return PGI_OK;
}

/* ------------------------------------------------------------ splat */

typedef struct sink {
    uint32_t *cnt;               /* per-node output counts (top: this chunk's row) */
    float *flux;                 /* trivial flux (top: this chunk's row; subtree: node_flux) */
    uint32_t *tcnt;              /* trivial counts, same indexing as flux */
    float *buckets;
    uint32_t *out;               /* recorded outputs: (node, photon) pairs */
    size_t nout, capout;
    uint64_t visited, deposits;
    int oom;
} sink;

typedef struct {
    pgi_v3 c;      /* view-space centre */
    float wx, wy, wz, fr, fg, fb;
    float rr2, re2;  /* (r + slack)^2: may touch; (r - slack)^2: encloses */
    int oct;
    uint32_t j;
} photon_q;

static inline void load_photon(const cl_state *s, const pgi__packed_photon *p, size_t j, photon_q *q) {
    const float r = s->r;
    q->c = pgi__to_view(&s->x, p->px, p->py, p->pz);
    q->wx = p->dx, q->wy = p->dy, q->wz = p->dz;
    q->fr = p->fr, q->fg = p->fg, q->fb = p->fb;
    /* The slack covers the rounding of the view transform of photon and samples
     * (relative to their distance from the eye) and of gather's d^2 < r^2. */
    float slack = 1e-4f * r + 1e-5f * (fabsf(q->c.x) + fabsf(q->c.y) + fabsf(q->c.z) + r);
    q->rr2 = (r + slack) * (r + slack);
    float re = r - slack;
    q->re2 = re > 0.f ? re * re : -1.f;
    q->oct = 0;
    if (s->variant & V_DIR) {
        pgi_v3 w = v3(q->wx, q->wy, q->wz);
        float vx = v3_dot(w, s->x.right), vy = v3_dot(w, s->x.up), vz = v3_dot(w, s->x.fwd);
        q->oct = (vx < 0.f) | (vy < 0.f) << 1 | (vz < 0.f) << 2;
    }
    q->j = (uint32_t)j;
}

/* Culling test of the children [f, f + nc) of one node, branch-free over
 * structure-of-arrays boxes and cones (the compiler vectorises it): bit k of
 * the result is set when child f + k may hold a sample the photon reaches. */
static inline __attribute__((always_inline)) uint32_t child_hits(const cl_state *s, const int variant, uint32_t f,
                                                                 int nc, const photon_q *q) {
    const float *x0 = s->sx0 + f, *y0 = s->sy0 + f, *z0 = s->sz0 + f, *x1 = s->sx1 + f, *y1 = s->sy1 + f,
                *z1 = s->sz1 + f;
    uint32_t m = 0;
#ifdef __SSE2__
    /* 4 children a step; the SoA arrays are padded, extra lanes are masked off. */
    const __m128 cx = _mm_set1_ps(q->c.x), cy = _mm_set1_ps(q->c.y), cz = _mm_set1_ps(q->c.z);
    const __m128 rr2 = _mm_set1_ps(q->rr2), zero = _mm_setzero_ps();
    const __m128 wx = _mm_set1_ps(q->wx), wy = _mm_set1_ps(q->wy), wz = _mm_set1_ps(q->wz);
    for (int k = 0; k < nc; k += 4) {
        __m128 ex = _mm_max_ps(_mm_max_ps(_mm_sub_ps(_mm_loadu_ps(x0 + k), cx), _mm_sub_ps(cx, _mm_loadu_ps(x1 + k))), zero);
        __m128 ey = _mm_max_ps(_mm_max_ps(_mm_sub_ps(_mm_loadu_ps(y0 + k), cy), _mm_sub_ps(cy, _mm_loadu_ps(y1 + k))), zero);
        __m128 ez = _mm_max_ps(_mm_max_ps(_mm_sub_ps(_mm_loadu_ps(z0 + k), cz), _mm_sub_ps(cz, _mm_loadu_ps(z1 + k))), zero);
        __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ex, ex), _mm_mul_ps(ey, ey)), _mm_mul_ps(ez, ez));
        __m128 hit = _mm_cmple_ps(d2, rr2);
        if (variant & V_CONE) {
            __m128 dw = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_loadu_ps(s->cax + f + k), wx),
                                              _mm_mul_ps(_mm_loadu_ps(s->cay + f + k), wy)),
                                   _mm_mul_ps(_mm_loadu_ps(s->caz + f + k), wz));
            hit = _mm_and_ps(hit, _mm_cmpge_ps(dw, _mm_loadu_ps(s->crej + f + k)));   /* §4.5 */
        }
        m |= (uint32_t)_mm_movemask_ps(hit) << k;
    }
    if (nc < 32) m &= (1u << nc) - 1u;
#else
    const float cx = q->c.x, cy = q->c.y, cz = q->c.z, rr2 = q->rr2;
    for (int k = 0; k < nc; k++) {
        float ex = pgi_maxf(pgi_maxf(x0[k] - cx, cx - x1[k]), 0.f);
        float ey = pgi_maxf(pgi_maxf(y0[k] - cy, cy - y1[k]), 0.f);
        float ez = pgi_maxf(pgi_maxf(z0[k] - cz, cz - z1[k]), 0.f);
        uint32_t hit = ex * ex + ey * ey + ez * ez <= rr2;
        if (variant & V_CONE) {
            float dw = s->cax[f + k] * q->wx + s->cay[f + k] * q->wy + s->caz[f + k] * q->wz;
            hit &= dw >= s->crej[f + k];   /* else below every surface in the child (§4.5) */
        }
        m |= hit << k;
    }
#endif
    return m;
}

/* Records one traversal output (node, photon) in the sink's growable array. */
static inline void emit(sink *k, uint32_t node, uint32_t j) {
    if (k->nout == k->capout) {
        size_t nc = k->capout ? 2 * k->capout : 4096;
        uint32_t *p = realloc(k->out, 2 * nc * sizeof *p);
        if (!p) {
            k->oom = 1;
            return;
        }
        k->out = p;
        k->capout = nc;
    }
    k->out[2 * k->nout] = node;
    k->out[2 * k->nout + 1] = j;
    k->nout++;
}

/* What to do with a node that passed the culling test. Returns 1 when the
 * traversal must descend into its children. */
static inline __attribute__((always_inline)) int decide(const cl_state *s, const int variant, const int top,
                                                        uint32_t ni, int level, const photon_q *q, sink *k) {
    if (top && level == s->J) goto job;
    if (variant & V_DIR) {
        /* §4.7: from level D down, an enclosed node or an intersected leaf
         * takes the photon's flux into the bucket of its direction octant. */
        int dep = 0;
        if (level >= s->D) {
            const cnode *nd = &s->nodes[ni];
            float f2 = 0.f, e;
            e = pgi_maxf(q->c.x - nd->lo[0], nd->hi[0] - q->c.x); f2 += e * e;
            e = pgi_maxf(q->c.y - nd->lo[1], nd->hi[1] - q->c.y); f2 += e * e;
            e = pgi_maxf(q->c.z - nd->lo[2], nd->hi[2] - q->c.z); f2 += e * e;
            dep = f2 < q->re2;
            if (!dep && level == s->L) {
                /* An intersected, not enclosed leaf takes the photon when the
                 * centre of its box lies in the sphere. (The paper adds it to
                 * every intersected leaf, which inflates the irradiance by about
                 * ((r + leaf/2) / r)^2: 1.4x for 8-pixel leaves at 1080p in
                 * Sibenik with r = 0.2.) */
                float mx = 0.5f * (nd->lo[0] + nd->hi[0]) - q->c.x, my = 0.5f * (nd->lo[1] + nd->hi[1]) - q->c.y,
                      mz = 0.5f * (nd->lo[2] + nd->hi[2]) - q->c.z;
                if (!(mx * mx + my * my + mz * mz < s->r * s->r)) return 0;
                dep = 1;
            }
        }
        if (!dep) return 1;
        float *b = k->buckets + ((size_t)(ni - s->lvl_off[s->D]) * 8 + (size_t)q->oct) * 3;
        b[0] += q->fr, b[1] += q->fg, b[2] += q->fb;
        k->deposits++;
        return 0;
    }
    {
        const cnode *nd = &s->nodes[ni];
        float f2 = 0.f, e;
        e = pgi_maxf(q->c.x - nd->lo[0], nd->hi[0] - q->c.x); f2 += e * e;
        e = pgi_maxf(q->c.y - nd->lo[1], nd->hi[1] - q->c.y); f2 += e * e;
        e = pgi_maxf(q->c.z - nd->lo[2], nd->hi[2] - q->c.z); f2 += e * e;
        if (f2 < q->re2) {
            if ((variant & V_TRIVIAL) && nd->lambert &&
                nd->ax * q->wx + nd->ay * q->wy + nd->az * q->wz > nd->acc) {
                /* encloses the node and above every surface in it (§4.6) */
                float *f = k->flux + 3 * (size_t)ni;
                f[0] += q->fr, f[1] += q->fg, f[2] += q->fb;
                k->tcnt[ni]++;
                return 0;
            }
            goto list;
        }
    }
    if (level == s->L) goto list;
    return 1;
list:
    k->cnt[ni]++;
    emit(k, ni, q->j);
    return 0;
job:
    k->cnt[ni]++;
    emit(k, ni, q->j);
    return 0;
}

/* Traversal from node `start` (at `start_level`, already known to pass the
 * culling test) with a small stack of child masks (§4.3): the lowest set bit
 * of the top mask is the next child (__builtin_ctz); children are contiguous,
 * so its index is first + bit. */
static inline __attribute__((always_inline)) void walk(const cl_state *s, const int variant, const int top,
                                                      uint32_t start, int start_level, const photon_q *q, sink *k) {
    if (!decide(s, variant, top, start, start_level, q, k)) return;
    struct {
        uint32_t mask, first;
    } stk[MAX_LEVELS + 2];
    int sp = 0;
    {
        const cnode *nd = &s->nodes[start];
        int nc = __builtin_popcount(nd->mask);
        k->visited += (uint64_t)nc;
        stk[0].mask = child_hits(s, variant, nd->first, nc, q);
        stk[0].first = nd->first;
        sp = 1;
    }
    while (sp > 0) {
        uint32_t m = stk[sp - 1].mask;
        if (!m) {
            sp--;
            continue;
        }
        stk[sp - 1].mask = m & (m - 1);
        uint32_t ch = stk[sp - 1].first + (uint32_t)__builtin_ctz(m);
        if (decide(s, variant, top, ch, start_level + sp, q, k)) {
            const cnode *nd = &s->nodes[ch];
            int nc = __builtin_popcount(nd->mask);
            k->visited += (uint64_t)nc;
            stk[sp].mask = child_hits(s, variant, nd->first, nc, q);
            stk[sp].first = nd->first;
            sp++;
        }
    }
}

/* Per-thread (and per top chunk) output records kept between frames. */
static pgi_status grow_outs(cl_state *s, int n) {
    if (n <= s->nouts) return PGI_OK;
    sink *o = realloc(s->outs, (size_t)n * sizeof *o);
    if (!o) return pgi__fail(PGI_ERR_OOM, "out of memory");
    for (int i = s->nouts; i < n; i++) memset(&o[i], 0, sizeof o[i]);
    s->outs = o;
    s->nouts = n;
    return PGI_OK;
}

static inline __attribute__((always_inline)) pgi_status splat_impl(cl_state *s, const pgi_photons *ph,
                                                                   const int variant, double *tm) {
    const size_t n = ph->count;
    size_t chunk = n / NCHUNK_MAX + 1;
    if (chunk < 8192) chunk = 8192;
    const size_t nch = (n + chunk - 1) / chunk;
    const uint32_t nabove = s->lvl_off[s->J], ntop = s->lvl_off[s->J + 1], nJ = ntop - nabove;
    const size_t nn = s->nnodes;
    const int nthr = omp_get_max_threads();
    pgi_status st;
    if ((st = ENSURE(top_cnt, nch * ntop + 1, uint32_t)) || (st = ENSURE(top_flux, nch * nabove * 3 + 1, float)) ||
        (st = ENSURE(top_tcnt, nch * nabove + 1, uint32_t)) || (st = ENSURE(job_start, (size_t)nJ + 1, uint32_t)) ||
        (st = ENSURE(node_start, nn + 1, uint32_t)) || (st = ENSURE(node_cnt, nn + 1, uint32_t)) ||
        (st = ENSURE(node_flux, 3 * nn + 1, float)) || (st = ENSURE(node_tcnt, nn + 1, uint32_t)) ||
        (st = ENSURE(cursor, nn + 1, uint32_t)) || (st = ENSURE(task_rec, 3 * (size_t)nJ + 1, uint32_t)) ||
        (st = grow_outs(s, (int)nch > nthr ? (int)nch : nthr)))
        return st;
    const size_t nD = (variant & V_DIR) ? nn - s->lvl_off[s->D] : 0;   /* nodes with buckets */
    if ((variant & V_DIR) && (st = ENSURE(buckets, nD * 24 + 1, float))) return st;
    if ((st = ENSURE(pk, n + 1, pgi__packed_photon))) return st;
    uint64_t visited = 0, deposits = 0;
    int oom = 0;
    /* Top pass, counting traversal: lists of nodes above J, jobs at J, trivial
     * flux above J, per fixed photon chunk; the outputs are recorded so that
     * the fill pass replays them instead of traversing again. */
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : visited) reduction(| : oom)
    for (long long ci = 0; ci < (long long)nch; ci++) {
        sink *k = &s->outs[ci];
        k->nout = 0;
        k->oom = 0;
        k->visited = 0;
        k->cnt = s->top_cnt + (size_t)ci * ntop;
        k->flux = s->top_flux + (size_t)ci * nabove * 3;
        k->tcnt = s->top_tcnt + (size_t)ci * nabove;
        memset(k->cnt, 0, ntop * sizeof *k->cnt);
        memset(k->flux, 0, (size_t)nabove * 3 * sizeof *k->flux);
        memset(k->tcnt, 0, (size_t)nabove * sizeof *k->tcnt);
        size_t j1 = ((size_t)ci + 1) * chunk < n ? ((size_t)ci + 1) * chunk : n;
        for (size_t j = (size_t)ci * chunk; j < j1; j++) {
            photon_q q;
            pgi__pack_photon(ph, j, &s->pk[j]);   /* sequential here; the later passes read pk */
            load_photon(s, &s->pk[j], j, &q);
            k->visited++;
            if (!(child_hits(s, variant, 0, 1, &q) & 1u)) continue;   /* the root */
            walk(s, variant, 1, 0, 0, &q, k);
        }
        visited += k->visited;
        oom |= k->oom;
    }
    if (oom) return pgi__fail(PGI_ERR_OOM, "cluster: out of memory for the traversal records");
    /* Prefix sums, node-major then chunk: photon order within every list. */
    size_t sum = 0;
    for (uint32_t nd = 0; nd < nabove; nd++) {
        s->node_start[nd] = (uint32_t)sum;
        for (size_t ci = 0; ci < nch; ci++) {
            uint32_t *c = s->top_cnt + ci * ntop + nd, v = *c;
            *c = (uint32_t)sum;
            sum += v;
        }
        s->node_cnt[nd] = (uint32_t)(sum - s->node_start[nd]);
    }
    s->ntop_list = sum;
    size_t js = 0;
    for (uint32_t t = 0; t < nJ; t++) {
        s->job_start[t] = (uint32_t)js;
        for (size_t ci = 0; ci < nch; ci++) {
            uint32_t *c = s->top_cnt + ci * ntop + nabove + t, v = *c;
            *c = (uint32_t)js;
            js += v;
        }
    }
    s->job_start[nJ] = (uint32_t)js;
    s->njobs = js;
    if (sum > UINT32_MAX / 2 || js > UINT32_MAX / 2)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "cluster: too many photon list entries; use a smaller radius");
    if ((st = ENSURE(jobs, js + 1, uint32_t)) || (st = ENSURE(jobq, js + 1, pgi__packed_photon)) ||
        (st = ENSURE(top_ids, sum + 1, uint32_t)))
        return st;
    /* Top fill: replay the records (jobs grouped by node, photon order). */
#pragma omp parallel for schedule(dynamic, 1)
    for (long long ci = 0; ci < (long long)nch; ci++) {
        const sink *k = &s->outs[ci];
        uint32_t *off = s->top_cnt + (size_t)ci * ntop;
        for (size_t u = 0; u < k->nout; u++) {
            uint32_t nd = k->out[2 * u], j = k->out[2 * u + 1];
            if (nd < nabove) {
                s->top_ids[off[nd]++] = j;
            } else {   /* the photon record too: the subtree pass then reads it sequentially */
                s->jobq[off[nd]] = s->pk[j];
                s->jobs[off[nd]++] = j;
            }
        }
    }
    /* Trivial flux above J: chunks summed in chunk order. */
#pragma omp parallel for schedule(static)
    for (long long nd = 0; nd < (long long)nabove; nd++) {
        float f[3] = {0.f, 0.f, 0.f};
        uint32_t c = 0;
        for (size_t ci = 0; ci < nch; ci++) {
            const float *g = s->top_flux + (ci * nabove + (size_t)nd) * 3;
            f[0] += g[0], f[1] += g[1], f[2] += g[2];
            c += s->top_tcnt[ci * nabove + (size_t)nd];
        }
        memcpy(s->node_flux + 3 * nd, f, sizeof f);
        s->node_tcnt[nd] = c;
    }
    memset(s->node_cnt + nabove, 0, (nn - nabove) * sizeof(uint32_t));
    memset(s->node_flux + 3 * (size_t)nabove, 0, (nn - nabove) * 3 * sizeof(float));
    memset(s->node_tcnt + nabove, 0, (nn - nabove) * sizeof(uint32_t));
    if (variant & V_DIR) memset(s->buckets, 0, nD * 24 * sizeof(float));
    tm[0] = pgi__now_ms();
    /* Subtree pass, counting traversal: one task per job-level node owns its
     * whole subtree, so counts and accumulators need no atomics and sum in job
     * (photon) order. Each thread records its tasks' outputs in its own array. */
#pragma omp parallel reduction(+ : visited, deposits) reduction(| : oom)
    {
        sink *k = &s->outs[omp_get_thread_num()];
        k->nout = 0;
        k->oom = 0;
        k->visited = 0;
        k->deposits = 0;
        k->cnt = s->node_cnt;
        k->flux = s->node_flux;
        k->tcnt = s->node_tcnt;
        k->buckets = s->buckets;
#pragma omp for schedule(dynamic, 1)
        for (long long t = 0; t < (long long)nJ; t++) {
            s->task_rec[3 * t] = (uint32_t)omp_get_thread_num();
            s->task_rec[3 * t + 1] = (uint32_t)k->nout;
            for (uint32_t u = s->job_start[t]; u < s->job_start[t + 1]; u++) {
                photon_q q;
                load_photon(s, &s->jobq[u], s->jobs[u], &q);
                walk(s, variant, 0, nabove + (uint32_t)t, s->J, &q, k);
            }
            s->task_rec[3 * t + 2] = (uint32_t)k->nout;
        }
        visited += k->visited;
        deposits += k->deposits;
        oom |= k->oom;
    }
    if (oom) return pgi__fail(PGI_ERR_OOM, "cluster: out of memory for the traversal records");
    s->c.st.nodes_visited = visited;
    s->deposits = deposits;
    tm[1] = pgi__now_ms();
    if (variant & V_DIR) {
        s->nlist = 0;
        s->node_start[nn] = 0;
        tm[2] = tm[1];
        return PGI_OK;
    }
    for (size_t nd = nabove; nd < nn; nd++) {
        s->node_start[nd] = (uint32_t)sum;
        sum += s->node_cnt[nd];
    }
    s->node_start[nn] = (uint32_t)sum;
    if (sum > UINT32_MAX / 2)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "cluster: too many photon list entries; use a smaller radius");
    s->nlist = sum;
    if ((st = ENSURE(lists, sum + 1, pgi__packed_photon))) return st;
#pragma omp parallel for schedule(static)
    for (long long u = 0; u < (long long)s->ntop_list; u++) s->lists[u] = s->pk[s->top_ids[u]];
    for (size_t nd = nabove; nd < nn; nd++) s->cursor[nd] = s->node_start[nd];
    /* Subtree fill: replay each task's records into its own nodes' lists. */
#pragma omp parallel for schedule(dynamic, 4)
    for (long long t = 0; t < (long long)nJ; t++) {
        const sink *k = &s->outs[s->task_rec[3 * t]];
        for (uint32_t u = s->task_rec[3 * t + 1]; u < s->task_rec[3 * t + 2]; u++)
            s->lists[s->cursor[k->out[2 * u]]++] = s->pk[k->out[2 * u + 1]];
    }
    tm[2] = pgi__now_ms();
    return PGI_OK;
}

static pgi_status splat(cl_state *s, const pgi_photons *ph, double *tm) {
    switch (s->variant) {
    case 0: return splat_impl(s, ph, 0, tm);
    case V_CONE: return splat_impl(s, ph, V_CONE, tm);
    case V_CONE | V_TRIVIAL: return splat_impl(s, ph, V_CONE | V_TRIVIAL, tm);
    default: return splat_impl(s, ph, V_DIR, tm);
    }
}

static pgi_status cl_build(void *state, const pgi_estimate_args *a) {
    cl_state *s = state;
    memset(&s->c.st, 0, sizeof s->c.st);
    const pgi_view_samples *vs = a->samples;
    const pgi_camera *cam = a->camera;
    if (vs->width != cam->width || vs->height != cam->height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: view samples are %dx%d but the camera is %dx%d",
                         s->variant & V_DIR ? "directional" : "cluster", vs->width, vs->height, cam->width,
                         cam->height);
    s->W = vs->width;
    s->H = vs->height;
    s->r = s->c.desc.radius;
    s->x = pgi__view_xf_make(cam, s->W, s->H);
    double t0 = pgi__now_ms(), t_sort = t0;
    pgi_status st = cl_build_hierarchy(s, vs, cam, &t_sort);
    if (st) return st;
    double t1 = pgi__now_ms();
    s->nlist = s->njobs = s->ntop_list = 0;
    s->deposits = 0;
    s->splatted = 0;
    double tm[3] = {t1, t1, t1};
    if (s->nnodes > 0 && a->photons->count > 0) {
        /* Job level: the first level with enough nodes to balance the subtree tasks. */
        int J = s->L;
        for (int l = 0; l <= s->L; l++)
            if (s->lvl_off[l + 1] - s->lvl_off[l] >= JOB_LEVEL_NODES) {
                J = l;
                break;
            }
        s->D = s->L - s->dir_up < 0 ? 0 : s->L - s->dir_up;
        if ((s->variant & V_DIR) && J > s->D) J = s->D;
        s->J = J;
        if ((st = splat(s, a->photons, tm))) return st;
        s->splatted = 1;
    } else {
        s->D = s->J = 0;
    }
    pgi__stats_pass(&s->c.st, "sort", t_sort - t0);
    pgi__stats_pass(&s->c.st, "hierarchy", t1 - t_sort);
    pgi__stats_pass(&s->c.st, "top", tm[0] - t1);
    pgi__stats_pass(&s->c.st, (s->variant & V_DIR) ? "splat" : "count", tm[1] - tm[0]);
    if (!(s->variant & V_DIR)) pgi__stats_pass(&s->c.st, "fill", tm[2] - tm[1]);
    s->c.st.build_ms = pgi__now_ms() - t0;
    return PGI_OK;
}

/* ------------------------------------------------------------ radiance */

/* Depth- and normal-aware blur along one axis (§4.7) on planes: tent weights
 * in pixels, times a depth weight falling to 0 at a 5% relative depth step
 * and a normal weight max(0, n.n')^8. Invalid samples have depth 1e30 and a
 * zero normal, so they neither give nor receive. Pixels are processed in spans
 * of up to BLUR_SPAN consecutive pixels of one row whose taps are all inside
 * the image: the centre values and the accumulators live in local arrays, and
 * for each tap offset the loop over the span is branch-free and vectorises
 * (restrict pointers, no aliasing checks); border pixels of the horizontal
 * pass take the same expressions with a bounds test. Taps are added in the
 * order -R..R for every pixel, so the result does not depend on the span cut. */
typedef struct {
    const float *z, *nx, *ny, *nz, *e[3];
    float *o[3];
} blur_planes;

#define BLUR_SPAN 256

static inline float blur_w(float tent, float z, float iz, float nx, float ny, float nz, float zj, float nxj, float nyj,
                           float nzj) {
    float wz = 1.f - fabsf(zj - z) * iz;
    wz = 0.5f * (wz + fabsf(wz));   /* max(wz, 0), exact and branch-free */
    float c = nx * nxj + ny * nyj + nz * nzj;
    c = 0.5f * (c + fabsf(c));
    c *= c, c *= c, c *= c;
    return tent * wz * c;
}

/* Pixels [c, c + n) with the taps at offsets off[0..nt) (weights tent[]). */
PGI__HOT_LOOP
static void blur_span(const float *restrict Z, const float *restrict NX, const float *restrict NY,
                      const float *restrict NZ, const float *restrict E0, const float *restrict E1,
                      const float *restrict E2, float *restrict O0, float *restrict O1, float *restrict O2, size_t c,
                      int n, const ptrdiff_t *off, const float *tent, int nt) {
    float cz[BLUR_SPAN], ciz[BLUR_SPAN], cnx[BLUR_SPAN], cny[BLUR_SPAN], cnz[BLUR_SPAN];
    float a0[BLUR_SPAN], a1[BLUR_SPAN], a2[BLUR_SPAN], ws[BLUR_SPAN];
    for (int t = 0; t < n; t++) {
        cz[t] = Z[c + t];
        ciz[t] = 1.f / (0.05f * fabsf(cz[t]) + 1e-12f);
        cnx[t] = NX[c + t], cny[t] = NY[c + t], cnz[t] = NZ[c + t];
        a0[t] = E0[c + t], a1[t] = E1[c + t], a2[t] = E2[c + t];
        ws[t] = 1.f;
    }
    for (int k = 0; k < nt; k++) {
        const size_t j = (size_t)((ptrdiff_t)c + off[k]);
        const float tk = tent[k];
        const float *restrict zj = Z + j, *restrict xj = NX + j, *restrict yj = NY + j, *restrict wj = NZ + j;
        const float *restrict e0 = E0 + j, *restrict e1 = E1 + j, *restrict e2 = E2 + j;
        for (int t = 0; t < n; t++) {
            float w = blur_w(tk, cz[t], ciz[t], cnx[t], cny[t], cnz[t], zj[t], xj[t], yj[t], wj[t]);
            a0[t] += w * e0[t], a1[t] += w * e1[t], a2[t] += w * e2[t];
            ws[t] += w;
        }
    }
    for (int t = 0; t < n; t++) {
        float inv = 1.f / ws[t];
        O0[c + t] = a0[t] * inv, O1[c + t] = a1[t] * inv, O2[c + t] = a2[t] * inv;
    }
}

static void blur_pass(const blur_planes *P, int W, int H, int R, int vertical) {
#pragma omp parallel for schedule(static)
    for (int y = 0; y < H; y++) {
        const size_t row = (size_t)y * W;
        ptrdiff_t off[2 * 64];
        float tent[2 * 64];
        int nt = 0;
        for (int k = -R; k <= R; k++) {
            if (!k) continue;
            if (vertical && (y + k < 0 || y + k >= H)) continue;
            off[nt] = vertical ? (ptrdiff_t)k * W : k;
            tent[nt++] = 1.f - (float)abs(k) / (float)(R + 1);
        }
        int x0 = vertical ? 0 : (R < W ? R : W), x1 = vertical ? W : (W - R > x0 ? W - R : x0);
        for (int x = x0; x < x1; x += BLUR_SPAN) {
            int n = x1 - x < BLUR_SPAN ? x1 - x : BLUR_SPAN;
            blur_span(P->z, P->nx, P->ny, P->nz, P->e[0], P->e[1], P->e[2], P->o[0], P->o[1], P->o[2], row + (size_t)x,
                      n, off, tent, nt);
        }
        if (vertical) continue;
        for (int x = 0; x < W; x++) {   /* horizontal borders: taps inside the row only */
            if (x >= x0 && x < x1) continue;
            const size_t i = row + (size_t)x;
            const float z = P->z[i], iz = 1.f / (0.05f * fabsf(z) + 1e-12f);
            float a[3] = {P->e[0][i], P->e[1][i], P->e[2][i]}, ws = 1.f;
            for (int k = 0; k < nt; k++) {
                if (x + off[k] < 0 || x + off[k] >= W) continue;
                const size_t j = (size_t)((ptrdiff_t)i + off[k]);
                float w = blur_w(tent[k], z, iz, P->nx[i], P->ny[i], P->nz[i], P->z[j], P->nx[j], P->ny[j], P->nz[j]);
                for (int d = 0; d < 3; d++) a[d] += w * P->e[d][j];
                ws += w;
            }
            for (int d = 0; d < 3; d++) P->o[d][i] = a[d] * (1.f / ws);
        }
    }
}

/* Octant-bucket shading of nb sorted samples (world normals n*), vectorised
 * over the samples: for each bucket o (direction: the octant's diagonal) the
 * weight is 2 max(0, cos(n, d_o)), a select instead of a branch; buckets are
 * added in octant order. */
PGI__HOT_LOOP
static void dir_block(const float *restrict snx, const float *restrict sny, const float *restrict snz, int nb,
                      const pgi__view_xf *x, const float *restrict b, float *restrict e0, float *restrict e1,
                      float *restrict e2) {
    const float c3 = 0.57735026919f;
    const float rx = x->right.x, ry = x->right.y, rz = x->right.z, ux = x->up.x, uy = x->up.y, uz = x->up.z,
                fx = x->fwd.x, fy = x->fwd.y, fz = x->fwd.z;
    float vx[64], vy[64], vz[64];
    for (int t = 0; t < nb; t++) {
        vx[t] = snx[t] * rx + sny[t] * ry + snz[t] * rz;
        vy[t] = snx[t] * ux + sny[t] * uy + snz[t] * uz;
        vz[t] = snx[t] * fx + sny[t] * fy + snz[t] * fz;
        e0[t] = e1[t] = e2[t] = 0.f;
    }
    for (int o = 0; o < 8; o++) {
        const float sx = (o & 1) ? -1.f : 1.f, sy = (o & 2) ? -1.f : 1.f, sz = (o & 4) ? -1.f : 1.f;
        const float b0 = b[3 * o], b1 = b[3 * o + 1], b2 = b[3 * o + 2];
        for (int t = 0; t < nb; t++) {
            float w = 2.f * c3 * (sx * vx[t] + sy * vy[t] + sz * vz[t]);
            w = 0.5f * (w + fabsf(w));   /* max(w, 0) */
            e0[t] += w * b0, e1[t] += w * b1, e2[t] += w * b2;
        }
    }
}

static pgi_status dir_radiance(cl_state *s, const pgi_estimate_args *a, double *t_blur) {
    const pgi_view_samples *vs = a->samples;
    const size_t npix = vs->count;
    pgi_status st;
    /* planes: 3 irradiance + 3 blurred, depth, normal (40 bytes a pixel) */
    if ((st = ENSURE(irr, 10 * npix, float))) return st;
    blur_planes P;
    float *pl = s->irr;
    float *ep[3] = {pl, pl + npix, pl + 2 * npix}, *op[3] = {pl + 3 * npix, pl + 4 * npix, pl + 5 * npix};
    float *pz = pl + 6 * npix, *pnx = pl + 7 * npix, *pny = pl + 8 * npix, *pnz = pl + 9 * npix;
    for (int d = 0; d < 3; d++) P.e[d] = ep[d], P.o[d] = op[d];
    P.z = pz, P.nx = pnx, P.ny = pny, P.nz = pnz;
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < (long long)npix; i++) {
        int ok = (vs->flags[i] & PGI_VS_VALID) != 0;
        pz[i] = ok ? vs->depth[i] : 1e30f;
        pnx[i] = ok ? vs->nrm[3 * i] : 0.f;
        pny[i] = ok ? vs->nrm[3 * i + 1] : 0.f;
        pnz[i] = ok ? vs->nrm[3 * i + 2] : 0.f;
        if (!ok || !s->splatted) ep[0][i] = ep[1][i] = ep[2][i] = 0.f;   /* valid samples are shaded below */
    }
    const float inv_area = 1.f / (PGI_PI * s->r * s->r);
    if (s->splatted) {
        const uint32_t leaf0 = s->lvl_off[s->L], leaf1 = s->lvl_off[s->L + 1];
#pragma omp parallel for schedule(dynamic, 16)
        for (long long li = leaf0; li < (long long)leaf1; li++) {
            /* the leaf's buckets plus those of its ancestors down from level D */
            float b[24];
            memset(b, 0, sizeof b);
            uint32_t path[MAX_LEVELS + 2];
            int np = 0;
            uint32_t u = (uint32_t)li;
            for (int l = s->L; l >= s->D; l--, u = s->nodes[u].parent) path[np++] = u;
            for (int p = np - 1; p >= 0; p--) {
                const float *bb = s->buckets + (size_t)(path[p] - s->lvl_off[s->D]) * 24;
                for (int c = 0; c < 24; c++) b[c] += bb[c];
            }
            const size_t nv = s->nvalid;
            const float *snx = s->sam + 3 * nv, *sny = snx + nv, *snz = sny + nv;   /* sorted normals */
            if (li + 1 < (long long)leaf1)   /* the next leaf's irradiance rows (written) */
                for (uint32_t k = s->sbeg[li + 1]; k < s->send[li + 1]; k += 8)
                    for (int d = 0; d < 3; d++) __builtin_prefetch(ep[d] + s->order[k], 1);
            enum { B = 64 };
            float e0[B], e1[B], e2[B];
            for (uint32_t k0 = s->sbeg[li]; k0 < s->send[li]; k0 += B) {
                const int nb = (int)(s->send[li] - k0 < B ? s->send[li] - k0 : B);
                dir_block(snx + k0, sny + k0, snz + k0, nb, &s->x, b, e0, e1, e2);
                for (int t = 0; t < nb; t++) {
                    const size_t i = s->order[k0 + t];
                    ep[0][i] = e0[t] * inv_area, ep[1][i] = e1[t] * inv_area, ep[2][i] = e2[t] * inv_area;
                }
            }
        }
    }
    *t_blur = pgi__now_ms();
    const float *E[3] = {P.e[0], P.e[1], P.e[2]};
    if (s->blur > 0 && s->splatted) {
        blur_pass(&P, vs->width, vs->height, s->blur, 0);   /* e -> o */
        blur_planes Q = P;
        for (int d = 0; d < 3; d++) Q.e[d] = op[d], Q.o[d] = ep[d];
        blur_pass(&Q, vs->width, vs->height, s->blur, 1);   /* o -> e */
    }
#pragma omp parallel for schedule(static)
    for (long long ii = 0; ii < (long long)npix; ii++) {
        float *out = a->out_rgb + 3 * ii;
        if (!(vs->flags[ii] & PGI_VS_VALID)) {
            out[0] = out[1] = out[2] = 0.f;
            continue;
        }
        const float *kd = vs->kd + 3 * ii;
        for (int d = 0; d < 3; d++) out[d] = kd[d] * PGI_INV_PI * E[d][ii];
    }
    return PGI_OK;
}

/* One block of nb samples (local arrays) against m list photons, photon-major:
 * the inner loop over the samples is branch-free and vectorises. It makes
 * exactly pgi__gather's decisions (same expressions; no FMA contraction) and
 * adds each contributing photon's flux in list order; a rejected photon adds
 * 0 * flux (flux is finite), so the sums are those of gather. */
PGI__HOT_LOOP
static void rad_block(const pgi__packed_photon *restrict q, uint32_t m, int nb, const float *restrict bx,
                      const float *restrict by, const float *restrict bz, const float *restrict bnx,
                      const float *restrict bny, const float *restrict bnz, float *restrict ar, float *restrict ag,
                      float *restrict ab, uint32_t *restrict an, float r2) {
    for (uint32_t e = 0; e < m; e++) {
        const float px = q[e].px, py = q[e].py, pz = q[e].pz, dx = q[e].dx, dy = q[e].dy, dz = q[e].dz, fr = q[e].fr,
                    fg = q[e].fg, fb = q[e].fb;
        for (int t = 0; t < nb; t++) {
            float ex = px - bx[t], ey = py - by[t], ez = pz - bz[t];
            float d2 = ex * ex + ey * ey + ez * ez;
            float c = bnx[t] * dx + bny[t] * dy + bnz[t] * dz;
            int ok = (d2 < r2) & (c > 0.f);
            float okf = (float)ok;   /* int, not unsigned: SSE2 has the conversion */
            ar[t] += okf * fr;
            ag[t] += okf * fg;
            ab[t] += okf * fb;
            an[t] += (uint32_t)ok;
        }
    }
}

static pgi_status cl_estimate(void *state, const pgi_estimate_args *a) {
    cl_state *s = state;
    double t0 = pgi__now_ms();
    const pgi_view_samples *vs = a->samples;
    if (vs->width != s->W || vs->height != s->H)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: estimate called with a frame size other than build's",
                         s->variant & V_DIR ? "directional" : "cluster");
    const size_t npix = vs->count;
    uint64_t reads = 0, contrib = 0;
    pgi_status st;
    if (s->variant & V_DIR) {
        double tb = t0;
        if ((st = dir_radiance(s, a, &tb))) return st;
        double t1 = pgi__now_ms();
        s->c.st.estimate_ms = t1 - t0;
        pgi__stats_pass(&s->c.st, "radiance", tb - t0);
        pgi__stats_pass(&s->c.st, "blur", t1 - tb);
        reads = contrib = s->deposits;
    } else {
#pragma omp parallel for schedule(static)
        for (long long ii = 0; ii < (long long)npix; ii++)
            if (!(vs->flags[ii] & PGI_VS_VALID)) a->out_rgb[3 * ii] = a->out_rgb[3 * ii + 1] = a->out_rgb[3 * ii + 2] = 0.f;
        const size_t nn = s->nnodes;
        if (!s->splatted) {
            /* no photons: every valid sample gets zero */
#pragma omp parallel for schedule(static)
            for (long long ii = 0; ii < (long long)npix; ii++)
                a->out_rgb[3 * ii] = a->out_rgb[3 * ii + 1] = a->out_rgb[3 * ii + 2] = 0.f;
        } else {
            if ((st = ENSURE(cum_flux, 3 * nn + 1, float)) || (st = ENSURE(cum_cnt, nn + 1, uint32_t))) return st;
            /* trivially accepted flux of a node and all its ancestors, top-down */
            for (int l = 0; l <= s->L; l++) {   /* small levels: no fork/join (barriers cost on a busy machine) */
#pragma omp parallel for schedule(static) if (s->lvl_off[l + 1] - s->lvl_off[l] >= 65536)
                for (long long ni = s->lvl_off[l]; ni < (long long)s->lvl_off[l + 1]; ni++) {
                    uint32_t p = s->nodes[ni].parent;
                    for (int d = 0; d < 3; d++)
                        s->cum_flux[3 * ni + d] = s->node_flux[3 * ni + d] + (l ? s->cum_flux[3 * (size_t)p + d] : 0.f);
                    s->cum_cnt[ni] = s->node_tcnt[ni] + (l ? s->cum_cnt[p] : 0u);
                }
            }
            const float r2 = s->r * s->r;
            const uint32_t leaf0 = s->lvl_off[s->L], leaf1 = s->lvl_off[s->L + 1];
#pragma omp parallel for schedule(dynamic, 8) reduction(+ : reads, contrib)
            for (long long li = leaf0; li < (long long)leaf1; li++) {
                if (li + 1 < (long long)leaf1)   /* the next leaf's kd and output rows */
                    for (uint32_t k = s->sbeg[li + 1]; k < s->send[li + 1]; k += 4) {
                        __builtin_prefetch(vs->kd + 3 * (size_t)s->order[k]);
                        __builtin_prefetch(a->out_rgb + 3 * (size_t)s->order[k], 1);
                    }
                uint32_t path[MAX_LEVELS + 2];
                int np = 0;
                uint64_t total = 0;
                for (uint32_t u = (uint32_t)li; u != UINT32_MAX; u = s->nodes[u].parent) {
                    if (s->node_start[u + 1] > s->node_start[u]) path[np++] = u;
                    total += s->node_start[u + 1] - s->node_start[u];
                }
                const float *cf = s->cum_flux + 3 * li;
                const uint32_t cc = s->cum_cnt[li];
                /* Photon-major over blocks of samples held as local arrays: the
                 * inner loop over samples is branch-free and vectorises. It makes
                 * exactly pgi__gather's decisions (same expressions, same order;
                 * no FMA contraction) and sums each sample's flux in the same
                 * order (root to leaf, photon order). Non-Lambertian samples are
                 * masked out (NaN position) and gathered with pgi__gather. */
                enum { B = 64 };
                float ar[B], ag[B], ab[B];
                uint32_t an[B];
                const size_t nv = s->nvalid;
                const float *const bx = s->sam, *const by = bx + nv, *const bz = by + nv, *const bnx = bz + nv,
                            *const bny = bnx + nv, *const bnz = bny + nv;
                for (uint32_t k0 = s->sbeg[li]; k0 < s->send[li]; k0 += B) {
                    const int nb = (int)(s->send[li] - k0 < B ? s->send[li] - k0 : B);
                    /* whole vectors: lanes past nb read the next samples (or the zero
                     * padding) and are ignored; each lane is independent */
                    const int nbv = (nb + 7) & ~7;
                    for (int t = 0; t < nbv; t++) ar[t] = ag[t] = ab[t] = 0.f, an[t] = 0;
                    for (int p = np - 1; p >= 0; p--) {
                        const pgi__packed_photon *q = s->lists + s->node_start[path[p]];
                        const uint32_t m = s->node_start[path[p] + 1] - s->node_start[path[p]];
                        rad_block(q, m, nbv, bx + k0, by + k0, bz + k0, bnx + k0, bny + k0, bnz + k0, ar, ag, ab, an, r2);
                    }
                    const float w = 1.f / (PGI_PI * r2);
                    for (int t = 0; t < nb; t++) {
                        size_t i = s->order[k0 + t];
                        if (bx[k0 + t] == bx[k0 + t]) {
                            /* Lambertian: pgi__acc_finish with no specular sum, reading only kd */
                            const float *kd = vs->kd + 3 * i;
                            float *o = a->out_rgb + 3 * i;
                            o[0] = (kd[0] * PGI_INV_PI * (ar[t] + cf[0])) * w;
                            o[1] = (kd[1] * PGI_INV_PI * (ag[t] + cf[1])) * w;
                            o[2] = (kd[2] * PGI_INV_PI * (ab[t] + cf[2])) * w;
                            reads += total;
                            contrib += an[t] + cc;
                            continue;
                        }
                        pgi__vs v;
                        pgi__vs_load(vs, i, &v);
                        pgi__acc acc = {ar[t], ag[t], ab[t], 0.f, 0.f, 0.f, an[t]};
                        if (!v.lambert) {
                            for (int p = np - 1; p >= 0; p--) {
                                const pgi__packed_photon *q = s->lists + s->node_start[path[p]];
                                const uint32_t m = s->node_start[path[p] + 1] - s->node_start[path[p]];
                                for (uint32_t e = 0; e < m; e++) pgi__gather_packed(&v, r2, q + e, &acc);
                            }
                        }
                        acc.fr += cf[0], acc.fg += cf[1], acc.fb += cf[2];
                        acc.contributing += cc;
                        pgi__acc_finish(&v, &acc, r2, a->out_rgb + 3 * i);
                        reads += total;
                        contrib += acc.contributing;
                    }
                }
            }
        }
        s->c.st.estimate_ms = pgi__now_ms() - t0;
        pgi__stats_pass(&s->c.st, "radiance", s->c.st.estimate_ms);
    }
    s->c.st.reads = reads;
    s->c.st.contributing = contrib;
    /* bytes per structure (the paper's Table 1) */
    const size_t nn = s->nnodes;
    s->c.st.memory_count = 0;
    pgi__stats_mem(&s->c.st, "hierarchy", nn * (4 * sizeof(uint32_t) + 2 * sizeof(uint32_t) + sizeof(uint64_t)) +
                                              s->nvalid * (sizeof(uint32_t) + sizeof(uint64_t)));
    pgi__stats_mem(&s->c.st, "bounds", nn * 6 * sizeof(float));
    pgi__stats_mem(&s->c.st, "sorted_samples", s->nvalid * 6 * sizeof(float));
    if (s->variant & V_CONE) pgi__stats_mem(&s->c.st, "normal_cones", nn * 6 * sizeof(float));
    if (s->variant & V_TRIVIAL) pgi__stats_mem(&s->c.st, "node_flux", nn * (3 * sizeof(float) + sizeof(uint32_t)));
    if (s->variant & V_DIR) {
        size_t nD = s->splatted ? nn - s->lvl_off[s->D] : 0;
        pgi__stats_mem(&s->c.st, "node_flux", nD * 24 * sizeof(float));
        pgi__stats_mem(&s->c.st, "irradiance", 10 * npix * sizeof(float));
    }
    pgi__stats_mem(&s->c.st, "jobs", s->njobs * (sizeof(uint32_t) + sizeof(pgi__packed_photon)));
    if (!(s->variant & V_DIR))
        pgi__stats_mem(&s->c.st, "photon_lists", s->nlist * sizeof(pgi__packed_photon) + (nn + 1) * sizeof(uint32_t));
    return PGI_OK;
}

static void cl_stats(const void *state, pgi_estimator_stats *out) { *out = ((const cl_state *)state)->c.st; }

static void cl_destroy(void *state) {
    cl_state *s = state;
    if (!s) return;
    pgi__buf *b[] = {&s->keys_buf, &s->keys2_buf, &s->spread_buf, &s->ck2_buf, &s->tcl_buf, &s->tn_buf,
                     &s->ci_buf, &s->ci2_buf, &s->cb_buf, &s->cn_buf, &s->cs_buf, &s->order_buf,
                     &s->hist_buf, &s->pix_cnt_buf, &s->nodes_buf, &s->sbeg_buf, &s->send_buf, &s->nkey_buf,
                     &s->top_cnt_buf, &s->top_tcnt_buf, &s->job_start_buf, &s->jobs_buf, &s->top_ids_buf,
                     &s->node_cnt_buf, &s->node_start_buf, &s->node_tcnt_buf, &s->cursor_buf, &s->top_flux_buf,
                     &s->node_flux_buf, &s->buckets_buf, &s->lists_buf, &s->pk_buf, &s->jobq_buf,
                     &s->cum_flux_buf, &s->irr_buf, &s->cum_cnt_buf, &s->task_rec_buf, &s->soa_buf, &s->sam_buf};
    for (size_t k = 0; k < sizeof b / sizeof b[0]; k++) pgi__buf_free(b[k]);
    for (int i = 0; i < s->nouts; i++) free(s->outs[i].out);
    free(s->outs);
    free(s);
}

const pgi_estimator_vtbl pgi__est_cluster = {
    "cluster", "view-sample cluster hierarchy; photons splatted into node lists (Moreau et al. 2016 §4.1-4.4)", 1,
    cluster_create, cl_build, cl_estimate, cl_stats, cl_destroy, 0,
};
const pgi_estimator_vtbl pgi__est_cluster_cone = {
    "cluster-cone", "cluster + normal-cone rejection of photons from below a node's surfaces (§4.5)", 1,
    cone_create, cl_build, cl_estimate, cl_stats, cl_destroy, 0,
};
const pgi_estimator_vtbl pgi__est_cluster_trivial = {
    "cluster-trivial",
    "cluster-cone + trivial accept: enclosed all-Lambertian nodes accumulate flux, no list (§4.6)", 1,
    trivial_create, cl_build, cl_estimate, cl_stats, cl_destroy, 0,
};
const pgi_estimator_vtbl pgi__est_directional = {
    "directional",
    "cluster hierarchy, flux in 8 octant buckets per node from a fixed level down, blurred irradiance (§4.7)", 0,
    dir_create, cl_build, cl_estimate, cl_stats, cl_destroy, 0,
};
