/* The per-photon contribution test and sum shared by every estimator
 * (docs/design.md, "Estimators"), so that all exact methods make identical decisions and
 * differ only in summation order; the kernel-weighted variants. */
#ifndef PGI__EST_GATHER_H
#define PGI__EST_GATHER_H

#include "core/core.h"

#include <string.h>
#include "scene/bsdf.h"

/* A view sample loaded once per gather. */
typedef struct pgi__vs {
    float px, py, pz, nx, ny, nz;
    pgi__v3 wo, kd;
    int lambert;
    pgi__lobe lobe; /* set up only when !lambert */
    float one_m_eo; /* GGX: 1 - E(n.wo), the same for every photon of the gather */
    float lkey[5];  /* pgi__vs_load_reuse: the ks, shininess, ior the lobe was set up from */
    uint8_t lflags; /* pgi__vs_load_reuse: and the sample's flags */
} pgi__vs;

/* Running sums of one gather: Lambertian part as a flux sum (kd/pi applied
 * once at the end), the rest of the BSDF (pgi__lobe_eval: Blinn-Phong, or the
 * plastic's lobe and its base's change from kd/pi) as f*flux. */
typedef struct pgi__acc {
    float fr, fg, fb; /* sum of flux */
    float sr, sg, sb; /* sum of specular f * flux */
    uint32_t contributing;
} pgi__acc;

/* Sample i's position, normal, wo and kd (pgi__vs_load, pgi__vs_load_reuse). */
static inline void pgi__vs_load_geom(const pgi_view_samples *vs, size_t i, pgi__vs *v) {
    const float *p = vs->pos + 3 * i, *n = vs->nrm + 3 * i;
    v->px = p[0];
    v->py = p[1];
    v->pz = p[2];
    v->nx = n[0];
    v->ny = n[1];
    v->nz = n[2];
    v->wo = v3_load(vs->wo + 3 * i);
    v->kd = v3_load(vs->kd + 3 * i);
}

static inline void pgi__vs_load(const pgi_view_samples *vs, size_t i, pgi__vs *v) {
    pgi__vs_load_geom(vs, i, v);
    v->lambert = (vs->flags[i] & PGI_VS_LAMBERT) != 0;
    if (!v->lambert) {
        pgi__vs_lobe(vs, i, &v->lobe);
        v->one_m_eo = pgi__lobe_one_m_eo(&v->lobe, v3(v->nx, v->ny, v->nz), v->wo);
    }
}

/* Starts the gather of sample i: an invalid sample (sky, lost eye path)
 * gets zero radiance and 0 is returned; otherwise the sample is loaded. */
static inline int pgi__vs_begin(const pgi_view_samples *vs, size_t i, float *out, pgi__vs *v) {
    if (!(vs->flags[i] & PGI_VS_VALID)) {
        out[0] = out[1] = out[2] = 0.f;
        return 0;
    }
    pgi__vs_load(vs, i, v);
    return 1;
}

/* Constant kernel: a photon contributes when it lies strictly inside the
 * sphere of radius r around the sample and arrives from the sample's
 * hemisphere (dot(n, w_p) > 0). */
static inline void pgi__gather(const pgi__vs *v, float r2, float px, float py, float pz, float dx, float dy, float dz,
                               float fr, float fg, float fb, pgi__acc *a) {
    float ex = px - v->px, ey = py - v->py, ez = pz - v->pz;
    float d2 = ex * ex + ey * ey + ez * ez;
    if (!(d2 < r2)) return;
    float c = v->nx * dx + v->ny * dy + v->nz * dz;
    if (!(c > 0.f)) return;
    a->contributing++;
    a->fr += fr;
    a->fg += fg;
    a->fb += fb;
    if (!v->lambert) {
        pgi__v3 f = pgi__lobe_eval_o(&v->lobe, v->kd, v3(v->nx, v->ny, v->nz), v3(dx, dy, dz), v->wo, v->one_m_eo);
        a->sr += f.x * fr;
        a->sg += f.y * fg;
        a->sb += f.z * fb;
    }
}

