/* Frame statistics as JSON (cJSON). Counters are written as JSON numbers
 * (doubles): exact up to 2^53, far beyond any photon or ray count we make. */
#include "core/core.h"
#include "io/io_internal.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include <cjson/cJSON.h>

static int clamp_count(int n) { return n < 0 ? 0 : n > PGI_MAX_STAT_ENTRIES ? PGI_MAX_STAT_ENTRIES : n; }

/* Adds `name: value`; NULL from cJSON means out of memory. */
static int add_num(cJSON *o, const char *name, double v) {
    /* JSON has no NaN/inf; cJSON would print them as null anyway. */
    return cJSON_AddNumberToObject(o, name, isfinite(v) ? v : 0.0) != NULL;
}

/* The shortest "%g" of f that reads back as f. */
static void float_text(float f, char *buf, size_t size) {
    for (int prec = 6; prec <= 9; ++prec) {
        snprintf(buf, size, "%.*g", prec, (double)f);
        if ((float)strtod(buf, NULL) == f) return;
    }
}

/* A float as the shortest decimal that reads back as the same float, so that
 * a radius of 0.05f is written 0.05 rather than 0.05000000074505806. */
static double float_as_double(float f) {
    if (!isfinite(f)) return 0.0;
    char buf[32];
    float_text(f, buf, sizeof buf);
    return strtod(buf, NULL);
}

/* The names of the settings' enums, as the command line spells them. */
static const char *const k_outputs[] = {"all", "indirect", "direct", "counts"};
static const char *const k_jitters[] = {"auto", "off", "on"};
static const char *const k_tex_filters[] = {"auto", "off", "on"};
static const char *const k_emissions[] = {"uniform", "guided", "auto", "portal"};
static const char *const k_policies[] = {"fixed", "path", "differentials"};

/* names[i] of the n names, else `otherwise`. */
static const char *name_of(const char *const *names, int n, int i, const char *otherwise) {
    return i >= 0 && i < n ? names[i] : otherwise;
}

/* "settings": the frame's settings as `photongi render` options (name without "--": value). */
static int add_settings(cJSON *root, const pgi_frame_stats *st) {
    const pgi_render_desc *d = &st->settings;
    cJSON *o = cJSON_AddObjectToObject(root, "settings");
    if (!o) return 0;
    char v[64];
    int ok = 1;
#define PGI__SET(name, ...) (snprintf(v, sizeof v, __VA_ARGS__), ok &= cJSON_AddStringToObject(o, name, v) != NULL)
    const char *est = d->estimator ? d->estimator : st->estimator;
    if (est) ok &= cJSON_AddStringToObject(o, "estimator", est) != NULL;
    PGI__SET("photons", "%u", d->photons);
    if (st->auto_radius.used) PGI__SET("radius", "auto");
    else {
        float_text(d->radius, v, sizeof v);
        ok &= cJSON_AddStringToObject(o, "radius", v) != NULL;
    }
    PGI__SET("size", "%dx%d", st->width, st->height);
    PGI__SET("bounces", "%d", d->bounces);
    PGI__SET("seed", "%llu", (unsigned long long)d->seed);
    if (d->threads > 0) PGI__SET("threads", "%d", d->threads);
    PGI__SET("camera", "%d", d->camera);
    PGI__SET("direct-samples", "%d", d->direct_samples);
    PGI__SET("output", "%s", name_of(k_outputs, 4, (int)d->output, "all"));
    PGI__SET("jitter", "%s", name_of(k_jitters, 3, (int)d->jitter, "auto"));
    PGI__SET("texture-filter", "%s", name_of(k_tex_filters, 3, (int)d->texture_filter, "auto"));
    PGI__SET("emission", "%s", name_of(k_emissions, 4, (int)d->emission, "uniform"));
    PGI__SET("store", "%s", d->store == PGI_STORE_VIEW ? "view" : "all");
    PGI__SET("radius-policy", "%s", name_of(k_policies, 3, d->radius_policy, "fixed"));
    if (d->radius_policy != PGI_RADIUS_FIXED) {
        const float *f[] = {&d->r_min, &d->r_max, &d->smoothing};
        static const char *const names[] = {"r-min", "r-max", "smoothing"};
        for (int k = 0; k < 3; k++)
            if (*f[k] > 0.f) {
                float_text(*f[k], v, sizeof v);
                ok &= cJSON_AddStringToObject(o, names[k], v) != NULL;
            }
    }
    if (d->filter > 0) PGI__SET("filter", "%d", d->filter);
    if (d->max_memory == PGI_MEMORY_UNLIMITED) PGI__SET("max-memory", "none");
    else if (d->max_memory && d->max_memory != pgi_memory_default_budget())
        PGI__SET("max-memory", "%llu", (unsigned long long)d->max_memory);
    if (d->device == PGI_DEVICE_VULKAN && d->device_index > 0) PGI__SET("device", "vulkan:%d", d->device_index - 1);
    else PGI__SET("device", "%s", d->device == PGI_DEVICE_VULKAN ? "vulkan" : "cpu");
    if (st->frames > 1) PGI__SET("progressive", "%d", st->frames);
#undef PGI__SET
    const pgi_estimator_vtbl *vt = est ? pgi_estimator_find(est) : NULL;
    for (size_t i = 0; vt && i < pgi_option_count(); i++) {
        const pgi_option *opt = pgi_option_at(i);
        if (!pgi_estimator_takes(vt, opt)) continue;
        /* a zero that is its own mode (subsampling off, the automatic cell size) stays unwritten */
        const char *field = (const char *)&d->est + opt->offset;
        if (opt->type == PGI_OPTION_INT && *(const int *)(const void *)field == 0) continue;
        if (opt->type == PGI_OPTION_FLOAT && *(const float *)(const void *)field == 0.f) continue;
        pgi_option_format(opt, &d->est, v, sizeof v);
        ok &= cJSON_AddStringToObject(o, opt->name, v) != NULL;
    }
    return ok;
}

