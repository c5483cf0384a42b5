/* photongi-bench: the foundation benchmark (not part of the tests).
 *
 * Renders each scene at 1920x1080 with 200k stored photons for every
 * registered estimator: one warm-up frame, then the median of N frames for
 * every pass and sub-pass, photon reads vs contributing, ray throughput and,
 * on a GPU, the device's memory. Writes a CSV and prints a table. Fixed seed;
 * thread count from --threads (default all). --photons and --threads take
 * lists (every combination is measured); --device vulkan runs the GPU frame
 * (default estimators: those with a GPU version).
 *
 *   photongi-bench [--scenes sibenik,crytek-sponza] [--estimators a,b] [--frames 5]
 *                  [--photons 200000[,1000000...]] [--size 1920x1080] [--radius R]
 *                  [--threads T[,T...]] [--device cpu|gpu|vulkan[:N]] [--max-seconds S]
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

#include "../apps/common/device.h"
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

/* Parses a comma-separated list of positive integers (photons, threads) into v; the count, or 0 when an item is
 * not a number or there are more than `cap`. */
static int parse_list(const char *list, double *v, int cap) {
    int n = 0;
    for (const char *p = list;;) {
        if (*p < '0' || *p > '9') return 0; /* no sign, no empty item, no trailing comma */
        char *end = NULL;
        unsigned long long x = strtoull(p, &end, 10);
        if (x > UINT32_MAX || n == cap || (*end != ',' && *end != 0)) return 0;
        v[n++] = (double)x;
        if (!*end) return n;
        p = end + 1;
    }
}

/* Sum of the device's buffers (memory_bytes entries named gpu_*; docs/gpu.md). */
static double gpu_bytes(const pgi_frame_stats *fs) {
    double b = 0.0;
    for (int k = 0; k < fs->memory_count; k++)
        if (strncmp(fs->memory_bytes[k].name, "gpu_", 4) == 0) b += fs->memory_bytes[k].value;
    return b;
}

/* Per-pass times of a config's frames, by pass name, for their medians. */
typedef struct pass_times {
    int n;
    const char *name[PGI_MAX_STAT_ENTRIES];
    double v[PGI_MAX_STAT_ENTRIES][MAXF];
    int count[PGI_MAX_STAT_ENTRIES];
} pass_times;

static void pass_times_add(pass_times *pt, const pgi_frame_stats *fs) {
    int added[PGI_MAX_STAT_ENTRIES] = {0}; /* a pass listed twice in a frame counts once, summed */
    for (int k = 0; k < fs->pass_count; k++) {
        int j = 0;
        while (j < pt->n && strcmp(pt->name[j], fs->passes_ms[k].name) != 0) j++;
        if (j == pt->n) {
            if (pt->n == PGI_MAX_STAT_ENTRIES) continue;
            pt->name[pt->n++] = fs->passes_ms[k].name; /* static strings of the library */
        }
        if (added[j]) pt->v[j][pt->count[j] - 1] += fs->passes_ms[k].value;
        else if (pt->count[j] < MAXF) {
            pt->v[j][pt->count[j]++] = fs->passes_ms[k].value;
            added[j] = 1;
        }
    }
}

/* The default mode: every scene x photon count x thread count x estimator (in that nesting, so that the
 * small photon counts of every estimator come first), a warm-up frame, then the median of `frames` frames
 * of every pass and of each estimator sub-pass. `max_seconds` > 0 stops taking frames of a config once its
 * frames (warm-up included) have taken that long, keeping at least one: the CSV's `frames` column says how
 * many were measured. Each row is written and flushed as soon as it is measured. */
