/* photongi study: a method table for any scene. Every chosen method renders the same frame at equal
 * photons (one frame) and at equal time (a progressive average, as many frames as fit in each budget;
 * the path tracer too), against a path-traced reference the study makes once and reuses; the
 * reference's own noise comes from its two halves. Writes study.md, study.csv, study.svg (PSNR against
 * time) and every image into --out. bench/quality.sh and bench/equal_time.sh are runs of it. */
#define _DEFAULT_SOURCE /* realpath (output.h) */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <limits.h>
#include <sys/stat.h>
#include <time.h>

#include "cli.h"
#include "cmd.h"
#include "output.h"
#include "progress.h"
#include "parse.h"
#include "photongi/metrics.h"
#include "photongi/photongi.h"
#include "photongi/reference.h"
#include "render_options.h"

static const char *k_study_help =
    "usage: photongi study [--scene S] [--estimators A,B,...] [--photons N] [--size WxH]\n"
    "                      [--time MS,...] [--frames N] [--equal-time on|off] [--spp N]\n"
    "                      [--reference REF.exr] [--threads T] [--out DIR] [-q] [render settings]\n"
    "\n"
    "Compares density-estimation methods on one scene against a path-traced reference: each\n"
    "estimator renders the same frame at equal photons (one frame, each pixel sampled over its\n"
    "area) and at equal time (a progressive average of as many frames as fit in --time), and\n"
    "its time, PSNR, SSIM, FLIP, relMSE, photon reads and memory go into one table.\n"
    "\n"
    "  --scene S          any scene 'render' takes (default cornell)\n"
    "  --estimators LIST  comma-separated methods: estimator names, exact (every exact\n"
    "                     estimator but the brute-force oracle; the default), all, and\n"
    "                     pathtracer (equal time only; its frames are samples a pixel); a name\n"
    "                     may end in +guided (--emission guided) and/or +view (--store view)\n"
    "  --photons N        photons a frame (default 100000)\n"
    "  --size WxH         image size (default 320x240)\n"
    "  --time MS[,MS...]  the equal-time budgets in milliseconds of rendering, increasing, up\n"
    "                     to 16 (default: one, the slowest method's single frame times --frames)\n"
    "  --frames N         the default budget in frames of the slowest method (default 8)\n"
    "  --equal-time on|off   the equal-time table (default on)\n"
    "  --spp N            the reference's samples per pixel (default 256)\n"
    "  --reference F.exr  where the reference and its half (F-half.exr) are kept (default\n"
    "                     DIR/reference.exr); one there of the same scene, size, samples,\n"
    "                     bounces, camera, sampling and glossy model is reused, else made\n"
    "  --threads T        threads (default: all)\n"
    "  --out DIR          where study.md, study.csv, study.svg and each method's PNG\n"
    "                     (METHOD-photons.png, METHOD-time[-MSms].png) go (default study-SCENE)\n"
    "  -q, --quiet        no progress lines\n"
    "\n"
    "Any other setting of 'render' (--radius, --bounces, --camera, --jitter, --emission, --store,\n"
    "--seed, --exposure, --specular, an estimator's options such as --cluster-tile, ...) applies\n"
    "to every method's frames; --bounces, --camera, --jitter and --specular to the reference too.\n"
    "--jitter off compares pixel centres with a pixel-centre reference: the estimators' error\n"
    "without the edge aliasing every single frame shares.\n"
    "\n"
    "The reference's noise is measured from its two halves: 'reference PSNR' in the table is what\n"
    "the reference itself scores against the truth (about); a method scoring near it is judged\n"
    "by the reference's noise, not its own (use more --spp).\n"
    "\n"
    "Exit status: 0 success, 2 usage error, 1 failure.\n";

#define MAX_EST 32

/* A method of the study: an estimator with its emission and storage variant, or the path tracer. */
typedef struct method {
    const pgi_estimator_vtbl *vt; /* NULL: the path tracer (PATHTRACER) */
    char name[96];                /* as the tables spell it: "hashgrid", "hashgrid+guided+view" */
    int guided, view;             /* +guided: --emission guided; +view: --store view */
} method;

#define PATHTRACER "pathtracer"
#define MAX_BUDGETS 16

typedef struct row {
    const char *estimator; /* the method's name */
    const char *mode;      /* "photons" or "time" */
    double budget_ms;      /* "time": the budget (0 for "photons") */
    int frames;
    double ms, psnr, ssim, flip, relmse, reads, contributing, bytes;
    double radius, build_ms, estimate_ms; /* the first frame's */
} row;

