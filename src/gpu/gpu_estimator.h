/* Estimators on the GPU (--device vulkan, docs/gpu.md): the same pgi_estimate_args as the CPU
 * estimators (photons and view samples from the CPU, uploaded each frame), one call that builds
 * and gathers on the device and writes args->out_rgb, and stats in the CPU estimators' form (GPU
 * passes named "gpu_*" with timestamps, the device's buffers as "gpu_*" memory entries). */
#ifndef PGI__GPU_ESTIMATOR_H
#define PGI__GPU_ESTIMATOR_H

#include <string.h>

#include "gpu/gpu.h"
#include "estimators/packed.h" /* pgi__packed_photon */
#include "scene/bsdf.h"        /* PGI__GGX_NMU */

/* The GPU frame's inputs (device buffers, no host round trip): photons on the device as
 * pgi__packed_photon (the GPU tracer's, or the CPU's uploaded), the view samples as gpu_view.h's
 * ViewSample array with the scene's material lobe table (gpu_scene.h) and the PixelExtra array
 * (geometric normal and view depth), and the camera they were made with. */
/* A photon's footprint on the device (radius policies `path` and `differentials`, BVH paper
 * §3.2/§4), one record a photon in the photons' order; mirrored by shaders/footprint.glsl. A sphere
 * has r only (a and b zero); an ellipsoid {p + u a + v b + w r n : u^2 + v^2 + w^2 < 1} has its
 * tangent semi-axes a, b, r = sqrt(|a x b|) and n the geometric normal where it was stored, as
 * pgi_photons' radius, sax..sbz and nx..nz. */
typedef struct pgi__gpu_footprint {
    float r, ax, ay, az, bx, by, bz, nx, ny, nz, pad0, pad1;
} pgi__gpu_footprint;
_Static_assert(sizeof(pgi__gpu_footprint) == 48, "footprint.glsl Footprint");

typedef struct pgi__gpu_est_inputs {
    pgi__gpu_buffer *photons;
    size_t nphotons;
    pgi__gpu_buffer *samples, *lobes, *extra;
    const pgi_camera *camera;
    int width, height;
    float radius;
    double scene_area; /* the scene's surface area (bvh's T_auto) */
    float jitter;      /* pgi_view_samples.jitter: 0.5 when the view samples are jittered in their pixels */
    /* Per-photon footprints (pgi__gpu_footprint a photon); NULL: every photon has the fixed radius.
     * footprint_ellipsoids: the records hold ellipsoids (else spheres of radius r). */
    pgi__gpu_buffer *footprints;
    int footprint_ellipsoids;
} pgi__gpu_est_inputs;

typedef struct pgi__gpu_est_vtbl {
    const char *name; /* the CPU estimator it mirrors ("hashgrid") */
    /* desc: resolved (pgi_estimator_desc_resolve); options the GPU version lacks are refused here */
    pgi_status (*create)(pgi__gpu *g, const pgi_estimator_desc *desc, void **state);
    pgi_status (*run)(void *state, const pgi_estimate_args *args, pgi_estimator_stats *st);
    void (*destroy)(void *state);
    /* Device inputs (the GPU frame). reserve: outside a command sequence, the buffers for the
     * inputs' photons and frame (an estimator whose buffers' sizes depend on the inputs may run a
     * sequence of its own here and read its sizes back); *out the radiance buffer (3 floats a
     * sample) record will write. record: inside the caller's sequence, on the same inputs
     * (timestamps "gpu_*" after each pass). finish: after it, the counters and the passes' times
     * (t: the sequence's pgi__gpu_timings; labels not the estimator's own are left out) into st. */
    pgi_status (*device_reserve)(void *state, const pgi__gpu_est_inputs *in, pgi__gpu_buffer **out);
    pgi_status (*device_record)(void *state, const pgi__gpu_est_inputs *in);
    pgi_status (*device_finish)(void *state, const pgi_named_value *t, int nt, pgi_estimator_stats *st);
} pgi__gpu_est_vtbl;

/* A build without the Vulkan backend: a GPU estimator's table whose every entry refuses with "no
 * Vulkan backend" (PGI_ERR_UNSUPPORTED); `const pgi__gpu_est_vtbl x = PGI__GPU_EST_NONE("x")`. */
pgi_status pgi__gpu_est_none_create(pgi__gpu *g, const pgi_estimator_desc *desc, void **state);
pgi_status pgi__gpu_est_none_run(void *state, const pgi_estimate_args *args, pgi_estimator_stats *st);
void pgi__gpu_est_none_destroy(void *state);
pgi_status pgi__gpu_est_none_reserve(void *state, const pgi__gpu_est_inputs *in, pgi__gpu_buffer **out);
pgi_status pgi__gpu_est_none_record(void *state, const pgi__gpu_est_inputs *in);
pgi_status pgi__gpu_est_none_finish(void *state, const pgi_named_value *t, int nt, pgi_estimator_stats *st);
#define PGI__GPU_EST_NONE(NAME)                                                                                        \
    {                                                                                                                  \
        .name = NAME, .create = pgi__gpu_est_none_create, .run = pgi__gpu_est_none_run,                                \
        .destroy = pgi__gpu_est_none_destroy, .device_reserve = pgi__gpu_est_none_reserve,                             \
        .device_record = pgi__gpu_est_none_record, .device_finish = pgi__gpu_est_none_finish                           \
    }

