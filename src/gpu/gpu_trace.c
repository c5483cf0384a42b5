/* Photon tracing on the GPU (gpu_trace.h, shaders/trace.comp, trace_compact.comp, trace_scale.comp).
 *
 * A run is a loop of batches, each one command sequence:
 *   trace         paths [path, path + batch): photons to per-path slots, counts, rays (atomic sum)
 *   scan          exclusive prefix sum of the counts (gpu_scan.h)
 *   compact       the slots in path order into the photon buffer after the photons already stored,
 *                 cut at the photons wanted; the filling path's index
 * then the batch's total, filling path and rays are read back; the next batch is sized by the
 * yield seen so far (an upper bound, 3 sigma of the photon count, as the CPU tracer: the batches
 * undershoot, so that few paths are traced for nothing). Last, trace_scale divides the flux by
 * the paths emitted. */
#include "gpu/gpu_trace.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/core.h"
#include "estimators/packed.h"
#include "gpu/gpu_estimator.h"
#include "photon/radius.h"
#include "scene/scene_internal.h"

#ifdef PGI__HAVE_VULKAN
#include "gpu/gpu_scan.h"
#include "gpu/spirv.h"
#endif

#define MAX_BATCH (1u << 20)        /* paths a launch */
#define MAX_SLOTS ((size_t)1 << 21) /* photon slots a launch (x 36 bytes: 72 MiB) */

pgi_status pgi__gpu_trace_check(const pgi__gpu_trace_desc *d) {
    if (d->radius_policy < PGI_RADIUS_FIXED || d->radius_policy >= PGI_RADIUS_POLICY_COUNT_)
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon tracing on the GPU: unknown radius policy %d", d->radius_policy);
    if (d->radius_policy != PGI_RADIUS_FIXED &&
        !(d->r_max > 0.f && d->r_min >= 0.f && d->r_min <= d->r_max && d->smoothing >= 0.f && isfinite(d->r_max)))
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "photon tracing on the GPU: --radius-policy %s needs 0 <= r_min <= r_max, r_max > 0 and "
                         "smoothing >= 0 (got %g, %g, %g)",
                         d->radius_policy == PGI_RADIUS_PATH ? "path" : "differentials", (double)d->r_min,
                         (double)d->r_max, (double)d->smoothing);
    if (d->emission != PGI_EMISSION_UNIFORM)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "photon tracing on the GPU: --emission %s is not supported (only uniform; use --device cpu)",
                         d->emission == PGI_EMISSION_GUIDED ? "guided"
                         : d->emission == PGI_EMISSION_AUTO ? "auto"
                                                            : "portal");
    if (d->store != PGI_STORE_ALL)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "photon tracing on the GPU: --store view is not supported (only all; use --device cpu)");
    if (d->bounces < 0 || d->bounces > 64)
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon tracing on the GPU: bounces %d outside 0..64", d->bounces);
    return PGI_OK;
}

#ifndef PGI__HAVE_VULKAN

pgi_status pgi__gpu_trace_create(pgi__gpu *g, pgi__gpu_scene *gs, pgi__gpu_trace **out) {
    (void)g, (void)gs;
    *out = NULL;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "photon tracing on the GPU: this build has no Vulkan backend");
}
void pgi__gpu_trace_destroy(pgi__gpu_trace *t) { (void)t; }
pgi_status pgi__gpu_trace_run(pgi__gpu_trace *t, const pgi_scene *s, const pgi__gpu_trace_desc *d,
                              pgi__gpu_trace_result *r) {
    (void)t, (void)s, (void)d;
    memset(r, 0, sizeof *r);
    return pgi__fail(PGI_ERR_UNSUPPORTED, "photon tracing on the GPU: this build has no Vulkan backend");
}
pgi__gpu_buffer *pgi__gpu_trace_photons(const pgi__gpu_trace *t) {
    (void)t;
    return NULL;
}
pgi__gpu_buffer *pgi__gpu_trace_footprints(const pgi__gpu_trace *t, int *ellipsoids) {
    (void)t;
    if (ellipsoids) *ellipsoids = 0;
    return NULL;
}
pgi_status pgi__gpu_trace_download(pgi__gpu_trace *t, pgi_photons *ph) {
    (void)t, (void)ph;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "photon tracing on the GPU: this build has no Vulkan backend");
}
void pgi__gpu_trace_set_max_batch(pgi__gpu_trace *t, uint32_t paths) { (void)t, (void)paths; }

