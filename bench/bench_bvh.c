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

#include "photon/photon.h"
#include "scene/scene_internal.h"
#include "view/view.h"

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
    if (threads > 0) omp_set_num_threads(threads);

    pgi_scene *s;
    if (pgi_scene_load(scene_name, &s)) return die("cannot load scene");
    if (!(radius > 0.f)) radius = s->defaults.radius > 0.f ? s->defaults.radius : 0.02f * v3_len(v3_sub(v3_load(s->bmax), v3_load(s->bmin)));
    pgi__rt *rt;
    if (pgi__rt_create(s, &rt)) return die("ray tracing scene");
    pgi_camera cam;
    const pgi_camera_def *cd = &s->cams[0];
    pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, width, height);
    pgi_view_samples vs;
    if (pgi_view_samples_alloc(&vs, width, height)) return die("view samples");
    float *emit = malloc(3 * vs.count * sizeof(float)), *out = malloc(3 * vs.count * sizeof(float));
    uint64_t rays;
    if (!emit || !out || pgi__view_build(s, rt, &cam, 1, &vs, emit, &rays)) return die("view");
    pgi_photons ph;
    if (pgi_photons_alloc(&ph, photons)) return die("photons");
    float *fp = NULL;
    uint64_t hist[PGI_FOOTPRINT_BINS] = {0};
    pgi__trace_desc td = {.photons = photons, .bounces = s->defaults.bounces > 0 ? s->defaults.bounces : 4, .seed = 1};
    if (diff) {
        fp = malloc(7 * (size_t)photons * sizeof(float));
        if (!fp) return 1;
        ph.radius = fp;
        float **ax[] = {&ph.sax, &ph.say, &ph.saz, &ph.sbx, &ph.sby, &ph.sbz};
        for (int k = 0; k < 6; k++) *ax[k] = fp + (size_t)(k + 1) * photons;
        td.radius_policy = PGI_RADIUS_DIFFERENTIALS;
        td.r_max = radius;
        td.r_min = radius / 8.f;
        td.smoothing = smoothing;
        td.footprint_hist = hist;
    }
    pgi__trace_scratch scr = {0};
    double t0 = pgi__now_ms();
    if (pgi__photons_trace(s, rt, &td, &ph, &scr, &rays)) return die("trace");
    double trace_ms = pgi__now_ms() - t0;
    double area = 0.0;
    for (size_t t = 0; t < s->ntris; t++) {
        const uint32_t *v = s->tri + 3 * t;
        pgi__v3 p0 = pgi__scene_vertex(s, v[0]), p1 = pgi__scene_vertex(s, v[1]), p2 = pgi__scene_vertex(s, v[2]);
        area += 0.5 * (double)v3_len(v3_cross(v3_sub(p1, p0), v3_sub(p2, p0)));
    }
    double fp_area = 0.0;
    for (size_t j = 0; j < ph.count; j++) {
        double r = diff ? ph.radius[j] : radius;
        fp_area += 3.14159265358979 * r * r;
    }
    printf("footprint area / scene area = %.3f\n", fp_area / area);
    printf("scene %s, %dx%d, %zu photons (%s footprints, r%s = %g), scene area %.1f, %d threads, %d frames, "
           "trace %.0f ms\n",
           scene_name, width, height, ph.count, policy, diff ? "_max" : "", (double)radius, area,
           omp_get_max_threads(), frames, trace_ms);

    static const int leaves[NL] = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 0};
    static double bms[2][NL][MAXF], ems[2][NL][MAXF];
    static int used[2][NL];
    static uint64_t reads[2][NL], contrib[2][NL];
    for (int f = 0; f < frames; f++)
        for (int b = 0; b < 2; b++)
            for (int l = 0; l < NL; l++) {
                pgi_estimator_desc d = {.radius = radius, .bvh_build = b, .leaf_size = leaves[l],
                                        .scene_area = (float)area};
                pgi_estimator *e;
                if (pgi_estimator_create("bvh", &d, &e)) return die("create");
                pgi_estimate_args a = {&ph, &vs, &cam, out};
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
            if (k < PGI_FOOTPRINT_BINS - 1) printf("  %7.4f - %7.4f %9llu\n", lo, lo + radius / 14.0, (unsigned long long)hist[k]);
            else printf("  > %-15.4f %9llu\n", lo, (unsigned long long)hist[k]);
        }
    }
    free(fp);
    pgi_photons_free(&ph);
    pgi__trace_scratch_free(&scr);
    pgi_view_samples_free(&vs);
    free(emit);
    free(out);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(s);
    return 0;
}
