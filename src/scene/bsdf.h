/* Materials as BSDFs: evaluation (shared by direct light and every
 * estimator, so that all of them compute the same numbers) and sampling
 * (photon tracing and eye paths). Directions point away from the surface. */
#ifndef PGI__BSDF_H
#define PGI__BSDF_H

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
    *k = (8.f + s) * (1.f / (8.f * PGI__PI)) * powf(hn, s);
}

/* Unpolarised Fresnel reflectance of a dielectric; cos_i > 0 on the incident side. */
static inline float pgi__fresnel_dielectric(float cos_i, float eta_i, float eta_t) {
    float sin_t = eta_i / eta_t * sqrtf(fmaxf(0.f, 1.f - cos_i * cos_i));
    if (sin_t >= 1.f) return 1.f;
    float cos_t = sqrtf(fmaxf(0.f, 1.f - sin_t * sin_t));
    float rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    float rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    return 0.5f * (rs * rs + rp * rp);
}

/* ------------------------------------------------ microfacet plastic (GGX)
 * A Lambertian base under a GGX (Trowbridge-Reitz) lobe with the Fresnel
 * reflectance of a dielectric of index eta (PGI__MAT_PLASTIC, docs/scene-format.md):
 *   f = tint F(h.wi) D(h) G2(wi, wo) / (4 |n.wi| |n.wo|)                   (Smith, height-correlated)
 *     + kd/pi (1 - E(n.wi)) (1 - E(n.wo)) / (1 - E_avg)                   (Kelemen & Szirmay-Kalos 2001)
 * E(mu) is the directional albedo of the untinted lobe (a table, microfacet.c) and
 * E_avg = 2 int_0^1 E(mu) mu dmu, so the base is reciprocal and a white base under
 * the lobe reflects exactly everything: albedo(wo) = E(wo) + kd (1 - E(wo)) (tint 1).
 * The table holds E at PGI__GGX_NMU values of mu = x^2, x uniform in [0, 1] (dense
 * at grazing angles, where E changes fastest), for alpha in
 * [PGI__GGX_ALPHA_MIN, 1] and a set of indices eta; pgi__lobe_init interpolates one
 * row for a material's alpha and eta. */
#define PGI__GGX_NMU 32
#define PGI__GGX_ALPHA_MIN 0.01f

typedef enum pgi__lobe_model { PGI__LOBE_NONE = 0, PGI__LOBE_PHONG = 1, PGI__LOBE_GGX = 2 } pgi__lobe_model;

/* The non-Lambertian part of a non-specular BSDF, set up once per shading point. */
typedef struct pgi__lobe {
    pgi__lobe_model model;
    pgi__v3 ks;           /* Phong: F0 per channel; GGX: tint (<= 1) on the dielectric's Fresnel */
    float s;              /* Phong: exponent; GGX: alpha */
    float eta;            /* GGX: index of refraction (> 1) */
    float a2;             /* GGX: alpha^2 */
    float inv_1mEavg;     /* GGX: 1 / (1 - E_avg) */
    float E[PGI__GGX_NMU]; /* GGX: E at the table's mu nodes for this alpha and eta */
} pgi__lobe;

/* GGX roughness of a Phong exponent (MTL Ns): alpha = sqrt(2 / (Ns + 2)), clamped to
 * [PGI__GGX_ALPHA_MIN, 1]. */
static inline float pgi__ggx_alpha_from_ns(float ns) {
    float a = sqrtf(2.f / (fmaxf(ns, 0.f) + 2.f));
    return a < PGI__GGX_ALPHA_MIN ? PGI__GGX_ALPHA_MIN : a > 1.f ? 1.f : a;
}
/* Normal-incidence reflectance of a dielectric of index eta (from air). */
static inline float pgi__fresnel_f0(float eta) {
    float r = (eta - 1.f) / (eta + 1.f);
    return r * r;
}

/* Sets up `l`: model PGI__LOBE_NONE (Lambertian), PHONG (ks = F0, s = exponent) or GGX
 * (ks = tint, s = alpha, eta). microfacet.c. */
