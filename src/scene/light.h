/* Lights: what each type of light does, in one place (docs/architecture.md, "How to add a light
 * type"). Here: the types (pgi__light_type) and the light record (pgi__light); each type's entry
 * of the table in light.c (pgi__light_kind: the name a scene description gives it, the fields its
 * description holds, which the scene formats read generically); and per type its power
 * (pgi__light_set_power), the start of its photons' differentials (pgi__light_diff_start), the
 * start of a photon path from it (emission: pgi__light_draw, then pgi__light_emit) and the light
 * it sends towards a point (direct light: pgi__light_delta, 16 points at once
 * pgi__light_delta16; area lights: pgi__light_area_cdf, pgi__light_area_toward,
 * pgi__light_area_pdf). The scene formats, the photon tracer (src/photon/trace.c), the
 * direct-light pass (src/view/view.c), the reference path tracer (src/reference/pathtrace.c) and
 * the GPU scene (src/gpu/gpu_scene.c) call these and test no light type themselves; the shaders'
 * copy is src/gpu/shaders/light.glsl.
 *
 * Everything here is the same operations as the code it came from, in the same order, so that
 * images stay the same bit for bit; the per-path functions are inline (the tracer is built for
 * three instruction sets).
 *
 * scene_internal.h includes the first part (the types) with PGI__LIGHT_TYPES_ONLY defined; the
 * rest needs the whole scene. */
#ifndef PGI__LIGHT_TYPES_H
#define PGI__LIGHT_TYPES_H

#include <stddef.h>
#include <stdint.h>

typedef enum pgi__light_type {
    PGI__LIGHT_POINT = 0, /* intensity I (W/sr), power 4 pi I */
    PGI__LIGHT_SPOT = 1,  /* intensity I inside the cone cos(theta) >= cos_cutoff */
    PGI__LIGHT_SUN = 2,   /* irradiance E (W/m^2) on surfaces facing -dir */
    PGI__LIGHT_AREA = 3,  /* one emissive triangle, one-sided Lambertian, radiance Le */
    PGI__LIGHT_ENV = 4    /* the environment (pgi__env.light; never in pgi_scene.lights) */
    /* a new type: its number here, its entry in light.c k_kinds, LIGHT_* in light.glsl */
} pgi__light_type;

typedef struct pgi__light {
    pgi__light_type type;
    float pos[3];     /* point/spot */
    float dir[3];     /* spot: axis; sun: direction light travels (unit) */
    float color[3];   /* I (point/spot), E (sun), Le (area) */
    float cos_cutoff; /* spot */
    uint32_t tri;     /* area: triangle index */
    float area;       /* area: triangle area */
    float normal[3];  /* area: unit emitting normal */
    float power[3];   /* computed by pgi__scene_finalize */
} pgi__light;

/* What a light's description holds besides its colour, field by field (pgi__light_kind.fields):
 * each scene format reads the fields a type lists, in this order, in its own way (scene_json.c
 * parse_light, gltf_scene.c, animate.c pgi__light_from_desc), and pgi__scene_check_numbers
 * checks them. */
enum {
    PGI__LIGHT_HAS_POS = 1,  /* pos: a position */
    PGI__LIGHT_HAS_DIR = 2,  /* dir: a direction, not zero (stored unit length) */
    PGI__LIGHT_HAS_CONE = 4, /* cos_cutoff: from a cone's half-angle in degrees, in (0, 180) */
};

/* A light type's entry in the table (light.c). */
typedef struct pgi__light_kind {
    pgi__light_type type;
    const char *name;     /* as a scene description spells it ("point"), and in messages */
    const char *gltf;     /* its KHR_lights_punctual type; NULL: none */
    const char *colour;   /* the key of its colour in a description ("intensity"); NULL: no
                             description gives this type (area lights, the sky) */
    const char *power_of; /* what its power is its colour times, for messages ("its solid angle") */
    int pub;              /* its pgi_light_kind (photongi.h); -1: none */
    int fields;           /* PGI__LIGHT_HAS_*: what its description holds besides the colour */
    size_t count_at;      /* offsetof its count in pgi_scene_info; 0: not counted there */
} pgi__light_kind;

