/* photongi study: a method table for any scene. Every chosen estimator renders the same frame at equal
 * photons (one frame) and at equal time (a progressive average, as many frames as fit in the budget),
 * against a path-traced reference the study makes once and reuses; the reference's own noise comes
 * from its two halves. Writes study.md, study.csv and study.svg (PSNR against time) into --out. */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "cmd.h"
#include "output.h"
#include "parse.h"
#include "photongi/metrics.h"
#include "photongi/photongi.h"
#include "photongi/reference.h"

static const char *k_study_help =
    "usage: photongi study [--scene S] [--estimators A,B,...] [--photons N] [--size WxH]\n"
    "                      [--time MS] [--frames N] [--spp N] [--threads T] [--out DIR] [-q]\n"
    "\n"
    "Compares density-estimation methods on one scene against a path-traced reference: each\n"
    "estimator renders the same frame at equal photons (one frame, each pixel sampled over its\n"
    "area) and at equal time (a progressive average of as many frames as fit in --time), and\n"
    "its time, PSNR, SSIM, FLIP, relMSE, photon reads and memory go into one table.\n"
    "\n"
    "  --scene S          any scene 'render' takes (default cornell)\n"
    "  --estimators LIST  comma-separated names, or exact (default: every exact estimator but\n"
    "                     the brute-force oracle), or all\n"
    "  --photons N        photons a frame (default 100000)\n"
    "  --size WxH         image size (default 320x240)\n"
    "  --time MS          the equal-time budget in milliseconds (default: the slowest method's\n"
    "                     single frame times --frames)\n"
    "  --frames N         the default budget in frames of the slowest method (default 8)\n"
    "  --spp N            the reference's samples per pixel (default 256)\n"
    "  --threads T        threads (default: all)\n"
    "  --out DIR          where study.md, study.csv, study.svg and reference.exr go (default\n"
    "                     study-SCENE); a reference there of the same scene, size and samples is\n"
    "                     reused\n"
    "  -q, --quiet        no progress lines\n"
    "\n"
    "The reference's noise is measured from its two halves: 'reference PSNR' in the table is what\n"
    "the reference itself scores against the truth (about); a method scoring near it is judged\n"
    "by the reference's noise, not its own (use more --spp).\n"
    "\n"
    "Exit status: 0 success, 2 usage error, 1 failure.\n";

#define MAX_EST 32

typedef struct row {
    const char *estimator;
    const char *mode; /* "photons" or "time" */
    int frames;
    double ms, psnr, ssim, flip, relmse, reads, contributing, bytes;
} row;

/* One frame (budget_ms 0), or a progressive average of the frames that fit in `budget_ms` of render time
 * (at least one; the next frame is expected to take as long as the last). */
static pgi_status run(pgi_renderer *r, const pgi_render_desc *d, double budget_ms, int max_frames, pgi_image *img,
                      int *frames, double *ms, pgi_frame_stats *fs) {
    pgi_progressive *p;
    pgi_status st = pgi_progressive_create(r, &p);
    if (st) return st;
    *ms = 0.0;
    *frames = 0;
    pgi_frame_stats one;
    memset(fs, 0, sizeof *fs);
    do {
        if ((st = pgi_progressive_step(p, d, img, &one))) break;
        *ms += one.total_ms;
        ++*frames;
        if (*frames == 1) *fs = one;
        else fs->reads += one.reads, fs->contributing += one.contributing;
    } while (budget_ms > 0.0 && *ms + one.total_ms <= budget_ms && *frames < max_frames); /* the next one fits */
    pgi_progressive_destroy(p);
    return st;
}

static double memory_of(const pgi_frame_stats *fs) {
    double b = 0.0;
    for (int k = 0; k < fs->memory_count; k++) b += fs->memory_bytes[k].value;
    return b;
}