static int run_frames(const char *scenes, const char *ests, int frames, const char *photons_arg, int width, int height,
                      float radius, const char *threads_arg, int brute, const pgi_render_desc *dev, double max_seconds,
                      const char *csv_path) {
    double plist[16], tlist[16];
    int np = parse_list(photons_arg, plist, 16), nt = parse_list(threads_arg, tlist, 16);
    if (!np || !nt) {
        fprintf(stderr, "photongi-bench: --photons and --threads take a whole number or a comma-separated list of up "
                        "to 16 (1,2,4)\n");
        return 2;
    }
    char gpu_ests[256] = "";
    if (ests && strcmp(ests, "default") == 0) ests = PGI_DEFAULT_ESTIMATOR; /* the renderer's */
    if (dev->device == PGI_DEVICE_VULKAN && !ests) {                        /* every estimator with a GPU version */
        char raw[256];
        pgi_device_estimators(raw, sizeof raw);
        size_t o = 0;
        for (const char *c = raw; *c && o + 1 < sizeof gpu_ests; c++)
            if (*c != ' ') gpu_ests[o++] = *c;
        gpu_ests[o] = 0;
        ests = gpu_ests;
    }
    size_t named = 0;
    for (size_t e = 0; e < pgi_estimator_count(); e++) named += in_list(ests, pgi_estimator_at(e)->name) != 0;
    if (!named) {
        fprintf(stderr, "photongi-bench: no estimator named in --estimators '%s' (photongi estimators lists them)\n",
                ests ? ests : "");
        return 2;
    }
    FILE *csv = open_csv(csv_path);
    if (!csv) return 1;
    fprintf(csv, "scene,estimator,width,height,threads,photons,emitted,radius,frames,view_ms,trace_ms,build_ms,"
                 "estimate_ms,direct_ms,total_ms,primary_mrays_s,photon_mrays_s,reads,contributing,"
                 "contributing_ratio,estimator_bytes,passes,device,gpu_bytes,peak_rss_bytes\n");
    fflush(csv);
    printf("%-14s %-15s %8s %3s %8s %8s %8s %9s %8s %8s | %8s %8s | %12s %11s %6s\n", "scene", "estimator", "photons",
           "thr", "view", "trace", "build", "estimate", "direct", "total", "prim MR/s", "phot MR/s", "reads", "contrib",
           "ratio");
    int failures = 0;
    const char *device_seen = NULL;
    char buf[4096];
    snprintf(buf, sizeof buf, "%s", scenes);
    char *save = NULL; /* the library may use strtok itself */
    for (char *sc = strtok_r(buf, ",", &save); sc; sc = strtok_r(NULL, ",", &save)) {
        pgi_scene *scene;
        pgi_renderer *r;
        if (!open_scene(sc, &scene, &r)) {
            failures++;
            continue;
        }
        for (int ip = 0; ip < np; ip++)
            for (int it = 0; it < nt; it++)
                for (size_t e = 0; e < pgi_estimator_count(); e++) {
                    const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
                    if (!in_list(ests, vt->name)) continue;
                    if (vt->oracle && !brute) {
                        printf("%-14s %-15s skipped: O(photons x pixels) oracle (--include-brute)\n", sc, vt->name);
                        continue;
                    }
                    pgi_render_desc d = *dev;
                    d.estimator = vt->name;
                    d.photons = (uint32_t)plist[ip];
                    d.width = width;
                    d.height = height;
                    d.threads = (int)tlist[it];
                    d.seed = 1;
                    d.radius = radius;
                    static double t[6][MAXF], prim[MAXF], phot[MAXF];
                    static pass_times pt;
                    memset(&pt, 0, sizeof pt);
                    pgi_frame_stats fs;
                    pgi_image img = {0};
                    int ok = 1, n = 0;
                    double t0 = omp_get_wtime();
                    for (int f = -1; f < frames; f++) {
                        if (pgi_renderer_render(r, &d, &img, &fs) != PGI_OK) {
                            fprintf(stderr, "photongi-bench: %s/%s, %u photons: %s\n", sc, vt->name, d.photons,
                                    pgi_last_error());
                            ok = 0;
                            break;
                        }
                        if (f >= 0) {
                            t[0][n] = fs.view_ms;
                            t[1][n] = fs.trace_ms;
                            t[2][n] = fs.build_ms;
                            t[3][n] = fs.estimate_ms;
                            t[4][n] = fs.direct_ms;
                            t[5][n] = fs.total_ms;
                            prim[n] = (double)fs.primary_rays / (fs.view_ms * 1e3);
                            phot[n] = (double)fs.photon_rays / (fs.trace_ms * 1e3);
                            pass_times_add(&pt, &fs);
                            n++;
                        }
                        if (max_seconds > 0.0 && n > 0 && omp_get_wtime() - t0 > max_seconds) break;
                    }
                    pgi_image_free(&img);
                    if (!ok) {
                        failures++;
                        fflush(stderr);
                        continue;
                    }
                    if (!device_seen) {
                        device_seen = fs.device;
                        printf("device: %s\n", fs.device ? fs.device : "cpu");
                    }
                    double m[6];
                    for (int k = 0; k < 6; k++) m[k] = median(t[k], n);
                    double mp = median(prim, n), mt = median(phot, n);
                    double ratio = fs.reads ? (double)fs.contributing / (double)fs.reads : 0.0;
                    double est_bytes = estimator_bytes(&fs);
                    printf("%-14s %-15s %8u %3d %8.1f %8.1f %8.1f %9.1f %8.1f %8.1f | %8.1f %8.1f | %12llu %11llu "
                           "%5.1f%%%s\n",
                           sc, vt->name, fs.settings.photons, fs.threads, m[0], m[1], m[2], m[3], m[4], m[5], mp, mt,
                           (unsigned long long)fs.reads, (unsigned long long)fs.contributing, 100.0 * ratio,
                           n < frames ? " (fewer frames: --max-seconds)" : "");
                    fprintf(csv,
                            "%s,%s,%d,%d,%d,%llu,%llu,%g,%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%llu,%llu,%.6f,"
                            "%.0f,",
                            sc, vt->name, fs.width, fs.height, fs.threads, (unsigned long long)fs.photons_stored,
                            (unsigned long long)fs.photons_emitted, (double)fs.radius, n, m[0], m[1], m[2], m[3], m[4],
                            m[5], mp, mt, (unsigned long long)fs.reads, (unsigned long long)fs.contributing, ratio,
                            est_bytes);
                    for (int k = 0; k < pt.n; k++)
                        fprintf(csv, "%s%s=%.3f", k ? ";" : "", pt.name[k], median(pt.v[k], pt.count[k]));
                    fprintf(csv, ",\"%s\",%.0f,%llu\n", fs.device ? fs.device : "cpu", gpu_bytes(&fs),
                            (unsigned long long)fs.memory_peak_rss);
                    fflush(csv);
                    fflush(stdout);
                }
        pgi_renderer_destroy(r);
        pgi_scene_destroy(scene);
    }
    fclose(csv);
    printf("(medians of %d frames after a warm-up, milliseconds; CSV: %s, with each sub-pass's median)\n", frames,
           csv_path);
    return failures ? 1 : 0;
}

