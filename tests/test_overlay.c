/* The viewer's overlay (apps/viewer/overlay.h) stays readable over a white
 * scene: every pixel around the glyphs is dark enough for a WCAG contrast of
 * 4.5:1 with the text colour, the glyphs keep their colour, and the image
 * outside the box behind the text is left alone. */
#include "test_util.h"

#include "overlay.h"

/* WCAG relative luminance of an 8-bit sRGB colour. */
static double rel_lum(const unsigned char *c) {
    static const double w[3] = {0.2126, 0.7152, 0.0722};
    double l = 0.0;
    for (int k = 0; k < 3; k++) {
        double v = c[k] / 255.0;
        l += w[k] * (v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4));
    }
    return l;
}

static void check_readable(int scale) {
    enum { W = 1100, H = 160, N = 3 };
    const char *lines[N] = {"cornell | hashgrid (2/11) | 4.2 FPS, 238 ms a frame",
                            "photons 200000 stored / 212345 paths, r 0.04, contributing 12.5% of 1234567 reads",
                            "H hides this; see photongi-view --help for keys"};
    const unsigned char rgb[N][3] = {{255, 255, 255}, {255, 255, 255}, {190, 190, 190}};
    const int x0 = 6, y0 = 6;
    unsigned char *img = malloc(3 * W * H), *mask = calloc(3 * W * H, 1);
    assert_non_null(img);
    assert_non_null(mask);
    memset(img, 255, 3 * W * H); /* a white scene */
    int box[4];
    overlay_lines(img, W, H, x0, y0, scale, lines, N, rgb, box);
    /* Where the glyphs are: the same lines drawn in white on black (their shadows are black). */
    static const unsigned char white[3] = {255, 255, 255};
    for (int i = 0; i < N; i++) overlay_text(mask, W, H, x0, y0 + i * 10 * scale, scale, lines[i], white);

    double worst = 1e9;
    size_t glyph_px = 0;
    for (int i = 0; i < N; i++) {
        const double lt = rel_lum(rgb[i]);
        /* The line's cell rows, shadow included, across the line's width. */
        const int ya = y0 + i * 10 * scale, yb = ya + 9 * scale, xb = x0 + overlay_text_width(lines[i], scale);
        for (int y = ya; y < yb; y++)
            for (int x = x0; x < xb; x++) {
                const unsigned char *p = img + 3 * ((size_t)y * W + x);
                if (mask[3 * ((size_t)y * W + x)]) {
                    glyph_px++;
                    if (memcmp(p, rgb[i], 3) != 0)
                        fail_msg("scale %d: glyph pixel (%d, %d) lost its colour", scale, x, y);
                    continue;
                }
                double ratio = (lt + 0.05) / (rel_lum(p) + 0.05);
                if (ratio < worst) worst = ratio;
            }
    }
    fprintf(stderr, "  scale %d: %zu glyph pixels, lowest text/background contrast %.2f:1 (box %d,%d-%d,%d)\n", scale,
            glyph_px, worst, box[0], box[1], box[2], box[3]);
    assert_true(glyph_px > 1000);
    assert_true(worst >= 4.5);
    /* Only the box is dimmed: the pixels just outside it are the scene's. */
    assert_true(box[2] < W && box[3] < H);
    const int outside[3][2] = {{box[2], box[1] + 1}, {box[0] + 1, box[3]}, {W - 1, H - 1}};
    for (int k = 0; k < 3; k++) {
        const unsigned char *p = img + 3 * ((size_t)outside[k][1] * W + outside[k][0]);
        if (p[0] != 255 || p[1] != 255 || p[2] != 255)
            fail_msg("scale %d: pixel (%d, %d) outside the box changed", scale, outside[k][0], outside[k][1]);
    }
    free(img);
    free(mask);
}

static void test_overlay_readable_on_white(void **state) {
    check_readable(1);
    check_readable(2);
}

int main(void) {
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_overlay_readable_on_white)};
    return cmocka_run_group_tests_name("overlay", tests, NULL, NULL);
}
