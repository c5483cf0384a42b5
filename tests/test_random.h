/* Random photons and view samples shared by the estimator-equality tests
 * (test_estimators.c, test_kdtree_bounds_kernels.c). */
#ifndef PGI__TEST_RANDOM_H
#define PGI__TEST_RANDOM_H

#include "test_util.h"

/* The photon box is [-0.5, 0.5]^3; the camera sees it from about 2.6 units
 * with a narrow field of view, so that parts of the box (and of the photon
 * spheres) fall outside the view frustum. */
typedef struct {
    float eye[3], at[3], up[3], fov, tmin, tmax;
} tu_view_setup;
static const tu_view_setup k_outside = {{0.3f, 0.4f, 2.5f}, {0.f, 0.f, 0.f}, {0.f, 1.f, 0.f}, 25.f, 2.0f, 3.1f};
/* The eye inside the photon cloud: photons behind it, beside it, and photon
 * spheres that contain the eye or cross the eye plane. */
static const tu_view_setup k_inside = {{0.1f, -0.05f, 0.2f}, {0.f, 0.f, -1.f}, {0.f, 1.f, 0.f}, 70.f, 0.02f, 0.7f};
/* n random photons (tu_random_photon), emitted = n. */
static inline void tu_make_photons(pgi_photons *ph, size_t n, uint64_t seed) {
    TU_CHECK_OK(pgi_photons_alloc(ph, n));
    tu_rng r = tu_rng_make(seed);
    for (size_t j = 0; j < n; j++) tu_random_photon(ph, j, &r, NULL);
    ph->count = n;
    ph->emitted = n;
}

/* View samples on a camera ray through each pixel at a random depth: through
 * the pixel centre, or with `jitter` through a random point of the pixel
 * (vs->jitter = 0.5, as the renderer's jittered frames; a quarter of them on
 * the pixel's edges and corners, the worst case for screen-space bounds).
 * About 10% invalid, 10% Blinn-Phong; `secondary` of the valid ones are
 * mirror-reflected samples (no PGI_VS_PRIMARY) anywhere in the box. */
static inline void tu_make_samples_j(pgi_view_samples *vs, pgi_camera *cam, const tu_view_setup *g_view, int W, int H,
                                     uint64_t seed, float secondary, int jitter) {
    TU_CHECK_OK(pgi_view_samples_alloc(vs, W, H));
    pgi_camera_look_at(cam, g_view->eye, g_view->at, g_view->up, g_view->fov, W, H);
    vs->jitter = jitter ? 0.5f : 0.f;
    tu_rng r = tu_rng_make(seed);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * W + (size_t)x;
            float dir[3], pos[3], wo[3];
            float jx = 0.5f, jy = 0.5f;
            if (jitter) {
                jx = tu_unif(&r), jy = tu_unif(&r);
                if (tu_unif(&r) < 0.25f) { /* on an edge or a corner of the pixel */
                    jx = jx < 0.5f ? 0.f : 1.f;
                    if (tu_unif(&r) < 0.5f) jy = jy < 0.5f ? 0.f : 1.f;
                }
            }
            tu_pixel_dir_at(cam, x, y, jx, jy, dir);
            float t = tu_range(&r, g_view->tmin, g_view->tmax);
            for (int k = 0; k < 3; k++) pos[k] = cam->eye[k] + t * dir[k];
            float kind = tu_unif(&r);
            uint8_t flags = PGI_VS_VALID | PGI_VS_PRIMARY | PGI_VS_LAMBERT;
            float ks = 0.f, shin = 0.f;
            if (kind < 0.1f) flags = 0;
            else if (kind < 0.2f) {
                flags = PGI_VS_VALID | PGI_VS_PRIMARY;
                ks = tu_range(&r, 0.04f, 0.5f);
                shin = 20.f;
            }
            if (flags && tu_unif(&r) < secondary) {
                /* Seen through a mirror: anywhere in the box, from anywhere. */
                flags = (uint8_t)(flags & ~PGI_VS_PRIMARY);
                for (int k = 0; k < 3; k++) pos[k] = tu_range(&r, -0.5f, 0.5f);
                tu_unit_vec(&r, wo);
            } else {
                for (int k = 0; k < 3; k++) wo[k] = cam->eye[k] - pos[k];
                tu_normalize(wo);
            }
            tu_set_random_sample(vs, i, &r, pos, wo, ks, shin, t, flags);
        }
}

/* View samples through pixel centres (tu_make_samples_j without jitter). */
static inline void tu_make_samples(pgi_view_samples *vs, pgi_camera *cam, const tu_view_setup *g_view, int W, int H,
                                   uint64_t seed, float secondary) {
    tu_make_samples_j(vs, cam, g_view, W, H, seed, secondary, 0);
}

#endif