static double memory_of(const pgi_frame_stats *fs);

/* What the study's methods share. */
typedef struct study_ctx {
    pgi_renderer *r;
    const pgi_scene *scene;
    const pgi_render_desc *d;       /* every method's settings but its estimator and variant */
    const pgi_reference_meta *want; /* the reference's: the path tracer's samples are made alike */
    const pgi_image *ref;
    float exposure;
    const char *dir;
    int quiet, nbudgets;
} study_ctx;

/* A row: the image's metrics against the reference, and its PNG in the study's folder. */
static pgi_status record(const study_ctx *c, const method *m, double budget, int nf, double ms,
                         const pgi_frame_stats *fs, const pgi_image *img, row *x) {
    pgi_metrics mt;
    pgi_status st = pgi_metrics_compute(img, c->ref, c->exposure, &mt);
    if (st) return st;
    *x = (row){m->name,
               budget > 0.0 ? "time" : "photons",
               budget,
               nf,
               ms,
               mt.psnr,
               mt.ssim,
               mt.flip.mean,
               mt.relmse,
               (double)fs->reads,
               (double)fs->contributing,
               memory_of(fs),
               fs->radius,
               fs->build_ms,
               fs->estimate_ms};
    char png[4400];
    if (budget <= 0.0) snprintf(png, sizeof png, "%s/%s-photons.png", c->dir, m->name);
    else if (c->nbudgets == 1) snprintf(png, sizeof png, "%s/%s-time.png", c->dir, m->name);
    else snprintf(png, sizeof png, "%s/%s-time-%gms.png", c->dir, m->name, budget);
    if ((st = pgi_image_write(img, png, c->exposure))) return st;
    if (!c->quiet)
        fprintf(stderr, "study: %-20s %-7s %5d frame%s %9.1f ms  PSNR %6.2f dB  FLIP %.4f\n", x->estimator, x->mode, nf,
                nf == 1 ? " " : "s", ms, mt.psnr, mt.flip.mean);
    return PGI_OK;
}

/* Method m: one frame (budgets NULL; a row "photons"), or a progressive average with a row at each
 * budget: the frames that fit in it (at least one; the next frame is expected to take as long as the
 * last; the clock counts rendering only). An estimator that cannot average frames keeps its one frame
 * for every budget; the path tracer adds one sample a pixel a step (seed 2: not the reference's). */
