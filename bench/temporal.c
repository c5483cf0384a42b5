/* The moving picture: a camera path (or a light that moves) rendered frame by frame (a) raw, each
 * frame on its own; (c) with temporal reuse (pgi_temporal, no filter); (d) with reuse and the
 * a-trous filter; against a path-traced reference at every frame. Per frame and averaged: PSNR and
 * FLIP against the reference, flicker (the mean absolute frame-to-frame change of the tone-mapped
 * image beyond the references' own change), and the milliseconds a frame (docs/temporal.md).
 *
 *   photongi-bench-temporal [--scene S] [--size WxH] [--frames N] [--photons N] [--ref-spp N]
 *       [--path strafe|dolly|light] [--step F] [--csv FILE] [--threads T] [--ref-dir DIR]
 *
 * --ref-dir keeps the references as EXR files in DIR (named by the scene, size, path, step, samples
 * and frame), read back instead of rendered when there: the path tracer dominates a run's time.
 *
 * strafe: the camera slides sideways, `step` (default 0.004) scene diagonals a frame; dolly: it
 * walks forward; light: the camera stands still and the first point light (or light group) moves
 * sideways every 4th frame. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "photongi/metrics.h"
#include "photongi/photongi.h"
#include "photongi/reference.h"

static double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return 1e3 * (double)t.tv_sec + 1e-6 * (double)t.tv_nsec;
}

/* Mean absolute change of the tone-mapped (8-bit sRGB, /255) image from the previous frame. */
static double change(const unsigned char *a, const unsigned char *b, size_t n) {
    double s = 0.0;
    for (size_t i = 0; i < n; i++) s += fabs((double)a[i] - (double)b[i]);
    return s / (255.0 * (double)n);
}

