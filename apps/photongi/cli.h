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

#include <stdarg.h>
#include <stdio.h>

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

#endif
