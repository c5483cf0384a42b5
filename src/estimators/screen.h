#ifndef PGI__EST_SCREEN_H
#define PGI__EST_SCREEN_H

#include "core/core.h"

/* World to view space of a pinhole camera (x right, y up, z forward) and
 * the screen scale: view (x, y, z) projects to x / (z sx), y / (z sy) in
 * [-1, 1]. Shared by the screen-space methods (tiled, bounds) and the cluster
 * family. */
typedef struct pgi__view_xf {
    pgi__v3 eye, right, up, fwd;
    float sx, sy; /* tan(fov/2) * aspect, tan(fov/2) */
    int W, H;
} pgi__view_xf;

static inline pgi__view_xf pgi__view_xf_make(const pgi_camera *cam, int W, int H) {
    pgi__view_xf x = {v3_load(cam->eye),
                      v3_load(cam->right),
                      v3_load(cam->up),
                      v3_load(cam->forward),
                      cam->tan_half_fov_y * cam->aspect,
                      cam->tan_half_fov_y,
                      W,
                      H};
    return x;
}

/* The radius r of a sphere at view-space centre c padded for the rounding of
 * the view transform (relative to the distance from the eye) and of the
 * gather's d^2 < r^2: a bound tested with it never drops a sample the gather
 * accepts. */
static inline float pgi__pad_radius(pgi__v3 c, float r) {
    return r + 1e-4f * r + 1e-6f * (fabsf(c.x) + fabsf(c.y) + fabsf(c.z));
}

/* Squared distance from c to the box [lo, hi] (0 inside). */
static inline float pgi__box_d2(const float lo[3], const float hi[3], pgi__v3 c) {
    const float cc[3] = {c.x, c.y, c.z};
    float d2 = 0.f;
    for (int k = 0; k < 3; k++) {
        float a = lo[k] - cc[k], b = cc[k] - hi[k];
        float e = a > b ? a : b;
        if (e > 0.f) d2 += e * e;
    }
    return d2;
}

static inline pgi__v3 pgi__to_view(const pgi__view_xf *x, float px, float py, float pz) {
    pgi__v3 d = v3_sub(v3(px, py, pz), x->eye);
    return v3(v3_dot(d, x->right), v3_dot(d, x->up), v3_dot(d, x->fwd));
}

#endif
