/* Ray casting. The only module that includes Embree; everything else sees
 * these few calls. */
#ifndef PGI_RT_H
#define PGI_RT_H

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

/* 8 rays with their own origins (tnear 0, tfar infinity), flagged incoherent. */
void pgi__rt_intersect8_any(const pgi__rt *rt, const int valid[8], const pgi__v3 org[8], const pgi__v3 dirs[8],
                            pgi__hit hits[8]);

/* 8 shadow rays from their own origins over (0, tfar[i]), flagged coherent (rays of one screen
 * tile towards one light): occluded[i] is 1 when lane i is valid and blocked. */
void pgi__rt_occluded8(const pgi__rt *rt, const int valid[8], const pgi__v3 org[8], const pgi__v3 dirs[8],
                       const float tfar[8], int occluded[8]);

#endif