/* "run": what the caller did around the frame (pgi_run_info). */
static int add_run(cJSON *root, const pgi_run_info *r) {
    if (!r->scene) return 1;
    cJSON *o = cJSON_AddObjectToObject(root, "run");
    if (!o) return 0;
    int ok = cJSON_AddStringToObject(o, "scene", r->scene) != NULL;
    ok &= cJSON_AddStringToObject(o, "scene_file", r->scene_file ? r->scene_file : "") != NULL;
    char h[24];
    snprintf(h, sizeof h, "%016llx", (unsigned long long)r->scene_hash);
    if (r->scene_hash) ok &= cJSON_AddStringToObject(o, "scene_file_fnv1a64", h) != NULL;
    ok &= add_num(o, "exposure", float_as_double(r->exposure));
    ok &= add_num(o, "time", float_as_double(r->time));
    ok &= cJSON_AddStringToObject(o, "specular",
                                  r->specular == PGI_SPECULAR_GGX     ? "ggx"
                                  : r->specular == PGI_SPECULAR_PHONG ? "phong"
                                                                      : "default") != NULL;
    if (r->view) {
        cJSON *v = cJSON_AddObjectToObject(o, "view");
        ok &= v && cJSON_AddItemToObject(v, "eye", cJSON_CreateFloatArray(r->view->eye, 3)) &&
              cJSON_AddItemToObject(v, "look_at", cJSON_CreateFloatArray(r->view->look_at, 3)) &&
              cJSON_AddItemToObject(v, "up", cJSON_CreateFloatArray(r->view->up, 3)) &&
              add_num(v, "fov_y", float_as_double(r->view->fov_y_deg));
    }
    return ok;
}

