/* bvh: the BVH photon map of Fabianowski & Dingliana, "Interactive Global
 * Photon Mapping" (EG 2009) §5-6. A bounding-volume hierarchy over photon
 * footprints (spheres of the fixed radius, spheres of per-photon radii, or
 * the skewed ellipsoids of photon differentials); a query point descends into
 * every node whose box contains it and accumulates every footprint that
 * contains it (docs/bvh.md).
 *
 * Builders (desc.bvh_build):
 *  - linear (default, §5.2/§6.2): 30-bit Morton codes of the photon positions
 *    in their bounding box, an LSD radix sort (stable: ties stay in photon
 *    order), splits at the highest differing code bit, bounds bottom-up. A
 *    range is a leaf when it holds at most T photons or one Morton code (it
 *    cannot be split further) - the same tree the paper's bottom-up fusing of
 *    sub-threshold splits yields.
 *  - vvh (§5.1): top-down, minimising C = V_L N_L + V_R N_R over the 3N plane
 *    sweeps (photons presorted by centroid along each axis, stable partition
 *    per split), stopping at T photons.
 * Leaf threshold T (desc.leaf_size): given, or T_auto (§5.3) = TAUTO_BASE +
 * TAUTO_SCALE * total footprint area / scene surface area, rounded.
 *
 * Everything is deterministic: the build is serial except for independent
 * per-photon work, and each sample sums in tree order. */
#include "estimator_internal.h"

enum { MODE_FIXED, MODE_SPHERE, MODE_ELLIPSOID };
/* T_auto = TAUTO_BASE + TAUTO_SCALE * footprint area / scene area. The paper's term is the
 * proportional one (it gives no constant). On our CPU a node visit costs as much as many photon
 * tests (photons are packed contiguously), so the best fixed threshold had a floor of about 16-32
 * even at low photon density and grew with density above it (photongi-bench-bvh on Sibenik and
 * Crytek Sponza, docs/bvh.md); the constant base models that floor. */
#define TAUTO_BASE 16.0
#define TAUTO_SCALE 6.0
#define MAX_DEPTH 60
#define STACK_SIZE 128

typedef struct {
    float lo[3], hi[3];
    uint32_t a; /* leaf: first photon (in packed order); inner: left child (right = a + 1) */
    uint32_t n; /* leaf: photon count (> 0); inner: 0 */
} bnode;

typedef struct {
    pgi__est_common c;
    int mode, leaf;
    size_t n;
    double footprint_area, scene_area;
    float *box; /* 6 per photon: lo xyz, hi xyz (photon index order) */
    size_t box_cap;
    uint32_t *keys, *keys2, *idx, *idx2, *vvh_idx, *flag; /* build scratch */
    size_t keys_cap, keys2_cap, idx_cap, idx2_cap, vvh_cap, flag_cap;
    float *sweep;
    size_t sweep_cap;
    bnode *nodes;
    size_t nnodes, node_cap;
    pgi__packed_photon *pk; /* photons in leaf order; flux premultiplied by 1/(pi r_p^2) unless fixed */
    size_t pk_cap;
    float *r2; /* MODE_SPHERE: r_p^2 in leaf order */
    size_t r2_cap;
    float *inv; /* MODE_ELLIPSOID: 9 per photon, pgi__photon_ellipsoid_inverse */
    size_t inv_cap;
    int max_depth;
} bvh_state;
_Static_assert(offsetof(bvh_state, c) == 0, "pgi__est_default_stats reads the state as its pgi__est_common");

static const pgi_option k_opt_build = {.name = "bvh-build",
                                       .type = PGI_OPTION_CHOICE,
                                       .offset = offsetof(pgi_estimator_desc, bvh.build),
                                       .choices = "linear|vvh",
                                       .help = "BVH builder: linear (Morton) or vvh (default linear)"};
static const pgi_option k_opt_leaf = {.name = "leaf-size",
                                      .type = PGI_OPTION_INT,
                                      .offset = offsetof(pgi_estimator_desc, bvh.leaf_size),
                                      .min = 0,
                                      .max = 65536,
                                      .help = "BVH leaf size threshold (1..65536; 0 = T_auto, the default)"};
