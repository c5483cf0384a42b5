/* Photon differentials of the BVH paper §4 (docs/bvh.md), the differentials radius policy (the
 * policies and the tracer hooks are in radius.h): two positional and two directional
 * differentials w.r.t. the emission parameters, scaled by eq. 8 so that one global spacing
 * Delta = sqrt(4 pi / n) serves every photon; Igehy's transfer and specular updates; 1/sqrt(p)
 * for Russian roulette; diffuse re-emission with the backward origin offset of eq. 13; the
 * ||dp||^(-3/4) compression and smoothing factor s; clamp to r_max; giving skewed ellipsoids. */
#ifndef PGI__DIFFERENTIALS_H
#define PGI__DIFFERENTIALS_H

#include "radius.h"

/* Directional differentials of eq. 8 for direction d in the frame around `axis`, times `scale`;
 * positional ones zero. */
void pgi__pd_emit_dir(pgi__pdiff *pd, pgi__v3 d, pgi__v3 axis, float scale);
/* Transfer over distance t along d onto the plane with normal n (Igehy 1999). */
void pgi__pd_transfer(pgi__pdiff *pd, pgi__v3 d, float t, pgi__v3 n);
/* Perfect specular reflection of travel direction d at normal n with normal differentials dn. */
void pgi__pd_reflect(pgi__pdiff *pd, pgi__v3 d, pgi__v3 n, const pgi__v3 dn[2]);
/* Refraction of d into t (relative index eta = eta_i / eta_t) at n (d.n < 0) with dn. */
void pgi__pd_refract(pgi__pdiff *pd, pgi__v3 d, pgi__v3 n, const pgi__v3 dn[2], float eta, pgi__v3 t);
/* Russian roulette survival with probability p: differentials times 1/sqrt(p). */
void pgi__pd_roulette(pgi__pdiff *pd, float p);
/* Diffuse re-emission into d_out around normal n: new directional differentials (eq. 8), origin
 * offset back by v (eq. 13) so that the footprint area is kept. */
void pgi__pd_reemit(pgi__pdiff *pd, pgi__v3 d_out, pgi__v3 n);
/* Footprint at the current hit (normal n) from the differentials. */
void pgi__pd_footprint(const pgi__pdiff *pd, const pgi__fp_params *p, pgi__v3 n, pgi__footprint *out);
/* Derivatives of the interpolated shading normal of triangle `prim` at barycentrics (bu, bv) along
 * the surface displacements dp[0..1], for the normal's orientation closest to `ref`; zero for flat
 * triangles. */
void pgi__pd_normal_derivative(const pgi_scene *s, uint32_t prim, float bu, float bv, const pgi__v3 dp[2], pgi__v3 ref,
                               pgi__v3 dn[2]);

/* Emission differentials for a photon leaving light L (picked with probability pl) in direction d
 * (the differentials policy of pgi__fp_emit). */
void pgi__pd_emit(pgi__pdiff *pd, const pgi__light *L, float pl, pgi__v3 d, float sun_radius);
/* Differentials update after the BSDF sampled wo from wi at surface sf of triangle prim (the
 * differentials policy of pgi__fp_scatter). */
void pgi__pd_scatter(pgi__pdiff *pd, const pgi_scene *s, uint32_t prim, float bu, float bv, const pgi__surface *sf,
                     pgi__v3 wi, pgi__v3 wo);

#endif