#else

typedef struct {
    pgi__gpu_scene_push scene;
    uint32_t path0_lo, path0_hi, npaths, bounces, seed_lo, seed_hi, nemit, pad;
} trace_push;
/* trace_fp.comp: trace.comp's push, then the radius policy's parameters (pgi__fp_params) */
typedef struct {
    trace_push t;
    uint32_t policy;
    float r_min, r_max, smoothing, smoothing_caustic, delta;
    uint32_t pad[2];
} trace_fp_push;
_Static_assert(offsetof(trace_fp_push, policy) == 96 && offsetof(trace_fp_push, delta) == 116,
               "differentials.glsl FpParams after trace.glsl's push");
typedef struct {
    uint32_t npaths, bounces, base, remaining;
} compact_push;
typedef struct {
    compact_push c;
    float bin_w; /* r_max / 14: the footprint histogram's bins (trace.c's float) */
    uint32_t pad[3];
} compact_fp_push;
typedef struct {
    uint32_t n;
    float inv;
    uint32_t pad[2];
} scale_push;

_Static_assert(sizeof(trace_push) == 96 && sizeof(trace_fp_push) == 128 && sizeof(pgi__packed_photon) == 36,
               "trace.glsl's push and photons");

enum { K_TRACE, K_COMPACT, K_SCALE, K_TRACE_FP, K_COMPACT_FP, K_N };

struct pgi__gpu_trace {
    pgi__gpu *g;
    pgi__gpu_scene *scene; /* borrowed */
    pgi__gpu_kernel *k[K_N];
    pgi__gpu_buffer *slots, *counts, *counters, *result, *photons;
    pgi__gpu_buffer *fslots, *footprints, *hist; /* radius policies: the footprints' slots, records, histogram */
    pgi__gpu_scan scan;                          /* each path's first slot in the compacted photons */
    pgi__fp_params fp;                           /* the last run's policy (PGI_RADIUS_FIXED: no footprints) */
    uint32_t count;
    uint64_t emitted;
    uint32_t max_batch;
    double prior_paths, prior_photons; /* the last run's yield seeds the next run's batches */
};

void pgi__gpu_trace_destroy(pgi__gpu_trace *t) {
    if (!t) return;
    for (int i = 0; i < K_N; i++) pgi__gpu_kernel_destroy(t->g, t->k[i]);
    pgi__gpu_buffer *b[] = {t->slots, t->counts, t->counters, t->result, t->photons, t->fslots, t->footprints, t->hist};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(t->g, b[i]);
    pgi__gpu_scan_destroy(&t->scan);
    free(t);
}

