/* Ray casting. The only module that includes Embree; everything else sees
 * these few calls. */
#ifndef PGI_RT_H
#define PGI_RT_H

#include "scene/scene_internal.h"

typedef struct pgi_rt pgi_rt;

typedef struct pgi_hit {
    float t;
    float u, v;          /* barycentrics of vertices 1 and 2 */
    uint32_t prim;       /* triangle index, UINT32_MAX for a miss */
} pgi_hit;

/* Builds the BVH over the scene's triangles. The scene is borrowed. */
pgi_status pgi__rt_create(const pgi_scene *s, pgi_rt **out);
void pgi__rt_destroy(pgi_rt *rt);
/* 1 when the scene's geometry moved since the BVH was built or updated. */
int pgi__rt_needs_update(const pgi_rt *rt, const pgi_scene *s);
/* Brings the BVH in line with the scene's current vertex positions
 * (animated objects: refit of their own geometry; anything else: rebuild).
 * Not thread-safe with queries in flight. */
pgi_status pgi__rt_update(pgi_rt *rt, const pgi_scene *s);
/* Closest hit in (tnear, tfar); returns 1 on a hit. Thread-safe. */
int pgi__rt_intersect(const pgi_rt *rt, pgi_v3 o, pgi_v3 d, float tnear, float tfar, pgi_hit *h);
/* 1 if anything lies on the segment (tnear, tfar). */
int pgi__rt_occluded(const pgi_rt *rt, pgi_v3 o, pgi_v3 d, float tnear, float tfar);
/* 8-wide packet from one origin (primary rays; AVX2-native). `valid[i]`
 * non-zero enables lane i; `dirs` holds 8 direction triples. */
void pgi__rt_intersect8(const pgi_rt *rt, const int valid[8], pgi_v3 o, const pgi_v3 dirs[8], float tfar,
                        pgi_hit hits[8]);

#endif
