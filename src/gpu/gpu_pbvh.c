/* bvh on the GPU (docs/gpu.md): the CPU estimator's photon BVH (src/estimators/est_bvh.c, linear
 * builder; Fabianowski & Dingliana, EG 2009, §5.2, §6.2) built and queried on the device, exact
 * like it. One command sequence, recorded into the frame's own (no read-back: every size is the
 * photon count's):
 *   pb_prep     the photons' box, their 30-bit Morton codes over it (est_bvh.c's quantisation),
 *   sort        the (code, photon) pairs by code (gpu_sort.h; stable: photon order among equal
 *               codes), then the photons copied in that order (with per-photon footprints: each
 *               flux weighted by 1 / (pi r_p^2), and its radius or its ellipsoid's inverse frame
 *               and half extents in the same order)
 *   pb_nodes    the binary radix tree of the sorted codes (Karras 2012), each internal node a
 *               function of the codes: split at the range's highest differing bit, as the CPU's
 *   pb_bounds   each node's box, the union of its range's footprint boxes (spheres of the fixed
 *               radius or their own, ellipsoids' padded boxes, as est_bvh.c's) from the unions of
 *               aligned blocks of 64 and 4096 photons (min/max only, no atomics)
 *   pb_gather   per view sample: every node whose box contains the point, depth first, left first
 *               (the photons in sorted order); a node of at most T photons is walked whole
 * Footprints: the fixed radius (any kernel), or per photon (pgi_photons radius and sax..sbz, or the
 * frame's pgi__gpu_est_inputs.footprints; the constant kernel only, as the CPU's): spheres d^2 < r_p^2,
 * ellipsoids by est_bvh.c's containment test, the sums finished with weight 1.
 * T: --leaf-size, or T_auto = round(16 + 6 A / scene area) as the CPU's, A the footprints' area
 * (n pi r^2, or the sum of pi r_p^2: on the frame's device footprints, summed on the device per
 * workgroup in compensated float and read back before the frame's sequence). The linear builder
 * only. */
#include "gpu/gpu_estimator.h"
#include "gpu/gpu_sort.h"

#include <stdio.h>
#include <string.h>

#include "core/core.h"
#include "estimators/estimator_internal.h"

#ifndef PGI__HAVE_VULKAN

const pgi__gpu_est_vtbl pgi__gpu_est_bvh = PGI__GPU_EST_NONE("bvh");

#else

#include "gpu/spirv.h"

#define NODE_BYTES 48  /* shaders/pbvh.glsl Node */

/* shaders/pbvh.glsl Push */
typedef struct {
    float r, r2, scale, pad0;
    uint32_t n, leaf, width, height, kernel, mode, fp, pad2;
} pb_push;
_Static_assert(sizeof(pb_push) == 48 && offsetof(pb_push, n) == 16 && offsetof(pb_push, fp) == 40, "pbvh.glsl Push");

/* shaders/pbvh.glsl FP_*: the photons' footprints, and the floats of each one's sorted shape */
enum { FP_FIXED, FP_SPHERE, FP_ELLIPSOID };
static const size_t k_shape_floats[] = {1, 1, 12};
#define AREA_GROUP 256 /* pb_prep mode 3: photons a partial sum */

enum { K_PREP, K_NODES, K_BOUNDS, K_GATHER, K_N };

typedef struct {
    pgi__gpu *g;
    pgi_estimator_desc desc;
    pgi__gpu_kernel *k[K_N];
    pgi__gpu_buffer *raw, *vs, *lobes, *box, *pairs, *sorted, *nodes, *blocks, *out, *counters;
    pgi__gpu_buffer *fp, *shapes; /* footprints (photon order; run's upload), their shapes (sorted) */
    pgi__gpu_sort sort;
    pb_push p;
    size_t n, ns;
    double area_ms; /* the device footprints' area, summed before the frame's sequence (0: not) */
    /* host-side upload arrays (pgi_estimate_args inputs) */
    pgi__packed_photon *packed;
    size_t packed_cap;
    pgi__gpu_footprint *hfp;
    size_t hfp_cap;
    float *partials; /* the device footprints' area: (hi, lo) a workgroup */
    size_t partials_cap;
    pgi__gpu_vs_pack pk;
} pb_state;

static void pb_destroy(void *state) {
    pb_state *s = state;
    if (!s) return;
    for (int i = 0; i < K_N; i++) pgi__gpu_kernel_destroy(s->g, s->k[i]);
    pgi__gpu_buffer *b[] = {s->raw,   s->vs,     s->lobes, s->box,      s->pairs, s->sorted,
                            s->nodes, s->blocks, s->out,   s->counters, s->fp,    s->shapes};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(s->g, b[i]);
    pgi__gpu_sort_destroy(&s->sort);
    pgi__afree(s->packed);
    pgi__afree(s->hfp);
    pgi__afree(s->partials);
    pgi__gpu_vs_pack_free(&s->pk);
    free(s);
}

