/* The registry of GPU estimators (gpu_estimator.h). */
#include "gpu/gpu_estimator.h"

#include <string.h>

#include "core/core.h"
#include "estimators/estimator_internal.h"

/* The GPU half of each CPU estimator that has one (the same name), with the options it takes on the
 * device: the PGI_EST_CAP_* it honours there (the CPU version's others are refused by name before it
 * is created, src/pipeline/render.c device_check). */
static const struct {
    const pgi__gpu_est_vtbl *vt;
    unsigned caps;
} k_gpu_estimators[] = {
    {&pgi__gpu_est_hashgrid, PGI_EST_CAP_KERNELS},
    {&pgi__gpu_est_bvh, PGI_EST_CAP_PHOTON_RADIUS},
    {&pgi__gpu_est_cluster, 0},
    {&pgi__gpu_est_cluster_cone, 0},
    {&pgi__gpu_est_cluster_trivial, 0},
    {&pgi__gpu_est_directional, 0},
    {&pgi__gpu_est_tiled, PGI_EST_CAP_KERNELS},
    {&pgi__gpu_est_bounds3d, PGI_EST_CAP_KERNELS},
    {&pgi__gpu_est_bounds25d, PGI_EST_CAP_KERNELS},
};
#define NGPU (sizeof k_gpu_estimators / sizeof k_gpu_estimators[0])

static size_t find(const char *name) {
    size_t i = 0;
    while (name && i < NGPU && strcmp(k_gpu_estimators[i].vt->name, name) != 0) i++;
    return name ? i : NGPU;
}

const pgi__gpu_est_vtbl *pgi__gpu_est_find(const char *name) {
    const size_t i = find(name);
    return i < NGPU ? k_gpu_estimators[i].vt : NULL;
}

unsigned pgi__gpu_est_caps(const char *name) {
    const size_t i = find(name);
    return i < NGPU ? k_gpu_estimators[i].caps : 0;
}

void pgi__gpu_est_names(char *buf, size_t size) {
    if (size) buf[0] = 0;
    for (size_t i = 0; i < NGPU; i++) pgi__list_append(buf, size, k_gpu_estimators[i].vt->name);
}

pgi_status pgi__gpu_pack_samples(pgi__gpu_vs_pack *s, const pgi_view_samples *vs, int threads, size_t *nlobes) {
    pgi_status st;
    const size_t n = vs->count;
    if ((st = pgi__ensure((void **)&s->hvs, &s->hvs_cap, n + 1, sizeof(pgi__gpu_vs))) ||
        (st = pgi__ensure((void **)&s->lobe_of, &s->lobe_of_cap, n + 1, sizeof(uint32_t))))
        return st;
    size_t nl = 0;
    for (size_t i = 0; i < n; i++) {
        const uint8_t f = vs->flags[i];
        s->lobe_of[i] = (uint32_t)nl;
        if ((f & PGI_VS_VALID) && !(f & PGI_VS_LAMBERT)) nl++;
    }
    if ((st = pgi__ensure((void **)&s->hlobes, &s->hlobes_cap, nl + 1, sizeof(pgi__gpu_lobe)))) return st;
#pragma omp parallel for schedule(dynamic, 256) num_threads(pgi__threads(threads))
    for (long long ii = 0; ii < (long long)n; ii++) {
        size_t i = (size_t)ii;
        pgi__gpu_vs *o = &s->hvs[i];
        memset(o, 0, sizeof *o);
        o->flags = vs->flags[i];
        if (!(vs->flags[i] & PGI_VS_VALID)) continue;
        pgi__vs v;
        pgi__vs_load(vs, i, &v);
        *o = (pgi__gpu_vs){v.px,   v.py,   v.pz,   v.nx,   v.ny,       v.nz,         v.wo.x,        v.wo.y,
                           v.wo.z, v.kd.x, v.kd.y, v.kd.z, v.one_m_eo, vs->flags[i], s->lobe_of[i], 0};
        if (v.lambert) continue;
        pgi__gpu_lobe_pack(&v.lobe, &s->hlobes[s->lobe_of[i]]);
    }
    *nlobes = nl;
    return PGI_OK;
}

void pgi__gpu_vs_pack_free(pgi__gpu_vs_pack *p) {
    pgi__afree(p->hvs);
    pgi__afree(p->hlobes);
    pgi__afree(p->lobe_of);
    memset(p, 0, sizeof *p);
}

size_t pgi__gpu_vs_pack_bytes(const pgi__gpu_vs_pack *p) {
    return p->hvs_cap * sizeof(pgi__gpu_vs) + p->hlobes_cap * sizeof(pgi__gpu_lobe) + p->lobe_of_cap * sizeof(uint32_t);
}

