/* Ray sets and hit comparisons shared by tests/test_gpu_bvh.c (the GPU BVH's CPU traversal against
 * Embree) and tests/test_gpu_rays.c (the compute shader against both). Header only; include after
 * test_util.h. */
#ifndef PGI__GPU_RAYS_COMMON_H
#define PGI__GPU_RAYS_COMMON_H

#include "test_util.h"

#include "rt/tri_bvh.h"
#include "rt/rt.h"
#include "scene/scene_internal.h"
#include "view/view.h"

typedef enum gr_kind { GR_RANDOM, GR_PRIMARY, GR_SEGMENT, GR_SHADOW } gr_kind;
static const char *const gr_kind_name[] = {"random", "primary", "segment", "shadow"};

/* n rays of one kind into r (shadow rays: any-hit queries; the others closest hit). random:
 * origins uniform in the scene's box (shrunk to 98 %), uniform directions, (0, inf). primary:
 * the centres of a w x h image from each scene camera in turn (n = w h ncams). segment: random
 * rays over (tnear, tfar) with tnear up to a quarter of the diagonal and a length up to half.
 * shadow: from the closest hits of random rays (Embree's; misses start anywhere in the box)
 * to uniform points in the box, over (epsilon, 0.9999 length): what the direct-light pass casts. */
static inline size_t gr_rays(const pgi_scene *s, const pgi__rt *rt, gr_kind kind, size_t n, int w, int h, uint64_t seed,
                             pgi__tri_bvh_ray *r) {
    tu_rng g = tu_rng_make(seed);
    float lo[3], ext[3];
    for (int k = 0; k < 3; k++) {
        ext[k] = 0.98f * (s->bmax[k] - s->bmin[k]);
        lo[k] = s->bmin[k] + 0.01f * (s->bmax[k] - s->bmin[k]);
    }
    const float diag = pgi__scene_diagonal(s), eps = pgi__scene_epsilon(s);
    if (kind == GR_PRIMARY) {
        size_t i = 0;
        for (size_t c = 0; c < s->ncams; c++) {
            pgi_camera cam;
            const pgi_camera_def *cd = &s->cams[c];
            pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, w, h);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++, i++) {
                    pgi__v3 d = pgi__camera_dir(&cam, x, y);
                    r[i] = (pgi__tri_bvh_ray){{cam.eye[0], cam.eye[1], cam.eye[2]}, 0.f, {d.x, d.y, d.z}, INFINITY};
                }
        }
        return i;
    }
    for (size_t i = 0; i < n; i++) {
        float o[3], d[3];
        for (int k = 0; k < 3; k++) o[k] = lo[k] + ext[k] * tu_unif(&g);
        tu_unit_vec(&g, d);
        r[i] = (pgi__tri_bvh_ray){{o[0], o[1], o[2]}, 0.f, {d[0], d[1], d[2]}, INFINITY};
        if (kind == GR_SEGMENT) {
            r[i].tnear = 0.25f * diag * tu_unif(&g);
            r[i].tfar = r[i].tnear + 0.5f * diag * tu_unif(&g);
        } else if (kind == GR_SHADOW) {
            pgi__hit hh;
            float p[3] = {o[0], o[1], o[2]};
            if (pgi__rt_intersect(rt, v3(o[0], o[1], o[2]), v3(d[0], d[1], d[2]), 0.f, INFINITY, &hh))
                for (int k = 0; k < 3; k++) p[k] = o[k] + hh.t * d[k];
            float q[3], dd[3];
            for (int k = 0; k < 3; k++) {
                q[k] = lo[k] + ext[k] * tu_unif(&g);
                dd[k] = q[k] - p[k];
            }
            float len = sqrtf(tu_dot(dd, dd));
            tu_normalize(dd);
            r[i] = (pgi__tri_bvh_ray){{p[0], p[1], p[2]}, eps, {dd[0], dd[1], dd[2]}, 0.9999f * len};
        }
    }
    return n;
}

/* Agreement of hits `got` with reference hits `ref` (closest-hit queries). */
typedef struct gr_tally {
    size_t rays, ref_hits;
    size_t missed;   /* the reference hit, got missed */
    size_t extra;    /* got hit, the reference missed */
    size_t ties;     /* different triangles at t within the tolerance, the point on an edge of one (shared edges) */
    size_t overlaps; /* different triangles at t within the tolerance, inside both: coplanar overlapping
                        triangles (the scene's own z-fighting: Embree's pick is as arbitrary) */
    size_t wrong;    /* different triangles at different t */
    size_t bad_tuv;  /* same triangle, t or u, v outside the tolerance */
    double max_rel_t;
} gr_tally;

/* Tolerances: t relative 1e-4 (plus 1e-7 of the scene's diagonal, for hits near the origin); u, v
 * absolute 1e-3 (same triangle). */
static inline void gr_compare(const pgi__hit *got, const pgi__hit *ref, size_t n, float diag, gr_tally *c) {
    for (size_t i = 0; i < n; i++) {
        const pgi__hit *a = &got[i], *b = &ref[i];
        c->rays++;
        int ha = a->prim != UINT32_MAX, hb = b->prim != UINT32_MAX;
        c->ref_hits += hb;
        if (!ha || !hb) {
            c->missed += hb && !ha;
            c->extra += ha && !hb;
            continue;
        }
        double dt = fabs((double)a->t - b->t), tol = 1e-4 * fabs((double)b->t) + 1e-7 * diag;
        if (b->t > 0) c->max_rel_t = fmax(c->max_rel_t, dt / b->t);
        if (a->prim != b->prim) {
            if (dt <= tol) {
                float ea = fminf(fminf(a->u, a->v), 1.f - a->u - a->v),
                      eb = fminf(fminf(b->u, b->v), 1.f - b->u - b->v);
                if (ea > 1e-3f && eb > 1e-3f) c->overlaps++;
                else c->ties++;
                if (getenv("GR_DEBUG"))
                    fprintf(stderr, "tie ray %zu: prims %u %u t %.9g %.9g edge dist %.3g %.3g\n", i, a->prim, b->prim,
                            a->t, b->t, ea, eb);
            } else c->wrong++;
        } else if (!(dt <= tol) || !(fabsf(a->u - b->u) <= 1e-3f) || !(fabsf(a->v - b->v) <= 1e-3f)) {
            if (c->bad_tuv < 3)
                fprintf(stderr, "  ray %zu prim %u: t %.9g u %.6g v %.6g, expected t %.9g u %.6g v %.6g\n", i, a->prim,
                        a->t, a->u, a->v, b->t, b->u, b->v);
            c->bad_tuv++;
        }
    }
}

static inline void gr_print(const char *what, const char *kind, const gr_tally *c) {
    fprintf(stderr,
            "  %-18s %-8s %7zu rays %7zu hits: missed %zu extra %zu edge ties %zu (%.3f %%) coplanar overlaps %zu "
            "(%.3f "
            "%%) wrong %zu bad t/u/v %zu, max rel t %.2g\n",
            what, kind, c->rays, c->ref_hits, c->missed, c->extra, c->ties,
            c->ref_hits ? 100.0 * (double)c->ties / (double)c->ref_hits : 0.0, c->overlaps,
            c->ref_hits ? 100.0 * (double)c->overlaps / (double)c->ref_hits : 0.0, c->wrong, c->bad_tuv, c->max_rel_t);
}

#endif
