/* Progressive-mode convergence: PSNR of the running average after 1, 2, 4,
 * ... frames against a reference, and the first frame count reaching a
 * target PSNR.
 *
 * Reference: until the path tracer and metrics of another branch are
 * merged, a long progressive render with an independent seed and more
 * photons per frame (--ref-frames x --ref-photons), and the PSNR below
 * (linear RGB clamped to [0, 1], peak 1).
 *
 *   photongi-bench-progressive [--scene S] [--estimator E] [--size WxH] [--photons N]
 *       [--frames N] [--ref-frames N] [--ref-photons N] [--target dB] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "photongi/photongi.h"

static double srgb(double c) {
    c = fmin(1.0, fmax(0.0, c));
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

/* PSNR (peak 1) of linear RGB clamped to [0, 1], or of the sRGB-encoded
 * values a PNG would hold (exposure 1): dark regions weigh more there. */
static double psnr(const pgi_image *a, const pgi_image *ref, int encoded) {
    size_t n = 3 * (size_t)ref->width * ref->height;
    double se = 0.0;
    for (size_t i = 0; i < n; i++) {
        double x = fmin(1.0, fmax(0.0, a->rgb[i])), y = fmin(1.0, fmax(0.0, ref->rgb[i]));
        if (encoded) x = srgb(x), y = srgb(y);
        se += (x - y) * (x - y);
    }
    return se > 0.0 ? 10.0 * log10((double)n / se) : INFINITY;
}

int main(int argc, char **argv) {
    const char *scene_spec = "cornell", *est = "hashgrid";
    int w = 256, h = 256, frames = 64, ref_frames = 64;
    unsigned photons = 0, ref_photons = 0;
    double target = 35.0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            puts("usage: photongi-bench-progressive [--scene S] [--estimator E] [--size WxH] [--photons N]\n"
                 "         [--frames N] [--ref-frames N] [--ref-photons N] [--target dB]");
            return 0;
        }
        if (!v) {
            fprintf(stderr, "photongi-bench-progressive: %s needs a value\n", a);
            return 2;
        }
        i++;
        if (strcmp(a, "--scene") == 0) scene_spec = v;
        else if (strcmp(a, "--estimator") == 0) est = v;
        else if (strcmp(a, "--size") == 0 && sscanf(v, "%dx%d", &w, &h) == 2 && w > 0 && h > 0) {}
        else if (strcmp(a, "--photons") == 0 && (photons = (unsigned)strtoul(v, NULL, 10)) > 0) {}
        else if (strcmp(a, "--frames") == 0 && (frames = atoi(v)) > 0) {}
        else if (strcmp(a, "--ref-frames") == 0 && (ref_frames = atoi(v)) > 0) {}
        else if (strcmp(a, "--ref-photons") == 0 && (ref_photons = (unsigned)strtoul(v, NULL, 10)) > 0) {}
        else if (strcmp(a, "--target") == 0) target = atof(v);
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
    if (!ref_photons) ref_photons = 4 * photons;
    pgi_render_desc d = {.estimator = est, .photons = photons, .photons_set = 1, .width = w, .height = h, .seed = 1};
    pgi_render_desc dr = d;
    dr.photons = ref_photons;
    dr.seed = 0x5eed5eedULL;
    dr.progressive = ref_frames;
    pgi_image ref = {0}, img = {0};
    pgi_frame_stats fs;
    if (pgi_render(s, &dr, &ref, &fs)) {
        fprintf(stderr, "photongi-bench-progressive: %s\n", pgi_last_error());
        return 1;
    }
    printf("# %s %dx%d %s, %u photons/frame, r0 %g; reference: %d frames x %u photons (%.1f s)\n", info.name, w, h,
           est, photons, (double)fs.radius / (double)pgi_progressive_radius(1.f, ref_frames - 1),
           ref_frames, ref_photons, fs.total_ms / 1000.0);
    printf("frames,radius,psnr_linear_db,psnr_srgb_db,ms_per_frame\n");
    pgi_renderer *r;
    if (pgi_renderer_create(s, &r)) return 1;
    int reached = 0, reached_srgb = 0;
    for (int k = 1; k <= frames; k++) {
        if (pgi_renderer_accumulate(r, &d, &img, &fs)) {
            fprintf(stderr, "photongi-bench-progressive: %s\n", pgi_last_error());
            return 1;
        }
        double p = psnr(&img, &ref, 0), ps = psnr(&img, &ref, 1);
        if (!reached && p >= target) reached = k;
        if (!reached_srgb && ps >= target) reached_srgb = k;
        if ((k & (k - 1)) == 0 || k == frames || k == reached || k == reached_srgb)
            printf("%d,%g,%.2f,%.2f,%.1f\n", k, (double)fs.radius, p, ps, fs.total_ms);
    }
    printf("# %.1f dB (linear) %s %d frames; %.1f dB (sRGB) %s %d frames\n", target,
           reached ? "reached after" : "not reached in", reached ? reached : frames, target,
           reached_srgb ? "reached after" : "not reached in", reached_srgb ? reached_srgb : frames);
    pgi_renderer_destroy(r);
    pgi_image_free(&ref);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
    return 0;
}
