/* hashgrid on the GPU (docs/gpu.md): the CPU hashgrid's cells (edge 2r, or --cell-size; the same
 * cell_coord), kept in a bucket table built on the device, and a gather per view sample with the
 * CPU's contribution math (shaders/gather.glsl mirrors src/estimators/gather.h and bsdf.h).
 *
 * Each frame: the photons (packed as pgi__packed_photon, in photon order) and the view samples
 * (64 bytes each, plus a lobe record per glossy sample) are uploaded; then one command sequence:
 *   hg_count    bucket of each photon's cell (a 32-bit hash of the cell, power-of-two table of at
 *               least as many buckets as photons) as a (bucket, photon) pair, photons per bucket
 *               (atomics)
 *   scan        exclusive prefix sum of the counts: each bucket's start (gpu_scan.h)
 *   sort        the pairs by bucket, stably (gpu_sort.h): every bucket in photon order, so the sums
 *               do not depend on the order the device ran anything in (the same image bit for bit
 *               every run)
 *   hg_reorder  the photons copied in bucket order
 *   hg_gather   per view sample: the cells its sphere overlaps, each cell's bucket, the bucket's
 *               photons of that cell, contribution test and sum; reads/contributing/cells counted
 * and the radiance is downloaded. Same contributing photons as brute; the sums differ from
 * brute's only by their order (and the device's division, sqrt and pow, within 1e-4). */
#include "gpu/gpu_estimator.h"
#include "gpu/gpu_scan.h"
#include "gpu/gpu_sort.h"

#include <stdio.h>
#include <string.h>

#include "core/core.h"
#include "estimators/estimator_internal.h"

#ifndef PGI__HAVE_VULKAN

const pgi__gpu_est_vtbl pgi__gpu_est_hashgrid = PGI__GPU_EST_NONE("hashgrid");

#else

#include "gpu/spirv.h"

#define GGX_NMU PGI__GGX_NMU

typedef pgi__gpu_vs gpu_vs;
typedef pgi__gpu_lobe gpu_lobe;

/* shaders/hashgrid.glsl Push */
typedef struct {
    float inv_cell, r, r2;
    uint32_t n, mask, width, height, kernel;
    float scale;
    uint32_t pad[3];
} hg_push;
_Static_assert(sizeof(hg_push) == 48 && offsetof(hg_push, n) == 12 && offsetof(hg_push, scale) == 32,
               "hashgrid.glsl Push");

enum { K_COUNT, K_REORDER, K_GATHER, K_N };

typedef struct {
    pgi__gpu *g;
    pgi_estimator_desc desc;
    pgi__gpu_kernel *k[K_N];
    pgi__gpu_buffer *photons, *sorted, *start, *bucket_of, *vs, *lobes, *out, *counters;
    pgi__gpu_sort sort; /* (bucket, photon) pairs by bucket */
    /* host-side upload arrays */
    pgi__packed_photon *packed;
    size_t packed_cap;
    pgi__gpu_vs_pack pk; /* the view samples in the shaders' form */
    pgi__gpu_scan scan;  /* the buckets' starts */
    /* hg_reserve's: buckets; photons reserved for by hg_device_reserve */
    size_t nb, dev_n;
} hg_state;

static void hg_destroy(void *state) {
    hg_state *s = state;
    if (!s) return;
    for (int i = 0; i < K_N; i++) pgi__gpu_kernel_destroy(s->g, s->k[i]);
    pgi__gpu_buffer *b[] = {s->photons, s->sorted, s->start, s->bucket_of, s->vs, s->lobes, s->out, s->counters};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(s->g, b[i]);
    pgi__gpu_scan_destroy(&s->scan);
    pgi__gpu_sort_destroy(&s->sort);
    pgi__afree(s->packed);
    pgi__gpu_vs_pack_free(&s->pk);
    free(s);
}

static pgi_status hg_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    *state = NULL;
    if (d->subsample > 1)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "hashgrid on the GPU: --subsample is not supported (CPU only)");
    hg_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->g = g;
    s->desc = *d;
    static const pgi__gpu_kernel_spec k[K_N] = {
        [K_COUNT] = PGI__GPU_KERNEL(hg_count, 3, sizeof(hg_push)),
        [K_REORDER] = PGI__GPU_KERNEL(hg_reorder, 3, sizeof(hg_push)),
        [K_GATHER] = PGI__GPU_KERNEL(hg_gather, 6, sizeof(hg_push)),
    };
    pgi_status st = pgi__gpu_kernels_create(g, k, K_N, 0, s->k);
    if (!st) st = pgi__gpu_scan_create(g, "gpu_hash", &s->scan);
    if (!st) st = pgi__gpu_sort_create(g, "gpu_photon_index", &s->sort);
    if (st) {
        hg_destroy(s);
        return st;
    }
    *state = s;
    return PGI_OK;
}

