/* Photon tracing: emission from lights picked by power, BSDF sampling,
 * flux-preserving Russian roulette (cluster paper eq. 1), storage from the
 * second hit on (the first hit is direct light, done with shadow rays; a path
 * whose first hits are all specular stores at its first non-specular hit:
 * a caustic). */
#include "photon.h"

#include <omp.h>
#include <string.h>

#include "radius.h"
#include "scene/bsdf.h"

typedef struct {
    float p[3], d[3], f[3], n[3];
    pgi__footprint fp; /* radius policies */
} stored_photon;

typedef struct {
    const pgi_scene *s;
    const pgi__rt *rt;
    const float *cdf; /* light CDF by luminance of power */
    size_t nl;
    int bounces;
    uint64_t seed;
    float eps;
    pgi__v3 centre;
    float radius;      /* bounding-sphere radius, for the sun's disk */
    pgi__fp_params fp; /* radius policy */
} tracer;

/* Traces path `index`; writes at most `bounces` photons to `out` and returns
 * how many. Flux is power / pick probability (divided by paths later). */
static int trace_path(const tracer *T, uint64_t index, stored_photon *out, uint64_t *rays) {
    pgi__rng rng;
    pgi_rng_seed(&rng, T->seed, index);
    float ul = pgi_rng_f(&rng);
    float pl;
    const pgi__light *L = &T->s->lights[pgi__cdf_pick(T->cdf, T->nl, ul, &pl)];
    if (!(pl > 0.f)) return 0;
    pgi__v3 flux = v3_scale(v3_load(L->power), 1.f / pl);
    pgi__v3 o, d;
    float u1 = pgi_rng_f(&rng), u2 = pgi_rng_f(&rng);
    switch (L->type) {
    case PGI_LIGHT_POINT:
        o = v3_load(L->pos);
        d = pgi_sample_sphere(u1, u2);
        break;
    case PGI_LIGHT_SPOT:
        o = v3_load(L->pos);
        d = pgi_to_world(pgi_sample_cone(u1, u2, L->cos_cutoff), v3_load(L->dir));
        break;
    case PGI_LIGHT_SUN: {
        d = v3_load(L->dir);
        float r = T->radius * sqrtf(u1), phi = 2.f * PGI_PI * u2;
        pgi__v3 disk = pgi_to_world(v3(r * cosf(phi), r * sinf(phi), 0.f), d);
        o = v3_add(v3_sub(T->centre, v3_scale(d, 1.01f * T->radius)), disk);
        break;
    }
    case PGI_LIGHT_AREA:
    default: {
        pgi__v3 n = v3_load(L->normal);
        o = v3_madd(pgi__triangle_sample(T->s, L->tri, u1, u2), n, T->eps);
        d = pgi_to_world(pgi_sample_cosine(pgi_rng_f(&rng), pgi_rng_f(&rng)), n);
        break;
    }
    }
    pgi__pdiff pd;
    pgi__fp_emit(&pd, &T->fp, T->s, L, pl, d, T->radius);
    int stored = 0;
    for (int b = 0;; b++) {
        pgi__hit h;
        (*rays)++;
        if (!pgi__rt_intersect(T->rt, o, d, 0.f, INFINITY, &h)) break;
        pgi__surface sf;
        pgi__v3 p = v3_madd(o, d, h.t);
        pgi__scene_surface(T->s, h.prim, h.u, h.v, p, &sf);
        pgi__v3 wi = v3_neg(d);
        pgi__v3 ng = v3_dot(wi, sf.ng) >= 0.f ? sf.ng : v3_neg(sf.ng);
        pgi__fp_hit(&pd, &T->fp, d, h.t, ng);
        if (b >= 1 && !pgi__mat_specular(sf.mat)) {
            stored_photon *sp = &out[stored++];
            pgi__fp_store(&pd, &T->fp, ng, &sp->fp);
            v3_store(sp->p, p);
            v3_store(sp->d, wi);
            v3_store(sp->f, flux);
            v3_store(sp->n, ng);
        }
        if (b >= T->bounces) break;
        pgi__v3 wo, w;
        float r1 = pgi_rng_f(&rng), r2 = pgi_rng_f(&rng), r3 = pgi_rng_f(&rng);
        if (!pgi__bsdf_sample(&sf, wi, r1, r2, r3, &wo, &w)) break;
        pgi__fp_scatter(&pd, &T->fp, T->s, h.prim, h.u, h.v, &sf, wi, wo, w);
        pgi__v3 nf = v3_mul(flux, w);
        float mf = v3_maxc(flux);
        float R = mf > 0.f ? fminf(1.f, v3_maxc(nf) / mf) : 0.f;
        if (!(pgi_rng_f(&rng) < R)) break;
        flux = v3_scale(nf, 1.f / R);
        if (!v3_finite(flux)) break;
        pgi__fp_roulette(&pd, &T->fp, R);
        o = v3_madd(p, v3_dot(wo, ng) >= 0.f ? ng : v3_neg(ng), T->eps);
        d = wo;
    }
    return stored;
}

void pgi__trace_scratch_free(pgi__trace_scratch *sc) {
    free(sc->paths);
    free(sc->counts);
    memset(sc, 0, sizeof *sc);
}

