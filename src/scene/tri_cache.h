/* The triangle cache: the scene's triangles as the passes that shade hits read them (the photon
 * tracer, the view pass, the reference path tracer), one record a triangle, rebuilt when the
 * scene's geometry changes. */
#ifndef PGI__TRI_CACHE_H
#define PGI__TRI_CACHE_H

#include "scene/bsdf.h"

/* A triangle as the passes shade it, one cache line: its unit geometric normal, material and
 * vertex normals (what pgi__scene_surface_untextured reads, less the positions); the texture
 * coordinates are in a second array, 8 floats a triangle (u0 v0 u1 v1 u2 v2, 2 unused). A hit
 * then needs one line (two when textured) instead of the triangle's indices and material
 * and its vertices' positions, normals and coordinates: 9 scattered lines after a dependent
 * one. */
typedef struct pgi__tri_rec {
    float ng[3];
    uint32_t mat;
    float n[9];
    float pad[3];
} pgi__tri_rec;
_Static_assert(sizeof(pgi__tri_rec) == 64, "a triangle record is one cache line");
#define PGI__TRI_UV 8

/* pgi__scene_surface_untextured from a triangle record, less the texture coordinates (the texels
 * are found before shading): the same operations on the same values, so the same bits. In two
 * halves for a path tracer: the geometry (p, ng, mat: all that a path's last vertex needs),
 * then the shading (ns, kd). */
static inline void pgi__tri_rec_geometry(const pgi_scene *s, const pgi__tri_rec *r, pgi__v3 p, pgi__surface *o) {
    o->p = p;
    o->ng = v3_load(r->ng);
    o->mat = &s->mats[r->mat];
}

/* The shading normal of r at barycentrics (bu, bv): its vertex normals interpolated, turned to
 * the side of the geometric normal g (g itself without vertex normals or where they cancel). */
static inline pgi__v3 pgi__tri_rec_ns(const pgi_scene *s, const pgi__tri_rec *r, float bu, float bv, pgi__v3 g) {
    if (!s->nrm) return g;
    float bw = 1.f - bu - bv;
    pgi__v3 n =
        v3_add(v3_add(v3_scale(v3_load(r->n), bw), v3_scale(v3_load(r->n + 3), bu)), v3_scale(v3_load(r->n + 6), bv));
    float l = v3_len(n);
    if (!(l > 0.f && isfinite(l))) return g;
    n = v3_scale(n, 1.f / l);
    return v3_dot(n, g) < 0.f ? v3_neg(n) : n;
}
/* (r is triangle prim's record: the vertex colours, where the scene has them, are read from the
 * scene's arrays.) */
static inline void pgi__tri_rec_shading(const pgi_scene *s, const pgi__tri_rec *r, uint32_t prim, float bu, float bv,
                                        pgi__surface *o) {
    o->ns = pgi__tri_rec_ns(s, r, bu, bv, o->ng);
    o->u = o->v = 0.f;
    o->kd = pgi__scene_kd(s, o->mat, prim, bu, bv);
}

static inline void pgi__tri_rec_surface(const pgi_scene *s, const pgi__tri_rec *r, uint32_t prim, float bu, float bv,
                                        pgi__v3 p, pgi__surface *o) {
    pgi__tri_rec_geometry(s, r, p, o);
    pgi__tri_rec_shading(s, r, prim, bu, bv, o);
}

/* The texture level of detail of a triangle with corners a, b, c and texture coordinates
 * q[0..5] (Ray Tracing Gems ch. 20, eq. 34's Delta): 0.5 log2(texture-space area / world-space
 * area), in uv units (a texture's 0.5 log2(w h) is added at the lookup: pgi__texture_cone_lod).
 * In double, once a triangle; -inf for a degenerate mapping (level 0), +inf for a degenerate
 * triangle (the coarsest level). Kept in the triangle's PGI__TRI_UV record, q[6]. */
static inline float pgi__tri_uv_lod(pgi__v3 a, pgi__v3 b, pgi__v3 c, const float *q) {
    const double e1[3] = {(double)b.x - a.x, (double)b.y - a.y, (double)b.z - a.z};
    const double e2[3] = {(double)c.x - a.x, (double)c.y - a.y, (double)c.z - a.z};
    const double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                 cz = e1[0] * e2[1] - e1[1] * e2[0];
    const double pa = sqrt(cx * cx + cy * cy + cz * cz);
    const double ta =
        fabs(((double)q[2] - q[0]) * ((double)q[5] - q[1]) - ((double)q[4] - q[0]) * ((double)q[3] - q[1]));
    if (!(ta > 0.0)) return -INFINITY;
    if (!(pa > 0.0)) return INFINITY;
    return (float)(0.5 * log2(ta / pa));
}

/* pgi__scene_uv from a triangle's PGI__TRI_UV coordinates `q`: the same operations. */
static inline void pgi__tri_rec_uv(const float *q, float bu, float bv, float *u, float *v) {
    float bw = 1.f - bu - bv;
    *u = bw * q[0] + bu * q[2] + bv * q[4];
    *v = bw * q[1] + bu * q[3] + bv * q[5];
}

/* The records of a scene, kept between frames. Zero-initialise; free with pgi__tri_cache_free. */
typedef struct pgi__tri_cache {
    pgi__tri_rec *tris;
    float *tri_uv;       /* PGI__TRI_UV floats a triangle (NULL: the scene has no texture coordinates) */
    size_t n, bytes;     /* triangles, bytes allocated for them */
    const void *key[6];  /* the scene and its arrays the records were made from */
    uint64_t version[2]; /* ... and its static_version / dynamic_version */
} pgi__tri_cache;

/* (Re)builds c's records with `threads` threads (0: OpenMP's default) when the scene's geometry
 * (its arrays, or static_version / dynamic_version) is not the one they hold. */
pgi_status pgi__tri_cache_update(pgi__tri_cache *c, const pgi_scene *s, int threads);
void pgi__tri_cache_free(pgi__tri_cache *c);

#endif
