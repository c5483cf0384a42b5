/* Lights (light.h): the parts that are not per path. */
#include "light.h"

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
