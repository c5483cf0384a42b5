/* sRGB decoding in one place (src/core/srgb.c): the texture table agrees with
 * the formula (three entries are one float ulp below it, kept for
 * bit-identical textured renders), and decoding a byte then tone mapping it
 * gives the byte back (what the image reader promises for PNGs). */
#include "test_util.h"

#include "core/core.h"
#include "scene/scene_internal.h"

static void test_texture_lut_matches_formula(void **state) {
    (void)state;
    for (int i = 0; i < 256; i++) {
        float f = (float)pgi__srgb_to_linear(i / 255.0);
        float t = pgi__srgb8_texture_lut[i];
        if (i == 98 || i == 122 || i == 164) assert_true(t == nextafterf(f, 0.f));
        else assert_true(t == f);
    }
}

static void test_decode_then_tonemap_round_trips(void **state) {
    (void)state;
    float rgb[3 * 256];
    for (int i = 0; i < 256; i++)
        for (int c = 0; c < 3; c++) rgb[3 * i + c] = (float)pgi__srgb_to_linear(i / 255.0);
    pgi_image img = {256, 1, rgb};
    unsigned char out[3 * 256];
    pgi_tonemap_srgb8(&img, 1.f, out);
    for (int i = 0; i < 3 * 256; i++) assert_int_equal(out[i], i / 3);
}

/* The table-driven tone map gives the bytes of the formula (exposure, clamp, exact OETF in
 * double, round to nearest) for every 64th float in [0, 1], each one's neighbours, values
 * around every code's threshold, and out-of-range and non-finite values. */
static unsigned char tonemap_formula(float value, float exposure) {
    float v = value * exposure;
    if (!(v > 0.f)) return 0;
    if (v >= 1.f) return 255;
    double x = (double)v, e = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    int b = (int)(e * 255.0 + 0.5);
    return (unsigned char)(b > 255 ? 255 : b);
}

static void test_tonemap_matches_formula(void **state) {
    (void)state;
    enum { N = (0x3f800000 >> 6) + 1 + 8 }; /* the sweep, then the extras */
    float *v = malloc(N * sizeof *v);
    unsigned char *out = malloc(N);
    assert_non_null(v);
    assert_non_null(out);
    size_t n = 0;
    for (uint32_t bits = 0; bits <= 0x3f800000u; bits += 64) memcpy(&v[n++], &bits, sizeof(float));
    const float extra[] = {-1.f, -0.f, NAN, INFINITY, -INFINITY, 1.5f, 1e30f, 0x1p-149f};
    for (int k = 0; k < 8; k++) v[n++] = extra[k];
    pgi_image img = {(int)n, 1, NULL};
    float *rgb = malloc(3 * n * sizeof *rgb);
    unsigned char *out3 = malloc(3 * n);
    assert_non_null(rgb);
    assert_non_null(out3);
    for (size_t i = 0; i < n; i++) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = v[i];
    img.rgb = rgb;
    const float exposures[] = {1.f, 0.37f, 3.f};
    for (int e = 0; e < 3; e++) {
        pgi_tonemap_srgb8(&img, exposures[e], out3);
        for (size_t i = 0; i < n; i++)
            if (out3[3 * i] != tonemap_formula(v[i], exposures[e]))
                fail_msg("value %a exposure %g: %d, formula %d", (double)v[i], (double)exposures[e], out3[3 * i],
                         tonemap_formula(v[i], exposures[e]));
    }
    /* Around each code's threshold, one ulp at a time: one pixel at a time (the scalar code), then
     * all of them in one image (the vector code where the CPU has it). */
    size_t steps = 0;
    for (size_t i = 0; i + 1 < n; i++) steps += tonemap_formula(v[i], 1.f) != tonemap_formula(v[i + 1], 1.f);
    float *near = malloc(3 * 66 * steps * sizeof *near);
    unsigned char *near8 = malloc(3 * 66 * steps);
    assert_non_null(near);
    assert_non_null(near8);
    size_t m = 0;
    for (size_t i = 0; i + 1 < n; i++) {
        if (tonemap_formula(v[i], 1.f) == tonemap_formula(v[i + 1], 1.f)) continue;
        float a = v[i];
        for (int s = 0; s < 66; s++, a = nextafterf(a, 2.f)) {
            pgi_image one = {1, 1, (float[3]){a, a, a}};
            unsigned char o[3];
            pgi_tonemap_srgb8(&one, 1.f, o);
            assert_int_equal(o[0], tonemap_formula(a, 1.f));
            near[3 * m] = near[3 * m + 1] = near[3 * m + 2] = a;
            m++;
        }
    }
    pgi_image all = {(int)m, 1, near};
    pgi_tonemap_srgb8(&all, 1.f, near8);
    for (size_t i = 0; i < 3 * m; i++) assert_int_equal(near8[i], tonemap_formula(near[i], 1.f));
    free(near);
    free(near8);
    free(v);
    free(out);
    free(rgb);
    free(out3);
}

