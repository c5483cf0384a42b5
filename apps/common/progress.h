/* A one-line progress display on standard error for long commands (photongi
 * render and reference): drawn only when standard error is a terminal and the
 * command is not quiet, redrawn at most 10 times a second, erased or ended
 * with a newline when the work is done. Header only (static inline). */
#ifndef PGI__APPS_PROGRESS_H
#define PGI__APPS_PROGRESS_H

#include <stdarg.h>
#include <stdio.h>
#include <time.h>
#include <unistd.h>

/* Wall-clock milliseconds from an arbitrary origin (CLOCK_MONOTONIC). */
static inline double app_now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return 1e3 * (double)t.tv_sec + 1e-6 * (double)t.tv_nsec;
}

typedef struct app_progress {
    int on;         /* draw at all: a terminal, not quiet */
    int drawn;      /* a line is on the screen and not ended yet */
    double last_ms; /* elapsed time of the last redraw */
} app_progress;

static inline void app_progress_init(app_progress *p, int quiet) {
    p->on = !quiet && isatty(STDERR_FILENO);
    p->drawn = 0;
    p->last_ms = -1e9;
}

/* Draws "\r[#####.....] TEXT" over the line (frac in [0, 1]; below 0: no bar), unless the last
 * redraw was under 100 ms ago (elapsed_ms: the command's clock) and `force` is 0. */
#if defined(__GNUC__)
__attribute__((format(printf, 5, 6)))
#endif
static inline void
app_progress_draw(app_progress *p, double frac, double elapsed_ms, int force, const char *fmt, ...) {
    if (!p->on || (!force && elapsed_ms - p->last_ms < 100.0)) return;
    p->last_ms = elapsed_ms;
    char bar[40] = "";
    if (frac >= 0.0) {
        const int width = 30;
        int fill = (int)((frac > 1.0 ? 1.0 : frac) * width);
        bar[0] = '[';
        for (int i = 0; i < width; i++) bar[1 + i] = i < fill ? '#' : '.';
        bar[width + 1] = ']';
        bar[width + 2] = ' ';
        bar[width + 3] = 0;
    }
    char text[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\r%s%s\033[K", bar, text); /* ESC[K: erase the rest of a longer last line */
    fflush(stderr);
    p->drawn = 1;
}

/* Ends the line when one is drawn: keep = 1 leaves it (newline), 0 erases it. */
static inline void app_progress_end(app_progress *p, int keep) {
    if (!p->drawn) return;
    fputs(keep ? "\n" : "\r\033[K", stderr);
    fflush(stderr);
    p->drawn = 0;
}

#endif
