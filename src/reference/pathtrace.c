/* Path-traced reference (docs/design.md "Reference path tracer").
 *
 * The estimate of pixel i is the photon pipeline's image in expectation:
 *   emission along the eye path (specular chain, up to 8 hits, one-sided),
 * + W * direct light at the first non-specular hit x0 (0 scattering events),
 * + W * indirect light at x0: light paths with 1..B scattering events before
 *   x0, whatever those events are (specular ones count, as in photon tracing).
 * A path x0, x1, ... extended by BSDF sampling; at a non-specular vertex x_k
 * next-event estimation represents light paths with k scattering events
 * (x_k .. x_1), and an emitter hit at x_{k+1} from x_k also k events; both are
 * combined by the power heuristic for area lights and the sky (a path that
 * leaves the scene sees the sky, as an emitter hit). Vertices are extended while
 * k < B. Point, spot and sun lights are delta lights, reached by NEE only:
 * a path tracer cannot find light -> mirror -> x0 from them (photon tracing
 * stores it as a caustic), so for such scenes the reference lacks those
 * caustics; area lights have no such gap. See
 * docs/design.md. */
#include "photongi/reference.h"

#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "scene/light.h"
#include "scene/tri_cache.h"
#include "pipeline/pipeline.h"
#include "rt/rt.h"
#include "scene/bsdf.h"
#include "view/view.h"

#define PGI__MAX_SPECULAR_DEPTH 8 /* as src/view/view.c */
#define PGI__REF_MAX_SIDE 16384
#define PGI__REF_MAX_BOUNCES 64

typedef struct {
    const pgi_scene *s;
    const pgi__rt *rt;
    pgi_camera cam;
    int bounces;
    int jitter; /* samples through uniform points of the pixel (else its centre) */
    uint64_t seed;
    float eps;
    size_t narea;
    float *cdf;      /* area lights by luminance of power (as pgi__direct) */
    size_t *idx;     /* cdf entry -> light index */
    float *tri_pick; /* triangle -> pick probability of its area light (0: none) */
    /* the triangles as the path's vertices after x0 read them (pgi__tri_cache_update): one
       cache line a hit instead of a dozen scattered ones */
    const pgi__tri_rec *tris;
    const float *tri_uv; /* PGI__TRI_UV floats a triangle (NULL: no texture coordinates) */
} pt_ctx;

/* What every sample of a pixel sees alike without jitter: the primary ray's hit and its surface
 * (no random numbers drawn) and, where that is x0, the sum of x0's delta lights in nee() (none
 * drawn either). One cache line. */
enum { PT_EYE_NONE, PT_EYE_MISS, PT_EYE_HIT, PT_EYE_X0 };
typedef struct pt_eye {
    float p[3], ng[3], ns[3], kd[3]; /* PT_EYE_HIT, PT_EYE_X0: the surface (kd with its texels) */
    float delta[3];                  /* PT_EYE_X0: x0's delta lights */
    uint32_t state : 2;              /* PT_EYE_*: how much of the above is known */
    uint32_t mat : 30;               /* the surface's material, an index into the scene's */
} pt_eye;
_Static_assert(sizeof(pt_eye) == 64, "a pixel's eye record is one cache line");

/* Applies the texels of *tq (pgi__texture_quad, NULL: applied) to sf's albedo. */
/* The power heuristic a^2 / (a^2 + b^2) of a strategy with pdf a against one with pdf b. The
 * squares overflow for a pdf above ~1.8e19 (a light seen edge-on): then the same weight from the
 * ratio of the two, so that an extreme pdf gives 1 or 0, never inf / inf. */
static inline float power_heuristic(float a, float b) {
    float w = a * a / (a * a + b * b);
    if (isfinite(w)) return w;
    if (!(a > 0.f)) return 0.f;
    if (a >= b) {
        float r = b / a;
        return 1.f / (1.f + r * r);
    }
    float r = a / b;
    return r * r / (1.f + r * r);
}

static inline void texture_resolve(pgi__surface *sf, const pgi__texel_quad **tq) {
    if (*tq) sf->kd = v3_mul(sf->kd, pgi__texture_quad_lookup(*tq));
    *tq = NULL;
}

/* Next-event estimation at a non-specular vertex: every delta light once (as
 * pgi__direct), one area-light sample picked by power, MIS-weighted against
 * BSDF sampling. `wo` points back along the path. The albedo's texels `tq`
 * (*tq, NULL: none) are applied where first needed, after a shadow ray where
 * there is one, so that their cache misses overlap its traversal; sf->kd has them on return.
 * `eye` (NULL: none): the vertex is its pixel's x0, whose delta lights it holds or receives. */
