/* Pixel-area sampling: where in its pixel a view sample looks.
 *
 * A straight edge crosses pixels at known covered fractions f. The scene
 * shows only emission (black, emissive quads; photons land on a white wall
 * behind the camera and on the quads, whose albedo is 0), so every pixel is
 * exactly  bg + f (obj - bg)  in the limit of a box filter over the pixel:
 * the progressive average and the path-traced reference must approach it,
 * while pixel-centre sampling gives bg or obj (off by at least 0.225 here).
 * Pixels the edge does not cross are bg or obj exactly in every frame: the
 * jittered points never leave their pixel. */
#include "test_util.h"

#include "photongi/reference.h"
#include "view/view.h"

#define EW 32
#define EH 32
#define OBJ 1.0   /* Ke of the foreground quad */
#define BG 0.25   /* Ke of the background plane */
#define EDGE_X 16 /* column crossed by the vertical edge at x = 16.3 pixels: covered 0.7 */
#define EDGE_Y 20 /* row crossed by the horizontal edge at y = 20.6 pixels: covered 0.6 */

static char g_dir[512], g_json[700];
static pgi_scene *g_scene;

/* The camera at z = 3 looks at the origin with tan(fov_y / 2) = 1/3: the
 * plane z = 0 spans x, y in [-1, 1] over the 32x32 image, pixel column
 * px = 16 (x + 1) and row py = 16 (1 - y). The foreground quad (z = 0) covers
 * px >= 16.3 and py <= 20.6: x >= 0.01875, y >= -0.2875. */
static int setup(void **state) {
    (void)state;
    tu_make_tmpdir(g_dir, sizeof g_dir);
    char path[700], json[1400];
    snprintf(path, sizeof path, "%s/edge.mtl", g_dir);
    if (tu_write_file(path, "newmtl fg\nKd 0 0 0\nKe 1 1 1\nillum 1\n"
                            "newmtl bg\nKd 0 0 0\nKe 0.25 0.25 0.25\nillum 1\n"
                            "newmtl wall\nKd 0.8 0.8 0.8\nillum 1\n"))
        return -1;
    snprintf(path, sizeof path, "%s/edge.obj", g_dir);
    if (tu_write_file(path, "mtllib edge.mtl\n"
                            "v 0.01875 -0.2875 0\nv 3 -0.2875 0\nv 3 3 0\nv 0.01875 3 0\n" /* foreground, faces +z */
                            "v -4 -4 -1\nv 4 -4 -1\nv 4 4 -1\nv -4 4 -1\n"                 /* background, faces +z */
                            "v -10 -10 5\nv -10 10 5\nv 10 10 5\nv 10 -10 5\n"             /* wall behind the eye */
                            "usemtl fg\nf 1 2 3 4\nusemtl bg\nf 5 6 7 8\nusemtl wall\nf 9 10 11 12\n"))
        return -1;
    snprintf(json, sizeof json,
             "{\"name\": \"edge\", \"mesh\": \"%s\",\n"
             " \"camera\": {\"eye\": [0, 0, 3], \"look_at\": [0, 0, 0], \"up\": [0, 1, 0], \"fov_y\": %.12f}}\n",
             path, 2.0 * atan(1.0 / 3.0) * 180.0 / 3.14159265358979323846);
    snprintf(g_json, sizeof g_json, "%s/edge.json", g_dir);
    if (tu_write_file(g_json, json)) return -1;
    if (pgi_scene_load(g_json, &g_scene) != PGI_OK) {
        fprintf(stderr, "cannot load %s: %s\n", g_json, pgi_last_error());
        return -1;
    }
    return 0;
}

static int teardown(void **state) {
    (void)state;
    pgi_scene_destroy(g_scene);
    tu_rm_tmpdir(g_dir);
    return 0;
}

/* Covered fraction of pixel (x, y): the box-filter weight of the foreground. */
static double coverage(int x, int y) {
    double fx = x < EDGE_X ? 0.0 : x == EDGE_X ? 0.7 : 1.0;
    double fy = y > EDGE_Y ? 0.0 : y == EDGE_Y ? 0.6 : 1.0;
    return fx * fy;
}
static double expected(int x, int y) { return BG + coverage(x, y) * (OBJ - BG); }
static int crossed(int x, int y) { return coverage(x, y) > 0.0 && coverage(x, y) < 1.0; }

