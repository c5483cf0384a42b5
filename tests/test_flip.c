/* LDR-FLIP (src/metrics/flip.c) against the values the metric's reference implementation
 * computed for the 12 image pairs of ../shared/flip/ (its README: viewing conditions, pooling,
 * tolerances). Every pair: the mean within 1e-5 of the double-accumulated mean, the weighted
 * median and quartiles (the tool's float pooling), min and max within 1e-5; the sampled pixels of pairs 03, 04 and 07
 * within 1e-4; the tool's grayscale maps within one 8-bit step everywhere. Plus properties the
 * paper states: identical images give 0, more noise more error, and a farther viewer (more
 * pixels per degree) sees fine noise blurred away. The folder: $PHOTONGI_FLIP_DATA, else the configured
 * PGI__FLIP_DATA (the source tree's ../shared/flip). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include "test_util.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "photongi/metrics.h"

static const char *data_dir(void) {
    const char *d = getenv("PHOTONGI_FLIP_DATA");
    return d && *d ? d : PGI__FLIP_DATA;
}

static char *slurp(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *s = malloc((size_t)n + 1);
    if (s && fread(s, 1, (size_t)n, f) != (size_t)n) {
        free(s);
        s = NULL;
    }
    if (s) s[n] = 0;
    fclose(f);
    return s;
}

/* The 8-bit sRGB bytes of a PNG: pgi_image_read decodes sRGB so that tone mapping at exposure 1
 * gives the bytes back. */
static unsigned char *read_srgb8(const char *name, int *w, int *h) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", data_dir(), name);
    pgi_image img = {0};
    if (pgi_image_read(path, &img, NULL) != PGI_OK) fail_msg("cannot read %s: %s", path, pgi_last_error());
    unsigned char *b = malloc((size_t)img.width * img.height * 3);
    assert_non_null(b);
    pgi_tonemap_srgb8(&img, 1.f, b);
    *w = img.width;
    *h = img.height;
    pgi_image_free(&img);
    return b;
}

static double num(const cJSON *o, const char *key) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(v)) fail_msg("values.json: no number '%s'", key);
    return v->valuedouble;
}

static void check_close(const char *what, int pair, double got, double want, double tol) {
    if (!(fabs(got - want) <= tol))
        fail_msg("pair %02d %s: %.9g, the reference tool %.9g (|diff| %.3g > %.1g)", pair, what, got, want,
                 fabs(got - want), tol);
}

static void test_reference_pairs(void **state) {
    (void)state;
    char path[1024];
    snprintf(path, sizeof path, "%s/values.json", data_dir());
    char *text = slurp(path);
    if (!text) fail_msg("cannot read %s (set PHOTONGI_FLIP_DATA to the folder of FLIP test pairs)", path);
    cJSON *root = cJSON_Parse(text);
    free(text);
    assert_non_null(root);
    const cJSON *pairs = cJSON_GetObjectItemCaseSensitive(root, "pairs");
    assert_true(cJSON_IsArray(pairs));
    assert_int_equal(cJSON_GetArraySize(pairs), 12);
    const float ppd = pgi_flip_ppd(0.7f, 3840.f, 0.7f);
    assert_true(fabsf(ppd - PGI_FLIP_DEFAULT_PPD) < 1e-5f);
    int checked_pixels = 0;
    const cJSON *p;
    cJSON_ArrayForEach(p, pairs) {
        int id = (int)num(p, "pair"), w, h, w2, h2;
        unsigned char *ref = read_srgb8(cJSON_GetObjectItemCaseSensitive(p, "reference")->valuestring, &w, &h);
        unsigned char *test = read_srgb8(cJSON_GetObjectItemCaseSensitive(p, "test")->valuestring, &w2, &h2);
        assert_int_equal(w, (int)num(p, "width"));
        assert_int_equal(h, (int)num(p, "height"));
        assert_int_equal(w, w2);
        assert_int_equal(h, h2);
        const size_t n = (size_t)w * h;
        float *map = malloc(n * sizeof *map);
        assert_non_null(map);
        assert_int_equal(pgi_flip_map_srgb8(ref, test, w, h, ppd, map), PGI_OK);
        pgi_flip_stats st;
        assert_int_equal(pgi_flip_pool(map, n, &st), PGI_OK);
        check_close("mean", id, st.mean, num(p, "mean_exact"), 1e-5);
        check_close("weighted median", id, st.weighted_median, num(p, "weighted_median"), 1e-5);
        check_close("weighted Q1", id, st.weighted_q1, num(p, "weighted_q1"), 1e-5);
        check_close("weighted Q3", id, st.weighted_q3, num(p, "weighted_q3"), 1e-5);
        check_close("min", id, st.min, num(p, "min"), 1e-5);
        check_close("max", id, st.max, num(p, "max"), 1e-5);
        const cJSON *samples = cJSON_GetObjectItemCaseSensitive(p, "pixel_samples"), *s;
        cJSON_ArrayForEach(s, samples) {
            int x = (int)num(s, "x"), y = (int)num(s, "y");
            char what[64];
            snprintf(what, sizeof what, "pixel (%d, %d)", x, y);
            check_close(what, id, map[(size_t)y * w + x], num(s, "flip"), 1e-4);
            checked_pixels++;
        }
        if (samples) {
            /* the tool's grayscale map: (uint8)(255 * clamp(flip) + 0.5), within one step */
            char name[64];
            snprintf(name, sizeof name, "pair_%02d_flipmap_gray.png", id);
            int gw, gh;
            unsigned char *gray = read_srgb8(name, &gw, &gh);
            assert_int_equal(gw, w);
            assert_int_equal(gh, h);
            for (size_t i = 0; i < n; i++) {
                int mine = (int)(255.f * fminf(fmaxf(map[i], 0.f), 1.f) + 0.5f);
                if (abs(mine - gray[3 * i]) > 1)
                    fail_msg("pair %02d pixel %zu: map byte %d, the tool's %d", id, i, mine, gray[3 * i]);
            }
            free(gray);
        }
        free(map);
        free(ref);
        free(test);
    }
    assert_int_equal(checked_pixels, 3 * 64);
    cJSON_Delete(root);
}