void pgi__lobe_init(pgi__lobe *l, pgi__lobe_model model, pgi__v3 ks, float s, float eta);
/* The lobe of a non-specular material (Lambert: PGI__LOBE_NONE). */
void pgi__lobe_of_material(const pgi__material *m, pgi__lobe *l);
/* What pgi__lobe_of_material passes to pgi__lobe_init (the view samples store these). */
pgi__lobe_model pgi__lobe_params(const pgi__material *m, pgi__v3 *ks, float *s, float *eta);
/* Computes the table rows an index eta needs now rather than on first use (outside timed
 * passes). */
void pgi__ggx_prepare(float eta);

/* E(mu) of a set-up GGX lobe: linear in x = sqrt(mu) between the nodes. */
static inline float pgi__lobe_E(const pgi__lobe *l, float mu) {
    float x = sqrtf(fminf(fmaxf(mu, 0.f), 1.f)) * (float)(PGI__GGX_NMU - 1);
    int i = (int)x;
    if (i > PGI__GGX_NMU - 2) i = PGI__GGX_NMU - 2;
    float t = x - (float)i;
    return l->E[i] + (l->E[i + 1] - l->E[i]) * t;
}

/* Trowbridge-Reitz D(h) with cos(h, n) = c. */
static inline float pgi__ggx_D(float a2, float c) {
    float d = c * c * (a2 - 1.f) + 1.f;
    return a2 / (PGI__PI * d * d);
}
/* sqrt(c^2 + a2 (1 - c^2)) = c sqrt(1 + a2 tan^2): Smith's Lambda(w) = (this / c - 1) / 2. */
static inline float pgi__ggx_root(float a2, float c) { return sqrtf(c * c * (1.f - a2) + a2); }

/* Untinted GGX lobe F D G2 / (4 ci co) for unit wi, wo (ci = n.wi, co = n.wo, both > 0). */
static inline float pgi__ggx_spec(const pgi__lobe *l, pgi__v3 n, pgi__v3 wi, pgi__v3 wo, float ci, float co) {
    pgi__v3 h = v3_add(wi, wo);
    float hl = v3_len(h);
    if (!(hl > 0.f)) return 0.f;
    float hn = v3_dot(h, n) / hl, hi = fminf(1.f, fmaxf(0.f, v3_dot(h, wi) / hl));
    float F = pgi__fresnel_dielectric(hi, 1.f, l->eta);
    /* G2 / (4 ci co) = 1 / (2 (co root(ci) + ci root(co))) */
    float v = 0.5f / (co * pgi__ggx_root(l->a2, ci) + ci * pgi__ggx_root(l->a2, co));
    return F * pgi__ggx_D(l->a2, hn) * v;
}

/* Half vector h (local frame, n = +z) of GGX's distribution of the normals visible from V
 * (unit, V.z > 0), by Heitz 2018 "Sampling the GGX distribution of visible normals". */
static inline pgi__v3 pgi__ggx_sample_vndf(pgi__v3 V, float alpha, float u1, float u2) {
    pgi__v3 Vh = v3_norm(v3(alpha * V.x, alpha * V.y, V.z));
    float lensq = Vh.x * Vh.x + Vh.y * Vh.y;
    pgi__v3 T1 = lensq > 0.f ? v3_scale(v3(-Vh.y, Vh.x, 0.f), 1.f / sqrtf(lensq)) : v3(1.f, 0.f, 0.f);
    pgi__v3 T2 = v3_cross(Vh, T1);
    float r = sqrtf(u1), phi = 2.f * PGI__PI * u2;
    float t1 = r * cosf(phi), t2 = r * sinf(phi), sv = 0.5f * (1.f + Vh.z);
    t2 = (1.f - sv) * sqrtf(fmaxf(0.f, 1.f - t1 * t1)) + sv * t2;
    pgi__v3 Nh =
        v3_add(v3_add(v3_scale(T1, t1), v3_scale(T2, t2)), v3_scale(Vh, sqrtf(fmaxf(0.f, 1.f - t1 * t1 - t2 * t2))));
    return v3_norm(v3(alpha * Nh.x, alpha * Nh.y, fmaxf(0.f, Nh.z)));
}

/* Solid-angle density of wo from pgi__ggx_sample_vndf seen from wi, reflected:
 * G1(wi) D(h) / (4 ci) = D(h) / (2 (ci + root(ci))). */
