/* What every estimator's state and vtbl share: the desc and stats block,
 * the stats helpers, the registry's vtbl declarations. */
#ifndef PGI__EST_COMMON_H
#define PGI__EST_COMMON_H

#include "core/core.h"

/* Stats helpers for the per-method state. */
typedef struct pgi__est_common {
    pgi_estimator_desc desc; /* resolved: defaults filled in, ranges checked */
    pgi_estimator_stats st;
    /* this frame's arguments (pgi__est_frame) */
    float radius;
    uint64_t seed;
    int threads; /* for num_threads(): never 0 */
    float scene_area;
    const pgi_cancel *cancel; /* pgi_estimate_args.cancel: loops test it with pgi__est_stop */
} pgi__est_common;

/* Takes the per-frame values of build/estimate into the state. */
static inline void pgi__est_frame(pgi__est_common *c, const pgi_estimate_args *a) {
    c->radius = a->radius;
    c->seed = a->seed;
    c->threads = pgi__threads(a->threads);
    c->scene_area = a->scene_area;
    c->cancel = a->cancel;
}
/* In an estimator's parallel loop over view samples (or tiles, or photons): once the caller asked
 * to cancel, `if (pgi__est_stop(&s->c)) continue;` drains the loop (pgi_estimator_build/estimate
 * then return PGI_ERR_CANCELLED). */
static inline int pgi__est_stop(const pgi__est_common *c) { return pgi__cancelled(c->cancel); }

static inline void pgi__stats_pass(pgi_estimator_stats *st, const char *name, double ms) {
    if (st->pass_count < PGI_EST_MAX_ENTRIES) {
        st->pass_names[st->pass_count] = name;
        st->pass_ms[st->pass_count++] = ms;
    }
}
static inline void pgi__stats_mem(pgi_estimator_stats *st, const char *name, size_t bytes) {
    if (st->memory_count < PGI_EST_MAX_ENTRIES) {
        st->memory_names[st->memory_count] = name;
        st->memory_bytes[st->memory_count++] = bytes;
    }
}

/* Records the gather pass: its time since t0 and the read counters. */
static inline void pgi__stats_estimated(pgi_estimator_stats *st, double t0, uint64_t reads, uint64_t contributing) {
    st->estimate_ms = pgi__now_ms() - t0;
    pgi__stats_pass(st, "gather", st->estimate_ms);
    st->reads = reads;
    st->contributing = contributing;
}

/* The stats hook of a state that starts with its pgi__est_common. */
void pgi__est_default_stats(const void *state, pgi_estimator_stats *out);

/* The table of an estimator whose state starts with its pgi__est_common (its stats hook
 * pgi__est_default_stats): its name, summary and four functions, then the rest as designated
 * initializers (.exact, .caps, .options, .defaults, and the memory budget .bytes_per_photon and
 * .bytes_per_sample: the bytes of its stats per photon and per view sample, measured and rounded
 * up). */
#define PGI__EST_TABLE(name_, summary_, create_, build_, estimate_, destroy_, ...)                                     \
    {                                                                                                                  \
        .name = name_, .summary = summary_, .create = create_, .build = build_, .estimate = estimate_,                 \
        .stats = pgi__est_default_stats, .destroy = destroy_, __VA_ARGS__                                              \
    }

extern const pgi_estimator_vtbl pgi__est_brute, pgi__est_hashgrid, pgi__est_tiled;
/* The tile-edge option of tiled, bounds3d and bounds25d (est_tiled.c). */
extern const pgi_option pgi__opt_tile;
/* Floats in one of directional's octant buckets (CPU and GPU): flux r, g, b, then the photons'
 * directions summed weighted by their flux (r + g + b). */
#define PGI__DIR_BUCKET 6
extern const pgi_estimator_vtbl pgi__est_cluster, pgi__est_cluster_cone, pgi__est_cluster_trivial, pgi__est_directional;
extern const pgi_estimator_vtbl pgi__est_bvh;
extern const pgi_estimator_vtbl pgi__est_kdtree, pgi__est_bounds3d, pgi__est_bounds25d;

#endif
