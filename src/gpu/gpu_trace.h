/* Photon tracing on the GPU (docs/gpu.md, "Photon tracing"): the CPU
 * tracer's policy (src/photon/trace.c: light pick by power, emission per light type, BSDF
 * sampling, flux-preserving Russian roulette, storage from the second hit on, at most `bounces`
 * scattering events, flux divided by the paths emitted) in src/gpu/shaders/trace.comp, one
 * invocation a path, rays through the GPU BVH (gpu_rays.h). The photons stay on the device in the
 * layout the GPU hashgrid reads (pgi__packed_photon, photon order = path order).
 *
 *   pgi__gpu_trace *t;  pgi__gpu_trace_create(gpu, gpu_scene, &t);
 *   pgi__gpu_trace_desc d = {.photons = 200000, .bounces = 4, .seed = 1};
 *   pgi__gpu_trace_result r;  pgi__gpu_trace_run(t, scene, &d, &r);
 *   pgi__gpu_trace_photons(t)      // device buffer: r.count pgi__packed_photon (36 bytes each)
 *   pgi__gpu_trace_download(t, ph) // or into host arrays (normals not traced: set to 0)
 * With a radius policy (desc.radius_policy path or differentials) the paths carry the CPU tracer's
 * footprint state (shaders/trace_fp.comp, differentials.glsl) and each photon gets its footprint
 * record (pgi__gpu_trace_footprints, in the photons' order; downloaded with the photons).
 *
 * Deterministic: batches of paths of consecutive indices; each path writes its photons to its
 * own slots (at most `bounces`), the counts are scanned and the slots compacted in path order, and
 * the last batch is cut after the path whose photons fill the buffer. The photons and `emitted`
 * are therefore the same bytes on every run and device order, whatever the batch sizes (a batch
 * size changes nothing but the paths traced for nothing). Random numbers: a counter-based hash
 * per path (trace.glsl), not the CPU's PCG streams: statistically, not numerically, equal to the
 * CPU tracer. */
#ifndef PGI__GPU_TRACE_H
#define PGI__GPU_TRACE_H

#include "gpu/gpu.h"
#include "gpu/gpu_scene.h"

typedef struct pgi__gpu_trace pgi__gpu_trace;

typedef struct pgi__gpu_trace_desc {
    uint32_t photons; /* photons to store */
    int bounces;      /* 1..64 scattering events (0: no photons) */
    uint64_t seed;
    /* pgi_radius_policy: PGI_RADIUS_PATH and PGI_RADIUS_DIFFERENTIALS give every photon a
       footprint (pgi__gpu_trace_footprints) as the CPU tracer does (src/photon/radius.h, with
       r_min, r_max and smoothing as pgi__fp_params_init takes them; r_max > 0) */
    int radius_policy;
    float r_min, r_max, smoothing;
    /* options of the CPU tracer that the GPU lacks: anything but the defaults is refused
       (PGI_ERR_UNSUPPORTED naming the option) */
    int emission; /* pgi_emission: PGI_EMISSION_UNIFORM only */
    int store;    /* pgi_store: PGI_STORE_ALL only */
} pgi__gpu_trace_desc;

typedef struct pgi__gpu_trace_result {
    uint32_t count;           /* photons stored (= photons unless the scene loses nearly all light) */
    uint64_t emitted;         /* paths emitted: up to the one that filled the buffer */
    uint64_t paths_traced;    /* all paths traced (emitted + discarded) */
    uint64_t paths_discarded; /* traced after the filling path (their photons dropped) */
    uint64_t rays;            /* photon rays cast */
    int batches;              /* launches (one submit each) */
    double trace_ms;          /* device time (timestamps "gpu_trace", or the CPU-timed sequences) */
    /* radius policies: the stored photons' footprint radius before the clamp, PGI_FOOTPRINT_BINS
       bins of r_max / 14 (the last one open), as the CPU tracer's footprint_hist; zeros otherwise */
    uint64_t footprint_hist[PGI_FOOTPRINT_BINS];
    double wall_ms; /* host wall clock of the whole call */
} pgi__gpu_trace_result;

/* 1 when the options are supported; else PGI_ERR_UNSUPPORTED with a message naming the option.
 * The renderer calls it before a GPU frame starts. */
pgi_status pgi__gpu_trace_check(const pgi__gpu_trace_desc *d);
/* Creates the kernels; the scene on the device (gpu_scene.h: its buffers, the BVH, and its emission
 * records pgi__gpu_scene_emit) is borrowed. A constant sky emits photons as on the CPU; an
 * environment map is refused by pgi__gpu_scene_create. */
pgi_status pgi__gpu_trace_create(pgi__gpu *g, pgi__gpu_scene *gs, pgi__gpu_trace **out);
void pgi__gpu_trace_destroy(pgi__gpu_trace *t);
/* Traces d->photons photons of scene s (the one the GPU scene holds; if its geometry or lights
 * moved, the GPU scene is updated first). */
pgi_status pgi__gpu_trace_run(pgi__gpu_trace *t, const pgi_scene *s, const pgi__gpu_trace_desc *d,
                              pgi__gpu_trace_result *r);
/* The photons of the last run (r.count of them, the buffer holds at least one entry),
 * pgi__packed_photon; NULL before a run. */
pgi__gpu_buffer *pgi__gpu_trace_photons(const pgi__gpu_trace *t);
/* The footprints of the last run's photons (pgi__gpu_footprint, record i photon i's; the buffer
 * holds at least one entry) when it had a radius policy, else NULL; *ellipsoids (may be NULL): 1
 * for differentials' ellipsoids, 0 for spheres. */
pgi__gpu_buffer *pgi__gpu_trace_footprints(const pgi__gpu_trace *t, int *ellipsoids);
/* Copies the last run's photons into ph (capacity >= count): positions, directions, flux; with a
 * radius policy, the footprints into ph->radius (and sax..sbz when ph has them) and the stored
 * geometric normals into nx..nz, where ph has radius arrays; normals 0 otherwise; ph->emitted set. */
pgi_status pgi__gpu_trace_download(pgi__gpu_trace *t, pgi_photons *ph);
/* Tests: at most `paths` paths a launch (>= 1; 0: the default limit). */
void pgi__gpu_trace_set_max_batch(pgi__gpu_trace *t, uint32_t paths);

#endif
