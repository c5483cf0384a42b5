#ifndef PGI__EST_PACKED_H
#define PGI__EST_PACKED_H

#include "gather.h"

/* A photon copied into an estimator's own structure (hash-grid cell order,
 * tile lists): position, incoming direction, flux; 36 bytes. */
typedef struct pgi__packed_photon {
    float px, py, pz, dx, dy, dz, fr, fg, fb;
} pgi__packed_photon;

static inline void pgi__pack_photon(const pgi_photons *ph, size_t j, pgi__packed_photon *o) {
    o->px = ph->px[j];
    o->py = ph->py[j];
    o->pz = ph->pz[j];
    o->dx = ph->dx[j];
    o->dy = ph->dy[j];
    o->dz = ph->dz[j];
    o->fr = ph->fr[j];
    o->fg = ph->fg[j];
    o->fb = ph->fb[j];
}

static inline void pgi__gather_packed(const pgi__vs *v, float r2, const pgi__packed_photon *q, pgi__acc *a) {
    pgi__gather(v, r2, q->px, q->py, q->pz, q->dx, q->dy, q->dz, q->fr, q->fg, q->fb, a);
}

static inline void pgi__gather_push_packed(const pgi__vs *v, float r2, const pgi__packed_photon *q, pgi__acc *a,
                                           pgi__gather_batch *b) {
    pgi__gather_push(v, r2, q->px, q->py, q->pz, q->dx, q->dy, q->dz, q->fr, q->fg, q->fb, a, b);
}

/* pgi__gather_packed over q[0, n), a non-Lambertian sample's lobe a batch of contributing
 * photons at a time (pgi__gather_push): the same sums. */
static inline void pgi__gather_packed_n(const pgi__vs *v, float r2, const pgi__packed_photon *q, uint32_t n,
                                        pgi__acc *a) {
    if (v->lambert) {
        for (uint32_t k = 0; k < n; k++) pgi__gather_packed(v, r2, q + k, a);
        return;
    }
    pgi__gather_batch b;
    b.n = 0;
    for (uint32_t k = 0; k < n; k++) pgi__gather_push_packed(v, r2, q + k, a, &b);
    pgi__gather_flush(v, &b, a);
}

static inline void pgi__gather_packed_k(const pgi__vs *v, float r2, pgi_kernel kern, const pgi__packed_photon *q,
                                        pgi__acc *a) {
    pgi__gather_k(v, r2, kern, q->px, q->py, q->pz, q->dx, q->dy, q->dz, q->fr, q->fg, q->fb, a);
}

#endif