static pgi__v3 nee(const pt_ctx *C, pgi__surface *sf, const pgi__texel_quad **tq, pgi__v3 wo, pgi__rng *rng,
                   pt_eye *eye) {
    const pgi_scene *s = C->s;
    float side = v3_dot(wo, sf->ng) >= 0.f ? 1.f : -1.f;
    pgi__v3 ng = v3_scale(sf->ng, side), ns = v3_scale(sf->ns, side);
    pgi__lobe lobe;
    pgi__lobe_of_material(sf->mat, &lobe);
    pgi__v3 x = v3_madd(sf->p, ng, C->eps);
    pgi__v3 L = v3(0.f, 0.f, 0.f);
    if (eye && eye->state == PT_EYE_X0) L = v3_load(eye->delta);
    else {
        for (size_t l = 0; l < s->nlights; l++) {
            pgi__v3 wi, Li;
            float cs, tmax;
            if (!pgi__light_delta(&s->lights[l], x, ns, ng, &wi, &Li, &cs, &tmax)) continue;
            if (pgi__rt_occluded(C->rt, x, wi, 0.f, tmax)) continue;
            texture_resolve(sf, tq);
            L = v3_add(L, v3_scale(v3_mul(pgi__brdf_eval(sf->kd, &lobe, ns, wi, wo), Li), cs));
        }
        if (eye) {
            v3_store(eye->delta, L);
            eye->state = PT_EYE_X0;
        }
    }
    if (C->narea) {
        float ul = pgi_rng_f(rng), u1 = pgi_rng_f(rng), u2 = pgi_rng_f(rng);
        float pl;
        const pgi__light *lt = &s->lights[C->idx[pgi__cdf_pick(C->cdf, C->narea, ul, &pl)]];
        pgi__v3 wi;
        float d2, dist, cl;
        if (pl > 0.f && pgi__light_area_toward(pgi__triangle_sample(s, lt->tri, u1, u2), v3_load(lt->normal), x, &wi,
                                               &d2, &dist, &cl)) {
            const float cs = v3_dot(ns, wi);
            if (cl > 0.f && cs > 0.f && v3_dot(ng, wi) > 0.f &&
                !pgi__rt_occluded(C->rt, x, wi, 0.f, dist * (1.f - 1e-3f))) {
                texture_resolve(sf, tq);
                float pdf_l = pgi__light_area_pdf(lt, pl, d2, cl);
                float pdf_b = pgi__bsdf_pdf(sf, wo, wi);
                float mis = power_heuristic(pdf_l, pdf_b);
                pgi__v3 f = pgi__brdf_eval(sf->kd, &lobe, ns, wi, wo);
                L = v3_add(L, v3_scale(v3_mul(f, v3_load(lt->color)), cs / pdf_l * mis));
            }
        }
    }
    if (s->env) {
        /* One sky direction (as pgi__direct's), power heuristic against BSDF sampling. */
        float u1 = pgi_rng_f(rng), u2 = pgi_rng_f(rng), pdf_l;
        pgi__v3 wi = pgi__env_sample_direct(s->env, ns, u1, u2, &pdf_l);
        float cs = v3_dot(ns, wi);
        if (pdf_l > 0.f && cs > 0.f && v3_dot(ng, wi) > 0.f && !pgi__rt_occluded(C->rt, x, wi, 0.f, INFINITY)) {
            texture_resolve(sf, tq);
            float pdf_b = pgi__bsdf_pdf(sf, wo, wi);
            float mis = power_heuristic(pdf_l, pdf_b);
            pgi__v3 f = pgi__brdf_eval(sf->kd, &lobe, ns, wi, wo);
            L = v3_add(L, v3_scale(v3_mul(f, pgi__env_eval(s->env, wi)), cs / pdf_l * mis));
        }
    }
    texture_resolve(sf, tq);
    return L;
}

/* The sky seen along a path that leaves the scene in direction d from `sf` (after the BSDF
 * sampled d with density pdf_b; 0: a specular bounce or the eye, weight 1), MIS-weighted
 * against the sky sample of nee(). */
