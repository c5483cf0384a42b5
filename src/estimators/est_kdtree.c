/* kdtree: the classic photon map (Jensen 1996/2001), pixel-major gather.
 *
 * Build: balanced median split. Every node of a range [lo, hi) of the photon
 * array holds its median photon at mid = lo + (hi - lo) / 2, split along the
 * axis of largest extent of the range's bounding box; the left range holds
 * the photons with (coordinate, photon index) below the median's, the right
 * range those above. Ranges of at most LEAF photons are leaves scanned
 * linearly. The tree is implicit (no pointers): one byte a node for the
 * axis. Quickselect with a deterministic pivot and a total order (ties broken
 * by photon index) makes the layout independent of the thread count; the top
 * levels build in parallel as OpenMP tasks.
 *
 * Queries:
 *  - range mode (knn = 0): every photon within the fixed radius, with the same
 *    per-photon decision as brute (pgi__gather); exact.
 *  - k-NN mode (knn = k): among the photons with d < r_max and dot(n, w_p) > 0,
 *    the k nearest (ties: lower photon index); the radius is the distance to
 *    the k-th (r_max when fewer are found) and the estimate is normalised by
 *    that disk. The k-th photon lies on the disk's edge and is included.
 * Both support the kernels; range mode supports stochastic subsampling (every
 * photon the walk reaches is eligible). */
#include <float.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "estimator_internal.h"

#define LEAF 8
#define MAX_STACK 128

typedef struct {
    pgi__est_common c;
    pgi__packed_photon *pts; /* tree order */
    size_t pts_cap;
    uint32_t *orig; /* photon index of each tree slot */
    size_t orig_cap;
    uint8_t *axis; /* split axis of the node whose median sits at that slot */
    size_t axis_cap;
    struct kitem_ *items; /* build scratch */
    size_t items_cap;
    size_t n;
} kdtree_state;
_Static_assert(offsetof(kdtree_state, c) == 0, "pgi__est_default_stats reads the state as its pgi__est_common");

static const pgi_option k_opt_knn =
    {.name = "knn",
     .type = PGI_OPTION_INT,
     .offset = offsetof(pgi_estimator_desc, kdtree.knn),
     .min = 1,
     .max = 4096,
     .flags = PGI_OPTION_STRICT,
     .help = "the N nearest photons within the radius, over the disk through the N-th (1..4096; default: "
             "range mode)"};
static const pgi_option *const k_options[] = {&k_opt_knn, NULL};

static pgi_status kd_create(const pgi_estimator_desc *d, void **state) {
    if (d->kdtree.knn > 0 && d->subsample > 1)
        return pgi__fail(PGI_ERR_INVALID_ARG, "kdtree: stochastic subsampling works in range mode only (knn 0)");
    kdtree_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->c.desc = *d;
    *state = s;
    return PGI_OK;
}

/* Build item: position and photon index together (16 bytes), so that the
 * selection and the boxes read memory in order. */
typedef struct kitem_ {
    float p[3];
    uint32_t idx;
} kitem;

/* Strict total order on (coordinate, photon index). */
static inline int less(int a, const kitem *x, const kitem *y) {
    return x->p[a] < y->p[a] || (x->p[a] == y->p[a] && x->idx < y->idx);
}

/* Puts the element of rank k of it[lo, hi) at k, smaller ones before it. */
static void select_kth(int a, kitem *it, size_t lo, size_t hi, size_t k) {
    while (hi - lo > 1) {
        size_t m = lo + (hi - lo) / 2;
        kitem t;
        /* median of three to it[m] */
        if (less(a, &it[m], &it[lo])) t = it[m], it[m] = it[lo], it[lo] = t;
        if (less(a, &it[hi - 1], &it[lo])) t = it[hi - 1], it[hi - 1] = it[lo], it[lo] = t;
        if (less(a, &it[hi - 1], &it[m])) t = it[hi - 1], it[hi - 1] = it[m], it[m] = t;
        /* Lomuto partition around the pivot, moved to the end (keys are distinct). */
        kitem pivot = it[m];
        it[m] = it[hi - 1];
        it[hi - 1] = pivot;
        size_t store = lo;
        for (size_t i = lo; i + 1 < hi; i++)
            if (less(a, &it[i], &pivot)) {
                t = it[i], it[i] = it[store], it[store] = t;
                store++;
            }
        it[hi - 1] = it[store];
        it[store] = pivot;
        if (k == store) return;
        if (k < store) hi = store;
        else lo = store + 1;
    }
}

