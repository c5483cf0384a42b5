/* Radius policies (BVH paper §4, tiled paper eqs. 4-5; docs/bvh.md): per-photon footprints.
 *  - fixed: nothing per photon (the estimators use the global radius);
 *  - path: tiled paper eqs. 4-5, r = r_min + (r_max - r_min) sqrt(1 - rho), rho the product of
 *    the a priori scattering probabilities into ||Gamma|| = 1e-3 sr of the previous bounces
 *    (radius.c);
 *  - differentials: photon differentials of the BVH paper §4, giving skewed ellipsoids
 *    (differentials.h / differentials.c).
 * The tracer calls the hooks below; each is a no-op for the fixed policy. */
#ifndef PGI__RADIUS_H
#define PGI__RADIUS_H

#include "scene/bsdf.h"

typedef struct pgi__fp_params {
    int policy; /* pgi_radius_policy */
    float r_min, r_max;
    float smoothing;         /* s for diffusely reflected photons (> 0) */
    float smoothing_caustic; /* s for photons with only specular bounces (paper: 5) */
    float delta;             /* global spacing sqrt(4 pi / n) */
    float photons;           /* n */
} pgi__fp_params;

typedef struct pgi__pdiff {
    pgi__v3 dp[2], dd[2]; /* positional / directional differentials */
    float rho;            /* path probability (path policy) */
    int diffuse;          /* at least one diffuse re-emission */
} pgi__pdiff;

/* A stored footprint: equivalent radius (clamped), semi-axes, and the radius before the clamp
 * (for the histogram). */
typedef struct pgi__footprint {
    float r, a[3], b[3], r_raw;
} pgi__footprint;

/* Fills p for `policy`; n = photons to store (the paper's n). smoothing 0 = automatic from the
 * scene diagonal. */
void pgi__fp_params_init(pgi__fp_params *p, int policy, float r_min, float r_max, float smoothing, uint32_t n,
                         float scene_diagonal);

/* ---- tracer hooks (no-ops for PGI_RADIUS_FIXED) ---- */
void pgi__fp_emit(pgi__pdiff *pd, const pgi__fp_params *p, const pgi_scene *s, const pgi__light *L, float pick_prob,
                  pgi__v3 d, float sun_radius);
void pgi__fp_hit(pgi__pdiff *pd, const pgi__fp_params *p, pgi__v3 d, float t, pgi__v3 ng);
void pgi__fp_store(const pgi__pdiff *pd, const pgi__fp_params *p, pgi__v3 ng, pgi__footprint *out);
/* After the BSDF sampled wo from wi (both away from the surface) with weight w. */
void pgi__fp_scatter(pgi__pdiff *pd, const pgi__fp_params *p, const pgi_scene *s, uint32_t prim, float bu, float bv,
                     const pgi__surface *sf, pgi__v3 wi, pgi__v3 wo, pgi__v3 w);
void pgi__fp_roulette(pgi__pdiff *pd, const pgi__fp_params *p, float survive);

#endif