static pgi__v3 escaped(const pgi_scene *s, const pgi__surface *sf, pgi__v3 wo, pgi__v3 d, float pdf_b) {
    pgi__v3 Le = pgi__env_eval(s->env, d);
    if (!(pdf_b > 0.f)) return Le;
    float side = v3_dot(wo, sf->ng) >= 0.f ? 1.f : -1.f;
    pgi__v3 ng = v3_scale(sf->ng, side), ns = v3_scale(sf->ns, side);
    /* nee() samples d only where it would count it */
    float pdf_l = v3_dot(ns, d) > 0.f && v3_dot(ng, d) > 0.f ? pgi__env_pdf_direct(s->env, ns, d) : 0.f;
    return v3_scale(Le, power_heuristic(pdf_b, pdf_l));
}

/* One sample of pixel (x, y), through the point (x + jx, y + jy) of the image. `eye` (NULL:
 * none): what the pixel's samples so far found of it, the same (x + jx, y + jy) each time. */
static pgi__v3 trace_sample(const pt_ctx *C, int px, int py, float jx, float jy, pgi__rng *rng, pt_eye *eye) {
    const pgi_scene *s = C->s;
    pgi__v3 o = v3_load(C->cam.eye), d = pgi__camera_dir_at(&C->cam, px, py, jx, jy);
    pgi__v3 L = v3(0.f, 0.f, 0.f), W = v3(1.f, 1.f, 1.f);
    pgi__hit h;
    pgi__surface sf;
    /* Eye path: the specular chain to the first non-specular hit x0, as view.c. */
    int depth;
    for (depth = 0;; depth++) {
        const int cached = depth == 0 && eye && eye->state != PT_EYE_NONE;
        const int hit = cached ? eye->state != PT_EYE_MISS : pgi__rt_intersect(C->rt, o, d, 0.f, INFINITY, &h);
        if (depth == 0 && eye && !cached) eye->state = hit ? PT_EYE_HIT : PT_EYE_MISS;
        if (!hit) return s->env ? v3_add(L, v3_mul(W, pgi__env_eval(s->env, d))) : L;
        if (cached)
            sf = (pgi__surface){.p = v3_load(eye->p),
                                .ng = v3_load(eye->ng),
                                .ns = v3_load(eye->ns),
                                .mat = &s->mats[eye->mat],
                                .kd = v3_load(eye->kd)}; /* u, v: no longer read */
        else {
            pgi__scene_surface(s, h.prim, h.u, h.v, v3_madd(o, d, h.t), &sf);
            if (depth == 0 && eye) {
                v3_store(eye->p, sf.p);
                v3_store(eye->ng, sf.ng);
                v3_store(eye->ns, sf.ns);
                v3_store(eye->kd, sf.kd);
                eye->mat = (uint32_t)(sf.mat - s->mats);
            }
        }
        pgi__v3 p = sf.p;
        pgi__v3 wo = v3_neg(d);
        if (v3_dot(wo, sf.ng) >= 0.f) L = v3_add(L, v3_mul(W, v3_load(sf.mat->ke)));
        if (!pgi__mat_specular(sf.mat)) break;
        if (depth + 1 >= PGI__MAX_SPECULAR_DEPTH) return L;
        pgi__v3 nd, w;
        float u1 = pgi_rng_f(rng), u2 = pgi_rng_f(rng), u3 = pgi_rng_f(rng);
        if (!pgi__bsdf_sample(&sf, wo, u1, u2, u3, &nd, &w)) return L;
        W = v3_mul(W, w);
        o = v3_madd(p, v3_dot(nd, sf.ng) >= 0.f ? sf.ng : v3_neg(sf.ng), C->eps);
        d = nd;
    }
    /* x0 = sf. Vertex k of the light path (k scattering events before x0). */
    const float w0 = v3_maxc(W);
    if (!(w0 > 0.f)) return L;
    pgi__v3 T = W;
    pgi__texel_quad quad;
    const pgi__texel_quad *tq = NULL; /* x_k's texels not yet in sf.kd */
    for (int k = 0;; k++) {
        pgi__v3 wo = v3_neg(d);
        int diffuse = !pgi__mat_specular(sf.mat);
        if (diffuse) L = v3_add(L, v3_mul(T, nee(C, &sf, &tq, wo, rng, k == 0 && depth == 0 ? eye : NULL)));
        texture_resolve(&sf, &tq);
        pgi__v3 wi, w;
        float u1 = pgi_rng_f(rng), u2 = pgi_rng_f(rng), u3 = pgi_rng_f(rng);
        if (!pgi__bsdf_sample(&sf, wo, u1, u2, u3, &wi, &w)) break;
        float pdf_b = diffuse ? pgi__bsdf_pdf(&sf, wo, wi) : 0.f;
        T = v3_mul(T, w);
        if (!v3_finite(T) || !(v3_maxc(T) > 0.f)) break;
        pgi__v3 p = sf.p;
        o = v3_madd(p, v3_dot(wi, sf.ng) >= 0.f ? sf.ng : v3_neg(sf.ng), C->eps);
        d = wi;
        if (!pgi__rt_intersect(C->rt, o, d, 0.f, INFINITY, &h)) {
            /* The sky at x_{k+1}: a light path with k scattering events, as an emitter hit. */
            if (s->env) L = v3_add(L, v3_mul(T, escaped(s, &sf, wo, d, pdf_b)));
            break;
        }
        const pgi__tri_rec *tr = &C->tris[h.prim];
        const float *tuv = C->tri_uv ? C->tri_uv + PGI__TRI_UV * (size_t)h.prim : NULL;
        if (tuv) __builtin_prefetch(tuv); /* its miss overlapping tr's */
        /* The geometry first: a vertex the path ends at needs no shading normal or texel. */
        pgi__tri_rec_geometry(s, tr, v3_madd(o, d, h.t), &sf);
        /* Emitter hit at x_{k+1}: a light path with k scattering events. */
        pgi__v3 ke = v3_load(sf.mat->ke);
        float cl = -v3_dot(d, sf.ng);
        if (cl > 0.f && (ke.x > 0.f || ke.y > 0.f || ke.z > 0.f)) {
            float mis = 1.f;
            float pl = C->tri_pick ? C->tri_pick[h.prim] : 0.f;
            if (diffuse && pl > 0.f) {
                const uint32_t *t = s->tri + 3 * (size_t)h.prim;
                pgi__v3 a = pgi__scene_vertex(s, t[0]), b = pgi__scene_vertex(s, t[1]), c = pgi__scene_vertex(s, t[2]);
                float area = 0.5f * v3_len(v3_cross(v3_sub(b, a), v3_sub(c, a)));
                float pdf_l = pl * h.t * h.t / (cl * area);
                mis = power_heuristic(pdf_b, pdf_l);
            }
            L = v3_add(L, v3_scale(v3_mul(T, ke), mis));
        }
        if (k + 1 > C->bounces) break;
        /* Russian roulette on the throughput relative to the eye chain's. */
        if (k + 1 >= 2) {
            float qrr = fminf(0.95f, v3_maxc(T) / w0);
            if (!(pgi_rng_f(rng) < qrr)) break;
            T = v3_scale(T, 1.f / qrr);
        }
        pgi__tri_rec_shading(s, tr, h.prim, h.u, h.v, &sf);
        /* as pgi__surface_texture, its texels fetched now and applied by nee() or above */
        if (sf.mat->tex_kd >= 0) {
            if (tuv) pgi__tri_rec_uv(tuv, h.u, h.v, &sf.u, &sf.v);
            /* no texels: pgi__texture_lookup's white, kd as it is */
            if (pgi__texture_quad(&s->texs[sf.mat->tex_kd], sf.u, sf.v, &quad)) tq = &quad;
        }
    }
    return L;
}

