/* photongi compare A B [--json] [--diff heat.png] [--flip-map F.png]: PSNR, SSIM and FLIP of A against
 * the reference B on the tone-mapped images (include/photongi/metrics.h). */
#define _DEFAULT_SOURCE /* realpath (output.h) */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cmd.h"
#include "output.h"
#include "parse.h"
#include "photongi/metrics.h"

static const char *k_compare_help =
    "usage: photongi compare A B [--json] [--diff HEAT.png] [--diff-max E] [--flip-map FLIP.png]\n"
    "                            [--ppd P] [--exposure X]\n"
    "\n"
    "Compares image A with the reference B (PNG or EXR, same size, at least 11x11). Both are\n"
    "tone-mapped as 'render' writes PNG (exposure, sRGB, 8 bits); a PNG already is, and compares\n"
    "by its bytes. A reference's sidecar (B.json, from 'photongi reference') is read when it is\n"
    "there: a note says when A's sampling or settings differ from it. When B has a half beside it\n"
    "(B-half.exr and its sidecar: the mean of B's last samples alone, as 'photongi study' writes),\n"
    "the reference's own noise is estimated from the two halves and reported as a PSNR: what B\n"
    "itself scores against the truth, about.\n"
    "\n"
    "  PSNR      10 log10(1/MSE) on sRGB values in [0,1], all channels ('inf': identical)\n"
    "  SSIM      Wang et al. 2004 as scikit-image: 11x11 Gaussian window, sigma 1.5, K1 0.01,\n"
    "            K2 0.03, data range 1, mean over the map without its 5-pixel border;\n"
    "            on luma (0.2126 R' + 0.7152 G' + 0.0722 B'), and the mean of R, G, B\n"
    "  FLIP      LDR-FLIP (Andersson et al. 2020) as NVlabs' reference tool computes it: per-pixel\n"
    "            error in [0,1] at P pixels per degree; its mean, and the weighted median and\n"
    "            quartiles (each value weighted by itself)\n"
    "  relMSE    mean of (A - B)^2 / (B^2 + 0.01) over pixels and channels, on linear values\n"
    "            (EXR radiance times --exposure; a PNG's values are clamped and quantised)\n"
    "\n"
    "  --json          print the result as one JSON object on standard output\n"
    "  --diff FILE     write a heat map PNG of the largest channel difference per pixel\n"
    "                  (black 0 -> red -> yellow -> white at --diff-max)\n"
    "  --diff-max E    difference shown as white, in [0,1] units (default 0.1)\n"
    "  --flip-map FILE write FLIP's error map PNG (magma colour map: black 0 -> yellow-white 1)\n"
    "  --ppd P         FLIP's pixels per degree, 1..1000 (default 67.02: 0.7 m from a 0.7 m wide\n"
    "                  3840-pixel monitor; halve it for a monitor of 1920 pixels)\n"
    "  --exposure X    multiply the radiance of EXR (and HDR) inputs by X before tone mapping\n"
    "                  (default 1), as 'render --exposure X' does before it writes PNG: an EXR and\n"
    "                  the PNG of the same render compare as identical at the render's exposure\n"
    "\n"
    "The maps must be files of their own (not each other, nor A or B: a usage error). Images with\n"
    "NaN or infinite pixels are refused (their count is given); --json writes null for a value\n"
    "JSON cannot hold (the PSNR of identical images).\n"
    "\n"
    "Exit status: 0 success, 2 usage error, 1 failure (an image missing, unreadable, not finite or\n"
    "not comparable with the other; standard output not written; see 'photongi --help').\n";

/* sRGB EOTF in float, as the viewer's screenshot has it (apps use the public API only, so not the
 * library's internal pgi__srgb_to_linear, which is in double). The two differ by a few float ulps for
 * most bytes: a PNG heat map gets the same bytes either way, an EXR one would not. */
static float srgb_to_linear(float c) { return c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f); }