static int pgi__gpu_name_in(const char *name, const char *const *list) {
    for (const char *const *n = list; *n; n++)
        if (strcmp(name, *n) == 0) return 1;
    return 0;
}

void pgi__gpu_est_keep_timings(pgi_estimator_stats *es, const pgi_named_value *t, int nt, const char *const *own,
                               const char *const *gather, double *build_ms, double *gather_ms) {
    for (int i = 0; i < nt; i++) {
        if (own && !pgi__gpu_name_in(t[i].name, own)) continue;
        pgi__stats_pass(es, t[i].name, t[i].value);
        *(pgi__gpu_name_in(t[i].name, gather) ? gather_ms : build_ms) += t[i].value;
    }
}

void pgi__gpu_est_add_timings(const pgi__gpu *g, pgi_estimator_stats *es, const char *const *gather, double *build_ms,
                              double *gather_ms) {
    pgi_named_value t[16];
    int nt = pgi__gpu_timings(g, t, 16);
    pgi__gpu_est_keep_timings(es, t, nt, NULL, gather, build_ms, gather_ms);
}

void pgi__gpu_est_two_sequence_times(const pgi__gpu *g, pgi_estimator_stats *es, const double t[8], double build,
                                     double gather) {
    pgi__stats_pass(es, "gpu_upload", t[1] - t[0]);
    pgi__stats_pass(es, "gpu_submit", (t[3] - t[2]) + (t[6] - t[5]));
    pgi__stats_pass(es, "gpu_download", (t[7] - t[6]) + (t[4] - t[3]));
    if (!pgi__gpu_has_timestamps(g)) { /* CPU-timed sequences: the first is the build, the second the gather */
        build = t[3] - t[2];
        gather = t[6] - t[5];
    }
    es->build_ms = (t[1] - t[0]) + build + (t[4] - t[3]);
    es->estimate_ms = gather + (t[7] - t[6]);
}

pgi_status pgi__gpu_est_sequence(pgi__gpu *g, pgi__gpu_est_record rec, void *state, const void *frame,
                                 pgi__gpu_buffer *photons, double t[2], pgi_estimator_stats *es,
                                 const char *const *gather, double *build_ms, double *gather_ms) {
    pgi_status st;
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = rec(state, frame, photons))) return pgi__gpu_abandon(g, st);
    t[0] = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    t[1] = pgi__now_ms();
    pgi__gpu_est_add_timings(g, es, gather, build_ms, gather_ms);
    return PGI_OK;
}

pgi_status pgi__gpu_est_copies(pgi__gpu *g, const char *name, pgi__gpu_buffer *counts, size_t ncounts,
                               pgi__gpu_buffer *counters, pgi__gpu_buffer **ids, uint32_t *copies) {
    uint32_t total = 0, tested[2];
    pgi_status st;
    if ((st = pgi__gpu_download(g, counts, ncounts * 4, &total, 4)) ||
        (st = pgi__gpu_download(g, counters, 6 * 4, tested, sizeof tested)))
        return st;
    /* every list test is a copy: the 64-bit count catches a scan that wrapped */
    const uint64_t ncopies = pgi__gpu_u64(tested);
    if (ncopies > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "%s on the GPU: %llu photon copies (at most 2^30); use a smaller radius or larger tiles", name,
                         (unsigned long long)ncopies);
    PGI__ASSERT(ncopies == total);
    *copies = total;
    return pgi__gpu_buffer_reserve(g, ids, ((size_t)total + 1) * 4, "gpu_tile_photons");
}

void pgi__gpu_est_finish(const pgi__gpu *g, pgi_estimator_stats *es, const pgi_estimator_stats *seq1,
                         const pgi_named_value *t, int nt, const char *const *own, const char *const *gather,
                         const double ft[8], double *build_ms, double *gather_ms) {
    *es = *seq1;
    pgi__gpu_est_keep_timings(es, t, nt, own, gather, build_ms, gather_ms);
    pgi__stats_pass(es, "gpu_submit", ft[3] - ft[2]);
    es->build_ms = pgi__gpu_has_timestamps(g) ? *build_ms : ft[3] - ft[2];
    es->estimate_ms = *gather_ms;
}

#define NO_BACKEND "this build of photongi has no Vulkan backend (built without Vulkan/glslc)"