/* study.svg: PSNR against time (log scale) for each estimator's equal-photon and equal-time points. */
static int write_svg(const char *path, const row *rows, int n, const char *title) {
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    double t0 = INFINITY, t1 = 0, p0 = INFINITY, p1 = -INFINITY;
    for (int i = 0; i < n; i++) {
        if (rows[i].ms > 0) t0 = fmin(t0, rows[i].ms), t1 = fmax(t1, rows[i].ms);
        if (isfinite(rows[i].psnr)) p0 = fmin(p0, rows[i].psnr), p1 = fmax(p1, rows[i].psnr);
    }
    if (!(t1 > 0) || !isfinite(p0)) t0 = 1, t1 = 10, p0 = 0, p1 = 1;
    if (t1 <= t0 * 1.01) t1 = t0 * 2;
    if (p1 <= p0 + 0.5) p1 = p0 + 1;
    const double W = 720, H = 420, L = 70, R = 180, T = 40, B = 50;
    const double lt0 = log10(t0 / 1.2), lt1 = log10(t1 * 1.2), pp0 = p0 - 0.5, pp1 = p1 + 0.5;
#define X(ms) (L + (log10(ms) - lt0) / (lt1 - lt0) * (W - L - R))
#define Y(p) (H - B - ((p)-pp0) / (pp1 - pp0) * (H - T - B))
    static const char *const colors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                         "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
    fprintf(f,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%g\" height=\"%g\" font-family=\"sans-serif\" "
            "font-size=\"12\">\n<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n"
            "<text x=\"%g\" y=\"22\" font-size=\"14\">%s</text>\n"
            "<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"black\"/>\n"
            "<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"black\"/>\n"
            "<text x=\"%g\" y=\"%g\" text-anchor=\"middle\">time (ms, log scale)</text>\n"
            "<text x=\"16\" y=\"%g\" transform=\"rotate(-90 16 %g)\" text-anchor=\"middle\">PSNR (dB)</text>\n",
            W, H, L, title, L, H - B, W - R, H - B, L, T, L, H - B, (L + W - R) / 2, H - 12, (T + H - B) / 2,
            (T + H - B) / 2);
    for (double dec = floor(lt0); dec <= lt1; dec += 1)
        for (int m = 1; m < 10; m++) {
            const double ms = m * pow(10, dec);
            if (log10(ms) < lt0 || log10(ms) > lt1) continue;
            fprintf(f, "<line x1=\"%.1f\" y1=\"%g\" x2=\"%.1f\" y2=\"%g\" stroke=\"#ddd\"/>\n", X(ms), T, X(ms), H - B);
            if (m == 1 || m == 2 || m == 5)
                fprintf(f, "<text x=\"%.1f\" y=\"%g\" text-anchor=\"middle\">%g</text>\n", X(ms), H - B + 16, ms);
        }
    for (double p = ceil(pp0); p <= pp1; p += (pp1 - pp0 > 12 ? 2 : 1))
        fprintf(f,
                "<line x1=\"%g\" y1=\"%.1f\" x2=\"%g\" y2=\"%.1f\" stroke=\"#ddd\"/>\n"
                "<text x=\"%g\" y=\"%.1f\" text-anchor=\"end\">%g</text>\n",
                L, Y(p), W - R, Y(p), L - 6, Y(p) + 4, p);
    int ci = 0;
    for (int i = 0; i < n; i++) {
        if (i > 0 && strcmp(rows[i].estimator, rows[i - 1].estimator) == 0) continue;
        const char *c = colors[ci++ % 10];
        fprintf(f, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"2\" points=\"", c);
        for (int j = i; j < n && strcmp(rows[j].estimator, rows[i].estimator) == 0; j++)
            if (rows[j].ms > 0 && isfinite(rows[j].psnr)) fprintf(f, "%.1f,%.1f ", X(rows[j].ms), Y(rows[j].psnr));
        fprintf(f, "\"/>\n");
        for (int j = i; j < n && strcmp(rows[j].estimator, rows[i].estimator) == 0; j++)
            if (rows[j].ms > 0 && isfinite(rows[j].psnr))
                fprintf(f, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3.5\" fill=\"%s\"/>\n", X(rows[j].ms), Y(rows[j].psnr),
                        c);
        fprintf(f,
                "<rect x=\"%g\" y=\"%d\" width=\"12\" height=\"12\" fill=\"%s\"/><text x=\"%g\" y=\"%d\">%s</text>\n",
                W - R + 14, (int)T + 18 * (ci - 1), c, W - R + 32, (int)T + 18 * (ci - 1) + 11, rows[i].estimator);
    }
#undef X
#undef Y
    fprintf(f, "</svg>\n");
    return fclose(f) == 0;
}

