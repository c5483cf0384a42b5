/* View samples (G-buffer) from primary rays, and direct light. */
#ifndef PGI__VIEW_H
#define PGI__VIEW_H

#include <string.h>

#include "rt/rt.h"
#include "scene/light.h"
#include "scene/tri_cache.h"

/* Where the view samples of a frame look in their pixels (pgi__pixel_jitter). */
typedef struct pgi__subpixel {
    int jitter;     /* 0: pixel centres */
    uint64_t seed;  /* the sequence's seed: the frame's own, or frame 0's in a progressive run */
    uint32_t index; /* the frame's place in the sequence: 0 for a lone frame, k for progressive frame k */
    float shift[2]; /* added to every point (pgi_render_desc.shift), pixels */
    /* 1: the view samples' textures are filtered (pgi_render_desc.texture_filter resolved: ray cones
       of a pixel's width, trilinear between mip levels; docs/design.md "Textures"); 0: level 0 */
    int tex_filter;
    float tex_scale; /* the cones' width in pixels (0: 1, a pixel's) */
} pgi__subpixel;
/* Do the view samples pass through the pixel centres (no jitter, no shift)? */
static inline int pgi__subpixel_centres(const pgi__subpixel *sp) {
    return !sp->jitter && sp->shift[0] == 0.f && sp->shift[1] == 0.f;
}

/* What the destination of the view pass holds already, row by row (the renderer keeps one beside
 * its view samples and emitted radiance). Most pixels of a frame store fixed defaults in five
 * planes -- ks, shininess and ior +0 (Lambertian samples, and no sample), weight 1 (primary
 * samples), emit +0 (no emitter seen) -- which the frame before has most likely stored at the
 * same place already: the view pass skips those rows' stores (44 of the 105 bytes a pixel it
 * writes) and the composite their loads. Entry (y, c) covers the pixels [PGI__FILL_W c,
 * PGI__FILL_W (c + 1)) of row y (fewer at the right edge); its PGI__FILL_* bits say which of
 * those planes hold exactly the bytes of their defaults there now. */
enum {
    PGI__FILL_LOBE = 1,   /* ks, shininess and ior: every bit 0 */
    PGI__FILL_WEIGHT = 2, /* weight: 1.0f */
    PGI__FILL_EMIT = 4    /* emit: every bit 0 */
};
#define PGI__FILL_W 32 /* the view pass's block width */
typedef struct pgi__view_fill {
    int width, height, cols; /* the image the entries describe (0 x 0: none); cols entries a row */
    uint8_t *rows;           /* height * cols entries */
} pgi__view_fill;
/* Nothing is known of the destination any more (it was reallocated, or written by anything but
 * pgi__view_build with this record). */
static inline void pgi__view_fill_forget(pgi__view_fill *f) {
    if (f->rows) memset(f->rows, 0, (size_t)f->height * (size_t)f->cols);
}
void pgi__view_fill_free(pgi__view_fill *f);

/* Casts primary rays in 16-wide packets of 4x4 pixels, one a pixel through its centre or,
 * with sp->jitter, through the point pgi__pixel_jitter gives (pgi__view_dir;
 * vs->jitter says which), follows
 * perfect mirrors and glass (up to 8 specular bounces; glass picks reflection
 * or refraction by Fresnel with a per-pixel RNG) to the first non-specular
 * hit, and fills `vs`. `emit` (3 floats a pixel) receives emitted radiance
 * seen along the eye path. `fill` (NULL: every row is written) is the record of what vs and
 * emit hold (pgi__view_fill): rows that hold what they would receive are left alone, and it
 * is brought up to date (made anew for another size). Primary hits are shaded from the triangle
 * cache `tris` (pgi__tri_cache_update, brought up to date here: the renderer passes its tracer's,
 * so that both passes share one copy); NULL: records of its own for the call. */
pgi_status pgi__view_build(const pgi_scene *s, const pgi__rt *rt, pgi__tri_cache *tris, const pgi_camera *cam,
                           uint64_t seed, const pgi__subpixel *sp, int threads, pgi_view_samples *vs, float *emit,
                           pgi__view_fill *fill, uint64_t *rays);

