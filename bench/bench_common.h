/* Small helpers shared by the benchmarks in bench/ (static inline, header only). */
#ifndef PGI_BENCH_COMMON_H
#define PGI_BENCH_COMMON_H

#include <stdlib.h>

static inline int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median of n values (sorts v in place). */
static inline double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

#endif