pgi_status pgi__gpu_trace_create(pgi__gpu *g, pgi__gpu_scene *gs, pgi__gpu_trace **out) {
    *out = NULL;
    pgi__gpu_trace *t = calloc(1, sizeof *t);
    if (!t) return pgi__fail(PGI_ERR_OOM, "out of memory creating the GPU photon tracer");
    t->g = g;
    t->scene = gs;
    t->max_batch = MAX_BATCH;
    static const pgi__gpu_kernel_spec k[K_N] = {
        [K_TRACE] = PGI__GPU_KERNEL(trace, 15, sizeof(trace_push)),
        [K_COMPACT] = PGI__GPU_KERNEL(trace_compact, 4, sizeof(compact_push)),
        [K_SCALE] = PGI__GPU_KERNEL(trace_scale, 1, sizeof(scale_push)),
        [K_TRACE_FP] = PGI__GPU_KERNEL(trace_fp, 16, sizeof(trace_fp_push)),
        [K_COMPACT_FP] = PGI__GPU_KERNEL(trace_compact_fp, 4, sizeof(compact_fp_push)),
    };
    pgi_status st = pgi__gpu_kernels_create(g, k, K_N, 0, t->k);
    if (!st) st = pgi__gpu_scan_create(g, "gpu_trace_scratch", &t->scan);
    if (!st) st = pgi__gpu_buffer_reserve(g, &t->counters, 16, "gpu_trace_scratch");
    if (!st) st = pgi__gpu_buffer_reserve(g, &t->result, 16, "gpu_trace_scratch");
    if (st) {
        pgi__gpu_trace_destroy(t);
        return st;
    }
    *out = t;
    return PGI_OK;
}

void pgi__gpu_trace_set_max_batch(pgi__gpu_trace *t, uint32_t paths) {
    t->max_batch = paths == 0 ? MAX_BATCH : paths > MAX_BATCH ? MAX_BATCH : paths;
}

pgi__gpu_buffer *pgi__gpu_trace_photons(const pgi__gpu_trace *t) { return t->photons; }

pgi__gpu_buffer *pgi__gpu_trace_footprints(const pgi__gpu_trace *t, int *ellipsoids) {
    if (ellipsoids) *ellipsoids = t->fp.policy == PGI_RADIUS_DIFFERENTIALS;
    return t->fp.policy != PGI_RADIUS_FIXED ? t->footprints : NULL;
}

/* One batch: paths [path, path + n) traced, their photons compacted after `base` (at most
 * `remaining`). Out: the batch's photons (all of them, before the cut), the filling path (relative;
 * UINT32_MAX: none), rays, device ms. */
