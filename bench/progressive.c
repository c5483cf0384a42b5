/* Progressive-mode convergence: PSNR and SSIM (the metrics of `photongi
 * compare`: tone-mapped 8-bit sRGB) of the running average after 1, 2, 4, ...
 * frames against a path-traced reference (pgi_reference_render, --ref-spp
 * samples a pixel over the whole pixel, same bounces and scene), and the first frame
 * count reaching a target PSNR.
 *
 *   photongi-bench-progressive [--scene S] [--estimator E] [--size WxH] [--photons N]
 *       [--frames N] [--ref-spp N] [--target dB] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "photongi/metrics.h"
#include "photongi/photongi.h"
#include "photongi/reference.h"

int main(int argc, char **argv) {
    const char *scene_spec = "cornell", *est = "hashgrid";
    int w = 256, h = 256, frames = 64;
    unsigned photons = 0;
    unsigned long ref_spp = 1024;
    double target = 35.0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            puts("usage: photongi-bench-progressive [--scene S] [--estimator E] [--size WxH] [--photons N]\n"
                 "         [--frames N] [--ref-spp N] [--target dB]");
            return 0;
        }
        if (!v) {
            fprintf(stderr, "photongi-bench-progressive: %s needs a value\n", a);
            return 2;
        }
        i++;
        if (strcmp(a, "--scene") == 0) scene_spec = v;
        else if (strcmp(a, "--estimator") == 0) est = v;
        else if (strcmp(a, "--size") == 0 && sscanf(v, "%dx%d", &w, &h) == 2 && w > 0 && h > 0) {
        } else if (strcmp(a, "--photons") == 0 && (photons = (unsigned)strtoul(v, NULL, 10)) > 0) {
        } else if (strcmp(a, "--frames") == 0 && (frames = atoi(v)) > 0) {
        } else if (strcmp(a, "--ref-spp") == 0 && (ref_spp = strtoul(v, NULL, 10)) > 0) {
        } else if (strcmp(a, "--target") == 0) target = atof(v);
        else {
            fprintf(stderr, "photongi-bench-progressive: bad option %s %s\n", a, v);
            return 2;
        }
    }
    pgi_scene *s;
    if (pgi_scene_load(scene_spec, &s)) {
        fprintf(stderr, "photongi-bench-progressive: %s\n", pgi_last_error());
        return 1;
    }
    pgi_scene_info info;
    pgi_scene_get_info(s, &info);
    if (!photons) photons = info.defaults.photons ? info.defaults.photons : 200000;
    pgi_render_desc d = {.estimator = est, .photons = photons, .width = w, .height = h, .seed = 1};
    pgi_reference_desc rd = {.width = w, .height = h, .seed = 0x5eed5eedULL, .spp = ref_spp};
    pgi_image ref = {0}, img = {0};
    pgi_frame_stats fs;
    uint64_t spp_done = 0;
    double t0 = (double)clock() / CLOCKS_PER_SEC;
    if (pgi_reference_render(s, &rd, &ref, &spp_done)) {
        fprintf(stderr, "photongi-bench-progressive: %s\n", pgi_last_error());
        return 1;
    }
    printf("# %s %dx%d %s, %u photons/frame; reference: path traced, %llu spp (%.1f CPU-s)\n", info.name, w, h, est,
           photons, (unsigned long long)spp_done, (double)clock() / CLOCKS_PER_SEC - t0);
    printf("frames,radius,psnr_db,ssim,ms_per_frame\n");
    pgi_renderer *r;
    pgi_progressive *prog;
    if (pgi_renderer_create(s, &r)) return 1;
    if (pgi_progressive_create(r, &prog)) return 1;
    int reached = 0;
    for (int k = 1; k <= frames; k++) {
        if (pgi_progressive_step(prog, &d, &img, &fs)) {
            fprintf(stderr, "photongi-bench-progressive: %s\n", pgi_last_error());
            return 1;
        }
        pgi_metrics m;
        if (pgi_metrics_compute(&img, &ref, info.defaults.exposure > 0.f ? info.defaults.exposure : 1.f, &m)) {
            fprintf(stderr, "photongi-bench-progressive: %s\n", pgi_last_error());
            return 1;
        }
        if (!reached && m.psnr >= target) reached = k;
        if ((k & (k - 1)) == 0 || k == frames || k == reached)
            printf("%d,%g,%.2f,%.4f,%.1f\n", k, (double)fs.radius, m.psnr, m.ssim, fs.total_ms);
    }
    printf("# %.1f dB %s %d frames\n", target, reached ? "reached after" : "not reached in",
           reached ? reached : frames);
    pgi_progressive_destroy(prog);
    pgi_renderer_destroy(r);
    pgi_image_free(&ref);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
    return 0;
}
