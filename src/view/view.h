/* View samples (G-buffer) from primary rays, and direct light. */
#ifndef PGI_VIEW_H
#define PGI_VIEW_H

#include "rt/rt.h"

/* Casts primary rays in 8-wide packets, one a pixel through its centre or,
 * with `jitter`, through a point of the pixel drawn from the seed
 * (pgi__view_dir; vs->jitter says which), follows
 * perfect mirrors and glass (up to 8 specular bounces; glass picks reflection
 * or refraction by Fresnel with a per-pixel RNG) to the first non-specular
 * hit, and fills `vs`. `emit` (3 floats a pixel) receives emitted radiance
 * seen along the eye path. */
pgi_status pgi__view_build(const pgi_scene *s, const pgi__rt *rt, const pgi_camera *cam, uint64_t seed, int jitter,
                           int threads, pgi_view_samples *vs, float *emit, uint64_t *rays);

/* Direct light at every valid view sample with shadow rays (point, spot, sun:
 * one ray each; emissive triangles: `area_samples` samples picked by power).
 * Writes weight-multiplied radiance (3 floats a pixel). */
pgi_status pgi__direct(const pgi_scene *s, const pgi__rt *rt, const pgi_view_samples *vs, int area_samples,
                       uint64_t seed, int threads, float *out, uint64_t *rays);

/* ---------------------------------------------------- where a pixel looks
 * A frame's view samples look through one point of their pixel each; the
 * image is the box-filtered pixel integral in expectation only when those
 * points are uniform over the pixel. Everything that decides the point is
 * here: the view pass (pgi__view_dir) and the reference path tracer
 * (pgi__camera_dir_at with its own random numbers) call these, nothing else
 * computes a primary direction. */

/* Unit direction through the image point (x + jx, y + jy), in pixels from the
 * top-left corner of the image: (jx, jy) in [0, 1)^2 is the position inside
 * pixel (x, y), (0.5, 0.5) its centre. */
static inline pgi__v3 pgi__camera_dir_at(const pgi_camera *c, int x, int y, float jx, float jy) {
    float u = (2.f * ((float)x + jx) / (float)c->width - 1.f) * c->tan_half_fov_y * c->aspect;
    float v = (1.f - 2.f * ((float)y + jy) / (float)c->height) * c->tan_half_fov_y;
    pgi__v3 d = v3_add(v3_load(c->forward), v3_add(v3_scale(v3_load(c->right), u), v3_scale(v3_load(c->up), v)));
    return v3_norm(d);
}

/* Unit direction through the centre of pixel (x, y). */
static inline pgi__v3 pgi__camera_dir(const pgi_camera *c, int x, int y) {
    return pgi__camera_dir_at(c, x, y, 0.5f, 0.5f);
}

/* Position (*jx, *jy) in [0, 1)^2 of the view sample of pixel i (= y * width
 * + x) in a frame with seed `seed`: the centre (0.5, 0.5) without `jitter`,
 * else uniform over the pixel, from a hash of (seed, i) alone (SplitMix64 of
 * a per-seed key stepped i times; 24 bits a coordinate): every pass of the
 * frame sees the same point, whatever the thread count or the loop order,
 * and frames with other seeds see independent points. */
static inline void pgi__pixel_jitter(int jitter, uint64_t seed, size_t i, float *jx, float *jy) {
    if (!jitter) {
        *jx = *jy = 0.5f;
        return;
    }
    uint64_t h = pgi__mix64(pgi__mix64(seed ^ 0x6a6974746572ULL) + 0x9e3779b97f4a7c15ULL * ((uint64_t)i + 1u));
    *jx = (float)(h >> 40) * (1.f / 16777216.f);
    *jy = (float)((h >> 16) & 0xffffffu) * (1.f / 16777216.f);
}

/* Unit direction of the view sample of pixel (x, y) (see pgi__pixel_jitter). */
static inline pgi__v3 pgi__view_dir(const pgi_camera *c, int jitter, uint64_t seed, int x, int y) {
    float jx, jy;
    pgi__pixel_jitter(jitter, seed, (size_t)y * (size_t)c->width + (size_t)x, &jx, &jy);
    return pgi__camera_dir_at(c, x, y, jx, jy);
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