static pgi_status run_batch(pgi__gpu_trace *t, const pgi__gpu_trace_desc *d, uint64_t path, uint32_t n, uint32_t base,
                            uint32_t remaining, uint32_t *total, uint32_t *fill, uint32_t *rays, double *ms) {
    pgi__gpu *g = t->g;
    pgi_status st;
    const size_t ncounts = (size_t)n + 1, nslots = (size_t)n * (size_t)d->bounces;
    const int fp = t->fp.policy != PGI_RADIUS_FIXED;
    if (fp && (st = pgi__gpu_buffer_reserve(g, &t->fslots, nslots * sizeof(pgi__gpu_footprint), "gpu_trace_scratch")))
        return st;
    if ((st = pgi__gpu_buffer_reserve(g, &t->slots, nslots * sizeof(pgi__packed_photon), "gpu_trace_scratch")) ||
        (st = pgi__gpu_buffer_reserve(g, &t->counts, ncounts * 4, "gpu_trace_scratch")) ||
        (st = pgi__gpu_scan_reserve(&t->scan, ncounts)))
        return st;
    pgi__gpu_buffer *b[PGI__GPU_SCENE_NBUF + 5];
    pgi__gpu_scene_buffers(t->scene, b);
    uint32_t nemit = 0;
    b[PGI__GPU_SCENE_NBUF] = pgi__gpu_scene_emit(t->scene, &nemit);
    b[PGI__GPU_SCENE_NBUF + 1] = t->slots;
    b[PGI__GPU_SCENE_NBUF + 2] = t->counts;
    b[PGI__GPU_SCENE_NBUF + 3] = t->counters;
    b[PGI__GPU_SCENE_NBUF + 4] = t->fslots;
    trace_push tp = {.path0_lo = (uint32_t)path,
                     .path0_hi = (uint32_t)(path >> 32),
                     .npaths = n,
                     .bounces = (uint32_t)d->bounces,
                     .seed_lo = (uint32_t)d->seed,
                     .seed_hi = (uint32_t)(d->seed >> 32),
                     .nemit = nemit};
    pgi__gpu_scene_info(t->scene, &tp.scene);
    const trace_fp_push fpp = {.t = tp,
                               .policy = (uint32_t)t->fp.policy,
                               .r_min = t->fp.r_min,
                               .r_max = t->fp.r_max,
                               .smoothing = t->fp.smoothing,
                               .smoothing_caustic = t->fp.smoothing_caustic,
                               .delta = t->fp.delta};
    compact_push cp = {n, (uint32_t)d->bounces, base, remaining};
    const compact_fp_push cfp = {.c = cp, .bin_w = t->fp.r_max / 14.f};
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = pgi__gpu_fill(g, t->counts, 0, ncounts * 4, 0)) || (st = pgi__gpu_fill(g, t->counters, 0, 16, 0)) ||
        (st = pgi__gpu_fill(g, t->result, 0, 16, 0xFFFFFFFFu)) ||
        (fp && base == 0 && (st = pgi__gpu_fill(g, t->hist, 0, PGI_FOOTPRINT_BINS * 4, 0))) || /* none kept yet */
        (st = fp ? pgi__gpu_dispatch_1d(g, t->k[K_TRACE_FP], b, &fpp, n, 64)
                 : pgi__gpu_dispatch_1d(g, t->k[K_TRACE], b, &tp, n, 64)))
        goto fail;
    pgi__gpu_timestamp(g, "gpu_trace");
    if ((st = pgi__gpu_scan_record(&t->scan, t->counts))) goto fail;
    if ((st = pgi__gpu_dispatch_1d(g, t->k[K_COMPACT],
                                   (pgi__gpu_buffer *[]){t->slots, t->counts, t->photons, t->result}, &cp, n, 64)) ||
        (fp &&
         (st = pgi__gpu_dispatch_1d(g, t->k[K_COMPACT_FP],
                                    (pgi__gpu_buffer *[]){t->fslots, t->counts, t->footprints, t->hist}, &cfp, n, 64))))
        goto fail;
    pgi__gpu_timestamp(g, "gpu_trace_compact");
    double t0 = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    double t1 = pgi__now_ms();
    uint32_t c[4];
    if ((st = pgi__gpu_download(g, t->counts, (size_t)n * 4, total, 4)) ||
        (st = pgi__gpu_download(g, t->result, 0, fill, 4)) || (st = pgi__gpu_download(g, t->counters, 0, c, 16)))
        return st;
    *rays = c[0];
    pgi_named_value tv[8];
    int nt = pgi__gpu_timings(g, tv, 8);
    *ms = 0.0;
    for (int i = 0; i < nt; i++) *ms += tv[i].value;
    if (!pgi__gpu_has_timestamps(g)) *ms = t1 - t0;
    return PGI_OK;
fail:
    (void)pgi__gpu_submit_wait(g);
    return st;
}