static int bits_for(size_t n) {
    int b = 0;
    while (b < 32 && ((size_t)1 << b) < n) b++;
    return b;
}

/* The buckets' table and its scan (of `start`, buckets + 1 words) for n photons, then every
 * buffer of a frame of ns samples but the inputs'. */
static pgi_status hg_reserve(hg_state *s, size_t n, size_t ns) {
    pgi__gpu *g = s->g;
    pgi_status st;
    if (n > UINT32_MAX / 2 || ns > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "hashgrid on the GPU: at most 2^31 photons and 2^30 view samples");
    size_t nb = 1024;
    while (nb < n) nb <<= 1;
    if ((st = pgi__gpu_scan_reserve(&s->scan, nb + 1))) return st;
    s->nb = nb;
    const size_t psz = sizeof(pgi__packed_photon);
    if ((st = pgi__gpu_buffer_reserve(g, &s->sorted, (n + 1) * psz, "gpu_sorted_photons")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->start, (nb + 1) * 4, "gpu_hash")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->bucket_of, (n + 1) * 8, "gpu_photon_index")) ||
        (st = pgi__gpu_sort_reserve(&s->sort, n)) ||
        (st = pgi__gpu_buffer_reserve(g, &s->out, (3 * ns + 1) * sizeof(float), "gpu_radiance")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counters, 6 * sizeof(uint32_t), "gpu_hash")))
        return st;
    return PGI_OK;
}