static pgi_status run_method(const study_ctx *c, const method *m, const double *budgets, int nb, row *rows, int *nr) {
    pgi_render_desc dm = *c->d;
    dm.estimator = m->vt ? m->vt->name : NULL;
    if (m->guided) dm.emission = PGI_EMISSION_GUIDED;
    if (m->view) dm.store = PGI_STORE_VIEW;
    const int max_frames = !m->vt ? INT_MAX : m->vt->exact ? PGI_MAX_PROGRESSIVE_FRAMES : 1;
    pgi_progressive *p = NULL;
    pgi_status st = m->vt ? pgi_progressive_create(c->r, &p) : PGI_OK;
    if (st) return st;
    pgi_reference_desc rd = {.width = dm.width,
                             .height = dm.height,
                             .threads = dm.threads,
                             .spp = 1,
                             .seed = 2,
                             .bounces = c->want->bounces,
                             .camera = c->want->camera,
                             .jitter = c->want->jitter};
    uint64_t have = 0;
    pgi_image img = {0};
    pgi_frame_stats fs, one;
    memset(&fs, 0, sizeof fs);
    double ms = 0.0, last = 0.0;
    int nf = 0, k = 0;
    while (!st) {
        if (nf > 0) {
            if (!budgets) {
                st = record(c, m, 0.0, nf, ms, &fs, &img, &rows[(*nr)++]);
                break;
            }
            const int done = nf >= max_frames;
            while (!st && k < nb && (done || ms + last > budgets[k]))
                st = record(c, m, budgets[k++], nf, ms, &fs, &img, &rows[(*nr)++]);
            if (st || k == nb) break;
        }
        if (m->vt) {
            st = pgi_progressive_step(p, &dm, &img, &one);
            last = one.total_ms;
        } else {
            const double t0 = app_now_ms();
            st = pgi_reference_render(c->scene, &rd, &img, &have);
            last = app_now_ms() - t0;
            memset(&one, 0, sizeof one);
        }
        if (st) break;
        ms += last;
        if (++nf == 1) fs = one;
        else fs.reads += one.reads, fs.contributing += one.contributing;
    }
    pgi_progressive_destroy(p);
    pgi_image_free(&img);
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

/* The reference at `path` (its sidecar says scene, size, samples, bounces, camera, sampling, glossy
 * model): reused when all match `want` and its half is there, else made (two halves, the second kept
 * alone in PATH-half.exr for the noise estimate). *noise_mse: about the reference's own mean squared
 * error (cli_halves_noise_mse; 0 when unknown). */
static int make_reference(const char *path, const pgi_reference_meta *want, const pgi_scene *scene, int threads,
                          float exposure, int quiet, pgi_image *ref, double *noise_mse) {
    char side[4400], half[4400], half_side[4500];
    const uint64_t spp = want->spp;
    const int w = want->width, h = want->height;
    snprintf(side, sizeof side, "%s.json", path);
    if (!cli_reference_half_path(path, half, sizeof half))
        return cli_usage("study", "--reference needs an .exr file name, got '%s'", path);
    snprintf(half_side, sizeof half_side, "%s.json", half);
    pgi_reference_meta m;
    pgi_image hb = {0};
    if (pgi_reference_meta_read(side, &m) == PGI_OK && !cli_reference_differs(&m, want) && m.spp == spp &&
        pgi_image_read(path, ref, NULL) == PGI_OK && pgi_image_read(half, &hb, NULL) == PGI_OK && hb.width == w &&
        hb.height == h) {
        if (!quiet) fprintf(stderr, "study: reusing %s (%" PRIu64 " samples)\n", path, spp);
    } else {
        pgi_image_free(ref);
        pgi_image_free(&hb);
        if (!quiet) fprintf(stderr, "study: reference, %" PRIu64 " samples per pixel at %dx%d ...\n", spp, w, h);
        pgi_reference_desc rd = {.width = w,
                                 .height = h,
                                 .threads = threads,
                                 .spp = spp / 2,
                                 .seed = want->seed,
                                 .bounces = want->bounces,
                                 .camera = want->camera,
                                 .jitter = want->jitter};
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
        pgi_reference_meta out_full = *want, out_half = *want;
        out_half.spp = spp - spp / 2;
        /* each EXR with its sidecar (size and hash), as 'reference' saves them */
        if ((st = pgi_reference_save(ref, path, &out_full, side)) ||
            (st = pgi_reference_save(&second, half, &out_half, half_side))) {
            pgi_image_free(&hb);
            pgi_image_free(&second);
            return cli_fail("study", "cannot write the reference", st);
        }
        /* PATH-half.exr keeps the second half (the noise estimate: cli_halves_noise_mse) */
        pgi_image_free(&hb);
        hb = second;
    }
    /* the halves: hb (the last spp - spp/2 samples) and the rest */
    *noise_mse = cli_halves_noise_mse(ref, spp, &hb, spp - spp / 2, exposure);
    pgi_image_free(&hb);
    return 0;
}

/* What the command line of 'study' gives, and the methods and the folder it names. */
typedef struct study_args {
    const char *scene_spec, *ests_arg, *out_dir, *ref_arg;
    long long photons, frames, spp;
    double budgets[MAX_BUDGETS];
    int nb; /* none given: one, the slowest method's frame times --frames */
    int quiet, equal_time;
    pgi_render_desc d;
    app_render_extra xo;
    method meth[MAX_EST];
    int ne;
    char dir[4096];
} study_args;

/* The study under way: the scene, the reference and the rows. */
typedef struct study_run {
    pgi_scene *scene;
    float exposure;
    pgi_reference_meta want; /* the reference's: the frames' scene, size, bounces, camera and sampling */
    char ref_path[4300];
    pgi_image ref;
    double ref_psnr;
    row *rows;
    int nr;
} study_run;

/* --time MS[,MS...] into sa->budgets: 0, else the exit status. */
static int parse_budgets(const char *v, study_args *sa) {
    char buf[512], *save = NULL;
    snprintf(buf, sizeof buf, "%s", v);
    double *budgets = sa->budgets;
    int nb = 0;
    sa->nb = 0;
    for (char *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (nb == MAX_BUDGETS || !parse_pos_double(t, &budgets[nb]) || (nb && budgets[nb] <= budgets[nb - 1]))
            return cli_usage("study", "--time needs up to %d increasing positive numbers of milliseconds, got '%s'",
                             MAX_BUDGETS, v);
        sa->nb = ++nb;
    }
    if (!nb) return cli_usage("study", "--time needs milliseconds, got '%s'", v);
    return 0;
}

/* Parses argv into sa; -1 to go on, else the exit status (0 after --help). */
static int parse_args(int argc, char **argv, study_args *sa) {
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (cli_is_help(a)) {
            fputs(k_study_help, stdout);
            return 0;
        }
        if (cli_is_quiet(a)) {
            sa->quiet = 1;
            continue;
        }
        if (a[0] != '-') return cli_usage("study", "unexpected argument '%s'", a);
        if (i + 1 >= argc) return cli_usage("study", "%s needs a value", a);
        const char *v = argv[++i];
        int rc;
        if (strcmp(a, "--scene") == 0) sa->scene_spec = v;
        else if (strcmp(a, "--estimators") == 0) sa->ests_arg = v;
        else if (strcmp(a, "--out") == 0) sa->out_dir = v;
        else if (strcmp(a, "--reference") == 0) sa->ref_arg = v;
        else if (strcmp(a, "--equal-time") == 0) {
            if (strcmp(v, "on") != 0 && strcmp(v, "off") != 0)
                return cli_usage("study", "--equal-time must be on or off, got '%s'", v);
            sa->equal_time = strcmp(v, "on") == 0;
        } else if (strcmp(a, "--frames") == 0) {
            if (!parse_whole(v, 1, 10000, &sa->frames))
                return cli_usage("study", "--frames needs a whole number in 1..10000, got '%s'", v);
        } else if (strcmp(a, "--spp") == 0) {
            if (!parse_whole(v, 2, 1000000, &sa->spp))
                return cli_usage("study", "--spp needs a whole number in 2..1000000, got '%s'", v);
        } else if (strcmp(a, "--time") == 0) {
            if ((rc = parse_budgets(v, sa))) return rc;
        } else if (strcmp(a, "--estimator") == 0 || strcmp(a, "--progressive") == 0 || strcmp(a, "--output") == 0 ||
                   strcmp(a, "--max-memory") == 0) {
            return cli_usage("study",
                             "%s is not a setting of study (--estimators, --time and --frames choose "
                             "what runs)",
                             a);
        } else {
            char err[512];
            const int ro = app_render_option(a, v, &sa->d, &sa->xo, NULL, err, sizeof err);
            if (ro < 0) return cli_usage("study", "%s", err);
            if (ro == 0) return cli_usage("study", "unknown option '%s'", a);
            if (strcmp(a, "--size") == 0 && (sa->d.width < 11 || sa->d.height < 11))
                return cli_usage("study", "--size needs each side 11 or more (the SSIM window), got '%s'", v);
        }
    }
    return -1;
}

