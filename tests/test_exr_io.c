/* EXR files read back as written, bit for bit, including the ZIP chunk whose zlib stream is
 * exactly as long as its packed pixels: OpenEXRCore (3.1.5, and later releases until the fix of
 * AcademySoftwareFoundation/openexr#2306) stores that stream where the format means the packed
 * pixels, and the chunk reads back as garbage (the NaN and 1e38 pixels in the last rows of Sibenik's
 * strafe reference at frame 20, bench/temporal.c). image_io.c's write_exr stores such a chunk's
 * pixels uncompressed. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "photongi/metrics.h"
#include "photongi/photongi.h"
#include "photongi/reference.h"
#include "test_util.h"

/* The bytes of a file (NULL: cannot read). */
static unsigned char *slurp(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = len > 0 ? malloc((size_t)len) : NULL;
    if (b && fread(b, 1, (size_t)len, f) != (size_t)len) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *n = b ? (size_t)len : 0;
    return b;
}

static uint32_t rd32(const unsigned char *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* The stored size of the first chunk of a one-part scanline EXR (-1: not understood): the header's
 * attributes (name, type, size, value) up to an empty name, then the chunk offsets, then at the first
 * offset the chunk's y and its size. */
static long first_chunk_size(const unsigned char *b, size_t n) {
    size_t p = 8;
    while (p < n && b[p]) {
        for (int k = 0; k < 2; k++) { /* name, type */
            while (p < n && b[p]) p++;
            p++;
        }
        if (p + 4 > n) return -1;
        p += 4 + rd32(b + p);
    }
    p++;
    if (p + 8 > n) return -1;
    uint64_t off = (uint64_t)rd32(b + p) | (uint64_t)rd32(b + p + 4) << 32;
    if (off + 8 > n) return -1;
    return (long)rd32(b + off + 4);
}

static uint64_t rng_next(uint64_t *s) {
    uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Images of W x H pixels (one ZIP chunk of H < 16 lines) of noisy radiance-like floats (random
 * mantissas, exponents within a few octaves of 1) with the first `flat` values zero: the more of
 * them, the shorter the zlib stream, which crosses the packed size on the way. Every image reads
 * back bit for bit, and some of them have a chunk exactly as long as their pixels (the case that
 * read back as garbage). */
static void test_zip_chunk_as_long_as_its_pixels(void **state) {
    (void)state;
    enum { W = 40, H = 4 };
    const size_t nv = 3 * (size_t)W * H, packed = nv * sizeof(float);
    char path[64];
    snprintf(path, sizeof path, "/tmp/photongi-test-exr-%ld.exr", (long)getpid());
    pgi_image img = {.width = W, .height = H, .rgb = malloc(nv * sizeof(float))};
    assert_non_null(img.rgb);
    int equal = 0, shorter = 0;
    for (uint64_t seed = 1; seed <= 4; seed++) {
        for (size_t flat = 0; flat < nv / 3; flat++) {
            uint64_t s = seed;
            for (size_t i = 0; i < nv; i++) {
                uint64_t r = rng_next(&s);
                uint32_t bits = ((uint32_t)(124 + r % 6) << 23) | ((uint32_t)(r >> 20) & 0x7fffffu);
                memcpy(&img.rgb[i], &bits, sizeof bits);
                if (i < flat) img.rgb[i] = 0.f;
            }
            assert_int_equal(pgi_image_write(&img, path, 1.f), PGI_OK);
            size_t n = 0;
            unsigned char *b = slurp(path, &n);
            assert_non_null(b);
            long size = first_chunk_size(b, n);
            free(b);
            assert_true(size > 0 && (size_t)size <= packed);
            if ((size_t)size == packed) equal++;
            else shorter++;
            pgi_image back = {0};
            assert_int_equal(pgi_image_read(path, &back, NULL), PGI_OK);
            assert_int_equal(back.width, W);
            assert_int_equal(back.height, H);
            size_t bad = 0;
            for (size_t i = 0; i < nv; i++) bad += memcmp(&back.rgb[i], &img.rgb[i], sizeof(float)) != 0;
            if (bad)
                fail_msg("seed %llu, %zu zero values: %zu of %zu values read back changed (chunk %ld bytes, pixels "
                         "%zu)",
                         (unsigned long long)seed, flat, bad, nv, size, packed);
            pgi_image_free(&back);
        }
    }
    fprintf(stderr, "  %d images with a chunk as long as its pixels, %d with a shorter one\n", equal, shorter);
    assert_true(equal > 0); /* the sweep met the case it is here for */
    free(img.rgb);
    remove(path);
}

/* Where it was found: the first 128 samples of Sibenik's 320x180 reference at frame 20 of
 * bench-temporal's strafe (--step 0.001; the camera as the bench moves it, 20 x 0.001 scene
 * diagonals to the right), kept as EXR: the last chunk (rows 176..179) compresses to exactly its
 * 15360 bytes and read back with 25 NaN values and others near 1e38. The render is finite; the file
 * must read back as it. */
static void test_sibenik_strafe_reference(void **state) {
    (void)state;
    char mesh[1024];
    snprintf(mesh, sizeof mesh, "%s/sibenik/sibenik.obj", tu_scenes_dir());
    if (!tu_file_exists("scenes/sibenik.json") || !tu_file_exists(mesh)) {
        fprintf(stderr, "skipping: scenes/sibenik.json or %s not found (set PHOTONGI_SCENES)\n", mesh);
        skip();
    }
    pgi_scene *s = tu_scene("sibenik");
    const pgi_camera_def cam = {.eye = {-18.f, -13.5f, 1.06743646f},
                                .look_at = {10.f, -12.f, 1.06743646f},
                                .up = {0.f, 1.f, 0.f},
                                .fov_y_deg = 60.f};
    pgi_reference_desc d = {.width = 320, .height = 180, .spp = 128, .view = &cam};
    pgi_image img = {0}, back = {0};
    uint64_t spp = 0;
    assert_int_equal(pgi_reference_render(s, &d, &img, &spp), PGI_OK);
    const size_t nv = 3 * (size_t)img.width * img.height;
    for (size_t i = 0; i < nv; i++) assert_true(isfinite(img.rgb[i]));
    char path[64];
    snprintf(path, sizeof path, "/tmp/photongi-test-exr-sibenik-%ld.exr", (long)getpid());
    assert_int_equal(pgi_image_write(&img, path, 1.f), PGI_OK);
    assert_int_equal(pgi_image_read(path, &back, NULL), PGI_OK);
    remove(path);
    assert_int_equal(back.width, img.width);
    assert_int_equal(back.height, img.height);
    size_t bad = 0, changed = 0;
    for (size_t i = 0; i < nv; i++) {
        bad += !isfinite(back.rgb[i]);
        changed += memcmp(&back.rgb[i], &img.rgb[i], sizeof(float)) != 0;
    }
    if (bad || changed) fail_msg("read back: %zu non-finite values, %zu changed", bad, changed);
    pgi_image_free(&img);
    pgi_image_free(&back);
    pgi_scene_destroy(s);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zip_chunk_as_long_as_its_pixels),
        cmocka_unit_test(test_sibenik_strafe_reference),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