/* The GPU half of CPU estimator `name`: NULL when it has none. */
const pgi__gpu_est_vtbl *pgi__gpu_est_find(const char *name);
/* The PGI_EST_CAP_* options estimator `name` takes on the device (0 when it has no GPU half). */
unsigned pgi__gpu_est_caps(const char *name);
/* "hashgrid, ...": the estimators with a GPU version. */
void pgi__gpu_est_names(char *buf, size_t size);

/* The view samples in the shaders' form (shaders/gather.glsl ViewSample) and the lobe of each glossy
 * one (Lobe), packed on the host by the estimators that run on uploaded inputs: the arrays grow and
 * are kept between frames. */
typedef struct pgi__gpu_vs {
    float px, py, pz, nx, ny, nz, wox, woy, woz, kdx, kdy, kdz, one_m_eo;
    uint32_t flags, lobe, pad;
} pgi__gpu_vs;
_Static_assert(sizeof(pgi__gpu_vs) == 64 && offsetof(pgi__gpu_vs, flags) == 52, "gather.glsl ViewSample");

typedef struct pgi__gpu_lobe {
    uint32_t model;
    float ksx, ksy, ksz, s, eta, a2, inv_1mEavg;
    float E[PGI__GGX_NMU];
} pgi__gpu_lobe;
_Static_assert(sizeof(pgi__gpu_lobe) == 4 * (8 + PGI__GGX_NMU) && offsetof(pgi__gpu_lobe, E) == 32, "gather.glsl Lobe");

/* lo as gather.glsl's Lobe (the table's unused entries zero). */
static inline void pgi__gpu_lobe_pack(const pgi__lobe *lo, pgi__gpu_lobe *l) {
    memset(l, 0, sizeof *l);
    l->model = (uint32_t)lo->model;
    l->ksx = lo->ks.x;
    l->ksy = lo->ks.y;
    l->ksz = lo->ks.z;
    l->s = lo->s;
    l->eta = lo->eta;
    l->a2 = lo->a2;
    l->inv_1mEavg = lo->inv_1mEavg;
    if (lo->model == PGI__LOBE_GGX) memcpy(l->E, lo->E, sizeof l->E);
}

typedef struct pgi__gpu_vs_pack {
    pgi__gpu_vs *hvs;
    size_t hvs_cap;
    pgi__gpu_lobe *hlobes;
    size_t hlobes_cap;
    uint32_t *lobe_of;
    size_t lobe_of_cap;
} pgi__gpu_vs_pack;

/* The device's passes of the sequence just submitted (pgi__gpu_timings) into the stats, each
 * added to *gather_ms when its name is in `gather` (NULL-terminated), else to *build_ms. */
void pgi__gpu_est_add_timings(const pgi__gpu *g, pgi_estimator_stats *es, const char *const *gather, double *build_ms,
                              double *gather_ms);
/* The passes of the caller's sequence (t: its pgi__gpu_timings) named in `own` (NULL-terminated) into
 * the stats, each added to *gather_ms when its name is in `gather`, else to *build_ms (device_finish). */
void pgi__gpu_est_keep_timings(pgi_estimator_stats *es, const pgi_named_value *t, int nt, const char *const *own,
                               const char *const *gather, double *build_ms, double *gather_ms);
/* The host part of an estimator's stats when it ran on uploaded inputs in two command sequences,
 * build then gather: t[0..7] the wall clock at upload start/end, build submit/end, build read-back end,
 * gather submit/end, download end; build and gather the device time of each (timestamps; on a device
 * without them the sequences' wall clock is taken). Sets the passes gpu_upload, gpu_submit,
 * gpu_download and build_ms / estimate_ms. */
void pgi__gpu_est_two_sequence_times(const pgi__gpu *g, pgi_estimator_stats *es, const double t[8], double build,
                                     double gather);
/* What an estimator's frame is made from, on either path: run's arguments (pgi__gpu_est_in_args)
 * or the device inputs (pgi__gpu_est_in_device). */