static inline float pgi__ggx_pdf(const pgi__lobe *l, pgi__v3 n, pgi__v3 wi, pgi__v3 wo) {
    float ci = v3_dot(n, wi);
    if (!(ci > 0.f)) return 0.f;
    pgi__v3 h = v3_add(wi, wo);
    float hl = v3_len(h);
    if (!(hl > 0.f)) return 0.f;
    float hn = v3_dot(h, n) / hl;
    if (!(hn > 0.f)) return 0.f;
    return pgi__ggx_D(l->a2, hn) / (2.f * (ci + pgi__ggx_root(l->a2, ci)));
}

/* pgi__lobe_eval with 1 - E(n.wo) given (`one_m_eo`, used by GGX only): a gather evaluates one
 * sample's lobe for many wi and the same wo, so it looks E(n.wo) up once (pgi__lobe_one_m_eo). */
static inline pgi__v3 pgi__lobe_eval_o(const pgi__lobe *l, pgi__v3 kd, pgi__v3 n, pgi__v3 wi, pgi__v3 wo,
                                       float one_m_eo) {
    if (l->model == PGI__LOBE_PHONG) {
        float k, fr;
        pgi__phong_lobe(n, wi, wo, l->s, &k, &fr);
        return v3(k * (l->ks.x + (1.f - l->ks.x) * fr), k * (l->ks.y + (1.f - l->ks.y) * fr),
                  k * (l->ks.z + (1.f - l->ks.z) * fr));
    }
    if (l->model != PGI__LOBE_GGX) return v3(0.f, 0.f, 0.f);
    float ci = v3_dot(n, wi), co = v3_dot(n, wo);
    float base = (1.f - pgi__lobe_E(l, ci)) * one_m_eo * l->inv_1mEavg - 1.f;
    pgi__v3 r = v3_scale(kd, base * PGI__INV_PI);
    if (ci > 0.f && co > 0.f) r = v3_add(r, v3_scale(l->ks, pgi__ggx_spec(l, n, wi, wo, ci, co)));
    return r;
}

/* 1 - E(n.wo) of a GGX lobe (0 for the other models, which do not use it). */
static inline float pgi__lobe_one_m_eo(const pgi__lobe *l, pgi__v3 n, pgi__v3 wo) {
    return l->model == PGI__LOBE_GGX ? 1.f - pgi__lobe_E(l, v3_dot(n, wo)) : 0.f;
}

/* f(wi, wo) - kd/pi: what a non-specular BSDF adds to its Lambertian kd/pi (0 for
 * PGI__LOBE_NONE). Phong: the tiled paper's lobe; GGX: the lobe plus the base's change
 * from kd/pi. The estimators sum kd/pi over the flux once and this per photon. */
static inline pgi__v3 pgi__lobe_eval(const pgi__lobe *l, pgi__v3 kd, pgi__v3 n, pgi__v3 wi, pgi__v3 wo) {
    return pgi__lobe_eval_o(l, kd, n, wi, wo, pgi__lobe_one_m_eo(l, n, wo));
}

/* f(wi, wo) for a non-specular surface: kd/pi plus the lobe. No cosine. */
static inline pgi__v3 pgi__brdf_eval(pgi__v3 kd, const pgi__lobe *l, pgi__v3 n, pgi__v3 wi, pgi__v3 wo) {
    pgi__v3 f = v3_scale(kd, PGI__INV_PI);
    if (l->model != PGI__LOBE_NONE) f = v3_add(f, pgi__lobe_eval(l, kd, n, wi, wo));
    return f;
}

