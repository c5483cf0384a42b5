/* The render settings of `photongi render` (and of the Python binding, python/photongi), parsed
 * from "--name value" into a pgi_render_desc, and the checks a frame's settings get before any
 * file is read. Header only (static inline); the callers report the errors themselves. */
#ifndef PGI__APPS_RENDER_OPTIONS_H
#define PGI__APPS_RENDER_OPTIONS_H

#include <inttypes.h>
#include <stdio.h>
#include <string.h>

#include "device.h"
#include "options.h"
#include "parse.h"
#include "photongi/photongi.h"

/* Settings that are not fields of pgi_render_desc. */
typedef struct app_render_extra {
    long long progressive; /* --progressive N: frames averaged (1: one frame) */
    float exposure;        /* --exposure (0: the scene's, else 1) */
    float time;            /* --time, seconds */
    pgi_specular specular; /* --specular */
    const char *camera;    /* --camera NAME: a camera name, found once the scene is loaded (app_render_camera);
                              NULL: --camera I (pgi_render_desc.camera) or none */
} app_render_extra;

#define APP_RENDER_EXTRA_INIT                                                                                          \
    { 1, 0.f, 0.f, PGI_SPECULAR_DEFAULT, NULL }

/* Parses flag `a` ("--photons") with value `v` into d and x: 1 handled, 0 not a render setting,
 * -1 a bad value (message in err). Estimator options ("--cluster-tile") are handled too (g may
 * be NULL). `--estimator` keeps the pointer v. */
