/* Lights (light.h): each type's entry in the table, and the parts that are not per path. */
#include "light.h"

#include <stdio.h>
#include <string.h>

#include "photongi/photongi.h"

/* Every type, in pgi__light_type order. The scene formats read a light's fields from this table
 * (light.h PGI__LIGHT_HAS_*), so that a new type with the fields of these is an entry here. */
static const pgi__light_kind k_kinds[] = {
    {PGI__LIGHT_POINT, "point", "point", "intensity", "its solid angle", PGI_LIGHT_KIND_POINT, PGI__LIGHT_HAS_POS,
     offsetof(pgi_scene_info, point_lights)},
    {PGI__LIGHT_SPOT, "spot", "spot", "intensity", "its solid angle", PGI_LIGHT_KIND_SPOT,
     PGI__LIGHT_HAS_POS | PGI__LIGHT_HAS_DIR | PGI__LIGHT_HAS_CONE, offsetof(pgi_scene_info, spot_lights)},
    {PGI__LIGHT_SUN, "sun", "directional", "irradiance", "the scene's cross-section", PGI_LIGHT_KIND_SUN,
     PGI__LIGHT_HAS_DIR, offsetof(pgi_scene_info, sun_lights)},
    /* emissive triangles (the materials' emission), and the sky (the scene's environment): no
     * description gives these (no colour key) */
    {PGI__LIGHT_AREA, "area", NULL, NULL, "its area", PGI_LIGHT_KIND_AREA, 0, offsetof(pgi_scene_info, area_triangles)},
    {PGI__LIGHT_ENV, "environment", NULL, NULL, "its area", -1, 0, 0},
};
#define N_KINDS (sizeof k_kinds / sizeof k_kinds[0])
_Static_assert(N_KINDS == PGI__LIGHT_ENV + 1, "k_kinds: one entry a pgi__light_type, in its order");

const pgi__light_kind *pgi__light_kind_of(pgi__light_type t) {
    return (size_t)t < N_KINDS ? &k_kinds[t] : &k_kinds[PGI__LIGHT_AREA];
}

const pgi__light_kind *pgi__light_kind_named(const char *name, int gltf) {
    for (size_t i = 0; i < N_KINDS; i++) {
        const char *n = gltf ? k_kinds[i].gltf : k_kinds[i].name;
        if (k_kinds[i].colour && n && strcmp(n, name) == 0) return &k_kinds[i];
    }
    return NULL;
}

const pgi__light_kind *pgi__light_kind_public(int pub) {
    for (size_t i = 0; i < N_KINDS; i++)
        if (k_kinds[i].colour && k_kinds[i].pub == pub) return &k_kinds[i];
    return NULL;
}

const char *pgi__light_kind_list(char *buf, size_t n, int quoted, int public_only) {
    size_t m = 0, k = 0;
    for (size_t i = 0; i < N_KINDS; i++) m += k_kinds[i].colour && (!public_only || k_kinds[i].pub >= 0);
    buf[0] = '\0';
    for (size_t i = 0; i < N_KINDS; i++) {
        if (!k_kinds[i].colour || (public_only && k_kinds[i].pub < 0)) continue;
        const char *sep = k == 0 ? "" : k + 1 == m ? " or " : ", ";
        const size_t used = strlen(buf);
        snprintf(buf + used, n - used, quoted ? "%s\"%s\"" : "%s%s", sep, k_kinds[i].name);
        k++;
    }
    return buf;
}

pgi__light_diff pgi__light_diff_start(const pgi__light *L, float pl, pgi__v3 d, float sun_radius) {
    /* Photons of this light: n * pl. Scale the unit differentials so that the global Delta gives
     * each photon its share of the light's solid angle (or area): |Delta dd|^2 = Omega / (n pl). */
    pgi__light_diff r = {0};
    switch (L->type) {
    case PGI__LIGHT_POINT:
        r.axis = v3(0.f, 0.f, 1.f);
        r.scale = sqrtf(1.f / pl);
        break;
    case PGI__LIGHT_SPOT: {
        float omega = 2.f * PGI__PI * (1.f - L->cos_cutoff);
        r.axis = v3_load(L->dir);
        r.scale = sqrtf(omega / (4.f * PGI__PI * pl));
        break;
    }
    case PGI__LIGHT_SUN:
    case PGI__LIGHT_ENV:
        /* parallel light over a disk of radius R: positional differentials only (the sky: its
         * photons' directions spread, but each enters as a sun's would) */
        r.parallel = 1;
        r.scale = sqrtf(PGI__PI * sun_radius * sun_radius / (4.f * PGI__PI * pl));
        break;
    case PGI__LIGHT_AREA:
    default: {
        /* cosine-weighted directions: solid angle per photon pi / (n pl cos theta); then the
         * origin is offset back (eq. 13) so that the footprint at the light is its area share */
        r.axis = v3_load(L->normal);
        float ct = fmaxf(v3_dot(d, r.axis), 0.05f);
        r.scale = sqrtf(1.f / (4.f * pl * ct));
        r.offset = 1;
        r.area = L->area / (4.f * PGI__PI * pl); /* |dp1 x dp2| with Delta^2 |dp1 x dp2| = area / (n pl) */
        break;
    }
    }
    return r;
}

void pgi__light_set_power(pgi__light *l, float diag) {
    float k = 0.f;
    switch (l->type) {
    case PGI__LIGHT_POINT: k = 4.f * PGI__PI; break;
    case PGI__LIGHT_SPOT: k = 2.f * PGI__PI * (1.f - l->cos_cutoff); break;
    case PGI__LIGHT_SUN: {
        float R = 0.5f * diag; /* photons leave a disk covering the scene's bounding sphere */
        k = PGI__PI * R * R;
        break;
    }
    case PGI__LIGHT_AREA: k = PGI__PI * l->area; break;
    case PGI__LIGHT_ENV: break;
    }
    for (int c = 0; c < 3; c++) l->power[c] = l->color[c] * k;
}

size_t pgi__light_area_count(const pgi_scene *s) {
    size_t n = 0;
    for (size_t l = 0; l < s->nlights; l++) n += s->lights[l].type == PGI__LIGHT_AREA;
    return n;
}

size_t pgi__light_area_cdf(const pgi_scene *s, float *cdf, size_t *idx) {
    double tot = 0.0;
    size_t n = 0;
    for (size_t l = 0; l < s->nlights; l++) {
        if (s->lights[l].type != PGI__LIGHT_AREA) continue;
        tot += v3_lum(v3_load(s->lights[l].power));
        cdf[n] = (float)tot;
        if (idx) idx[n] = l;
        n++;
    }
    if (!n) return 0;
    for (size_t k = 0; k < n; k++) cdf[k] = tot > 0.0 ? (float)(cdf[k] / tot) : (float)(k + 1) / (float)n;
    cdf[n - 1] = 1.f;
    return n;
}