static void build_range(kdtree_state *s, size_t lo, size_t hi) {
    if (hi - lo <= LEAF) return;
    kitem *it = s->items;
    float bmin[3] = {INFINITY, INFINITY, INFINITY}, bmax[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = lo; i < hi; i++)
        for (int k = 0; k < 3; k++) {
            bmin[k] = fminf(bmin[k], it[i].p[k]);
            bmax[k] = fmaxf(bmax[k], it[i].p[k]);
        }
    int a = 0;
    for (int k = 1; k < 3; k++)
        if (bmax[k] - bmin[k] > bmax[a] - bmin[a]) a = k;
    size_t mid = lo + (hi - lo) / 2;
    select_kth(a, it, lo, hi, mid);
    s->axis[mid] = (uint8_t)a;
    if (hi - lo > 32768) {
#pragma omp task default(shared) firstprivate(lo, mid)
        build_range(s, lo, mid);
#pragma omp task default(shared) firstprivate(mid, hi)
        build_range(s, mid + 1, hi);
#pragma omp taskwait
    } else {
        build_range(s, lo, mid);
        build_range(s, mid + 1, hi);
    }
}

static pgi_status kd_build(void *state, const pgi_estimate_args *a) {
    kdtree_state *s = state;
    pgi__est_frame(&s->c, a);
    memset(&s->c.st, 0, sizeof s->c.st);
    const pgi_photons *ph = a->photons;
    const size_t n = ph->count;
    if (n > UINT32_MAX) return pgi__fail(PGI_ERR_UNSUPPORTED, "kdtree: more than 2^32 photons");
    pgi_status st;
    if ((st = pgi__ensure((void **)&s->pts, &s->pts_cap, n + 1, sizeof(pgi__packed_photon))) ||
        (st = pgi__ensure((void **)&s->orig, &s->orig_cap, n + 1, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->axis, &s->axis_cap, n + 1, 1)) ||
        (st = pgi__ensure((void **)&s->items, &s->items_cap, n + 1, sizeof(kitem))))
        return st;
    double t0 = pgi__now_ms();
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
    for (long long j = 0; j < (long long)n; j++) s->items[j] = (kitem){{ph->px[j], ph->py[j], ph->pz[j]}, (uint32_t)j};
    memset(s->axis, 0, n + 1);
#pragma omp parallel num_threads(s->c.threads)
#pragma omp single
    build_range(s, 0, n);
    double t1 = pgi__now_ms();
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
    for (long long i = 0; i < (long long)n; i++) {
        s->orig[i] = s->items[i].idx;
        pgi__pack_photon(ph, s->items[i].idx, &s->pts[i]);
    }
    double t2 = pgi__now_ms();
    s->n = n;
    pgi__stats_pass(&s->c.st, "median split", t1 - t0);
    pgi__stats_pass(&s->c.st, "pack", t2 - t1);
    s->c.st.build_ms = t2 - t0;
    return PGI_OK;
}

static inline float pc(const pgi__packed_photon *q, int a) { return a == 0 ? q->px : a == 1 ? q->py : q->pz; }

/* Range query: every photon the walk cannot rule out is passed to visit. */
static void range_query(const kdtree_state *s, const pgi__vs *v, float r, float r2, pgi_kernel kern, pgi__sub *ss,
                        pgi__acc *acc, uint64_t *nodes) {
    const float rr = r * 1.0001f + 1e-7f; /* pruning margin: never drops a photon the test would accept */
    const float q[3] = {v->px, v->py, v->pz};
    size_t stk_lo[MAX_STACK], stk_hi[MAX_STACK];
    int sp = 0;
    stk_lo[sp] = 0, stk_hi[sp++] = s->n;
    while (sp) {
        sp--;
        size_t lo = stk_lo[sp], hi = stk_hi[sp];
        (*nodes)++;
        if (hi - lo <= LEAF) {
            for (size_t i = lo; i < hi; i++)
                if (pgi__sub_take(ss)) pgi__gather_packed_k(v, r2, kern, &s->pts[i], acc);
            continue;
        }
        size_t mid = lo + (hi - lo) / 2;
        int a = s->axis[mid];
        float d = q[a] - pc(&s->pts[mid], a);
        if (pgi__sub_take(ss)) pgi__gather_packed_k(v, r2, kern, &s->pts[mid], acc);
        /* left: coordinates <= split; right: >= split */
        if (d <= rr && mid > lo) stk_lo[sp] = lo, stk_hi[sp++] = mid;
        if (-d <= rr && hi > mid + 1) stk_lo[sp] = mid + 1, stk_hi[sp++] = hi;
    }
}

