/* Materials as BSDFs: evaluation (shared by direct light and every
 * estimator, so that all of them compute the same numbers) and sampling
 * (photon tracing and eye paths). Directions point away from the surface. */
#ifndef PGI_BSDF_H
#define PGI_BSDF_H

#include "scene_internal.h"

/* Energy-conserving Blinn-Phong specular lobe of the tiled paper, eqs. 6-8:
 * (8+s)/(8 pi) * F * max(0, h.n)^s with Schlick's F = F0 + (1-F0)(1 - max(0, h.wi))^5.
 * Returns the lobe without F0 applied in `fs` and the (1-F) factor base, so the
 * caller combines per channel: spec_c = k * (F0_c + (1 - F0_c) * fr). */
static inline void pgi__phong_lobe(pgi__v3 n, pgi__v3 wi, pgi__v3 wo, float s, float *k, float *fr) {
    pgi__v3 h = v3_add(wi, wo);
    float hl = v3_len(h);
    if (!(hl > 0.f)) {
        *k = 0.f;
        *fr = 0.f;
        return;
    }
    h = v3_scale(h, 1.f / hl);
    float hn = fmaxf(0.f, v3_dot(h, n));
    float hi = fmaxf(0.f, v3_dot(h, wi));
    float m = 1.f - hi, m2 = m * m;
    *fr = m2 * m2 * m;
    *k = (8.f + s) * (1.f / (8.f * PGI_PI)) * powf(hn, s);
}

/* f(wi, wo) for a non-specular surface: kd/pi + Blinn-Phong (ks = F0).
 * Lambertian when ks is zero. No cosine. */
static inline pgi__v3 pgi__brdf_eval(pgi__v3 kd, pgi__v3 ks, float s, pgi__v3 n, pgi__v3 wi, pgi__v3 wo) {
    pgi__v3 f = v3_scale(kd, PGI_INV_PI);
    if (ks.x > 0.f || ks.y > 0.f || ks.z > 0.f) {
        float k, fr;
        pgi__phong_lobe(n, wi, wo, s, &k, &fr);
        f.x += k * (ks.x + (1.f - ks.x) * fr);
        f.y += k * (ks.y + (1.f - ks.y) * fr);
        f.z += k * (ks.z + (1.f - ks.z) * fr);
    }
    return f;
}

static inline pgi__v3 pgi__reflect(pgi__v3 w, pgi__v3 n) { return v3_sub(v3_scale(n, 2.f * v3_dot(w, n)), w); }

/* Unpolarised Fresnel reflectance of a dielectric; cos_i > 0 on the incident side. */
static inline float pgi__fresnel_dielectric(float cos_i, float eta_i, float eta_t) {
    float sin_t = eta_i / eta_t * sqrtf(fmaxf(0.f, 1.f - cos_i * cos_i));
    if (sin_t >= 1.f) return 1.f;
    float cos_t = sqrtf(fmaxf(0.f, 1.f - sin_t * sin_t));
    float rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    float rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    return 0.5f * (rs * rs + rp * rp);
}

/* Surface point from a hit. */
typedef struct pgi__surface {
    pgi__v3 p;
    pgi__v3 ng; /* unit geometric normal (winding order) */
    pgi__v3 ns; /* unit shading normal, same side as ng */
    float u, v; /* texture coordinates */
    const pgi__material *mat;
    pgi__v3 kd; /* albedo with the texture applied */
} pgi__surface;

void pgi__scene_surface(const pgi_scene *s, uint32_t prim, float bu, float bv, pgi__v3 p, pgi__surface *out);
/* The same without the texture fetch (kd is the material's); pgi__surface_texture applies it
 * later, only where a path needs the albedo. */
void pgi__scene_surface_untextured(const pgi_scene *s, uint32_t prim, float bu, float bv, pgi__v3 p, pgi__surface *out);
/* Texture coordinates at barycentrics (bu, bv) of triangle prim (the scene has uvs). */
static inline void pgi__scene_uv(const pgi_scene *s, uint32_t prim, float bu, float bv, float *u, float *v) {
    const uint32_t *t = s->tri + 3 * (size_t)prim;
    const float *ua = s->uv + 2 * (size_t)t[0], *ub = s->uv + 2 * (size_t)t[1], *uc = s->uv + 2 * (size_t)t[2];
    float bw = 1.f - bu - bv;
    *u = bw * ua[0] + bu * ub[0] + bv * uc[0];
    *v = bw * ua[1] + bu * ub[1] + bv * uc[1];
}

/* Prefetches the texels pgi__surface_texture will read for a hit (nothing for an untextured
 * material). */
static inline void pgi__surface_prefetch_texels(const pgi_scene *s, uint32_t prim, float bu, float bv) {
    const pgi__material *m = &s->mats[s->tri_mat[prim]];
    if (m->tex_kd < 0 || !s->uv) return;
    float u, v;
    pgi__scene_uv(s, prim, bu, bv, &u, &v);
    pgi__texture_prefetch(&s->texs[m->tex_kd], u, v);
}

static inline void pgi__surface_texture(const pgi_scene *s, pgi__surface *sf) {
    if (sf->mat->tex_kd >= 0) sf->kd = v3_mul(sf->kd, pgi__texture_lookup(&s->texs[sf->mat->tex_kd], sf->u, sf->v));
}

static inline int pgi__mat_specular(const pgi__material *m) {
    return m->type == PGI_MAT_MIRROR || m->type == PGI_MAT_GLASS;
}

/* Samples the continuation of a path arriving from `wi` (pointing away from
 * the surface) at `sf`. Writes the new direction and the weight f*cos/pdf.
 * Returns 0 when the path ends (absorbed, or sampled under the surface). */
int pgi__bsdf_sample(const pgi__surface *sf, pgi__v3 wi, float u1, float u2, float u3, pgi__v3 *wo, pgi__v3 *weight);

/* Solid-angle density with which pgi__bsdf_sample picks `wo` at a non-specular
 * surface, arriving from `wi` (both pointing away). 0 for mirror and glass
 * (delta lobes) and below the surface. Used for multiple importance sampling. */
float pgi__bsdf_pdf(const pgi__surface *sf, pgi__v3 wi, pgi__v3 wo);

#endif