#endif /* PGI__LIGHT_TYPES_H */

#if !defined(PGI__LIGHT_TYPES_ONLY) && !defined(PGI__LIGHT_H)
#define PGI__LIGHT_H

#include "scene/portal.h"
#include "scene/scene_internal.h"

/* ---------------------------------------------------------------- table */

/* Type t's entry (every pgi__light_type has one). */
const pgi__light_kind *pgi__light_kind_of(pgi__light_type t);

/* The type named `name` by a scene description (gltf = 0: pgi__light_kind.name) or by glTF's
 * KHR_lights_punctual (gltf = 1: .gltf); NULL when none. */
const pgi__light_kind *pgi__light_kind_named(const char *name, int gltf);
/* The type a description may give whose public kind (pgi_light_kind) is `pub`; NULL when none. */
const pgi__light_kind *pgi__light_kind_public(int pub);

/* The names of the types a description may give (public_only = 1: those with a public kind), for
 * messages: `"point", "spot" or "sun"` (quoted = 1) or `point, spot or sun`. */
const char *pgi__light_kind_list(char *buf, size_t n, int quoted, int public_only);

/* The start of a photon's differentials (src/photon/differentials.c pgi__pd_emit): a light whose
 * photons leave over a disk in parallel (parallel: positional differentials of length `scale`
 * across d), or from a point or a surface in directions spread about `axis` (directional ones
 * scaled by `scale`, then, offset: the origin moved back so that the footprint at the light is
 * `area`, its share of the light's area). pl: the light's pick probability (> 0); sun_radius: the
 * disk's. */
typedef struct pgi__light_diff {
    int parallel, offset;
    pgi__v3 axis;
    float scale, area;
} pgi__light_diff;
pgi__light_diff pgi__light_diff_start(const pgi__light *L, float pl, pgi__v3 d, float sun_radius);

/* ---------------------------------------------------------------- power */

/* Sets l->power from its colour: intensity over the solid angle it lights (point, spot),
 * irradiance over a disk covering the scene's bounding sphere of diagonal `diag` (sun), radiance
 * over its area (area light, l->area set). The sky's is pgi__env_set_radius's. */
void pgi__light_set_power(pgi__light *l, float diag);

/* The luminance of the power the photon tracer picks light L by: its power's, or with portal
 * emission (pe: the sky's table; NULL: none) the sun's and the sky's power through the portals. */
static inline double pgi__light_pick_power(const pgi_scene *s, const pgi__light *L, const pgi__portal_emit *pe) {
    if (pe && L->type == PGI__LIGHT_SUN)
        return fmax(0.0, (double)v3_lum(v3_load(L->color))) * pgi__portal_sun_area(s, v3_load(L->dir));
    if (pe && L->type == PGI__LIGHT_ENV) return pe->sky_lum;
    return fmax(0.0, (double)v3_lum(v3_load(L->power)));
}

/* Whether every path of light L starts at one point (point and spot lights): the tracer sorts
 * those paths by direction and casts their first rays as coherent packets (trace.c first_hits). */
static inline int pgi__light_from_point(const pgi__light *L) {
    return L->type == PGI__LIGHT_POINT || L->type == PGI__LIGHT_SPOT;
}

/* ------------------------------------------------------------- emission */

/* Whether the light's own pair of numbers (the one a guide steers) is u[2], u[3] of its four
 * (an area light's direction, the sky's disk point) rather than u[0], u[1]. */
static inline int pgi__light_pair_late(const pgi__light *L) {
    return L->type == PGI__LIGHT_AREA || L->type == PGI__LIGHT_ENV;
}

/* The four numbers of an emission from L, drawn from `rng` in their historical order: u[0] and
 * u[1], then an area light's u[3] before its u[2] (the order gcc gave two draws that were
 * arguments of one call; explicit, so that every compiler draws the same), the sky's u[2], u[3];
 * zeros for the rest. */