static void ctx_free(pt_ctx *C) {
    free(C->cdf);
    free(C->idx);
    free(C->tri_pick);
}

static pgi_status ctx_lights(pt_ctx *C) {
    const pgi_scene *s = C->s;
    C->narea = pgi__light_area_count(s);
    if (!C->narea) return PGI_OK;
    C->cdf = malloc(C->narea * sizeof *C->cdf);
    C->idx = malloc(C->narea * sizeof *C->idx);
    C->tri_pick = calloc(s->ntris ? s->ntris : 1, sizeof *C->tri_pick);
    if (!C->cdf || !C->idx || !C->tri_pick) return pgi__fail(PGI_ERR_OOM, "out of memory for the area-light table");
    pgi__light_area_cdf(s, C->cdf, C->idx);
    for (size_t k = 0; k < C->narea; k++) {
        uint32_t t = s->lights[C->idx[k]].tri;
        if (t < s->ntris) C->tri_pick[t] = C->cdf[k] - (k ? C->cdf[k - 1] : 0.f);
    }
    return PGI_OK;
}

struct pgi_reference_sampler {
    pt_ctx C;
    pgi__rt *rt;
    pgi__tri_cache tris;
    pt_eye *eye;          /* a pixel's, without jitter (NULL: none, or no memory for them) */
    pgi_reference_desc d; /* resolved */
    uint64_t rng_seed;
};