typedef struct pgi__gpu_est_in {
    size_t n; /* photons */
    int width, height;
    const pgi_camera *cam;
    float radius, jitter;
} pgi__gpu_est_in;
static inline pgi__gpu_est_in pgi__gpu_est_in_args(const pgi_estimate_args *a) {
    return (pgi__gpu_est_in){a->photons->count, a->samples->width, a->samples->height,
                             a->camera,         a->radius,         a->samples->jitter};
}
static inline pgi__gpu_est_in pgi__gpu_est_in_device(const pgi__gpu_est_inputs *in) {
    return (pgi__gpu_est_in){in->nphotons, in->width, in->height, in->camera, in->radius, in->jitter};
}
/* A sequence that could not be recorded: closed, so that the next frame can begin one; returns st. */
static inline pgi_status pgi__gpu_abandon(pgi__gpu *g, pgi_status st) {
    (void)pgi__gpu_submit_wait(g);
    return st;
}
/* What records a command sequence's work: an estimator's state, its frame and the photons. */
typedef pgi_status (*pgi__gpu_est_record)(void *state, const void *frame, pgi__gpu_buffer *photons);
/* One command sequence of an estimator: begun, a "start" timestamp, recorded by rec (abandoned when
 * that fails), submitted and waited for; t[0] and t[1] the host clock after recording and at the
 * end; then the device's passes into the stats (pgi__gpu_est_add_timings). */
pgi_status pgi__gpu_est_sequence(pgi__gpu *g, pgi__gpu_est_record rec, void *state, const void *frame,
                                 pgi__gpu_buffer *photons, double t[2], pgi_estimator_stats *es,
                                 const char *const *gather, double *build_ms, double *gather_ms);
/* After a sequence that counted photon copies into lists (tiled, bounds3d/25d): the copies, the
 * scan's total (counts' word ncounts), checked against the 64-bit count the counters hold at word 6
 * (which catches a scan that wrapped; `name` in the message); *ids reserved for them. */
pgi_status pgi__gpu_est_copies(pgi__gpu *g, const char *name, pgi__gpu_buffer *counts, size_t ncounts,
                               pgi__gpu_buffer *counters, pgi__gpu_buffer **ids, uint32_t *copies);
/* device_finish of an estimator that ran sequence 1 in device_reserve: its stats are that
 * sequence's (seq1) with its own passes of the caller's sequence (t, nt; pgi__gpu_est_keep_timings),
 * ft the frame's host clock (pgi__gpu_est_two_sequence_times' t). */
void pgi__gpu_est_finish(const pgi__gpu *g, pgi_estimator_stats *es, const pgi_estimator_stats *seq1,
                         const pgi_named_value *t, int nt, const char *const *own, const char *const *gather,
                         const double ft[8], double *build_ms, double *gather_ms);
/* A 64-bit counter kept by the shaders as two 32-bit words, low first. */
static inline uint64_t pgi__gpu_u64(const uint32_t *w) { return (uint64_t)w[0] | (uint64_t)w[1] << 32; }

/* `run`'s inputs uploaded: a's photons packed in photon order into *photons ("gpu_photons"), its
 * view samples and their lobes (pgi__gpu_pack_samples) into *vs and *lobes ("gpu_view_samples");
 * the host arrays (kept, growing) in *packed and *pk. */
pgi_status pgi__gpu_est_upload(pgi__gpu *g, const pgi_estimate_args *a, pgi__packed_photon **packed, size_t *packed_cap,
                               pgi__gpu_vs_pack *pk, pgi__gpu_buffer **photons, pgi__gpu_buffer **vs,
                               pgi__gpu_buffer **lobes);
/* `run`'s per-photon footprints uploaded (pgi_photons radius, with sax..sbz and nx..nz for ellipsoids,
 * as the frame's pgi__gpu_est_inputs.footprints): one pgi__gpu_footprint a photon in photon order
 * into *buf (memory entry `what`), the host array (kept, growing) in *host. *area: the footprints' total
 * area, the sum of pi r^2 in double (est_bvh.c's T_auto). Photons without radius: nothing, 0. */
pgi_status pgi__gpu_est_upload_footprints(pgi__gpu *g, const pgi_photons *ph, int threads, const char *what,
                                          pgi__gpu_footprint **host, size_t *host_cap, pgi__gpu_buffer **buf,
                                          double *area);
/* Packs vs (pgi__vs_load: the CPU estimators' set-up, GGX's E row included); *nlobes: glossy samples. */
pgi_status pgi__gpu_pack_samples(pgi__gpu_vs_pack *p, const pgi_view_samples *vs, int threads, size_t *nlobes);
void pgi__gpu_vs_pack_free(pgi__gpu_vs_pack *p);
/* Host bytes the pack holds. */
size_t pgi__gpu_vs_pack_bytes(const pgi__gpu_vs_pack *p);

extern const pgi__gpu_est_vtbl pgi__gpu_est_hashgrid;
extern const pgi__gpu_est_vtbl pgi__gpu_est_bvh;
extern const pgi__gpu_est_vtbl pgi__gpu_est_cluster;
extern const pgi__gpu_est_vtbl pgi__gpu_est_cluster_cone;
extern const pgi__gpu_est_vtbl pgi__gpu_est_cluster_trivial;
extern const pgi__gpu_est_vtbl pgi__gpu_est_directional;
extern const pgi__gpu_est_vtbl pgi__gpu_est_tiled;
extern const pgi__gpu_est_vtbl pgi__gpu_est_bounds3d;
extern const pgi__gpu_est_vtbl pgi__gpu_est_bounds25d;

#endif