static inline void pgi__light_draw(const pgi__light *L, pgi__rng *rng, float u[4]) {
    u[0] = pgi_rng_f(rng);
    u[1] = pgi_rng_f(rng);
    u[2] = u[3] = 0.f;
    if (L->type == PGI__LIGHT_AREA) {
        u[3] = pgi_rng_f(rng);
        u[2] = pgi_rng_f(rng);
    } else if (L->type == PGI__LIGHT_ENV) {
        u[2] = pgi_rng_f(rng);
        u[3] = pgi_rng_f(rng);
    }
}

/* What an emission needs of the scene besides the light: the bounding sphere (centre, radius) the
 * sun's and the sky's parallel photons cover, the offset of an area light's origins, and portal
 * emission (portals: NULL, or the sky's table; the sun and the sky then start on the portals). */
typedef struct pgi__emit_frame {
    const pgi_scene *s;
    pgi__v3 centre;
    float radius, eps;
    const pgi__portal_emit *portals;
} pgi__emit_frame;

/* pgi__light_emit for a point or spot light (pgi__light_from_point): the ray from its position,
 * the flux power / pl. `cs`: cos and sin of 2 pi u[1] where known (the same bits as cosf and
 * sinf); NULL: computed here. */
static inline void pgi__light_emit_point(const pgi__light *L, float pl, const float u[4], const float *cs, pgi__v3 *o,
                                         pgi__v3 *d, pgi__v3 *flux) {
    const float u1 = u[0], u2 = u[1];
    *flux = v3_scale(v3_load(L->power), 1.f / pl);
    *o = v3_load(L->pos);
    if (L->type == PGI__LIGHT_POINT) *d = cs ? pgi_sample_sphere_cs(u1, cs[0], cs[1]) : pgi_sample_sphere(u1, u2);
    else
        *d = pgi_to_world(cs ? pgi_sample_cone_cs(u1, cs[0], cs[1], L->cos_cutoff)
                             : pgi_sample_cone(u1, u2, L->cos_cutoff),
                          v3_load(L->dir));
}

/* The start of a photon path from L, picked with probability pl > 0, from its four numbers u
 * (pgi__light_draw, or a guide's): origin o, direction d and flux (its power / pl, or with
 * portals and the sky the radiance over the density of the line). Portal emission draws one more
 * number from `rng`. 0 when the path carries nothing. */
static inline int pgi__light_emit(const pgi__light *L, const pgi__emit_frame *F, float pl, const float u[4],
                                  pgi__rng *rng, pgi__v3 *o, pgi__v3 *d, pgi__v3 *flux) {
    const float u1 = u[0], u2 = u[1], u3 = u[2], u4 = u[3];
    switch (L->type) {
    case PGI__LIGHT_POINT:
    case PGI__LIGHT_SPOT: pgi__light_emit_point(L, pl, u, NULL, o, d, flux); return 1;
    case PGI__LIGHT_SUN: {
        *d = v3_load(L->dir);
        if (F->portals) {
            /* a point of a portal picked by its area across the beam: flux E A_perp / (portals
               the line crosses) / the pick probability (portal.h) */
            float wgt;
            if (!pgi__portal_sun_emit(F->s, *d, pgi_rng_f(rng), u1, u2, F->centre, F->radius, o, &wgt)) return 0;
            *flux = v3_scale(v3_load(L->color), wgt / pl);
            return 1;
        }
        *flux = v3_scale(v3_load(L->power), 1.f / pl);
        float r = F->radius * sqrtf(u1), phi = 2.f * PGI__PI * u2;
        pgi__v3 disk = pgi_to_world(v3(r * cosf(phi), r * sinf(phi), 0.f), *d);
        *o = v3_add(v3_sub(F->centre, v3_scale(*d, 1.01f * F->radius)), disk);
        return 1;
    }
    case PGI__LIGHT_ENV: {
        if (F->portals) {
            /* a line through a portal (portal.h): its radiance over the line's density */
            const float up[5] = {pgi_rng_f(rng), u1, u2, u3, u4};
            pgi__v3 f;
            if (!pgi__portal_sky_emit(F->portals, F->s->env, up, F->centre, F->radius, o, d, &f)) return 0;
            *flux = v3_scale(f, 1.f / pl);
            return 1;
        }
        /* A direction w by the sky's density, then a uniform point of the disk of radius R
         * perpendicular to w outside the bounding sphere, travelling along -w: flux
         * L(w) pi R^2 / pdf(w) (the light's power pi R^2 int L dw when pdf is proportional to L). */
        float pdf;
        pgi__v3 w = pgi__env_sample(F->s->env, u1, u2, &pdf);
        if (!(pdf > 0.f)) return 0;
        *flux = v3_scale(pgi__env_eval(F->s->env, w), PGI__PI * F->radius * F->radius / (pdf * pl));
        *d = v3_neg(w);
        float r = F->radius * sqrtf(u3), phi = 2.f * PGI__PI * u4;
        pgi__v3 disk = pgi_to_world(v3(r * cosf(phi), r * sinf(phi), 0.f), *d);
        *o = v3_add(v3_madd(F->centre, w, 1.01f * F->radius), disk);
        return 1;
    }
    case PGI__LIGHT_AREA:
    default: {
        *flux = v3_scale(v3_load(L->power), 1.f / pl);
        pgi__v3 n = v3_load(L->normal);
        *o = v3_madd(pgi__triangle_sample(F->s, L->tri, u1, u2), n, F->eps);
        *d = pgi_to_world(pgi_sample_cosine(u3, u4), n);
        return 1;
    }
    }
}