static int cmp_double(const void *a, const void *b) {
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

enum { RAW, REUSE, FILTERED, MODES };
static const char *const k_mode[MODES] = {"raw", "reuse", "reuse+filter"};

int main(int argc, char **argv) {
    const char *scene_spec = "sibenik", *path = "strafe", *csv = NULL, *ref_dir = NULL;
    int w = 320, h = 180, frames = 24, threads = 0;
    unsigned photons = 0;
    unsigned long ref_spp = 256;
    float step = 0.004f;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            puts("usage: photongi-bench-temporal [--scene S] [--size WxH] [--frames N] [--photons N] [--ref-spp N]\n"
                 "         [--path strafe|dolly|light] [--step F] [--csv FILE] [--threads T] [--ref-dir DIR]");
            return 0;
        }
        if (!v) {
            fprintf(stderr, "photongi-bench-temporal: %s needs a value\n", a);
            return 2;
        }
        i++;
        if (strcmp(a, "--scene") == 0) scene_spec = v;
        else if (strcmp(a, "--path") == 0 && (!strcmp(v, "strafe") || !strcmp(v, "dolly") || !strcmp(v, "light")))
            path = v;
        else if (strcmp(a, "--size") == 0 && sscanf(v, "%dx%d", &w, &h) == 2 && w >= 11 && h >= 11) {
        } else if (strcmp(a, "--frames") == 0 && (frames = atoi(v)) >= 2) {
        } else if (strcmp(a, "--photons") == 0 && (photons = (unsigned)strtoul(v, NULL, 10)) > 0) {
        } else if (strcmp(a, "--ref-spp") == 0 && (ref_spp = strtoul(v, NULL, 10)) >= 2) {
        } else if (strcmp(a, "--step") == 0 && (step = strtof(v, NULL)) > 0.f) {
        } else if (strcmp(a, "--threads") == 0 && (threads = atoi(v)) > 0) {
        } else if (strcmp(a, "--csv") == 0) csv = v;
        else if (strcmp(a, "--ref-dir") == 0) ref_dir = v;
        else {
            fprintf(stderr, "photongi-bench-temporal: bad option %s %s\n", a, v);
            return 2;
        }
    }
    pgi_scene *s;
    if (pgi_scene_load(scene_spec, &s)) {
        fprintf(stderr, "photongi-bench-temporal: %s\n", pgi_last_error());
        return 1;
    }
    pgi_scene_info info;
    pgi_scene_get_info(s, &info);
    const float ext[3] = {info.bounds_max[0] - info.bounds_min[0], info.bounds_max[1] - info.bounds_min[1],
                          info.bounds_max[2] - info.bounds_min[2]};
    const float diag = sqrtf(ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]);
    pgi_camera_def cam0;
    pgi_scene_get_camera(s, 0, &cam0);
    float fwd[3], right[3];
    for (int k = 0; k < 3; k++) fwd[k] = cam0.look_at[k] - cam0.eye[k];
    const float fl = sqrtf(fwd[0] * fwd[0] + fwd[1] * fwd[1] + fwd[2] * fwd[2]);
    for (int k = 0; k < 3; k++) fwd[k] /= fl;
    right[0] = fwd[1] * cam0.up[2] - fwd[2] * cam0.up[1];
    right[1] = fwd[2] * cam0.up[0] - fwd[0] * cam0.up[2];
    right[2] = fwd[0] * cam0.up[1] - fwd[1] * cam0.up[0];
    const float rl = sqrtf(right[0] * right[0] + right[1] * right[1] + right[2] * right[2]);
    for (int k = 0; k < 3; k++) right[k] /= rl;
    const int light_path = strcmp(path, "light") == 0;
    pgi_light_group lg0 = {0};
    if (light_path && (pgi_scene_light_group_count(s) == 0 || pgi_scene_get_light_group(s, 0, &lg0))) {
        fprintf(stderr, "photongi-bench-temporal: --path light needs a light\n");
        return 1;
    }

    pgi_renderer *r[MODES];
    pgi_temporal *t[MODES] = {NULL};
    for (int m = 0; m < MODES; m++) {
        if (pgi_renderer_create(s, &r[m])) return 1;
        if (m == RAW) continue;
        pgi_temporal_desc td = {.filter = m == FILTERED ? 0 : PGI_TEMPORAL_OFF};
        if (pgi_temporal_create(r[m], &td, &t[m])) return 1;
    }
    FILE *out = csv ? fopen(csv, "w") : NULL;
    if (csv && !out) {
        fprintf(stderr, "photongi-bench-temporal: cannot write %s\n", csv);
        return 1;
    }
    if (out) fprintf(out, "frame,mode,psnr,flip,change,ref_change,ms,ref_psnr\n");
    const size_t n8 = 3 * (size_t)w * (size_t)h;
    unsigned char *prev8[MODES + 1], *cur8 = malloc(n8);
    for (int m = 0; m <= MODES; m++) prev8[m] = malloc(n8);
    double sum_psnr[MODES] = {0}, sum_flip[MODES] = {0}, sum_flicker[MODES] = {0}, sum_ms[MODES] = {0};
    double sum_mse[MODES] = {0}, sum_ref_var = 0.0;
    double sum_tms[MODES] = {0}, sum_fms[MODES] = {0}; /* the temporal step's own reprojection and filter */
    double *ms_of[MODES];
    for (int m = 0; m < MODES; m++)
        if (!(ms_of[m] = calloc((size_t)frames, sizeof(double)))) return 1;
    const float exposure = info.defaults.exposure > 0.f ? info.defaults.exposure : 1.f;
    printf("%s %dx%d, path %s, %d frames, references %lu spp\n", info.name, w, h, path, frames, ref_spp);
    printf("frame  ref_change | raw: dB FLIP | reuse: dB FLIP | reuse+filter: dB FLIP\n");
    for (int f = 0; f < frames; f++) {
        pgi_camera_def cam = cam0;
        if (!light_path)
            for (int k = 0; k < 3; k++) {
                const float d = (strcmp(path, "dolly") == 0 ? fwd[k] : right[k]) * step * diag * (float)f;
                cam.eye[k] += d, cam.look_at[k] += d;
            }
        else if (f % 4 == 0) {
            float p[3];
            for (int k = 0; k < 3; k++) p[k] = lg0.position[k] + right[k] * 0.02f * diag * (float)(f / 4);
            pgi_scene_set_light_position(s, 0, p);
        }
        pgi_reference_desc rd = {.width = w, .height = h, .spp = ref_spp, .threads = threads, .view = &cam};
        /* the reference in two halves of its samples (the first half's mean kept): their difference
           estimates the reference's own noise, which the PSNR against it counts as error */
        pgi_image ref = {0}, half = {0};
        uint64_t spp = 0;
        char ref_path[2][4096] = {"", ""};
        if (ref_dir) {
            const char *base = strrchr(info.name, '/');
            for (int i = 0; i < 2; i++)
                snprintf(ref_path[i], sizeof ref_path[i], "%s/%s-%dx%d-%s-%g-%lu-%d%s.exr", ref_dir,
                         base ? base + 1 : info.name, w, h, path, (double)step, ref_spp, f, i ? "-half" : "");
        }
        int cached = ref_dir && pgi_image_read(ref_path[0], &ref, NULL) == PGI_OK &&
                     pgi_image_read(ref_path[1], &half, NULL) == PGI_OK && ref.width == w && ref.height == h &&
                     half.width == w && half.height == h;
        if (!cached) {
            pgi_image_free(&ref), pgi_image_free(&half);
            rd.spp = ref_spp / 2;
            if (pgi_reference_render(s, &rd, &ref, &spp) || !(half.rgb = malloc(n8 * sizeof(float)))) {
                fprintf(stderr, "photongi-bench-temporal: reference: %s\n", pgi_last_error());
                return 1;
            }
            half.width = w, half.height = h;
            memcpy(half.rgb, ref.rgb, n8 * sizeof(float));
            rd.spp = ref_spp - ref_spp / 2;
            if (pgi_reference_render(s, &rd, &ref, &spp)) {
                fprintf(stderr, "photongi-bench-temporal: reference: %s\n", pgi_last_error());
                return 1;
            }
            for (int i = 0; ref_dir && i < 2; i++)
                if (pgi_image_write(i ? &half : &ref, ref_path[i], 1.f))
                    fprintf(stderr, "photongi-bench-temporal: cannot keep the reference: %s\n", pgi_last_error());
        }
        /* the mean of the halves' squared difference over 4: the full reference's noise variance
           (tone-mapped, as the PSNR), over the values finite in both (a half cached by a build
           before the EXR writer's fix can read back with a few non-finite pixels: Sibenik's
           strafe, frame 20, src/io/image_io.c) */
        size_t finite = 0;
        for (size_t i = 0; i < n8; i++) finite += isfinite(half.rgb[i]) && isfinite(ref.rgb[i]);
        for (size_t i = 0; i < n8; i++) half.rgb[i] = 2.f * ref.rgb[i] - half.rgb[i]; /* the second half */
        unsigned char *h8 = malloc(n8);
        if (!h8) return 1;
        pgi_tonemap_srgb8(&half, exposure, h8);
        for (size_t i = 0; i < n8; i++) half.rgb[i] = 2.f * ref.rgb[i] - half.rgb[i]; /* the first again */
        pgi_tonemap_srgb8(&half, exposure, cur8);
        double ref_var = 0.0;
        for (size_t i = 0; i < n8; i++) {
            const double dd = ((double)cur8[i] - (double)h8[i]) / 255.0;
            if (isfinite(half.rgb[i]) && isfinite(ref.rgb[i])) ref_var += dd * dd;
        }
        ref_var /= 4.0 * (double)(finite ? finite : 1);
        free(h8);
        pgi_image_free(&half);
        sum_ref_var += ref_var;
        pgi_tonemap_srgb8(&ref, exposure, cur8);
        const double ref_change = f ? change(cur8, prev8[MODES], n8) : 0.0;
        memcpy(prev8[MODES], cur8, n8);
        printf("%5d  %10.5f", f, ref_change);
        for (int m = 0; m < MODES; m++) {
            pgi_render_desc d = {.width = w,
                                 .height = h,
                                 .photons = photons,
                                 .view = &cam,
                                 .threads = threads,
                                 /* fresh photons every frame: raw frames by their seed, pgi_temporal by itself */
                                 .seed = m == RAW ? (uint64_t)f + 1 : 1};
            pgi_image img = {0};
            pgi_frame_stats fs;
            const double t0 = now_ms();
            pgi_status st =
                m == RAW ? pgi_renderer_render(r[m], &d, &img, &fs) : pgi_temporal_step(t[m], &d, &img, &fs);
            const double ms = now_ms() - t0;
            if (st) {
                fprintf(stderr, "photongi-bench-temporal: %s: %s\n", k_mode[m], pgi_last_error());
                return 1;
            }
            pgi_metrics mt;
            pgi_metrics_compute(&img, &ref, exposure, &mt);
            pgi_tonemap_srgb8(&img, exposure, cur8);
            const double ch = f ? change(cur8, prev8[m], n8) : 0.0;
            memcpy(prev8[m], cur8, n8);
            printf(" | %6.2f %.4f", mt.psnr, mt.flip.mean);
            if (out)
                fprintf(out, "%d,%s,%.4f,%.5f,%.6f,%.6f,%.2f,%.4f\n", f, k_mode[m], mt.psnr, mt.flip.mean, ch,
                        ref_change, ms, 10.0 * log10(1.0 / ref_var));
            sum_psnr[m] += mt.psnr, sum_flip[m] += mt.flip.mean, sum_ms[m] += ms;
            sum_mse[m] += mt.mse;
            ms_of[m][f] = ms;
            if (m != RAW) sum_tms[m] += fs.temporal.reproject_ms, sum_fms[m] += fs.temporal.filter_ms;
            if (f) sum_flicker[m] += fmax(0.0, ch - ref_change);
            pgi_image_free(&img);
        }
        printf("\n");
        fflush(stdout);
        pgi_image_free(&ref);
    }
    /* against the truth: the mean squared error less the reference's own noise variance */
    const double ref_var = sum_ref_var / frames;
    printf("\nmean over %d frames (PSNR: of each frame, averaged; truth: of the mean squared error less the "
           "references' own noise, %.2f dB; ms: median, and the temporal step's reprojection and filter means):\n"
           "| mode | PSNR dB | vs truth dB | FLIP | flicker | ms a frame | reuse ms | filter ms |\n"
           "|---|---|---|---|---|---|---|---|\n",
           frames, 10.0 * log10(1.0 / ref_var));
    for (int m = 0; m < MODES; m++) {
        qsort(ms_of[m], (size_t)frames, sizeof(double), cmp_double);
        const double med = frames % 2 ? ms_of[m][frames / 2] : 0.5 * (ms_of[m][frames / 2 - 1] + ms_of[m][frames / 2]);
        const double mse_true = sum_mse[m] / frames - ref_var;
        printf("| %s | %.2f | %.2f | %.4f | %.5f | %.1f | %.1f | %.1f |\n", k_mode[m], sum_psnr[m] / frames,
               mse_true > 0.0 ? 10.0 * log10(1.0 / mse_true) : INFINITY, sum_flip[m] / frames,
               sum_flicker[m] / (frames - 1), med, sum_tms[m] / frames, sum_fms[m] / frames);
        free(ms_of[m]);
    }
    if (out) fclose(out);
    for (int m = 0; m < MODES; m++) {
        pgi_temporal_destroy(t[m]);
        pgi_renderer_destroy(r[m]);
    }
    for (int m = 0; m <= MODES; m++) free(prev8[m]);
    free(cur8);
    pgi_scene_destroy(s);
    return 0;
}
