/* How a frame's photons leave the lights (docs/emission.md): the choice `--emission auto` makes,
 * in one place. Before tracing, from the scene alone: the portals when the scene has them and they
 * carry under PGI__PORTAL_AUTO_SHARE of the sun's and the sky's uniform lines (known from geometry
 * and radiance: no pilot); else the guide's uniform pilot, which steers when its predicted photons
 * in view per unit of frame cost (pgi__guide.value) reach PGI__EMISSION_AUTO_VALUE, and otherwise
 * keeps its photons (the frame is then byte-identical to uniform emission). On the GPU `auto` is
 * uniform emission (the device traces no other). */
#ifndef PGI__EMISSION_H
#define PGI__EMISSION_H

#include "photon/guide.h"
#include "photongi/photongi.h"

/* `auto` steers when the pilot predicts at least this many times uniform emission's photons in
 * view per unit of frame cost (pgi__guide_update's value). */
#define PGI__EMISSION_AUTO_VALUE 1.25

/* What a frame does before tracing. */
typedef struct pgi__emission_plan {
    int portal;          /* the sun's and the sky's photons start on the portals */
    int guide;           /* the guide runs: guided emission, or auto's pilot */
    double min_value;    /* the guide steers when its value reaches this (0: always) */
    double portal_share; /* pgi__portal_share, where it was computed (auto or portal with portals) */
} pgi__emission_plan;

/* The plan of desc d (resolved: its emission, radius policy and device) in scene s. */
void pgi__emission_plan_of(const pgi_scene *s, const pgi_render_desc *d, pgi__emission_plan *p);

/* After the trace: the emission the photons had (PGI_EMISSION_UNIFORM, _GUIDED or _PORTAL) and
 * why, a static string for the statistics. g: the guide when it ran (else NULL). */
pgi_emission pgi__emission_used(const pgi_render_desc *d, const pgi__emission_plan *p, const pgi__guide *g,
                                const char **reason);

#endif