static cJSON *build(const pgi_frame_stats *st) {
    cJSON *root = cJSON_CreateObject(), *o;
    if (!root) return NULL;
    int ok = 1;
    ok &= cJSON_AddStringToObject(root, "version", pgi_version()) != NULL;
    ok &= (st->estimator ? cJSON_AddStringToObject(root, "estimator", st->estimator)
                         : cJSON_AddNullToObject(root, "estimator")) != NULL;
    ok &= cJSON_AddStringToObject(root, "device", st->device ? st->device : "cpu") != NULL;
    ok &= add_num(root, "width", st->width);
    ok &= add_num(root, "height", st->height);
    ok &= add_num(root, "threads", st->threads);
    ok &= add_num(root, "radius", float_as_double(st->radius));
    const pgi_auto_radius_stats *ar = &st->auto_radius;
    ok &= cJSON_AddStringToObject(root, "radius_source", ar->used ? "auto" : "given") != NULL;
    if (ar->used) {
        /* what the automatic radius looked at and why it is what it is */
        ok &= (o = cJSON_AddObjectToObject(root, "radius_auto")) != NULL;
        if (o) {
            ok &= add_num(o, "k", ar->k);
            ok &= add_num(o, "quantile", float_as_double(ar->quantile));
            ok &= add_num(o, "knn_distance", float_as_double(ar->knn));
            ok &= add_num(o, "lo", float_as_double(ar->lo));
            ok &= add_num(o, "hi", float_as_double(ar->hi));
            ok &= add_num(o, "queries", ar->queries);
            ok &= add_num(o, "starved", ar->starved);
            ok &= add_num(o, "mean_reads", ar->mean_reads);
            ok &= add_num(o, "mean_cap", ar->mean_cap);
            ok &= cJSON_AddStringToObject(o, "why", ar->why ? ar->why : "") != NULL;
        }
    }

    ok &= (o = cJSON_AddObjectToObject(root, "photons")) != NULL;
    if (o) {
        ok &= add_num(o, "emitted", (double)st->photons_emitted);
        ok &= add_num(o, "stored", (double)st->photons_stored);
        ok &= add_num(o, "rays", (double)st->photon_rays);
        ok &= add_num(o, "discarded_paths", (double)st->photon_paths_discarded);
    }
    ok &= (o = cJSON_AddObjectToObject(root, "rays")) != NULL;
    if (o) {
        ok &= add_num(o, "primary", (double)st->primary_rays);
        ok &= add_num(o, "shadow", (double)st->shadow_rays);
    }
    if (st->traffic.submits || st->traffic.downloads) {
        ok &= (o = cJSON_AddObjectToObject(root, "device_traffic")) != NULL;
        if (o) {
            ok &= add_num(o, "submits", (double)st->traffic.submits);
            ok &= add_num(o, "dispatches", (double)st->traffic.dispatches);
            ok &= add_num(o, "uploads", (double)st->traffic.uploads);
            ok &= add_num(o, "upload_bytes", (double)st->traffic.upload_bytes);
            ok &= add_num(o, "downloads", (double)st->traffic.downloads);
            ok &= add_num(o, "download_bytes", (double)st->traffic.download_bytes);
        }
    }
    ok &= (o = cJSON_AddObjectToObject(root, "times_ms")) != NULL;
    if (o) {
        ok &= add_num(o, "view", st->view_ms);
        ok &= add_num(o, "trace", st->trace_ms);
        ok &= add_num(o, "radius", st->radius_ms);
        ok &= add_num(o, "build", st->build_ms);
        ok &= add_num(o, "estimate", st->estimate_ms);
        ok &= add_num(o, "direct", st->direct_ms);
        ok &= add_num(o, "total", st->total_ms);
    }
    ok &= (o = cJSON_AddObjectToObject(root, "passes_ms")) != NULL;
    if (o)
        for (int i = 0, n = clamp_count(st->pass_count); i < n; ++i)
            ok &= add_num(o, st->passes_ms[i].name ? st->passes_ms[i].name : "?", st->passes_ms[i].value);
    double total = 0.0;
    ok &= (o = cJSON_AddObjectToObject(root, "memory_bytes")) != NULL;
    if (o) {
        for (int i = 0, n = clamp_count(st->memory_count); i < n; ++i) {
            ok &= add_num(o, st->memory_bytes[i].name ? st->memory_bytes[i].name : "?", st->memory_bytes[i].value);
            total += st->memory_bytes[i].value;
        }
        ok &= add_num(o, "total", total);
    }
    /* the counted total next to what the process really used (docs/memory.md) */
    ok &= (o = cJSON_AddObjectToObject(root, "memory")) != NULL;
    if (o) {
        ok &= add_num(o, "counted_bytes", total);
        ok &= add_num(o, "counted_peak_bytes", (double)st->memory_counted_peak);
        ok &= add_num(o, "peak_rss_bytes", (double)st->memory_peak_rss);
        ok &= add_num(o, "counted_over_peak_rss", st->memory_peak_rss ? total / (double)st->memory_peak_rss : 0.0);
        ok &= (st->settings.max_memory == PGI_MEMORY_UNLIMITED || st->settings.max_memory == 0
                   ? cJSON_AddNullToObject(o, "budget_bytes")
                   : cJSON_AddNumberToObject(o, "budget_bytes", (double)st->settings.max_memory)) != NULL;
    }
    ok &= add_num(root, "reads", (double)st->reads);
    ok &= add_num(root, "contributing", (double)st->contributing);
    ok &= add_num(root, "reads_bulk", (double)st->reads_bulk);
    ok &= add_num(root, "contributing_ratio", st->reads ? (double)st->contributing / (double)st->reads : 0.0);
    ok &= add_num(root, "nodes_visited", (double)st->nodes_visited);
    ok &= add_num(root, "frames", (double)st->frames);
    ok &= add_num(root, "rt_update_ms", st->rt_update_ms);
    ok &= cJSON_AddStringToObject(root, "radius_policy", name_of(k_policies, 3, st->radius_policy, "?")) != NULL;
    ok &= cJSON_AddStringToObject(root, "jitter", name_of(k_jitters, 3, (int)st->settings.jitter, "?")) != NULL;
    ok &= cJSON_AddStringToObject(root, "texture_filter",
                                  name_of(k_tex_filters, 3, (int)st->settings.texture_filter, "?")) != NULL;
    ok &= cJSON_AddStringToObject(root, "emission", name_of(k_emissions, 4, (int)st->settings.emission, "?")) != NULL;
    ok &= cJSON_AddStringToObject(root, "emission_used", name_of(k_emissions, 4, (int)st->emission.used, "?")) != NULL;
    if (st->emission.reason) ok &= cJSON_AddStringToObject(root, "emission_reason", st->emission.reason) != NULL;
    ok &= cJSON_AddStringToObject(root, "store", st->settings.store == PGI_STORE_VIEW ? "view" : "all") != NULL;
    if (st->emission.bins > 0 || st->settings.store == PGI_STORE_VIEW) {
        const pgi_emission_stats *es = &st->emission;
        ok &= (o = cJSON_AddObjectToObject(root, "emission_guide")) != NULL;
        if (o) {
            ok &= cJSON_AddBoolToObject(o, "guided", es->guided) != NULL;
            ok &= add_num(o, "bins", es->bins);
            ok &= add_num(o, "pilot_paths", (double)es->pilot_paths);
            ok &= add_num(o, "gain", es->gain);
            ok &= add_num(o, "paths_per_stored", es->paths_per_stored);
            ok &= add_num(o, "paths_per_stored_uniform", es->paths_per_stored_uniform);
            ok &= add_num(o, "value", es->value);
            ok &= add_num(o, "in_view", es->in_view);
            ok &= add_num(o, "in_view_uniform", es->in_view_uniform);
            ok &= add_num(o, "cells", (double)es->cells);
            ok &= add_num(o, "cell", float_as_double(es->cell));
            ok &= add_num(o, "grid_ms", es->grid_ms);
            ok &= add_num(o, "culled", (double)es->culled);
        }
    }
    if (st->temporal.on) { /* pgi_temporal_step: its history and filter */
        const pgi_temporal_stats *ts = &st->temporal;
        ok &= (o = cJSON_AddObjectToObject(root, "temporal")) != NULL;
        if (o) {
            ok &= cJSON_AddBoolToObject(o, "restarted", ts->restarted) != NULL;
            ok &= add_num(o, "reused", ts->reused);
            ok &= add_num(o, "history", ts->history);
            ok &= add_num(o, "filter_weight", float_as_double(ts->filter_weight));
            ok &= add_num(o, "filter_passes", ts->filter_passes);
            ok &= add_num(o, "reproject_ms", ts->reproject_ms);
            ok &= add_num(o, "filter_ms", ts->filter_ms);
        }
    }
    if (st->emission.portals > 0) {
        const pgi_emission_stats *es = &st->emission;
        ok &= (o = cJSON_AddObjectToObject(root, "emission_portals")) != NULL;
        if (o) {
            ok &= cJSON_AddBoolToObject(o, "portal", es->portal) != NULL;
            ok &= add_num(o, "portals", (double)es->portals);
            ok &= add_num(o, "share", es->portal_share);
        }
    }
    if (st->leaf_size > 0) ok &= add_num(root, "bvh_leaf_size", (double)st->leaf_size);
    if (st->footprint_bin_width > 0.f) {
        /* BVH paper Table 3: counts of footprint radii in [k, k+1) * bin_width, the last bin open */
        ok &= (o = cJSON_AddObjectToObject(root, "footprint_histogram")) != NULL;
        if (o) {
            ok &= add_num(o, "bin_width", (double)st->footprint_bin_width);
            cJSON *arr = cJSON_AddArrayToObject(o, "counts");
            ok &= arr != NULL;
            for (int k = 0; arr && k < PGI_FOOTPRINT_BINS; k++) {
                cJSON *x = cJSON_CreateNumber((double)st->footprint_hist[k]);
                ok &= x != NULL && cJSON_AddItemToArray(arr, x);
            }
        }
    }
    ok &= add_settings(root, st);
    ok &= add_run(root, &st->run);
    if (!ok) {
        cJSON_Delete(root);
        return NULL;
    }
    return root;
}