/* The lobe of valid view sample i (its PGI_VS_LAMBERT / PGI_VS_GGX flags, ks, shininess, ior). */
static inline void pgi__vs_lobe(const pgi_view_samples *vs, size_t i, pgi__lobe *l) {
    uint8_t f = vs->flags[i];
    pgi__lobe_model m = (f & PGI_VS_LAMBERT) ? PGI__LOBE_NONE : (f & PGI_VS_GGX) ? PGI__LOBE_GGX : PGI__LOBE_PHONG;
    /* A Lambertian lobe is its model alone (nothing reads its ks, s or eta): no load of the ks and
     * shininess planes, which the view pass then need not touch either (pgi__view_fill). ior only
     * for GGX: samples filled by hand for Blinn-Phong or Lambert need no ior plane. */
    if (m == PGI__LOBE_NONE) pgi__lobe_init(l, m, v3(0.f, 0.f, 0.f), 0.f, 1.5f);
    else pgi__lobe_init(l, m, v3_load(vs->ks + 3 * i), vs->shininess[i], m == PGI__LOBE_GGX ? vs->ior[i] : 1.5f);
}

static inline pgi__v3 pgi__reflect(pgi__v3 w, pgi__v3 n) { return v3_sub(v3_scale(n, 2.f * v3_dot(w, n)), w); }

/* Surface point from a hit. */
typedef struct pgi__surface {
    pgi__v3 p;
    pgi__v3 ng; /* unit geometric normal (winding order) */
    pgi__v3 ns; /* unit shading normal, same side as ng */
    float u, v; /* texture coordinates */
    const pgi__material *mat;
    pgi__v3 kd; /* albedo with the vertex colour and the texture applied (pgi__scene_kd, pgi__surface_texture) */
} pgi__surface;

void pgi__scene_surface(const pgi_scene *s, uint32_t prim, float bu, float bv, pgi__v3 p, pgi__surface *out);
/* The same without the texture fetch (kd is pgi__scene_kd's: the material's times the vertex
 * colour); pgi__surface_texture applies it later, only where a path needs the albedo. */
void pgi__scene_surface_untextured(const pgi_scene *s, uint32_t prim, float bu, float bv, pgi__v3 p, pgi__surface *out);
/* Texture coordinates at barycentrics (bu, bv) of triangle prim (the scene has uvs). */
static inline void pgi__scene_uv(const pgi_scene *s, uint32_t prim, float bu, float bv, float *u, float *v) {
    const uint32_t *t = s->tri + 3 * (size_t)prim;
    const float *ua = s->uv + 2 * (size_t)t[0], *ub = s->uv + 2 * (size_t)t[1], *uc = s->uv + 2 * (size_t)t[2];
    float bw = 1.f - bu - bv;
    *u = bw * ua[0] + bu * ub[0] + bv * uc[0];
    *v = bw * ua[1] + bu * ub[1] + bv * uc[1];
}

/* The vertex colour at barycentrics (bu, bv) of triangle prim (the scene has colours), interpolated
 * as pgi__scene_uv interpolates texture coordinates. */
static inline pgi__v3 pgi__scene_col(const pgi_scene *s, uint32_t prim, float bu, float bv) {
    const uint32_t *t = s->tri + 3 * (size_t)prim;
    const float *ca = s->col + 3 * (size_t)t[0], *cb = s->col + 3 * (size_t)t[1], *cc = s->col + 3 * (size_t)t[2];
    float bw = 1.f - bu - bv;
    return v3(bw * ca[0] + bu * cb[0] + bv * cc[0], bw * ca[1] + bu * cb[1] + bv * cc[1],
              bw * ca[2] + bu * cb[2] + bv * cc[2]);
}

/* The diffuse albedo of material m at barycentrics (bu, bv) of triangle prim before its texture:
 * m->kd, times the vertex colour where the scene has colours (scene_internal.h pgi_scene.col).
 * Every shading path starts from this (the texture, pgi__surface_texture, multiplies it after). */
static inline pgi__v3 pgi__scene_kd(const pgi_scene *s, const pgi__material *m, uint32_t prim, float bu, float bv) {
    const pgi__v3 kd = v3_load(m->kd);
    return s->col ? v3_mul(kd, pgi__scene_col(s, prim, bu, bv)) : kd;
}

static inline void pgi__surface_texture(const pgi_scene *s, pgi__surface *sf) {
    if (sf->mat->tex_kd >= 0) sf->kd = v3_mul(sf->kd, pgi__texture_lookup(&s->texs[sf->mat->tex_kd], sf->u, sf->v));
}

static inline int pgi__mat_specular(const pgi__material *m) {
    return m->type == PGI__MAT_MIRROR || m->type == PGI__MAT_GLASS;
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