int main(int argc, char **argv) {
    const char *scenes = "sibenik,crytek-sponza", *ests = NULL, *csv_path = "bench/results/bench.csv";
    int frames = 5, width = 1920, height = 1080, threads = 0, brute = 0;
    unsigned photons = 200000;
    float radius = 0.f;
    int frames_set = 0;
    int table1 = 0, knn = 50, limits = 0, mirrors = 0, scenes_set = 0, size_set = 0, photons_set = 0;
    const char *photons_arg = NULL, *threads_arg = NULL;
    double max_seconds = 0.0;
    pgi_render_desc dev = {0};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            printf("usage: photongi-bench [--scenes a,b] [--estimators a,b] [--frames N] [--photons N[,N...]]\n"
                   "                      [--size WxH] [--radius R] [--threads T[,T...]] [--device D]\n"
                   "                      [--max-seconds S] [--csv FILE] [--include-brute]\n"
                   "Median of N frames after a warm-up; per-pass ms, reads vs contributing, Mrays/s.\n"
                   "Every scene x photon count x thread count x estimator, rows written as measured;\n"
                   "--estimators default: the renderer's default estimator.\n"
                   "--device cpu|gpu|vulkan[:N]: where the frame runs (default cpu); on a Vulkan device\n"
                   "the default estimators are those with a GPU version, and the CSV has the device's\n"
                   "memory (gpu_bytes). --max-seconds S: stop a config's frames once they took S seconds\n"
                   "(at least one is kept; the CSV's frames column says how many).\n"
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
        else if (strcmp(a, "--threads") == 0) threads = atoi(v), threads_arg = v;
        else if (strcmp(a, "--max-seconds") == 0) max_seconds = strtod(v, NULL);
        else if (strcmp(a, "--device") == 0) {
            char err[256];
            if (!app_parse_device(v, &dev, err, sizeof err)) {
                fprintf(stderr, "photongi-bench: %s\n", err);
                return 2;
            }
        } else if (strcmp(a, "--csv") == 0) csv_path = v;
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
    return run_frames(scenes, ests, frames, photons_set ? photons_arg : "200000", width, height, radius,
                      threads_arg ? threads_arg : "0", brute, &dev, max_seconds, csv_path);
}
