/* Photon tracing (docs/design.md, "One frame"). */
#ifndef PGI__PHOTON_H
#define PGI__PHOTON_H

#include "rt/rt.h"
#include "scene/bsdf.h"
#include "scene/light.h"
#include "scene/tri_cache.h"

typedef struct pgi__trace_desc {
    uint32_t photons; /* photons to store */
    int bounces;      /* maximum scattering events of a path */
    uint64_t seed;
    int threads; /* 0 = OpenMP's default */
    /* radius policies (radius.h): per-photon footprints go to ph->radius (and the ellipsoid
       axes ph->sax.. for differentials) when those arrays are set */
    int radius_policy;
    float r_min, r_max, smoothing;
    uint64_t *footprint_hist; /* optional out: PGI_FOOTPRINT_BINS counts of the radius before the clamp */
    /* optional: called with the photons stored so far and the photons wanted, before the first
       batch and after each one, on the calling thread (outside the parallel regions) */
    void (*progress)(void *ctx, uint64_t stored, uint64_t wanted);
    void *progress_ctx;
    const pgi_cancel *cancel; /* may be NULL: once requested, the tracer stops after the batch in flight
                                 (PGI_ERR_CANCELLED) */
    /* view-importance emission (guide.h): NULL = uniform. A uniform pilot batch, then batches
       steered by the guide whenever it predicts at least `min_gain` times the photons in view */
    struct pgi__guide *guide;
    const struct pgi__view_grid *vgrid;
    const struct pgi__view_grid *near; /* non-NULL: store only photons in its cells (PGI_STORE_VIEW) */
    double min_gain;
    /* 1: the guide's evidence of the frames before this one is kept (the same light layout), and
       when it holds any the frame runs no pilot: it steers from its first path where that
       evidence predicts min_gain, else traces uniformly, and adds its paths' counts to the
       evidence (progressive frames of one picture, pgi_progressive_keep_guide). 0: a fresh guide */
    int guide_keep;
    /* portal emission (scene/portal.h): the sun's and the sky's photons start on the scene's
       portals (needs portals; no guide, a fixed radius) */
    int portals;
} pgi__trace_desc;

/* Fills `ph` (capacity >= photons) with exactly `photons` photons, unless the
 * scene loses nearly all light (then fewer: after 64 paths per requested
 * photon the tracer stops). ph->emitted is the number of light paths, and the
 * flux of every photon is already divided by it. `rays` counts rays cast.
 * The result is identical for any thread count: path i uses RNG stream i and
 * paths are appended in index order. */
/* Tracing buffers kept between frames, so that steady-state frames allocate nothing: each
 * thread's photons (about the photons stored, whatever --bounces), a byte a path of the
 * current batch, and the yield seen in the last frame. Zero-initialise; free with
 * pgi__trace_scratch_free. */
struct pgi__trace_tbuf;
struct chunk_info;
typedef struct pgi__trace_scratch {
    struct pgi__trace_tbuf *tbuf;
    int nthreads;
    uint8_t *counts;    /* photons of each path of the batch */
    uint16_t *path_bin; /* guided emission: the guide's bin of each path of the batch */
    uint16_t *ph_bin;   /* ... and of each photon stored */
    size_t path_bin_cap, ph_bin_cap;
    struct chunk_info *chunks; /* where each chunk's photons are */
    size_t cap;                /* paths */
    /* How each path of the batch starts, the states of those from point and spot lights
       between their first and second hits (trace.c first_hits), their differentials (when a
       radius policy follows them: pd_cap), whether each goes on after its first hit (live: a
       byte a state for each thread, which writes those of the states it shades; live_n bytes),
       and their emission order (sort keys, indices) */
    uint8_t *mode;
    struct path_state *ps;
    uint8_t *live;
    struct pgi__pdiff *ps_pd;
    uint32_t *key, *idx, *tkey, *tidx, *hist;
    size_t mode_cap, ps_cap, pd_cap, hist_n, live_n;
    double prior_paths, prior_photons; /* the last frame's traced paths and their photons */
    uint64_t paths_traced;             /* out: paths traced by the last call (emitted + discarded + pilot) */
    uint64_t paths_pilot;              /* out: guided emission's uniform pilot, whose photons were dropped */
    uint64_t culled;                   /* out: photons not stored (trace desc `near`) */
    pgi__tri_cache tc;                 /* the scene's triangles as the tracer shades them (pgi__tri_cache_update) */
} pgi__trace_scratch;
void pgi__trace_scratch_free(pgi__trace_scratch *sc);
/* Bytes the scratch holds. */
size_t pgi__trace_scratch_bytes(const pgi__trace_scratch *sc);

/* Tests: at most this many paths of a chunk from point and spot lights start in the emission
 * pre-pass (0: no cap); the others start in their chunk (trace.c start_paths). */
extern int pgi__trace_room_cap;

pgi_status pgi__photons_trace(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                              pgi__trace_scratch *scratch, uint64_t *rays);

#if PGI__AVX2_TARGET
/* The same tracer built for AVX2, FMA, BMI1/2 and POPCNT (trace_v3.c): pgi__photons_trace calls it
 * where pgi__trace_v3_ok(); the same photons, bit for bit. */
pgi_status pgi__photons_trace_v3(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                                 pgi__trace_scratch *scratch, uint64_t *rays);
static inline int pgi__trace_v3_ok(void) {
    return pgi__cpu_avx2() && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
           __builtin_cpu_supports("bmi2");
}
/* ... and for AVX-512 F, DQ, VL, BW and CD as well (trace_v4.c: x86-64-v4), where
 * pgi__trace_v4_ok() (not with pgi__cpu_no512); the same photons, bit for bit. */
pgi_status pgi__photons_trace_v4(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                                 pgi__trace_scratch *scratch, uint64_t *rays);
static inline int pgi__trace_v4_ok(void) {
    return pgi__trace_v3_ok() && pgi__cpu_avx512() && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512cd");
}
#endif

#endif
