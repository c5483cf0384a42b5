/* Strict number parsing shared by the apps (photongi, photongi-view): the
 * whole string must be a number, else 0 is returned and *out is left alone.
 * Header only (static inline); the apps report the error themselves. */
#ifndef PGI__APPS_PARSE_H
#define PGI__APPS_PARSE_H

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "photongi/photongi.h"

/* Index of s in the NULL-terminated `names` (an enum's values in order), or -1. */
static inline int parse_choice(const char *s, const char *const *names) {
    for (int i = 0; names[i]; i++)
        if (strcmp(s, names[i]) == 0) return i;
    return -1;
}

/* "uniform", "guided" or "auto" (--emission). */
static inline int app_parse_emission(const char *s, pgi_emission *out) {
    static const char *const names[] = {"uniform", "guided", "auto", NULL};
    int i = parse_choice(s, names);
    if (i >= 0) *out = (pgi_emission)i;
    return i >= 0;
}

/* "all" or "view" (--store). */
static inline int app_parse_store(const char *s, pgi_store *out) {
    static const char *const names[] = {"all", "view", NULL};
    int i = parse_choice(s, names);
    if (i >= 0) *out = (pgi_store)i;
    return i >= 0;
}

/* Integer in [lo, hi]. */
static inline int parse_long(const char *s, long long lo, long long hi, long long *out) {
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) return 0;
    *out = v;
    return 1;
}

/* A count: a whole number in [lo, hi], written as digits or in exponent form ("2e6", "1.5e5";
 * whole numbers only). Callers name the range in their message, so that "1e12 photons" is told
 * the limit rather than a format. */
static inline int parse_whole(const char *s, long long lo, long long hi, long long *out) {
    if (parse_long(s, lo, hi, out)) return 1;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !isfinite(v) || v != floor(v) || v < (double)lo || v > (double)hi) return 0;
    *out = (long long)v;
    return 1;
}

/* Image size "WIDTHxHEIGHT": each side in 1..max_side, at most max_pixels in all. */
static inline int parse_size(const char *s, long long max_side, long long max_pixels, int *w, int *h) {
    char ws[32], hs[32], extra;
    long long x, y;
    if (sscanf(s, "%31[0-9]x%31[0-9]%c", ws, hs, &extra) != 2 || !parse_long(ws, 1, max_side, &x) ||
        !parse_long(hs, 1, max_side, &y) || x * y > max_pixels)
        return 0;
    *w = (int)x;
    *h = (int)y;
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

/* --checkpoint's seconds: a number in 0..1e9 (0: none). */
static inline int parse_checkpoint(const char *s, double *out) {
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (!*s || *end || errno || !(v >= 0.0 && v <= 1e9)) return 0;
    *out = v;
    return 1;
}

/* A memory size (--max-memory): a positive number with an optional binary unit K, M, G or T
 * (1024-based; "KB", "KiB", "k" alike; none: bytes), e.g. "2G", "1.5GiB", "512M"; or "none"
 * (PGI_MEMORY_UNLIMITED). */
static inline int parse_bytes(const char *s, uint64_t *out) {
    if (strcmp(s, "none") == 0) {
        *out = PGI_MEMORY_UNLIMITED;
        return 1;
    }
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || !isfinite(v) || !(v > 0.0)) return 0;
    double unit = 1.0;
    const char *units = "KMGT";
    const char *u = *end ? strchr(units, toupper((unsigned char)*end)) : NULL;
    if (*end && !u) return 0;
    if (u) {
        for (const char *k = units; k <= u; k++) unit *= 1024.0;
        end++;
        if (*end == 'i' || *end == 'I') end++;
        if (*end == 'B' || *end == 'b') end++;
    }
    if (*end) return 0;
    v *= unit;
    if (v < 1.0 || v >= 18446744073709551615.0) return 0;
    *out = (uint64_t)v;
    return 1;
}

/* "ggx" or "phong" (--specular); 0 when s is neither. */
static inline int parse_specular(const char *s, pgi_specular *out) {
    if (strcmp(s, "ggx") == 0) *out = PGI_SPECULAR_GGX;
    else if (strcmp(s, "phong") == 0) *out = PGI_SPECULAR_PHONG;
    else return 0;
    return 1;
}

#endif
