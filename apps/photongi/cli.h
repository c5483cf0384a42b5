/* What every photongi command shares: the exit statuses and the messages that
 * go with them. Header only (static inline).
 *
 * Exit status (documented in 'photongi --help' and docs/usage.md):
 *   0  success
 *   2  usage error: the command line alone is wrong, whatever the files hold; found before
 *      any file is opened (unknown command, option or help topic; a missing, malformed or
 *      out-of-range value; options that do not go together, such as an estimator option
 *      the chosen estimator refuses; an output format photongi does not write)
 *   1  failure: the command line is well formed, but what it names or the work is not
 *      (a scene, mesh, image or sidecar file missing, unreadable or malformed; a scene name
 *      with no built-in scene and no NAME.json; a camera the scene does not have; an output
 *      folder that does not exist or cannot be written; out of memory; a failed render)
 * Messages start with "photongi COMMAND: "; usage errors end with a pointer to --help. */
#ifndef PGI__CLI_H
#define PGI__CLI_H

#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "camera.h"
#include "photongi/photongi.h"

enum { CLI_EXIT_OK = 0, CLI_EXIT_FAILURE = 1, CLI_EXIT_USAGE = 2 };

/* "photongi CMD: <message>" and the tail (a newline, or the usage hint). */
static inline void cli_vreport(const char *cmd, const char *tail, const char *fmt, va_list ap) {
    fprintf(stderr, "photongi %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    fputs(tail, stderr);
}

/* "photongi CMD: <message>\nTry 'photongi CMD --help'.": returns CLI_EXIT_USAGE. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static inline int
cli_usage(const char *cmd, const char *fmt, ...) {
    char tail[96];
    snprintf(tail, sizeof tail, "\nTry 'photongi %s --help'.\n", cmd);
    va_list ap;
    va_start(ap, fmt);
    cli_vreport(cmd, tail, fmt, ap);
    va_end(ap);
    return CLI_EXIT_USAGE;
}

/* "photongi CMD: <message>": returns CLI_EXIT_FAILURE. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static inline int
cli_failure(const char *cmd, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    cli_vreport(cmd, "\n", fmt, ap);
    va_end(ap);
    return CLI_EXIT_FAILURE;
}

/* "photongi CMD: WHAT: <the library's message>" for a failed library call. A render or write
 * that refuses its arguments (PGI_ERR_INVALID_ARG: options that do not go together) is a usage
 * error, anything else (files, memory, Embree) a failure. Scene loading uses cli_input_fail. */
static inline int cli_fail(const char *cmd, const char *what, pgi_status st) {
    const char *msg = pgi_last_error();
    fprintf(stderr, "photongi %s: %s: %s\n", cmd, what, *msg ? msg : pgi_status_string(st));
    return st == PGI_ERR_INVALID_ARG ? CLI_EXIT_USAGE : CLI_EXIT_FAILURE;
}

/* The same for reading what the command line names (a scene, an image, a sidecar): whatever the
 * status, the files are at fault, not the command line (an unknown scene name included: named
 * scenes are files). */
static inline int cli_input_fail(const char *cmd, const char *what, pgi_status st) {
    cli_fail(cmd, what, st);
    return CLI_EXIT_FAILURE;
}

/* "photongi CMD: warning: <message>" unless quiet (-q silences warnings and notes, not errors). */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static inline void
cli_warn(int quiet, const char *cmd, const char *fmt, ...) {
    if (quiet) return;
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "photongi %s: warning: ", cmd);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

/* "--help" or "-h". */
static inline int cli_is_help(const char *a) { return strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0; }

/* "-q" or "--quiet". */
static inline int cli_is_quiet(const char *a) { return strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0; }

/* The signal that interrupted a command, by name (render and reference catch SIGINT and SIGTERM). */
static inline const char *cli_signal_name(int sig) { return sig == SIGINT ? "SIGINT" : "SIGTERM"; }

/* Loads a scene (max_memory as pgi_scene_load_budget: 0 the default budget, as pgi_scene_load) and
 * sets its glossy model (PGI_SPECULAR_DEFAULT: the description's). 0, or prints "photongi CMD: ..."
 * and returns the exit status (nothing left to free). */
static inline int cli_load_scene(const char *cmd, const char *spec, uint64_t max_memory, pgi_specular specular,
                                 pgi_scene **scene) {
    pgi_status st = pgi_scene_load_budget(spec, max_memory, scene);
    if (st) return cli_input_fail(cmd, "cannot load scene", st);
    if (specular != PGI_SPECULAR_DEFAULT && (st = pgi_scene_set_specular(*scene, specular))) {
        pgi_scene_destroy(*scene);
        *scene = NULL;
        return cli_fail(cmd, "cannot set the specular model", st);
    }
    return 0;
}

/* The camera of --eye, --look-at, --up and --fov (c), the parts not given taken from the scene's
 * camera `camera`, into *view. 0, or prints "photongi CMD: scene NAME: <why>" and returns 1. */
static inline int cli_resolve_view(const char *cmd, const pgi_scene *scene, int camera, const char *scene_name,
                                   const app_camera_args *c, pgi_camera_def *view) {
    char err[400];
    pgi_camera_def base;
    pgi_scene_get_camera(scene, (size_t)camera, &base);
    if (!app_camera_resolve(c, &base, view, err, sizeof err)) return cli_failure(cmd, "scene %s: %s", scene_name, err);
    return 0;
}

/* The exposure given (above 0; 0: none), else the scene's, else 1. */
static inline float cli_exposure(float given, const pgi_scene_info *info) {
    return given > 0.f ? given : info->defaults.exposure > 0.f ? info->defaults.exposure : 1.f;
}

/* Pixels with a channel that is not a finite number once multiplied by exposure (NaN, Inf). */
static inline size_t cli_non_finite_pixels(const pgi_image *img, float exposure) {
    size_t bad = 0, npx = (size_t)img->width * (size_t)img->height;
    for (size_t i = 0; i < npx; i++) {
        const float *p = img->rgb + 3 * i;
        bad += !isfinite(p[0] * exposure) || !isfinite(p[1] * exposure) || !isfinite(p[2] * exposure);
    }
    return bad;
}

#endif