/* Every pixel the edge misses equals bg or obj (to float rounding of a mean);
 * every crossed pixel is within `tol` of bg + f (obj - bg), and so is their
 * mean within `mean_tol`. Returns the largest error at a crossed pixel. */
static double check_edges(const pgi_image *img, double tol, double mean_tol, const char *what) {
    assert_int_equal(img->width, EW);
    assert_int_equal(img->height, EH);
    double worst = 0.0, sum = 0.0, sum_expect = 0.0;
    int n = 0;
    for (int y = 0; y < EH; y++)
        for (int x = 0; x < EW; x++) {
            const float *p = img->rgb + 3 * ((size_t)y * EW + x);
            double e = expected(x, y);
            for (int c = 0; c < 3; c++) {
                double err = fabs((double)p[c] - e);
                if (!crossed(x, y) && err > 1e-6)
                    fail_msg("%s: pixel (%d, %d), not on the edge, is %.7f, expected %.7f exactly", what, x, y,
                             (double)p[c], e);
                if (crossed(x, y) && err > worst) worst = err;
            }
            if (crossed(x, y)) {
                if (fabs((double)p[0] - e) > tol)
                    fail_msg("%s: edge pixel (%d, %d) is %.4f, the pixel integral %.4f (covered %.2f; bound %.2f)",
                             what, x, y, (double)p[0], e, coverage(x, y), tol);
                sum += p[0];
                sum_expect += e;
                n++;
            }
        }
    assert_int_equal(n, EDGE_Y + (EW - EDGE_X)); /* column 16 down to row 20, row 20 from column 16 */
    double mean_err = (sum - sum_expect) / n;
    fprintf(stderr, "  %s: %d edge pixels, worst %.4f, mean error %+.4f\n", what, n, worst, mean_err);
    if (fabs(mean_err) > mean_tol)
        fail_msg("%s: edge pixels are off by %+.4f on average (bound %.3f)", what, mean_err, mean_tol);
    return worst;
}

static pgi_render_desc edge_desc(void) {
    return (pgi_render_desc){.estimator = "hashgrid",
                             .photons = 200,
                             .width = EW,
                             .height = EH,
                             .direct_samples = 1,
                             .seed = 5};
}

/* The progressive average converges to the pixel integral. 256 frames: frame
 * 0 is at pixel centres (value obj at every edge pixel, a bias of at most
 * 0.75 (1 - f)/256 = 0.002), frames 1..255 at points 1..255 of the pixel's
 * stratified sequence: the covered fraction of those is within 6.6/256 of f
 * (test_jitter_helper), 0.02 in value. Bounds: 0.03 a pixel, 0.01 for the
 * mean of the 36 (measured 0.007 and 0.002). Independent points would have
 * sd up to 0.023 a pixel and exceed 0.03 at some of the 36; centre sampling
 * misses by 0.225 (column, f = 0.7) to 0.435 (corner, f = 0.42). */
static void test_edge_progressive(void **state) {
    (void)state;
    pgi_render_desc d = edge_desc();
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(g_scene, &r));
    pgi_image img = {0};
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_render_progressive(r, &d, 256, &img, &fs));
    assert_int_equal(fs.frames, 256);
    assert_true(fs.photons_stored > 0);
    check_edges(&img, 0.03, 0.01, "progressive, 256 frames");
    /* --jitter off: the average stays at the pixel centres' values. */
    d.jitter = PGI_JITTER_OFF;
    TU_CHECK_OK(pgi_render_progressive(r, &d, 8, &img, &fs));
    assert_float_equal(img.rgb[3 * (5 * EW + EDGE_X)], OBJ, 1e-6);
    assert_float_equal(img.rgb[3 * (EDGE_Y * EW + 20)], OBJ, 1e-6);
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
}

/* The reference averages samples over the pixel (256 a pixel, points 0..255
 * of the same kind of sequence; same bounds, measured 0.008 and 0.0002); with
 * jitter off it samples pixel centres: obj at every edge pixel here. */