/* The frame's image as pgi__direct writes it in place of its direct light (the composite): a
 * pixel's floats are emitted + direct light, plus its weight times the indirect light, `output`
 * picking the parts. A pass of its own would read the direct light back from memory (at
 * 1920x1080, 25 MB) on one thread. */
typedef struct pgi__direct_sum {
    const float *emit, *indirect; /* 3 floats a pixel each */
    pgi_output output;
    float *direct;            /* non-NULL: also receives emitted + direct light (3 floats a pixel; the AOV) */
    const pgi_cancel *cancel; /* may be NULL: once requested, the pass stops within a row of tiles a
                                 thread (PGI_ERR_CANCELLED, the image partly written) */
} pgi__direct_sum;
/* The image of PGI_OUTPUT_INDIRECT without the direct pass: weight x indirect, the floats the
 * composite writes. */
void pgi__indirect_image(const pgi_view_samples *vs, const float *indirect, int threads, float *out);
/* The AOVs of a frame (pgi_aovs) but direct, which the direct pass writes: albedo, normal and
 * depth from the view samples, indirect as weight x indirect. */
void pgi__view_aovs(const pgi_view_samples *vs, const float *indirect, int threads, pgi_aovs *aovs);

/* Direct light at every valid view sample with shadow rays (point, spot, sun:
 * one ray each; emissive triangles: `area_samples` samples picked by power;
 * the sky: `area_samples` directions, pgi__env_sample_direct, rays to infinity).
 * Writes weight-multiplied radiance (3 floats a pixel), or with `sum` (NULL: none) the image it
 * describes. `fill` (NULL: none), the record of what vs and sum->emit hold: the weights of the
 * rows it knows to be 1 and the emission of those it knows to be +0 are not read. */
pgi_status pgi__direct(const pgi_scene *s, const pgi__rt *rt, const pgi_view_samples *vs, const pgi__view_fill *fill,
                       const pgi__direct_sum *sum, int area_samples, uint64_t seed, int threads, float *out,
                       uint64_t *rays);

/* The area lights as pgi__direct samples them: their CDF by the luminance of their power (the
 * table the GPU backend and the reference path tracer build too) and one record a light (no
 * trip through the light, its triangle and its vertices). */
typedef struct pgi__area_rec {
    pgi__v3 a, b, c; /* the triangle's vertices */
    pgi__v3 normal, color;
    float area, p; /* p: the light's probability, cdf[k] - cdf[k - 1] as pgi__cdf_pick gives it */
} pgi__area_rec;
/* A guide table over the CDF (the cutpoint method, Chen and Asau 1974) makes a pick O(1) on
 * average whatever the number of emissive triangles: start[b] is the first entry whose cdf
 * exceeds (b - 1.5) / nb, below any u of bucket b = (int)(u nb) (float rounding moves u nb by
 * at most 1/16 for nb <= 2^20), so the first entry with u < cdf lies at or after start[b],
 * and a scan from there finds the entry pgi__cdf_pick's binary search finds: the same light
 * for the same u (tests/test_area_pick.c). */
typedef struct pgi__area_table {
    size_t n, nb;
    float *cdf;      /* n entries, cdf[n - 1] = 1 */
    uint32_t *start; /* nb + 1 entries; NULL: binary search (n < 2, or a cdf that decreases) */
    pgi__area_rec *rec;
} pgi__area_table;
/* The scene's area lights (t->n = 0: none). */
pgi_status pgi__area_table_build(const pgi_scene *s, pgi__area_table *t);
/* (Re)builds t->start from t->cdf and t->n. */
pgi_status pgi__area_table_guide(pgi__area_table *t);
void pgi__area_table_free(pgi__area_table *t);
/* The entry pgi__cdf_pick(t->cdf, t->n, u, .) picks, for u in [0, 1]. */
static inline size_t pgi__area_pick(const pgi__area_table *t, float u) {
    if (!t->start) {
        float p;
        return pgi__cdf_pick(t->cdf, t->n, u, &p);
    }
    size_t b = (size_t)(u * (float)t->nb);
    if (b >= t->nb) b = t->nb - 1;
    size_t i = t->start[b];
    while (i < t->n - 1 && !(u < t->cdf[i])) i++;
    return i;
}