char *pgi__stats_to_json(const pgi_frame_stats *st) {
    if (!st) return NULL;
    cJSON *root = build(st);
    if (!root) return NULL;
    /* cJSON allocates with malloc unless cJSON_InitHooks says otherwise (we never do). */
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    return text;
}

size_t pgi_stats_json(const pgi_frame_stats *st, char *buf, size_t size) {
    char *text = pgi__stats_to_json(st);
    if (!text) {
        if (size) buf[0] = 0;
        return 0;
    }
    size_t n = strlen(text);
    if (size) {
        size_t k = n < size - 1 ? n : size - 1;
        memcpy(buf, text, k);
        buf[k] = 0;
    }
    free(text);
    return n;
}

pgi_status pgi_stats_write_json(const pgi_frame_stats *st, const char *path) {
    if (!path || !path[0]) return pgi__fail(PGI_ERR_INVALID_ARG, "stats: no output path");
    if (!st) return pgi__fail(PGI_ERR_INVALID_ARG, "%s: no statistics to write", path);
    char *text = pgi__stats_to_json(st);
    if (!text) return pgi__fail(PGI_ERR_OOM, "%s: out of memory formatting statistics", path);

    if (strcmp(path, "-") == 0) { /* standard output */
        int bad = fputs(text, stdout) == EOF || fputc('\n', stdout) == EOF || fflush(stdout) != 0;
        free(text);
        return bad ? pgi__fail(PGI_ERR_IO, "stats: cannot write to standard output") : PGI_OK;
    }
    pgi__out o;
    pgi_status s = pgi__out_begin(path, &o);
    if (s) {
        free(text);
        return s;
    }
    errno = 0;
    FILE *f = fopen(pgi__out_path(&o, path), "w");
    if (!f) {
        int e = errno;
        free(text);
        pgi__out_abort(&o);
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, strerror(e));
    }
    size_t n = strlen(text);
    int err = 0;
    if (fwrite(text, 1, n, f) != n || fputc('\n', f) == EOF || fflush(f) != 0) err = errno ? errno : -1;
    free(text);
    if (fclose(f) != 0 && !err) err = errno ? errno : -1;
    if (err) {
        pgi__out_abort(&o);
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, err > 0 ? strerror(err) : "write error");
    }
    return pgi__out_commit(&o, path);
}