static void test_edge_reference(void **state) {
    (void)state;
    pgi_reference_desc rd = {.width = EW, .height = EH, .spp = 256, .seed = 3};
    pgi_image img = {0};
    uint64_t spp = 0;
    TU_CHECK_OK(pgi_reference_render(g_scene, &rd, &img, &spp));
    check_edges(&img, 0.03, 0.01, "reference, 256 spp");
    rd.jitter = PGI_JITTER_OFF;
    rd.spp = 4;
    spp = 0;
    TU_CHECK_OK(pgi_reference_render(g_scene, &rd, &img, &spp));
    for (int y = 0; y < EH; y++)
        for (int x = 0; x < EW; x++)
            if (crossed(x, y)) assert_float_equal(img.rgb[3 * ((size_t)y * EW + x)], OBJ, 1e-6);
    pgi_image_free(&img);
}

/* One frame: pixel centres by default (every edge pixel obj here, the centre
 * being covered); with PGI_JITTER_ON each pixel sees one point of itself (obj
 * or bg at an edge pixel, exact elsewhere), another point for another seed. */
static void test_single_frame(void **state) {
    (void)state;
    pgi_render_desc d = edge_desc();
    pgi_image img = {0}, other = {0};
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_render(g_scene, &d, &img, &fs));
    assert_int_equal(fs.settings.jitter, PGI_JITTER_OFF); /* AUTO resolves to centres for one frame */
    for (int y = 0; y < EH; y++)
        for (int x = 0; x < EW; x++) {
            double c = coverage(x, y) > 0.0 ? OBJ : BG;
            assert_float_equal(img.rgb[3 * ((size_t)y * EW + x)], c, 1e-6);
        }
    d.jitter = PGI_JITTER_ON;
    TU_CHECK_OK(pgi_render(g_scene, &d, &img, &fs));
    assert_int_equal(fs.settings.jitter, PGI_JITTER_ON);
    int obj = 0, bg = 0;
    for (int y = 0; y < EH; y++)
        for (int x = 0; x < EW; x++) {
            double v = img.rgb[3 * ((size_t)y * EW + x)];
            if (!crossed(x, y)) assert_float_equal(v, expected(x, y), 1e-6);
            else if (fabs(v - OBJ) < 1e-6) obj++;
            else if (fabs(v - BG) < 1e-6) bg++;
            else fail_msg("jittered frame: edge pixel (%d, %d) is %g, neither obj nor bg", x, y, v);
        }
    assert_true(obj > 0 && bg > 0); /* about 60% and 40% of the 36 */
    d.seed = 6;
    TU_CHECK_OK(pgi_render(g_scene, &d, &other, &fs));
    assert_true(memcmp(img.rgb, other.rgb, 3 * EW * EH * sizeof(float)) != 0);
    d.jitter = (pgi_jitter)7;
    assert_int_equal(pgi_render(g_scene, &d, &img, &fs), PGI_ERR_INVALID_ARG);
    pgi_image_free(&img);
    pgi_image_free(&other);
}

/* The one helper that places view samples: the centre without jitter; with
 * it, for each sequence index uniform over [0, 1)^2 per pixel, independent
 * across pixels, coordinates and seeds; and for each pixel the points of
 * indices 0..N-1 spread evenly (stratified), which independent points are
 * not: for N = 256 a box [0, f) x [0, g) of the pixel holds N f g points to
 * within 10 (measured: 6.6 at worst over 2000 rotations; independent points
 * have sd up to 8) and a strip [0, f) to within 4 (measured 2.8). */
