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
 *                    view-space octant buckets of that node, each with the sum
 *                    of its photons' directions; shading takes a bucket whose
 *                    mean direction lies above the surface; irradiance is
 *                    blurred (depth- and normal-aware) and multiplied by kd/pi.
 *                    Approximate.
 *                    Its shading and blur: est_directional.c.
 *
 * Hierarchy (rebuilt each frame, §4.1): screen tiles x view-depth slices,
 * sparse, breadth first; built in cluster_build.c.
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
 * Counters: reads = (photon, sample) pairs the radiance pass examined: the
 * list entries it reads for each sample, and the photons of the trivially
 * accepted nodes, which it takes as one sum (cum_cnt) without reading them
 * one by one; contributing = the pairs that contribute, those accepted ones
 * included, so it equals brute force's count and never exceeds reads;
 * reads_bulk = the accepted ones (of reads);
 * nodes_visited = node tests in the traversals. */
#include "cluster_internal.h"
#include "estimator_internal.h"

#include <omp.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif
/* x86-64 GCC: the top pass's traversals also come in an AVX2 build (8 children a step), picked at run time. */
#if PGI__AVX2_DISPATCH
#define CL_AVX2 1
#include <immintrin.h>
#endif

const pgi_option pgi__opt_cluster_tile = {.name = "cluster-tile",
                                          .type = PGI_OPTION_INT,
                                          .offset = offsetof(pgi_estimator_desc, cluster.tile),
                                          .min = 1,
                                          .max = 256,
                                          .def = 8,
                                          .help = "cluster edge in pixels (1..256, default 8; directional: a 64th of "
                                                  "the image's shorter side, 1..8)"};
static const pgi_option *const k_options[] = {&pgi__opt_cluster_tile, NULL};

/* d is resolved: defaults filled in, ranges checked (pgi_estimator_desc_resolve). */
pgi_status cl_create_variant(const pgi_estimator_desc *d, void **state, int variant) {
    cl_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->c.desc = *d;
    s->variant = variant;
    s->T = d->cluster.tile;
    s->dir_up = d->directional.level == PGI_DIRECTIONAL_LEAVES ? 0 : d->directional.level;
    s->blur = d->directional.blur == PGI_DIRECTIONAL_NO_BLUR ? 0 : d->directional.blur;
    *state = s;
    return PGI_OK;
}

static pgi_status cluster_create(const pgi_estimator_desc *d, void **st) { return cl_create_variant(d, st, 0); }
static pgi_status cone_create(const pgi_estimator_desc *d, void **st) { return cl_create_variant(d, st, V_CONE); }
static pgi_status trivial_create(const pgi_estimator_desc *d, void **st) {
    return cl_create_variant(d, st, V_CONE | V_TRIVIAL);
}

/* ------------------------------------------------------------ splat */

typedef struct sink {
    uint32_t *cnt;  /* per-node output counts (top: this chunk's row) */
    float *flux;    /* trivial flux (top: this chunk's row; subtree: node_flux) */
    uint32_t *tcnt; /* trivial counts, same indexing as flux */
    float *buckets;
    uint32_t *out; /* recorded outputs: (node, photon) pairs */
    size_t nout, capout;
    uint64_t visited, deposits;
    int oom;
} sink;

typedef struct {
    pgi__v3 c; /* view-space centre */
    float wx, wy, wz, fr, fg, fb;
    float rr2, re2; /* (r + slack)^2: may touch; (r - slack)^2: encloses */
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
        pgi__v3 w = v3(q->wx, q->wy, q->wz);
        float vx = v3_dot(w, s->x.right), vy = v3_dot(w, s->x.up), vz = v3_dot(w, s->x.fwd);
        q->oct = (vx < 0.f) | (vy < 0.f) << 1 | (vz < 0.f) << 2;
    }
    q->j = (uint32_t)j;
}

/* Culling test of the children [f, f + nc) of one node, branch-free over
 * structure-of-arrays boxes and cones (the compiler vectorises it): bit k of
 * the result is set when child f + k may hold a sample the photon reaches.
 * With `encl` (the list variants), bit k of *encl is set when the sphere
 * encloses child f + k (far2 < re2, decide's test, the same expressions), and
 * of *triv when it is also trivially accepted there (V_TRIVIAL: dot(axis, w) >
 * cacc, +inf unless all-Lambertian): decide then needs no node record. */
static inline __attribute__((always_inline)) uint32_t child_hits(const cl_state *s, const int variant, uint32_t f,
                                                                 int nc, const photon_q *q, uint32_t *encl,
                                                                 uint32_t *triv) {
    const float *x0 = s->sx0 + f, *y0 = s->sy0 + f, *z0 = s->sz0 + f, *x1 = s->sx1 + f, *y1 = s->sy1 + f,
                *z1 = s->sz1 + f;
    uint32_t m = 0, me = 0, mt = 0;
#ifdef __SSE2__
    /* 4 children a step; the SoA arrays are padded, extra lanes are masked off. */
    const __m128 cx = _mm_set1_ps(q->c.x), cy = _mm_set1_ps(q->c.y), cz = _mm_set1_ps(q->c.z);
    const __m128 rr2 = _mm_set1_ps(q->rr2), re2 = _mm_set1_ps(q->re2), zero = _mm_setzero_ps();
    const __m128 wx = _mm_set1_ps(q->wx), wy = _mm_set1_ps(q->wy), wz = _mm_set1_ps(q->wz);
    for (int k = 0; k < nc; k += 4) {
        const __m128 lx = _mm_loadu_ps(x0 + k), ly = _mm_loadu_ps(y0 + k), lz = _mm_loadu_ps(z0 + k),
                     hx = _mm_loadu_ps(x1 + k), hy = _mm_loadu_ps(y1 + k), hz = _mm_loadu_ps(z1 + k);
        __m128 ex = _mm_max_ps(_mm_max_ps(_mm_sub_ps(lx, cx), _mm_sub_ps(cx, hx)), zero);
        __m128 ey = _mm_max_ps(_mm_max_ps(_mm_sub_ps(ly, cy), _mm_sub_ps(cy, hy)), zero);
        __m128 ez = _mm_max_ps(_mm_max_ps(_mm_sub_ps(lz, cz), _mm_sub_ps(cz, hz)), zero);
        __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ex, ex), _mm_mul_ps(ey, ey)), _mm_mul_ps(ez, ez));
        __m128 hit = _mm_cmple_ps(d2, rr2), dw = zero;
        if (variant & V_CONE) {
            dw = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_loadu_ps(s->cax + f + k), wx),
                                       _mm_mul_ps(_mm_loadu_ps(s->cay + f + k), wy)),
                            _mm_mul_ps(_mm_loadu_ps(s->caz + f + k), wz));
            hit = _mm_and_ps(hit, _mm_cmpge_ps(dw, _mm_loadu_ps(s->crej + f + k))); /* §4.5 */
        }
        m |= (uint32_t)_mm_movemask_ps(hit) << k;
        if (encl) {
            /* far2: max(c - lo, hi - c) per axis (_mm_max_ps(a, b) is pgi_maxf's a > b ? a : b) */
            __m128 fx = _mm_max_ps(_mm_sub_ps(cx, lx), _mm_sub_ps(hx, cx));
            __m128 fy = _mm_max_ps(_mm_sub_ps(cy, ly), _mm_sub_ps(hy, cy));
            __m128 fz = _mm_max_ps(_mm_sub_ps(cz, lz), _mm_sub_ps(hz, cz));
            __m128 f2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(fx, fx), _mm_mul_ps(fy, fy)), _mm_mul_ps(fz, fz));
            __m128 in = _mm_cmplt_ps(f2, re2);
            me |= (uint32_t)_mm_movemask_ps(in) << k;
            if (variant & V_TRIVIAL)
                mt |= (uint32_t)_mm_movemask_ps(_mm_and_ps(in, _mm_cmpgt_ps(dw, _mm_loadu_ps(s->cacc + f + k)))) << k;
        }
    }
    if (nc < 32) m &= (1u << nc) - 1u;
