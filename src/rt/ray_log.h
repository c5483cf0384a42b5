/* Ray capture and replay: what the renderer's ray passes ask of Embree, and
 * how long Embree alone takes for the same rays (photongi-bench --limits).
 *
 * While a log is set on a pgi__rt (pgi__rt_capture_set: rt.c's capture hook), every query entry
 * point of rt.c appends its rays (origin, direction, tnear, tfar), the call
 * style (single ray, lane of an 8-wide packet, ...), the packet it belonged
 * to, the pass the pipeline tagged (pgi__rt_capture_pass) and Embree's answer
 * to a per-thread buffer: no lock, no shared counter on the hot path. Off, an
 * entry point pays one load and a not-taken branch. pgi__ray_log_merge then
 * gathers the buffers, grouped by (pass, kind), and pgi__rt_replay casts one
 * group again with raw Embree calls in the style asked for, timed, in
 * parallel over the given thread count, checking every answer against the
 * captured one. */
#ifndef PGI__RAY_LOG_H
#define PGI__RAY_LOG_H

#include "rt/rt.h"

/* The log's records are pgi__ray_rec (rt.h), of kinds pgi__ray_kind. */
typedef struct pgi__ray_log pgi__ray_log;

pgi_status pgi__ray_log_create(pgi__ray_log **out);
void pgi__ray_log_destroy(pgi__ray_log *log);
/* Forgets every ray (captured and merged). Not while a capture is running. */
void pgi__ray_log_clear(pgi__ray_log *log);
/* The pass tag of the rays captured from now on (pgi__rt_capture_pass sets it on the rt's log). */
void pgi__ray_log_set_pass(pgi__ray_log *log, pgi__pass pass);

/* Captures every query of `rt` into `log` from now on (NULL: stops). Sets the rt's capture
 * hook (pgi__rt_capture_hook); between frames, never with queries in flight. */
void pgi__rt_capture_set(pgi__rt *rt, pgi__ray_log *log);

/* The hook's reserve: `n` records (one call: 1, the packet width or the stream length) in the
 * calling thread's buffer, with kind, pass, packet and lane filled in. NULL when memory runs
 * out or more than 256 threads capture (the rays are then counted in pgi__ray_log_dropped).
 * Thread-safe, lock-free. */
pgi__ray_rec *pgi__ray_log_reserve(pgi__ray_log *log, pgi__ray_kind kind, unsigned n, unsigned flags);

/* Moves the per-thread buffers into one array grouped by (pass, kind), in
 * capture order within a thread and threads in the order they first
 * captured; renumbers packets. Call with no capture running. */
pgi_status pgi__ray_log_merge(pgi__ray_log *log);
/* Merged records of one group (rec may be NULL) and its valid rays. */
size_t pgi__ray_log_group(const pgi__ray_log *log, pgi__pass pass, pgi__ray_kind kind, const pgi__ray_rec **rec);
uint64_t pgi__ray_log_rays(const pgi__ray_log *log, pgi__pass pass, pgi__ray_kind kind);
/* Rays lost to memory or thread limits while capturing. */
uint64_t pgi__ray_log_dropped(const pgi__ray_log *log);

/* Call styles a group can be replayed in. */
typedef enum pgi__replay_method {
    PGI__REPLAY_CAST, /* as captured: the same calls, packets and streams, lanes and context flags */
    PGI__REPLAY_1,    /* rtcIntersect1 / rtcOccluded1 per ray */
    PGI__REPLAY_8,    /* rtcIntersect8 / rtcOccluded8 over 8 consecutive rays, coherent context */
    PGI__REPLAY_8I,   /* the same, incoherent context */
    PGI__REPLAY_16,   /* rtcIntersect16 / rtcOccluded16 over 16 consecutive rays, coherent context */
    PGI__REPLAY_16I,  /* the same, incoherent context */
    PGI__REPLAY_1M,   /* rtcIntersect1M / rtcOccluded1M streams of PGI__REPLAY_STREAM rays, incoherent context */
    PGI__REPLAY_1MC,  /* the same, coherent context */
    PGI__REPLAY_METHOD_COUNT
} pgi__replay_method;

#ifndef PGI__REPLAY_STREAM
#define PGI__REPLAY_STREAM 256 /* rays per stream call, and per unit of work */
#endif

/* Short name ("cast", "1", "8", "8i", "16", "16i", "1M", "1Mc") and the
 * Embree call it makes for an intersect or occluded group. */
const char *pgi__replay_method_name(pgi__replay_method m);
const char *pgi__replay_method_call(pgi__replay_method m, int occluded);
/* 1 when the method can run here (16-wide packets need Embree's native ray16 support). */
int pgi__rt_replay_supported(const pgi__rt *rt, pgi__replay_method m);
/* Short name of a kind ("intersect1", "occluded8", ...) and whether it is an occlusion query. */
const char *pgi__ray_kind_name(pgi__ray_kind k);
int pgi__ray_kind_occluded(pgi__ray_kind k);

typedef struct pgi__replay_result {
    double ms;           /* wall time of the parallel replay */
    uint64_t rays;       /* valid rays cast */
    uint64_t hits;       /* rays that hit (intersect) or were occluded */
    uint64_t mismatches; /* answers that differ from the captured ones */
} pgi__replay_result;

/* Casts group (pass, kind) of a merged log again with raw Embree calls in
 * style `m`, over pgi__threads(threads) OpenMP threads (units of
 * PGI__REPLAY_STREAM rays, or one captured packet / stream for CAST, dynamic
 * schedule). The rt must hold the scene the rays were captured on. */
pgi_status pgi__rt_replay(const pgi__rt *rt, const pgi__ray_log *log, pgi__pass pass, pgi__ray_kind kind,
                          pgi__replay_method m, int threads, pgi__replay_result *out);

#endif