static void test_jitter_helper(void **state) {
    (void)state;
    float jx, jy;
    pgi__subpixel sp = {.jitter = 0, .seed = 99, .index = 3};
    pgi__pixel_jitter(&sp, 12345, &jx, &jy);
    assert_true(jx == 0.5f && jy == 0.5f);
    const size_t n = 1u << 18;
    const uint32_t indices[] = {0, 37};
    for (int q = 0; q < 2; q++) {
        sp = (pgi__subpixel){.jitter = 1, .seed = 42, .index = indices[q]};
        pgi__subpixel other = {.jitter = 1, .seed = 43, .index = indices[q]};
        double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0, sxn = 0;
        int hist[16] = {0};
        float px = 0.f;
        int same = 0;
        for (size_t i = 0; i < n; i++) {
            pgi__pixel_jitter(&sp, i, &jx, &jy);
            assert_true(jx >= 0.f && jx < 1.f && jy >= 0.f && jy < 1.f);
            float a, b;
            pgi__pixel_jitter(&sp, i, &a, &b);
            assert_true(a == jx && b == jy); /* a function of (seed, index, pixel) only */
            pgi__pixel_jitter(&other, i, &a, &b);
            same += a == jx && b == jy;
            sx += jx, sy += jy, sxx += jx * jx, syy += jy * jy, sxy += jx * jy, sxn += jx * px;
            hist[(int)(jx * 4.f) * 4 + (int)(jy * 4.f)]++;
            px = jx;
        }
        double mx = sx / n, my = sy / n;
        double vx = sxx / n - mx * mx, vy = syy / n - my * my, cxy = sxy / n - mx * my, cxn = sxn / n - mx * mx;
        fprintf(stderr,
                "  jitter, index %u: mean %.4f %.4f, var %.4f %.4f (1/12 = 0.0833), cov xy %+.5f, neighbours %+.5f\n",
                (unsigned)indices[q], mx, my, vx, vy, cxy, cxn);
        assert_true(same < 4);
        assert_true(fabs(mx - 0.5) < 0.003 && fabs(my - 0.5) < 0.003); /* sd 0.00056 */
        assert_true(fabs(vx - 1.0 / 12) < 0.002 && fabs(vy - 1.0 / 12) < 0.002);
        assert_true(fabs(cxy) < 0.001 && fabs(cxn) < 0.001);                          /* sd 0.00016 */
        for (int k = 0; k < 16; k++) assert_true(abs(hist[k] - (int)(n / 16)) < 600); /* sd 124 */
    }
    /* Stratified over the sequence, in every pixel. */
    double worst_box = 0.0, worst_strip = 0.0;
    for (size_t i = 0; i < 1000; i++) {
        int cnt[5][4] = {{0}};
        const double f[5] = {0.1, 0.3, 0.5, 0.7, 0.9}, g[4] = {0.25, 0.5, 0.75, 1.0};
        for (uint32_t k = 0; k < 256; k++) {
            sp = (pgi__subpixel){.jitter = 1, .seed = 7, .index = k};
            pgi__pixel_jitter(&sp, i, &jx, &jy);
            for (int a = 0; a < 5; a++)
                for (int b = 0; b < 4; b++) cnt[a][b] += jx < f[a] && jy < g[b];
        }
        for (int a = 0; a < 5; a++)
            for (int b = 0; b < 4; b++) {
                double e = fabs(cnt[a][b] - 256.0 * f[a] * g[b]);
                if (b == 3) worst_strip = fmax(worst_strip, e);
                else worst_box = fmax(worst_box, e);
            }
    }
    fprintf(stderr, "  256 points a pixel: worst strip count error %.1f, box %.1f\n", worst_strip, worst_box);
    assert_true(worst_strip <= 4.0);
    assert_true(worst_box <= 10.0);
    /* The view direction: through the centre without jitter, through the jittered point with it. */
    pgi_camera cam;
    const float eye[3] = {0, 0, 3}, at[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    pgi_camera_look_at(&cam, eye, at, up, 40.f, 40, 30);
    sp = (pgi__subpixel){.jitter = 0, .seed = 7, .index = 2};
    pgi__v3 a = pgi__view_dir(&cam, &sp, 13, 9), b = pgi__camera_dir(&cam, 13, 9);
    assert_true(a.x == b.x && a.y == b.y && a.z == b.z);
    sp.jitter = 1;
    pgi__pixel_jitter(&sp, 9 * 40 + 13, &jx, &jy);
    a = pgi__view_dir(&cam, &sp, 13, 9), b = pgi__camera_dir_at(&cam, 13, 9, jx, jy);
    assert_true(a.x == b.x && a.y == b.y && a.z == b.z);
}

TU_MAIN("pixel sampling", setup, teardown, cmocka_unit_test(test_jitter_helper), cmocka_unit_test(test_single_frame),
        cmocka_unit_test(test_edge_progressive), cmocka_unit_test(test_edge_reference))
