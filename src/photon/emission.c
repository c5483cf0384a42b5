/* The choice of photon emission, `--emission auto` (emission.h, docs/emission.md). */
#include "emission.h"

#include "scene/portal.h"

void pgi__emission_plan_of(const pgi_scene *s, const pgi_render_desc *d, pgi__emission_plan *p) {
    *p = (pgi__emission_plan){0};
    if (d->device == PGI_DEVICE_VULKAN) return; /* the device traces uniform emission only */
    const int may_portal = d->emission == PGI_EMISSION_PORTAL || d->emission == PGI_EMISSION_AUTO;
    if (s->nportals && may_portal) p->portal_share = pgi__portal_share(s);
    /* auto: the portals where uniform emission would trace over twice the sun's and the sky's paths
       for the light that comes in through them (the footprint policies size a photon from the
       sun's and the sky's disk, so not with those) */
    p->portal = d->emission == PGI_EMISSION_PORTAL ||
                (d->emission == PGI_EMISSION_AUTO && s->nportals && d->radius_policy == PGI_RADIUS_FIXED &&
                 p->portal_share > 0.0 && p->portal_share < PGI__PORTAL_AUTO_SHARE);
    p->guide = !p->portal && (d->emission == PGI_EMISSION_GUIDED || d->emission == PGI_EMISSION_AUTO);
    p->min_value = d->emission == PGI_EMISSION_AUTO ? PGI__EMISSION_AUTO_VALUE : 0.0;
}

pgi_emission pgi__emission_used(const pgi_render_desc *d, const pgi__emission_plan *p, const pgi__guide *g,
                                const char **reason) {
    const int asked = d->emission != PGI_EMISSION_AUTO;
    pgi_emission used = PGI_EMISSION_UNIFORM;
    if (d->device == PGI_DEVICE_VULKAN) *reason = "the GPU traces uniform emission only";
    else if (p->portal) {
        used = PGI_EMISSION_PORTAL;
        *reason = "the portals carry under half of the sun's and the sky's uniform lines";
    } else if (!p->guide) *reason = "uniform";
    else if (g && g->on) {
        used = PGI_EMISSION_GUIDED;
        *reason = "the pilot predicts at least 1.25x the photons in view per unit of frame cost";
    } else if (g && g->value == 1.0 && g->gain == 1.0)
        *reason = "the pilot found too little to steer by (under 32 photons in view, or all of them in view)";
    else *reason = "the pilot predicts under 1.25x the photons in view per unit of frame cost";
    if (asked && (used != PGI_EMISSION_UNIFORM || d->emission == PGI_EMISSION_UNIFORM)) *reason = "asked for";
    return used;
}