static pgi_status pb_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    *state = NULL;
    if (d->bvh.build != PGI_BVH_LINEAR)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "bvh on the GPU: --bvh-build vvh is not supported (linear only)");
    pb_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->g = g;
    s->desc = *d;
    static const pgi__gpu_kernel_spec k[K_N] = {
        [K_PREP] = PGI__GPU_KERNEL(pb_prep, 6, sizeof(pb_push)),
        [K_NODES] = PGI__GPU_KERNEL(pb_nodes, 2, sizeof(pb_push)),
        [K_BOUNDS] = PGI__GPU_KERNEL(pb_bounds, 4, sizeof(pb_push)),
        [K_GATHER] = PGI__GPU_KERNEL(pb_gather, 7, sizeof(pb_push)),
    };
    pgi_status st = pgi__gpu_kernels_create(g, k, K_N, 0, s->k);
    if (!st) st = pgi__gpu_sort_create(g, "gpu_photon_order", &s->sort);
    if (st) {
        pb_destroy(s);
        return st;
    }
    *state = s;
    return PGI_OK;
}

static const char *const gather_passes[] = {"gpu_gather", NULL};
static const char *const own_passes[] = {"gpu_photon_order", "gpu_nodes", "gpu_bounds", "gpu_gather", NULL};

/* est_bvh.c T_auto from the footprints' area and the scene's (or the photons' box's) */
static uint32_t pb_t_auto(double area, double sa) {
    const double t = 16.0 + (sa > 0.0 ? 6.0 * area / sa : 0.0);
    return !(t < 65536.0) ? 65536 : t < 1.0 ? 1 : (uint32_t)(t + 0.5);
}

/* The frame's push constants (T from --leaf-size or T_auto) and buffers. fp: the footprints (FP_*);
 * fp_area: their total area (FP_FIXED: n pi r^2 taken here; negative: not known yet, T_auto set by
 * the caller). scene_area: the scene's surface area, or 0 (then the photons' box's, as the CPU's:
 * box_area). */
static pgi_status pb_plan(pb_state *s, size_t n, int width, int height, float r, int fp, double fp_area,
                          double scene_area, double box_area) {
    pgi__gpu *g = s->g;
    const size_t ns = (size_t)width * (size_t)height;
    if (n > UINT32_MAX / 4 || ns > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "bvh on the GPU: at most 2^30 photons and view samples");
    if (fp != FP_FIXED && s->desc.kernel != PGI_KERNEL_CONSTANT)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "bvh on the GPU: per-photon footprints use the constant kernel only");
    const double area = fp == FP_FIXED ? (double)n * PGI__PI * (double)r * (double)r : fp_area;
    const uint32_t leaf = s->desc.bvh.leaf_size > 0 ? (uint32_t)s->desc.bvh.leaf_size
                                                    : pb_t_auto(area, scene_area > 0.0 ? scene_area : box_area);
    s->n = n;
    s->ns = ns;
    s->p = (pb_push){.r = r,
                     .r2 = r * r,
                     .scale = pgi__kernel_norm(s->desc.kernel),
                     .n = (uint32_t)n,
                     .leaf = (uint32_t)leaf,
                     .width = (uint32_t)width,
                     .height = (uint32_t)height,
                     .kernel = (uint32_t)s->desc.kernel,
                     .fp = (uint32_t)fp};
    const size_t psz = sizeof(pgi__packed_photon);
    pgi_status st;
    if ((st = pgi__gpu_buffer_reserve(g, &s->box, 8 * 4, "gpu_photon_order")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->pairs, (n + 1) * 8, "gpu_photon_order")) ||
        (st = pgi__gpu_sort_reserve(&s->sort, n)) ||
        (st = pgi__gpu_buffer_reserve(g, &s->sorted, (n + 1) * psz, "gpu_photons")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->shapes, (fp ? n + 1 : 1) * k_shape_floats[fp] * sizeof(float),
                                      "gpu_photons")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->nodes, (n + 1) * NODE_BYTES, "gpu_photon_bvh")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->blocks, ((n + 63) / 64 + (n + 4095) / 4096 + 1) * 24, "gpu_photon_bvh")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->out, (3 * ns + 1) * sizeof(float), "gpu_radiance")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counters, 8 * 4, "gpu_photon_bvh")))
        return st;
    return PGI_OK;
}

/* The device footprints' total area (T_auto) in a sequence of its own: pb_prep's per-workgroup
 * compensated sums, read back and added in double. */