typedef struct {
    float d2;
    uint32_t orig, slot;
} cand;

static inline int cand_less(const cand *x, const cand *y) {
    return x->d2 < y->d2 || (x->d2 == y->d2 && x->orig < y->orig);
}

/* Max-heap of the best k candidates by (d2, photon index). */
static inline void heap_push(cand *h, int *n, cand c) {
    int i = (*n)++;
    while (i > 0) {
        int p = (i - 1) / 2;
        if (!cand_less(&h[p], &c)) break;
        h[i] = h[p];
        i = p;
    }
    h[i] = c;
}
static inline void heap_replace_top(cand *h, int n, cand c) {
    int i = 0;
    for (;;) {
        int l = 2 * i + 1, r = l + 1, m = i;
        const cand *mc = &c;
        if (l < n && cand_less(mc, &h[l])) m = l, mc = &h[l];
        if (r < n && cand_less(mc, &h[r])) m = r;
        if (m == i) break;
        h[i] = h[m];
        i = m;
    }
    h[i] = c;
}

static inline void knn_offer(const kdtree_state *s, const pgi__vs *v, float rmax2, size_t slot, cand *h, int *hn,
                             int k) {
    const pgi__packed_photon *q = &s->pts[slot];
    float ex = q->px - v->px, ey = q->py - v->py, ez = q->pz - v->pz;
    float d2 = ex * ex + ey * ey + ez * ez;
    if (!(d2 < rmax2)) return;
    float c = v->nx * q->dx + v->ny * q->dy + v->nz * q->dz;
    if (!(c > 0.f)) return;
    cand cd = {d2, s->orig[slot], (uint32_t)slot};
    if (*hn < k) heap_push(h, hn, cd);
    else if (cand_less(&cd, &h[0])) heap_replace_top(h, *hn, cd);
}

/* k-NN query; returns the squared radius used for normalisation. */
static float knn_query(const kdtree_state *s, const pgi__vs *v, float rmax, int k, pgi_kernel kern, cand *h,
                       pgi__acc *acc, uint64_t *nodes, uint64_t *reads) {
    const float rmax2 = rmax * rmax;
    const float q[3] = {v->px, v->py, v->pz};
    size_t stk_lo[MAX_STACK], stk_hi[MAX_STACK];
    int sp = 0, hn = 0;
    stk_lo[sp] = 0, stk_hi[sp++] = s->n;
    while (sp) {
        sp--;
        size_t lo = stk_lo[sp], hi = stk_hi[sp];
        (*nodes)++;
        if (hi - lo <= LEAF) {
            for (size_t i = lo; i < hi; i++) knn_offer(s, v, rmax2, i, h, &hn, k);
            *reads += hi - lo;
            continue;
        }
        size_t mid = lo + (hi - lo) / 2;
        int a = s->axis[mid];
        float d = q[a] - pc(&s->pts[mid], a);
        knn_offer(s, v, rmax2, mid, h, &hn, k);
        (*reads)++;
        /* current search radius: the k-th best so far, else r_max */
        float cur = hn == k ? sqrtf(h[0].d2) : rmax;
        float rr = cur * 1.0001f + 1e-7f;
        /* push the far side first, so the near side is searched first */
        int near_left = d <= 0.f;
        size_t nlo = near_left ? lo : mid + 1, nhi = near_left ? mid : hi;
        size_t flo = near_left ? mid + 1 : lo, fhi = near_left ? hi : mid;
        float fd = near_left ? -d : d;
        if (fd <= rr && fhi > flo) stk_lo[sp] = flo, stk_hi[sp++] = fhi;
        if (nhi > nlo) stk_lo[sp] = nlo, stk_hi[sp++] = nhi;
    }
    /* the far side was pushed with the radius known then; re-checking is not
       needed for correctness (a wider search only costs time) */
    float r2 = hn == k ? h[0].d2 : rmax2;
    if (!(r2 > 0.f)) r2 = fmaxf(1e-12f * rmax2, FLT_MIN); /* k coincident photons: avoid 1/0 */
    for (int i = 0; i < hn; i++) {
        const pgi__packed_photon *p = &s->pts[h[i].slot];
        float w = kern == PGI_KERNEL_CONSTANT ? 1.f : pgi__kernel_weight(kern, fminf(h[i].d2, r2), r2);
        pgi__acc_add(v, w, p->dx, p->dy, p->dz, p->fr, p->fg, p->fb, acc);
    }
    return r2;
}

