/* Radius policies (see radius.h and docs/bvh.md): the tracer's hooks, which dispatch on the
 * policy; the path-probability radius (tiled paper eqs. 4-5) is computed here, the photon
 * differentials in differentials.c. */
#include "radius.h"

#include "differentials.h"
#include "photongi/photongi.h"

void pgi__fp_params_init(pgi__fp_params *p, int policy, float r_min, float r_max, float smoothing, uint32_t n,
                         float diag) {
    p->policy = policy;
    p->r_min = r_min;
    p->r_max = r_max;
    p->photons = (float)(n ? n : 1);
    p->delta = sqrtf(4.f * PGI__PI / p->photons);
    /* Automatic s: a photon re-emitted a quarter of the scene diagonal away gets r_max / 2
     * (semi-axis Delta * s * ||dp||^(1/4) with ||dp|| = that distance). */
    if (!(smoothing > 0.f)) smoothing = 0.5f * r_max / (p->delta * powf(fmaxf(0.25f * diag, 1e-6f), 0.25f));
    p->smoothing = smoothing;
    p->smoothing_caustic = 5.f;
}

/* ------------------------------------------------------------------ hooks */

void pgi__fp_emit(pgi__pdiff *pd, const pgi__fp_params *p, const pgi_scene *s, const pgi__light *L, float pl, pgi__v3 d,
                  float sun_radius) {
    pd->rho = 1.f;
    pd->diffuse = 0;
    if (p->policy != PGI_RADIUS_DIFFERENTIALS) return;
    pgi__pd_emit(pd, L, pl, d, sun_radius);
}

void pgi__fp_hit(pgi__pdiff *pd, const pgi__fp_params *p, pgi__v3 d, float t, pgi__v3 ng) {
    if (p->policy == PGI_RADIUS_DIFFERENTIALS) pgi__pd_transfer(pd, d, t, ng);
}

void pgi__fp_store(const pgi__pdiff *pd, const pgi__fp_params *p, pgi__v3 ng, pgi__footprint *o) {
    if (p->policy == PGI_RADIUS_DIFFERENTIALS) {
        pgi__pd_footprint(pd, p, ng, o);
    } else if (p->policy == PGI_RADIUS_PATH) {
        float rho = fminf(fmaxf(pd->rho, 0.f), 1.f);
        o->r = o->r_raw = p->r_min + (p->r_max - p->r_min) * sqrtf(1.f - rho);
    }
}

void pgi__fp_scatter(pgi__pdiff *pd, const pgi__fp_params *p, const pgi_scene *s, uint32_t prim, float bu, float bv,
                     const pgi__surface *sf, pgi__v3 wi, pgi__v3 wo, pgi__v3 w) {
    if (p->policy == PGI_RADIUS_FIXED) return;
    const int spec = pgi__mat_specular(sf->mat);
    if (p->policy == PGI_RADIUS_PATH) {
        /* a priori probability of scattering into ||Gamma|| = 1e-3 sr around wo: the whole
         * reflectance for a delta lobe, f cos ||Gamma|| otherwise (eq. 5) */
        float pb;
        if (spec) pb = v3_lum(w);
        else {
            float side = v3_dot(wi, sf->ng) >= 0.f ? 1.f : -1.f;
            pgi__v3 ns = v3_scale(sf->ns, side);
            pgi__lobe lobe;
            pgi__lobe_of_material(sf->mat, &lobe);
            pgi__v3 f = pgi__brdf_eval(sf->kd, &lobe, ns, wi, wo);
            pb = v3_lum(f) * fmaxf(0.f, v3_dot(wo, ns)) * 1e-3f;
        }
        pd->rho *= fminf(fmaxf(pb, 0.f), 1.f);
        return;
    }
    pgi__pd_scatter(pd, s, prim, bu, bv, sf, wi, wo);
}

void pgi__fp_roulette(pgi__pdiff *pd, const pgi__fp_params *p, float survive) {
    if (p->policy == PGI_RADIUS_DIFFERENTIALS) pgi__pd_roulette(pd, survive);
}
