/* Estimator options on the command line, from the library's option tables
 * (pgi_option): the apps parse, document and check them without knowing any
 * estimator. Header only (static inline), shared by photongi and the viewer. */
#ifndef PGI_APPS_OPTIONS_H
#define PGI_APPS_OPTIONS_H

#include <stdio.h>
#include <string.h>

#include "photongi/photongi.h"

/* Every option (shared ones first, each once) in the order of the registry. */
static inline size_t app_options(const pgi_option **out, size_t cap) {
    size_t n = 0;
    for (const pgi_option *const *l = pgi_estimator_shared_options(); *l && n < cap; l++) out[n++] = *l;
    for (size_t e = 0; e < pgi_estimator_count(); e++)
        for (const pgi_option *const *l = pgi_estimator_at(e)->options; l && *l && n < cap; l++) {
            size_t k = 0;
            while (k < n && out[k] != *l) k++;
            if (k == n) out[n++] = *l;
        }
    return n;
}

/* "tiled, bounds3d, bounds25d": the estimators that take option o. */
static inline void app_option_takers(const pgi_option *o, char *buf, size_t cap) {
    buf[0] = 0;
    for (size_t e = 0; e < pgi_estimator_count(); e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        if (!pgi_estimator_takes(vt, o)) continue;
        size_t n = strlen(buf);
        snprintf(buf + n, cap - n, "%s%s", n ? ", " : "", vt->name);
    }
}

/* The help section for the estimator options. */
static inline void app_print_estimator_options(FILE *f) {
    const pgi_option *all[64];
    size_t n = app_options(all, 64);
    fprintf(f, "Estimator options (an estimator ignores the options of others):\n");
    for (size_t i = 0; i < n; i++) {
        char arg[80], takers[256];
        if (all[i]->type == PGI_OPTION_CHOICE) snprintf(arg, sizeof arg, "--%s %s", all[i]->name, all[i]->choices);
        else snprintf(arg, sizeof arg, "--%s %s", all[i]->name, all[i]->type == PGI_OPTION_FLOAT ? "X" : "N");
        app_option_takers(all[i], takers, sizeof takers);
        if (strlen(arg) > 20) fprintf(f, "  %s\n  %-20s %s\n", arg, "", all[i]->help);
        else fprintf(f, "  %-20s %s\n", arg, all[i]->help);
        fprintf(f, "  %-20s [%s]\n", "", takers);
    }
}

/* Options given on the command line, for app_check_estimator_options. */
typedef struct app_given_options {
    const pgi_option *given[64];
    int count;
} app_given_options;

/* Parses "--name value" into d when name is an estimator option: returns 1
 * (handled), 0 (not an estimator option) or -1 (bad value; message printed
 * as "<prog>: <message>"). */
static inline int app_estimator_option(const char *prog, const char *flag, const char *value, pgi_estimator_desc *d,
                                       app_given_options *g) {
    if (strncmp(flag, "--", 2) != 0) return 0;
    const pgi_option *o = pgi_option_find(flag + 2);
    if (!o) return 0;
    if (pgi_estimator_desc_set(d, o->name, value) != PGI_OK) {
        fprintf(stderr, "%s: %s\n", prog, pgi_last_error());
        return -1;
    }
    if (g && g->count < 64) g->given[g->count++] = o;
    return 1;
}

/* Notes options given for estimators other than `est` (the library ignores
 * them; strict ones it rejects with its own message). */
static inline void app_note_ignored_options(const char *prog, const char *est, const app_given_options *g) {
    const pgi_estimator_vtbl *vt = pgi_estimator_find(est && *est ? est : "tiled");
    if (!vt) return;
    for (int i = 0; i < g->count; i++) {
        const pgi_option *o = g->given[i];
        if (pgi_estimator_takes(vt, o) || (o->flags & PGI_OPTION_STRICT)) continue;
        char takers[256];
        app_option_takers(o, takers, sizeof takers);
        fprintf(stderr, "%s: note: --%s is an option of %s, not of '%s'; ignored\n", prog, o->name, takers, vt->name);
    }
}

#endif
