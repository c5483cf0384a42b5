/* Portals (docs/scene-format.md "portals", docs/emission.md "Portals"): parallelograms that mark
 * where the sun and the sky come into the inside of a scene (windows, skylights), the way Cycles
 * and Corona users mark them. Photon emission through them (--emission portal, trace.c) and the
 * sky's direct light (portal samples combined with the cosine ones by MIS, view.c) use the
 * helpers here.
 *
 * A portal is o + a e1 + b e2, a, b in [0, 1]; light crosses it along n = unit(e1 x e2) (into the
 * interior). Sampling is by area (a uniform point of a portal picked by weight), so every density
 * here is of lines (area across the line times solid angle): a portal point x and a direction d
 * with density p_A(x) p(d) have the line density p_A(x) p(d) / |n . d|. */
#ifndef PGI__PORTAL_H
#define PGI__PORTAL_H

#include "scene/scene_internal.h"

#define PGI__MAX_PORTALS 256

/* Sets a portal from its four corners in order (v0 v1 v2 v3 around it; v2 = v1 + v3 - v0 within
 * 1e-3 of its size). NULL on success, else what is wrong (static string). */
const char *pgi__portal_from_quad(pgi__portal *p, const float v[4][3]);

/* Where the line o + t d meets portal p: 1 and *t when inside the parallelogram (any t), else 0. */
static inline int pgi__portal_hit(const pgi__portal *p, pgi__v3 o, pgi__v3 d, float *t) {
    const pgi__v3 n = v3_load(p->n);
    const float dn = v3_dot(d, n);
    if (!(fabsf(dn) > 1e-12f)) return 0;
    const float tt = v3_dot(v3_sub(v3_load(p->o), o), n) / dn;
    const pgi__v3 q = v3_sub(v3_madd(o, d, tt), v3_load(p->o));
    const float a = v3_dot(q, v3_load(p->d1)), b = v3_dot(q, v3_load(p->d2));
    /* a point sampled on an edge is found again despite rounding (the margin is of measure ~1e-6) */
    const float lo = -1e-6f, hi = 1.f + 1e-6f;
    if (!(a >= lo && a <= hi && b >= lo && b <= hi)) return 0;
    *t = tt;
    return 1;
}

/* Point (a, b) of portal p. */
static inline pgi__v3 pgi__portal_point(const pgi__portal *p, float a, float b) {
    return v3_add(v3_load(p->o), v3_add(v3_scale(v3_load(p->e1), a), v3_scale(v3_load(p->e2), b)));
}

/* Emission through the portals (trace.c), set up per frame from the scene's sky: each portal's
 * power from the sky (luminance), their CDF, and the sky's total through them. */
typedef struct pgi__portal_emit {
    const pgi__portal *p;
    size_t n;
    float *cdf;       /* n entries: the sky's power through each portal, cumulative, normalised */
    double *w;        /* n: each portal's pick probability (sky) */
    double sky_lum;   /* the sky's power through the portals, luminance (0: no sky) */
    float sky_rgb[3]; /* ... and per channel */
    int map_mix;      /* an environment map: half of the directions by the map's density */
} pgi__portal_emit;

/* Builds the table for scene s (its portals and sky). */
pgi_status pgi__portal_emit_init(pgi__portal_emit *e, const pgi_scene *s);
void pgi__portal_emit_free(pgi__portal_emit *e);
/* A sun of direction d (unit, as light travels): the area of the portals across its beam, sum of
 * A_i max(0, n_i . d). */
double pgi__portal_sun_area(const pgi_scene *s, pgi__v3 d);
/* Photon emission of a sun of irradiance E through the portals: numbers u0 (portal pick), u1, u2
 * (point). Returns 0 when no portal faces it; else the ray (o: outside the bounding sphere of
 * centre c and radius R, d: dir) and the flux weight (area across the beam / portals the line
 * crosses). */
int pgi__portal_sun_emit(const pgi_scene *s, pgi__v3 dir, float u0, float u1, float u2, pgi__v3 c, float R, pgi__v3 *o,
                         float *weight);
/* Photon emission of the sky through the portals: five numbers; the ray and the flux (the
 * radiance over the line density, to be divided by the light pick probability). 0: none. */
int pgi__portal_sky_emit(const pgi__portal_emit *e, const pgi__env *env, const float u[5], pgi__v3 c, float R,
                         pgi__v3 *o, pgi__v3 *d, pgi__v3 *flux);

/* Lines through the portals per line of uniform emission, over the sun's and the sky's power
 * (luminance): the share of their uniform paths that can come in (0: no sun, sky or portal). */
double pgi__portal_share(const pgi_scene *s);
/* `auto` emission takes the portals when their share is below this: uniform emission would then
 * trace more than twice the sun's and the sky's paths for the same light inside. */
#define PGI__PORTAL_AUTO_SHARE 0.5

/* A rectangular portal seen from a point, set up for sampling its solid angle (portal.c): the
 * rectangle in a frame at the point, its spherical rectangle's angles and its solid angle S. */
typedef struct pgi__portal_sph {
    pgi__v3 x, y, z;
    float x0, y0, z0, x1, y1, b0, b1, k, S;
} pgi__portal_sph;
/* The first PGI__PORTAL_CACHE portals' set-ups are kept by pgi__portal_direct_weights for the
 * samples at the same point (the others are set up again at each sample). */
#define PGI__PORTAL_CACHE 4

/* Direct light from the sky at x of shading normal ns (view.c). w holds 2n floats: w[i] the
 * portals' pick probabilities seen from x (their solid angle, times 0.1 + the cosine at x
 * towards their centre; 0 for a portal x is not on the inside of, or whose four corners lie
 * below x's horizon, the plane of ns), w[n + i] portal i's solid angle
 * where it is sampled by solid angle (a rectangle seen under more than 1e-3 sr: Ureña et al.
 * 2013's spherical rectangles, uniform in the solid angle), else 0 (a uniform point of its area,
 * converted: distance^2 / (area cos)). Returns the weights' sum before normalisation (0: no
 * portal lights x). */
float pgi__portal_direct_weights(const pgi__portal *p, size_t n, pgi__v3 x, pgi__v3 ns, float *w,
                                 pgi__portal_sph cache[PGI__PORTAL_CACHE]);
/* A direction from x towards a portal picked by w with u0; the point is uniform in the portal's
 * solid angle or its area, as w says, its first number u0's place within the portal's share of
 * [0, 1) (so that stratified u0 stratify the points too), its second u2. 0 when it is degenerate. */
int pgi__portal_direct_sample(const pgi__portal *p, size_t n, const float *w,
                              const pgi__portal_sph cache[PGI__PORTAL_CACHE], pgi__v3 x, float u0, float u2,
                              pgi__v3 *dir);
/* Solid-angle density of pgi__portal_direct_sample for direction dir from x (every portal the ray
 * x + t dir, t > 0, crosses inwards). */
float pgi__portal_direct_pdf(const pgi__portal *p, size_t n, const float *w, pgi__v3 x, pgi__v3 dir);

#endif
