/* brute: every photon for every view sample. O(N * pixels); the oracle that
 * every exact estimator is tested against (tests/test_estimators.c). */
#include "estimator_internal.h"

typedef struct {
    pgi__est_common c;
} brute_state;
_Static_assert(offsetof(brute_state, c) == 0, "pgi__est_default_stats reads the state as its pgi__est_common");

static pgi_status brute_create(const pgi_estimator_desc *d, void **state) {
    brute_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->c.desc = *d;
    *state = s;
    return PGI_OK;
}

static pgi_status brute_build(void *state, const pgi_estimate_args *a) {
    brute_state *s = state;
    pgi__est_frame(&s->c, a);
    memset(&s->c.st, 0, sizeof s->c.st);
    pgi__stats_pass(&s->c.st, "build", 0.0);
    return PGI_OK;
}

/* Every photon for every view sample: with the constant kernel at a fixed radius (pgi__gather);
 * beyond that, non-constant kernels (pgi__gather_k, fixed radius), or per-photon footprints
 * (spheres of radius[j], or ellipsoids when sax is set; constant kernel, weight 1/(pi r_j^2)) for
 * every estimator with PGI_EST_CAP_PHOTON_RADIUS. */
static pgi_status brute_estimate(void *state, const pgi_estimate_args *a) {
    brute_state *s = state;
    pgi__est_frame(&s->c, a);
    double t0 = pgi__now_ms();
    const pgi_photons *ph = a->photons;
    const pgi_view_samples *vs = a->samples;
    const pgi_kernel kern = s->c.desc.kernel;
    const int footprints = ph->radius != NULL, ell = ph->sax != NULL;
    const int plain = !footprints && kern == PGI_KERNEL_CONSTANT;
    if (footprints && kern != PGI_KERNEL_CONSTANT)
        return pgi__fail(PGI_ERR_INVALID_ARG, "brute: per-photon footprints use the constant kernel only");
    const float r2 = s->c.radius * s->c.radius;
    const size_t n = ph->count;
    uint64_t reads = 0, contrib = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : reads, contrib) num_threads(s->c.threads)
    for (long long ii = 0; ii < (long long)vs->count; ii++) {
        pgi__vs v;
        float *out = pgi__est_sample(&s->c, a, ii, &v);
        if (!out) continue;
        pgi__acc acc = {0};
        if (plain) {
            for (size_t j = 0; j < n; j++)
                pgi__gather(&v, r2, ph->px[j], ph->py[j], ph->pz[j], ph->dx[j], ph->dy[j], ph->dz[j], ph->fr[j],
                            ph->fg[j], ph->fb[j], &acc);
            pgi__acc_finish(&v, &acc, r2, out);
        } else if (!footprints) {
            for (size_t j = 0; j < n; j++)
                pgi__gather_k(&v, r2, kern, ph->px[j], ph->py[j], ph->pz[j], ph->dx[j], ph->dy[j], ph->dz[j], ph->fr[j],
                              ph->fg[j], ph->fb[j], &acc);
            pgi__acc_finish_k(&v, &acc, r2, kern, 1.f, out);
        } else {
            for (size_t j = 0; j < n; j++) {
                float r = ph->radius[j], w = pgi__footprint_weight(r);
                if (ell) {
                    float inv[9];
                    pgi__photon_ellipsoid_inverse(ph, j, inv);
                    pgi__gather_ellipsoid(&v, inv, ph->px[j], ph->py[j], ph->pz[j], ph->dx[j], ph->dy[j], ph->dz[j],
                                          ph->fr[j] * w, ph->fg[j] * w, ph->fb[j] * w, &acc);
                } else {
                    pgi__gather(&v, r * r, ph->px[j], ph->py[j], ph->pz[j], ph->dx[j], ph->dy[j], ph->dz[j],
                                ph->fr[j] * w, ph->fg[j] * w, ph->fb[j] * w, &acc);
                }
            }
            pgi__acc_finish_w(&v, &acc, 1.f, out);
        }
        reads += n;
        contrib += acc.contributing;
    }
    pgi__stats_estimated(&s->c.st, t0, reads, contrib);
    return PGI_OK;
}

static void brute_destroy(void *state) { free(state); }

/* memory budget: it holds nothing of its own (1: not the default of an estimator that gives none) */
const pgi_estimator_vtbl pgi__est_brute =
    PGI__EST_TABLE("brute", "every photon for every view sample (the test oracle)", brute_create, brute_build,
                   brute_estimate, brute_destroy, .exact = 1, .oracle = 1,
                   .caps = PGI_EST_CAP_PHOTON_RADIUS | PGI_EST_CAP_KERNELS, .bytes_per_photon = 1);