/* The methods of --estimators: names, "exact", "all", "pathtracer"; a name may end in +guided
 * and/or +view. 0, else the exit status. */
static int parse_methods(study_args *sa) {
    method *meth = sa->meth;
    int ne = 0;
    char buf[1024], *save = NULL;
    snprintf(buf, sizeof buf, "%s", sa->ests_arg);
    for (char *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        const int all = strcmp(t, "all") == 0, exact = strcmp(t, "exact") == 0;
        if (all || exact) {
            for (size_t e = 0; e < pgi_estimator_count() && ne < MAX_EST; e++) {
                const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
                if (!vt->oracle && (all || vt->exact)) {
                    meth[ne] = (method){.vt = vt};
                    snprintf(meth[ne++].name, sizeof meth[0].name, "%s", vt->name);
                }
            }
            continue;
        }
        if (ne == MAX_EST) return cli_usage("study", "--estimators names more than %d methods", MAX_EST);
        method *m = &meth[ne];
        *m = (method){0};
        snprintf(m->name, sizeof m->name, "%s", t);
        for (char *plus; (plus = strrchr(t, '+'));) {
            if (strcmp(plus, "+guided") == 0) m->guided = 1;
            else if (strcmp(plus, "+view") == 0) m->view = 1;
            else return cli_usage("study", "'%s': a method's variant is +guided or +view, got '%s'", m->name, plus);
            *plus = 0;
        }
        if (strcmp(t, PATHTRACER) == 0) {
            if (m->guided || m->view) return cli_usage("study", "'%s': the path tracer has no variants", m->name);
        } else if (!(m->vt = pgi_estimator_find(t)))
            return cli_usage("study", "unknown estimator '%s' ('photongi estimators' lists them)", t);
        ne++;
    }
    sa->ne = ne;
    return 0;
}