static pgi_status pb_footprint_area(pb_state *s, pgi__gpu_buffer *photons, pgi__gpu_buffer *fp, double *area) {
    pgi__gpu *g = s->g;
    const size_t groups = (s->n + AREA_GROUP - 1) / AREA_GROUP;
    pb_push q = s->p;
    q.mode = 3;
    pgi_status st;
    *area = 0.0;
    if (!groups) return PGI_OK;
    const double t0 = pgi__now_ms();
    if ((st = pgi__ensure((void **)&s->partials, &s->partials_cap, 2 * groups, sizeof(float))) ||
        (st = pgi__gpu_begin(g)))
        return st;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_PREP],
                                   (pgi__gpu_buffer *[]){photons, s->box, s->pairs, s->sorted, fp, s->shapes}, &q, s->n,
                                   AREA_GROUP))) {
        (void)pgi__gpu_submit_wait(g);
        return st;
    }
    if ((st = pgi__gpu_submit_wait(g)) ||
        (st = pgi__gpu_download(g, s->pairs, 0, s->partials, 2 * groups * sizeof(float))))
        return st;
    for (size_t k = 0; k < 2 * groups; k++) *area += (double)s->partials[k];
    s->area_ms = pgi__now_ms() - t0;
    return PGI_OK;
}

/* Records the build and the gather into the open sequence; fp: the footprints (photon order; NULL
 * with FP_FIXED). */
