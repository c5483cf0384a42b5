/* Ray casting. src/rt is the only folder that includes Embree: rt.c (the CPU's scene and rays)
 * and tri_bvh.c (the GPU backend's triangle BVH, built with Embree's rtcBuildBVH); everything
 * else sees these few calls and tri_bvh.h. */
#ifndef PGI__RT_H
#define PGI__RT_H

#include "scene/scene_internal.h"

typedef struct pgi__rt pgi__rt;

typedef struct pgi__hit {
    float t;
    float u, v;    /* barycentrics of vertices 1 and 2 */
    uint32_t prim; /* triangle index, UINT32_MAX for a miss */
} pgi__hit;

/* Builds the BVH over the scene's triangles. The scene is borrowed. */
pgi_status pgi__rt_create(const pgi_scene *s, pgi__rt **out);
void pgi__rt_destroy(pgi__rt *rt);
/* Bytes the ray tracer holds now: what Embree's memory monitor counted (BVH, geometry buffers)
 * and the ray tracer's own triangle maps; *peak (may be NULL): the most it has held, Embree's
 * build scratch included. */
size_t pgi__rt_memory(const pgi__rt *rt, size_t *peak);
/* 1 when the scene's geometry moved since the BVH was built or updated. */
int pgi__rt_needs_update(const pgi__rt *rt, const pgi_scene *s);
/* Brings the BVH in line with the scene's current vertex positions
 * (animated objects: refit of their own geometry; anything else: rebuild).
 * Not thread-safe with queries in flight. */
pgi_status pgi__rt_update(pgi__rt *rt, const pgi_scene *s);
/* Closest hit in (tnear, tfar); returns 1 on a hit. Thread-safe. */
int pgi__rt_intersect(const pgi__rt *rt, pgi__v3 o, pgi__v3 d, float tnear, float tfar, pgi__hit *h);
/* 1 if anything lies on the segment (tnear, tfar). */
int pgi__rt_occluded(const pgi__rt *rt, pgi__v3 o, pgi__v3 d, float tnear, float tfar);
/* 8-wide packet from one origin (primary rays; AVX2-native). `valid[i]`
 * non-zero enables lane i; `dirs` holds 8 direction triples. */
void pgi__rt_intersect8(const pgi__rt *rt, const int valid[8], pgi__v3 o, const pgi__v3 dirs[8], float tfar,
                        pgi__hit hits[8]);

/* 16-wide packets (on AVX2, Embree runs them as two 8-wide halves with one traversal; measured
 * the fastest call style for primary and shadow rays by photongi-bench --limits).
 * intersect16: ray i from (o[0][i], o[1][i], o[2][i]) along (d[0][i], d[1][i], d[2][i]) over
 * (0, infinity) (arrays in Embree's packet layout); `coherent` picks Embree's coherent or
 * incoherent traversal context; lane i's hit in t[i], u[i], v[i] (barycentrics of vertices 1
 * and 2), prim[i] (UINT32_MAX: none, or a disabled lane; t, u, v then hold nothing useful).
 * occluded16: rays over (0, tfar[i]), coherent or not likewise; occluded[i] is 1 when lane i
 * is valid and blocked. */
void pgi__rt_intersect16(const pgi__rt *rt, const int valid[16], const float o[3][16], const float d[3][16],
                         int coherent, float t[16], float u[16], float v[16], uint32_t prim[16]);
/* intersect16 from one origin with the lanes in arrays (structure of arrays, as Embree's packet),
 * coherent context: ray i along (d[0][i], d[1][i], d[2][i]); lane i's hit is prim[i] (UINT32_MAX:
 * none, or lane off) at distance t[i] and barycentrics u[i], v[i] (0 without a hit). */
void pgi__rt_intersect16_soa(const pgi__rt *rt, const int valid[16], pgi__v3 o, const float *const d[3], float t[16],
                             float u[16], float v[16], uint32_t prim[16]);
void pgi__rt_occluded16(const pgi__rt *rt, const int valid[16], const pgi__v3 org[16], const pgi__v3 dirs[16],
                        const float tfar[16], int coherent, int occluded[16]);
/* occluded16 with its lanes in arrays (structure of arrays, as Embree's packet): ray i from
 * (o[0][i], o[1][i], o[2][i]) along (d[0][i], d[1][i], d[2][i]) over (0, tfar[i]), coherent
 * context; invalid lanes are masked (their values are not read). */
void pgi__rt_occluded16_soa(const pgi__rt *rt, const int valid[16], const float *const o[3], const float *const d[3],
                            const float tfar[16], int occluded[16]);
/* A stream of n (<= PGI__RT_STREAM_MAX) occlusion rays in one rtcOccluded1M call with an
 * incoherent context (the fastest style for scattered shadow rays, e.g. the sky's:
 * photongi-bench --limits): ray i from org[i] along dirs[i] over (0, tfar[i]); occluded[i]
 * is 1 when it is blocked. */
