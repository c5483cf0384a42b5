/* The view-sample cluster hierarchy of one frame (Moreau et al., HPG 2016,
 * §4.1, §4.5; the hierarchy of Sintorn et al. 2014), shared by the cluster
 * estimators and directional.
 *
 * Hierarchy (rebuilt each frame, §4.1): a cluster is a screen tile of T x T
 * pixels (default 8) x a view-depth slice k = floor(log(z/near) /
 * log(1 + 2 tan(fov_y/2) / tiles_y)) (Olsson et al. 2012), so clusters are
 * roughly cubical. The key bits of tile x, tile y and slice are interleaved
 * (the dimension with the most bits left first), and the key is cut into
 * 5-bit digits: 32 children a node, a 32-bit child mask, key >> 5 = parent
 * key.
 *
 * Samples seen through mirrors/glass (no PGI_VS_PRIMARY) lie anywhere in the
 * reflected scene, so a tile and a depth slice would group far-apart points
 * (a curved mirror shows the whole scene in a few pixels) and the boxes of
 * those clusters would catch nearly every photon. They get one extra top key
 * bit, their own subtree, and under it a key by position instead: the Morton
 * code of a uniform grid over their view-space box (3 x floor(bits / 3) bits),
 * so each of their clusters is one occupied grid cell.
 *
 * Unlike the paper's dense GPU arrays, the tree is sparse: each tile's
 * primary samples are sorted locally by slice, the mirror-seen samples by
 * their cell (one radix sort), the resulting clusters are radix-sorted by key, the
 * leaves are the clusters in key order, and every level is the run list of the
 * key prefixes, stored breadth first; a node's children are contiguous (first
 * child index + mask), and every node covers one contiguous range of the
 * sorted samples. Boxes are view-space AABBs of the ACTUAL sample positions
 * (so mirror samples anywhere are bounded), cones bound the actual shading
 * normals; both are propagated bottom-up.
 *
 * The build runs in phases: scan_samples (valid counts, depth range),
 * key_layout (interleaved key bits), sort_tiles (per-tile local sorts),
 * sort_secondary (the mirror-seen samples by cell),
 * sort_clusters (radix sort of the clusters, samples in cluster order),
 * link_levels (nodes of every level, parent/child links, sample ranges),
 * leaf_bounds and inner_bounds (boxes, cones, Lambert flags). */
#include <string.h>

#include "cluster_internal.h"
#include "spec_cells.h"

#define RADIX_BITS 13 /* at most; 2 passes up to 26 key bits (1080p with 8-pixel tiles) */
#define RADIX (1u << RADIX_BITS)
#define RADIX_CHUNKS 8 /* fixed (thread-count independent); few: the digit prefix sum walks chunks x digits */

/* A monotone, continuous stand-in for log2 (exact at powers of two): slices
 * only need to be roughly cubical, and a libm log per pixel costs more than
 * the rest of the key. */
