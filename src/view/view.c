/* View samples and direct light. */
#include "view.h"

#include <string.h>

#include "photon/photon.h"
#include "scene/bsdf.h"

#define PGI_MAX_SPECULAR_DEPTH 8

static void clear_sample(pgi_view_samples *vs, size_t i) {
    memset(vs->pos + 3 * i, 0, 3 * sizeof(float));
    memset(vs->nrm + 3 * i, 0, 3 * sizeof(float));
    memset(vs->ngeo + 3 * i, 0, 3 * sizeof(float));
    memset(vs->wo + 3 * i, 0, 3 * sizeof(float));
    memset(vs->kd + 3 * i, 0, 3 * sizeof(float));
    memset(vs->ks + 3 * i, 0, 3 * sizeof(float));
    memset(vs->weight + 3 * i, 0, 3 * sizeof(float));
    vs->shininess[i] = 0.f;
    vs->depth[i] = 0.f;
    vs->flags[i] = 0;
}

/* Continues the eye path of pixel i from its primary hit. */
static void shade_eye_path(const pgi_scene *s, const pgi__rt *rt, const pgi_camera *cam, uint64_t seed, float eps,
                           size_t i, pgi__v3 o, pgi__v3 d, pgi__hit h, pgi_view_samples *vs, float *emit,
                           uint64_t *rays) {
    clear_sample(vs, i);
    v3_store(emit + 3 * i, v3(0.f, 0.f, 0.f));
    if (h.prim == UINT32_MAX) return;
    pgi__v3 weight = v3(1.f, 1.f, 1.f), e = v3(0.f, 0.f, 0.f);
    pgi__rng rng;
    int rng_ready = 0;
    for (int depth = 0;; depth++) {
        pgi__v3 p = v3_madd(o, d, h.t);
        if (depth == 0) vs->depth[i] = v3_dot(v3_sub(p, v3_load(cam->eye)), v3_load(cam->forward));
        pgi__surface sf;
        pgi__scene_surface(s, h.prim, h.u, h.v, p, &sf);
        pgi__v3 wo = v3_neg(d);
        float side = v3_dot(wo, sf.ng) >= 0.f ? 1.f : -1.f;
        pgi__v3 ke = v3_load(sf.mat->ke);
        if (side > 0.f) e = v3_add(e, v3_mul(weight, ke)); /* one-sided emitters */
        if (!pgi__mat_specular(sf.mat)) {
            pgi__v3 ng = v3_scale(sf.ng, side), ns = v3_scale(sf.ns, side);
            v3_store(vs->pos + 3 * i, p);
            v3_store(vs->nrm + 3 * i, ns);
            v3_store(vs->ngeo + 3 * i, ng);
            v3_store(vs->wo + 3 * i, wo);
            v3_store(vs->kd + 3 * i, sf.kd);
            int phong = sf.mat->type == PGI_MAT_PHONG;
            v3_store(vs->ks + 3 * i, phong ? v3_load(sf.mat->ks) : v3(0.f, 0.f, 0.f));
            vs->shininess[i] = phong ? sf.mat->shininess : 0.f;
            v3_store(vs->weight + 3 * i, weight);
            vs->flags[i] = PGI_VS_VALID | (depth == 0 ? PGI_VS_PRIMARY : 0) | (phong ? 0 : PGI_VS_LAMBERT);
            break;
        }
        if (depth + 1 >= PGI_MAX_SPECULAR_DEPTH) break;
        if (!rng_ready) {
            pgi_rng_seed(&rng, seed ^ 0x5eed0f1e11e5ULL, (uint64_t)i);
            rng_ready = 1;
        }
        pgi__v3 nd, w;
        if (!pgi__bsdf_sample(&sf, wo, pgi_rng_f(&rng), pgi_rng_f(&rng), pgi_rng_f(&rng), &nd, &w)) break;
        weight = v3_mul(weight, w);
        pgi__v3 ng = v3_dot(nd, sf.ng) >= 0.f ? sf.ng : v3_neg(sf.ng);
        o = v3_madd(p, ng, eps);
        d = nd;
        (*rays)++;
        if (!pgi__rt_intersect(rt, o, d, 0.f, INFINITY, &h)) break;
    }
    v3_store(emit + 3 * i, e);
}

pgi_status pgi__view_build(const pgi_scene *s, const pgi__rt *rt, const pgi_camera *cam, uint64_t seed,
                           const pgi__subpixel *sp, int threads, pgi_view_samples *vs, float *emit,
                           uint64_t *rays_out) {
    const int W = cam->width, H = cam->height;
    if (vs->width != W || vs->height != H)
        return pgi__fail(PGI_ERR_INVALID_ARG, "view-sample buffer is %dx%d, camera %dx%d", vs->width, vs->height, W, H);
    vs->jitter = sp->jitter ? 0.5f : 0.f;
    uint64_t rays = 0;
    const pgi__v3 eye = v3_load(cam->eye);
    const float eps = pgi__scene_epsilon(s);
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : rays) num_threads(pgi__threads(threads))
    for (int y = 0; y < H; y++) {
        for (int x0 = 0; x0 < W; x0 += 8) {
            int valid[8];
            pgi__v3 dirs[8];
            pgi__hit hits[8];
            for (int k = 0; k < 8; k++) {
                valid[k] = x0 + k < W;
                dirs[k] = pgi__view_dir(cam, sp, valid[k] ? x0 + k : x0, y);
            }
            pgi__rt_intersect8(rt, valid, eye, dirs, INFINITY, hits);
            for (int k = 0; k < 8 && x0 + k < W; k++) {
                rays++;
                size_t i = (size_t)y * W + (size_t)(x0 + k);
                shade_eye_path(s, rt, cam, seed, eps, i, eye, dirs[k], hits[k], vs, emit, &rays);
            }
        }
    }
    *rays_out = rays;
    return PGI_OK;
}