pgi_status pgi__gpu_est_none_create(pgi__gpu *g, const pgi_estimator_desc *desc, void **state) {
    (void)g, (void)desc;
    *state = NULL;
    return pgi__fail(PGI_ERR_UNSUPPORTED, NO_BACKEND);
}
pgi_status pgi__gpu_est_none_run(void *state, const pgi_estimate_args *args, pgi_estimator_stats *st) {
    (void)state, (void)args, (void)st;
    return pgi__fail(PGI_ERR_UNSUPPORTED, NO_BACKEND);
}
void pgi__gpu_est_none_destroy(void *state) { (void)state; }
pgi_status pgi__gpu_est_none_reserve(void *state, const pgi__gpu_est_inputs *in, pgi__gpu_buffer **out) {
    (void)state, (void)in, (void)out;
    return pgi__fail(PGI_ERR_UNSUPPORTED, NO_BACKEND);
}
pgi_status pgi__gpu_est_none_record(void *state, const pgi__gpu_est_inputs *in) {
    (void)state, (void)in;
    return pgi__fail(PGI_ERR_UNSUPPORTED, NO_BACKEND);
}
pgi_status pgi__gpu_est_none_finish(void *state, const pgi_named_value *t, int nt, pgi_estimator_stats *st) {
    (void)state, (void)t, (void)nt, (void)st;
    return pgi__fail(PGI_ERR_UNSUPPORTED, NO_BACKEND);
}

pgi_status pgi__gpu_est_upload(pgi__gpu *g, const pgi_estimate_args *a, pgi__packed_photon **packed, size_t *packed_cap,
                               pgi__gpu_vs_pack *pk, pgi__gpu_buffer **photons, pgi__gpu_buffer **vs,
                               pgi__gpu_buffer **lobes) {
    const pgi_photons *ph = a->photons;
    const size_t n = ph->count, ns = a->samples->count, psz = sizeof(pgi__packed_photon);
    size_t nlobes = 0;
    pgi_status st;
    if ((st = pgi__ensure((void **)packed, packed_cap, n + 1, psz))) return st;
    pgi__packed_photon *pp = *packed;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(a->threads))
    for (long long j = 0; j < (long long)n; j++) pgi__pack_photon(ph, (size_t)j, &pp[j]);
    if ((st = pgi__gpu_pack_samples(pk, a->samples, a->threads, &nlobes)) ||
        (st = pgi__gpu_buffer_reserve(g, photons, (n + 1) * psz, "gpu_photons")) ||
        (st = pgi__gpu_buffer_reserve(g, vs, (ns + 1) * sizeof(pgi__gpu_vs), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, lobes, (nlobes + 1) * sizeof(pgi__gpu_lobe), "gpu_view_samples")) ||
        (st = pgi__gpu_upload(g, *photons, 0, pp, n * psz)) ||
        (st = pgi__gpu_upload(g, *vs, 0, pk->hvs, ns * sizeof(pgi__gpu_vs))) ||
        (st = pgi__gpu_upload(g, *lobes, 0, pk->hlobes, nlobes * sizeof(pgi__gpu_lobe))))
        return st;
    return PGI_OK;
}

pgi_status pgi__gpu_est_upload_footprints(pgi__gpu *g, const pgi_photons *ph, int threads, const char *what,
                                          pgi__gpu_footprint **host, size_t *host_cap, pgi__gpu_buffer **buf,
                                          double *area) {
    const size_t n = ph->count;
    double sum = 0.0;
    *area = 0.0;
    if (!ph->radius) return PGI_OK;
    pgi_status st = pgi__ensure((void **)host, host_cap, n + 1, sizeof(pgi__gpu_footprint));
    if (st) return st;
    pgi__gpu_footprint *f = *host;
    const int ell = ph->sax != NULL;
#pragma omp parallel for schedule(static) reduction(+ : sum) num_threads(pgi__threads(threads))
    for (long long jj = 0; jj < (long long)n; jj++) {
        const size_t j = (size_t)jj;
        const float r = ph->radius[j];
        f[j] = ell ? (pgi__gpu_footprint){r,          ph->sax[j], ph->say[j], ph->saz[j], ph->sbx[j], ph->sby[j],
                                          ph->sbz[j], ph->nx[j],  ph->ny[j],  ph->nz[j],  0.f,        0.f}
                   : (pgi__gpu_footprint){.r = r};
        sum += (double)PGI__PI * (double)r * (double)r;
    }
    *area = sum;
    if ((st = pgi__gpu_buffer_reserve(g, buf, (n + 1) * sizeof(pgi__gpu_footprint), what)) ||
        (st = pgi__gpu_upload(g, *buf, 0, f, n * sizeof(pgi__gpu_footprint))))
        return st;
    return PGI_OK;
}