static pgi_status kd_estimate(void *state, const pgi_estimate_args *a) {
    kdtree_state *s = state;
    pgi__est_frame(&s->c, a);
    double t0 = pgi__now_ms();
    const pgi_view_samples *vs = a->samples;
    if (s->n != a->photons->count)
        return pgi__fail(PGI_ERR_INVALID_ARG, "kdtree: estimate called with other photons than build's");
    const float r = s->c.radius, r2 = r * r;
    const pgi_kernel kern = s->c.desc.kernel;
    const int k = s->c.desc.kdtree.knn, sub = s->c.desc.subsample;
    const uint64_t seed = s->c.seed;
    cand *heaps = NULL;
    int nthreads = 1;
#ifdef _OPENMP
    nthreads = s->c.threads;
#endif
    if (k > 0) {
        heaps = malloc((size_t)nthreads * (size_t)k * sizeof *heaps);
        if (!heaps) return pgi__fail(PGI_ERR_OOM, "kdtree: out of memory for k-NN heaps");
    }
    uint64_t reads = 0, contrib = 0, nodes = 0;
#pragma omp parallel reduction(+ : reads, contrib, nodes) num_threads(s->c.threads)
    {
        int tid = 0;
#ifdef _OPENMP
        tid = omp_get_thread_num();
#endif
        cand *h = heaps ? heaps + (size_t)tid * (size_t)k : NULL;
#pragma omp for schedule(dynamic, 64)
        for (long long ii = 0; ii < (long long)vs->count; ii++) {
            pgi__vs v;
            float *out = pgi__est_sample(&s->c, a, ii, &v);
            if (!out) continue;
            pgi__acc acc = {0};
            if (k > 0) {
                float rk2 = knn_query(s, &v, r, k, kern, h, &acc, &nodes, &reads);
                pgi__acc_finish_k(&v, &acc, rk2, kern, 1.f, out);
            } else {
                pgi__sub ss;
                pgi__sub_init(&ss, sub, seed, (size_t)ii);
                range_query(s, &v, r, r2, kern, &ss, &acc, &nodes);
                pgi__acc_finish_k(&v, &acc, r2, kern, pgi__sub_scale(&ss), out);
                reads += ss.visited;
            }
            contrib += acc.contributing;
        }
    }
    free(heaps);
    pgi__stats_estimated(&s->c.st, t0, reads, contrib);
    s->c.st.nodes_visited = nodes;
    s->c.st.memory_count = 0;
    pgi__stats_mem(&s->c.st, "tree_photons", s->n * (sizeof(pgi__packed_photon) + sizeof(uint32_t) + 1));
    return PGI_OK;
}

static void kd_destroy(void *state) {
    kdtree_state *s = state;
    if (!s) return;
    pgi__afree(s->pts);
    pgi__afree(s->orig);
    pgi__afree(s->axis);
    pgi__afree(s->items);
    free(s);
}

const pgi_estimator_vtbl pgi__est_kdtree =
    PGI__EST_TABLE("kdtree", "balanced kd-tree photon map; fixed-radius range gather or k nearest (Jensen)", kd_create,
                   kd_build, kd_estimate, kd_destroy, .exact = 1, .caps = PGI_EST_CAP_KERNELS | PGI_EST_CAP_SUBSAMPLE,
                   .options = k_options, .bytes_per_photon = 48);