/* Records build and gather (hg_reserve done for these sizes) into the open sequence. */
static pgi_status hg_record(hg_state *s, pgi__gpu_buffer *photons, size_t n, pgi__gpu_buffer *vsb,
                            pgi__gpu_buffer *lobes, int width, int height, float r) {
    pgi__gpu *g = s->g;
    pgi_status st;
    const size_t nb = s->nb;
    const float cell = s->desc.hashgrid.cell_size;
    if (cell > 0.f && cell < r / 64.f)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "hashgrid: --cell-size must be 0 (default: 2r) or at least r/64 = %g, got %g",
                         (double)(r / 64.f), (double)cell);
    const float cell_edge = cell > 0.f ? cell : 2.f * r;
    hg_push p = {.inv_cell = 1.f / cell_edge,
                 .r = r,
                 .r2 = r * r,
                 .n = (uint32_t)n,
                 .mask = (uint32_t)(nb - 1),
                 .width = (uint32_t)width,
                 .height = (uint32_t)height,
                 .kernel = (uint32_t)s->desc.kernel,
                 .scale = pgi__kernel_norm(s->desc.kernel)};
    pgi__gpu_buffer *keys, *order;
    if ((st = pgi__gpu_fill(g, s->start, 0, (nb + 1) * 4, 0)) || (st = pgi__gpu_fill(g, s->counters, 0, 6 * 4, 0)) ||
        (st =
             pgi__gpu_dispatch_1d(g, s->k[K_COUNT], (pgi__gpu_buffer *[]){photons, s->start, s->bucket_of}, &p, n, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_count");
    if ((st = pgi__gpu_scan_record(&s->scan, s->start))) return st;
    pgi__gpu_timestamp(g, "gpu_scan");
    if ((st = pgi__gpu_sort_record(&s->sort, s->bucket_of, n, 0, bits_for(nb), &keys, &order))) return st;
    pgi__gpu_timestamp(g, "gpu_sort");
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_REORDER], (pgi__gpu_buffer *[]){photons, order, s->sorted}, &p, n, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_reorder");
    if ((st = pgi__gpu_dispatch(g, s->k[K_GATHER],
                                (pgi__gpu_buffer *[]){vsb, lobes, s->start, s->sorted, s->out, s->counters}, &p,
                                ((uint32_t)width + 7) / 8, ((uint32_t)height + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_gather");
    return PGI_OK;
}

static int hg_label(const char *name) {
    static const char *const own[] = {"gpu_count", "gpu_scan", "gpu_sort", "gpu_reorder", "gpu_gather"};
    for (size_t i = 0; i < sizeof own / sizeof own[0]; i++)
        if (strcmp(name, own[i]) == 0) return 1;
    return 0;
}

/* The counters and the device passes (t: the sequence's timings) into es; *build, *gather the
 * device time of the build and of the gather. */
static pgi_status hg_counters(hg_state *s, const pgi_named_value *t, int nt, pgi_estimator_stats *es, double *build,
                              double *gather) {
    uint32_t c[6];
    pgi_status st = pgi__gpu_download(s->g, s->counters, 0, c, sizeof c);
    if (st) return st;
    *build = *gather = 0.0;
    for (int i = 0; i < nt; i++) {
        if (!hg_label(t[i].name)) continue;
        pgi__stats_pass(es, t[i].name, t[i].value);
        if (strcmp(t[i].name, "gpu_gather") == 0) *gather += t[i].value;
        else *build += t[i].value;
    }
    es->reads = pgi__gpu_u64(c);
    es->contributing = pgi__gpu_u64(c + 2);
    es->nodes_visited = pgi__gpu_u64(c + 4);
    return PGI_OK;
}

static pgi_status hg_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *es) {
    hg_state *s = state;
    pgi__gpu *g = s->g;
    pgi_status st;
    memset(es, 0, sizeof *es);
    if (a->photons->radius)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "hashgrid on the GPU: per-photon footprints are not supported");
    const pgi_photons *ph = a->photons;
    const pgi_view_samples *vs = a->samples;
    const size_t n = ph->count, ns = vs->count;

    /* upload: photons packed in photon order, the view samples and lobes */
    double t0 = pgi__now_ms();
    if ((st = pgi__gpu_est_upload(g, a, &s->packed, &s->packed_cap, &s->pk, &s->photons, &s->vs, &s->lobes)) ||
        (st = hg_reserve(s, n, ns)))
        return st;
    double t1 = pgi__now_ms();

    /* build and gather: one sequence */
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = hg_record(s, s->photons, n, s->vs, s->lobes, vs->width, vs->height, a->radius))) {
        /* close the sequence so that the next frame can begin one */
        (void)pgi__gpu_submit_wait(g);
        return st;
    }
    double t2 = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    double t3 = pgi__now_ms();
    if ((st = pgi__gpu_download(g, s->out, 0, a->out_rgb, 3 * ns * sizeof(float)))) return st;
    double t4 = pgi__now_ms();

    /* stats: host passes (wall clock) and the device's (timestamps) */
    pgi_named_value t[16];
    int nt = pgi__gpu_timings(g, t, 16);
    double gpu_build = 0.0, gpu_gather = 0.0;
    pgi__stats_pass(es, "gpu_upload", t1 - t0);
    if ((st = hg_counters(s, t, nt, es, &gpu_build, &gpu_gather))) return st;
    pgi__stats_pass(es, "gpu_submit", t3 - t2);
    pgi__stats_pass(es, "gpu_download", t4 - t3);
    if (!pgi__gpu_has_timestamps(g)) { /* the CPU-timed sequence (one entry) is the gather's */
        gpu_build = 0.0;
        gpu_gather = t3 - t2;
    }
    es->build_ms = (t1 - t0) + gpu_build;
    es->estimate_ms = gpu_gather + (t4 - t3);
    /* host memory of the upload arrays (the device's buffers are listed by the renderer) */
    pgi__stats_mem(es, "gpu_host_upload",
                   s->packed_cap * sizeof(pgi__packed_photon) + s->pk.hvs_cap * sizeof(gpu_vs) +
                       s->pk.hlobes_cap * sizeof(gpu_lobe) + s->pk.lobe_of_cap * sizeof(uint32_t));
    return PGI_OK;
}

/* ---- device inputs (the GPU frame) */

static pgi_status hg_device_reserve(void *state, const pgi__gpu_est_inputs *in, pgi__gpu_buffer **out) {
    hg_state *s = state;
    pgi_status st = hg_reserve(s, in->nphotons, (size_t)in->width * (size_t)in->height);
    if (st) return st;
    s->dev_n = in->nphotons;
    *out = s->out;
    return PGI_OK;
}

static pgi_status hg_device_record(void *state, const pgi__gpu_est_inputs *in) {
    hg_state *s = state;
    if (in->nphotons != s->dev_n)
        return pgi__fail(PGI_ERR_INTERNAL, "hashgrid on the GPU: reserved for %zu photons, given %zu", s->dev_n,
                         in->nphotons);
    return hg_record(s, in->photons, in->nphotons, in->samples, in->lobes, in->width, in->height, in->radius);
}

static pgi_status hg_device_finish(void *state, const pgi_named_value *t, int nt, pgi_estimator_stats *es) {
    hg_state *s = state;
    memset(es, 0, sizeof *es);
    double build, gather;
    pgi_status st = hg_counters(s, t, nt, es, &build, &gather);
    es->build_ms = build;
    es->estimate_ms = gather;
    return st;
}


const pgi__gpu_est_vtbl pgi__gpu_est_hashgrid = {
    .name = "hashgrid",
    .create = hg_create,
    .run = hg_run,
    .destroy = hg_destroy,
    .device_reserve = hg_device_reserve,
    .device_record = hg_device_record,
    .device_finish = hg_device_finish,
};

#endif /* PGI__HAVE_VULKAN */
