/* Surface interaction and BSDF sampling. */
#include "bsdf.h"

void pgi__scene_surface_untextured(const pgi_scene *s, uint32_t prim, float bu, float bv, pgi__v3 p, pgi__surface *o) {
    const uint32_t *t = s->tri + 3 * (size_t)prim;
    pgi__v3 a = pgi__scene_vertex(s, t[0]), b = pgi__scene_vertex(s, t[1]), c = pgi__scene_vertex(s, t[2]);
    float bw = 1.f - bu - bv;
    o->p = p;
    o->ng = v3_norm(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    o->ns = o->ng;
    if (s->nrm) {
        pgi__v3 n = v3_add(v3_add(v3_scale(v3_load(s->nrm + 3 * (size_t)t[0]), bw),
                                  v3_scale(v3_load(s->nrm + 3 * (size_t)t[1]), bu)),
                           v3_scale(v3_load(s->nrm + 3 * (size_t)t[2]), bv));
        float l = v3_len(n);
        if (l > 0.f && isfinite(l)) {
            n = v3_scale(n, 1.f / l);
            o->ns = v3_dot(n, o->ng) < 0.f ? v3_neg(n) : n;
        }
    }
    o->u = o->v = 0.f;
    if (s->uv) pgi__scene_uv(s, prim, bu, bv, &o->u, &o->v);
    o->mat = &s->mats[s->tri_mat[prim]];
    o->kd = pgi__scene_kd(s, o->mat, prim, bu, bv);
}

void pgi__scene_surface(const pgi_scene *s, uint32_t prim, float bu, float bv, pgi__v3 p, pgi__surface *o) {
    pgi__scene_surface_untextured(s, prim, bu, bv, p, o);
    pgi__surface_texture(s, o);
}

/* Probability that pgi__bsdf_sample picks the glossy lobe (else the cosine-weighted base):
 * Phong: by the luminances of ks and kd; GGX: by the lobe's and the base's albedos seen from wi,
 * lum(tint) E(ci) against lum(kd) (1 - E(ci)). */
static float glossy_pick(const pgi__lobe *l, pgi__v3 kd, pgi__v3 ns, pgi__v3 wi) {
    float wd = v3_lum(kd), wsp = v3_lum(l->ks);
    if (l->model == PGI__LOBE_GGX) {
        float ci = v3_dot(wi, ns);
        if (!(ci > 0.f)) return 0.f; /* wi under the shading normal: the lobe is zero there */
        float e = pgi__lobe_E(l, ci);
        wsp *= e;
        wd *= 1.f - e;
    }
    return wd + wsp > 0.f ? wsp / (wd + wsp) : 0.f;
}

/* Solid-angle density of the glossy lobe's sampling. */
static float glossy_pdf(const pgi__lobe *l, pgi__v3 ns, pgi__v3 wi, pgi__v3 wo) {
    if (l->model == PGI__LOBE_GGX) return pgi__ggx_pdf(l, ns, wi, wo);
    float s = l->s;
    pgi__v3 h = v3_norm(v3_add(wi, wo));
    float hn = fmaxf(0.f, v3_dot(h, ns)), hw = fabsf(v3_dot(h, wo));
    return hw > 0.f ? (s + 1.f) / (2.f * PGI__PI) * powf(hn, s) / (4.f * hw) : 0.f;
}

int pgi__bsdf_sample(const pgi__surface *sf, pgi__v3 wi, float u1, float u2, float u3, pgi__v3 *wo, pgi__v3 *weight) {
    const pgi__material *m = sf->mat;
    float side = v3_dot(wi, sf->ng) >= 0.f ? 1.f : -1.f;
    pgi__v3 ng = v3_scale(sf->ng, side), ns = v3_scale(sf->ns, side);
    switch (m->type) {
    case PGI__MAT_MIRROR:
        *wo = pgi__reflect(wi, ns);
        *weight = v3_load(m->ks);
        return v3_dot(*wo, ng) > 0.f;
    case PGI__MAT_GLASS: {
        /* side > 0: arriving from outside (the side the normal points to). */
        float eta_i = side > 0.f ? 1.f : m->ior, eta_t = side > 0.f ? m->ior : 1.f;
        float ci = fminf(1.f, fmaxf(0.f, v3_dot(wi, ns)));
        float F = pgi__fresnel_dielectric(ci, eta_i, eta_t);
        if (u1 < F) {
            *wo = pgi__reflect(wi, ns);
            *weight = v3(1.f, 1.f, 1.f);
            return v3_dot(*wo, ng) > 0.f;
        }
        float eta = eta_i / eta_t;
        float st2 = eta * eta * (1.f - ci * ci);
        float ct = sqrtf(fmaxf(0.f, 1.f - st2));
        *wo = v3_norm(v3_sub(v3_scale(v3_neg(wi), eta), v3_scale(ns, ct - eta * ci)));
        *weight = v3_load(m->ks);
        return v3_dot(*wo, ng) < 0.f;
    }
    case PGI__MAT_PHONG:
    case PGI__MAT_PLASTIC: {
        pgi__lobe l;
        pgi__lobe_of_material(m, &l);
        float ps = glossy_pick(&l, sf->kd, ns, wi);
        if (u3 < ps) {
            if (l.model == PGI__LOBE_GGX) {
                /* Visible normals (Heitz 2018) in the frame pgi_to_world uses. */
                pgi__v3 t, b;
                v3_basis(ns, &t, &b);
                pgi__v3 V = v3(v3_dot(wi, t), v3_dot(wi, b), v3_dot(wi, ns));
                *wo = pgi__reflect(wi, pgi_to_world(pgi__ggx_sample_vndf(V, l.s, u1, u2), ns));
            } else {
                /* Half vector from the normalised Blinn distribution (s+1)/(2pi) cos^s. */
                float s = l.s;
                float ct = powf(u1, 1.f / (s + 1.f)), st = sqrtf(fmaxf(0.f, 1.f - ct * ct)), phi = 2.f * PGI__PI * u2;
                pgi__v3 h = pgi_to_world(v3(st * cosf(phi), st * sinf(phi), ct), ns);
                *wo = pgi__reflect(wi, h);
            }
        } else {
            *wo = pgi_to_world(pgi_sample_cosine(u1, u2), ns);
        }
        float cg = v3_dot(*wo, ng), cs = v3_dot(*wo, ns);
        if (!(cg > 0.f) || !(cs > 0.f)) return 0;
        float pdf = ps * glossy_pdf(&l, ns, wi, *wo) + (1.f - ps) * cs * PGI__INV_PI;
        if (!(pdf > 0.f)) return 0;
        pgi__v3 f = pgi__brdf_eval(sf->kd, &l, ns, wi, *wo);
        *weight = v3_scale(f, cs / pdf);
        return 1;
    }
    case PGI__MAT_LAMBERT:
    default:
        *wo = pgi_to_world(pgi_sample_cosine(u1, u2), ns);
        *weight = sf->kd;
        return v3_dot(*wo, ng) > 0.f;
    }
}

float pgi__bsdf_pdf(const pgi__surface *sf, pgi__v3 wi, pgi__v3 wo) {
    const pgi__material *m = sf->mat;
    if (pgi__mat_specular(m)) return 0.f;
    float side = v3_dot(wi, sf->ng) >= 0.f ? 1.f : -1.f;
    pgi__v3 ng = v3_scale(sf->ng, side), ns = v3_scale(sf->ns, side);
    float cg = v3_dot(wo, ng), cs = v3_dot(wo, ns);
    if (!(cg > 0.f) || !(cs > 0.f)) return 0.f;
    if (m->type != PGI__MAT_PHONG && m->type != PGI__MAT_PLASTIC) return cs * PGI__INV_PI;
    /* Same lobe mixture as pgi__bsdf_sample. */
    pgi__lobe l;
    pgi__lobe_of_material(m, &l);
    float ps = glossy_pick(&l, sf->kd, ns, wi);
    return ps * glossy_pdf(&l, ns, wi, wo) + (1.f - ps) * cs * PGI__INV_PI;
}