/* --------------------------------------------------- towards a point */

/* Light from a delta light (point, spot, sun) at x with shading normal ns and geometric normal
 * ng: the unit direction `wi` towards the light, the unshadowed radiance `Li`, the cosine `cs` =
 * ns.wi and the far end `tmax` of the shadow ray from x. Returns 0 when the light cannot reach x
 * (an area light or the sky, x at the light's position, outside a spot's cone, behind ns or ng).
 * Shared by the direct-light pass and the reference path tracer's next-event estimation, so that
 * both compute the same numbers. */
static inline int pgi__light_delta(const pgi__light *lt, pgi__v3 x, pgi__v3 ns, pgi__v3 ng, pgi__v3 *wi, pgi__v3 *Li,
                                   float *cs, float *tmax) {
    float dist;
    if (lt->type == PGI__LIGHT_AREA || lt->type == PGI__LIGHT_ENV) return 0;
    if (lt->type == PGI__LIGHT_SUN) {
        *wi = v3_neg(v3_load(lt->dir));
        dist = INFINITY;
        *Li = v3_load(lt->color);
    } else {
        pgi__v3 dv = v3_sub(v3_load(lt->pos), x);
        float d2 = v3_dot(dv, dv);
        if (!(d2 > 0.f)) return 0;
        dist = sqrtf(d2);
        *wi = v3_scale(dv, 1.f / dist);
        if (lt->type == PGI__LIGHT_SPOT && -v3_dot(*wi, v3_load(lt->dir)) < lt->cos_cutoff) return 0;
        *Li = v3_scale(v3_load(lt->color), 1.f / d2);
    }
    *cs = v3_dot(ns, *wi);
    if (!(*cs > 0.f) || !(v3_dot(ng, *wi) > 0.f)) return 0;
    *tmax = dist == INFINITY ? INFINITY : dist * (1.f - 1e-4f);
    return 1;
}

/* Whether lt is a delta light (point, spot, sun), the lights pgi__light_delta serves. */
static inline int pgi__light_is_delta(const pgi__light *lt) {
    return lt->type != PGI__LIGHT_AREA && lt->type != PGI__LIGHT_ENV;
}

/* Whether pgi__light_delta16 serves light lt (point lights and the sun; pgi__light_delta the
 * others, lane by lane). */
static inline int pgi__light_delta16_ok(const pgi__light *lt) {
    return lt->type == PGI__LIGHT_POINT || lt->type == PGI__LIGHT_SUN;
}

/* pgi__light_delta at 16 points at once (x, ns, ng by component, `on` the lanes to light) for a
 * point light or the sun: the same operations lane by lane (so the same numbers, bit for bit),
 * branch-free over arrays so that the compiler runs four or more lanes in one instruction. Fills
 * valid (0 where off or unreachable), wi, Li, cs and tmax as pgi__light_delta would; returns the
 * number of valid lanes. */