/* Validates and resolves a desc (spp, mean and time limit aside) into `d`. */
static pgi_status resolve_desc(const pgi_scene *s, const pgi_reference_desc *in, pgi_reference_desc *out) {
    pgi_reference_desc d = *in;
    const pgi_scene_defaults *sd = &s->defaults;
    if (d.width == 0 && d.height == 0) {
        d.width = sd->width > 0 ? sd->width : 640;
        d.height = sd->height > 0 ? sd->height : 480;
    }
    if (d.width <= 0 || d.height <= 0 || d.width > PGI__REF_MAX_SIDE || d.height > PGI__REF_MAX_SIDE)
        return pgi__fail(PGI_ERR_INVALID_ARG, "image size %dx%d is out of range (1..%d a side)", d.width, d.height,
                         PGI__REF_MAX_SIDE);
    if (d.bounces == 0) d.bounces = sd->bounces > 0 ? sd->bounces : 4;
    if (d.bounces < 1 || d.bounces > PGI__REF_MAX_BOUNCES)
        return pgi__fail(PGI_ERR_INVALID_ARG, "bounces must be in 1..%d, got %d", PGI__REF_MAX_BOUNCES, d.bounces);
    if (d.seed == 0) d.seed = 1;
    if (d.threads < 0) return pgi__fail(PGI_ERR_INVALID_ARG, "threads must be 0 (all) or positive, got %d", d.threads);
    if (d.jitter < PGI_JITTER_AUTO || d.jitter > PGI_JITTER_ON)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown jitter mode %d", (int)d.jitter);
    if (d.camera < 0 || (size_t)d.camera >= s->ncams)
        return pgi__fail(PGI_ERR_INVALID_ARG, "camera %d does not exist (the scene has %zu)", d.camera, s->ncams);
    pgi_status st;
    if (d.view && (st = pgi__check_view(d.view))) return st;
    *out = d;
    return PGI_OK;
}

pgi_status pgi_reference_sampler_create(const pgi_scene *s, const pgi_reference_desc *in, pgi_reference_sampler **out) {
    if (!out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_reference_sampler_create: NULL argument");
    *out = NULL;
    if (!s || !in) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_reference_sampler_create: NULL argument");
    pgi__clear_error();
    pgi_reference_desc d;
    pgi_status st = resolve_desc(s, in, &d);
    if (st) return st;
    pgi_reference_sampler *S = calloc(1, sizeof *S);
    if (!S) return pgi__fail(PGI_ERR_OOM, "out of memory for the reference sampler");
    S->d = d;
    pt_ctx *C = &S->C;
    C->s = s;
    C->bounces = d.bounces;
    C->jitter = d.jitter != PGI_JITTER_OFF;
    C->seed = d.seed;
    C->eps = pgi__scene_epsilon(s);
    const pgi_camera_def *cd = d.view ? d.view : &s->cams[d.camera];
    S->d.view = NULL; /* borrowed for the call only */
    pgi_camera_look_at(&C->cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, d.width, d.height);
    if ((st = ctx_lights(C)) || (st = pgi__rt_create(s, &S->rt)) ||
        (st = pgi__tri_cache_update(&S->tris, s, d.threads))) {
        pgi_reference_sampler_destroy(S);
        return st;
    }
    C->rt = S->rt;
    C->tris = S->tris.tris;
    C->tri_uv = S->tris.tri_uv;
    /* Worth its 64 bytes a pixel: a sample of Sibenik at 4 bounces traces 1.8 of its 5.0
       rays there, and shades a surface. Without the memory, every sample does that again. */
    if (!C->jitter && s->nmats <= (size_t)1 << 30) S->eye = calloc((size_t)d.width * (size_t)d.height, sizeof *S->eye);
    S->rng_seed = pgi__mix64(d.seed ^ 0x7265666572656e63ULL);
    *out = S;
    return PGI_OK;
}

void pgi_reference_sampler_destroy(pgi_reference_sampler *S) {
    if (!S) return;
    if (S->rt) pgi__rt_destroy(S->rt);
    ctx_free(&S->C);
    pgi__tri_cache_free(&S->tris);
    free(S->eye);
    free(S);
}

void pgi_reference_sampler_size(const pgi_reference_sampler *S, int *width, int *height) {
    if (width) *width = S ? S->d.width : 0;
    if (height) *height = S ? S->d.height : 0;
}

pgi_status pgi_reference_sampler_add(pgi_reference_sampler *S, uint64_t sidx, double *sum) {
    if (!S || !sum) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_reference_sampler_add: NULL argument");
    const pt_ctx *C = &S->C;
    const uint64_t rng_seed = S->rng_seed;
    const int W = S->d.width, H = S->d.height;
    /* Sample sidx of a pixel looks through point sidx of the pixel's sub-pixel sequence (the view
       pass's, pgi__pixel_jitter): uniform over the pixel, and the samples so far cover it evenly,
       so the mean converges to the box-filtered pixel integral; without jitter, the centre. */
    const pgi__subpixel sp = {.jitter = C->jitter, .seed = rng_seed, .index = (uint32_t)sidx};
#pragma omp parallel for schedule(dynamic, 1) num_threads(pgi__threads(S->d.threads))
    for (int y = 0; y < H; y++) {
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * W + (size_t)x;
            pgi__rng rng;
            /* Stream per pixel, sequence per sample: independent of threads and passes. */
            pgi_rng_seed(&rng, rng_seed + sidx, (uint64_t)i);
            float jx, jy;
            pgi__pixel_jitter(&sp, i, &jx, &jy);
            /* each pixel's eye record is one thread's in a call, and calls come one at a time */
            pgi__v3 c = trace_sample(C, x, y, jx, jy, &rng, S->eye ? &S->eye[i] : NULL);
            if (!v3_finite(c)) c = v3(0.f, 0.f, 0.f);
            sum[3 * i] += c.x;
            sum[3 * i + 1] += c.y;
            sum[3 * i + 2] += c.z;
        }
    }
    return PGI_OK;
}