/* Writes 8-bit sRGB bytes as a PNG through the library's writer: bytes -> linear, so that its sRGB tone
 * map gives them back. */
static pgi_status write_rgb8(const unsigned char *rgb8, int w, int h, const char *path) {
    size_t n3 = (size_t)w * h * 3;
    pgi_image img = {w, h, malloc(n3 * sizeof(float))};
    if (!img.rgb) return PGI_ERR_OOM;
    for (size_t i = 0; i < n3; i++) img.rgb[i] = srgb_to_linear((float)rgb8[i] / 255.f);
    pgi_status st = pgi_image_write(&img, path, 1.f);
    pgi_image_free(&img);
    return st;
}

/* Notes on stderr where the sidecars (FILE.json of 'photongi reference') say that A and the reference B
 * were not made alike: a single frame (no sidecar, pixel centres) against a pixel-area reference, or two
 * references of different scenes, cameras, bounces, sampling or glossy models. */
static void note_sidecars(const char *a, const char *b) {
    char pa[4096], pb[4096];
    pgi_reference_meta ma, mb;
    snprintf(pa, sizeof pa, "%s.json", a);
    snprintf(pb, sizeof pb, "%s.json", b);
    const int has_a = pgi_reference_meta_read(pa, &ma) == PGI_OK, has_b = pgi_reference_meta_read(pb, &mb) == PGI_OK;
    if (!has_b) return;
    if (!has_a) {
        if (mb.jitter == PGI_JITTER_ON)
            fprintf(stderr,
                    "photongi compare: note: %s is a pixel-area reference (%llu samples over each pixel); a single "
                    "frame of 'render' samples pixel centres, so its edges alias against it: render with --jitter "
                    "on and --progressive N to compare like with like\n",
                    b, (unsigned long long)mb.spp);
        return;
    }
    const char *what = cli_reference_differs(&ma, &mb);
    if (what) fprintf(stderr, "photongi compare: note: %s and %s differ in their %s (their .json)\n", a, b, what);
}

double cli_halves_noise_mse(const pgi_image *ref, uint64_t n, const pgi_image *half, uint64_t n_half, float exposure) {
    if (n_half == 0 || n_half >= n || half->width != ref->width || half->height != ref->height) return 0.0;
    const size_t n3 = (size_t)ref->width * ref->height * 3;
    const double N = (double)n, n2 = (double)n_half, n1 = N - n2;
    pgi_image first = {ref->width, ref->height, malloc(n3 * sizeof(float))};
    if (!first.rgb) return 0.0;
    for (size_t i = 0; i < n3; i++) first.rgb[i] = (float)((N * ref->rgb[i] - n2 * half->rgb[i]) / n1);
    pgi_metrics m;
    double mse = pgi_metrics_compute(&first, half, exposure, &m) == PGI_OK ? m.mse * n1 * n2 / (N * N) : 0.0;
    pgi_image_free(&first);
    return mse;
}

int cli_reference_half_path(const char *ref, char *out, size_t cap) {
    const size_t len = strlen(ref);
    if (len < 5 || strcmp(ref + len - 4, ".exr") != 0) return 0;
    return snprintf(out, cap, "%.*s-half.exr", (int)(len - 4), ref) < (int)cap;
}

/* The noise of reference B (img, already scaled by the exposure) from its half B-half.exr, when there is
 * one whose sidecar says it belongs to B; 0 when none. *half_out gets its path. */
static double reference_noise(const char *b, const pgi_image *img, float exposure, char *half_out, size_t cap) {
    char pb[4200], ph[4200];
    pgi_reference_meta mb, mh;
    snprintf(pb, sizeof pb, "%s.json", b);
    if (!cli_reference_half_path(b, half_out, cap) || snprintf(ph, sizeof ph, "%s.json", half_out) >= (int)sizeof ph)
        return 0.0;
    if (pgi_reference_meta_read(pb, &mb) != PGI_OK || pgi_reference_meta_read(ph, &mh) != PGI_OK ||
        cli_reference_differs(&mb, &mh) || mh.spp >= mb.spp)
        return 0.0;
    pgi_image half = {0};
    int hdr = 0;
    double mse = 0.0;
    if (pgi_image_read(half_out, &half, &hdr) == PGI_OK && hdr) {
        for (size_t i = 0, n3 = (size_t)half.width * half.height * 3; i < n3; i++) half.rgb[i] *= exposure;
        mse = cli_halves_noise_mse(img, mb.spp, &half, mh.spp, 1.f);
    }
    pgi_image_free(&half);
    return mse;
}