pgi_status pgi__gpu_trace_run(pgi__gpu_trace *t, const pgi_scene *s, const pgi__gpu_trace_desc *d,
                              pgi__gpu_trace_result *r) {
    memset(r, 0, sizeof *r);
    t->count = 0;
    t->emitted = 0;
    pgi_status st = pgi__gpu_trace_check(d);
    if (st) return st;
    const double w0 = pgi__now_ms();
    if (pgi__gpu_scene_needs_update(t->scene, s) && (st = pgi__gpu_scene_update(t->scene, s))) return st;
    if (d->photons > UINT32_MAX / 2)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "photon tracing on the GPU: at most 2^31 photons (%u requested)",
                         d->photons);
    const uint32_t want = d->photons;
    pgi__fp_params_init(&t->fp, d->radius_policy, d->r_min, d->r_max, d->smoothing, want, pgi__scene_diagonal(s));
    const int fp = d->radius_policy != PGI_RADIUS_FIXED;
    /* the buffers exist even when nothing is stored (a pass may bind them); the footprints' only
       with a policy */
    if ((st = pgi__gpu_buffer_reserve(t->g, &t->photons, ((size_t)want + 1) * sizeof(pgi__packed_photon),
                                      "gpu_photons")))
        return st;
    if (fp && ((st = pgi__gpu_buffer_reserve(t->g, &t->footprints, ((size_t)want + 1) * sizeof(pgi__gpu_footprint),
                                             "gpu_footprints")) ||
               (st = pgi__gpu_buffer_reserve(t->g, &t->hist, PGI_FOOTPRINT_BINS * 4, "gpu_trace_scratch"))))
        return st;
    if (!fp) {
        pgi__gpu_buffer *b[] = {t->footprints, t->fslots, t->hist};
        for (int i = 0; i < 3; i++) pgi__gpu_buffer_destroy(t->g, b[i]);
        t->footprints = t->fslots = t->hist = NULL;
    }
    uint32_t nemit = 0;
    (void)pgi__gpu_scene_emit(t->scene, &nemit);
    if (d->bounces < 1 || d->photons == 0 || nemit == 0) return PGI_OK;
    uint32_t max_batch = t->max_batch;
    /* with footprints (48 bytes a slot besides the photon's 36), half the slots */
    const size_t max_slots = fp ? MAX_SLOTS / 2 : MAX_SLOTS;
    if ((size_t)max_batch * (size_t)d->bounces > max_slots) max_batch = (uint32_t)(max_slots / (size_t)d->bounces);
    const uint64_t max_paths = 64ull * want + (1u << 20);
    double seen_paths = t->prior_paths, seen_photons = t->prior_photons, frame_paths = 0, frame_photons = 0;
    uint64_t path = 0, traced = 0, rays = 0;
    uint32_t count = 0;
    double ms = 0.0;
    while (count < want && path < max_paths) {
        const uint32_t remaining = want - count;
        double b;
        if (seen_photons < 64.0) {
            /* no estimate yet: a pilot of an eighth of the photons' paths at most one a path (a scene
               storing nearly nothing grows the pilots: each as many paths as all before it) */
            b = (double)remaining / 8.0 + 64.0;
            if (b > 65536.0) b = 65536.0;
            if (b < seen_paths) b = seen_paths;
        } else {
            const double y = seen_photons / seen_paths * (1.0 + 3.0 / sqrt(seen_photons));
            b = (double)remaining / y + 1.0;
        }
        if (b < 32.0) b = 32.0;
        if (b > (double)max_batch) b = (double)max_batch;
        if (b > (double)(max_paths - path)) b = (double)(max_paths - path);
        const uint32_t n = (uint32_t)b;
        uint32_t total = 0, fill = UINT32_MAX, brays = 0;
        double bms = 0.0;
        if ((st = run_batch(t, d, path, n, count, remaining, &total, &fill, &brays, &bms))) return st;
        r->batches++;
        ms += bms;
        rays += brays;
        traced += n;
        seen_paths += n;
        seen_photons += total;
        frame_paths += n;
        frame_photons += total;
        if (total >= remaining) {
            if (fill >= n) return pgi__fail(PGI_ERR_INTERNAL, "photon tracing on the GPU: no filling path found");
            count = want;
            path += (uint64_t)fill + 1;
        } else {
            count += total;
            path += n;
        }
    }
    t->prior_paths = frame_paths;
    t->prior_photons = frame_photons;
    /* the flux over the paths emitted */
    if (count > 0 && path > 0) {
        scale_push sp = {count, (float)(1.0 / (double)path), {0}};
        if ((st = pgi__gpu_begin(t->g))) return st;
        pgi__gpu_timestamp(t->g, "start");
        if ((st = pgi__gpu_dispatch_1d(t->g, t->k[K_SCALE], (pgi__gpu_buffer *[]){t->photons}, &sp, count, 64))) {
            (void)pgi__gpu_submit_wait(t->g);
            return st;
        }
        pgi__gpu_timestamp(t->g, "gpu_trace_scale");
        double t0 = pgi__now_ms();
        if ((st = pgi__gpu_submit_wait(t->g))) return st;
        double t1 = pgi__now_ms();
        pgi_named_value tv[4];
        int nt = pgi__gpu_timings(t->g, tv, 4);
        if (!pgi__gpu_has_timestamps(t->g)) ms += t1 - t0;
        else
            for (int i = 0; i < nt; i++) ms += tv[i].value;
    }
    if (fp && count > 0) {
        uint32_t h[PGI_FOOTPRINT_BINS];
        if ((st = pgi__gpu_download(t->g, t->hist, 0, h, sizeof h))) return st;
        for (int i = 0; i < PGI_FOOTPRINT_BINS; i++) r->footprint_hist[i] = h[i];
    }
    t->count = count;
    t->emitted = path;
    r->count = count;
    r->emitted = path;
    r->paths_traced = traced;
    r->paths_discarded = traced - path;
    r->rays = rays;
    r->trace_ms = ms;
    r->wall_ms = pgi__now_ms() - w0;
    return PGI_OK;
}