pgi_status pgi_reference_render(const pgi_scene *s, const pgi_reference_desc *in, pgi_image *mean, uint64_t *spp) {
    if (!s || !in || !mean || !spp) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_reference_render: NULL argument");
    pgi__clear_error();
    pgi_reference_desc d;
    pgi_status st = resolve_desc(s, in, &d);
    if (st) return st;
    if (d.spp < 1) return pgi__fail(PGI_ERR_INVALID_ARG, "samples per pixel must be at least 1");
    if (*spp > 0 && (!mean->rgb || mean->width != d.width || mean->height != d.height))
        return pgi__fail(PGI_ERR_INVALID_ARG, "the image to continue is %dx%d, the reference is %dx%d", mean->width,
                         mean->height, d.width, d.height);
    pgi_reference_sampler *S;
    if ((st = pgi_reference_sampler_create(s, &d, &S))) return st;
    const size_t n = (size_t)d.width * (size_t)d.height;
    double *sum = malloc(3 * n * sizeof *sum), *block = calloc(3 * n, sizeof *block);
    float *img = *spp > 0 ? mean->rgb : malloc(3 * n * sizeof(float));
    if (!sum || !block || !img) {
        free(sum);
        free(block);
        if (img != mean->rgb) free(img);
        pgi_reference_sampler_destroy(S);
        return pgi__fail(PGI_ERR_OOM, "out of memory for a %dx%d accumulation buffer", d.width, d.height);
    }
    const uint64_t n0 = *spp;
    for (size_t i = 0; i < 3 * n; i++) sum[i] = n0 > 0 ? (double)img[i] * (double)n0 : 0.0;
    const double t0 = pgi__now_ms();
    uint64_t done = 0;
    while (done < d.spp) {
        /* Blocks of PGI_REFERENCE_BLOCK samples from this call's first, in sample order within a
           block, block sums in block order (reference.h). */
        pgi_reference_sampler_add(S, n0 + done, block);
        done++;
        if (done % PGI_REFERENCE_BLOCK == 0) {
            pgi_block_sum_merge(sum, block, 3 * n);
            pgi_block_sum_round(sum, 3 * n, n0 + done); /* what a save here and a continue give back */
            memset(block, 0, 3 * n * sizeof *block);
        }
        double el = pgi__now_ms() - t0;
        int stop = 0;
        if (d.progress) stop = d.progress(d.progress_user, done, d.spp, el);
        if (d.time_limit_s > 0.0 && el >= 1000.0 * d.time_limit_s) stop = 1;
        if (stop) break;
    }
    pgi_block_sum_mean(sum, done % PGI_REFERENCE_BLOCK ? block : NULL, 3 * n, n0 + done, img);
    free(sum);
    free(block);
    pgi_reference_sampler_destroy(S);
    if (img != mean->rgb) {
        pgi_image_free(mean);
        mean->rgb = img;
    }
    mean->width = d.width;
    mean->height = d.height;
    *spp = n0 + done;
    return PGI_OK;
}
