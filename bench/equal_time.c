/* Equal-time comparison: each estimator's progressive mode and the path tracer get the same
 * wall-time budgets, and the image each has after a budget is compared with a converged
 * path-traced reference (PSNR, SSIM and FLIP on the tone-mapped image, relMSE on radiance).
 * The image at budget B is the last one finished within B (the clock runs only while
 * rendering: the metrics are not charged); a method whose first step takes longer than B
 * reports its first image with its own time. Every sample of every method looks through its
 * own point of the pixel, so all converge to the same box-filtered pixel integral, which is
 * what the reference is (a different seed than the path tracer under test).
 *
 *   photongi-bench-equal-time [--scene S] [--size WxH] [--photons N] [--budgets 0.25,1,4,16]
 *       [--estimators a,b | all | exact] [--ref-spp N] [--ref FILE.exr] [--threads T] [--csv FILE]
 *       [--radius R] [--emission-variants]
 *
 * --emission-variants runs each estimator four times: uniform emission storing every photon (its
 * plain name), guided emission (+guided), storing only the photons in view (+view, needs --radius)
 * and both (+guided+view); docs/emission.md.
 *
 * The reference is cached in $PHOTONGI_CACHE (default ~/.cache/photongi) by scene, size,
 * bounces and samples. bench/equal_time.sh runs it on scenes and plots the CSV (gnuplot). */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "photongi/estimator.h"
#include "photongi/metrics.h"
#include "photongi/photongi.h"
#include "photongi/reference.h"

#define MAX_BUDGETS 16
#define PATHTRACER "pathtracer"

static double now_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

typedef struct run_ctx {
    const pgi_scene *scene;
    const char *scene_name;
    const pgi_image *ref;
    float exposure;
    int w, h, threads;
    uint32_t photons;
    uint64_t ref_spp;
    FILE *csv;
} run_ctx;

/* Compares one image with the reference and writes a row. */
static int report(const run_ctx *c, const char *method, double budget, double t, long steps, const pgi_image *img) {
    pgi_metrics m;
    if (pgi_metrics_compute(img, c->ref, c->exposure, &m)) {
        fprintf(stderr, "photongi-bench-equal-time: %s\n", pgi_last_error());
        return 0;
    }
    char psnr[32];
    if (isinf(m.psnr)) snprintf(psnr, sizeof psnr, "inf");
    else snprintf(psnr, sizeof psnr, "%.3f", m.psnr);
    fprintf(c->csv, "%s,%s,%g,%.4f,%ld,%s,%.5f,%.6f,%.6g,%d,%d,%u,%llu\n", c->scene_name, method, budget, t, steps,
            psnr, m.ssim, m.flip.mean, m.relmse, c->w, c->h, c->photons, (unsigned long long)c->ref_spp);
    fflush(c->csv);
    fprintf(stderr, "  %-16s %6.2f s: %6.2f s, %5ld %s  PSNR %s  SSIM %.4f  FLIP %.4f  relMSE %.4g\n", method, budget,
            t, steps, strcmp(method, PATHTRACER) ? "frames" : "spp", psnr, m.ssim, m.flip.mean, m.relmse);
    return 1;
}

/* Runs one method until every budget is reported. step() renders one more frame (one more sample
 * a pixel for the path tracer) into img. */
typedef int (*step_fn)(void *state, pgi_image *img);

static int run_method(const run_ctx *c, const char *method, step_fn step, void *state, const double *budgets, int nb) {
    pgi_image img = {0}, prev = {c->w, c->h, malloc((size_t)c->w * c->h * 3 * sizeof(float))};
    if (!prev.rgb) return 0;
    double t_prev = 0.0, t = 0.0;
    long steps = 0;
    int b = 0, ok = 1;
    while (ok && b < nb) {
        double t0 = now_s();
        if (!step(state, &img)) {
            ok = 0;
            break;
        }
        t += now_s() - t0;
        steps++;
        for (; b < nb && t > budgets[b]; b++) {
            /* the image before this step was the last one within the budget */
            ok = steps > 1 ? report(c, method, budgets[b], t_prev, steps - 1, &prev)
                           : report(c, method, budgets[b], t, steps, &img);
            if (!ok) break;
        }
        memcpy(prev.rgb, img.rgb, (size_t)c->w * c->h * 3 * sizeof(float));
        t_prev = t;
    }
    pgi_image_free(&img);
    pgi_image_free(&prev);
    return ok;
}

typedef struct prog_state {
    pgi_progressive *p;
    pgi_render_desc d;
} prog_state;

static int prog_step(void *state, pgi_image *img) {
    prog_state *s = state;
    pgi_frame_stats fs;
    if (pgi_progressive_step(s->p, &s->d, img, &fs)) {
        fprintf(stderr, "photongi-bench-equal-time: %s: %s\n", s->d.estimator, pgi_last_error());
        return 0;
    }
    return 1;
}