#define PGI__RT_STREAM_MAX 256
void pgi__rt_occluded1M(const pgi__rt *rt, size_t n, const pgi__v3 *org, const pgi__v3 *dirs, const float *tfar,
                        int *occluded);

/* Ray capture (photongi-bench --limits; the log behind it is src/rt/ray_log.h). While a hook is
 * set, every query above hands its rays and answers to it: the query reserves one record a ray
 * of the call (1, the packet width or the stream length) with hook.reserve and fills each with
 * pgi__ray_rec_set. No hook (the default): the queries pay one load and a not-taken branch. Set
 * and unset it between frames, never with queries in flight. */
typedef enum pgi__pass { PGI__PASS_NONE, PGI__PASS_VIEW, PGI__PASS_TRACE, PGI__PASS_DIRECT, PGI__PASS_COUNT } pgi__pass;

/* How a ray was cast: the entry point's Embree call. Packet and stream kinds record every lane
 * of the call (invalid lanes too, flagged), so that a replay can rebuild the call exactly. */
typedef enum pgi__ray_kind {
    PGI__RAY_INTERSECT1,  /* rtcIntersect1 */
    PGI__RAY_OCCLUDED1,   /* rtcOccluded1 */
    PGI__RAY_INTERSECT8,  /* one lane of rtcIntersect8 */
    PGI__RAY_OCCLUDED8,   /* one lane of rtcOccluded8 */
    PGI__RAY_INTERSECT16, /* one lane of rtcIntersect16 */
    PGI__RAY_OCCLUDED16,  /* one lane of rtcOccluded16 */
    PGI__RAY_INTERSECT1M, /* one ray of an rtcIntersect1M stream */
    PGI__RAY_OCCLUDED1M,  /* one ray of an rtcOccluded1M stream */
    PGI__RAY_KIND_COUNT
} pgi__ray_kind;

/* Record flags. */
enum {
    PGI__RAY_VALID = 1,   /* the lane was enabled */
    PGI__RAY_COHERENT = 2 /* cast with RTC_INTERSECT_CONTEXT_FLAG_COHERENT */
};

#define PGI__RAY_NO_GEOM 0xFFu /* rec.geom: missed / not occluded */

typedef struct pgi__ray_rec {
    float org[3], tnear;
    float dir[3], tfar;
    uint32_t packet; /* the call this ray was cast in (lanes of one packet or stream share it);
                        after merging, numbered 0, 1, ... within its (pass, kind) group */
    uint32_t prim;   /* Embree's answer: primID of the closest hit (intersect), else UINT32_MAX */
    uint16_t lane;   /* lane in its packet or stream */
    uint8_t kind;    /* pgi__ray_kind */
    uint8_t pass;    /* pgi__pass */
    uint8_t flags;   /* PGI__RAY_VALID | PGI__RAY_COHERENT */
    uint8_t geom;    /* geomID of the hit (intersect), 0 when occluded (occluded), PGI__RAY_NO_GEOM otherwise */
    uint8_t pad[2];
} pgi__ray_rec;

static inline void pgi__ray_rec_set(pgi__ray_rec *r, pgi__v3 o, pgi__v3 d, float tnear, float tfar, int valid,
                                    unsigned geom, unsigned prim) {
    r->org[0] = o.x;
    r->org[1] = o.y;
    r->org[2] = o.z;
    r->tnear = tnear;
    r->dir[0] = d.x;
    r->dir[1] = d.y;
    r->dir[2] = d.z;
    r->tfar = tfar;
    if (!valid) r->flags = (uint8_t)(r->flags & ~PGI__RAY_VALID);
    r->geom = geom > 0xFEu ? PGI__RAY_NO_GEOM : (uint8_t)geom;
    r->prim = geom > 0xFEu ? UINT32_MAX : prim;
}

typedef struct pgi__rt_capture {
    /* `n` records of one call with kind, pass, packet and lane filled in; NULL drops the call's
     * rays. Called from many threads at once. */
    pgi__ray_rec *(*reserve)(void *user, pgi__ray_kind kind, unsigned n, unsigned flags);
    /* The pass tag of the rays captured from now on (pgi__rt_capture_pass). */
    void (*set_pass)(void *user, pgi__pass pass);
    void *user;
} pgi__rt_capture;

/* Sets the hook (copied; NULL: capture off). */
void pgi__rt_capture_hook(pgi__rt *rt, const pgi__rt_capture *hook);
/* Tags the rays captured from now on (a no-op while capture is off). */
void pgi__rt_capture_pass(const pgi__rt *rt, pgi__pass pass);
/* The Embree scene, for the replay in ray_log.c (an RTCScene). */
struct RTCSceneTy *pgi__rt_embree_scene(const pgi__rt *rt);

#endif