static const pgi_option *const k_options[] = {&k_opt_build, &k_opt_leaf, NULL};

static pgi_status bvh_create(const pgi_estimator_desc *d, void **state) {
    bvh_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->c.desc = *d;
    *state = s;
    return PGI_OK;
}

/* LSD radix sort of (key, value) pairs on the low `bits` bits, 8 bits a pass; stable. The result
 * ends in (k, v); kt/vt are scratch of the same size. */
static void radix_sort(uint32_t *k, uint32_t *v, uint32_t *kt, uint32_t *vt, size_t n, int bits) {
    for (int shift = 0; shift < bits; shift += 8) {
        size_t cnt[257] = {0};
        for (size_t i = 0; i < n; i++) cnt[((k[i] >> shift) & 255u) + 1]++;
        for (int b = 0; b < 256; b++) cnt[b + 1] += cnt[b];
        for (size_t i = 0; i < n; i++) {
            size_t o = cnt[(k[i] >> shift) & 255u]++;
            kt[o] = k[i];
            vt[o] = v[i];
        }
        memcpy(k, kt, n * sizeof *k);
        memcpy(v, vt, n * sizeof *v);
    }
}

/* Spreads the low 10 bits of x to every third bit. */
static inline uint32_t expand_bits(uint32_t x) {
    x = (x * 0x00010001u) & 0xFF0000FFu;
    x = (x * 0x00000101u) & 0x0F00F00Fu;
    x = (x * 0x00000011u) & 0xC30C30C3u;
    x = (x * 0x00000005u) & 0x49249249u;
    return x;
}

static inline uint32_t quant10(float x, float lo, float scale) {
    float q = (x - lo) * scale;
    if (!(q > 0.f)) return 0; /* also NaN */
    if (q > 1023.f) return 1023;
    return (uint32_t)q;
}

static void box_of(const bvh_state *s, const uint32_t *ids, size_t cnt, float lo[3], float hi[3]) {
    lo[0] = lo[1] = lo[2] = INFINITY;
    hi[0] = hi[1] = hi[2] = -INFINITY;
    for (size_t i = 0; i < cnt; i++) {
        const float *b = s->box + 6 * (size_t)ids[i];
        for (int k = 0; k < 3; k++) {
            lo[k] = pgi_minf(lo[k], b[k]);
            hi[k] = pgi_maxf(hi[k], b[3 + k]);
        }
    }
}

static void make_leaf(bvh_state *s, uint32_t ni, uint32_t start, uint32_t cnt, const uint32_t *ids) {
    bnode *nd = &s->nodes[ni];
    nd->a = start;
    nd->n = cnt;
    box_of(s, ids + start, cnt, nd->lo, nd->hi);
}

static void union_children(bvh_state *s, uint32_t ni) {
    bnode *nd = &s->nodes[ni];
    const bnode *l = &s->nodes[nd->a], *r = &s->nodes[nd->a + 1];
    for (int k = 0; k < 3; k++) {
        nd->lo[k] = pgi_minf(l->lo[k], r->lo[k]);
        nd->hi[k] = pgi_maxf(l->hi[k], r->hi[k]);
    }
    nd->n = 0;
}

/* Linear build over the sorted codes keys[start, start+cnt); photon ids in idx. */
static void build_linear(bvh_state *s, uint32_t ni, uint32_t start, uint32_t cnt, int depth) {
    if (depth > s->max_depth) s->max_depth = depth;
    uint32_t last = start + cnt - 1;
    if (cnt <= (uint32_t)s->leaf || s->keys[start] == s->keys[last] || depth >= MAX_DEPTH) {
        make_leaf(s, ni, start, cnt, s->idx);
        return;
    }
    uint32_t x = s->keys[start] ^ s->keys[last];
    uint32_t bit = 1u << (31 - __builtin_clz(x));
    /* first index whose code has `bit` set (codes share the bits above it) */
    uint32_t lo = start + 1, hi = last;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (s->keys[mid] & bit) hi = mid;
        else lo = mid + 1;
    }
    uint32_t l = (uint32_t)s->nnodes;
    s->nnodes += 2;
    s->nodes[ni].a = l;
    build_linear(s, l, start, lo - start, depth + 1);
    build_linear(s, l + 1, lo, start + cnt - lo, depth + 1);
    union_children(s, ni);
}