typedef struct pt_state {
    const pgi_scene *scene;
    pgi_reference_desc d;
    uint64_t spp;
} pt_state;

static int pt_step(void *state, pgi_image *img) {
    pt_state *s = state;
    if (pgi_reference_render(s->scene, &s->d, img, &s->spp)) {
        fprintf(stderr, "photongi-bench-equal-time: path tracer: %s\n", pgi_last_error());
        return 0;
    }
    return 1;
}

static int ref_progress(void *user, uint64_t done, uint64_t total, double elapsed_ms) {
    (void)user;
    if (done == total || done % 16 == 0)
        fprintf(stderr, "\r  reference: %llu/%llu spp, %.0f s", (unsigned long long)done, (unsigned long long)total,
                elapsed_ms / 1000.0);
    if (done == total) fputc('\n', stderr);
    return 0;
}

/* The reference: read from --ref, else from the cache, else path-traced and cached. */
static int load_reference(const run_ctx *c, const char *ref_path, int bounces, pgi_image *ref) {
    if (ref_path) {
        if (pgi_image_read(ref_path, ref, NULL)) {
            fprintf(stderr, "photongi-bench-equal-time: %s\n", pgi_last_error());
            return 0;
        }
        if (ref->width != c->w || ref->height != c->h) {
            fprintf(stderr, "photongi-bench-equal-time: %s is %dx%d, the runs %dx%d\n", ref_path, ref->width,
                    ref->height, c->w, c->h);
            return 0;
        }
        return 1;
    }
    const char *cache = getenv("PHOTONGI_CACHE"), *home = getenv("HOME");
    char dir[1024], path[1200], name[128];
    if (cache && *cache) snprintf(dir, sizeof dir, "%s", cache);
    else snprintf(dir, sizeof dir, "%s/.cache/photongi", home ? home : ".");
    size_t k = 0;
    for (const char *p = c->scene_name; *p && k + 1 < sizeof name; p++)
        name[k++] = isalnum((unsigned char)*p) || *p == '-' ? *p : '_';
    name[k] = 0;
    /* a fingerprint of what the scene is made of, so that an edited description (a sky added, a
     * light moved) does not reuse a stale reference */
    pgi_scene_info info;
    pgi_scene_get_info(c->scene, &info);
    uint64_t fp = 1469598103934665603ULL;
    const double vals[] = {(double)info.triangles,
                           (double)info.vertices,
                           (double)info.materials,
                           (double)info.lights,
                           (double)info.sky_lights,
                           (double)info.glossy_materials,
                           (double)info.specular,
                           (double)info.bounds_min[0],
                           (double)info.bounds_min[1],
                           (double)info.bounds_min[2],
                           (double)info.bounds_max[0],
                           (double)info.bounds_max[1],
                           (double)info.bounds_max[2],
                           (double)info.camera.eye[0],
                           (double)info.camera.eye[1],
                           (double)info.camera.eye[2],
                           (double)info.camera.look_at[0],
                           (double)info.camera.look_at[1],
                           (double)info.camera.look_at[2],
                           (double)info.camera.fov_y_deg,
                           info.surface_area};
    for (size_t i = 0; i < sizeof vals / sizeof vals[0]; i++) {
        uint64_t b;
        memcpy(&b, &vals[i], sizeof b);
        fp = (fp ^ b) * 1099511628211ULL;
    }
    snprintf(path, sizeof path, "%s/eqt_%s_%dx%d_b%d_%llu_%08llx.exr", dir, name, c->w, c->h, bounces,
             (unsigned long long)c->ref_spp, (unsigned long long)(fp & 0xffffffffULL));
    if (pgi_image_read(path, ref, NULL) == PGI_OK && ref->width == c->w && ref->height == c->h) {
        fprintf(stderr, "  reference: %s (cached)\n", path);
        return 1;
    }
    pgi_image_free(ref);
    fprintf(stderr, "  reference: path tracing %llu spp at %dx%d (cached as %s)\n", (unsigned long long)c->ref_spp,
            c->w, c->h, path);
    pgi_reference_desc rd = {.width = c->w,
                             .height = c->h,
                             .bounces = bounces,
                             .seed = 0x5eed5eedULL,
                             .threads = c->threads,
                             .spp = c->ref_spp,
                             .jitter = PGI_JITTER_ON,
                             .progress = ref_progress};
    uint64_t done = 0;
    if (pgi_reference_render(c->scene, &rd, ref, &done)) {
        fprintf(stderr, "photongi-bench-equal-time: reference: %s\n", pgi_last_error());
        return 0;
    }
    /* mkdir -p of the cache folder (two levels at most below an existing home) */
    char tmp[1024];
    snprintf(tmp, sizeof tmp, "%s", dir);
    for (char *p = tmp + 1; *p; p++)
        if (*p == '/') {
            *p = 0;
            mkdir(tmp, 0755);
            *p = '/';
        }
    mkdir(tmp, 0755);
    if (pgi_image_write(ref, path, 1.f))
        fprintf(stderr, "photongi-bench-equal-time: warning: cannot cache the reference: %s\n", pgi_last_error());
    return 1;
}