/* pgi__texture_lookup16_soa (the view pass's lookups of a uniform tile) equals
 * pgi__texture_lookup lane by lane, bit for bit, in each build the CPU can take (AVX-512 permutes,
 * AVX2 gathers, the narrow lookups): textures of odd sizes, coordinates anywhere (negative, past
 * 1, on texel centres and edges, huge, non-finite). */
static void test_texture_lookup16_builds(void **state) {
    (void)state;
    pgi_scene *s = calloc(1, sizeof *s);
    assert_non_null(s);
    const int sizes[][2] = {{1, 1}, {3, 5}, {64, 64}, {257, 130}};
    tu_rng r = tu_rng_make(11);
    for (size_t t = 0; t < sizeof sizes / sizeof sizes[0]; t++) {
        const int w = sizes[t][0], h = sizes[t][1];
        unsigned char *rgba = malloc(4 * (size_t)w * h);
        assert_non_null(rgba);
        for (size_t k = 0; k < 4 * (size_t)w * h; k++) rgba[k] = (unsigned char)(tu_next(&r) >> 56);
        int idx = -1;
        TU_CHECK_OK(pgi__scene_add_texture(s, w, h, 4, rgba, "test", &idx));
    }
    for (size_t t = 0; t < s->ntexs; t++) {
        const pgi__texture *tex = &s->texs[t];
        for (int round = 0; round < 200; round++) {
            float u[16], v[16];
            for (int k = 0; k < 16; k++) {
                const int kind = (int)((uint32_t)tu_next(&r) % 8);
                const float a = tu_unif(&r), b = tu_unif(&r);
                switch (kind) {
                case 0: u[k] = a, v[k] = b; break;
                case 1: u[k] = 4.f * a - 2.f, v[k] = 4.f * b - 2.f; break; /* wrapping */
                case 2:                                                    /* texel centres and edges */
                    u[k] = (float)((uint32_t)tu_next(&r) % 64) / (2.f * (float)tex->width);
                    v[k] = (float)((uint32_t)tu_next(&r) % 64) / (2.f * (float)tex->height);
                    break;
                case 3: u[k] = 1e6f * a, v[k] = -3e5f * b; break;
                case 4: u[k] = NAN, v[k] = b; break;
                case 5: u[k] = a, v[k] = -INFINITY; break;
                case 6: u[k] = 1.f, v[k] = 0.f; break;
                default: u[k] = -0.f, v[k] = 1.f - 1e-7f; break;
                }
            }
            for (int build = 0; build < 3; build++) {
                pgi__cpu_no512 = build >= 1;
                pgi__cpu_narrow = build == 2;
                float out[3][16];
                pgi__texture_lookup16_soa(tex, u, v, out);
                pgi__cpu_no512 = pgi__cpu_narrow = 0;
                for (int k = 0; k < 16; k++) {
                    const pgi__v3 e = pgi__texture_lookup(tex, u[k], v[k]);
                    const float ev[3] = {e.x, e.y, e.z};
                    for (int c = 0; c < 3; c++)
                        if (memcmp(&out[c][k], &ev[c], sizeof(float)) != 0)
                            fail_msg("texture %dx%d, build %d, (%g, %g) component %d: %.9g, expected %.9g", tex->width,
                                     tex->height, build, (double)u[k], (double)v[k], c, (double)out[c][k],
                                     (double)ev[c]);
                }
            }
        }
    }
    pgi_scene_destroy(s);
}

TU_MAIN("srgb", NULL, NULL, cmocka_unit_test(test_texture_lut_matches_formula),
        cmocka_unit_test(test_texture_lookup16_builds), cmocka_unit_test(test_decode_then_tonemap_round_trips),
        cmocka_unit_test(test_tonemap_matches_formula))
