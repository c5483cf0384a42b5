/* sRGB decoding in one place (src/core/srgb.c): the texture table agrees with
 * the formula (three entries are one float ulp below it, kept for
 * bit-identical textured renders), and decoding a byte then tone mapping it
 * gives the byte back (what the image reader promises for PNGs). */
#include "test_util.h"

#include "core/core.h"

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

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_texture_lut_matches_formula),
        cmocka_unit_test(test_decode_then_tonemap_round_trips),
    };
    return cmocka_run_group_tests_name("srgb", tests, NULL, NULL);
}
