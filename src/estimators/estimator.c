/* Estimator interface: registry, lifecycle wrappers, buffers. */
#include <errno.h>
#include <stddef.h>
#include <stdio.h>

#include "estimator_internal.h"

static const pgi_estimator_vtbl *const k_estimators[] = {
    &pgi__est_brute,        &pgi__est_hashgrid,        &pgi__est_tiled,       &pgi__est_cluster,
    &pgi__est_cluster_cone, &pgi__est_cluster_trivial, &pgi__est_directional, &pgi__est_bvh,
    &pgi__est_kdtree,       &pgi__est_bounds3d,        &pgi__est_bounds25d,
};
#define N_EST (sizeof k_estimators / sizeof k_estimators[0])

struct pgi_estimator {
    const pgi_estimator_vtbl *vt;
    void *state;
    pgi_estimator_desc desc; /* resolved */
    int built;               /* the last build succeeded */
    float built_radius;
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

/* ------------------------------------------------------------ options */

static const pgi_option k_opt_kernel = {.name = "kernel",
                                        .type = PGI_OPTION_CHOICE,
                                        .offset = offsetof(pgi_estimator_desc, kernel),
                                        .choices = "constant|cone|epanechnikov",
                                        .caps = PGI_EST_CAP_KERNELS,
                                        .flags = PGI_OPTION_STRICT,
                                        .help = "density-estimation kernel (default constant)"};
static const pgi_option k_opt_subsample =
    {.name = "subsample",
     .type = PGI_OPTION_INT,
     .offset = offsetof(pgi_estimator_desc, subsample),
     .min = 1,
     .max = 64,
     .caps = PGI_EST_CAP_SUBSAMPLE,
     .flags = PGI_OPTION_STRICT,
     .help = "stochastic subsampling: about 1/N^2 of the eligible photons per pixel (1..64; default off)"};
static const pgi_option *const k_shared_options[] = {&k_opt_kernel, &k_opt_subsample, NULL};


static int has_option(const pgi_option *const *list, const pgi_option *o) {
    for (; list && *list; list++)
        if (*list == o) return 1;
    return 0;
}

int pgi_estimator_takes(const pgi_estimator_vtbl *vt, const pgi_option *o) {
    if (o->caps) return (vt->caps & o->caps) != 0 && has_option(k_shared_options, o);
    return has_option(vt->options, o);
}

#define MAX_OPTIONS 64

/* Every distinct option: the shared ones, then each estimator's own in registry order. */
static size_t all_options(const pgi_option *out[MAX_OPTIONS]) {
    size_t n = 0;
    for (const pgi_option *const *l = k_shared_options; *l; l++) out[n++] = *l;
    for (size_t e = 0; e < N_EST; e++)
        for (const pgi_option *const *l = k_estimators[e]->options; l && *l; l++) {
            size_t k = 0;
            while (k < n && out[k] != *l) k++;
            if (k == n && n < MAX_OPTIONS) out[n++] = *l;
        }
    return n;
}

size_t pgi_option_count(void) {
    const pgi_option *all[MAX_OPTIONS];
    return all_options(all);
}

const pgi_option *pgi_option_at(size_t i) {
    const pgi_option *all[MAX_OPTIONS];
    return i < all_options(all) ? all[i] : NULL;
}

const pgi_option *pgi_option_find(const char *name) {
    if (!name) return NULL;
    const pgi_option *all[MAX_OPTIONS];
    for (size_t i = 0, n = all_options(all); i < n; i++)
        if (strcmp(all[i]->name, name) == 0) return all[i];
    return NULL;
}

static int *int_field(const pgi_option *o, pgi_estimator_desc *d) { return (int *)(void *)((char *)d + o->offset); }
static float *float_field(const pgi_option *o, pgi_estimator_desc *d) {
    return (float *)(void *)((char *)d + o->offset);
}

/* The k-th choice of "a|b|c" into buf; 0 if there is none. */
static int choice_at(const char *choices, int k, char *buf, size_t size) {
    const char *p = choices;
    for (int i = 0; i < k && p; i++) p = (p = strchr(p, '|')) ? p + 1 : NULL;
    if (!p || k < 0) return 0;
    const char *e = strchr(p, '|');
    size_t n = e ? (size_t)(e - p) : strlen(p);
    snprintf(buf, size, "%.*s", (int)n, p);
    return 1;
}

/* "an even number in 4..64", "a number in 0..16", "one of constant|cone": what a user may write. */
static void describe(const pgi_option *o, char *buf, size_t size) {
    if (o->type == PGI_OPTION_CHOICE) {
        snprintf(buf, size, "one of %s", o->choices);
        return;
    }
    if (o->type == PGI_OPTION_FLOAT) {
        if (o->max > 0) snprintf(buf, size, "a number above %g and at most %g", o->min, o->max);
        else snprintf(buf, size, "a finite number above %g", o->min);
        return;
    }
    if (o->step > 2) snprintf(buf, size, "a multiple of %d in %g..%g", o->step, o->min, o->max);
    else snprintf(buf, size, "%s in %g..%g", o->step == 2 ? "an even number" : "a number", o->min, o->max);
}

/* FLOAT options: finite, above min, at most max (max 0: no upper bound). */
static int float_in_range(const pgi_option *o, float f) {
    return isfinite(f) && f > (float)o->min && !(o->max > 0 && f > (float)o->max);
}

static int int_in_range(const pgi_option *o, long long v) {
    return v >= (long long)o->min && v <= (long long)o->max && (o->step <= 1 || v % o->step == 0);
}

pgi_status pgi_estimator_desc_set(pgi_estimator_desc *d, const char *name, const char *value) {
    const pgi_option *o = pgi_option_find(name);
    if (!o) return pgi__fail(PGI_ERR_INVALID_ARG, "unknown estimator option '--%s'", name ? name : "(null)");
    char what[96];
    describe(o, what, sizeof what);
    const char *v = value ? value : "";
    if (o->type == PGI_OPTION_CHOICE) {
        char c[64];
        for (int k = 0; choice_at(o->choices, k, c, sizeof c); k++)
            if (strcmp(c, v) == 0) {
                *int_field(o, d) = k;
                return PGI_OK;
            }
        return pgi__fail(PGI_ERR_INVALID_ARG, "--%s must be %s, got '%s'", o->name, what, v);
    }
    char *end;
    errno = 0;
    if (o->type == PGI_OPTION_FLOAT) {
        float f = strtof(v, &end);
        if (errno || end == v || *end || !float_in_range(o, f))
            return pgi__fail(PGI_ERR_INVALID_ARG, "--%s needs %s, got '%s'", o->name, what, v);
        *float_field(o, d) = f;
        return PGI_OK;
    }
    long long n = strtoll(v, &end, 10);
    if (errno || end == v || *end || !int_in_range(o, n))
        return pgi__fail(PGI_ERR_INVALID_ARG, "--%s needs %s, got '%s'", o->name, what, v);
    *int_field(o, d) = n == 0 ? o->zero : (int)n;
    return PGI_OK;
}

void pgi_option_format(const pgi_option *o, const pgi_estimator_desc *d, char *buf, size_t size) {
    pgi_estimator_desc c = *d;
    if (o->type == PGI_OPTION_FLOAT) {
        snprintf(buf, size, "%g", (double)*float_field(o, &c));
        return;
    }
    int v = *int_field(o, &c);
    if (o->type == PGI_OPTION_CHOICE) {
        if (!choice_at(o->choices, v, buf, size)) snprintf(buf, size, "%d", v);
        return;
    }
    snprintf(buf, size, "%d", v == o->zero && o->zero != 0 ? 0 : v);
}

void pgi_option_takers(const pgi_option *o, char *buf, size_t size) {
    if (!size) return;
    buf[0] = 0;
    for (size_t i = 0; i < N_EST; i++)
        if (pgi_estimator_takes(k_estimators[i], o)) pgi__list_append(buf, size, k_estimators[i]->name);
}

/* The value a zero field of row `o` resolves to for `vt`: its own default, else the row's. */
static int option_default(const pgi_estimator_vtbl *vt, const pgi_option *o) {
    for (const pgi_option_default *d = vt->defaults; d && d->option; d++)
        if (d->option == o) return d->value;
    return o->def;
}

pgi_status pgi_estimator_desc_resolve(const pgi_estimator_vtbl *vt, const pgi_estimator_desc *in,
                                      pgi_estimator_desc *out) {
    pgi_estimator_desc r = *in;
    pgi_estimator_desc d;
    memset(&d, 0, sizeof d);
    const pgi_option *all[MAX_OPTIONS];
    for (size_t i = 0, n = all_options(all); i < n; i++) {
        const pgi_option *o = all[i];
        char what[96], names[256];
        const int takes = pgi_estimator_takes(vt, o);
        describe(o, what, sizeof what);
        /* An invalid value is an error for every estimator, also one that would ignore the option. */
        if (o->type == PGI_OPTION_FLOAT) {
            float f = *float_field(o, &r);
            if (f == 0.f) continue;
            if (!float_in_range(o, f))
                return pgi__fail(PGI_ERR_INVALID_ARG, "%s: --%s needs %s, got %g: %s", vt->name, o->name, what,
                                 (double)f, o->help);
        } else {
            int v = *int_field(o, &r);
            if (v == 0) {
                if (takes) *int_field(o, &d) = o->type == PGI_OPTION_INT ? option_default(vt, o) : 0;
                continue;
            }
            char c[64];
            if (o->type == PGI_OPTION_CHOICE ? !choice_at(o->choices, v, c, sizeof c)
                                             : !(o->zero != 0 && v == o->zero) && !int_in_range(o, v))
                return pgi__fail(PGI_ERR_INVALID_ARG, "%s: --%s needs %s, got %d: %s", vt->name, o->name, what, v,
                                 o->help);
        }
        if (!takes) {
            if (!(o->flags & PGI_OPTION_STRICT)) continue;
            if (o->caps) {
                if (o->type == PGI_OPTION_INT && *int_field(o, &r) == 1) continue; /* subsample 1 is off */
                /* Name those that do: --kernel/--subsample given without --estimator reach the default. */
                pgi_option_takers(o, names, sizeof names);
                return pgi__fail(PGI_ERR_INVALID_ARG,
                                 "estimator '%s'%s does not support --%s (%s); the estimators that do: %s", vt->name,
                                 strcmp(vt->name, PGI_DEFAULT_ESTIMATOR) ? "" : " (the default)", o->name, o->help,
                                 names);
            }
            pgi_option_takers(o, names, sizeof names);
            return pgi__fail(PGI_ERR_INVALID_ARG, "--%s is an option of %s, not of '%s'", o->name, names, vt->name);
        }
        if (o->type == PGI_OPTION_FLOAT) *float_field(o, &d) = *float_field(o, &r);
        else *int_field(o, &d) = *int_field(o, &r);
    }
    *out = d;
    return PGI_OK;
}

pgi_status pgi_estimator_create(const char *name, const pgi_estimator_desc *desc, pgi_estimator **out) {
    *out = NULL;
    const pgi_estimator_vtbl *vt = pgi_estimator_find(name);
    if (!vt) return pgi__fail_unknown_estimator(name);
    pgi_estimator_desc d;
    pgi_status st = pgi_estimator_desc_resolve(vt, desc ? desc : &(pgi_estimator_desc){0}, &d);
    if (st) return st;
    pgi_estimator *e = calloc(1, sizeof *e);
    if (!e) return pgi__fail(PGI_ERR_OOM, "out of memory creating estimator '%s'", name);
    e->vt = vt;
    e->desc = d;
    st = vt->create(&d, &e->state);
    if (st) {
        free(e);
        return st;
    }
    *out = e;
    return PGI_OK;
}

static pgi_status check_args(const pgi_estimator *e, const pgi_estimate_args *a) {
    if (!a || !a->photons || !a->samples || !a->camera)
        return pgi__fail(PGI_ERR_INVALID_ARG, "estimator arguments need photons, view samples and a camera");
    if (!(a->radius > 0.f) || !isfinite(a->radius))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: photon radius must be a positive finite number, got %g", e->vt->name,
                         (double)a->radius);
    if (a->threads < 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "threads must be 0 (all) or positive, got %d", a->threads);
    if (a->scene_area < 0.f || !isfinite(a->scene_area))
        return pgi__fail(PGI_ERR_INVALID_ARG, "scene area must be 0 (unknown) or a positive finite number, got %g",
                         (double)a->scene_area);
    if (!(a->samples->jitter >= 0.f && a->samples->jitter <= 0.5f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "view-sample jitter must be in [0, 0.5] pixels, got %g",
                         (double)a->samples->jitter);
    return PGI_OK;
}

pgi_status pgi_estimator_build(pgi_estimator *e, const pgi_estimate_args *a) {
    pgi_status st = check_args(e, a);
    if (st) return st;
    if (a->photons->radius && !(e->vt->caps & PGI_EST_CAP_PHOTON_RADIUS))
        return pgi__fail(PGI_ERR_INVALID_ARG, "estimator '%s' needs one fixed radius; it cannot use per-photon radii",
                         e->vt->name);
    if (a->photons->sax && !a->photons->radius)
        return pgi__fail(PGI_ERR_INVALID_ARG, "ellipsoid footprints need the per-photon radius array as well");
    e->built = 0;
    if ((st = e->vt->build(e->state, a))) return st;
    if (pgi__cancelled(a->cancel)) return pgi__fail_cancelled(e->vt->name); /* a build cut short */
    e->built = 1;
    e->built_radius = a->radius;
    return PGI_OK;
}

pgi_status pgi_estimator_estimate(pgi_estimator *e, const pgi_estimate_args *a) {
    pgi_status st = check_args(e, a);
    if (st) return st;
    if (!a->out_rgb) return pgi__fail(PGI_ERR_INVALID_ARG, "estimate needs an output buffer");
    if (!e->built) return pgi__fail(PGI_ERR_INVALID_ARG, "%s: estimate before a successful build", e->vt->name);
    if (a->radius != e->built_radius)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: estimate with radius %g after a build with radius %g", e->vt->name,
                         (double)a->radius, (double)e->built_radius);
    if ((st = e->vt->estimate(e->state, a))) return st;
    return pgi__cancelled(a->cancel) ? pgi__fail_cancelled(e->vt->name) : PGI_OK; /* out_rgb is partial */
}

void pgi_estimator_get_stats(const pgi_estimator *e, pgi_estimator_stats *out) {
    memset(out, 0, sizeof *out);
    e->vt->stats(e->state, out);
}

const char *pgi_estimator_name(const pgi_estimator *e) { return e->vt->name; }

void pgi_estimator_get_desc(const pgi_estimator *e, pgi_estimator_desc *out) { *out = e->desc; }

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
    for (size_t k = 0; k < sizeof v3s / sizeof v3s[0]; k++)
        ok &= (*v3s[k] = pgi__aalloc(3 * n * sizeof(float))) != NULL;
    ok &= (vs->shininess = pgi__aalloc(n * sizeof(float))) != NULL;
    ok &= (vs->ior = pgi__aalloc(n * sizeof(float))) != NULL;
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
    void *arrs[] = {vs->pos,    vs->nrm,       vs->ngeo, vs->wo,    vs->kd,   vs->ks,
                    vs->weight, vs->shininess, vs->ior,  vs->depth, vs->flags};
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
    c->tan_half_fov_y = tanf(0.5f * fov_y_deg * PGI__PI / 180.f);
    c->width = width;
    c->height = height;
    c->aspect = height > 0 ? (float)width / (float)height : 1.f;
}
