/* photongi compare A B [--json] [--diff heat.png]: PSNR and SSIM of A against
 * the reference B on the tone-mapped images (include/photongi/metrics.h). */
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
    "usage: photongi compare A B [--json] [--diff HEAT.png] [--diff-max E] [--exposure X]\n"
    "\n"
    "Compares image A with the reference B (PNG or EXR, same size, at least 11x11). Both are\n"
    "tone-mapped as 'render' writes PNG (exposure, sRGB, 8 bits; a PNG compares by its bytes).\n"
    "\n"
    "  PSNR      10 log10(1/MSE) on sRGB values in [0,1], all channels ('inf': identical)\n"
    "  SSIM      Wang et al. 2004 as scikit-image: 11x11 Gaussian window, sigma 1.5, K1 0.01,\n"
    "            K2 0.03, data range 1, mean over the map without its 5-pixel border;\n"
    "            on luma (0.2126 R' + 0.7152 G' + 0.0722 B'), and the mean of R, G, B\n"
    "\n"
    "  --json          print the result as one JSON object on standard output\n"
    "  --diff FILE     write a heat map PNG of the largest channel difference per pixel\n"
    "                  (black 0 -> red -> yellow -> white at --diff-max)\n"
    "  --diff-max E    difference shown as white, in [0,1] units (default 0.1)\n"
    "  --exposure X    multiply EXR radiance by X before tone mapping (default 1)\n"
    "\n"
    "Exit status: 0 success, 2 usage error, 1 failure (an image missing, unreadable, or not\n"
    "comparable with the other; see 'photongi --help').\n";

/* sRGB EOTF in float, as the viewer's screenshot has it (apps use the public API only, so not the
 * library's internal pgi__srgb_to_linear, which is in double). The two differ by a few float ulps for
 * most bytes: a PNG heat map gets the same bytes either way, an EXR one would not. */
static float srgb_to_linear(float c) { return c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f); }

int pgi_cmd_compare(int argc, char **argv) {
    const char *files[2] = {NULL, NULL}, *diff = NULL;
    int nfiles = 0, json = 0;
    float exposure = 1.f, diff_max = 0.1f;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            fputs(k_compare_help, stdout);
            return 0;
        } else if (strcmp(a, "--json") == 0) {
            json = 1;
        } else if (strcmp(a, "--diff") == 0 || strcmp(a, "--diff-max") == 0 || strcmp(a, "--exposure") == 0) {
            if (i + 1 >= argc) return cli_usage("compare", "%s needs a value", a);
            const char *v = argv[++i];
            if (strcmp(a, "--diff") == 0) diff = v;
            else if (!parse_pos_float(v, strcmp(a, "--exposure") == 0 ? &exposure : &diff_max))
                return cli_usage("compare", "%s needs a positive number, got '%s'", a, v);
        } else if (a[0] == '-' && a[1]) {
            return cli_usage("compare", "unknown option '%s'", a);
        } else {
            if (nfiles == 2) return cli_usage("compare", "unexpected argument '%s' (give two images)", a);
            files[nfiles++] = a;
        }
    }
    if (nfiles != 2) return cli_usage("compare", "%s", "give two images: photongi compare TEST REFERENCE");
    static const char *const k_png[] = {".png", NULL};
    int rc = diff ? app_check_output("photongi compare", "--diff", diff, k_png) : 0;
    if (rc) return rc;
    pgi_image img[2] = {{0}, {0}};
    for (int k = 0; k < 2; k++) {
        pgi_status st = pgi_image_read(files[k], &img[k], NULL);
        if (st) {
            pgi_image_free(&img[0]);
            return cli_input_fail("compare", "cannot read", st);
        }
    }
    pgi_metrics m;
    pgi_status st = pgi_metrics_compute(&img[0], &img[1], exposure, &m);
    if (st) {
        pgi_image_free(&img[0]);
        pgi_image_free(&img[1]);
        /* sizes differ, smaller than the SSIM window: the images are at fault, not the command line */
        const char *msg = pgi_last_error();
        if (strncmp(msg, "compare: ", 9) == 0) msg += 9;
        return cli_failure("compare", "%s vs %s: %s", files[0], files[1], *msg ? msg : pgi_status_string(st));
    }
    if (diff) {
        size_t n = (size_t)img[0].width * img[0].height;
        unsigned char *heat = malloc(3 * n);
        pgi_image hi = {img[0].width, img[0].height, malloc(3 * n * sizeof(float))};
        if (!heat || !hi.rgb) {
            free(heat);
            pgi_image_free(&hi);
            pgi_image_free(&img[0]);
            pgi_image_free(&img[1]);
            return cli_failure("compare", "%s", "out of memory for the heat map");
        }
        st = pgi_metrics_heatmap(&img[0], &img[1], exposure, diff_max, heat);
        /* Bytes -> linear, so that the PNG writer's sRGB tone map gives them back. */
        for (size_t i = 0; i < 3 * n; i++) hi.rgb[i] = srgb_to_linear((float)heat[i] / 255.f);
        if (!st) st = pgi_image_write(&hi, diff, 1.f);
        free(heat);
        pgi_image_free(&hi);
        if (st) {
            pgi_image_free(&img[0]);
            pgi_image_free(&img[1]);
            return cli_fail("compare", "cannot write the heat map", st);
        }
    }
    pgi_image_free(&img[0]);
    pgi_image_free(&img[1]);
    char psnr[32];
    if (isinf(m.psnr)) snprintf(psnr, sizeof psnr, json ? "null" : "inf");
    else snprintf(psnr, sizeof psnr, "%.8f", m.psnr);
    if (json) {
        printf("{\"width\": %d, \"height\": %d, \"psnr\": %s, \"mse\": %.9g, \"ssim\": %.8f, \"ssim_rgb\": %.8f, "
               "\"ssim_r\": %.8f, \"ssim_g\": %.8f, \"ssim_b\": %.8f, \"max_abs\": %.6f}\n",
               m.width, m.height, psnr, m.mse, m.ssim, m.ssim_rgb, m.ssim_channel[0], m.ssim_channel[1],
               m.ssim_channel[2], m.max_abs);
    } else {
        printf("PSNR %s dB  SSIM %.4f (luma)  %.4f (RGB mean: %.4f %.4f %.4f)  max diff %.4f  %dx%d\n", psnr, m.ssim,
               m.ssim_rgb, m.ssim_channel[0], m.ssim_channel[1], m.ssim_channel[2], m.max_abs, m.width, m.height);
    }
    return 0;
}
