/* Per-photon footprints for the radius policies (docs/bvh.md):
 *  - path: tiled paper eqs. 4-5, r = r_min + (r_max - r_min) sqrt(1 - rho), rho the product of
 *    the a priori scattering probabilities into ||Gamma|| = 1e-3 sr of the previous bounces;
 *  - differentials: photon differentials of the BVH paper §4 (two positional and two directional
 *    differentials w.r.t. the emission parameters, scaled by eq. 8 so that one global spacing
 *    Delta = sqrt(4 pi / n) serves every photon; Igehy's transfer and specular updates; 1/sqrt(p)
 *    for Russian roulette; diffuse re-emission with the backward origin offset of eq. 13; the
 *    ||dp||^(-3/4) compression and smoothing factor s; clamp to r_max), giving skewed ellipsoids.
 * The tracer calls these hooks; each is a no-op for the fixed policy. */
#ifndef PGI_DIFFERENTIALS_H
#define PGI_DIFFERENTIALS_H

#include "scene/bsdf.h"

typedef struct pgi__fp_params {
    int policy;             /* pgi_radius_policy */
    float r_min, r_max;
    float smoothing;        /* s for diffusely reflected photons (> 0) */
    float smoothing_caustic;/* s for photons with only specular bounces (paper: 5) */
    float delta;            /* global spacing sqrt(4 pi / n) */
    float photons;          /* n */
} pgi__fp_params;

typedef struct pgi__pdiff {
    pgi_v3 dp[2], dd[2];    /* positional / directional differentials */
    float rho;              /* path probability (path policy) */
    int diffuse;            /* at least one diffuse re-emission */
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

/* Directional differentials of eq. 8 for direction d in the frame around `axis`, times `scale`;
 * positional ones zero. */
void pgi__pd_emit_dir(pgi__pdiff *pd, pgi_v3 d, pgi_v3 axis, float scale);
/* Transfer over distance t along d onto the plane with normal n (Igehy 1999). */
void pgi__pd_transfer(pgi__pdiff *pd, pgi_v3 d, float t, pgi_v3 n);
/* Perfect specular reflection of travel direction d at normal n with normal differentials dn. */
void pgi__pd_reflect(pgi__pdiff *pd, pgi_v3 d, pgi_v3 n, const pgi_v3 dn[2]);
/* Refraction of d into t (relative index eta = eta_i / eta_t) at n (d.n < 0) with dn. */
void pgi__pd_refract(pgi__pdiff *pd, pgi_v3 d, pgi_v3 n, const pgi_v3 dn[2], float eta, pgi_v3 t);
/* Russian roulette survival with probability p: differentials times 1/sqrt(p). */
void pgi__pd_roulette(pgi__pdiff *pd, float p);
/* Diffuse re-emission into d_out around normal n: new directional differentials (eq. 8), origin
 * offset back by v (eq. 13) so that the footprint area is kept. */
void pgi__pd_reemit(pgi__pdiff *pd, pgi_v3 d_out, pgi_v3 n);
/* Footprint at the current hit (normal n) from the differentials. */
void pgi__pd_footprint(const pgi__pdiff *pd, const pgi__fp_params *p, pgi_v3 n, pgi__footprint *out);
/* Derivatives of the interpolated shading normal of triangle `prim` at barycentrics (bu, bv) along
 * the surface displacements dp[0..1], for the normal's orientation closest to `ref`; zero for flat
 * triangles. */
void pgi__pd_normal_derivative(const pgi_scene *s, uint32_t prim, float bu, float bv, const pgi_v3 dp[2], pgi_v3 ref,
                               pgi_v3 dn[2]);

/* ---- tracer hooks (no-ops for PGI_RADIUS_FIXED) ---- */
void pgi__fp_emit(pgi__pdiff *pd, const pgi__fp_params *p, const pgi_scene *s, const pgi_light *L, float pick_prob,
                  pgi_v3 d, float sun_radius);
void pgi__fp_hit(pgi__pdiff *pd, const pgi__fp_params *p, pgi_v3 d, float t, pgi_v3 ng);
void pgi__fp_store(const pgi__pdiff *pd, const pgi__fp_params *p, pgi_v3 ng, pgi__footprint *out);
/* After the BSDF sampled wo from wi (both away from the surface) with weight w. */
void pgi__fp_scatter(pgi__pdiff *pd, const pgi__fp_params *p, const pgi_scene *s, uint32_t prim, float bu, float bv,
                     const pgi_surface *sf, pgi_v3 wi, pgi_v3 wo, pgi_v3 w);
void pgi__fp_roulette(pgi__pdiff *pd, const pgi__fp_params *p, float survive);

#endif
