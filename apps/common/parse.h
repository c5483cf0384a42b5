/* Strict number parsing shared by the apps (photongi, photongi-view): the
 * whole string must be a number, else 0 is returned and *out is left alone.
 * Header only (static inline); the apps report the error themselves. */
#ifndef PGI_APPS_PARSE_H
#define PGI_APPS_PARSE_H

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

/* Integer in [lo, hi]. */
static inline int parse_long(const char *s, long long lo, long long hi, long long *out) {
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) return 0;
    *out = v;
    return 1;
}

/* Non-negative integer of 64 bits (a leading '-' is refused). */
static inline int parse_u64(const char *s, uint64_t *out) {
    char *end;
    errno = 0;
    if (*s == '-') return 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s || *end) return 0;
    *out = v;
    return 1;
}

/* Any float strtof accepts, infinities and NaN included (callers check the range). */
static inline int parse_float(const char *s, float *out) {
    char *end;
    errno = 0;
    float v = strtof(s, &end);
    if (errno || end == s || *end) return 0;
    *out = v;
    return 1;
}

/* Finite float. */
static inline int parse_finite_float(const char *s, float *out) {
    float v;
    if (!parse_float(s, &v) || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

/* Finite float > 0. */
static inline int parse_pos_float(const char *s, float *out) {
    float v;
    if (!parse_float(s, &v) || !(v > 0.f) || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

/* Finite double > 0. */
static inline int parse_pos_double(const char *s, double *out) {
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !(v > 0.0) || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

#endif
