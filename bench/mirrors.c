/* photongi-bench --mirrors: what samples seen through mirrors and glass cost
 * each estimator. The built-in cornell-mirrors scene (a mirror wall, a mirror
 * sphere, a glass sphere) is rendered as it is and with those materials made
 * Lambertian (same geometry, every view sample primary); for each photon count
 * and estimator: median build + estimate time, the estimator's memory, photon
 * reads, and the ratios of time and memory to hashgrid's on the same frame. */
#include <stdio.h>
#include <string.h>

#include "bench_common.h"
#include "mirrors.h"
#include "scene/bsdf.h"
#include "scene/scene_internal.h"

#define MAXF 64

typedef struct {
    double ms, bytes, reads;
    int ok;
} row;

/* Turns the scene's mirrors and glass into grey Lambertian surfaces. */
static void make_matte(pgi_scene *s) {
    for (size_t m = 0; m < s->nmats; m++)
        if (pgi__mat_specular(&s->mats[m])) {
            s->mats[m].type = PGI__MAT_LAMBERT;
            for (int k = 0; k < 3; k++) s->mats[m].kd[k] = 0.7f;
        }
}

static row run_one(pgi_renderer *r, const char *est, unsigned photons, int width, int height, float radius, int threads,
                   int frames) {
    row out = {0};
    pgi_render_desc d = {.estimator = est,
                         .photons = photons,
                         .width = width,
                         .height = height,
                         .threads = threads,
                         .seed = 1,
                         .radius = radius,
                         .output = PGI_OUTPUT_INDIRECT};
    double t[MAXF];
    pgi_frame_stats fs;
    pgi_image img = {0};
    for (int f = -1; f < frames; f++) {
        if (pgi_renderer_render(r, &d, &img, &fs) != PGI_OK) {
            fprintf(stderr, "photongi-bench: %s: %s\n", est, pgi_last_error());
            pgi_image_free(&img);
            return out;
        }
        if (f >= 0) t[f] = fs.build_ms + fs.estimate_ms;
    }
    pgi_image_free(&img);
    out.ms = median(t, frames);
    out.bytes = estimator_bytes(&fs);
    out.reads = (double)fs.reads;
    out.ok = 1;
    return out;
}

int pgi_bench_mirrors(const char *photon_list, const char *estimators, int frames, int width, int height, float radius,
                      int threads, const char *csv_path) {
    if (frames > MAXF) frames = MAXF;
    FILE *csv = open_csv(csv_path);
    if (!csv) return 1;
    fprintf(csv, "scene,photons,radius,estimator,build_estimate_ms,estimator_bytes,reads,time_vs_hashgrid,"
                 "memory_vs_hashgrid\n");
    printf("cornell-mirrors %dx%d, build + estimate (median of %d frames after a warm-up), estimator memory;\n"
           "x hashgrid: ratio to hashgrid on the same frame. matte: the mirrors and glass made Lambertian.\n\n",
           width, height, frames);
    printf("%-8s %-9s %8s %-16s %10s %8s %9s %8s %14s\n", "scene", "photons", "radius", "estimator", "ms", "x hgrid",
           "MB", "x hgrid", "reads");
    int failed = 0;
    char plist[512];
    snprintf(plist, sizeof plist, "%s", photon_list);
    for (int variant = 0; variant < 2; variant++) {
        pgi_scene *scene;
        pgi_renderer *r;
        if (pgi_scene_load("cornell-mirrors", &scene) != PGI_OK) {
            fprintf(stderr, "photongi-bench: %s\n", pgi_last_error());
            fclose(csv);
            return 1;
        }
        if (variant == 1) make_matte(scene);
        if (pgi_renderer_create(scene, &r) != PGI_OK) {
            fprintf(stderr, "photongi-bench: %s\n", pgi_last_error());
            pgi_scene_destroy(scene);
            fclose(csv);
            return 1;
        }
        const char *vname = variant ? "matte" : "mirrors";
        char *save = NULL;
        char pbuf[512];
        snprintf(pbuf, sizeof pbuf, "%s", plist);
        for (char *p = strtok_r(pbuf, ",", &save); p; p = strtok_r(NULL, ",", &save)) {
            unsigned photons = (unsigned)strtod(p, NULL);
            if (photons == 0) {
                fprintf(stderr, "photongi-bench: --photons: '%s' is not a photon count\n", p);
                failed = 1;
                continue;
            }
            /* The scene's own radius (0.05 at 200k photons) shrunk as 1/sqrt(photons): about as many
             * photons in reach at every count. */
            float rad = radius > 0.f ? radius : 0.05f * sqrtf(200000.f / (float)photons);
            row hg = run_one(r, "hashgrid", photons, width, height, rad, threads, frames);
            char ebuf[512], *esave = NULL;
            snprintf(ebuf, sizeof ebuf, "%s", estimators);
            for (char *e = strtok_r(ebuf, ",", &esave); e; e = strtok_r(NULL, ",", &esave)) {
                row x = strcmp(e, "hashgrid") == 0 ? hg : run_one(r, e, photons, width, height, rad, threads, frames);
                if (!x.ok) {
                    failed = 1;
                    continue;
                }
                double tr = hg.ok && hg.ms > 0 ? x.ms / hg.ms : 0.0,
                       mr = hg.ok && hg.bytes > 0 ? x.bytes / hg.bytes : 0.0;
                printf("%-8s %-9u %8.4f %-16s %10.1f %8.2f %9.1f %8.2f %14.0f\n", vname, photons, (double)rad, e, x.ms,
                       tr, x.bytes / 1048576.0, mr, x.reads);
                fprintf(csv, "%s,%u,%g,%s,%.3f,%.0f,%.0f,%.4f,%.4f\n", vname, photons, (double)rad, e, x.ms, x.bytes,
                        x.reads, tr, mr);
                fflush(stdout);
            }
        }
        pgi_renderer_destroy(r);
        pgi_scene_destroy(scene);
    }
    fclose(csv);
    printf("\n(CSV: %s)\n", csv_path);
    return failed;
}
