/* Estimator interface: registry, lifecycle wrappers, buffers. */
#include <stdio.h>

#include "estimator_internal.h"

static const pgi_estimator_vtbl *const k_estimators[] = {
    &pgi__est_brute,
    &pgi__est_hashgrid,
    &pgi__est_tiled,
    &pgi__est_cluster,
    &pgi__est_cluster_cone,
    &pgi__est_cluster_trivial,
    &pgi__est_directional,
    &pgi__est_bvh,
    &pgi__est_kdtree,
    &pgi__est_bounds3d,
    &pgi__est_bounds25d,
};
#define N_EST (sizeof k_estimators / sizeof k_estimators[0])

struct pgi_estimator {
    const pgi_estimator_vtbl *vt;
    void *state;
};

size_t pgi_estimator_count(void) { return N_EST; }

pgi_status pgi__fail_unknown_estimator(const char *name) {
    char names[256] = "";
    for (size_t i = 0; i < N_EST; i++) pgi__list_append(names, sizeof names, k_estimators[i]->name);
    return pgi__fail(PGI_ERR_INVALID_ARG, "unknown estimator '%s' (registered: %s)", name ? name : "(null)", names);
}

const pgi_estimator_vtbl *pgi_estimator_at(size_t i) { return i < N_EST ? k_estimators[i] : NULL; }

const pgi_estimator_vtbl *pgi_estimator_find(const char *name) {
    if (!name) return NULL;
    for (size_t i = 0; i < N_EST; i++)
        if (strcmp(k_estimators[i]->name, name) == 0) return k_estimators[i];
    return NULL;
}

pgi_status pgi_estimator_create(const char *name, const pgi_estimator_desc *desc, pgi_estimator **out) {
    *out = NULL;
    const pgi_estimator_vtbl *vt = pgi_estimator_find(name);
    if (!vt) return pgi__fail_unknown_estimator(name);
    if (!(desc->radius > 0.f) || !isfinite(desc->radius))
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon radius must be a positive finite number, got %g",
                         (double)desc->radius);
    if (desc->tile_size < 0 || desc->tile_size > 4096)
        return pgi__fail(PGI_ERR_INVALID_ARG, "tile size %d is out of range (1..4096)", desc->tile_size);
    /* Below r/64 a query would visit over 2 million cells: reject rather than hang. */
    if (desc->cell_size < 0.f || !isfinite(desc->cell_size) ||
        (desc->cell_size > 0.f && desc->cell_size < desc->radius / 64.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "cell size must be 0 (default: 2r) or at least r/64 = %g, got %g",
                         (double)(desc->radius / 64.f), (double)desc->cell_size);
    if ((unsigned)desc->kernel >= PGI_KERNEL_COUNT_)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown kernel %d", (int)desc->kernel);
    if (desc->kernel != PGI_KERNEL_CONSTANT && !(vt->caps & PGI_EST_CAP_KERNELS))
        return pgi__fail(PGI_ERR_INVALID_ARG, "estimator '%s' supports only the constant kernel", name);
    if (desc->subsample < 0 || desc->subsample > 64)
        return pgi__fail(PGI_ERR_INVALID_ARG, "subsampling factor %d is out of range (0..64)", desc->subsample);
    if (desc->subsample > 1 && !(vt->caps & PGI_EST_CAP_SUBSAMPLE))
        return pgi__fail(PGI_ERR_INVALID_ARG, "estimator '%s' does not support stochastic subsampling", name);
    if (desc->bvh_build != PGI_BVH_LINEAR && desc->bvh_build != PGI_BVH_VVH)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown BVH build %d (0 linear, 1 vvh)", desc->bvh_build);
    if (desc->leaf_size < 0 || desc->leaf_size > 65536)
        return pgi__fail(PGI_ERR_INVALID_ARG, "BVH leaf size %d is out of range (0 = T_auto, 1..65536)", desc->leaf_size);
    if (desc->scene_area < 0.f || !isfinite(desc->scene_area))
        return pgi__fail(PGI_ERR_INVALID_ARG, "scene area must be 0 (unknown) or a positive finite number, got %g",
                         (double)desc->scene_area);
    if (desc->knn < 0 || desc->knn > 4096)
        return pgi__fail(PGI_ERR_INVALID_ARG, "k-NN count %d is out of range (0 = range mode, 1..4096)", desc->knn);
    if (desc->knn > 0 && strcmp(vt->name, "kdtree") != 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "k-NN mode (knn %d) needs the kdtree estimator, not '%s'", desc->knn,
                         name);
    if (desc->knn > 0 && desc->subsample > 1)
        return pgi__fail(PGI_ERR_INVALID_ARG, "kdtree: stochastic subsampling works in range mode only (knn 0)");
    if (desc->polygon_vertices != 0 &&
        (desc->polygon_vertices < 4 || desc->polygon_vertices > 64 || desc->polygon_vertices % 2))
        return pgi__fail(PGI_ERR_INVALID_ARG, "polygon vertices must be an even number in 4..64, got %d",
                         desc->polygon_vertices);
    pgi_estimator *e = calloc(1, sizeof *e);
    if (!e) return pgi__fail(PGI_ERR_OOM, "out of memory creating estimator '%s'", name);
    e->vt = vt;
    pgi_status st = vt->create(desc, &e->state);
    if (st) {
        free(e);
        return st;
    }
    *out = e;
    return PGI_OK;
}

static pgi_status check_args(const pgi_estimate_args *a) {
    if (!a || !a->photons || !a->samples || !a->camera)
        return pgi__fail(PGI_ERR_INVALID_ARG, "estimator arguments need photons, view samples and a camera");
    return PGI_OK;
}