/* ------------------------------------------------- batched glossy gather
 * pgi__gather for a non-Lambertian sample over many photons, with the lobe taken a batch at a
 * time: pgi__gather_push makes gather's two tests (the same expressions) and keeps a
 * contributing photon's direction and flux, branch-free (every photon is written to the next
 * slot, which only a contributing one takes); the batch, when full and at the end
 * (pgi__gather_flush), evaluates the lobe for its photons (8 at a time in an AVX2 build,
 * gather.c) and adds their flux and f * flux to the sums in push order. Each sum takes the same
 * terms in the same order as with pgi__gather, and the lobe's lanes compute pgi__lobe_eval_o's
 * expressions (no FMA), so the sums are the same bits. The lobe, the costly part, runs only for
 * the photons that contribute. */
#define PGI__GATHER_BATCH 64
typedef struct pgi__gather_batch {
    uint32_t n;
    float dx[PGI__GATHER_BATCH], dy[PGI__GATHER_BATCH], dz[PGI__GATHER_BATCH];
    float fr[PGI__GATHER_BATCH], fg[PGI__GATHER_BATCH], fb[PGI__GATHER_BATCH];
} pgi__gather_batch;

/* Evaluates the lobe of v (not Lambertian) for the batch's photons, adds their flux and f * flux
 * to a's sums in batch order and empties the batch. gather.c. */
void pgi__gather_flush(const pgi__vs *v, pgi__gather_batch *b, pgi__acc *a);

/* pgi__gather for a non-Lambertian sample, its sums deferred to the batch. */
static inline void pgi__gather_push(const pgi__vs *v, float r2, float px, float py, float pz, float dx, float dy,
                                    float dz, float fr, float fg, float fb, pgi__acc *a, pgi__gather_batch *b) {
    float ex = px - v->px, ey = py - v->py, ez = pz - v->pz;
    float d2 = ex * ex + ey * ey + ez * ez;
    float c = v->nx * dx + v->ny * dy + v->nz * dz;
    const uint32_t ok = (d2 < r2) & (c > 0.f), k = b->n;
    b->dx[k] = dx, b->dy[k] = dy, b->dz[k] = dz;
    b->fr[k] = fr, b->fg[k] = fg, b->fb[k] = fb;
    a->contributing += ok;
    if ((b->n = k + ok) == PGI__GATHER_BATCH) pgi__gather_flush(v, b, a);
}

/* pgi__vs_load into a v that may hold the lobe of an earlier sample: the lobe is set up again
 * (pgi__lobe_init interpolates a table row) only when sample i's lobe parameters differ from the
 * ones it was set up from (*have: v holds a lobe; neighbouring samples mostly share a
 * material). The same v as pgi__vs_load. */
static inline void pgi__vs_load_reuse(const pgi_view_samples *vs, size_t i, pgi__vs *v, int *have) {
    const uint8_t f = vs->flags[i];
    if (!*have || (f & PGI_VS_LAMBERT) || v->lambert || ((f ^ v->lflags) & PGI_VS_GGX) ||
        memcmp(v->lkey, vs->ks + 3 * i, 3 * sizeof(float)) || v->lkey[3] != vs->shininess[i] ||
        ((f & PGI_VS_GGX) && v->lkey[4] != vs->ior[i])) {
        pgi__vs_load(vs, i, v);
        if (!v->lambert) {
            memcpy(v->lkey, vs->ks + 3 * i, 3 * sizeof(float));
            v->lkey[3] = vs->shininess[i];
            v->lkey[4] = (f & PGI_VS_GGX) ? vs->ior[i] : 0.f;
            v->lflags = f;
            *have = 1;
        }
        return;
    }
    pgi__vs_load_geom(vs, i, v);
    v->one_m_eo = pgi__lobe_one_m_eo(&v->lobe, v3(v->nx, v->ny, v->nz), v->wo);
}

