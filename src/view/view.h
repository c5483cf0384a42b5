/* View samples (G-buffer) from primary rays, and direct light. */
#ifndef PGI_VIEW_H
#define PGI_VIEW_H

#include "rt/rt.h"

/* Casts primary rays in 8-wide packets through pixel centres, follows
 * perfect mirrors and glass (up to 8 specular bounces; glass picks reflection
 * or refraction by Fresnel with a per-pixel RNG) to the first non-specular
 * hit, and fills `vs`. `emit` (3 floats a pixel) receives emitted radiance
 * seen along the eye path. */
pgi_status pgi__view_build(const pgi_scene *s, const pgi__rt *rt, const pgi_camera *cam, uint64_t seed, int threads,
                           pgi_view_samples *vs, float *emit, uint64_t *rays);

/* Direct light at every valid view sample with shadow rays (point, spot, sun:
 * one ray each; emissive triangles: `area_samples` samples picked by power).
 * Writes weight-multiplied radiance (3 floats a pixel). */
pgi_status pgi__direct(const pgi_scene *s, const pgi__rt *rt, const pgi_view_samples *vs, int area_samples,
                       uint64_t seed, int threads, float *out, uint64_t *rays);

/* Unit direction through the centre of pixel (x, y); shared by the view pass
 * and the reference path tracer so that their pixels match. */
static inline pgi__v3 pgi__camera_dir(const pgi_camera *c, int x, int y) {
    float u = (2.f * ((float)x + 0.5f) / (float)c->width - 1.f) * c->tan_half_fov_y * c->aspect;
    float v = (1.f - 2.f * ((float)y + 0.5f) / (float)c->height) * c->tan_half_fov_y;
    pgi__v3 d = v3_add(v3_load(c->forward), v3_add(v3_scale(v3_load(c->right), u), v3_scale(v3_load(c->up), v)));
    return v3_norm(d);
}

/* Light from a delta light (point, spot, sun) at x with shading normal ns and
 * geometric normal ng: the unit direction `wi` towards the light, the
 * unshadowed radiance `Li`, the cosine `cs` = ns.wi and the far end `tmax` of
 * the shadow ray from x. Returns 0 when the light cannot reach x (an area
 * light, x at the light's position, outside a spot's cone, behind ns or ng).
 * Shared by pgi__direct and the reference path tracer's next-event
 * estimation, so that both compute the same numbers. */
static inline int pgi__delta_light(const pgi__light *lt, pgi__v3 x, pgi__v3 ns, pgi__v3 ng, pgi__v3 *wi, pgi__v3 *Li,
                                   float *cs, float *tmax) {
    float dist;
    if (lt->type == PGI_LIGHT_AREA) return 0;
    if (lt->type == PGI_LIGHT_SUN) {
        *wi = v3_neg(v3_load(lt->dir));
        dist = INFINITY;
        *Li = v3_load(lt->color);
    } else {
        pgi__v3 dv = v3_sub(v3_load(lt->pos), x);
        float d2 = v3_dot(dv, dv);
        if (!(d2 > 0.f)) return 0;
        dist = sqrtf(d2);
        *wi = v3_scale(dv, 1.f / dist);
        if (lt->type == PGI_LIGHT_SPOT && -v3_dot(*wi, v3_load(lt->dir)) < lt->cos_cutoff) return 0;
        *Li = v3_scale(v3_load(lt->color), 1.f / d2);
    }
    *cs = v3_dot(ns, *wi);
    if (!(*cs > 0.f) || !(v3_dot(ng, *wi) > 0.f)) return 0;
    *tmax = dist == INFINITY ? INFINITY : dist * (1.f - 1e-4f);
    return 1;
}

#endif