pgi_status pgi__direct(const pgi_scene *s, const pgi__rt *rt, const pgi_view_samples *vs, int area_samples,
                       uint64_t seed, int threads, float *out, uint64_t *rays_out) {
    /* Area lights get their own CDF by power (luminance). */
    size_t narea = 0;
    for (size_t l = 0; l < s->nlights; l++) narea += s->lights[l].type == PGI_LIGHT_AREA;
    float *cdf = NULL;
    size_t *idx = NULL;
    if (narea) {
        cdf = malloc(narea * sizeof *cdf);
        idx = malloc(narea * sizeof *idx);
        if (!cdf || !idx) {
            free(cdf);
            free(idx);
            return pgi__fail(PGI_ERR_OOM, "out of memory for the area-light table");
        }
        double tot = 0.0;
        size_t k = 0;
        for (size_t l = 0; l < s->nlights; l++) {
            if (s->lights[l].type != PGI_LIGHT_AREA) continue;
            tot += v3_lum(v3_load(s->lights[l].power));
            cdf[k] = (float)tot;
            idx[k++] = l;
        }
        for (k = 0; k < narea; k++) cdf[k] = tot > 0.0 ? (float)(cdf[k] / tot) : (float)(k + 1) / (float)narea;
        cdf[narea - 1] = 1.f;
    }
    const float eps = pgi__scene_epsilon(s);
    uint64_t rays = 0;
    const long long n = (long long)vs->count;
#pragma omp parallel for schedule(dynamic, 1024) reduction(+ : rays) num_threads(pgi__threads(threads))
    for (long long ii = 0; ii < n; ii++) {
        size_t i = (size_t)ii;
        pgi__v3 L = v3(0.f, 0.f, 0.f);
        if (!(vs->flags[i] & PGI_VS_VALID)) {
            v3_store(out + 3 * i, L);
            continue;
        }
        pgi__v3 p = v3_load(vs->pos + 3 * i), ns = v3_load(vs->nrm + 3 * i), ng = v3_load(vs->ngeo + 3 * i);
        pgi__v3 wo = v3_load(vs->wo + 3 * i), kd = v3_load(vs->kd + 3 * i), ks = v3_load(vs->ks + 3 * i);
        float sh = vs->shininess[i];
        pgi__v3 x = v3_madd(p, ng, eps);
        for (size_t l = 0; l < s->nlights; l++) {
            pgi__v3 wi, Li;
            float cs, tmax;
            if (!pgi__delta_light(&s->lights[l], x, ns, ng, &wi, &Li, &cs, &tmax)) continue;
            rays++;
            if (pgi__rt_occluded(rt, x, wi, 0.f, tmax)) continue;
            L = v3_add(L, v3_scale(v3_mul(pgi__brdf_eval(kd, ks, sh, ns, wi, wo), Li), cs));
        }
        if (narea && area_samples > 0) {
            pgi__rng rng;
            pgi_rng_seed(&rng, seed ^ 0xd15ec7ULL, (uint64_t)i);
            pgi__v3 La = v3(0.f, 0.f, 0.f);
            for (int k = 0; k < area_samples; k++) {
                float u = ((float)k + pgi_rng_f(&rng)) / (float)area_samples; /* stratified light pick */
                float pl;
                const pgi__light *lt = &s->lights[idx[pgi__cdf_pick(cdf, narea, u, &pl)]];
                float u1 = pgi_rng_f(&rng), u2 = pgi_rng_f(&rng);
                pgi__v3 y = pgi__triangle_sample(s, lt->tri, u1, u2);
                pgi__v3 dv = v3_sub(y, x);
                float d2 = v3_dot(dv, dv);
                if (!(d2 > 0.f) || !(pl > 0.f)) continue;
                float dist = sqrtf(d2);
                pgi__v3 wi = v3_scale(dv, 1.f / dist);
                float cl = -v3_dot(wi, v3_load(lt->normal)), cs = v3_dot(ns, wi);
                if (!(cl > 0.f) || !(cs > 0.f) || !(v3_dot(ng, wi) > 0.f)) continue;
                rays++;
                if (pgi__rt_occluded(rt, x, wi, 0.f, dist * (1.f - 1e-3f))) continue;
                float g = cs * cl / d2 * lt->area / pl;
                La = v3_add(La, v3_scale(v3_mul(pgi__brdf_eval(kd, ks, sh, ns, wi, wo), v3_load(lt->color)), g));
            }
            L = v3_add(L, v3_scale(La, 1.f / (float)area_samples));
        }
        v3_store(out + 3 * i, v3_mul(L, v3_load(vs->weight + 3 * i)));
    }
    free(cdf);
    free(idx);
    *rays_out = rays;
    return PGI_OK;
}