/* The command line of photongi compare. */
typedef struct compare_args {
    const char *files[2], *diff, *flip_map;
    int json;
    float exposure, diff_max, ppd;
} compare_args;

/* Parses argv into `c`: -1 when it is complete, else the exit code (0 after --help). */
static int compare_parse(int argc, char **argv, compare_args *c) {
    int nfiles = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (cli_is_help(a)) {
            fputs(k_compare_help, stdout);
            return 0;
        } else if (strcmp(a, "--json") == 0) {
            c->json = 1;
        } else if (strcmp(a, "--diff") == 0 || strcmp(a, "--diff-max") == 0 || strcmp(a, "--exposure") == 0 ||
                   strcmp(a, "--flip-map") == 0 || strcmp(a, "--ppd") == 0) {
            if (i + 1 >= argc) return cli_usage("compare", "%s needs a value", a);
            const char *v = argv[++i];
            if (strcmp(a, "--diff") == 0) c->diff = v;
            else if (strcmp(a, "--flip-map") == 0) c->flip_map = v;
            else if (strcmp(a, "--ppd") == 0) {
                if (!parse_pos_float(v, &c->ppd) || c->ppd < 1.f || c->ppd > 1000.f)
                    return cli_usage("compare", "--ppd needs a number in [1, 1000], got '%s'", v);
            } else if (!parse_pos_float(v, strcmp(a, "--exposure") == 0 ? &c->exposure : &c->diff_max))
                return cli_usage("compare", "%s needs a positive number, got '%s'", a, v);
        } else if (a[0] == '-' && a[1]) {
            return cli_usage("compare", "unknown option '%s'", a);
        } else {
            if (nfiles == 2) return cli_usage("compare", "unexpected argument '%s' (give two images)", a);
            c->files[nfiles++] = a;
        }
    }
    if (nfiles != 2) return cli_usage("compare", "%s", "give two images: photongi compare TEST REFERENCE");
    if (nfiles != 2) return cli_usage("compare", "%s", "give two images: photongi compare TEST REFERENCE");
    return -1;
}

/* Reads the two images, refuses non-finite pixels, applies the exposure to linear inputs and
 * notes what the comparison mixes (8-bit and EXR inputs). 0, or the exit code (nothing held). */
static int compare_read(const compare_args *c, pgi_image img[2], int hdr[2]) {
    const char *const *files = c->files;
    const float exposure = c->exposure;
    for (int k = 0; k < 2; k++) {
        pgi_status st = pgi_image_read(files[k], &img[k], &hdr[k]);
        if (st) {
            pgi_image_free(&img[0]);
            return cli_input_fail("compare", "cannot read", st);
        }
    }
    /* Metrics of NaN or infinite pixels are meaningless: refuse them, naming the file. */
    for (int k = 0; k < 2; k++) {
        const size_t bad = cli_non_finite_pixels(&img[k], 1.f), n = (size_t)img[k].width * img[k].height;
        if (bad) {
            pgi_image_free(&img[0]);
            pgi_image_free(&img[1]);
            return cli_failure("compare", "%s has %zu pixel%s of %zu with NaN or infinite values", files[k], bad,
                               bad == 1 ? "" : "s", n);
        }
    }
    /* The exposure is the linear inputs' own: an 8-bit input carries the exposure it was written with. */
    for (int k = 0; k < 2; k++)
        if (hdr[k] && exposure != 1.f)
            for (size_t i = 0, n3 = (size_t)img[k].width * img[k].height * 3; i < n3; i++) img[k].rgb[i] *= exposure;
    if (exposure != 1.f && !hdr[0] && !hdr[1])
        fprintf(stderr, "photongi compare: note: --exposure applies to EXR inputs; both are 8-bit images\n");
    if (hdr[0] != hdr[1])
        fprintf(stderr,
                "photongi compare: note: %s is an 8-bit image, written at an exposure of its own: the EXR is "
                "tone-mapped at --exposure %g to match it; relMSE comes from its clamped, quantised values\n",
                files[hdr[0] ? 1 : 0], (double)exposure);
    return 0;
}

