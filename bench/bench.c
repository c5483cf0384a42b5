/* photongi-bench: the foundation benchmark (not part of the tests).
 *
 * Renders each scene at 1920x1080 with 200k stored photons for every
 * registered estimator: one warm-up frame, then the median of N frames for
 * every pass, photon reads vs contributing, and ray throughput. Writes a CSV
 * and prints a table. Fixed seed; thread count from --threads (default all).
 *
 *   photongi-bench [--scenes sibenik,crytek-sponza] [--estimators a,b] [--frames 5]
 *                  [--photons 200000] [--size 1920x1080] [--radius R] [--threads T]
 *                  [--csv bench/results/bench.csv] [--include-brute]
 *   photongi-bench --table1 [--knn K] [...]   the tiled paper's Table 1 protocol
 *                  (estimate time, tests vs contributing of every gather/scatter method and
 *                  bounds25d with 4/8/16 vertices) to bench/results/table1.csv
 *   photongi-bench --limits [...]   each ray pass (view, trace, direct) next to raw Embree
 *                  on the same captured rays, every call style (bench/limits.c); default
 *                  sibenik, 1280x720, to bench/results/limits.csv
 *   photongi-bench --mirrors [...]  build + estimate time and memory of each estimator on the
 *                  built-in cornell-mirrors scene with and without its mirrors (bench/mirrors.c)
 */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "photongi/photongi.h"

#include "bench_common.h"
#include "limits.h"
#include "mirrors.h"

#define MAXF 64

static int in_list(const char *list, const char *name) {
    if (!list) return 1;
    size_t n = strlen(name);
    for (const char *p = list; *p;) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == n && strncmp(p, name, n) == 0) return 1;
        if (!e) break;
        p = e + 1;
    }
    return 0;
}

/* The tiled paper's Table 1 protocol (--table1): estimate time of
 * every gather/scatter method on this branch, and photon/pixel tests vs
 * contributing ones (wasted tests of the 3D vs 2.5D bounds). Medians of
 * `frames` frames after a warm-up, one run. */
typedef struct {
    const char *label, *estimator;
    int knn, polygon;
} t1_config;