/* What the command line decides before any file is read: the frames' sampling, the methods, the
 * folder (made here). 0 to go on, else the exit status. */
static int check_args(study_args *sa) {
    sa->photons = sa->d.photons;
    if (sa->d.jitter == PGI_JITTER_AUTO) sa->d.jitter = PGI_JITTER_ON;
    int rc = parse_methods(sa);
    if (rc) return rc;
    if (!sa->ne) return cli_usage("study", "%s", "--estimators names none");
    if (sa->out_dir) snprintf(sa->dir, sizeof sa->dir, "%s", sa->out_dir);
    else {
        const char *b = strrchr(sa->scene_spec, '/');
        snprintf(sa->dir, sizeof sa->dir, "study-%s", b ? b + 1 : sa->scene_spec);
    }
    if (mkdir(sa->dir, 0777) != 0 && errno != EEXIST)
        return cli_failure("study", "cannot make the folder %s: %s", sa->dir, strerror(errno));
    return 0;
}

/* Loads the scene with its glossy model and camera, resolves the exposure and what the reference
 * must be. 0 to go on, else the exit status (the scene freed). */
static int open_scene(study_args *sa, study_run *sr) {
    int rc = cli_load_scene("study", sa->scene_spec, 0, sa->xo.specular, &sr->scene);
    if (rc) return rc;
    pgi_scene_info info;
    pgi_scene_get_info(sr->scene, &info);
    if (*info.warnings) cli_warn(sa->quiet, "study", "%s", info.warnings);
    {
        char cerr[1400];
        if (!app_render_camera(sr->scene, &sa->d, &sa->xo, cerr, sizeof cerr)) {
            pgi_scene_destroy(sr->scene);
            return cli_failure("study", "%s", cerr);
        }
    }
    sr->exposure = cli_exposure(sa->xo.exposure, &info);
    const pgi_render_desc *d = &sa->d;
    /* the reference: the frames' scene, size, bounces, camera and sampling */
    sr->want = (pgi_reference_meta){.width = d->width,
                                    .height = d->height,
                                    .bounces = d->bounces                  ? d->bounces
                                               : info.defaults.bounces > 0 ? info.defaults.bounces
                                                                           : 4,
                                    .camera = d->camera,
                                    .seed = 1,
                                    .spp = (uint64_t)sa->spp,
                                    .jitter = d->jitter,
                                    .specular = info.specular};
    snprintf(sr->want.scene, sizeof sr->want.scene, "%s", sa->scene_spec);
    return 0;
}

/* The reference (made, or reused from --reference or DIR/reference.exr) and what its own noise
 * scores. 0 to go on, else the exit status (the scene freed). */
static int open_reference(const study_args *sa, study_run *sr) {
    if (sa->ref_arg) snprintf(sr->ref_path, sizeof sr->ref_path, "%s", sa->ref_arg);
    else snprintf(sr->ref_path, sizeof sr->ref_path, "%s/reference.exr", sa->dir);
    double noise_mse = 0.0;
    int rc = make_reference(sr->ref_path, &sr->want, sr->scene, sa->d.threads, sr->exposure, sa->quiet, &sr->ref,
                            &noise_mse);
    if (rc) {
        pgi_scene_destroy(sr->scene);
        return rc;
    }
    sr->ref_psnr = noise_mse > 0 ? 10.0 * log10(1.0 / noise_mse) : INFINITY;
    return 0;
}

/* Every method at equal photons, then at equal time (the budgets given, else one from the slowest
 * method's frame): the rows in sr. Frees the reference and the scene. 0, else the exit status. */