#else
    const float cx = q->c.x, cy = q->c.y, cz = q->c.z, rr2 = q->rr2;
    for (int k = 0; k < nc; k++) {
        float ex = pgi_maxf(pgi_maxf(x0[k] - cx, cx - x1[k]), 0.f);
        float ey = pgi_maxf(pgi_maxf(y0[k] - cy, cy - y1[k]), 0.f);
        float ez = pgi_maxf(pgi_maxf(z0[k] - cz, cz - z1[k]), 0.f);
        uint32_t hit = ex * ex + ey * ey + ez * ez <= rr2;
        float dw = 0.f;
        if (variant & V_CONE) {
            dw = s->cax[f + k] * q->wx + s->cay[f + k] * q->wy + s->caz[f + k] * q->wz;
            hit &= dw >= s->crej[f + k]; /* else below every surface in the child (§4.5) */
        }
        m |= hit << k;
        if (encl) {
            float fx = pgi_maxf(cx - x0[k], x1[k] - cx), fy = pgi_maxf(cy - y0[k], y1[k] - cy),
                  fz = pgi_maxf(cz - z0[k], z1[k] - cz);
            uint32_t in = fx * fx + fy * fy + fz * fz < q->re2;
            me |= in << k;
            if (variant & V_TRIVIAL) mt |= (uint32_t)(in && dw > s->cacc[f + k]) << k;
        }
    }
#endif
    if (encl) *encl = me & m, *triv = mt & m;
    return m;
}

#ifdef CL_AVX2
/* child_hits, 8 children a step: the same expressions lane by lane (no FMA), so the same bits.
 * Not always_inline: only the AVX2 traversals may inline it. */
__attribute__((target("avx2"))) static inline uint32_t child_hits8(const cl_state *s, const int variant, uint32_t f,
                                                                   int nc, const photon_q *q, uint32_t *encl,
                                                                   uint32_t *triv) {
    const float *x0 = s->sx0 + f, *y0 = s->sy0 + f, *z0 = s->sz0 + f, *x1 = s->sx1 + f, *y1 = s->sy1 + f,
                *z1 = s->sz1 + f;
    uint32_t m = 0, me = 0, mt = 0;
    const __m256 cx = _mm256_set1_ps(q->c.x), cy = _mm256_set1_ps(q->c.y), cz = _mm256_set1_ps(q->c.z);
    const __m256 rr2 = _mm256_set1_ps(q->rr2), re2 = _mm256_set1_ps(q->re2), zero = _mm256_setzero_ps();
    const __m256 wx = _mm256_set1_ps(q->wx), wy = _mm256_set1_ps(q->wy), wz = _mm256_set1_ps(q->wz);
    for (int k = 0; k < nc; k += 8) { /* the SoA padding (16) covers the lanes past nc */
        const __m256 lx = _mm256_loadu_ps(x0 + k), ly = _mm256_loadu_ps(y0 + k), lz = _mm256_loadu_ps(z0 + k),
                     hx = _mm256_loadu_ps(x1 + k), hy = _mm256_loadu_ps(y1 + k), hz = _mm256_loadu_ps(z1 + k);
        __m256 ex = _mm256_max_ps(_mm256_max_ps(_mm256_sub_ps(lx, cx), _mm256_sub_ps(cx, hx)), zero);
        __m256 ey = _mm256_max_ps(_mm256_max_ps(_mm256_sub_ps(ly, cy), _mm256_sub_ps(cy, hy)), zero);
        __m256 ez = _mm256_max_ps(_mm256_max_ps(_mm256_sub_ps(lz, cz), _mm256_sub_ps(cz, hz)), zero);
        __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ex, ex), _mm256_mul_ps(ey, ey)), _mm256_mul_ps(ez, ez));
        __m256 hit = _mm256_cmp_ps(d2, rr2, _CMP_LE_OS), dw = zero;
        if (variant & V_CONE) {
            dw = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_loadu_ps(s->cax + f + k), wx),
                                             _mm256_mul_ps(_mm256_loadu_ps(s->cay + f + k), wy)),
                               _mm256_mul_ps(_mm256_loadu_ps(s->caz + f + k), wz));
            hit = _mm256_and_ps(hit, _mm256_cmp_ps(dw, _mm256_loadu_ps(s->crej + f + k), _CMP_GE_OS));
        }
        m |= (uint32_t)_mm256_movemask_ps(hit) << k;
        if (encl) {
            __m256 fx = _mm256_max_ps(_mm256_sub_ps(cx, lx), _mm256_sub_ps(hx, cx));
            __m256 fy = _mm256_max_ps(_mm256_sub_ps(cy, ly), _mm256_sub_ps(hy, cy));
            __m256 fz = _mm256_max_ps(_mm256_sub_ps(cz, lz), _mm256_sub_ps(hz, cz));
            __m256 f2 =
                _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(fx, fx), _mm256_mul_ps(fy, fy)), _mm256_mul_ps(fz, fz));
            __m256 in = _mm256_cmp_ps(f2, re2, _CMP_LT_OS);
            me |= (uint32_t)_mm256_movemask_ps(in) << k;
            if (variant & V_TRIVIAL)
                mt |= (uint32_t)_mm256_movemask_ps(
                          _mm256_and_ps(in, _mm256_cmp_ps(dw, _mm256_loadu_ps(s->cacc + f + k), _CMP_GT_OS)))
                      << k;
        }
    }
    if (nc < 32) m &= (1u << nc) - 1u;
    if (encl) *encl = me & m, *triv = mt & m;
    return m;
}
#endif