/* Writes the --diff heat map and the --flip-map (from fmap) where asked for. */
static pgi_status compare_maps(const compare_args *c, const pgi_image img[2], const float *fmap, const char **what) {
    const int w = img[0].width, h = img[0].height;
    const size_t n = (size_t)w * h;
    const char *diff = c->diff, *flip_map = c->flip_map;
    pgi_status st = PGI_OK;
    unsigned char *rgb8 = (diff || flip_map) ? malloc(3 * n) : NULL;
    if ((diff || flip_map) && !rgb8) {
        *what = "out of memory for the maps";
        st = PGI_ERR_OOM;
    }
    if (!st && diff) {
        *what = "cannot write the heat map";
        st = pgi_metrics_heatmap(&img[0], &img[1], 1.f, c->diff_max, rgb8);
        if (!st) st = write_rgb8(rgb8, w, h, diff);
    }
    if (!st && flip_map) {
        *what = "cannot write the FLIP map";
        pgi_flip_colorize(fmap, n, rgb8);
        st = write_rgb8(rgb8, w, h, flip_map);
    }
    free(rgb8);
    return st;
}

/* Prints the metrics (and the reference's own noise, 0: unknown), as text or JSON. */
static void compare_print(const pgi_metrics *mp, int json, double noise, const char *half) {
    const pgi_metrics m = *mp;
    char psnr[32], noise_psnr[32];
    if (isinf(m.psnr)) snprintf(psnr, sizeof psnr, json ? "null" : "inf");
    else snprintf(psnr, sizeof psnr, "%.8f", m.psnr);
    snprintf(noise_psnr, sizeof noise_psnr, noise > 0.0 ? "%.8f" : "null", 10.0 * log10(1.0 / noise));
    if (json) {
        /* JSON has no NaN or infinity: null for any such value (psnr of identical images). */
        char v[16][40];
        const double x[16] = {m.mse,
                              m.ssim,
                              m.ssim_rgb,
                              m.ssim_channel[0],
                              m.ssim_channel[1],
                              m.ssim_channel[2],
                              m.max_abs,
                              m.flip.mean,
                              m.flip.weighted_median,
                              m.flip.weighted_q1,
                              m.flip.weighted_q3,
                              m.flip.max,
                              (double)m.flip.ppd,
                              m.relmse,
                              0.0,
                              0.0};
        static const char *const fmt[14] = {"%.9g", "%.8f", "%.8f", "%.8f", "%.8f", "%.8f", "%.6f",
                                            "%.8f", "%.8f", "%.8f", "%.8f", "%.8f", "%.6f", "%.9g"};
        for (int i = 0; i < 14; i++) {
            if (isfinite(x[i])) snprintf(v[i], sizeof v[i], fmt[i], x[i]);
            else snprintf(v[i], sizeof v[i], "null");
        }
        if (!isfinite(m.psnr)) snprintf(psnr, sizeof psnr, "null");
        if (noise > 0.0 && !isfinite(10.0 * log10(1.0 / noise))) snprintf(noise_psnr, sizeof noise_psnr, "null");
        printf("{\"width\": %d, \"height\": %d, \"psnr\": %s, \"mse\": %s, \"ssim\": %s, \"ssim_rgb\": %s, "
               "\"ssim_r\": %s, \"ssim_g\": %s, \"ssim_b\": %s, \"max_abs\": %s, \"flip\": %s, "
               "\"flip_weighted_median\": %s, \"flip_weighted_q1\": %s, \"flip_weighted_q3\": %s, "
               "\"flip_max\": %s, \"flip_ppd\": %s, \"relmse\": %s, \"reference_noise_psnr\": %s}\n",
               m.width, m.height, psnr, v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11], v[12],
               v[13], noise_psnr);
    } else {
        printf("PSNR %s dB  SSIM %.4f (luma)  %.4f (RGB mean: %.4f %.4f %.4f)  max diff %.4f  %dx%d\n", psnr, m.ssim,
               m.ssim_rgb, m.ssim_channel[0], m.ssim_channel[1], m.ssim_channel[2], m.max_abs, m.width, m.height);
        printf("FLIP %.6f (weighted median %.6f, quartiles %.6f %.6f, max %.6f; %.2f pixels per degree)  "
               "relMSE %.6g\n",
               m.flip.mean, m.flip.weighted_median, m.flip.weighted_q1, m.flip.weighted_q3, m.flip.max,
               (double)m.flip.ppd, m.relmse);
        if (noise > 0.0)
            printf("reference noise: PSNR %.2f dB from its half %s (the reference's own error, about: a PSNR near "
                   "it says more about the reference than about A)\n",
                   10.0 * log10(1.0 / noise), half);
    }
}