/* The reference in DIR/reference.exr (its sidecar says scene, size, samples): reused when it matches,
 * else made (two halves, kept for the noise estimate). *noise_mse: the mean squared difference of
 * the tone-mapped halves / 4, about the full reference's own error (0 when unknown). */
static int make_reference(const char *dir, const char *scene_spec, const pgi_scene *scene, int w, int h, uint64_t spp,
                          int threads, float exposure, int quiet, pgi_image *ref, double *noise_mse) {
    char path[4300], side[4400], half[4400];
    snprintf(path, sizeof path, "%s/reference.exr", dir);
    snprintf(side, sizeof side, "%s.json", path);
    if (!cli_reference_half_path(path, half, sizeof half)) return cli_failure("study", "--out path too long");
    pgi_reference_meta m;
    pgi_image hb = {0};
    if (pgi_reference_meta_read(side, &m) == PGI_OK && strcmp(m.scene, scene_spec) == 0 && m.width == w &&
        m.height == h && m.spp == spp && pgi_image_read(path, ref, NULL) == PGI_OK &&
        pgi_image_read(half, &hb, NULL) == PGI_OK && hb.width == w && hb.height == h) {
        if (!quiet) fprintf(stderr, "study: reusing %s (%" PRIu64 " samples)\n", path, spp);
    } else {
        pgi_image_free(ref);
        pgi_image_free(&hb);
        if (!quiet) fprintf(stderr, "study: reference, %" PRIu64 " samples per pixel at %dx%d ...\n", spp, w, h);
        pgi_reference_desc rd = {.width = w, .height = h, .threads = threads, .spp = spp / 2, .seed = 1};
        uint64_t have = 0;
        pgi_status st = pgi_reference_render(scene, &rd, &hb, &have); /* samples 0 .. spp/2 - 1 */
        pgi_image second = {0};
        uint64_t from = have;
        rd.spp = spp - spp / 2;
        if (!st) { /* samples spp/2 .. spp - 1 alone: from a zero mean "of the first spp/2 samples" */
            second = (pgi_image){w, h, calloc((size_t)w * h * 3, sizeof(float))};
            st = second.rgb ? pgi_reference_render(scene, &rd, &second, &from) : PGI_ERR_OOM;
        }
        if (st) {
            pgi_image_free(&hb);
            pgi_image_free(&second);
            return cli_fail("study", "cannot make the reference", st);
        }
        /* second holds (0 * h1 + S2) / (h1 + h2); the full mean is (S1 + S2) / spp */
        const size_t n3 = (size_t)w * h * 3;
        const double h1 = (double)have, h2 = (double)(spp - spp / 2);
        *ref = (pgi_image){w, h, malloc(n3 * sizeof(float))};
        if (!ref->rgb) {
            pgi_image_free(&hb);
            pgi_image_free(&second);
            return cli_failure("study", "out of memory for the reference");
        }
        for (size_t i = 0; i < n3; i++) {
            const double s2 = (double)second.rgb[i] * (h1 + h2);
            ref->rgb[i] = (float)((hb.rgb[i] * h1 + s2) / (h1 + h2));
            second.rgb[i] = (float)(s2 / h2); /* the second half's own mean */
        }
        pgi_reference_meta out =
            {.width = w, .height = h, .bounces = 0, .seed = 1, .spp = spp, .jitter = PGI_JITTER_ON};
        snprintf(out.scene, sizeof out.scene, "%s", scene_spec);
        pgi_reference_meta out_half = out;
        out_half.spp = spp - spp / 2;
        char half_side[4500];
        snprintf(half_side, sizeof half_side, "%s.json", half);
        if ((st = pgi_image_write(ref, path, 1.f)) || (st = pgi_reference_meta_write(&out, side)) ||
            (st = pgi_image_write(&second, half, 1.f)) || (st = pgi_reference_meta_write(&out_half, half_side))) {
            pgi_image_free(&hb);
            pgi_image_free(&second);
            return cli_fail("study", "cannot write the reference", st);
        }
        /* reference-half.exr keeps the second half (the noise estimate: cli_halves_noise_mse) */
        pgi_image_free(&hb);
        hb = second;
    }
    /* the halves: hb (the last spp - spp/2 samples) and the rest */
    *noise_mse = cli_halves_noise_mse(ref, spp, &hb, spp - spp / 2, exposure);
    pgi_image_free(&hb);
    return 0;
}