/* ---------------------------------------------------- where a pixel looks
 * A frame's view samples look through one point of their pixel each; the
 * image is the box-filtered pixel integral in expectation only when those
 * points are uniform over the pixel. Everything that decides the point is
 * here: the view pass (pgi__view_dir) and the reference path tracer
 * (pgi__camera_dir_at with its own random numbers) call these, nothing else
 * computes a primary direction. */

/* The direction through the image point (x + jx, y + jy), in pixels from the
 * top-left corner of the image ((jx, jy) in [0, 1)^2 is the position inside
 * pixel (x, y), (0.5, 0.5) its centre), not normalised: its component along
 * the camera's forward axis is 1, so eye + t * it lies at view depth t (the
 * temporal step reprojects view samples with it). */
static inline pgi__v3 pgi__camera_ray_at(const pgi_camera *c, int x, int y, float jx, float jy) {
    float u = (2.f * ((float)x + jx) / (float)c->width - 1.f) * c->tan_half_fov_y * c->aspect;
    float v = (1.f - 2.f * ((float)y + jy) / (float)c->height) * c->tan_half_fov_y;
    return v3_add(v3_load(c->forward), v3_add(v3_scale(v3_load(c->right), u), v3_scale(v3_load(c->up), v)));
}

/* Unit direction through the image point (x + jx, y + jy) (pgi__camera_ray_at). */
static inline pgi__v3 pgi__camera_dir_at(const pgi_camera *c, int x, int y, float jx, float jy) {
    return v3_norm(pgi__camera_ray_at(c, x, y, jx, jy));
}

/* Unit direction through the centre of pixel (x, y). */
static inline pgi__v3 pgi__camera_dir(const pgi_camera *c, int x, int y) {
    return pgi__camera_dir_at(c, x, y, 0.5f, 0.5f);
}

/* Position (*jx, *jy) in [0, 1)^2 of pixel i's (= y * width + x) sample: the
 * centre (0.5, 0.5) without sp->jitter, else point sp->index of a per-pixel
 * R2 sequence (Roberts 2018: steps 1/g, 1/g^2 of the plastic number g, in
 * 32-bit fixed point, so the wrap-around is the fractional part) rotated by a
 * uniform offset hashed from (sp->seed, i) (SplitMix64 of a per-seed key
 * stepped i + 1 times). Each point is uniform over the pixel and independent
 * of other pixels' (the rotation), and the points of indices 0..N-1 cover the
 * pixel evenly (error O(log N / N) instead of O(1/sqrt N) for independent
 * points, which matters at high-contrast edges). A function of (seed, index,
 * i) alone: every pass of a frame sees the same point, whatever the thread
 * count or the loop order. */
static inline void pgi__pixel_jitter(const pgi__subpixel *sp, size_t i, float *jx, float *jy) {
    if (!sp->jitter) {
        *jx = 0.5f + sp->shift[0];
        *jy = 0.5f + sp->shift[1];
        return;
    }
    uint64_t h = pgi__mix64(pgi__mix64(sp->seed ^ 0x6a6974746572ULL) + 0x9e3779b97f4a7c15ULL * ((uint64_t)i + 1u));
    uint32_t ux = (uint32_t)(h >> 32) + sp->index * 0xc13fa9a9u; /* 2^32 / g */
    uint32_t uy = (uint32_t)h + sp->index * 0x91e10da6u;         /* 2^32 / g^2 */
    *jx = (float)(ux >> 8) * (1.f / 16777216.f) + sp->shift[0];
    *jy = (float)(uy >> 8) * (1.f / 16777216.f) + sp->shift[1];
}

/* Unit direction of the view sample of pixel (x, y) (see pgi__pixel_jitter). */
static inline pgi__v3 pgi__view_dir(const pgi_camera *c, const pgi__subpixel *sp, int x, int y) {
    float jx, jy;
    pgi__pixel_jitter(sp, (size_t)y * (size_t)c->width + (size_t)x, &jx, &jy);
    return pgi__camera_dir_at(c, x, y, jx, jy);
}

#endif