static int run_methods(study_args *sa, study_run *sr) {
    pgi_renderer *r;
    pgi_status st;
    if ((st = pgi_renderer_create(sr->scene, &r))) {
        pgi_image_free(&sr->ref);
        pgi_scene_destroy(sr->scene);
        return cli_fail("study", "cannot create a renderer", st);
    }
    const int ne = sa->ne;
    row *rows = sr->rows = malloc((size_t)ne * (MAX_BUDGETS + 1) * sizeof *rows);
    int *nr = &sr->nr;
    if (!rows) st = PGI_ERR_OOM;
    study_ctx c = {r, sr->scene, &sa->d, &sr->want, &sr->ref, sr->exposure, sa->dir, sa->quiet, sa->nb ? sa->nb : 1};
    /* equal photons: one frame each (not the path tracer: it has no photons) */
    double slowest = 0.0;
    for (int e = 0; e < ne && !st; e++)
        if (sa->meth[e].vt && !(st = run_method(&c, &sa->meth[e], NULL, 0, rows, nr)))
            slowest = fmax(slowest, rows[*nr - 1].ms);
    /* equal time: the budgets given, else the slowest method's frame times --frames */
    if (!sa->nb) sa->budgets[sa->nb++] = slowest > 0.0 ? slowest * (double)sa->frames : 1000.0;
    for (int e = 0; e < ne && !st && sa->equal_time; e++)
        st = run_method(&c, &sa->meth[e], sa->budgets, sa->nb, rows, nr);
    pgi_renderer_destroy(r);
    pgi_image_free(&sr->ref);
    pgi_scene_destroy(sr->scene);
    if (st) {
        free(rows);
        return cli_fail("study", "a render failed", st);
    }
    return 0;
}

/* study.md: what was compared, then a table for equal photons and one for each time budget. */
static void write_md(FILE *md, const study_args *sa, const study_run *sr) {
    const pgi_render_desc *d = &sa->d;
    const int nb = sa->nb;
    const double *budgets = sa->budgets;
    const char *refname = strrchr(sr->ref_path, '/') ? strrchr(sr->ref_path, '/') + 1 : sr->ref_path;
    fprintf(md,
            "# %s, %dx%d, %lld photons a frame\n\nAgainst a %lld-sample path-traced reference (%s); "
            "its own noise, from its two halves, scores about **%.1f dB**: a method near that is judged by the "
            "reference's noise. Every frame samples each pixel %s, with the same seed and photons",
            sa->scene_spec, d->width, d->height, sa->photons, sa->spp, refname, sr->ref_psnr,
            d->jitter == PGI_JITTER_OFF ? "at its centre (as the reference)" : "over its area");
    if (sa->equal_time) {
        fprintf(md, "; equal time is a progressive average of as many frames as fit in ");
        for (int k = 0; k < nb; k++) fprintf(md, "%s%.0f", k ? (k + 1 == nb ? " and " : ", ") : "", budgets[k]);
        fprintf(md, " ms of rendering");
    }
    fprintf(md, ". Radius: %s. photongi %s.\n",
            d->radius == PGI_RADIUS_AUTO ? "automatic (each row's in study.csv)"
            : d->radius > 0.f            ? "as given (study.csv)"
                                         : "the scene's (study.csv)",
            pgi_version());
    for (int pass = 0; pass < 1 + sa->equal_time; pass++)
        for (int k = 0; k < (pass ? nb : 1); k++) {
            if (pass && nb > 1) fprintf(md, "\n## Equal time: %g ms\n", budgets[k]);
            else fprintf(md, "\n## %s\n", pass ? "Equal time" : "Equal photons (one frame)");
            fprintf(md, "\n| method | frames | ms | PSNR dB | SSIM | FLIP | relMSE | reads (M) | contributing "
                        "| memory MiB |\n|---|---|---|---|---|---|---|---|---|---|\n");
            for (int i = 0; i < sr->nr; i++) {
                const row *x = &sr->rows[i];
                if (strcmp(x->mode, pass ? "time" : "photons") != 0 || (pass && x->budget_ms != budgets[k])) continue;
                fprintf(md, "| %s | %d | %.1f | %.2f | %.4f | %.4f | %.5f | %.2f | %.1f %% | %.1f |\n", x->estimator,
                        x->frames, x->ms, x->psnr, x->ssim, x->flip, x->relmse, x->reads / 1e6,
                        x->reads > 0 ? 100.0 * x->contributing / x->reads : 0.0, x->bytes / 1048576.0);
            }
        }
}