static inline int app_render_option(const char *a, const char *v, pgi_render_desc *d, app_render_extra *x,
                                    app_given_options *g, char *err, size_t size) {
    long long n;
#define APP_FAIL_(...) return (snprintf(err, size, __VA_ARGS__), -1)
    int eo = app_estimator_option(NULL, a, v, &d->est, g);
    if (eo < 0) APP_FAIL_("%s", pgi_last_error());
    if (eo > 0) return 1;
    if (strcmp(a, "--estimator") == 0) {
        if (!*v) APP_FAIL_("%s", "--estimator needs a name ('photongi estimators' lists them)");
        d->estimator = v;
    } else if (strcmp(a, "--photons") == 0) {
        if (!parse_whole(v, 1, PGI_MAX_PHOTONS, &n))
            APP_FAIL_("--photons needs a whole number in 1..%u, got '%s'", PGI_MAX_PHOTONS, v);
        d->photons = (uint32_t)n;
    } else if (strcmp(a, "--radius") == 0) {
        if (strcmp(v, "auto") == 0) d->radius = PGI_RADIUS_AUTO;
        else if (!parse_pos_float(v, &d->radius) ||
                 !(d->radius >= (float)PGI_MIN_RADIUS && d->radius <= PGI_MAX_RADIUS))
            APP_FAIL_("--radius needs a number in %g..%g (scene units) or auto, got '%s'", (double)PGI_MIN_RADIUS,
                      (double)PGI_MAX_RADIUS, v);
    } else if (strcmp(a, "--size") == 0) {
        if (!parse_size(v, PGI_MAX_IMAGE_SIDE, PGI_MAX_IMAGE_PIXELS, &d->width, &d->height))
            APP_FAIL_("--size needs WIDTHxHEIGHT, e.g. 1280x720, each side in 1..%d and at most %u pixels, got '%s'",
                      PGI_MAX_IMAGE_SIDE, PGI_MAX_IMAGE_PIXELS, v);
    } else if (strcmp(a, "--bounces") == 0) {
        if (!parse_whole(v, 1, 64, &n)) APP_FAIL_("--bounces needs a whole number in 1..64, got '%s'", v);
        d->bounces = (int)n;
    } else if (strcmp(a, "--seed") == 0) {
        if (!parse_u64(v, &d->seed))
            APP_FAIL_("--seed needs a whole number in 0..%" PRIu64 ", got '%s'", UINT64_MAX, v);
    } else if (strcmp(a, "--threads") == 0) {
        if (!parse_whole(v, 1, 1024, &n)) APP_FAIL_("--threads needs a whole number in 1..1024, got '%s'", v);
        d->threads = (int)n;
    } else if (strcmp(a, "--camera") == 0) {
        if (*v >= '0' && *v <= '9') {
            if (!parse_whole(v, 0, 1000000, &n))
                APP_FAIL_("--camera needs a camera name or index (a whole number from 0), got '%s'", v);
            d->camera = (int)n;
            x->camera = NULL;
        } else if (*v) x->camera = v;
        else APP_FAIL_("%s", "--camera needs a camera name or index (a whole number from 0)");
    } else if (strcmp(a, "--direct-samples") == 0) {
        if (!parse_whole(v, 1, 4096, &n)) APP_FAIL_("--direct-samples needs a whole number in 1..4096, got '%s'", v);
        d->direct_samples = (int)n;
    } else if (strcmp(a, "--exposure") == 0) {
        if (!parse_pos_float(v, &x->exposure)) APP_FAIL_("--exposure needs a positive number, got '%s'", v);
    } else if (strcmp(a, "--output") == 0) {
        if (strcmp(v, "all") == 0) d->output = PGI_OUTPUT_ALL;
        else if (strcmp(v, "direct") == 0) d->output = PGI_OUTPUT_DIRECT;
        else if (strcmp(v, "indirect") == 0) d->output = PGI_OUTPUT_INDIRECT;
        else if (strcmp(v, "counts") == 0) d->output = PGI_OUTPUT_PHOTON_COUNT;
        else APP_FAIL_("--output must be all, direct, indirect or counts, got '%s'", v);
    } else if (strcmp(a, "--progressive") == 0) {
        if (!parse_whole(v, 1, PGI_MAX_PROGRESSIVE_FRAMES, &x->progressive))
            APP_FAIL_("--progressive needs a frame count, a whole number in 1..%d, got '%s'",
                      PGI_MAX_PROGRESSIVE_FRAMES, v);
    } else if (strcmp(a, "--device") == 0) {
        if (!app_parse_device(v, d, err, size)) return -1;
    } else if (strcmp(a, "--specular") == 0) {
        if (!parse_specular(v, &x->specular)) APP_FAIL_("--specular must be ggx or phong, got '%s'", v);
    } else if (strcmp(a, "--time") == 0) {
        if (!parse_finite_float(v, &x->time)) APP_FAIL_("--time needs a number of seconds, got '%s'", v);
    } else if (strcmp(a, "--max-memory") == 0) {
        if (!parse_bytes(v, &d->max_memory))
            APP_FAIL_("--max-memory needs a size (bytes, or with K, M, G, T: 4G, 512M) or none, got '%s'", v);
    } else if (strcmp(a, "--radius-policy") == 0) {
        if (strcmp(v, "fixed") == 0) d->radius_policy = PGI_RADIUS_FIXED;
        else if (strcmp(v, "path") == 0) d->radius_policy = PGI_RADIUS_PATH;
        else if (strcmp(v, "differentials") == 0) d->radius_policy = PGI_RADIUS_DIFFERENTIALS;
        else APP_FAIL_("--radius-policy must be fixed, path or differentials, got '%s'", v);
    } else if (strcmp(a, "--r-min") == 0 || strcmp(a, "--r-max") == 0 || strcmp(a, "--smoothing") == 0) {
        float f;
        if (!parse_pos_float(v, &f)) APP_FAIL_("%s needs a positive number, got '%s'", a, v);
        if (a[2] == 'r' && !(f >= (float)PGI_MIN_RADIUS && f <= PGI_MAX_RADIUS))
            APP_FAIL_("%s needs a number in %g..%g (scene units), got '%s'", a, (double)PGI_MIN_RADIUS,
                      (double)PGI_MAX_RADIUS, v);
        if (a[2] == 's') d->smoothing = f;
        else if (strcmp(a, "--r-min") == 0) d->r_min = f;
        else d->r_max = f;
    } else if (strcmp(a, "--jitter") == 0) {
        if (strcmp(v, "auto") == 0) d->jitter = PGI_JITTER_AUTO;
        else if (strcmp(v, "on") == 0) d->jitter = PGI_JITTER_ON;
        else if (strcmp(v, "off") == 0) d->jitter = PGI_JITTER_OFF;
        else APP_FAIL_("--jitter must be auto, on or off, got '%s'", v);
    } else if (strcmp(a, "--texture-filter") == 0) {
        if (strcmp(v, "auto") == 0) d->texture_filter = PGI_TEXTURE_FILTER_AUTO;
        else if (strcmp(v, "on") == 0) d->texture_filter = PGI_TEXTURE_FILTER_ON;
        else if (strcmp(v, "off") == 0) d->texture_filter = PGI_TEXTURE_FILTER_OFF;
        else APP_FAIL_("--texture-filter must be auto, on or off, got '%s'", v);
    } else if (strcmp(a, "--store") == 0) {
        if (!app_parse_store(v, &d->store)) APP_FAIL_("--store must be all or view, got '%s'", v);
    } else if (strcmp(a, "--emission") == 0) {
        if (!app_parse_emission(v, &d->emission))
            APP_FAIL_("--emission must be uniform, guided, auto or portal, got '%s'", v);
    } else if (strcmp(a, "--filter") == 0) {
        if (!parse_whole(v, 0, 16, &n))
            APP_FAIL_("--filter needs a radius in pixels, a whole number in 0..16, got '%s'", v);
        d->filter = (int)n;
    } else return 0;
    return 1;
}

