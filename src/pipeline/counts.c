/* Per-pixel contributing-photon counts (PGI_OUTPUT_PHOTON_COUNT) for the
 * viewer's false-colour view. The estimator interface returns radiance, not
 * counts, so the counts come from a second build + estimate of the same
 * estimator over inputs chosen so that radiance equals count / (pi r^2):
 * every photon gets flux 1 and every sample becomes Lambertian with albedo
 * pi (no specular part). The per-photon decision (pgi__gather: inside the
 * sphere, from the sample's hemisphere) is untouched, so for exact
 * estimators these are exactly the photons that contributed to the image.
 * Cost: one more build + estimate, and scratch allocated per call. */
#include <string.h>

#include "pipeline/pipeline.h"

pgi_status pgi__photon_counts(pgi_estimator *e, const pgi_estimate_args *a, float *out_rgb) {
    const pgi_photons *ph = a->photons;
    const pgi_view_samples *vs = a->samples;
    size_t np = ph->count, n = vs->count;
    float *ones = malloc((np ? np : 1) * sizeof *ones);
    float *kd = malloc(3 * n * sizeof *kd), *ks = calloc(3 * n, sizeof *ks);
    uint8_t *flags = malloc(n ? n : 1);
    pgi_status st = PGI_OK;
    if (!ones || !kd || !ks || !flags) {
        st = pgi__fail(PGI_ERR_OOM, "out of memory for photon counts (%zu photons, %zu samples)", np, n);
        goto done;
    }
    for (size_t i = 0; i < np; i++) ones[i] = 1.f;
    for (size_t i = 0; i < 3 * n; i++) kd[i] = PGI__PI;
    for (size_t i = 0; i < n; i++) flags[i] = vs->flags[i] | PGI_VS_LAMBERT;
    pgi_photons uph = *ph;
    uph.fr = uph.fg = uph.fb = ones;
    pgi_view_samples uvs = *vs;
    uvs.kd = kd;
    uvs.ks = ks;
    uvs.flags = flags;
    pgi_estimate_args ua = *a;
    ua.photons = &uph;
    ua.samples = &uvs;
    ua.out_rgb = out_rgb;
    if ((st = pgi_estimator_build(e, &ua))) goto done;
    if ((st = pgi_estimator_estimate(e, &ua))) goto done;
    const float area = PGI__PI * a->radius * a->radius;
    for (size_t i = 0; i < n; i++) {
        float c = rintf(out_rgb[3 * i] * area);
        out_rgb[3 * i] = out_rgb[3 * i + 1] = out_rgb[3 * i + 2] = c > 0.f ? c : 0.f;
    }
done:
    free(ones);
    free(kd);
    free(ks);
    free(flags);
    return st;
}