static int run_table1(const char *scenes, int frames, unsigned photons, int width, int height, float radius,
                      int threads, int knn, const char *csv_path) {
    const t1_config cfg[] = {
        {"hashgrid", "hashgrid", 0, 0},     {"tiled", "tiled", 0, 0},
        {"kdtree-range", "kdtree", 0, 0},   {"kdtree-knn", "kdtree", knn, 0},
        {"bounds3d", "bounds3d", 0, 0},     {"bounds25d-4", "bounds25d", 0, 4},
        {"bounds25d-8", "bounds25d", 0, 8}, {"bounds25d-16", "bounds25d", 0, 16},
    };
    FILE *csv = open_csv(csv_path);
    if (!csv) return 1;
    fprintf(csv, "scene,method,width,height,threads,photons,radius,frames,build_ms,estimate_ms,tests,contributing,"
                 "wasted_ratio,covered_or_nodes,passes\n");
    printf("%-14s %-13s %9s %9s %13s %12s %7s %13s\n", "scene", "method", "build", "estimate", "tests", "contrib",
           "wasted", "covered/nodes");
    char buf[4096];
    snprintf(buf, sizeof buf, "%s", scenes);
    for (char *sc = strtok(buf, ","); sc; sc = strtok(NULL, ",")) {
        pgi_scene *scene;
        pgi_renderer *r;
        if (!open_scene(sc, &scene, &r)) continue;
        for (size_t c = 0; c < sizeof cfg / sizeof cfg[0]; c++) {
            pgi_render_desc d = {.estimator = cfg[c].estimator,
                                 .photons = photons,
                                 .width = width,
                                 .height = height,
                                 .threads = threads,
                                 .seed = 1,
                                 .radius = radius,
                                 .direct_samples = 1,
                                 .est = {.kdtree.knn = cfg[c].knn, .bounds.polygon = cfg[c].polygon}};
            double tb[MAXF], te[MAXF];
            pgi_frame_stats fs;
            pgi_image img = {0};
            int ok = 1;
            for (int f = -1; f < frames; f++) {
                if (pgi_renderer_render(r, &d, &img, &fs) != PGI_OK) {
                    fprintf(stderr, "photongi-bench: %s/%s: %s\n", sc, cfg[c].label, pgi_last_error());
                    ok = 0;
                    break;
                }
                if (f >= 0) tb[f] = fs.build_ms, te[f] = fs.estimate_ms;
            }
            pgi_image_free(&img);
            if (!ok) continue;
            double mb = median(tb, frames), me = median(te, frames);
            double wasted = fs.reads ? 1.0 - (double)fs.contributing / (double)fs.reads : 0.0;
            printf("%-14s %-13s %9.1f %9.1f %13llu %12llu %6.1f%% %13llu\n", sc, cfg[c].label, mb, me,
                   (unsigned long long)fs.reads, (unsigned long long)fs.contributing, 100.0 * wasted,
                   (unsigned long long)fs.nodes_visited);
            fprintf(csv, "%s,%s,%d,%d,%d,%llu,%g,%d,%.3f,%.3f,%llu,%llu,%.6f,%llu,", sc, cfg[c].label, fs.width,
                    fs.height, fs.threads, (unsigned long long)fs.photons_stored, (double)fs.radius, frames, mb, me,
                    (unsigned long long)fs.reads, (unsigned long long)fs.contributing, wasted,
                    (unsigned long long)fs.nodes_visited);
            for (int k = 0; k < fs.pass_count; k++)
                fprintf(csv, "%s%s=%.3f", k ? ";" : "", fs.passes_ms[k].name, fs.passes_ms[k].value);
            fprintf(csv, "\n");
            fflush(stdout);
        }
        pgi_renderer_destroy(r);
        pgi_scene_destroy(scene);
    }
    fclose(csv);
    printf("(medians of %d frames after a warm-up, ms; tests = photon/pixel tests (reads), wasted = 1 - contributing/"
           "tests; covered = pixels inside a bound (bounds*), nodes visited (kdtree), probes (hashgrid), tile tests "
           "(tiled); CSV: %s)\n",
           frames, csv_path);
    return 0;
}