/* The footprints into ph->radius, sax..sbz (where ph has them) and the normals. */
static pgi_status download_footprints(pgi__gpu_trace *t, pgi_photons *ph) {
    pgi__gpu_footprint *f = malloc((size_t)t->count * sizeof *f);
    if (!f) return pgi__fail(PGI_ERR_OOM, "out of memory downloading %u photon footprints", t->count);
    pgi_status st = pgi__gpu_download(t->g, t->footprints, 0, f, (size_t)t->count * sizeof *f);
    for (size_t j = 0; !st && j < t->count; j++) {
        ph->radius[j] = f[j].r;
        ph->nx[j] = f[j].nx, ph->ny[j] = f[j].ny, ph->nz[j] = f[j].nz;
        if (ph->sax) {
            ph->sax[j] = f[j].ax, ph->say[j] = f[j].ay, ph->saz[j] = f[j].az;
            ph->sbx[j] = f[j].bx, ph->sby[j] = f[j].by, ph->sbz[j] = f[j].bz;
        }
    }
    free(f);
    return st;
}

pgi_status pgi__gpu_trace_download(pgi__gpu_trace *t, pgi_photons *ph) {
    if (t->count > ph->capacity)
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon buffer holds %zu photons, the GPU traced %u", ph->capacity,
                         t->count);
    ph->count = 0;
    ph->emitted = t->emitted;
    if (t->count == 0) return PGI_OK;
    pgi__packed_photon *p = malloc((size_t)t->count * sizeof *p);
    if (!p) return pgi__fail(PGI_ERR_OOM, "out of memory downloading %u photons", t->count);
    pgi_status st = pgi__gpu_download(t->g, t->photons, 0, p, (size_t)t->count * sizeof *p);
    if (!st && t->fp.policy != PGI_RADIUS_FIXED && ph->radius) st = download_footprints(t, ph);
    if (!st) {
        for (size_t j = 0; j < t->count; j++) {
            ph->px[j] = p[j].px, ph->py[j] = p[j].py, ph->pz[j] = p[j].pz;
            ph->dx[j] = p[j].dx, ph->dy[j] = p[j].dy, ph->dz[j] = p[j].dz;
            ph->fr[j] = p[j].fr, ph->fg[j] = p[j].fg, ph->fb[j] = p[j].fb;
            if (t->fp.policy == PGI_RADIUS_FIXED || !ph->radius) ph->nx[j] = ph->ny[j] = ph->nz[j] = 0.f;
        }
        ph->count = t->count;
    }
    free(p);
    return st;
}

#endif /* PGI__HAVE_VULKAN */