/* A grey image against itself with noise: 0 for identical images, more for more noise, less when
 * seen from farther away (more pixels per degree: the CSF filters the noise out). */
static void test_properties(void **state) {
    (void)state;
    enum { W = 48, H = 40 };
    unsigned char a[W * H * 3], b[W * H * 3], c[W * H * 3];
    unsigned s = 12345;
    for (int i = 0; i < W * H * 3; i++) {
        s = s * 1664525u + 1013904223u;
        int noise = (int)(s >> 28) - 8; /* -8..7 */
        a[i] = 128;
        b[i] = (unsigned char)(128 + noise);
        c[i] = (unsigned char)(128 + 4 * noise);
    }
    float map[W * H];
    pgi_flip_stats same, small, big, far;
    assert_int_equal(pgi_flip_map_srgb8(a, a, W, H, PGI_FLIP_DEFAULT_PPD, map), PGI_OK);
    assert_int_equal(pgi_flip_pool(map, W * H, &same), PGI_OK);
    assert_true(same.max == 0.0);
    assert_int_equal(pgi_flip_map_srgb8(a, b, W, H, PGI_FLIP_DEFAULT_PPD, map), PGI_OK);
    assert_int_equal(pgi_flip_pool(map, W * H, &small), PGI_OK);
    assert_int_equal(pgi_flip_map_srgb8(a, c, W, H, PGI_FLIP_DEFAULT_PPD, map), PGI_OK);
    assert_int_equal(pgi_flip_pool(map, W * H, &big), PGI_OK);
    assert_int_equal(pgi_flip_map_srgb8(a, c, W, H, 4 * PGI_FLIP_DEFAULT_PPD, map), PGI_OK);
    assert_int_equal(pgi_flip_pool(map, W * H, &far), PGI_OK);
    assert_true(small.mean > 0.0);
    assert_true(big.mean > 2.0 * small.mean);
    assert_true(far.mean < big.mean);
    assert_true(big.weighted_q1 <= big.weighted_median && big.weighted_median <= big.weighted_q3);
    assert_true(big.min <= big.weighted_q1 && big.weighted_q3 <= big.max && big.max <= 1.0);

    /* bad arguments: a clear status, no crash */
    assert_int_equal(pgi_flip_map_srgb8(a, b, 0, H, PGI_FLIP_DEFAULT_PPD, map), PGI_ERR_INVALID_ARG);
    assert_int_equal(pgi_flip_map_srgb8(a, b, W, H, NAN, map), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "pixels per degree"));
    assert_int_equal(pgi_flip_pool(map, 0, &far), PGI_ERR_INVALID_ARG);
}

/* pgi_metrics_compute reports FLIP on the images `render` writes, test against reference. */
static void test_metrics_carry_flip(void **state) {
    (void)state;
    enum { W = 32, H = 24 };
    float ra[W * H * 3], rb[W * H * 3];
    for (int i = 0; i < W * H * 3; i++) {
        ra[i] = 0.2f;
        rb[i] = (i / 3) % W < W / 2 ? 0.2f : 0.25f;
    }
    pgi_image a = {W, H, ra}, b = {W, H, rb};
    pgi_metrics m;
    assert_int_equal(pgi_metrics_compute(&a, &b, 1.f, &m), PGI_OK);
    assert_true(m.flip.mean > 0.0 && m.flip.mean < 1.0);
    assert_true(fabsf(m.flip.ppd - PGI_FLIP_DEFAULT_PPD) < 1e-6f);
    pgi_flip_stats st;
    float *map = malloc(W * H * sizeof *map);
    assert_int_equal(pgi_metrics_flip(&a, &b, 1.f, PGI_FLIP_DEFAULT_PPD, map, &st), PGI_OK);
    assert_true(st.mean == m.flip.mean);
    /* the left half is identical and far from the edge: no error there */
    assert_true(map[(H / 2) * W + 2] < 0.05f);
    assert_true(map[(H / 2) * W + W - 3] > 0.0f);
    free(map);
}

TU_MAIN("flip", NULL, NULL, cmocka_unit_test(test_reference_pairs), cmocka_unit_test(test_properties),
        cmocka_unit_test(test_metrics_carry_flip))