int main(int argc, char **argv) {
    const char *scenes = "sibenik,crytek-sponza", *ests = NULL, *csv_path = "bench/results/bench.csv";
    int frames = 5, width = 1920, height = 1080, threads = 0, brute = 0;
    unsigned photons = 200000;
    float radius = 0.f;
    int frames_set = 0;
    int table1 = 0, knn = 50, limits = 0, mirrors = 0, scenes_set = 0, size_set = 0, photons_set = 0;
    const char *photons_arg = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            printf("usage: photongi-bench [--scenes a,b] [--estimators a,b] [--frames N] [--photons N]\n"
                   "                      [--size WxH] [--radius R] [--threads T] [--csv FILE] [--include-brute]\n"
                   "Median of N frames after a warm-up; per-pass ms, reads vs contributing, Mrays/s.\n"
                   "brute is skipped unless --include-brute (O(photons x pixels)).\n"
                   "--table1 [--knn K]: Table 1 protocol of the tiled paper (estimate time, tests vs\n"
                   "contributing) for hashgrid, tiled, kdtree range/k-NN, bounds3d, bounds25d 4/8/16.\n"
                   "--limits: each ray pass (view, trace, direct) next to raw Embree on the same rays\n"
                   "(captured from one frame, replayed in every call style); default --scenes sibenik\n"
                   "--size 1280x720, the first of --estimators (default: the renderer's), CSV\n"
                   "bench/results/limits.csv.\n"
                   "--mirrors: the built-in cornell-mirrors scene as it is and with its mirrors and\n"
                   "glass made Lambertian: build + estimate time and estimator memory next to\n"
                   "hashgrid's; --photons takes a list (default 1000000,5000000), the radius shrinks\n"
                   "as 1/sqrt(photons) from the scene's 0.05 at 200k unless --radius; default\n"
                   "--estimators hashgrid,tiled,cluster-trivial, --size 512x512, --frames 3, CSV\n"
                   "bench/results/mirrors.csv.\n");
            return 0;
        }
        if (strcmp(a, "--limits") == 0) {
            limits = 1;
            continue;
        }
        if (strcmp(a, "--mirrors") == 0) {
            mirrors = 1;
            continue;
        }
        if (strcmp(a, "--table1") == 0) {
            table1 = 1;
            continue;
        }
        if (strcmp(a, "--knn") == 0 && v) {
            knn = atoi(argv[++i]);
            continue;
        }
        if (strcmp(a, "--include-brute") == 0) {
            brute = 1;
            continue;
        }
        if (!v) {
            fprintf(stderr, "photongi-bench: %s needs a value\n", a);
            return 2;
        }
        i++;
        if (strcmp(a, "--scenes") == 0) scenes = v, scenes_set = 1;
        else if (strcmp(a, "--estimators") == 0) ests = v;
        else if (strcmp(a, "--frames") == 0) frames = atoi(v), frames_set = 1;
        else if (strcmp(a, "--photons") == 0) {
            photons = (unsigned)strtoul(v, NULL, 10);
            photons_arg = v;
            photons_set = 1;
        } else if (strcmp(a, "--size") == 0) {
            if (sscanf(v, "%dx%d", &width, &height) != 2) {
                fprintf(stderr, "photongi-bench: --size needs WxH\n");
                return 2;
            }
            size_set = 1;
        } else if (strcmp(a, "--radius") == 0) radius = strtof(v, NULL);
        else if (strcmp(a, "--threads") == 0) threads = atoi(v);
        else if (strcmp(a, "--csv") == 0) csv_path = v;
        else {
            fprintf(stderr, "photongi-bench: unknown option %s\n", a);
            return 2;
        }
    }
    if (frames < 1 || frames > MAXF) {
        fprintf(stderr, "photongi-bench: --frames must be 1..%d\n", MAXF);
        return 2;
    }
    if (mirrors)
        return pgi_bench_mirrors(photons_set ? photons_arg : "1000000,5000000",
                                 ests ? ests : "hashgrid,tiled,cluster-trivial", frames_set ? frames : 3,
                                 size_set ? width : 512, size_set ? height : 512, radius, threads,
                                 strcmp(csv_path, "bench/results/bench.csv") == 0 ? "bench/results/mirrors.csv"
                                                                                  : csv_path);
    if (limits) {
        char est[64] = "";
        if (ests) snprintf(est, sizeof est, "%.*s", (int)strcspn(ests, ","), ests);
        return pgi_bench_limits(scenes_set ? scenes : "sibenik", est[0] ? est : NULL, frames, photons,
                                size_set ? width : 1280, size_set ? height : 720, radius, threads,
                                strcmp(csv_path, "bench/results/bench.csv") == 0 ? "bench/results/limits.csv"
                                                                                 : csv_path);
    }
    if (table1)
        return run_table1(scenes, frames, photons, width, height, radius, threads, knn,
                          strcmp(csv_path, "bench/results/bench.csv") == 0 ? "bench/results/table1.csv" : csv_path);
    FILE *csv = open_csv(csv_path);
    if (!csv) return 1;
    fprintf(csv, "scene,estimator,width,height,threads,photons,emitted,radius,frames,view_ms,trace_ms,build_ms,"
                 "estimate_ms,direct_ms,total_ms,primary_mrays_s,photon_mrays_s,reads,contributing,"
                 "contributing_ratio,estimator_bytes,passes\n");
    printf("%-14s %-10s %8s %8s %8s %9s %8s %8s | %8s %8s | %12s %11s %6s\n", "scene", "estimator", "view", "trace",
           "build", "estimate", "direct", "total", "prim MR/s", "phot MR/s", "reads", "contrib", "ratio");
    char buf[4096];
    snprintf(buf, sizeof buf, "%s", scenes);
    for (char *sc = strtok(buf, ","); sc; sc = strtok(NULL, ",")) {
        pgi_scene *scene;
        pgi_renderer *r;
        if (!open_scene(sc, &scene, &r)) continue;
        for (size_t e = 0; e < pgi_estimator_count(); e++) {
            const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
            if (!in_list(ests, vt->name)) continue;
            if (vt->oracle && !brute) {
                printf("%-14s %-10s skipped: O(photons x pixels) oracle (--include-brute)\n", sc, vt->name);
                continue;
            }
            pgi_render_desc d = {.estimator = vt->name,
                                 .photons = photons,
                                 .width = width,
                                 .height = height,
                                 .threads = threads,
                                 .seed = 1,
                                 .radius = radius};
            double t[6][MAXF], prim[MAXF], phot[MAXF];
            pgi_frame_stats fs;
            pgi_image img = {0};
            int ok = 1;
            for (int f = -1; f < frames && ok; f++) {
                if (pgi_renderer_render(r, &d, &img, &fs) != PGI_OK) {
                    fprintf(stderr, "photongi-bench: %s/%s: %s\n", sc, vt->name, pgi_last_error());
                    ok = 0;
                    break;
                }
                if (f < 0) continue; /* warm-up */
                t[0][f] = fs.view_ms;
                t[1][f] = fs.trace_ms;
                t[2][f] = fs.build_ms;
                t[3][f] = fs.estimate_ms;
                t[4][f] = fs.direct_ms;
                t[5][f] = fs.total_ms;
                prim[f] = (double)fs.primary_rays / (fs.view_ms * 1e3);
                phot[f] = (double)fs.photon_rays / (fs.trace_ms * 1e3);
            }
            pgi_image_free(&img);
            if (!ok) continue;
            double m[6];
            for (int k = 0; k < 6; k++) m[k] = median(t[k], frames);
            double mp = median(prim, frames), mt = median(phot, frames);
            double ratio = fs.reads ? (double)fs.contributing / (double)fs.reads : 0.0;
            double est_bytes = estimator_bytes(&fs);
            printf("%-14s %-10s %8.1f %8.1f %8.1f %9.1f %8.1f %8.1f | %8.1f %8.1f | %12llu %11llu %5.1f%%\n", sc,
                   vt->name, m[0], m[1], m[2], m[3], m[4], m[5], mp, mt, (unsigned long long)fs.reads,
                   (unsigned long long)fs.contributing, 100.0 * ratio);
            fprintf(csv, "%s,%s,%d,%d,%d,%llu,%llu,%g,%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%llu,%llu,%.6f,%.0f,",
                    sc, vt->name, fs.width, fs.height, fs.threads, (unsigned long long)fs.photons_stored,
                    (unsigned long long)fs.photons_emitted, (double)fs.radius, frames, m[0], m[1], m[2], m[3], m[4],
                    m[5], mp, mt, (unsigned long long)fs.reads, (unsigned long long)fs.contributing, ratio, est_bytes);
            for (int k = 0; k < fs.pass_count; k++)
                fprintf(csv, "%s%s=%.3f", k ? ";" : "", fs.passes_ms[k].name, fs.passes_ms[k].value);
            fprintf(csv, "\n");
            fflush(stdout);
        }
        pgi_renderer_destroy(r);
        pgi_scene_destroy(scene);
    }
    fclose(csv);
    printf("(medians of %d frames after a warm-up, milliseconds; CSV: %s; per-pass times of the last frame in the "
           "CSV)\n",
           frames, csv_path);
    return 0;
}