static pgi_status pb_record(pb_state *s, pgi__gpu_buffer *photons, pgi__gpu_buffer *fp, pgi__gpu_buffer *vsb,
                            pgi__gpu_buffer *lobes) {
    pgi__gpu *g = s->g;
    const size_t n = s->n;
    pb_push q = s->p;
    pgi_status st;
    if (!fp) fp = photons; /* bound, not read */
    if ((st = pgi__gpu_fill(g, s->counters, 0, 8 * 4, 0))) return st;
    if (n) {
        pgi__gpu_buffer *keys, *order;
        pgi__gpu_buffer *b[] = {photons, s->box, s->pairs, s->sorted, fp, s->shapes};
        if ((st = pgi__gpu_fill(g, s->box, 0, 12, 0xffffffffu)) || (st = pgi__gpu_fill(g, s->box, 12, 20, 0)))
            return st;
        for (uint32_t m = 0; m < 2; m++) {
            q.mode = m;
            if ((st = pgi__gpu_dispatch_1d(g, s->k[K_PREP], b, &q, n, 256))) return st;
        }
        if ((st = pgi__gpu_sort_record(&s->sort, s->pairs, n, 0, 30, &keys, &order))) return st;
        q.mode = 2;
        b[2] = order;
        if ((st = pgi__gpu_dispatch_1d(g, s->k[K_PREP], b, &q, n, 256))) return st;
        pgi__gpu_timestamp(g, "gpu_photon_order");
        if ((st = pgi__gpu_dispatch_1d(g, s->k[K_NODES], (pgi__gpu_buffer *[]){keys, s->nodes}, &s->p, n, 64)))
            return st;
        pgi__gpu_timestamp(g, "gpu_nodes");
        const size_t items[3] = {(n + 63) / 64, (n + 4095) / 4096, n};
        for (uint32_t m = 0; m < 3; m++) {
            q.mode = m;
            if ((st = pgi__gpu_dispatch_1d(g, s->k[K_BOUNDS],
                                           (pgi__gpu_buffer *[]){s->sorted, s->nodes, s->blocks, s->shapes}, &q,
                                           items[m], 64)))
                return st;
        }
        pgi__gpu_timestamp(g, "gpu_bounds");
    }
    if ((st = pgi__gpu_dispatch(g, s->k[K_GATHER],
                                (pgi__gpu_buffer *[]){vsb, lobes, s->sorted, s->nodes, s->out, s->counters, s->shapes},
                                &s->p, (s->p.width + 7) / 8, (s->p.height + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_gather");
    return PGI_OK;
}

/* The counters into the stats; a query stack that overflowed is an error, not a wrong image. */
static pgi_status pb_counters(pb_state *s, pgi_estimator_stats *es) {
    uint32_t c[8];
    pgi_status st = pgi__gpu_download(s->g, s->counters, 0, c, sizeof c);
    if (st) return st;
    if (c[6])
        return pgi__fail(PGI_ERR_INTERNAL, "bvh on the GPU: %u queries overflowed their stack (tree deeper than 64)",
                         c[6]);
    es->reads = pgi__gpu_u64(c);
    es->contributing = pgi__gpu_u64(c + 2);
    es->nodes_visited = pgi__gpu_u64(c + 4);
    es->leaf_size = (int)s->p.leaf;
    return PGI_OK;
}

static pgi_status pb_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *es) {
    pb_state *s = state;
    pgi__gpu *g = s->g;
    pgi_status st;
    memset(es, 0, sizeof *es);
    const pgi_photons *ph = a->photons;
    const int fp = !ph->radius ? FP_FIXED : ph->sax ? FP_ELLIPSOID : FP_SPHERE;
    const pgi_view_samples *vs = a->samples;
    const size_t n = ph->count, ns = vs->count;
    double t0 = pgi__now_ms();
    double box_area = 0.0; /* T_auto's stand-in for the scene's area, only when both are missing */
    if (n && !(a->scene_area > 0.0) && s->desc.bvh.leaf_size <= 0) {
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        const float *P[3] = {ph->px, ph->py, ph->pz};
        for (int d = 0; d < 3; d++)
            for (size_t j = 0; j < n; j++) lo[d] = pgi_minf(lo[d], P[d][j]), hi[d] = pgi_maxf(hi[d], P[d][j]);
        const double ex = hi[0] - lo[0], ey = hi[1] - lo[1], ez = hi[2] - lo[2];
        box_area = 2.0 * (ex * ey + ey * ez + ez * ex);
    }
    double fp_area = 0.0;
    if ((st = pgi__gpu_est_upload_footprints(g, ph, a->threads, "gpu_photons", &s->hfp, &s->hfp_cap, &s->fp,
                                             &fp_area)) ||
        (st = pb_plan(s, n, vs->width, vs->height, a->radius, fp, fp_area, a->scene_area, box_area)) ||
        (st = pgi__gpu_est_upload(g, a, &s->packed, &s->packed_cap, &s->pk, &s->raw, &s->vs, &s->lobes)))
        return st;
    double t1 = pgi__now_ms();
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = pb_record(s, s->raw, fp ? s->fp : NULL, s->vs, s->lobes))) {
        (void)pgi__gpu_submit_wait(g);
        return st;
    }
    double t2 = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    double t3 = pgi__now_ms();
    double build = 0.0, gather = 0.0;
    pgi__gpu_est_add_timings(g, es, gather_passes, &build, &gather);
    if ((st = pgi__gpu_download(g, s->out, 0, a->out_rgb, 3 * ns * sizeof(float))) || (st = pb_counters(s, es)))
        return st;
    double t4 = pgi__now_ms();
    pgi__stats_pass(es, "gpu_upload", t1 - t0);
    pgi__stats_pass(es, "gpu_submit", t3 - t2);
    pgi__stats_pass(es, "gpu_download", t4 - t3);
    if (!pgi__gpu_has_timestamps(g)) build = 0.0, gather = t3 - t2;
    es->build_ms = (t1 - t0) + build;
    es->estimate_ms = gather + (t4 - t3);
    pgi__stats_mem(es, "gpu_host_upload",
                   s->packed_cap * sizeof(pgi__packed_photon) + s->hfp_cap * sizeof(pgi__gpu_footprint) +
                       pgi__gpu_vs_pack_bytes(&s->pk));
    return PGI_OK;
}

static pgi_status pb_device_reserve(void *state, const pgi__gpu_est_inputs *in, pgi__gpu_buffer **out) {
    pb_state *s = state;
    const int fp = !in->footprints ? FP_FIXED : in->footprint_ellipsoids ? FP_ELLIPSOID : FP_SPHERE;
    double area = 0.0;
    s->area_ms = 0.0;
    pgi_status st = pb_plan(s, in->nphotons, in->width, in->height, in->radius, fp, -1.0, in->scene_area, 0.0);
    if (!st && fp != FP_FIXED && s->desc.bvh.leaf_size <= 0 &&
        !(st = pb_footprint_area(s, in->photons, in->footprints, &area)))
        s->p.leaf = pb_t_auto(area, in->scene_area);
    if (st) return st;
    *out = s->out;
    return PGI_OK;
}

static pgi_status pb_device_record(void *state, const pgi__gpu_est_inputs *in) {
    pb_state *s = state;
    if (in->nphotons != s->n)
        return pgi__fail(PGI_ERR_INTERNAL, "bvh on the GPU: recorded on inputs it was not reserved for");
    return pb_record(s, in->photons, in->footprints, in->samples, in->lobes);
}

static pgi_status pb_device_finish(void *state, const pgi_named_value *t, int nt, pgi_estimator_stats *es) {
    pb_state *s = state;
    memset(es, 0, sizeof *es);
    double build = 0.0, gather = 0.0;
    pgi__gpu_est_keep_timings(es, t, nt, own_passes, gather_passes, &build, &gather);
    if (s->area_ms > 0.0) pgi__stats_pass(es, "gpu_footprint_area", s->area_ms);
    es->build_ms = build + s->area_ms;
    es->estimate_ms = gather;
    return pb_counters(s, es);
}


const pgi__gpu_est_vtbl pgi__gpu_est_bvh = {
    .name = "bvh",
    .create = pb_create,
    .run = pb_run,
    .destroy = pb_destroy,
    .device_reserve = pb_device_reserve,
    .device_record = pb_device_record,
    .device_finish = pb_device_finish,
};

#endif /* PGI__HAVE_VULKAN */