int pgi_cmd_compare(int argc, char **argv) {
    compare_args c = {.exposure = 1.f, .diff_max = 0.1f, .ppd = PGI_FLIP_DEFAULT_PPD};
    int rc = compare_parse(argc, argv, &c);
    if (rc >= 0) return rc;
    const char *const *files = c.files, *diff = c.diff, *flip_map = c.flip_map;
    static const char *const k_png[] = {".png", NULL};
    rc = diff ? app_check_output("photongi compare", "--diff", diff, k_png) : 0;
    if (!rc && flip_map) rc = app_check_output("photongi compare", "--flip-map", flip_map, k_png);
    if (rc) return rc;
    /* the maps must not overwrite each other or an image compared (A and B may be one file) */
    for (int k = 0; k < 2 && (diff || flip_map); k++) {
        const char *names[] = {"--diff", "--flip-map", k ? "the reference" : "the image"},
                   *paths[] = {diff, flip_map, files[k]};
        if ((rc = app_check_distinct("photongi compare", 3, names, paths))) return rc;
    }
    pgi_image img[2] = {{0}, {0}};
    int hdr[2] = {0, 0};
    if ((rc = compare_read(&c, img, hdr))) return rc;
    note_sidecars(files[0], files[1]);
    char half[4200];
    const double noise = hdr[1] ? reference_noise(files[1], &img[1], c.exposure, half, sizeof half) : 0.0;
    const size_t n = (size_t)img[0].width * img[0].height;
    float *fmap = flip_map ? malloc(n * sizeof *fmap) : NULL;
    pgi_metrics m;
    pgi_status st = flip_map && !fmap ? PGI_ERR_OOM : pgi_metrics_compute_flip(&img[0], &img[1], 1.f, c.ppd, fmap, &m);
    if (st) {
        free(fmap);
        pgi_image_free(&img[0]);
        pgi_image_free(&img[1]);
        /* sizes differ, smaller than the SSIM window: the images are at fault, not the command line */
        const char *msg = pgi_last_error();
        if (strncmp(msg, "compare: ", 9) == 0) msg += 9;
        return cli_failure("compare", "%s vs %s: %s", files[0], files[1], *msg ? msg : pgi_status_string(st));
    }
    const char *what = NULL;
    st = compare_maps(&c, img, fmap, &what);
    free(fmap);
    pgi_image_free(&img[0]);
    pgi_image_free(&img[1]);
    if (st) return cli_fail("compare", what, st);
    compare_print(&m, c.json, noise, half);
    return 0;
}
