/* Estimator options on the command line, from the library's option tables
 * (pgi_option): the apps parse, document and check them without knowing any
 * estimator. Header only (static inline), shared by photongi and the viewer. */
#ifndef PGI__APPS_OPTIONS_H
#define PGI__APPS_OPTIONS_H

#include <stdio.h>
#include <string.h>

#include "photongi/photongi.h"

/* The help section for the estimator options. */
static inline void app_print_estimator_options(FILE *f) {
    fprintf(f, "Estimator options (in [] the estimators that take one; the others ignore it, except a\n"
               "strict option, which they refuse):\n");
    for (size_t i = 0; i < pgi_option_count(); i++) {
        const pgi_option *o = pgi_option_at(i);
        char arg[80], takers[256];
        if (o->type == PGI_OPTION_CHOICE) snprintf(arg, sizeof arg, "--%s %s", o->name, o->choices);
        else snprintf(arg, sizeof arg, "--%s %s", o->name, o->type == PGI_OPTION_FLOAT ? "X" : "N");
        pgi_option_takers(o, takers, sizeof takers);
        if (strlen(arg) > 20) fprintf(f, "  %s\n  %-20s %s\n", arg, "", o->help);
        else fprintf(f, "  %-20s %s\n", arg, o->help);
        fprintf(f, "  %-20s [%s]%s\n", "", takers, (o->flags & PGI_OPTION_STRICT) ? " strict" : "");
    }
}

/* Options given on the command line, for app_note_ignored_options. */
typedef struct app_given_options {
    const pgi_option *given[64];
    int count;
} app_given_options;

/* Parses "--name value" into d when name is an estimator option: returns 1
 * (handled), 0 (not an estimator option) or -1 (bad value; message printed
 * as "<prog>: <message>" unless prog is NULL; pgi_last_error() has it). */
static inline int app_estimator_option(const char *prog, const char *flag, const char *value, pgi_estimator_desc *d,
                                       app_given_options *g) {
    if (strncmp(flag, "--", 2) != 0) return 0;
    const pgi_option *o = pgi_option_find(flag + 2);
    if (!o) return 0;
    if (pgi_estimator_desc_set(d, o->name, value) != PGI_OK) {
        if (prog) fprintf(stderr, "%s: %s\n", prog, pgi_last_error());
        return -1;
    }
    if (g && g->count < 64) g->given[g->count++] = o;
    return 1;
}

/* Notes options given for estimators other than `est` (the library ignores
 * them; strict ones it rejects with its own message). */
static inline void app_note_ignored_options(const char *prog, const char *est, const app_given_options *g) {
    const pgi_estimator_vtbl *vt = pgi_estimator_find(est && *est ? est : PGI_DEFAULT_ESTIMATOR);
    if (!vt) return;
    for (int i = 0; i < g->count; i++) {
        const pgi_option *o = g->given[i];
        if (pgi_estimator_takes(vt, o) || (o->flags & PGI_OPTION_STRICT)) continue;
        char takers[256];
        pgi_option_takers(o, takers, sizeof takers);
        fprintf(stderr, "%s: note: --%s is an option of %s, not of '%s'; ignored\n", prog, o->name, takers, vt->name);
    }
}

#endif
