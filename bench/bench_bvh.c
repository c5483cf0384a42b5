/* photongi-bench-bvh: the BVH paper's Table 1 protocol on our scenes (not a test).
 *
 * One scene, one camera, 1920x1080 view samples and one photon map (fixed seed) are made once;
 * then the "bvh" estimator is built and queried for every leaf-size threshold 1, 2, 4, ..., 512
 * and T_auto, with both builders (linear and VVH), N frames each (configurations interleaved
 * frame by frame so that machine noise hits all alike); medians of build and estimate time.
 * Prints the table, T_auto's speed relative to the best fixed threshold, and (--policy
 * differentials) the footprint radius histogram (BVH paper Table 3).
 *
 *   photongi-bench-bvh [--scene sibenik] [--photons 200000] [--size 1920x1080] [--frames 3]
 *                      [--policy fixed|differentials] [--radius R] [--smoothing S] [--threads T]
 */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "photongi/photongi.h"

#include "bench_common.h"

#define NL 11
#define MAXF 32

static int die(const char *what) {
    fprintf(stderr, "photongi-bench-bvh: %s: %s\n", what, pgi_last_error());
    return 1;
}

int main(int argc, char **argv) {
    const char *scene_name = "sibenik", *policy = "fixed";
    uint32_t photons = 200000;
    int width = 1920, height = 1080, frames = 3, threads = 0;
    float radius = 0.f, smoothing = 0.f;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) {
            fprintf(stderr, "usage: photongi-bench-bvh [--scene S] [--photons N] [--size WxH] [--frames N]\n"
                            "       [--policy fixed|differentials] [--radius R] [--smoothing S] [--threads T]\n");
            return 2;
        }
        i++;
        if (strcmp(a, "--scene") == 0) scene_name = v;
        else if (strcmp(a, "--photons") == 0) photons = (uint32_t)strtoul(v, NULL, 10);
        else if (strcmp(a, "--size") == 0) {
            if (sscanf(v, "%dx%d", &width, &height) != 2) return 2;
        } else if (strcmp(a, "--frames") == 0) frames = atoi(v);
        else if (strcmp(a, "--policy") == 0) policy = v;
        else if (strcmp(a, "--radius") == 0) radius = strtof(v, NULL);
        else if (strcmp(a, "--smoothing") == 0) smoothing = strtof(v, NULL);
        else if (strcmp(a, "--threads") == 0) threads = atoi(v);
        else {
            fprintf(stderr, "unknown option %s\n", a);
            return 2;
        }
    }
    if (frames < 1 || frames > MAXF || photons < 1 || width < 1 || height < 1) return 2;
    int diff = strcmp(policy, "differentials") == 0;

    pgi_scene *s;
    if (pgi_scene_load(scene_name, &s)) return die("cannot load scene");
    pgi_renderer *r;
    if (pgi_renderer_create(s, &r)) return die("renderer");
    /* View samples and one photon map, as a frame makes them. */
    pgi_render_desc rd = {.photons = photons,
                          .radius = radius,
                          .width = width,
                          .height = height,
                          .seed = 1,
                          .threads = threads,
                          .smoothing = smoothing,
                          .radius_policy = diff ? PGI_RADIUS_DIFFERENTIALS : PGI_RADIUS_FIXED};
    rd.estimator = diff ? "bvh" : NULL;
    pgi_frame_inputs in;
    pgi_frame_stats fs;
    if (pgi_renderer_prepare(r, &rd, &in, &fs)) return die("view samples / photons");
    radius = in.radius;
    const pgi_photons ph = *in.photons;
    const pgi_view_samples vs = *in.samples;
    const double area = in.scene_area, trace_ms = fs.trace_ms;
    const uint64_t *hist = fs.footprint_hist;
    float *out = malloc(3 * vs.count * sizeof(float));
    if (!out) return die("output buffer");
    double fp_area = 0.0;
    for (size_t j = 0; j < ph.count; j++) {
        double rj = diff ? ph.radius[j] : radius;
        fp_area += 3.14159265358979 * rj * rj;
    }
    printf("footprint area / scene area = %.3f\n", fp_area / area);
    printf("scene %s, %dx%d, %zu photons (%s footprints, r%s = %g), scene area %.1f, %d threads, %d frames, "
           "trace %.0f ms\n",
           scene_name, width, height, ph.count, policy, diff ? "_max" : "", (double)radius, area,
           threads > 0 ? threads : omp_get_max_threads(), frames, trace_ms);

    static const int leaves[NL] = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 0};
    static double bms[2][NL][MAXF], ems[2][NL][MAXF];
    static int used[2][NL];
    static uint64_t reads[2][NL], contrib[2][NL];
    for (int f = 0; f < frames; f++)
        for (int b = 0; b < 2; b++)
            for (int l = 0; l < NL; l++) {
                pgi_estimator_desc d = {.bvh = {.build = (pgi_bvh_build)b, .leaf_size = leaves[l]}};
                pgi_estimator *e;
                if (pgi_estimator_create("bvh", &d, &e)) return die("create");
                pgi_estimate_args a = {.photons = &ph,
                                       .samples = &vs,
                                       .camera = &in.camera,
                                       .out_rgb = out,
                                       .radius = radius,
                                       .seed = 1,
                                       .threads = threads,
                                       .scene_area = (float)area};
                if (pgi_estimator_build(e, &a) || pgi_estimator_estimate(e, &a)) return die("bvh");
                pgi_estimator_stats st;
                pgi_estimator_get_stats(e, &st);
                bms[b][l][f] = st.build_ms;
                ems[b][l][f] = st.estimate_ms;
                used[b][l] = st.leaf_size;
                reads[b][l] = st.reads;
                contrib[b][l] = st.contributing;
                pgi_estimator_destroy(e);
            }
    printf("\n%-8s | %10s %10s %10s %9s | %10s %10s %10s %9s\n", "leaf", "lin build", "lin est", "lin total",
           "reads/px", "vvh build", "vvh est", "vvh total", "reads/px");
    double best[2] = {1e300, 1e300}, tot[2][NL];
    int best_l[2] = {0, 0};
    for (int l = 0; l < NL; l++) {
        char name[32];
        if (leaves[l]) snprintf(name, sizeof name, "%d", leaves[l]);
        else snprintf(name, sizeof name, "auto=%d", used[0][l]);
        printf("%-8s |", name);
        for (int b = 0; b < 2; b++) {
            double bm = median(bms[b][l], frames), em = median(ems[b][l], frames);
            tot[b][l] = bm + em;
            if (leaves[l] && tot[b][l] < best[b]) best[b] = tot[b][l], best_l[b] = leaves[l];
            printf(" %10.1f %10.1f %10.1f %9.1f |", bm, em, tot[b][l], (double)reads[b][l] / (double)vs.count);
        }
        printf("\n");
    }
    for (int b = 0; b < 2; b++)
        printf("%s: best fixed threshold %d (%.1f ms); T_auto = %d (%.1f ms) reaches %.1f%% of its speed\n",
               b ? "vvh" : "linear", best_l[b], best[b], used[b][NL - 1], tot[b][NL - 1],
               100.0 * best[b] / tot[b][NL - 1]);
    printf("contributing per pixel: %.2f\n", (double)contrib[0][0] / (double)vs.count);
    if (diff) {
        printf("\nfootprint radius histogram (before the r_max clamp), bin width r_max/14 = %g:\n",
               (double)(radius / 14.f));
        for (int k = 0; k < PGI_FOOTPRINT_BINS; k++) {
            double lo = k * (double)radius / 14.0;
            if (k < PGI_FOOTPRINT_BINS - 1)
                printf("  %7.4f - %7.4f %9llu\n", lo, lo + radius / 14.0, (unsigned long long)hist[k]);
            else printf("  > %-15.4f %9llu\n", lo, (unsigned long long)hist[k]);
        }
    }
    free(out);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
    return 0;
}