/* study.csv: a row per method and mode (and budget), with the run's settings. */
static void write_csv(FILE *csv, const study_args *sa, const study_run *sr) {
    const pgi_render_desc *d = &sa->d;
    fprintf(csv, "scene,width,height,photons,estimator,mode,frames,ms,psnr,ssim,flip,relmse,reads,contributing,"
                 "memory_bytes,reference_spp,reference_psnr,radius,build_ms,estimate_ms,jitter,budget_ms\n");
    for (int i = 0; i < sr->nr; i++) {
        const row *x = &sr->rows[i];
        fprintf(csv,
                "\"%s\",%d,%d,%lld,%s,%s,%d,%.3f,%.4f,%.6f,%.6f,%.6g,%.0f,%.0f,%.0f,%lld,%.4f,%.6g,%.3f,%.3f,%s,%g\n",
                sa->scene_spec, d->width, d->height, sa->photons, x->estimator, x->mode, x->frames, x->ms, x->psnr,
                x->ssim, x->flip, x->relmse, x->reads, x->contributing, x->bytes, sa->spp, sr->ref_psnr, x->radius,
                x->build_ms, x->estimate_ms, d->jitter == PGI_JITTER_OFF ? "off" : "on", x->budget_ms);
    }
}

/* study.svg. Frees the rows. 1 when it could not be written. */
static int write_plot(const study_args *sa, study_run *sr) {
    const row *rows = sr->rows;
    const int nr = sr->nr;
    /* the plot: each method's points in time order, methods in the order given */
    row *sorted = malloc((size_t)(nr ? nr : 1) * sizeof *sorted);
    int ns = 0;
    for (int e = 0; e < sa->ne && sorted; e++) {
        const int first = ns;
        for (int i = 0; i < nr; i++)
            if (rows[i].estimator == sa->meth[e].name) {
                int j = ns++;
                for (; j > first && sorted[j - 1].ms > rows[i].ms; j--) sorted[j] = sorted[j - 1];
                sorted[j] = rows[i];
            }
    }
    free(sr->rows);
    sr->rows = NULL;
    char title[512], path[4200];
    snprintf(title, sizeof title, "%s %dx%d, %lld photons a frame: PSNR against time", sa->scene_spec, sa->d.width,
             sa->d.height, sa->photons);
    for (char *ch = title; *ch; ch++)
        if (*ch == '<' || *ch == '>' || *ch == '&' || *ch == '"') *ch = '_'; /* plain text inside the SVG */
    snprintf(path, sizeof path, "%s/study.svg", sa->dir);
    const int bad = !sorted || !write_svg(path, sorted, ns, title);
    free(sorted);
    return bad;
}

/* The table, the CSV, the plot: one row per method and mode (and budget), equal photons first;
 * then the line that names them. Frees the rows. Returns the exit status. */
static int write_results(const study_args *sa, study_run *sr) {
    const char *dir = sa->dir;
    char path[4200];
    snprintf(path, sizeof path, "%s/study.csv", dir);
    FILE *csv = fopen(path, "w");
    snprintf(path, sizeof path, "%s/study.md", dir);
    FILE *md = fopen(path, "w");
    if (!csv || !md) {
        if (csv) fclose(csv);
        if (md) fclose(md);
        free(sr->rows);
        return cli_failure("study", "cannot write into %s: %s", dir, strerror(errno));
    }
    write_csv(csv, sa, sr);
    write_md(md, sa, sr);
    int bad = fclose(csv) != 0;
    bad |= fclose(md) != 0;
    bad |= write_plot(sa, sr);
    if (bad) return cli_failure("study", "cannot write the results into %s", dir);
    printf("study: %s/study.md, study.csv, study.svg (reference noise about %.1f dB)\n", dir, sr->ref_psnr);
    return 0;
}

int pgi_cmd_study(int argc, char **argv) {
    study_args sa = {.scene_spec = "cornell",
                     .ests_arg = "exact",
                     .photons = 100000,
                     .frames = 8,
                     .spp = 256,
                     .equal_time = 1,
                     /* every method: the same seed, photons and pixel-area sampling; only the estimate differs */
                     .d = {.photons = 100000, .width = 320, .height = 240, .seed = 1, .jitter = PGI_JITTER_ON},
                     .xo = APP_RENDER_EXTRA_INIT};
    int rc = parse_args(argc, argv, &sa);
    if (rc >= 0) return rc;
    if ((rc = check_args(&sa))) return rc;
    study_run sr;
    memset(&sr, 0, sizeof sr);
    if ((rc = open_scene(&sa, &sr)) || (rc = open_reference(&sa, &sr)) || (rc = run_methods(&sa, &sr))) return rc;
    return write_results(&sa, &sr);
}
