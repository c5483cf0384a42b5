/* Small helpers shared by the benchmarks in bench/ (static inline, header only). */
#ifndef PGI__BENCH_COMMON_H
#define PGI__BENCH_COMMON_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "photongi/photongi.h"

static inline int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median of n values (sorts v in place). */
static inline double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Loads a scene and a renderer for it; on failure says why and returns 0 (the scene is skipped). */
static inline int open_scene(const char *sc, pgi_scene **scene, pgi_renderer **r) {
    if (pgi_scene_load(sc, scene) != PGI_OK) {
        fprintf(stderr, "photongi-bench: skipping scene %s: %s\n", sc, pgi_last_error());
        return 0;
    }
    if (pgi_renderer_create(*scene, r) != PGI_OK) {
        fprintf(stderr, "photongi-bench: skipping scene %s: %s\n", sc, pgi_last_error());
        pgi_scene_destroy(*scene);
        return 0;
    }
    return 1;
}

/* Opens a results CSV for writing (creating bench/results); on failure says why and returns NULL. */
static inline FILE *open_csv(const char *path) {
    mkdir("bench/results", 0755);
    FILE *f = fopen(path, "w");
    if (!f) fprintf(stderr, "photongi-bench: cannot write %s\n", path);
    return f;
}

/* Bytes the estimator itself holds in a frame: the renderer lists its photons,
 * view samples and tracer scratch first (src/pipeline/render.c), then the
 * estimator's entries, then (adaptive radius) the footprints. */
static inline double estimator_bytes(const pgi_frame_stats *fs) {
    double b = 0.0;
    for (int k = 3; k < fs->memory_count; k++)
        if (strcmp(fs->memory_bytes[k].name, "footprints") != 0) b += fs->memory_bytes[k].value;
    return b;
}

#endif