static int parse_budgets(const char *s, double *b) {
    int n = 0;
    char *end;
    while (*s && n < MAX_BUDGETS) {
        errno = 0;
        double v = strtod(s, &end);
        if (end == s || errno || !(v > 0.0) || !isfinite(v) || (n > 0 && v <= b[n - 1])) return 0;
        b[n++] = v;
        s = *end == ',' ? end + 1 : end;
        if (*end && *end != ',') return 0;
    }
    return *s ? 0 : n;
}

/* Whether `name` is a token of the comma-separated `list`. */
static int in_list(const char *list, const char *name) {
    size_t n = strlen(name);
    for (const char *p = list; (p = strstr(p, name)) != NULL; p += n)
        if ((p == list || p[-1] == ',') && (p[n] == 0 || p[n] == ',')) return 1;
    return 0;
}

/* Whether estimator e runs: "all" (every estimator but the oracle), "exact" (those that converge
 * progressively), or a comma-separated list of names. */
static int selected(const char *list, const pgi_estimator_vtbl *e) {
    if (strcmp(list, "all") == 0) return !e->oracle;
    if (strcmp(list, "exact") == 0) return e->exact && !e->oracle;
    return in_list(list, e->name);
}

int main(int argc, char **argv) {
    const char *scene_spec = "cornell", *ests = "exact", *ref_path = NULL, *csv_path = NULL, *budget_s = "0.25,1,4,16";
    int w = 0, h = 0, threads = 0, with_pt = 1, variants = 0;
    float radius = 0.f;
    unsigned long photons = 0;
    unsigned long long ref_spp = 1024;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            puts("usage: photongi-bench-equal-time [--scene S] [--size WxH] [--photons N] [--budgets 0.25,1,4,16]\n"
                 "         [--estimators a,b | all | exact] [--no-pathtracer] [--ref-spp N] [--ref FILE.exr]\n"
                 "         [--threads T] [--csv FILE] [--radius R] [--emission-variants]\n"
                 "\n"
                 "Each estimator's progressive mode and the path tracer get the same wall-time budgets (seconds,\n"
                 "increasing); the image each has after a budget is compared with a path-traced reference:\n"
                 "PSNR, SSIM, FLIP (tone-mapped) and relMSE (radiance). Defaults: scene cornell at its size,\n"
                 "the scene's photons a frame, the exact estimators, reference 1024 spp (cached in\n"
                 "$PHOTONGI_CACHE), CSV bench/results/equal_time_<scene>.csv. bench/equal_time.sh plots it.\n"
                 "--radius R: the progressive start radius (default the scene's, else automatic).\n"
                 "--emission-variants: each estimator with uniform and guided emission (+guided), storing every\n"
                 "photon or only those in view (+view, needs a radius): docs/emission.md.");
            return 0;
        }
        if (strcmp(a, "--no-pathtracer") == 0) {
            with_pt = 0;
            continue;
        }
        if (strcmp(a, "--emission-variants") == 0) {
            variants = 1;
            continue;
        }
        if (!v) {
            fprintf(stderr, "photongi-bench-equal-time: %s needs a value\n", a);
            return 2;
        }
        i++;
        char *end = NULL;
        if (strcmp(a, "--scene") == 0) scene_spec = v;
        else if (strcmp(a, "--estimators") == 0) ests = v;
        else if (strcmp(a, "--ref") == 0) ref_path = v;
        else if (strcmp(a, "--csv") == 0) csv_path = v;
        else if (strcmp(a, "--budgets") == 0) budget_s = v;
        else if (strcmp(a, "--size") == 0 && sscanf(v, "%dx%d", &w, &h) == 2 && w > 0 && h > 0 && w <= 16384 &&
                 h <= 16384) {
        } else if (strcmp(a, "--photons") == 0 && (photons = strtoul(v, &end, 10)) > 0 && !*end &&
                   photons <= PGI_MAX_PHOTONS) {
        } else if (strcmp(a, "--ref-spp") == 0 && (ref_spp = strtoull(v, &end, 10)) > 0 && !*end) {
        } else if (strcmp(a, "--threads") == 0 && (threads = atoi(v)) > 0 && threads <= 1024) {
        } else if (strcmp(a, "--radius") == 0 && (radius = strtof(v, &end)) > 0.f && !*end && isfinite(radius)) {
        } else {
            fprintf(stderr, "photongi-bench-equal-time: bad option %s %s (see --help)\n", a, v);
            return 2;
        }
    }
    double budgets[MAX_BUDGETS];
    int nb = parse_budgets(budget_s, budgets);
    if (!nb) {
        fprintf(stderr, "photongi-bench-equal-time: --budgets needs increasing positive seconds, got '%s'\n", budget_s);
        return 2;
    }
    pgi_scene *scene;
    if (pgi_scene_load(scene_spec, &scene)) {
        fprintf(stderr, "photongi-bench-equal-time: %s\n", pgi_last_error());
        return 1;
    }
    pgi_scene_info info;
    pgi_scene_get_info(scene, &info);
    if (!w) {
        w = info.defaults.width > 0 ? info.defaults.width : 640;
        h = info.defaults.height > 0 ? info.defaults.height : 480;
    }
    int bounces = info.defaults.bounces > 0 ? info.defaults.bounces : 4;
    run_ctx c = {.scene = scene,
                 .scene_name = info.name,
                 .exposure = info.defaults.exposure > 0.f ? info.defaults.exposure : 1.f,
                 .w = w,
                 .h = h,
                 .threads = threads,
                 .photons = photons ? (uint32_t)photons : (info.defaults.photons ? info.defaults.photons : 200000),
                 .ref_spp = ref_spp};
    char default_csv[512];
    if (!csv_path) {
        mkdir("bench/results", 0755);
        snprintf(default_csv, sizeof default_csv, "bench/results/equal_time_%s.csv", info.name);
        csv_path = default_csv;
    }
    pgi_image ref = {0};
    fprintf(stderr, "equal time: %s %dx%d, %u photons a frame, budgets %s s\n", info.name, w, h, c.photons, budget_s);
    if (!load_reference(&c, ref_path, bounces, &ref)) {
        pgi_scene_destroy(scene);
        return 1;
    }
    c.ref = &ref;
    c.csv = fopen(csv_path, "w");
    if (!c.csv) {
        fprintf(stderr, "photongi-bench-equal-time: cannot write %s: %s\n", csv_path, strerror(errno));
        pgi_image_free(&ref);
        pgi_scene_destroy(scene);
        return 1;
    }
    fprintf(c.csv, "scene,method,budget_s,time_s,steps,psnr,ssim,flip,relmse,width,height,photons,ref_spp\n");
    int ok = 1, nrun = 0;
    pgi_renderer *r = NULL;
    if (pgi_renderer_create(scene, &r)) {
        fprintf(stderr, "photongi-bench-equal-time: %s\n", pgi_last_error());
        ok = 0;
    }
    for (size_t i = 0; ok && i < pgi_estimator_count(); i++) {
        const pgi_estimator_vtbl *e = pgi_estimator_at(i);
        if (!selected(ests, e)) continue;
        for (int v = 0; ok && v < (variants ? 4 : 1); v++) {
            static const char *const suffix[] = {"", "+guided", "+view", "+guided+view"};
            prog_state s = {.d = {.estimator = e->name,
                                  .photons = c.photons,
                                  .radius = radius,
                                  .width = w,
                                  .height = h,
                                  .seed = 1,
                                  .threads = threads,
                                  .bounces = bounces,
                                  .emission = (v & 1) ? PGI_EMISSION_GUIDED : PGI_EMISSION_UNIFORM,
                                  .store = (v & 2) ? PGI_STORE_VIEW : PGI_STORE_ALL}};
            char name[128];
            snprintf(name, sizeof name, "%s%s", e->name, suffix[v]);
            if (pgi_progressive_create(r, &s.p)) {
                fprintf(stderr, "photongi-bench-equal-time: %s\n", pgi_last_error());
                ok = 0;
                break;
            }
            ok = run_method(&c, name, prog_step, &s, budgets, nb);
            pgi_progressive_destroy(s.p);
            nrun++;
        }
    }
    if (ok && with_pt) {
        pt_state s = {.scene = scene,
                      .d = {.width = w,
                            .height = h,
                            .bounces = bounces,
                            .seed = 7,
                            .threads = threads,
                            .spp = 1,
                            .jitter = PGI_JITTER_ON}};
        ok = run_method(&c, PATHTRACER, pt_step, &s, budgets, nb);
        nrun++;
    }
    if (ok && !nrun) {
        fprintf(stderr, "photongi-bench-equal-time: no estimator matches '%s' (see photongi estimators)\n", ests);
        ok = 0;
    }
    fclose(c.csv);
    if (ok) fprintf(stderr, "equal time: wrote %s\n", csv_path);
    pgi_renderer_destroy(r);
    pgi_image_free(&ref);
    pgi_scene_destroy(scene);
    return ok ? 0 : 1;
}