static inline int pgi__light_delta16(const pgi__light *lt, const int on[16], const float xs[3][16],
                                     const float nss[3][16], const float ngs[3][16], int valid[16], float wi[3][16],
                                     float Li[3][16], float cs[16], float tmax[16]) {
    int nv = 0;
    const float cr = lt->color[0], cg = lt->color[1], cb = lt->color[2];
    if (lt->type == PGI__LIGHT_SUN) {
        const float wx = -lt->dir[0], wy = -lt->dir[1], wz = -lt->dir[2];
        for (int k = 0; k < 16; k++) {
            wi[0][k] = wx;
            wi[1][k] = wy;
            wi[2][k] = wz;
            Li[0][k] = cr;
            Li[1][k] = cg;
            Li[2][k] = cb;
            const float c = nss[0][k] * wx + nss[1][k] * wy + nss[2][k] * wz;
            const float g = ngs[0][k] * wx + ngs[1][k] * wy + ngs[2][k] * wz;
            cs[k] = c;
            tmax[k] = INFINITY;
            valid[k] = on[k] & (c > 0.f) & (g > 0.f);
            nv += valid[k];
        }
        return nv;
    }
    const float px = lt->pos[0], py = lt->pos[1], pz = lt->pos[2];
    for (int k = 0; k < 16; k++) {
        const float dx = px - xs[0][k], dy = py - xs[1][k], dz = pz - xs[2][k];
        const float d2 = dx * dx + dy * dy + dz * dz, dist = sqrtf(d2), inv = 1.f / dist, il = 1.f / d2;
        const float wx = dx * inv, wy = dy * inv, wz = dz * inv;
        wi[0][k] = wx;
        wi[1][k] = wy;
        wi[2][k] = wz;
        Li[0][k] = cr * il;
        Li[1][k] = cg * il;
        Li[2][k] = cb * il;
        const float c = nss[0][k] * wx + nss[1][k] * wy + nss[2][k] * wz;
        const float g = ngs[0][k] * wx + ngs[1][k] * wy + ngs[2][k] * wz;
        cs[k] = c;
        tmax[k] = dist * (1.f - 1e-4f); /* infinity stays infinity, as in pgi__light_delta */
        valid[k] = on[k] & (d2 > 0.f) & (c > 0.f) & (g > 0.f);
        nv += valid[k];
    }
    return nv;
}

/* The scene's area lights picked by the luminance of their power (uniformly when all are dark):
 * cdf[k] of the k-th area light, idx[k] its index in s->lights (idx may be NULL); both hold room
 * for every area light. Returns how many there are (0: none, cdf untouched). */
size_t pgi__light_area_cdf(const pgi_scene *s, float *cdf, size_t *idx);

/* How many area lights the scene has. */
size_t pgi__light_area_count(const pgi_scene *s);

/* From x towards y, a point of an area light with unit normal n (pgi__triangle_sample): the unit
 * direction *wi, the squared distance *d2, the distance *dist and the cosine at the light *cl
 * (the light reaches x where cl > 0). 0, with nothing written, where y is x. */
static inline int pgi__light_area_toward(pgi__v3 y, pgi__v3 n, pgi__v3 x, pgi__v3 *wi, float *d2, float *dist,
                                         float *cl) {
    const pgi__v3 dv = v3_sub(y, x);
    const float q = v3_dot(dv, dv);
    if (!(q > 0.f)) return 0;
    const float l = sqrtf(q);
    *d2 = q;
    *dist = l;
    *wi = v3_scale(dv, 1.f / l);
    *cl = -v3_dot(*wi, n);
    return 1;
}

/* The density, in solid angle at the shaded point, of a point on area light lt picked with
 * probability pl, at squared distance d2 and cosine cl at the light. */
static inline float pgi__light_area_pdf(const pgi__light *lt, float pl, float d2, float cl) {
    return pl * d2 / (cl * lt->area);
}

#endif /* PGI__LIGHT_H */