pgi_status pgi_estimator_build(pgi_estimator *e, const pgi_estimate_args *a) {
    pgi_status st = check_args(a);
    if (st) return st;
    if (a->photons->radius && !(e->vt->caps & PGI_EST_CAP_PHOTON_RADIUS))
        return pgi__fail(PGI_ERR_INVALID_ARG, "estimator '%s' needs one fixed radius; it cannot use per-photon radii",
                         e->vt->name);
    if (a->photons->sax && !a->photons->radius)
        return pgi__fail(PGI_ERR_INVALID_ARG, "ellipsoid footprints need the per-photon radius array as well");
    return e->vt->build(e->state, a);
}

pgi_status pgi_estimator_estimate(pgi_estimator *e, const pgi_estimate_args *a) {
    pgi_status st = check_args(a);
    if (st) return st;
    if (!a->out_rgb) return pgi__fail(PGI_ERR_INVALID_ARG, "estimate needs an output buffer");
    return e->vt->estimate(e->state, a);
}

void pgi_estimator_get_stats(const pgi_estimator *e, pgi_estimator_stats *out) {
    memset(out, 0, sizeof *out);
    e->vt->stats(e->state, out);
}

const char *pgi_estimator_name(const pgi_estimator *e) { return e->vt->name; }

void pgi_estimator_destroy(pgi_estimator *e) {
    if (!e) return;
    e->vt->destroy(e->state);
    free(e);
}

pgi_status pgi__ensure(void **p, size_t *cap, size_t n, size_t size) {
    if (n <= *cap && *p) return PGI_OK;
    size_t want = n + n / 4 + 16;
    void *q = pgi__aalloc(want * size);
    if (!q) return pgi__fail(PGI_ERR_OOM, "out of memory (%zu bytes)", want * size);
    pgi__afree(*p);
    *p = q;
    *cap = want;
    return PGI_OK;
}

/* ------------------------------------------------------------ buffers */

pgi_status pgi_photons_alloc(pgi_photons *ph, size_t capacity) {
    memset(ph, 0, sizeof *ph);
    size_t n = capacity ? capacity : 1;
    float **arrs[] = {&ph->px, &ph->py, &ph->pz, &ph->dx, &ph->dy, &ph->dz,
                      &ph->fr, &ph->fg, &ph->fb, &ph->nx, &ph->ny, &ph->nz};
    for (size_t k = 0; k < sizeof arrs / sizeof arrs[0]; k++) {
        *arrs[k] = pgi__aalloc(n * sizeof(float));
        if (!*arrs[k]) {
            pgi_photons_free(ph);
            return pgi__fail(PGI_ERR_OOM, "out of memory for %zu photons", capacity);
        }
    }
    ph->capacity = capacity;
    return PGI_OK;
}

void pgi_photons_free(pgi_photons *ph) {
    float *arrs[] = {ph->px, ph->py, ph->pz, ph->dx, ph->dy, ph->dz, ph->fr, ph->fg, ph->fb, ph->nx, ph->ny, ph->nz};
    for (size_t k = 0; k < sizeof arrs / sizeof arrs[0]; k++) pgi__afree(arrs[k]);
    memset(ph, 0, sizeof *ph);
}

pgi_status pgi_view_samples_alloc(pgi_view_samples *vs, int width, int height) {
    memset(vs, 0, sizeof *vs);
    if (width <= 0 || height <= 0) return pgi__fail(PGI_ERR_INVALID_ARG, "view samples need a positive size");
    size_t n = (size_t)width * (size_t)height;
    float **v3s[] = {&vs->pos, &vs->nrm, &vs->ngeo, &vs->wo, &vs->kd, &vs->ks, &vs->weight};
    int ok = 1;
    for (size_t k = 0; k < sizeof v3s / sizeof v3s[0]; k++) ok &= (*v3s[k] = pgi__aalloc(3 * n * sizeof(float))) != NULL;
    ok &= (vs->shininess = pgi__aalloc(n * sizeof(float))) != NULL;
    ok &= (vs->depth = pgi__aalloc(n * sizeof(float))) != NULL;
    ok &= (vs->flags = pgi__aalloc(n)) != NULL;
    if (!ok) {
        pgi_view_samples_free(vs);
        return pgi__fail(PGI_ERR_OOM, "out of memory for %dx%d view samples", width, height);
    }
    memset(vs->flags, 0, n);
    vs->width = width;
    vs->height = height;
    vs->count = n;
    return PGI_OK;
}

void pgi_view_samples_free(pgi_view_samples *vs) {
    void *arrs[] = {vs->pos, vs->nrm, vs->ngeo, vs->wo, vs->kd, vs->ks, vs->weight, vs->shininess, vs->depth, vs->flags};
    for (size_t k = 0; k < sizeof arrs / sizeof arrs[0]; k++) pgi__afree(arrs[k]);
    memset(vs, 0, sizeof *vs);
}

void pgi_camera_look_at(pgi_camera *c, const float eye[3], const float look_at[3], const float up[3], float fov_y_deg,
                        int width, int height) {
    pgi__v3 e = v3_load(eye), f = v3_norm(v3_sub(v3_load(look_at), e));
    pgi__v3 r = v3_norm(v3_cross(f, v3_load(up)));
    pgi__v3 u = v3_cross(r, f);
    v3_store(c->eye, e);
    v3_store(c->forward, f);
    v3_store(c->right, r);
    v3_store(c->up, u);
    c->tan_half_fov_y = tanf(0.5f * fov_y_deg * PGI_PI / 180.f);
    c->width = width;
    c->height = height;
    c->aspect = height > 0 ? (float)width / (float)height : 1.f;
}