int pgi_cmd_study(int argc, char **argv) {
    const char *scene_spec = "cornell", *ests_arg = "exact", *out_dir = NULL;
    long long photons = 100000, frames = 8, spp = 256, threads = 0;
    double budget = 0.0;
    int w = 320, h = 240, quiet = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            fputs(k_study_help, stdout);
            return 0;
        }
        if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            quiet = 1;
            continue;
        }
        if (a[0] != '-') return cli_usage("study", "unexpected argument '%s'", a);
        if (i + 1 >= argc) return cli_usage("study", "%s needs a value", a);
        const char *v = argv[++i];
        if (strcmp(a, "--scene") == 0) scene_spec = v;
        else if (strcmp(a, "--estimators") == 0) ests_arg = v;
        else if (strcmp(a, "--out") == 0) out_dir = v;
        else if (strcmp(a, "--photons") == 0) {
            if (!parse_whole(v, 1, PGI_MAX_PHOTONS, &photons))
                return cli_usage("study", "--photons needs a whole number in 1..%u, got '%s'", PGI_MAX_PHOTONS, v);
        } else if (strcmp(a, "--frames") == 0) {
            if (!parse_whole(v, 1, 10000, &frames))
                return cli_usage("study", "--frames needs a whole number in 1..10000, got '%s'", v);
        } else if (strcmp(a, "--spp") == 0) {
            if (!parse_whole(v, 2, 1000000, &spp))
                return cli_usage("study", "--spp needs a whole number in 2..1000000, got '%s'", v);
        } else if (strcmp(a, "--threads") == 0) {
            if (!parse_whole(v, 1, 1024, &threads))
                return cli_usage("study", "--threads needs a whole number in 1..1024, got '%s'", v);
        } else if (strcmp(a, "--time") == 0) {
            if (!parse_pos_double(v, &budget))
                return cli_usage("study", "--time needs a positive number of milliseconds, got '%s'", v);
        } else if (strcmp(a, "--size") == 0) {
            if (!parse_size(v, PGI_MAX_IMAGE_SIDE, PGI_MAX_IMAGE_PIXELS, &w, &h) || w < 11 || h < 11)
                return cli_usage("study", "--size needs WIDTHxHEIGHT, each side 11..%d, got '%s'", PGI_MAX_IMAGE_SIDE,
                                 v);
        } else return cli_usage("study", "unknown option '%s'", a);
    }
    /* the estimators */
    const pgi_estimator_vtbl *ests[MAX_EST];
    int ne = 0;
    const int all = strcmp(ests_arg, "all") == 0, exact = strcmp(ests_arg, "exact") == 0;
    for (size_t e = 0; e < pgi_estimator_count() && ne < MAX_EST; e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        if (all ? !vt->oracle : exact ? vt->exact && !vt->oracle : 0) ests[ne++] = vt;
    }
    if (!all && !exact) {
        char buf[1024];
        snprintf(buf, sizeof buf, "%s", ests_arg);
        char *save = NULL;
        for (char *t = strtok_r(buf, ",", &save); t && ne < MAX_EST; t = strtok_r(NULL, ",", &save)) {
            const pgi_estimator_vtbl *vt = pgi_estimator_find(t);
            if (!vt) return cli_usage("study", "unknown estimator '%s' ('photongi estimators' lists them)", t);
            ests[ne++] = vt;
        }
    }
    if (!ne) return cli_usage("study", "%s", "--estimators names none");
    char dir[4096];
    if (out_dir) snprintf(dir, sizeof dir, "%s", out_dir);
    else {
        const char *b = strrchr(scene_spec, '/');
        snprintf(dir, sizeof dir, "study-%s", b ? b + 1 : scene_spec);
    }
    if (mkdir(dir, 0777) != 0 && errno != EEXIST)
        return cli_failure("study", "cannot make the folder %s: %s", dir, strerror(errno));

    pgi_scene *scene;
    pgi_status st = pgi_scene_load(scene_spec, &scene);
    if (st) return cli_input_fail("study", "cannot load scene", st);
    pgi_scene_info info;
    pgi_scene_get_info(scene, &info);
    const float exposure = info.defaults.exposure > 0.f ? info.defaults.exposure : 1.f;
    pgi_image ref = {0};
    double noise_mse = 0.0;
    int rc =
        make_reference(dir, scene_spec, scene, w, h, (uint64_t)spp, (int)threads, exposure, quiet, &ref, &noise_mse);
    if (rc) {
        pgi_scene_destroy(scene);
        return rc;
    }
    const double ref_psnr = noise_mse > 0 ? 10.0 * log10(1.0 / noise_mse) : INFINITY;
    pgi_renderer *r;
    if ((st = pgi_renderer_create(scene, &r))) {
        pgi_image_free(&ref);
        pgi_scene_destroy(scene);
        return cli_fail("study", "cannot create a renderer", st);
    }
    row rows[2 * MAX_EST];
    int nr = 0;
    pgi_image img = {0};
    pgi_frame_stats fs;
    /* every method: the same seed, photons and pixel-area sampling; only the estimate differs */
    pgi_render_desc d = {.photons = (uint32_t)photons,
                         .width = w,
                         .height = h,
                         .seed = 1,
                         .threads = (int)threads,
                         .jitter = PGI_JITTER_ON};
    double slowest = 0.0;
    for (int pass = 0; pass < 2 && !st; pass++) {
        if (pass == 1 && budget <= 0.0) budget = slowest * (double)frames;
        for (int e = 0; e < ne && !st; e++) {
            d.estimator = ests[e]->name;
            int nf;
            double ms;
            const int max_frames = ests[e]->exact ? PGI_MAX_PROGRESSIVE_FRAMES : 1;
            st = run(r, &d, pass ? budget : 0.0, max_frames, &img, &nf, &ms, &fs);
            if (st) break;
            pgi_metrics m;
            if ((st = pgi_metrics_compute(&img, &ref, exposure, &m))) break;
            row *x = &rows[nr++];
            *x = (row){ests[e]->name,
                       pass ? "time" : "photons",
                       nf,
                       ms,
                       m.psnr,
                       m.ssim,
                       m.flip.mean,
                       m.relmse,
                       (double)fs.reads,
                       (double)fs.contributing,
                       memory_of(&fs)};
            if (pass == 0) slowest = fmax(slowest, ms);
            if (!quiet)
                fprintf(stderr, "study: %-16s %-7s %5d frame%s %9.1f ms  PSNR %6.2f dB  FLIP %.4f\n", x->estimator,
                        x->mode, nf, nf == 1 ? " " : "s", ms, m.psnr, m.flip.mean);
        }
    }
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_image_free(&ref);
    pgi_scene_destroy(scene);
    if (st) return cli_fail("study", "a render failed", st);

    /* the table, the CSV, the plot: one row per estimator and mode, equal photons first */
    char path[4200];
    snprintf(path, sizeof path, "%s/study.csv", dir);
    FILE *csv = fopen(path, "w");
    snprintf(path, sizeof path, "%s/study.md", dir);
    FILE *md = fopen(path, "w");
    if (!csv || !md) {
        if (csv) fclose(csv);
        if (md) fclose(md);
        return cli_failure("study", "cannot write into %s: %s", dir, strerror(errno));
    }
    fprintf(csv, "scene,width,height,photons,estimator,mode,frames,ms,psnr,ssim,flip,relmse,reads,contributing,"
                 "memory_bytes,reference_spp,reference_psnr\n");
    fprintf(md,
            "# %s, %dx%d, %lld photons a frame\n\nAgainst a %lld-sample path-traced reference (reference.exr); "
            "its own noise, from its two halves, scores about **%.1f dB**: a method near that is judged by the "
            "reference's noise. Every frame samples each pixel over its area, with the same seed and photons; "
            "equal time is a progressive average of as many frames as fit in %.0f ms. photongi %s.\n",
            scene_spec, w, h, photons, spp, ref_psnr, budget, pgi_version());
    for (int pass = 0; pass < 2; pass++) {
        fprintf(md,
                "\n## %s\n\n| estimator | frames | ms | PSNR dB | SSIM | FLIP | relMSE | reads (M) | contributing "
                "| memory MiB |\n|---|---|---|---|---|---|---|---|---|---|\n",
                pass ? "Equal time" : "Equal photons (one frame)");
        for (int i = 0; i < nr; i++) {
            const row *x = &rows[i];
            if (strcmp(x->mode, pass ? "time" : "photons") != 0) continue;
            fprintf(md, "| %s | %d | %.1f | %.2f | %.4f | %.4f | %.5f | %.2f | %.1f %% | %.1f |\n", x->estimator,
                    x->frames, x->ms, x->psnr, x->ssim, x->flip, x->relmse, x->reads / 1e6,
                    x->reads > 0 ? 100.0 * x->contributing / x->reads : 0.0, x->bytes / 1048576.0);
        }
    }
    for (int i = 0; i < nr; i++) {
        const row *x = &rows[i];
        fprintf(csv, "\"%s\",%d,%d,%lld,%s,%s,%d,%.3f,%.4f,%.6f,%.6f,%.6g,%.0f,%.0f,%.0f,%lld,%.4f\n", scene_spec, w, h,
                photons, x->estimator, x->mode, x->frames, x->ms, x->psnr, x->ssim, x->flip, x->relmse, x->reads,
                x->contributing, x->bytes, spp, ref_psnr);
    }
    int bad = fclose(csv) != 0;
    bad |= fclose(md) != 0;
    /* the plot: each estimator's equal-photon and equal-time points, in estimator order */
    row sorted[2 * MAX_EST];
    int ns = 0;
    for (int e = 0; e < ne; e++)
        for (int i = 0; i < nr; i++)
            if (rows[i].estimator == ests[e]->name) sorted[ns++] = rows[i];
    char title[512];
    snprintf(title, sizeof title, "%s %dx%d, %lld photons a frame: PSNR against time", scene_spec, w, h, photons);
    for (char *c = title; *c; c++)
        if (*c == '<' || *c == '>' || *c == '&' || *c == '"') *c = '_'; /* plain text inside the SVG */
    snprintf(path, sizeof path, "%s/study.svg", dir);
    bad |= !write_svg(path, sorted, ns, title);
    if (bad) return cli_failure("study", "cannot write the results into %s", dir);
    printf("study: %s/study.md, study.csv, study.svg (reference noise about %.1f dB)\n", dir, ref_psnr);
    return 0;
}