/* The camera of `--camera` in the loaded scene: d->camera set from x->camera (a name) or checked (an
 * index). 1 fine; 0 no such camera (message, listing the scene's cameras, in err). */
static inline int app_render_camera(const pgi_scene *scene, pgi_render_desc *d, const app_render_extra *x, char *err,
                                    size_t size) {
    char idx[24];
    snprintf(idx, sizeof idx, "%d", d->camera);
    size_t i;
    if (pgi_scene_find_camera(scene, x->camera ? x->camera : idx, &i) != PGI_OK)
        return (snprintf(err, size, "--camera %s: %s", x->camera ? x->camera : idx, pgi_last_error()), 0);
    d->camera = (int)i;
    return 1;
}

/* The settings' own consistency, before any file is read: 1 fine; 0 a usage error, -1 a failure
 * of this build or machine (no GPU version, no Vulkan), with the message in err. */
static inline int app_render_check(const pgi_render_desc *d, const app_render_extra *x, char *err, size_t size) {
    const pgi_estimator_vtbl *vt = pgi_estimator_find(d->estimator ? d->estimator : PGI_DEFAULT_ESTIMATOR);
    if (!vt) {
        int o = snprintf(err, size, "unknown estimator '%s'; registered:", d->estimator);
        for (size_t i = 0; i < pgi_estimator_count() && o > 0 && (size_t)o < size; i++)
            o += snprintf(err + o, size - (size_t)o, " %s", pgi_estimator_at(i)->name);
        return 0;
    }
    pgi_estimator_desc resolved;
    if (pgi_estimator_desc_resolve(vt, &d->est, &resolved) != PGI_OK)
        return (snprintf(err, size, "%s", pgi_last_error()), 0); /* a strict option the estimator refuses */
    if (x->progressive > 1 && !vt->exact)
        return (snprintf(err, size, "--progressive needs an exact estimator; '%s' is approximate", vt->name), 0);
    if (x->progressive > 1 && d->output == PGI_OUTPUT_PHOTON_COUNT)
        return (snprintf(err, size, "%s", "--progressive cannot average --output counts"), 0);
    if (d->radius_policy != PGI_RADIUS_FIXED && !(vt->caps & PGI_EST_CAP_PHOTON_RADIUS))
        return (snprintf(err, size,
                         "--radius-policy %s needs an estimator with per-photon footprints (see 'photongi "
                         "estimators -v'); '%s' has one fixed radius",
                         d->radius_policy == PGI_RADIUS_PATH ? "path" : "differentials", vt->name),
                0);
    if (d->r_min > 0.f && d->r_max > 0.f && d->r_min > d->r_max)
        return (snprintf(err, size, "--r-min (%g) must not exceed --r-max (%g)", (double)d->r_min, (double)d->r_max),
                0);
    if (!app_check_device(d, d->estimator, err, size)) return -1;
    return 1;
}
#undef APP_FAIL_

#endif