static inline float fast_log2(float x) {
    union {
        float f;
        uint32_t u;
    } v = {x};
    float e = (float)((int)((v.u >> 23) & 255) - 127);
    v.u = (v.u & 0x007fffffu) | 0x3f800000u; /* mantissa in [1, 2) */
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

/* slice_of for the w depths of each of h rows (stride W) into out (w a row), 8 a step with
 * the same expressions lane by lane (no FMA: the same slices), the rest of a row by slice_of;
 * an AVX2 clone where the CPU has it. */
typedef float cl_b8f __attribute__((vector_size(32)));
typedef int32_t cl_b8i __attribute__((vector_size(32)));
#define CL_SEL(m, a, b) ((cl_b8f)(((cl_b8i)(a) & (m)) | ((cl_b8i)(b) & ~(m))))
PGI__HOT_LOOP
static void slice_rows(const float *z, size_t W, int w, int h, float near, float log_near, float inv_step,
                       int32_t *out) {
    const cl_b8f top = {65535.f, 65535.f, 65535.f, 65535.f, 65535.f, 65535.f, 65535.f, 65535.f}, zero = {0.f};
    for (int y = 0; y < h; y++) {
        const float *zr = z + (size_t)y * W;
        int x = 0;
        for (; x + 8 <= w; x += 8) {
            cl_b8f zz;
            memcpy(&zz, zr + x, sizeof zz);
            const cl_b8i u = (cl_b8i)zz;
            const cl_b8f e = __builtin_convertvector(((u >> 23) & 255) - 127, cl_b8f);
            const cl_b8f m = (cl_b8f)((u & 0x007fffff) | 0x3f800000) - 1.f;
            const cl_b8f k = CL_SEL(zz > near, (e + m * (1.3465f - 0.3465f * m) - log_near) * inv_step, zero);
            const cl_b8f kc = CL_SEL(k >= 0.f, CL_SEL(k < 65535.f, k, top), CL_SEL(k < 0.f, zero, top));
            const cl_b8i r = __builtin_convertvector(kc, cl_b8i);
            memcpy(out + y * w + x, &r, sizeof r);
        }
        for (; x < w; x++) out[y * w + x] = slice_of(zr[x], near, log_near, inv_step);
    }
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
static int radix_sort(uint64_t *k0, uint32_t *v0, uint64_t *k1, uint32_t *v1, size_t n, int bits, uint32_t *hist,
                      int nt) {
    const size_t nch = RADIX_CHUNKS, chunk = (n + nch - 1) / nch + 1;
    const int passes = (bits + RADIX_BITS - 1) / RADIX_BITS;
    const int digit = passes ? (bits + passes - 1) / passes : 0; /* <= RADIX_BITS, balanced */
    const uint64_t dm = ((uint64_t)1 << digit) - 1;
    const uint32_t nb = (uint32_t)1 << digit;
    int swapped = 0;
    for (int pass = 0; pass < passes; pass++) {
        const int shift = pass * digit;
#pragma omp parallel for schedule(static) if (n >= 262144) num_threads(nt)
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
#pragma omp parallel for schedule(static) if (n >= 262144) num_threads(nt)
        for (long long ci = 0; ci < (long long)nch; ci++) {
            uint32_t *h = hist + (size_t)ci * nb;
            size_t a = (size_t)ci * chunk, b = a + chunk < n ? a + chunk : n;
            for (size_t i = a; i < b; i++) {
                uint32_t o = h[(k0[i] >> shift) & dm]++;
                k1[o] = k0[i];
                v1[o] = v0[i];
            }
        }
        uint64_t *tk = k0;
        k0 = k1;
        k1 = tk;
        uint32_t *tv = v0;
        v0 = v1;
        v1 = tv;
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
        nd->rej = -2.f; /* never: the cone reaches past the tangent plane */
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
    /* trivial accept needs dot > acc and an all-Lambertian node: never when it is not */
    s->cacc[ni] = nd->lambert ? nd->acc : INFINITY;
}

/* What one phase of the build hands to the next. */
typedef struct {
    float near, log_near, inv_step; /* depth slices */
    int nslices_m1;
    uint64_t *sp[3];    /* spread tables: tile x, tile y, slice -> key bits */
    uint64_t sec_bit;   /* top key bit of the mirror/glass subtree */
    int bits;           /* key bits */
    size_t nclus;       /* clusters (= leaves) */
    size_t nclus_tiles; /* of which from tiles (primary samples); the rest are cells of mirror-seen samples */
    size_t nsec;        /* mirror-seen samples */
    size_t sec_base;    /* their (cell key << 32 | pixel) entries start at keys2[sec_base] */
} build_ctx;

static pgi_status scan_samples(cl_state *s, const pgi_view_samples *vs, const pgi_camera *cam, build_ctx *bc) {
    const int W = vs->width, H = vs->height;
    pgi_status st;
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
    int any_nan = 0;
    size_t nsec = 0;
#pragma omp parallel for schedule(static) reduction(min                                                                \
                                                    : near) reduction(max                                              \
                                                                      : zmax) reduction(|                              \
                                                                                        : any_nan) reduction(+ : nsec) \
    num_threads(s->c.threads)
    for (int c = 0; c < npc; c++) {
        uint32_t cnt = 0;
        for (int y = c * rows_per; y < (c + 1) * rows_per && y < H; y++)
            for (int x = 0; x < W; x++) {
                size_t i = (size_t)y * W + (size_t)x;
                uint8_t f = vs->flags[i];
                if (!(f & PGI_VS_VALID)) continue;
                cnt++;
                if (!(f & PGI_VS_PRIMARY)) {
                    nsec++;
                    continue;
                }
                float z = vs->depth[i];
                if (z > 0.f && z < near) near = z;
                if (z > zmax) zmax = z;
                any_nan |= !(z == z);
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
    bc->near = near, bc->log_near = log_near, bc->inv_step = inv_step;
    bc->nslices_m1 = nslices_m1;
    bc->nsec = nsec;
    return PGI_OK;
}

static pgi_status key_layout(cl_state *s, build_ctx *bc) {
    const int nslices_m1 = bc->nslices_m1;
    pgi_status st;
    /* Key layout: interleave (the dimension with the most bits left first). */
    int bd[3] = {bits_for((uint32_t)s->ntx), bits_for((uint32_t)s->nty), bits_for((uint32_t)nslices_m1 + 1)};
    int btot = bd[0] + bd[1] + bd[2];
    size_t dimn[3] = {(size_t)1 << bd[0], (size_t)1 << bd[1], (size_t)1 << bd[2]};
    if ((st = ENSURE(spread, dimn[0] + dimn[1] + dimn[2], uint64_t))) return st;
    uint64_t **const sp = bc->sp;
    sp[0] = s->spread, sp[1] = s->spread + dimn[0], sp[2] = s->spread + dimn[0] + dimn[1];
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
    const int bits = btot + (bc->nsec > 0 ? 1 : 0);
    const uint64_t sec_bit = (uint64_t)1 << btot;
    int L = (bits + 4) / 5;
    if (L > MAX_LEVELS) return pgi__fail(PGI_ERR_UNSUPPORTED, "cluster: %d key bits exceed the hierarchy depth", bits);
    s->L = L;
    bc->bits = bits, bc->sec_bit = sec_bit;
    return PGI_OK;
}

static pgi_status sort_tiles(cl_state *s, const pgi_view_samples *vs, build_ctx *bc) {
    const int W = vs->width, H = vs->height, T = s->T;
    const float near = bc->near, log_near = bc->log_near, inv_step = bc->inv_step;
    const size_t nvalid = s->nvalid;
    pgi_status st;
    /* Per tile: its valid primary samples sorted by slice, the part of the
     * key that varies inside a tile (the spread tables are monotone, so this
     * is key order); the runs are the tile's clusters. Then only the
     * clusters are radix-sorted by key, and the samples are copied into
     * cluster order: sorting 2M samples is replaced by ~64-sample local sorts. */
    const int ntiles = s->ntx * s->nty;
    const size_t tsz = (size_t)T * (size_t)T;
    bc->sec_base = (size_t)ntiles * tsz;
    if ((st = ENSURE(keys2, (size_t)ntiles * tsz + bc->nsec + 1, uint64_t)) ||
        (st = ENSURE(tcl, (size_t)ntiles + 1, uint32_t)) || (st = ENSURE(tn, (size_t)ntiles + 1, uint32_t)) ||
        (st = ENSURE(order, nvalid + 1, uint32_t)))
        return st;
#pragma omp parallel for schedule(dynamic, 16) num_threads(s->c.threads)
    for (int t = 0; t < ntiles; t++) {
        const int tx = t % s->ntx, ty = t / s->ntx;
        uint64_t *const out = s->keys2 + (size_t)t * tsz;
        uint64_t tmp[4096]; /* the keys in pixel order (tiles up to 64 x 64 pixels) */
        uint64_t *v = tsz <= 4096 ? tmp : out;
        uint32_t n = 0, smin = UINT32_MAX, smax = 0;
        const int tw = (tx + 1) * T < W ? T : W - tx * T, th = (ty + 1) * T < H ? T : H - ty * T;
        int32_t sls[4096]; /* the tile's slices, every pixel */
        if (tsz <= 4096)
            slice_rows(vs->depth + (size_t)(ty * T) * W + (size_t)(tx * T), (size_t)W, tw, th, near, log_near, inv_step,
                       sls);
        for (int y = ty * T; y < (ty + 1) * T && y < H; y++)
            for (int x = tx * T; x < (tx + 1) * T && x < W; x++) {
                size_t i = (size_t)y * W + (size_t)x;
                if ((vs->flags[i] & (PGI_VS_VALID | PGI_VS_PRIMARY)) != (PGI_VS_VALID | PGI_VS_PRIMARY)) continue;
                uint64_t sl = tsz <= 4096 ? (uint64_t)sls[(y - ty * T) * tw + (x - tx * T)]
                                          : (uint64_t)slice_of(vs->depth[i], near, log_near, inv_step);
                uint64_t j = (uint64_t)((y - ty * T) * T + (x - tx * T));
                v[n++] = sl << 20 | j;
                smin = (uint32_t)sl < smin ? (uint32_t)sl : smin;
                smax = (uint32_t)sl > smax ? (uint32_t)sl : smax;
            }
        /* Sort by (slice, pixel): the pixels come in increasing j,
         * so a stable counting sort over the tile's few slices gives the
         * sorted order; wide slice ranges (rare) use a comparison sort. */
        const uint32_t range = n ? smax - smin + 1 : 0;
        int sorted = n < 2;
        if (v == tmp && n > 1 && range > 1 && range <= 64) {
            sorted = 1;
            uint32_t cnt[65];
            memset(cnt, 0, sizeof cnt);
            for (uint32_t k = 0; k < n; k++) cnt[1 + ((uint32_t)(v[k] >> 20) - smin)]++;
            for (uint32_t b = 1; b <= range; b++) cnt[b] += cnt[b - 1];
            for (uint32_t k = 0; k < n; k++) out[cnt[(uint32_t)(v[k] >> 20) - smin]++] = v[k];
            v = out;
        }
        if (v != out) {
            for (uint32_t k = 0; k < n; k++) out[k] = v[k];
            v = out;
        }
        if (!sorted && range == 1) {
            /* one slice: already in order */
        } else if (!sorted && n <= 256) {
            for (uint32_t k = 1; k < n; k++) { /* insertion sort: tiles are small */
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
    bc->nclus = bc->nclus_tiles = nclus;
    return PGI_OK;
}

/* Spreads the low 21 bits of v to every third bit. */
static inline uint64_t spread3(uint64_t v) {
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffull;
    v = (v | v << 16) & 0x1f0000ff0000ffull;
    v = (v | v << 8) & 0x100f00f00f00f00full;
    v = (v | v << 4) & 0x10c30c30c30c30c3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

/* The mirror-seen samples: keyed by the Morton code of their cell in a uniform
 * grid over their view-space box, sorted by it (stable: pixel order inside a
 * cell), stored as (cell key << 32 | pixel) at keys2[sec_base]; each run of
 * one cell is a cluster. */
static pgi_status sort_secondary(cl_state *s, const pgi_view_samples *vs, build_ctx *bc) {
    const size_t nsec = bc->nsec;
    if (!nsec) return PGI_OK;
    pgi_status st;
    if ((st = ENSURE(sec_key, 2 * nsec + 1, uint64_t)) || (st = ENSURE(sec_pix, 2 * nsec + 1, uint32_t)) ||
        (st = ENSURE(sec_pos, 3 * nsec + 1, float)))
        return st;
    float lo[3], hi[3];
    const size_t m = pgi__spec_samples(vs, &s->x, s->sec_pix, s->sec_pos, lo, hi, s->c.threads);
    PGI__ASSERT(m == nsec);
    (void)m;
    /* as many bits a side as the primary key has per dimension on average (at most 21) */
    int b = (bc->bits - 1) / 3;
    b = b > 21 ? 21 : b;
    float ext = 0.f;
    for (int d = 0; d < 3; d++) ext = pgi_maxf(ext, hi[d] - lo[d]);
    const float cells = (float)(1u << b), inv = ext > 0.f && isfinite(ext) ? cells / ext : 0.f;
    for (size_t k = 0; k < nsec; k++) {
        uint64_t key = 0;
        for (int d = 0; d < 3; d++) {
            float f = (s->sec_pos[3 * k + d] - lo[d]) * inv;
            uint64_t c = f >= 1.f ? (f < cells ? (uint64_t)f : (uint64_t)cells - 1) : 0; /* NaN: cell 0 */
            key |= spread3(c) << (2 - d);
        }
        s->sec_key[k] = key;
    }
    uint64_t *k0 = s->sec_key, *k1 = s->sec_key + nsec;
    uint32_t *v0 = s->sec_pix, *v1 = s->sec_pix + nsec;
    if (radix_sort(k0, v0, k1, v1, nsec, 3 * b, s->hist, s->c.threads)) k0 = k1, v0 = v1;
    uint64_t *out = s->keys2 + bc->sec_base;
    size_t runs = 0;
    for (size_t k = 0; k < nsec; k++) {
        out[k] = k0[k] << 32 | v0[k];
        runs += k == 0 || k0[k] != k0[k - 1];
    }
    bc->nclus = bc->nclus_tiles + runs;
    return PGI_OK;
}

static pgi_status sort_clusters(cl_state *s, const pgi_view_samples *vs, const build_ctx *bc) {
    const int W = vs->width, T = s->T;
    const int ntiles = s->ntx * s->nty;
    const size_t tsz = (size_t)T * (size_t)T, nclus = bc->nclus, nvalid = s->nvalid;
    uint64_t *const *const sp = bc->sp;
    const uint64_t sec_bit = bc->sec_bit;
    const size_t sec_base = bc->sec_base;
    const int bits = bc->bits;
    pgi_status st;
    if ((st = ENSURE(keys, nclus + 1, uint64_t)) || (st = ENSURE(ck2, nclus + 1, uint64_t)) ||
        (st = ENSURE(ci, nclus + 1, uint32_t)) || (st = ENSURE(ci2, nclus + 1, uint32_t)) ||
        (st = ENSURE(cb, nclus + 1, uint32_t)) || (st = ENSURE(cn, nclus + 1, uint32_t)) ||
        (st = ENSURE(cs, nclus + 1, uint32_t)))
        return st;
#pragma omp parallel for schedule(dynamic, 16) num_threads(s->c.threads)
    for (int t = 0; t < ntiles; t++) {
        const int tx = t % s->ntx, ty = t / s->ntx;
        const uint64_t *v = s->keys2 + (size_t)t * tsz;
        const uint32_t n = s->tn[t];
        uint32_t c = s->tcl[t];
        for (uint32_t k = 0; k < n;) {
            const uint32_t k0 = k;
            while (k < n && (v[k] >> 20) == (v[k0] >> 20)) k++;
            const uint64_t sl = (v[k0] >> 20) & 0xFFFFFu;
            s->keys[c] = sp[0][tx] | sp[1][ty] | sp[2][sl];
            s->ci[c] = c;
            s->cb[c] = (uint32_t)((size_t)t * tsz + k0);
            s->cn[c] = k - k0;
            c++;
        }
    }
    {
        const uint64_t *v = s->keys2 + bc->sec_base;
        size_t c = bc->nclus_tiles;
        for (size_t k = 0; k < bc->nsec;) {
            const size_t k0 = k;
            while (k < bc->nsec && (v[k] >> 32) == (v[k0] >> 32)) k++;
            s->keys[c] = sec_bit | v[k0] >> 32;
            s->ci[c] = (uint32_t)c;
            s->cb[c] = (uint32_t)(bc->sec_base + k0);
            s->cn[c] = (uint32_t)(k - k0);
            c++;
        }
        PGI__ASSERT(c == nclus);
    }
    if (radix_sort(s->keys, s->ci, s->ck2, s->ci2, nclus, bits, s->hist, s->c.threads)) {
        pgi__buf tk = s->keys_buf;
        s->keys_buf = s->ck2_buf;
        s->ck2_buf = tk;
        pgi__buf tv = s->ci_buf;
        s->ci_buf = s->ci2_buf;
        s->ci2_buf = tv;
    }
    {
        size_t acc = 0;
        for (size_t i = 0; i < nclus; i++) {
            s->cs[i] = (uint32_t)acc;
            acc += s->cn[s->ci[i]];
        }
        s->cs[nclus] = (uint32_t)acc;
        PGI__ASSERT(acc == nvalid);
    }
#pragma omp parallel for schedule(dynamic, 256) num_threads(s->c.threads)
    for (long long i = 0; i < (long long)nclus; i++) {
        const int tsh = (T & (T - 1)) == 0 ? __builtin_ctz((unsigned)T) : -1;
        const uint32_t c = s->ci[i], t = (uint32_t)(s->cb[c] / tsz);
        const int tx = (int)(t % (uint32_t)s->ntx), ty = (int)(t / (uint32_t)s->ntx);
        const size_t base = (size_t)(ty * T) * W + (size_t)(tx * T);
        const uint64_t *kv = s->keys2 + s->cb[c];
        uint32_t *o = s->order + s->cs[i];
        if (s->cb[c] >= sec_base) { /* a cell of mirror-seen samples: pixel indices */
            for (uint32_t j = 0; j < s->cn[c]; j++) o[j] = (uint32_t)kv[j];
        } else if (tsh >= 0) { /* power-of-two tiles (the default 8): no divisions */
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
    return PGI_OK;
}

static pgi_status link_levels(cl_state *s, const build_ctx *bc) {
    const int L = s->L;
    const size_t nclus = bc->nclus, nvalid = s->nvalid;
    pgi_status st;
    /* Levels: count the distinct key prefixes per level (one scan), then fill. */
    size_t cnt[MAX_LEVELS + 1] = {0};
    const uint64_t *K = s->keys; /* sorted cluster keys, all distinct: one leaf each */
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
    return PGI_OK;
}

static pgi_status leaf_bounds(cl_state *s, const pgi_view_samples *vs) {
    const int L = s->L;
    const size_t nn = s->nnodes, nvalid = s->nvalid;
    pgi_status st;
    /* Structure-of-arrays copies of boxes and cones for the child tests. */
    const size_t stride = nn + 16;
    if ((st = ENSURE(soa, 11 * stride, float))) return st;
    float **arr[11] = {&s->sx0, &s->sy0, &s->sz0, &s->sx1,  &s->sy1, &s->sz1,
                       &s->cax, &s->cay, &s->caz, &s->crej, &s->cacc};
    for (int k = 0; k < 11; k++) *arr[k] = s->soa + (size_t)k * stride;
    /* Leaf boxes, cones, Lambert flags from the samples; the samples' position
     * and normal are copied in sorted order (SoA) for the radiance pass, which
     * then reads them sequentially instead of gathering tile rows again. */
    const uint32_t leaf0 = s->lvl_off[L], leaf1 = s->lvl_off[L + 1];
    if ((st = ENSURE(sam, 6 * nvalid + 16, float))) return st;
    memset(s->sam + 6 * nvalid, 0, 16 * sizeof(float)); /* padding read by the last radiance block */
    float *const S0 = s->sam, *const S1 = S0 + nvalid, *const S2 = S1 + nvalid, *const S3 = S2 + nvalid,
                 *const S4 = S3 + nvalid, *const S5 = S4 + nvalid;
#pragma omp parallel for schedule(dynamic, 64) num_threads(s->c.threads)
    for (long long li = leaf0; li < (long long)leaf1; li++) {
        if (li + 2 < (long long)leaf1) /* tile rows two leaves ahead: gathers, not streams */
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
            pgi__v3 q = pgi__to_view(&s->x, p[0], p[1], p[2]);
            float qq[3] = {q.x, q.y, q.z};
            for (int d = 0; d < 3; d++) {
                lo[d] = pgi_minf(lo[d], qq[d]);
                hi[d] = pgi_maxf(hi[d], qq[d]);
            }
            sx += n[0], sy += n[1], sz += n[2];
            const int lk = (vs->flags[i] & PGI_VS_LAMBERT) != 0;
            lam &= (uint32_t)lk;
            if (!(s->variant & V_DIR))
                S0[k] = lk ? p[0] : NAN, S1[k] = p[1], S2[k] = p[2]; /* directional: normals only */
            S3[k] = n[0], S4[k] = n[1], S5[k] = n[2];
        }
        memcpy(nd->lo, lo, sizeof lo);
        memcpy(nd->hi, hi, sizeof hi);
        nd->lambert = lam;
        nd->rej = -2.f, nd->acc = 2.f, nd->alpha = 4.f; /* open unless the variant uses cones */
        if ((s->variant & V_CONE) && cone_axis(nd, sx, sy, sz, (double)(s->send[li] - s->sbeg[li]))) {
            /* The largest angle is the smallest cosine: one acos a leaf. The
             * float dot products of near-unit vectors are off by < 1e-6, so
             * acos(cmin - 1e-6) bounds every normal's angle from above. */
            const float ax = nd->ax, ay = nd->ay, az = nd->az;
            float cmin = 1.f;
            int bad = 0;
            for (uint32_t k = s->sbeg[li]; k < s->send[li]; k++) {
                float c = ax * S3[k] + ay * S4[k] + az * S5[k];
                bad |= !(c == c); /* a NaN normal opens the cone */
                cmin = pgi_minf(cmin, c);
            }
            double cm = (double)cmin - 1e-6;
            cm = cm < -1.0 ? -1.0 : cm;
            if (!bad) cone_thresholds(nd, acos(cm) + 1e-5);
            else nd->rej = -2.f, nd->acc = 2.f, nd->alpha = 4.f;
        }
        soa_store(s, (size_t)li, nd);
    }
    return PGI_OK;
}

/* Inner levels bottom-up: union of child boxes; cone = mean child axis,
 * half-angle = max(angle to child axis + child half-angle) (§4.5). Open
 * child cones (alpha > pi) make the parent open. */
static void inner_bounds(cl_state *s) {
    const int L = s->L;
    for (int l = L - 1; l >= 0; l--) { /* nodes of one level are independent */
        const long long n0 = s->lvl_off[l], n1 = s->lvl_off[l + 1];
#pragma omp parallel for schedule(dynamic, 32) if (n1 - n0 >= 512) num_threads(s->c.threads)
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
}

pgi_status cl_build_hierarchy(cl_state *s, const pgi_view_samples *vs, const pgi_camera *cam, double *t_sort) {
    const int W = vs->width, H = vs->height, T = s->T;
    build_ctx bc;
    memset(&bc, 0, sizeof bc);
    pgi_status st;
    s->ntx = (W + T - 1) / T;
    s->nty = (H + T - 1) / T;
    if ((st = scan_samples(s, vs, cam, &bc)) || (st = key_layout(s, &bc)) || (st = sort_tiles(s, vs, &bc)) ||
        (st = sort_secondary(s, vs, &bc)) || (st = sort_clusters(s, vs, &bc)))
        return st;
    *t_sort = pgi__now_ms();
    if ((st = link_levels(s, &bc)) || (st = leaf_bounds(s, vs))) return st;
    inner_bounds(s);
    return PGI_OK;
}