pgi_status pgi__photons_trace(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                              pgi__trace_scratch *sc, uint64_t *rays_out) {
    ph->count = 0;
    ph->emitted = 0;
    *rays_out = 0;
    if (d->photons > ph->capacity)
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon buffer holds %zu photons, %u requested", ph->capacity,
                         d->photons);
    if (d->bounces < 1) return PGI_OK;
    float *cdf = malloc((s->nlights ? s->nlights : 1) * sizeof *cdf);
    if (!cdf) return pgi__fail(PGI_ERR_OOM, "out of memory for the light table");
    double total = 0.0;
    for (size_t i = 0; i < s->nlights; i++) {
        total += fmax(0.0, (double)v3_lum(v3_load(s->lights[i].power)));
        cdf[i] = (float)total;
    }
    if (!(total > 0.0)) {
        free(cdf);
        return PGI_OK; /* no light: no photons; the image is black but valid */
    }
    for (size_t i = 0; i < s->nlights; i++) cdf[i] = (float)(cdf[i] / total);
    cdf[s->nlights - 1] = 1.f;

    tracer T = {s,
                rt,
                cdf,
                s->nlights,
                d->bounces,
                d->seed,
                pgi__scene_epsilon(s),
                v3_scale(v3_add(v3_load(s->bmin), v3_load(s->bmax)), 0.5f),
                0.5f * v3_len(v3_sub(v3_load(s->bmax), v3_load(s->bmin))),
                {0}};
    pgi__fp_params_init(&T.fp, d->radius_policy, d->r_min, d->r_max, d->smoothing, d->photons, 2.f * T.radius);
    const int fp_on = d->radius_policy != PGI_RADIUS_FIXED && ph->radius;
    const float bin_w = d->r_max / 14.f;
    const int B = d->bounces;
    if (sc->bounces != B) pgi__trace_scratch_free(sc);
    sc->bounces = B;
    uint64_t path = 0, rays = 0;
    const uint64_t max_paths = 64ull * d->photons + (1u << 20);
    size_t want = d->photons;
    pgi_status st = PGI_OK;
    double yield = 0.5; /* photons per path, updated after each batch */
    while (ph->count < want && path < max_paths) {
        size_t remaining = want - ph->count;
        size_t batch = (size_t)(remaining / yield * 1.05) + 1024;
        if (batch > (1u << 18)) batch = 1u << 18;
        if (batch > max_paths - path) batch = (size_t)(max_paths - path);
        if (batch > sc->cap) {
            pgi__trace_scratch_free(sc);
            sc->bounces = B;
            sc->paths = malloc(batch * (size_t)B * sizeof(stored_photon));
            sc->counts = malloc(batch * sizeof(int));
            if (!sc->paths || !sc->counts) {
                pgi__trace_scratch_free(sc);
                st = pgi__fail(PGI_ERR_OOM, "out of memory tracing photons (%zu paths a batch)", batch);
                break;
            }
            sc->cap = batch;
        }
        stored_photon *buf = sc->paths;
        int *cnt = sc->counts;
        uint64_t batch_rays = 0;
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : batch_rays) num_threads(pgi__threads(d->threads))
        for (long long i = 0; i < (long long)batch; i++) {
            uint64_t r = 0;
            cnt[i] = trace_path(&T, path + (uint64_t)i, buf + (size_t)i * B, &r);
            batch_rays += r;
        }
        rays += batch_rays;
        size_t produced = 0;
        size_t i = 0;
        for (; i < batch && ph->count < want; i++) {
            for (int k = 0; k < cnt[i] && ph->count < want; k++) {
                const stored_photon *sp = &buf[i * B + k];
                size_t j = ph->count++;
                ph->px[j] = sp->p[0];
                ph->py[j] = sp->p[1];
                ph->pz[j] = sp->p[2];
                ph->dx[j] = sp->d[0];
                ph->dy[j] = sp->d[1];
                ph->dz[j] = sp->d[2];
                ph->fr[j] = sp->f[0];
                ph->fg[j] = sp->f[1];
                ph->fb[j] = sp->f[2];
                ph->nx[j] = sp->n[0];
                ph->ny[j] = sp->n[1];
                ph->nz[j] = sp->n[2];
                if (fp_on) {
                    ph->radius[j] = sp->fp.r;
                    if (ph->sax) {
                        ph->sax[j] = sp->fp.a[0];
                        ph->say[j] = sp->fp.a[1];
                        ph->saz[j] = sp->fp.a[2];
                        ph->sbx[j] = sp->fp.b[0];
                        ph->sby[j] = sp->fp.b[1];
                        ph->sbz[j] = sp->fp.b[2];
                    }
                    if (d->footprint_hist) {
                        float q = sp->fp.r_raw / bin_w;
                        int bin = q < (float)(PGI_FOOTPRINT_BINS - 1) ? (int)q : PGI_FOOTPRINT_BINS - 1;
                        d->footprint_hist[bin < 0 ? 0 : bin]++;
                    }
                }
            }
            produced += (size_t)cnt[i];
        }
        path += i;
        yield = produced > 0 ? (double)produced / (double)i : yield * 0.25;
        if (yield < 1e-4) yield = 1e-4;
    }
    free(cdf);
    *rays_out = rays;
    if (st) return st;
    ph->emitted = path;
    if (path > 0) {
        const float inv = (float)(1.0 / (double)path);
        for (size_t j = 0; j < ph->count; j++) {
            ph->fr[j] *= inv;
            ph->fg[j] *= inv;
            ph->fb[j] *= inv;
        }
    }
    return PGI_OK;
}