static inline float box_volume(const float lo[3], const float hi[3]) {
    return (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
}

/* VVH build: vvh_idx holds three copies of the ids [axis][n], each sorted by that centroid axis;
 * range [start, start+cnt) holds the same photons in all three. */
static void build_vvh(bvh_state *s, uint32_t ni, uint32_t start, uint32_t cnt, int depth) {
    if (depth > s->max_depth) s->max_depth = depth;
    const size_t n = s->n;
    if (cnt <= (uint32_t)s->leaf || depth >= MAX_DEPTH) {
        make_leaf(s, ni, start, cnt, s->vvh_idx);
        return;
    }
    float best = INFINITY;
    int best_axis = -1;
    uint32_t best_i = 0;
    float *right = s->sweep; /* right[i]: volume of items i..cnt-1 */
    for (int ax = 0; ax < 3; ax++) {
        const uint32_t *ids = s->vvh_idx + (size_t)ax * n + start;
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (uint32_t i = cnt; i-- > 1;) {
            const float *b = s->box + 6 * (size_t)ids[i];
            for (int k = 0; k < 3; k++) {
                lo[k] = pgi_minf(lo[k], b[k]);
                hi[k] = pgi_maxf(hi[k], b[3 + k]);
            }
            right[i] = box_volume(lo, hi);
        }
        lo[0] = lo[1] = lo[2] = INFINITY;
        hi[0] = hi[1] = hi[2] = -INFINITY;
        for (uint32_t i = 1; i < cnt; i++) {
            const float *b = s->box + 6 * (size_t)ids[i - 1];
            for (int k = 0; k < 3; k++) {
                lo[k] = pgi_minf(lo[k], b[k]);
                hi[k] = pgi_maxf(hi[k], b[3 + k]);
            }
            float c = box_volume(lo, hi) * (float)i + right[i] * (float)(cnt - i);
            if (c < best) {
                best = c;
                best_axis = ax;
                best_i = i;
            }
        }
    }
    if (best_axis < 0) { /* non-finite volumes: split the x order in the middle */
        best_axis = 0;
        best_i = cnt / 2;
    }
    /* Stable partition of the other two orders by membership in the left set. */
    const uint32_t *sel = s->vvh_idx + (size_t)best_axis * n + start;
    for (uint32_t i = 0; i < cnt; i++) s->flag[sel[i]] = i < best_i;
    for (int ax = 0; ax < 3; ax++) {
        if (ax == best_axis) continue;
        uint32_t *ids = s->vvh_idx + (size_t)ax * n + start;
        uint32_t *tmp = s->idx2;
        uint32_t nl = 0, nr = best_i;
        for (uint32_t i = 0; i < cnt; i++) {
            if (s->flag[ids[i]]) tmp[nl++] = ids[i];
            else tmp[nr++] = ids[i];
        }
        memcpy(ids, tmp, cnt * sizeof *ids);
    }
    uint32_t l = (uint32_t)s->nnodes;
    s->nnodes += 2;
    s->nodes[ni].a = l;
    build_vvh(s, l, start, best_i, depth + 1);
    build_vvh(s, l + 1, start + best_i, cnt - best_i, depth + 1);
    union_children(s, ni);
}

static pgi_status bvh_build(void *state, const pgi_estimate_args *a) {
    bvh_state *s = state;
    pgi__est_frame(&s->c, a);
    memset(&s->c.st, 0, sizeof s->c.st);
    double t0 = pgi__now_ms();
    const pgi_photons *ph = a->photons;
    const size_t n = ph->count;
    if (n >= (size_t)UINT32_MAX / 4) return pgi__fail(PGI_ERR_INVALID_ARG, "bvh: too many photons (%zu)", n);
    s->n = n;
    s->mode = !ph->radius ? MODE_FIXED : ph->sax ? MODE_ELLIPSOID : MODE_SPHERE;
    const int vvh = s->c.desc.bvh.build == PGI_BVH_VVH;
    pgi_status st;
    size_t m = n + 1;
    if ((st = pgi__ensure((void **)&s->box, &s->box_cap, 6 * m, sizeof(float))) ||
        (st = pgi__ensure((void **)&s->keys, &s->keys_cap, m, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->keys2, &s->keys2_cap, m, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->idx, &s->idx_cap, m, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->idx2, &s->idx2_cap, m, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->nodes, &s->node_cap, 2 * m, sizeof(bnode))) ||
        (st = pgi__ensure((void **)&s->pk, &s->pk_cap, m, sizeof(pgi__packed_photon))))
        return st;
    if (s->mode == MODE_SPHERE && (st = pgi__ensure((void **)&s->r2, &s->r2_cap, m, sizeof(float)))) return st;
    if (s->mode == MODE_ELLIPSOID && (st = pgi__ensure((void **)&s->inv, &s->inv_cap, 9 * m, sizeof(float)))) return st;
    if (vvh && ((st = pgi__ensure((void **)&s->vvh_idx, &s->vvh_cap, 3 * m, sizeof(uint32_t))) ||
                (st = pgi__ensure((void **)&s->flag, &s->flag_cap, m, sizeof(uint32_t))) ||
                (st = pgi__ensure((void **)&s->sweep, &s->sweep_cap, m, sizeof(float)))))
        return st;

    /* Footprint boxes and the footprint area (T_auto). */
    const float rf = s->c.radius;
    const int mode = s->mode;
    double area = 0.0;
    float plo[3] = {INFINITY, INFINITY, INFINITY}, phi[3] = {-INFINITY, -INFINITY, -INFINITY};
#pragma omp parallel for schedule(static) reduction(+ : area) num_threads(s->c.threads)
    for (long long jj = 0; jj < (long long)n; jj++) {
        size_t j = (size_t)jj;
        float p[3] = {ph->px[j], ph->py[j], ph->pz[j]}, h[3];
        float r = mode == MODE_FIXED ? rf : ph->radius[j];
        if (mode == MODE_ELLIPSOID) pgi__ellipsoid_extent(ph, j, h);
        else h[0] = h[1] = h[2] = r;
        float *b = s->box + 6 * j;
        for (int k = 0; k < 3; k++) {
            /* Spheres: rounding is monotonic, so a photon passing d^2 < r^2 lies in [p-r, p+r] as
             * computed; the pad covers the ellipsoid test's rounding. */
            float pad = mode == MODE_ELLIPSOID ? 1e-3f * h[k] + 1e-6f * fabsf(p[k]) : 0.f;
            b[k] = p[k] - h[k] - pad;
            b[3 + k] = p[k] + h[k] + pad;
        }
        area += (double)PGI__PI * (double)r * (double)r;
    }
    for (size_t j = 0; j < n; j++) {
        float p[3] = {ph->px[j], ph->py[j], ph->pz[j]};
        for (int k = 0; k < 3; k++) {
            plo[k] = pgi_minf(plo[k], p[k]);
            phi[k] = pgi_maxf(phi[k], p[k]);
        }
    }
    s->footprint_area = area;
    double sa = s->c.scene_area;
    if (!(sa > 0.0) && n > 0) {
        double ex = phi[0] - plo[0], ey = phi[1] - plo[1], ez = phi[2] - plo[2];
        sa = 2.0 * (ex * ey + ey * ez + ez * ex);
    }
    s->scene_area = sa;
    if (s->c.desc.bvh.leaf_size > 0) s->leaf = s->c.desc.bvh.leaf_size;
    else {
        double t = TAUTO_BASE + (sa > 0.0 ? TAUTO_SCALE * area / sa : 0.0);
        s->leaf = !(t < 65536.0) ? 65536 : t < 1.0 ? 1 : (int)(t + 0.5);
    }
    double t1 = pgi__now_ms();

    s->nnodes = 0;
    s->max_depth = 0;
    if (n > 0) {
        s->nnodes = 1;
        if (!vvh) {
            float scale[3];
            for (int k = 0; k < 3; k++) {
                float e = phi[k] - plo[k];
                scale[k] = e > 0.f ? 1024.f / e : 0.f;
            }
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
            for (long long jj = 0; jj < (long long)n; jj++) {
                size_t j = (size_t)jj;
                s->keys[j] = (expand_bits(quant10(ph->px[j], plo[0], scale[0])) << 2) |
                             (expand_bits(quant10(ph->py[j], plo[1], scale[1])) << 1) |
                             expand_bits(quant10(ph->pz[j], plo[2], scale[2]));
                s->idx[j] = (uint32_t)j;
            }
            double tm = pgi__now_ms();
            radix_sort(s->keys, s->idx, s->keys2, s->idx2, n, 30);
            double ts = pgi__now_ms();
            build_linear(s, 0, 0, (uint32_t)n, 0);
            pgi__stats_pass(&s->c.st, "boxes", t1 - t0);
            pgi__stats_pass(&s->c.st, "morton", tm - t1);
            pgi__stats_pass(&s->c.st, "sort", ts - tm);
            pgi__stats_pass(&s->c.st, "hierarchy", pgi__now_ms() - ts);
        } else {
            for (int ax = 0; ax < 3; ax++) {
                const float *c = ax == 0 ? ph->px : ax == 1 ? ph->py : ph->pz;
                uint32_t *ids = s->vvh_idx + (size_t)ax * n;
                for (size_t j = 0; j < n; j++) {
                    uint32_t u;
                    float f = c[j] + 0.f; /* -0 -> +0 */
                    memcpy(&u, &f, sizeof u);
                    s->keys[j] = (u & 0x80000000u) ? ~u : (u | 0x80000000u); /* order-preserving */
                    ids[j] = (uint32_t)j;
                }
                radix_sort(s->keys, ids, s->keys2, s->idx2, n, 32);
            }
            double ts = pgi__now_ms();
            build_vvh(s, 0, 0, (uint32_t)n, 0);
            memcpy(s->idx, s->vvh_idx, n * sizeof *s->idx);
            pgi__stats_pass(&s->c.st, "boxes", t1 - t0);
            pgi__stats_pass(&s->c.st, "presort", ts - t1);
            pgi__stats_pass(&s->c.st, "vvh", pgi__now_ms() - ts);
        }
    }
    double t2 = pgi__now_ms();
    /* Photons in leaf order, with what the query needs. */
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
    for (long long kk = 0; kk < (long long)n; kk++) {
        size_t k = (size_t)kk, j = s->idx[k];
        pgi__packed_photon *q = &s->pk[k];
        pgi__pack_photon(ph, j, q);
        if (mode != MODE_FIXED) {
            float w = pgi__footprint_weight(ph->radius[j]);
            q->fr *= w;
            q->fg *= w;
            q->fb *= w;
        }
        if (mode == MODE_SPHERE) s->r2[k] = ph->radius[j] * ph->radius[j];
        if (mode == MODE_ELLIPSOID) pgi__photon_ellipsoid_inverse(ph, j, s->inv + 9 * k);
    }
    double t3 = pgi__now_ms();
    pgi__stats_pass(&s->c.st, "pack", t3 - t2);
    s->c.st.build_ms = t3 - t0;
    s->c.st.leaf_size = s->leaf;
    return PGI_OK;
}

static inline int in_box(const bnode *b, float x, float y, float z) {
    return x >= b->lo[0] && x <= b->hi[0] && y >= b->lo[1] && y <= b->hi[1] && z >= b->lo[2] && z <= b->hi[2];
}

static pgi_status bvh_estimate(void *state, const pgi_estimate_args *a) {
    bvh_state *s = state;
    pgi__est_frame(&s->c, a);
    double t0 = pgi__now_ms();
    const pgi_view_samples *vs = a->samples;
    const float r2f = s->c.radius * s->c.radius;
    const int mode = s->mode;
    const bnode *nodes = s->nodes;
    const int have = s->nnodes > 0;
    uint64_t reads = 0, contrib = 0, visited = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : reads, contrib, visited) num_threads(s->c.threads)
    for (long long ii = 0; ii < (long long)vs->count; ii++) {
        pgi__vs v;
        float *out = pgi__est_sample(&s->c, a, ii, &v);
        if (!out) continue;
        pgi__acc acc = {0};
        uint32_t stack[STACK_SIZE];
        int sp = 0;
        visited++;
        if (have && in_box(&nodes[0], v.px, v.py, v.pz)) stack[sp++] = 0;
        while (sp > 0) {
            const bnode *nd = &nodes[stack[--sp]];
            if (nd->n) {
                const uint32_t b = nd->a, e = nd->a + nd->n;
                reads += nd->n;
                if (mode == MODE_FIXED) pgi__gather_packed_n(&v, r2f, &s->pk[b], nd->n, &acc);
                else if (mode == MODE_SPHERE && v.lambert)
                    for (uint32_t k = b; k < e; k++) pgi__gather_packed(&v, s->r2[k], &s->pk[k], &acc);
                else if (mode == MODE_SPHERE) { /* the lobe a batch at a time, as pgi__gather_packed_n */
                    pgi__gather_batch gb;
                    gb.n = 0;
                    for (uint32_t k = b; k < e; k++) pgi__gather_push_packed(&v, s->r2[k], &s->pk[k], &acc, &gb);
                    pgi__gather_flush(&v, &gb, &acc);
                } else
                    for (uint32_t k = b; k < e; k++) {
                        const pgi__packed_photon *q = &s->pk[k];
                        pgi__gather_ellipsoid(&v, s->inv + 9 * (size_t)k, q->px, q->py, q->pz, q->dx, q->dy, q->dz,
                                              q->fr, q->fg, q->fb, &acc);
                    }
                continue;
            }
            /* right first, so that the left child is popped first (tree order) */
            visited += 2;
            if (in_box(&nodes[nd->a + 1], v.px, v.py, v.pz)) stack[sp++] = nd->a + 1;
            if (in_box(&nodes[nd->a], v.px, v.py, v.pz)) stack[sp++] = nd->a;
        }
        if (mode == MODE_FIXED) pgi__acc_finish(&v, &acc, r2f, out);
        else pgi__acc_finish_w(&v, &acc, 1.f, out);
        contrib += acc.contributing;
    }
    pgi__stats_estimated(&s->c.st, t0, reads, contrib);
    s->c.st.nodes_visited = visited;
    s->c.st.memory_count = 0;
    pgi__stats_mem(&s->c.st, "bvh_nodes", s->nnodes * sizeof(bnode));
    pgi__stats_mem(&s->c.st, "bvh_photons",
                   s->n * (sizeof(pgi__packed_photon) + (mode == MODE_SPHERE ? sizeof(float) : 0) +
                           (mode == MODE_ELLIPSOID ? 9 * sizeof(float) : 0)));
    pgi__stats_mem(&s->c.st, "bvh_build_scratch",
                   s->n * (6 * sizeof(float) + 4 * sizeof(uint32_t)) +
                       (s->c.desc.bvh.build == PGI_BVH_VVH ? s->n * (4 * sizeof(uint32_t) + sizeof(float)) : 0));
    return PGI_OK;
}

static void bvh_destroy(void *state) {
    bvh_state *s = state;
    if (!s) return;
    void *p[] = {s->box,  s->keys,  s->keys2, s->idx, s->idx2, s->vvh_idx,
                 s->flag, s->sweep, s->nodes, s->pk,  s->r2,   s->inv};
    for (size_t k = 0; k < sizeof p / sizeof p[0]; k++) pgi__afree(p[k]);
    free(s);
}

const pgi_estimator_vtbl pgi__est_bvh =
    PGI__EST_TABLE("bvh",
                   "BVH over photon footprints, linear or VVH build, T_auto leaves (Fabianowski & Dingliana 2009)",
                   bvh_create, bvh_build, bvh_estimate, bvh_destroy, .exact = 1, .caps = PGI_EST_CAP_PHOTON_RADIUS,
                   .options = k_options, .bytes_per_photon = 112);