/* Radiance from the sums: (kd/pi * flux + spec) / (pi r^2). */
static inline void pgi__acc_finish(const pgi__vs *v, const pgi__acc *a, float r2, float *out) {
    float w = 1.f / (PGI__PI * r2);
    out[0] = (v->kd.x * PGI__INV_PI * a->fr + a->sr) * w;
    out[1] = (v->kd.y * PGI__INV_PI * a->fg + a->sg) * w;
    out[2] = (v->kd.z * PGI__INV_PI * a->fb + a->sb) * w;
}

/* ---------------------------------------------------------------- kernels
 * Kernel-weighted variants of pgi__gather (same per-photon decision: d^2 < r^2
 * strictly, dot(n, w_p) > 0). The weight w(d) is the kernel without its
 * normalisation; pgi__acc_finish_k applies norm / (pi r^2):
 *   constant     1                     norm 1
 *   cone         1 - d/r               norm 3
 *   Epanechnikov 1 - d^2/r^2           norm 2
 * so that each kernel integrates to 1 over its disk (tests check this). */
static inline float pgi__kernel_weight(pgi_kernel k, float d2, float r2) {
    if (k == PGI_KERNEL_CONE) return 1.f - sqrtf(d2 / r2);
    if (k == PGI_KERNEL_EPANECHNIKOV) return 1.f - d2 / r2;
    return 1.f;
}
static inline float pgi__kernel_norm(pgi_kernel k) {
    return k == PGI_KERNEL_CONE ? 3.f : k == PGI_KERNEL_EPANECHNIKOV ? 2.f : 1.f;
}

/* Adds one photon with weight w, unconditionally (k-NN uses it for the
 * photons it selected). */
static inline void pgi__acc_add(const pgi__vs *v, float w, float dx, float dy, float dz, float fr, float fg, float fb,
                                pgi__acc *a) {
    a->contributing++;
    a->fr += w * fr;
    a->fg += w * fg;
    a->fb += w * fb;
    if (!v->lambert) {
        pgi__v3 f = pgi__lobe_eval_o(&v->lobe, v->kd, v3(v->nx, v->ny, v->nz), v3(dx, dy, dz), v->wo, v->one_m_eo);
        a->sr += f.x * (w * fr);
        a->sg += f.y * (w * fg);
        a->sb += f.z * (w * fb);
    }
}

/* pgi__gather with a kernel; the constant kernel takes pgi__gather itself. */
static inline void pgi__gather_k(const pgi__vs *v, float r2, pgi_kernel kern, float px, float py, float pz, float dx,
                                 float dy, float dz, float fr, float fg, float fb, pgi__acc *a) {
    if (kern == PGI_KERNEL_CONSTANT) {
        pgi__gather(v, r2, px, py, pz, dx, dy, dz, fr, fg, fb, a);
        return;
    }
    float ex = px - v->px, ey = py - v->py, ez = pz - v->pz;
    float d2 = ex * ex + ey * ey + ez * ez;
    if (!(d2 < r2)) return;
    float c = v->nx * dx + v->ny * dy + v->nz * dz;
    if (!(c > 0.f)) return;
    pgi__acc_add(v, pgi__kernel_weight(kern, d2, r2), dx, dy, dz, fr, fg, fb, a);
}

/* pgi__acc_finish times the kernel normalisation and `scale` (subsampling). */
static inline void pgi__acc_finish_k(const pgi__vs *v, const pgi__acc *a, float r2, pgi_kernel kern, float scale,
                                     float *out) {
    pgi__acc_finish(v, a, r2, out);
    float m = pgi__kernel_norm(kern) * scale;
    if (m != 1.f) out[0] *= m, out[1] *= m, out[2] *= m;
}

#endif