/* child_hits, 8 at a time in the AVX2 traversals (wide). */
static inline __attribute__((always_inline)) uint32_t child_hits_w(const cl_state *s, const int variant, const int wide,
                                                                   uint32_t f, int nc, const photon_q *q,
                                                                   uint32_t *encl, uint32_t *triv) {
#ifdef CL_AVX2
    if (wide) return child_hits8(s, variant, f, nc, q, encl, triv);
#else
    (void)wide;
#endif
    return child_hits(s, variant, f, nc, q, encl, triv);
}

/* Makes room for n more records in the sink's growable array; 0 when out of memory. */
static inline int reserve(sink *k, size_t n) {
    if (k->nout + n > k->capout) {
        size_t nc = k->capout ? 2 * k->capout : 4096;
        while (nc < k->nout + n) nc *= 2;
        uint32_t *p = realloc(k->out, 2 * nc * sizeof *p);
        if (!p) {
            k->oom = 1;
            return 0;
        }
        k->out = p;
        k->capout = nc;
    }
    return 1;
}

/* Records one traversal output (node, photon) in the sink's growable array. */
static inline void emit(sink *k, uint32_t node, uint32_t j) {
    if (k->nout == k->capout && !reserve(k, 1)) return;
    k->out[2 * k->nout] = node;
    k->out[2 * k->nout + 1] = j;
    k->nout++;
}

/* Squared distance from c to the farthest corner of a node's box: the node
 * lies inside a sphere around c when this is below its radius squared. */
