/* Photon tracing on the GPU device against the CPU tracer (docs/gpu.md "Photon tracing"):
 *   photongi-bench-gpu-trace [--scene NAME] [--photons N] [--bounces N] [--threads N] [--runs N]
 *                            [--radius-policy fixed|path|differentials]
 * (a radius policy: both tracers compute the footprints, r_max 2 % of the diagonal, r_min r_max / 8)
 * traces once per device as a warm-up (lavapipe compiles its kernels on first use), then `runs`
 * times each, and prints the best times: the CPU tracer's wall clock on `threads` threads (default
 * 2), the GPU's device time (timestamps "gpu_trace") and its wall clock (submits and read-backs of
 * its batches included), photons per second, paths emitted, paths discarded, rays and the yield.
 * Exit 1 with the message when something fails. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/core.h"
#include "gpu/gpu_trace.h"
#include "photon/photon.h"
#include "rt/rt.h"
#include "scene/scene_internal.h"

static int fail(const char *what) {
    fprintf(stderr, "%s failed: %s\n", what, pgi_last_error());
    return 1;
}

int main(int argc, char **argv) {
    const char *scene = "cornell";
    uint32_t photons = 200000;
    int bounces = 4, threads = 2, runs = 3, policy = PGI_RADIUS_FIXED;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--scene") && v) scene = argv[++i];
        else if (!strcmp(a, "--photons") && v) photons = (uint32_t)strtoul(argv[++i], NULL, 10);
        else if (!strcmp(a, "--bounces") && v) bounces = atoi(argv[++i]);
        else if (!strcmp(a, "--threads") && v) threads = atoi(argv[++i]);
        else if (!strcmp(a, "--runs") && v) runs = atoi(argv[++i]);
        else if (!strcmp(a, "--radius-policy") && v &&
                 (!strcmp(v, "fixed") || !strcmp(v, "path") || !strcmp(v, "differentials"))) {
            policy = !strcmp(v, "fixed")  ? PGI_RADIUS_FIXED
                     : !strcmp(v, "path") ? PGI_RADIUS_PATH
                                          : PGI_RADIUS_DIFFERENTIALS;
            i++;
        } else {
            fprintf(stderr, "usage: photongi-bench-gpu-trace [--scene NAME] [--photons N] [--bounces N] [--threads N] "
                            "[--runs N] [--radius-policy fixed|path|differentials]\n");
            return 2;
        }
    }
    if (runs < 1) runs = 1;
    pgi_scene *s = NULL;
    if (pgi_scene_load(scene, &s) != PGI_OK) return fail("loading the scene");
    pgi__rt *rt = NULL;
    if (pgi__rt_create(s, &rt) != PGI_OK) return fail("Embree");
    pgi_photons ph = {0};
    if (pgi_photons_alloc(&ph, photons) != PGI_OK) return fail("photons");
    const float r_max = 0.02f * pgi__scene_diagonal(s), r_min = r_max / 8.f;
    float *fp = NULL;
    if (policy != PGI_RADIUS_FIXED) { /* the footprint arrays: radius and the six semi-axis planes */
        if (!(fp = calloc(7 * (size_t)photons, sizeof *fp))) return fail("footprints");
        float **pl[] = {&ph.radius, &ph.sax, &ph.say, &ph.saz, &ph.sbx, &ph.sby, &ph.sbz};
        for (int k = 0; k < (policy == PGI_RADIUS_DIFFERENTIALS ? 7 : 1); k++) *pl[k] = fp + (size_t)k * photons;
    }
    pgi__trace_desc td = {.photons = photons,
                          .bounces = bounces,
                          .seed = 1,
                          .threads = threads,
                          .radius_policy = policy,
                          .r_min = r_min,
                          .r_max = r_max};
    pgi__trace_scratch sc = {0};
    double cpu_ms = -1.0;
    uint64_t crays = 0;
    for (int k = 0; k <= runs; k++) {
        double t0 = pgi__now_ms();
        if (pgi__photons_trace(s, rt, &td, &ph, &sc, &crays) != PGI_OK) return fail("the CPU tracer");
        double ms = pgi__now_ms() - t0;
        if (k > 0 && (cpu_ms < 0.0 || ms < cpu_ms)) cpu_ms = ms;
    }
    const uint64_t cemitted = ph.emitted, cdiscarded = sc.paths_traced - ph.emitted;
    printf("scene %s, %u photons, %d bounces (%zu triangles), radius policy %s\n", scene, photons, bounces, s->ntris,
           policy == PGI_RADIUS_FIXED  ? "fixed"
           : policy == PGI_RADIUS_PATH ? "path"
                                       : "differentials");
    printf("  CPU (%d threads): %8.1f ms  %6.2f Mphotons/s  emitted %llu  discarded %llu  rays %llu  yield %.4f\n",
           threads, cpu_ms, photons / cpu_ms / 1e3, (unsigned long long)cemitted, (unsigned long long)cdiscarded,
           (unsigned long long)crays, (double)photons / (double)cemitted);
    pgi__trace_scratch_free(&sc);
    ph.radius = ph.sax = ph.say = ph.saz = ph.sbx = ph.sby = ph.sbz = NULL;
    free(fp);
    pgi_photons_free(&ph);
    pgi__rt_destroy(rt);

    pgi__gpu *g = NULL;
    if (pgi__gpu_create(-1, &g) != PGI_OK) return fail("the Vulkan device");
    pgi__gpu_scene *gs = NULL;
    pgi__gpu_trace *gt = NULL;
    if (pgi__gpu_scene_create(g, s, &gs) != PGI_OK) return fail("the GPU scene");
    if (pgi__gpu_trace_create(g, gs, &gt) != PGI_OK) return fail("the GPU tracer");
    pgi__gpu_trace_desc gd =
        {.photons = photons, .bounces = bounces, .seed = 1, .radius_policy = policy, .r_min = r_min, .r_max = r_max};
    pgi__gpu_trace_result r, best = {0};
    best.trace_ms = best.wall_ms = -1.0;
    for (int k = 0; k <= runs; k++) {
        if (pgi__gpu_trace_run(gt, s, &gd, &r) != PGI_OK) return fail("the GPU tracer");
        if (k == 0) continue;
        if (best.trace_ms < 0.0 || r.trace_ms < best.trace_ms) {
            double w = best.wall_ms;
            best = r;
            best.wall_ms = w;
        }
        if (best.wall_ms < 0.0 || r.wall_ms < best.wall_ms) best.wall_ms = r.wall_ms;
    }
    printf("  GPU %s: device %8.1f ms (wall %.1f ms, %d batches)  %6.2f Mphotons/s  emitted %llu  discarded %llu  "
           "rays %llu  yield %.4f\n",
           pgi__gpu_device_name(g), best.trace_ms, best.wall_ms, best.batches, photons / best.trace_ms / 1e3,
           (unsigned long long)best.emitted, (unsigned long long)best.paths_discarded, (unsigned long long)best.rays,
           (double)best.count / (double)best.emitted);
    pgi__gpu_trace_destroy(gt);
    pgi__gpu_scene_destroy(gs);
    pgi__gpu_destroy(g);
    pgi_scene_destroy(s);
    return 0;
}
