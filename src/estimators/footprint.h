#ifndef PGI__EST_FOOTPRINT_H
#define PGI__EST_FOOTPRINT_H

#include "gather.h"

/* ---- Per-photon footprints (radius policies, PGI_EST_CAP_PHOTON_RADIUS) ----
 * A photon with its own footprint contributes f * flux / A_p, A_p = pi r_p^2 (for an ellipsoid
 * r_p^2 = |a x b|: the area of its footprint ellipse on the surface it hit, BVH paper eq. 10).
 * The weight 1/A_p is folded into the flux before the sum, and the sum is finished with
 * pgi__acc_finish_w(.., 1). Spheres use pgi__gather with r_p^2 (same strict test as the fixed
 * radius); ellipsoids test containment in their skewed frame, then call pgi__gather with an
 * infinite radius so that the hemisphere test and the sum are the shared ones. */
static inline float pgi__footprint_weight(float r) { return 1.f / (PGI__PI * r * r); }

static inline void pgi__acc_finish_w(const pgi__vs *v, const pgi__acc *a, float w, float *out) {
    out[0] = (v->kd.x * PGI__INV_PI * a->fr + a->sr) * w;
    out[1] = (v->kd.y * PGI__INV_PI * a->fg + a->sg) * w;
    out[2] = (v->kd.z * PGI__INV_PI * a->fb + a->sb) * w;
}

/* Inverse (row-major, 9 floats) of the ellipsoid frame M = [a | b | c*n]: u = inv * (x - p) are the
 * ellipsoid coordinates of x. Returns 0 (and a zero matrix: nothing is inside) when degenerate.
 * Every estimator computes inv with this function, so all of them take the same decisions. */
static inline int pgi__ellipsoid_inverse(float ax, float ay, float az, float bx, float by, float bz, float cx, float cy,
                                         float cz, float inv[9]) {
    /* rows of M^-1 are (b x c, c x a, a x b) / det */
    float r0x = by * cz - bz * cy, r0y = bz * cx - bx * cz, r0z = bx * cy - by * cx;
    float r1x = cy * az - cz * ay, r1y = cz * ax - cx * az, r1z = cx * ay - cy * ax;
    float r2x = ay * bz - az * by, r2y = az * bx - ax * bz, r2z = ax * by - ay * bx;
    float det = ax * r0x + ay * r0y + az * r0z;
    if (!(fabsf(det) > 0.f) || !isfinite(det)) {
        for (int k = 0; k < 9; k++) inv[k] = 0.f;
        return 0;
    }
    float id = 1.f / det;
    inv[0] = r0x * id;
    inv[1] = r0y * id;
    inv[2] = r0z * id;
    inv[3] = r1x * id;
    inv[4] = r1y * id;
    inv[5] = r1z * id;
    inv[6] = r2x * id;
    inv[7] = r2y * id;
    inv[8] = r2z * id;
    return 1;
}

/* x - p strictly inside the ellipsoid (|u|^2 < 1). A degenerate (zero) inverse accepts nothing. */
static inline int pgi__ellipsoid_contains(const float inv[9], float ex, float ey, float ez) {
    float u = inv[0] * ex + inv[1] * ey + inv[2] * ez;
    float w = inv[3] * ex + inv[4] * ey + inv[5] * ez;
    float t = inv[6] * ex + inv[7] * ey + inv[8] * ez;
    float q = u * u + w * w + t * t;
    return q < 1.f && (inv[0] != 0.f || inv[1] != 0.f || inv[2] != 0.f);
}

/* Ellipsoid footprint: flux already multiplied by pgi__footprint_weight(r_p). */
static inline void pgi__gather_ellipsoid(const pgi__vs *v, const float inv[9], float px, float py, float pz, float dx,
                                         float dy, float dz, float fr, float fg, float fb, pgi__acc *a) {
    if (!pgi__ellipsoid_contains(inv, v->px - px, v->py - py, v->pz - pz)) return;
    pgi__gather(v, INFINITY, px, py, pz, dx, dy, dz, fr, fg, fb, a);
}

/* Axis-aligned half extents of photon j's ellipsoid [a | b | r n]. */
static inline void pgi__ellipsoid_extent(const pgi_photons *ph, size_t j, float h[3]) {
    float r = ph->radius[j];
    float cx = r * ph->nx[j], cy = r * ph->ny[j], cz = r * ph->nz[j];
    h[0] = sqrtf(ph->sax[j] * ph->sax[j] + ph->sbx[j] * ph->sbx[j] + cx * cx);
    h[1] = sqrtf(ph->say[j] * ph->say[j] + ph->sby[j] * ph->sby[j] + cy * cy);
    h[2] = sqrtf(ph->saz[j] * ph->saz[j] + ph->sbz[j] * ph->sbz[j] + cz * cz);
}

/* pgi__ellipsoid_inverse for photon j. */
static inline int pgi__photon_ellipsoid_inverse(const pgi_photons *ph, size_t j, float inv[9]) {
    float r = ph->radius[j];
    return pgi__ellipsoid_inverse(ph->sax[j], ph->say[j], ph->saz[j], ph->sbx[j], ph->sby[j], ph->sbz[j], r * ph->nx[j],
                                  r * ph->ny[j], r * ph->nz[j], inv);
}

#endif