static inline float far2(const cnode *nd, pgi__v3 c) {
    float f2 = 0.f, e;
    e = pgi_maxf(c.x - nd->lo[0], nd->hi[0] - c.x);
    f2 += e * e;
    e = pgi_maxf(c.y - nd->lo[1], nd->hi[1] - c.y);
    f2 += e * e;
    e = pgi_maxf(c.z - nd->lo[2], nd->hi[2] - c.z);
    f2 += e * e;
    return f2;
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
            dep = far2(nd, q->c) < q->re2;
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
        /* the bucket: flux, and the directions summed weighted by flux (r + g + b) */
        float *b = k->buckets + ((size_t)(ni - s->lvl_off[s->D]) * 8 + (size_t)q->oct) * PGI__DIR_BUCKET;
        const float lw = q->fr + q->fg + q->fb;
        b[0] += q->fr, b[1] += q->fg, b[2] += q->fb;
        b[3] += lw * q->wx, b[4] += lw * q->wy, b[5] += lw * q->wz;
        k->deposits++;
        return 0;
    }
    {
        const cnode *nd = &s->nodes[ni];
        if (far2(nd, q->c) < q->re2) {
            if ((variant & V_TRIVIAL) && nd->lambert && nd->ax * q->wx + nd->ay * q->wy + nd->az * q->wz > nd->acc) {
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
static inline __attribute__((always_inline)) void walk(const cl_state *s, const int variant, const int wide,
                                                       const int top, uint32_t start, int start_level,
                                                       const photon_q *q, sink *k) {
    if (!decide(s, variant, top, start, start_level, q, k)) return;
    /* The list variants take decide's enclosure and trivial-accept tests of the children from
     * child_hits (SoA, 4 at a time) instead of each child's node record; directional's buckets
     * keep decide. */
    const int masks = !(variant & V_DIR);
    struct {
        uint32_t mask, first, encl, triv;
    } stk[MAX_LEVELS + 2];
    int sp = 0;
    {
        const cnode *nd = &s->nodes[start];
        int nc = __builtin_popcount(nd->mask);
        k->visited += (uint64_t)nc;
        /* the top pass's children at J become jobs whatever the masks say */
        stk[0].mask = masks && !(top && start_level + 1 == s->J)
                          ? child_hits_w(s, variant, wide, nd->first, nc, q, &stk[0].encl, &stk[0].triv)
                          : child_hits_w(s, variant, wide, nd->first, nc, q, NULL, NULL);
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
        const uint32_t bit = m & (0u - m);
        uint32_t ch = stk[sp - 1].first + (uint32_t)__builtin_ctz(m);
        const int level = start_level + sp;
        int down = 0;
        if (!masks) {
            down = decide(s, variant, top, ch, level, q, k);
        } else if (top && level == s->J) { /* decide's job at J */
            k->cnt[ch]++;
            emit(k, ch, q->j);
        } else if ((variant & V_TRIVIAL) && (stk[sp - 1].triv & bit)) {
            /* encloses the node and above every surface in it (§4.6) */
            float *f = k->flux + 3 * (size_t)ch;
            f[0] += q->fr, f[1] += q->fg, f[2] += q->fb;
            k->tcnt[ch]++;
        } else if ((stk[sp - 1].encl & bit) || level == s->L) { /* list: enclosed node or leaf */
            k->cnt[ch]++;
            emit(k, ch, q->j);
        } else {
            down = 1;
        }
        if (down) {
            const cnode *nd = &s->nodes[ch];
            int nc = __builtin_popcount(nd->mask);
            k->visited += (uint64_t)nc;
            stk[sp].mask = masks && !(top && level + 1 == s->J)
                               ? child_hits_w(s, variant, wide, nd->first, nc, q, &stk[sp].encl, &stk[sp].triv)
                               : child_hits_w(s, variant, wide, nd->first, nc, q, NULL, NULL);
            stk[sp].first = nd->first;
            sp++;
        }
    }
}

/* The subtree pass's walk for the list variants: walk's decisions, but the children of a node
 * are settled together from child_hits' masks (trivial flux, then list records, then the
 * children to descend into, the only ones stacked): leaves are never stacked or popped one by
 * one. Within one photon the order of its outputs is free: a list or an accumulator only sees
 * the order of the photons (jobs), which is unchanged. (In the top pass it gained nothing.) */
static inline __attribute__((always_inline)) void walk_sub(const cl_state *s, const int variant, const int wide,
                                                           uint32_t start, const photon_q *q, sink *k) {
    const int start_level = s->J;
    if (!decide(s, variant, 0, start, start_level, q, k)) return;
    const int L = s->L;
    struct {
        uint32_t mask, first;
    } stk[MAX_LEVELS + 2];
    int sp = 0, level = start_level; /* of node ni */
    uint32_t ni = start;
    for (;;) {
        const cnode *nd = &s->nodes[ni];
        const int nc = __builtin_popcount(nd->mask);
        const uint32_t f = nd->first;
        k->visited += (uint64_t)nc;
        uint32_t encl, triv;
        const uint32_t m = child_hits_w(s, variant, wide, f, nc, q, &encl, &triv);
        if (variant & V_TRIVIAL) /* enclosed and above every surface in it (§4.6); triv is in encl */
            for (uint32_t b = triv; b; b &= b - 1) {
                const uint32_t ch = f + (uint32_t)__builtin_ctz(b);
                float *fl = k->flux + 3 * (size_t)ch;
                fl[0] += q->fr, fl[1] += q->fg, fl[2] += q->fb;
                k->tcnt[ch]++;
            }
        const int leaves = level + 1 == L;
        uint32_t e = (leaves ? m : encl) & ~triv; /* lists: enclosed nodes, intersected leaves */
        if (e && reserve(k, 32))
            for (; e; e &= e - 1) {
                const uint32_t ch = f + (uint32_t)__builtin_ctz(e);
                k->cnt[ch]++;
                k->out[2 * k->nout] = ch;
                k->out[2 * k->nout + 1] = q->j;
                k->nout++;
            }
        if (!leaves && (m & ~encl)) {
            stk[sp].mask = m & ~encl;
            stk[sp].first = f;
            sp++;
        }
        while (sp > 0 && !stk[sp - 1].mask) sp--;
        if (!sp) return;
        const uint32_t d = stk[sp - 1].mask;
        stk[sp - 1].mask = d & (d - 1);
        ni = stk[sp - 1].first + (uint32_t)__builtin_ctz(d);
        level = start_level + sp;
    }
}


/* Top pass over the photons [j0, j1): walks each from the root (pk is filled later). perm[j]
 * gets the first node photon j recorded (none: nkey), counted in h (splat_impl groups pk by it;
 * counted here, not in a pass over the records afterwards). */
static inline __attribute__((always_inline)) void top_photons_impl(cl_state *s, const pgi_photons *ph,
                                                                   const int variant, const int wide, size_t j0,
                                                                   size_t j1, sink *k, uint32_t *h, uint32_t nkey) {
    for (size_t j = j0; j < j1; j++) {
        photon_q q;
        pgi__packed_photon p;
        pgi__pack_photon(ph, j, &p); /* into pk once its position is known (splat_impl) */
        load_photon(s, &p, j, &q);
        k->visited++;
        const size_t u = k->nout;
        if (child_hits(s, variant, 0, 1, &q, NULL, NULL) & 1u) walk(s, variant, wide, 1, 0, 0, &q, k); /* the root */
        const uint32_t key = k->nout > u ? k->out[2 * u] : nkey;
        s->perm[j] = key;
        h[key]++;
    }
}

/* The top pass's traversals, one function per variant, narrow (SSE2) and, where the CPU has
 * it, wide (AVX2: child_hits8): 10 % off the top pass (the OpenMP body takes the target of
 * splat_impl, so the wide code needs a function of its own). */
#define CL_BY_VARIANT(call)                                                                                            \
    switch (s->variant) {                                                                                              \
    case 0: call(0); break;                                                                                            \
    case V_CONE: call(V_CONE); break;                                                                                  \
    case V_CONE | V_TRIVIAL: call(V_CONE | V_TRIVIAL); break;                                                          \
    default: call(V_DIR); break;                                                                                       \
    }
#define CL_TOP_N(v) top_photons_impl(s, ph, v, 0, j0, j1, k, h, nkey)
#define CL_TOP_W(v) top_photons_impl(s, ph, v, 1, j0, j1, k, h, nkey)
static void top_photons_n(cl_state *s, const pgi_photons *ph, size_t j0, size_t j1, sink *k, uint32_t *h,
                          uint32_t nkey) {
    CL_BY_VARIANT(CL_TOP_N)
}
#ifdef CL_AVX2
__attribute__((target("avx2,popcnt"))) static void top_photons_w(cl_state *s, const pgi_photons *ph, size_t j0,
                                                                 size_t j1, sink *k, uint32_t *h, uint32_t nkey) {
    CL_BY_VARIANT(CL_TOP_W)
}
#else
#define top_photons_w top_photons_n
#endif

/* How many jobs ahead the subtree pass prefetches their packed photons. */
#define PREFETCH_JOBS 8

/* Subtree pass, task t: the jobs of job-level node nabove + t. */
static inline __attribute__((always_inline)) void subtree_task_impl(cl_state *s, const int variant, const int wide,
                                                                    uint32_t t, sink *k) {
    const uint32_t node = s->lvl_off[s->J] + t, u1 = s->job_start[t + 1];
    for (uint32_t u = s->job_start[t]; u < u1; u++) {
        /* The jobs' photons are sparse in pk: without the prefetch a third of this pass
         * waited on their first load. 36-byte records: two lines. */
        if (u + PREFETCH_JOBS < u1) {
            const char *p = (const char *)&s->pk[s->jobs[u + PREFETCH_JOBS]];
            __builtin_prefetch(p);
            __builtin_prefetch(p + sizeof(pgi__packed_photon) - 1);
        }
        photon_q q;
        load_photon(s, &s->pk[s->jobs[u]], s->jobs[u], &q);
        if (variant & V_DIR) walk(s, variant, wide, 0, node, s->J, &q, k);
        else walk_sub(s, variant, wide, node, &q, k);
    }
}

/* The subtree pass's tasks, narrow and wide as the top pass's traversals, dispatched once a
 * task (target_clones on the walk itself was slower: every call went through the ifunc); the
 * wide build also has popcnt (a libgcc call in the narrow one). With walk_sub, -21 % CPU time
 * of the count pass (Sibenik 1280x720, 200k photons, one thread: 40.8 -> 32.3 ms). */
#define CL_SUB_N(v) subtree_task_impl(s, v, 0, t, k)
#define CL_SUB_W(v) subtree_task_impl(s, v, 1, t, k)
static void subtree_task_n(cl_state *s, uint32_t t, sink *k) { CL_BY_VARIANT(CL_SUB_N) }
#ifdef CL_AVX2
__attribute__((target("avx2,popcnt"))) static void subtree_task_w(cl_state *s, uint32_t t, sink *k) {
    CL_BY_VARIANT(CL_SUB_W)
}
#else
#define subtree_task_w subtree_task_n
#endif

/* The end of top chunk ci of n photons. */
static inline size_t chunk_end(size_t ci, size_t chunk, size_t n) {
    return (ci + 1) * chunk < n ? (ci + 1) * chunk : n;
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
    const int nthr = s->c.threads;
#ifdef CL_AVX2
    const int wide = pgi__cpu_avx2(); /* the wide build is also compiled for popcnt */
#else
    const int wide = 0;
#endif
    pgi_status st;
    if ((st = ENSURE(top_cnt, nch * ntop + 1, uint32_t)) || (st = ENSURE(top_flux, nch * nabove * 3 + 1, float)) ||
        (st = ENSURE(top_tcnt, nch * nabove + 1, uint32_t)) || (st = ENSURE(job_start, (size_t)nJ + 1, uint32_t)) ||
        (st = ENSURE(node_start, nn + 1, uint32_t)) || (st = ENSURE(node_cnt, nn + 1, uint32_t)) ||
        (st = ENSURE(node_flux, 3 * nn + 1, float)) || (st = ENSURE(node_tcnt, nn + 1, uint32_t)) ||
        (st = ENSURE(cursor, nn + 1, uint32_t)) || (st = ENSURE(task_rec, 3 * (size_t)nJ + 1, uint32_t)) ||
        (st = grow_outs(s, (int)nch > nthr ? (int)nch : nthr)))
        return st;
    const size_t nD = (variant & V_DIR) ? nn - s->lvl_off[s->D] : 0; /* nodes with buckets */
    if ((variant & V_DIR) && (st = ENSURE(buckets, nD * 8 * PGI__DIR_BUCKET + 1, float))) return st;
    const size_t nkeys = (size_t)ntop + 1; /* the first-record keys grouping pk: nodes up to J, none */
    if ((st = ENSURE(pk, n + 1, pgi__packed_photon)) || (st = ENSURE(perm, n + 1, uint32_t)) ||
        (st = ENSURE(perm_hist, nch * nkeys + 1, uint32_t)))
        return st;
    s->npacked = n;
    uint64_t visited = 0, deposits = 0;
    int oom = 0;
    /* Top pass, counting traversal: lists of nodes above J, jobs at J, trivial
     * flux above J, per fixed photon chunk; the outputs are recorded so that
     * the fill pass replays them instead of traversing again. */
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : visited) reduction(| : oom) num_threads(s->c.threads)
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
        size_t j1 = chunk_end((size_t)ci, chunk, n);
        uint32_t *h = s->perm_hist + (size_t)ci * nkeys;
        memset(h, 0, nkeys * sizeof *h);
        if (wide) top_photons_w(s, ph, (size_t)ci * chunk, j1, k, h, ntop);
        else top_photons_n(s, ph, (size_t)ci * chunk, j1, k, h, ntop);
        visited += k->visited;
        oom |= k->oom;
    }
    if (oom) return pgi__fail(PGI_ERR_OOM, "cluster: out of memory for the traversal records");
    /* Where each photon goes in pk: grouped by the first node its top walk recorded (a job-level
     * node, in key order, or a list node above; photons with no record last), photon order
     * within a group (a counting sort over the fixed chunks). The jobs of one subtree and the
     * lists of its leaves then read few, nearby records; in photon order pk was a random
     * scatter, and those loads were a third of the subtree and radiance passes. Lists and jobs
     * hold pk positions but stay in photon order, so every sum is unchanged. The top pass
     * found each photon's key and counted the keys per chunk (perm, perm_hist). */
    {
        uint32_t pos = 0;
        for (size_t key = 0; key < nkeys; key++)
            for (size_t ci = 0; ci < nch; ci++) {
                uint32_t *h = s->perm_hist + ci * nkeys + key, v = *h;
                *h = pos;
                pos += v;
            }
    }
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
    for (long long ci = 0; ci < (long long)nch; ci++) {
        uint32_t *h = s->perm_hist + (size_t)ci * nkeys;
        size_t j1 = chunk_end((size_t)ci, chunk, n);
        for (size_t j = (size_t)ci * chunk; j < j1; j++) {
            s->perm[j] = h[s->perm[j]]++;
            pgi__pack_photon(ph, j, &s->pk[s->perm[j]]);
        }
    }
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
    if ((st = ENSURE(jobs, js + 1, uint32_t)) || (st = ENSURE(top_ids, sum + 1, uint32_t))) return st;
        /* Top fill: replay the records (jobs grouped by node, photon order). */
#pragma omp parallel for schedule(dynamic, 1) num_threads(s->c.threads)
    for (long long ci = 0; ci < (long long)nch; ci++) {
        const sink *k = &s->outs[ci];
        uint32_t *off = s->top_cnt + (size_t)ci * ntop;
        for (size_t u = 0; u < k->nout; u++) {
            uint32_t nd = k->out[2 * u], j = s->perm[k->out[2 * u + 1]];
            if (nd < nabove) {
                s->top_ids[off[nd]++] = j;
            } else { /* the subtree pass reads pk[j], mostly increasing within a job: no copy of the
                      * record (it cost 36 of the 40 bytes a job entry took: 90 MB at 1M photons) */
                s->jobs[off[nd]++] = j;
            }
        }
    }
    /* Trivial flux above J: chunks summed in chunk order. */
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
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
    if (variant & V_DIR) memset(s->buckets, 0, nD * 8 * PGI__DIR_BUCKET * sizeof(float));
    tm[0] = pgi__now_ms();
    /* Subtree pass, counting traversal: one task per job-level node owns its
     * whole subtree, so counts and accumulators need no atomics and sum in job
     * (photon) order. Each thread records its tasks' outputs in its own array. */
#pragma omp parallel reduction(+ : visited, deposits) reduction(| : oom) num_threads(s->c.threads)
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
            if (wide) subtree_task_w(s, (uint32_t)t, k);
            else subtree_task_n(s, (uint32_t)t, k);
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
    if ((st = ENSURE(lists, sum + 1, uint32_t))) return st;
    memcpy(s->lists, s->top_ids, s->ntop_list * sizeof(uint32_t));
    for (size_t nd = nabove; nd < nn; nd++) s->cursor[nd] = s->node_start[nd];
        /* Subtree fill: replay each task's records into its own nodes' lists. */
#pragma omp parallel for schedule(dynamic, 4) num_threads(s->c.threads)
    for (long long t = 0; t < (long long)nJ; t++) {
        const sink *k = &s->outs[s->task_rec[3 * t]];
        for (uint32_t u = s->task_rec[3 * t + 1]; u < s->task_rec[3 * t + 2]; u++)
            s->lists[s->cursor[k->out[2 * u]]++] = k->out[2 * u + 1];
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

pgi_status cl_build(void *state, const pgi_estimate_args *a) {
    cl_state *s = state;
    pgi__est_frame(&s->c, a);
    memset(&s->c.st, 0, sizeof s->c.st);
    const pgi_view_samples *vs = a->samples;
    const pgi_camera *cam = a->camera;
    if (vs->width != cam->width || vs->height != cam->height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: view samples are %dx%d but the camera is %dx%d",
                         s->variant & V_DIR ? "directional" : "cluster", vs->width, vs->height, cam->width,
                         cam->height);
    s->W = vs->width;
    s->H = vs->height;
    s->T = pgi__cluster_tile(s->c.desc.cluster.tile, s->W, s->H);
    s->r = s->c.radius;
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

/* 8 lanes: 8 consecutive samples of a block; an AVX2 register (the default clone uses two SSE ones). */
typedef float cl_v8f __attribute__((vector_size(32)));
typedef int32_t cl_v8i __attribute__((vector_size(32)));
#define CL_SPLAT(f) ((cl_v8f){(f), (f), (f), (f), (f), (f), (f), (f)})

/* One block of nbv samples (a multiple of 8; sorted-sample arrays) against the
 * lists of the np path nodes (path[np - 1] is the root), into the block's
 * local sums. Sample-major, 8 samples a step: their sums stay in registers
 * over every photon of the path (photon-major, each photon stored and reloaded
 * them, a store-to-load chain per photon). The loop over the lanes is
 * branch-free; it makes exactly pgi__gather's decisions (same expressions; no
 * FMA contraction) and adds each sample's contributing photons in path order
 * (root first), then list order; a rejected photon adds +0 (its flux masked
 * off: a sum that starts at +0 is never -0, so no bit changes), so the sums
 * are those of gather. An inner node lists only photons whose sphere encloses it (far corner
 * within r - slack, as for a trivial accept), so every sample under it passes d^2 < r^2 in float:
 * for the lists of the ancestors (all of the path but path[0] when leaf_list) the lanes test only
 * dot(n, w) > 0 (and Lambertian: NaN x), 9 of the 20 operations a photon; the same masks. */
PGI__HOT_LOOP
static void rad_block(const pgi__packed_photon *restrict pk, const uint32_t *restrict lists,
                      const uint32_t *restrict node_start, const uint32_t *restrict path, int np, int leaf_list,
                      int nbv, const float *restrict bx, const float *restrict by, const float *restrict bz,
                      const float *restrict bnx, const float *restrict bny, const float *restrict bnz,
                      float *restrict ar, float *restrict ag, float *restrict ab, uint32_t *restrict an, float r2) {
    for (int t = 0; t < nbv; t += 8) {
        cl_v8f x, y, z, nx, ny, nz;
        memcpy(&x, bx + t, sizeof x), memcpy(&y, by + t, sizeof y), memcpy(&z, bz + t, sizeof z);
        memcpy(&nx, bnx + t, sizeof nx), memcpy(&ny, bny + t, sizeof ny), memcpy(&nz, bnz + t, sizeof nz);
        cl_v8f sr = {0.f}, sg = {0.f}, sb = {0.f};
        cl_v8i sn = {0};
        const cl_v8i lam = x == x; /* Lambertian lanes (the others are gathered afterwards) */
        const int p1 = leaf_list ? 1 : 0;
        for (int p = np - 1; p >= p1; p--) { /* enclosing photons: the normal test only */
            const uint32_t *li = lists + node_start[path[p]];
            const uint32_t m = node_start[path[p] + 1] - node_start[path[p]];
            for (uint32_t e = 0; e < m; e++) {
                if (t == 0 && e + 8 < m) __builtin_prefetch(pk + li[e + 8]);
                const pgi__packed_photon *q = pk + li[e];
                const cl_v8f c = nx * q->dx + ny * q->dy + nz * q->dz;
                const cl_v8i ok = lam & (c > 0.f);
                sr += (cl_v8f)(ok & (cl_v8i)CL_SPLAT(q->fr));
                sg += (cl_v8f)(ok & (cl_v8i)CL_SPLAT(q->fg));
                sb += (cl_v8f)(ok & (cl_v8i)CL_SPLAT(q->fb));
                sn -= ok;
            }
        }
        if (leaf_list) {
            const uint32_t *li = lists + node_start[path[0]];
            const uint32_t m = node_start[path[0] + 1] - node_start[path[0]];
            for (uint32_t e = 0; e < m; e++) {
                if (t == 0 && e + 8 < m) __builtin_prefetch(pk + li[e + 8]);
                const pgi__packed_photon *q = pk + li[e];
                const cl_v8f ex = q->px - x, ey = q->py - y, ez = q->pz - z;
                const cl_v8f d2 = ex * ex + ey * ey + ez * ez;
                const cl_v8f c = nx * q->dx + ny * q->dy + nz * q->dz;
                const cl_v8i ok = (d2 < r2) & (c > 0.f); /* lanes: -1 or 0 */
                /* flux or +0.f: what 1.f * flux or 0.f * flux (finite flux) adds to a sum that
                 * starts at +0.f and so is never -0.f (x + y is -0.f only for two -0.f); a mask
                 * is one operation where the multiply by 1.f or 0.f was two (-1 ms CPU) */
                sr += (cl_v8f)(ok & (cl_v8i)CL_SPLAT(q->fr));
                sg += (cl_v8f)(ok & (cl_v8i)CL_SPLAT(q->fg));
                sb += (cl_v8f)(ok & (cl_v8i)CL_SPLAT(q->fb));
                sn -= ok;
            }
        }
        memcpy(ar + t, &sr, sizeof sr), memcpy(ag + t, &sg, sizeof sg), memcpy(ab + t, &sb, sizeof sb);
        memcpy(an + t, &sn, sizeof sn);
    }
}

static pgi_status cl_estimate(void *state, const pgi_estimate_args *a) {
    cl_state *s = state;
    pgi__est_frame(&s->c, a);
    double t0 = pgi__now_ms();
    const pgi_view_samples *vs = a->samples;
    if (vs->width != s->W || vs->height != s->H)
        return pgi__fail(PGI_ERR_INVALID_ARG, "cluster: estimate called with a frame size other than build's");
    const size_t npix = vs->count;
    uint64_t reads = 0, contrib = 0, bulk = 0;
    pgi_status st;
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
    for (long long ii = 0; ii < (long long)npix; ii++)
        if (!(vs->flags[ii] & PGI_VS_VALID)) a->out_rgb[3 * ii] = a->out_rgb[3 * ii + 1] = a->out_rgb[3 * ii + 2] = 0.f;
    const size_t nn = s->nnodes;
    if (!s->splatted) {
        /* no photons: every valid sample gets zero */
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
        for (long long ii = 0; ii < (long long)npix; ii++)
            a->out_rgb[3 * ii] = a->out_rgb[3 * ii + 1] = a->out_rgb[3 * ii + 2] = 0.f;
    } else {
        if ((st = ENSURE(cum_flux, 3 * nn + 1, float)) || (st = ENSURE(cum_cnt, nn + 1, uint32_t))) return st;
        /* trivially accepted flux of a node and all its ancestors, top-down */
        for (int l = 0; l <= s->L; l++) { /* small levels: no fork/join (barriers cost on a busy machine) */
#pragma omp parallel for schedule(static) if (s->lvl_off[l + 1] - s->lvl_off[l] >= 65536) num_threads(s->c.threads)
            for (long long ni = s->lvl_off[l]; ni < (long long)s->lvl_off[l + 1]; ni++) {
                uint32_t p = s->nodes[ni].parent;
                for (int d = 0; d < 3; d++)
                    s->cum_flux[3 * ni + d] = s->node_flux[3 * ni + d] + (l ? s->cum_flux[3 * (size_t)p + d] : 0.f);
                s->cum_cnt[ni] = s->node_tcnt[ni] + (l ? s->cum_cnt[p] : 0u);
            }
        }
        const float r2 = s->r * s->r;
        const uint32_t leaf0 = s->lvl_off[s->L], leaf1 = s->lvl_off[s->L + 1];
#pragma omp parallel for schedule(dynamic, 8) reduction(+ : reads, contrib, bulk) num_threads(s->c.threads)
        for (long long li = leaf0; li < (long long)leaf1; li++) {
            if (pgi__est_stop(&s->c)) continue;
            if (li + 1 < (long long)leaf1) /* the next leaf's kd and output rows */
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
            /* Blocks of up to B sorted samples, 8 at a time against every
             * photon of the path (rad_block): the same decisions and the same
             * summation order as pgi__gather (root to leaf, photon order).
             * Non-Lambertian samples are masked out (NaN position) and
             * gathered with pgi__gather_push (gather.h: pgi__gather's sums, the
             * lobe evaluated a batch of contributing photons at a time). */
            enum { B = 64 };
            float ar[B], ag[B], ab[B];
            uint32_t an[B];
            pgi__vs v; /* the last non-Lambertian sample: its lobe serves the next one of the same material */
            int have_lobe = 0;
            const size_t nv = s->nvalid;
            const float *const bx = s->sam, *const by = bx + nv, *const bz = by + nv, *const bnx = bz + nv,
                               *const bny = bnx + nv, *const bnz = bny + nv;
            for (uint32_t k0 = s->sbeg[li]; k0 < s->send[li]; k0 += B) {
                const int nb = (int)(s->send[li] - k0 < B ? s->send[li] - k0 : B);
                /* whole vectors: lanes past nb read the next samples (or the zero
                 * padding) and are ignored; each lane is independent */
                const int nbv = (nb + 7) & ~7;
                rad_block(s->pk, s->lists, s->node_start, path, np, np > 0 && path[0] == (uint32_t)li, nbv, bx + k0,
                          by + k0, bz + k0, bnx + k0, bny + k0, bnz + k0, ar, ag, ab, an, r2);
                const float w = 1.f / (PGI__PI * r2);
                for (int t = 0; t < nb; t++) {
                    size_t i = s->order[k0 + t];
                    if (bx[k0 + t] == bx[k0 + t]) {
                        /* Lambertian: pgi__acc_finish with no specular sum, reading only kd */
                        const float *kd = vs->kd + 3 * i;
                        float *o = a->out_rgb + 3 * i;
                        o[0] = (kd[0] * PGI__INV_PI * (ar[t] + cf[0])) * w;
                        o[1] = (kd[1] * PGI__INV_PI * (ag[t] + cf[1])) * w;
                        o[2] = (kd[2] * PGI__INV_PI * (ab[t] + cf[2])) * w;
                        reads += total + cc;
                        bulk += cc;
                        contrib += an[t] + cc;
                        continue;
                    }
                    pgi__vs_load_reuse(vs, i, &v, &have_lobe);
                    pgi__acc acc = {ar[t], ag[t], ab[t], 0.f, 0.f, 0.f, an[t]};
                    if (!v.lambert) {
                        /* pgi__gather's sums, the lobe a batch of contributing photons at a time */
                        pgi__gather_batch gb;
                        gb.n = 0;
                        for (int p = np - 1; p >= 0; p--) {
                            const uint32_t *q = s->lists + s->node_start[path[p]];
                            const uint32_t m = s->node_start[path[p] + 1] - s->node_start[path[p]];
                            for (uint32_t e = 0; e < m; e++) pgi__gather_push_packed(&v, r2, s->pk + q[e], &acc, &gb);
                        }
                        pgi__gather_flush(&v, &gb, &acc);
                    }
                    acc.fr += cf[0], acc.fg += cf[1], acc.fb += cf[2];
                    acc.contributing += cc;
                    pgi__acc_finish(&v, &acc, r2, a->out_rgb + 3 * i);
                    reads += total + cc;
                    bulk += cc;
                    contrib += acc.contributing;
                }
            }
        }
    }
    s->c.st.estimate_ms = pgi__now_ms() - t0;
    pgi__stats_pass(&s->c.st, "radiance", s->c.st.estimate_ms);
    s->c.st.reads = reads;
    s->c.st.contributing = contrib;
    s->c.st.reads_bulk = bulk;
    cl_stats_memory(s, npix);
    return PGI_OK;
}

/* Every buffer of the state, for cl_destroy and the memory stats. */
#define CL_NBUFS 43
static void cl_bufs(cl_state *s, pgi__buf *out[CL_NBUFS]) {
    pgi__buf *b[CL_NBUFS] = {&s->keys_buf,      &s->keys2_buf,  &s->spread_buf,   &s->ck2_buf,       &s->tcl_buf,
                             &s->tn_buf,        &s->ci_buf,     &s->ci2_buf,      &s->cb_buf,        &s->cn_buf,
                             &s->cs_buf,        &s->order_buf,  &s->hist_buf,     &s->pix_cnt_buf,   &s->nodes_buf,
                             &s->sbeg_buf,      &s->send_buf,   &s->nkey_buf,     &s->top_cnt_buf,   &s->top_tcnt_buf,
                             &s->job_start_buf, &s->jobs_buf,   &s->top_ids_buf,  &s->node_cnt_buf,  &s->node_start_buf,
                             &s->node_tcnt_buf, &s->cursor_buf, &s->top_flux_buf, &s->node_flux_buf, &s->buckets_buf,
                             &s->lists_buf,     &s->pk_buf,     &s->cum_flux_buf, &s->irr_buf,       &s->cum_cnt_buf,
                             &s->task_rec_buf,  &s->soa_buf,    &s->sam_buf,      &s->sec_key_buf,   &s->sec_pix_buf,
                             &s->sec_pos_buf,   &s->perm_buf,   &s->perm_hist_buf};
    memcpy(out, b, sizeof b);
}

/* Bytes per structure (the paper's Table 1), after the radiance pass. */
void cl_stats_memory(cl_state *s, size_t npix) {
    const size_t nn = s->nnodes;
    s->c.st.memory_count = 0;
    pgi__stats_mem(&s->c.st, "hierarchy",
                   nn * (4 * sizeof(uint32_t) + 2 * sizeof(uint32_t) + sizeof(uint64_t)) +
                       s->nvalid * (sizeof(uint32_t) + sizeof(uint64_t)));
    pgi__stats_mem(&s->c.st, "bounds", nn * 6 * sizeof(float));
    pgi__stats_mem(&s->c.st, "sorted_samples", s->nvalid * 6 * sizeof(float));
    if (s->variant & V_CONE) pgi__stats_mem(&s->c.st, "normal_cones", nn * 6 * sizeof(float));
    if (s->variant & V_TRIVIAL) pgi__stats_mem(&s->c.st, "node_flux", nn * (3 * sizeof(float) + sizeof(uint32_t)));
    if (s->variant & V_DIR) {
        size_t nD = s->splatted ? nn - s->lvl_off[s->D] : 0;
        pgi__stats_mem(&s->c.st, "node_flux", nD * 8 * PGI__DIR_BUCKET * sizeof(float));
        pgi__stats_mem(&s->c.st, "irradiance", 10 * npix * sizeof(float));
    }
    pgi__stats_mem(&s->c.st, "jobs", s->njobs * sizeof(uint32_t));
    pgi__stats_mem(&s->c.st, "packed_photons", s->npacked * sizeof(pgi__packed_photon));
    if (!(s->variant & V_DIR))
        pgi__stats_mem(&s->c.st, "photon_lists", s->nlist * sizeof(uint32_t) + (nn + 1) * sizeof(uint32_t));
    /* what its buffers hold beyond the structures above: sort keys, build and traversal scratch */
    pgi__buf *b[CL_NBUFS];
    cl_bufs(s, b);
    size_t held = 0, listed = 0;
    for (size_t k = 0; k < CL_NBUFS; k++) held += b[k]->bytes;
    for (int i = 0; i < s->nouts; i++) held += s->outs[i].capout * 2 * sizeof(uint32_t);
    for (int k = 0; k < s->c.st.memory_count; k++) listed += s->c.st.memory_bytes[k];
    if (held > listed) pgi__stats_mem(&s->c.st, "estimator_scratch", held - listed);
}

void cl_destroy(void *state) {
    cl_state *s = state;
    if (!s) return;
    pgi__buf *b[CL_NBUFS];
    cl_bufs(s, b);
    for (size_t k = 0; k < CL_NBUFS; k++) pgi__buf_free(b[k]);
    for (int i = 0; i < s->nouts; i++) free(s->outs[i].out);
    free(s->outs);
    free(s);
}

const pgi_estimator_vtbl pgi__est_cluster =
    PGI__EST_TABLE("cluster",
                   "view-sample cluster hierarchy; photons splatted into node lists (Moreau et al. 2016 §4.1-4.4)",
                   cluster_create, cl_build, cl_estimate, cl_destroy, .exact = 1, .options = k_options,
                   .bytes_per_photon = 192, .bytes_per_sample = 128);
const pgi_estimator_vtbl pgi__est_cluster_cone =
    PGI__EST_TABLE("cluster-cone", "cluster + normal-cone rejection of photons from below a node's surfaces (§4.5)",
                   cone_create, cl_build, cl_estimate, cl_destroy, .exact = 1, .options = k_options,
                   .bytes_per_photon = 192, .bytes_per_sample = 128);
const pgi_estimator_vtbl pgi__est_cluster_trivial =
    PGI__EST_TABLE("cluster-trivial",
                   "cluster-cone + trivial accept: enclosed all-Lambertian nodes accumulate flux, no list (§4.6)",
                   trivial_create, cl_build, cl_estimate, cl_destroy, .exact = 1, .options = k_options,
                   .bytes_per_photon = 144, .bytes_per_sample = 96);
