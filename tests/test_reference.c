/* Reference path tracer: analytic furnace (docs/design.md, "Reference path tracer"), agreement with the
 * photon pipeline on the Cornell box, determinism, continuation, and bad input. */
#include "test_util.h"
#include "test_scenes.h"

#include "photongi/reference.h"

#define PI_D 3.14159265358979323846

/* ------------------------------------------------ furnace */

/* The furnace scene: tests/test_scenes.h. */

static double image_mean(const pgi_image *img) {
    size_t n = 3 * (size_t)img->width * img->height;
    double s = 0.0;
    for (size_t i = 0; i < n; i++) s += img->rgb[i];
    return s / (double)n;
}

/* With B bounces the reference is direct + indirect:
 *     L = rho E0 / pi * sum_{k=0..B} rho^k
 * (k = 0 direct, k = 1..B the light paths with k scattering events before the
 * visible point). Next-event estimation to the central point light is exact
 * and cosine sampling of a Lambertian surface has weight rho, so the only
 * noise is Russian roulette; faceting moves points inward by at most 0.12%
 * (irradiance within 0.3%). Tolerance 0.5% on the mean: an off-by-one bounce
 * limit changes the answer by rho^B / sum >= 1.6% (B = 4) and 33% (B = 1); a
 * missing or extra 1/pi by a factor pi. */
static void furnace_pt(int bounces) {
    pgi_scene *s = tu_scene(tu_furnace_json);
    pgi_reference_desc d = {.width = 64, .height = 48, .bounces = bounces, .spp = 32, .seed = 5};
    pgi_image img = {0};
    uint64_t spp = 0;
    TU_CHECK_OK(pgi_reference_render(s, &d, &img, &spp));
    assert_int_equal(spp, 32);
    const double rho = FURNACE_RHO, E0 = FURNACE_I;
    double expect = rho * E0 / PI_D * (1.0 - pow(rho, bounces + 1)) / (1.0 - rho);
    double mean = image_mean(&img), rel = mean / expect - 1.0;
    fprintf(stderr, "  path-traced furnace B=%d: expected %.5f, got %.5f (%+.3f%%)\n", bounces, expect, mean,
            100 * rel);
    if (fabs(rel) > 0.005)
        fail_msg("furnace, %d bounces: expected %g, mean %g (%+.3f%%)", bounces, expect, mean, 100 * rel);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
}

static void test_furnace_pt_4(void **state) { furnace_pt(4); }
static void test_furnace_pt_1(void **state) { furnace_pt(1); }

/* ------------------------------------------------ Cornell box */

#define CB_W 64
#define CB_H 64
#define CB_BLOCK 16

/* Mean of each 16x16 block, luminance. */
static void block_means(const pgi_image *img, double *out) {
    const int nb = CB_W / CB_BLOCK;
    for (int by = 0; by < nb; by++)
        for (int bx = 0; bx < nb; bx++) {
            double s = 0.0;
            for (int y = by * CB_BLOCK; y < (by + 1) * CB_BLOCK; y++)
                for (int x = bx * CB_BLOCK; x < (bx + 1) * CB_BLOCK; x++) {
                    const float *p = img->rgb + 3 * ((size_t)y * CB_W + x);
                    s += 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
                }
            out[by * nb + bx] = s / (CB_BLOCK * CB_BLOCK);
        }
}

/* The reference (512 spp) against the photon pipeline (hashgrid, which equals
 * brute up to summation order by the estimator tests; 2M photons, r = 0.02,
 * 64 area-light shadow samples) on 16 blocks of 16x16 pixels.
 * Noise: the reference's per-pixel relative sd at 512 spp is about 10%, so a
 * block mean (256 pixels) about 0.7%; the photon estimate's indirect part has
 * about 2M * pi r^2 / (box area 24) ~ 100 photons a disk (10% sd per pixel,
 * <1% per block of the indirect third). Bias: the radius blurs indirect light
 * over 0.02 (a quarter of a pixel here at the back wall) and darkens concave
 * corners. Bounds: the whole image within 2%, every block within 6%
 * (measured: about 0.3% and 2.5%). A factor pi, a cosine dropped or taken
 * twice, or a bounce too many or too few moves whole blocks by 10% or more. */
/* The reference (512 spp at pixel centres, as the single frame it is compared with: light
 * transport only, no aliasing) and the photon pipeline (hashgrid, 2M photons, r = 0.02) of s. */
static void reference_and_photons(const pgi_scene *s, int direct_samples, pgi_image *ref, pgi_image *pm) {
    pgi_reference_desc rd =
        {.width = CB_W, .height = CB_H, .bounces = 4, .spp = 512, .seed = 7, .jitter = PGI_JITTER_OFF};
    uint64_t spp = 0;
    TU_CHECK_OK(pgi_reference_render(s, &rd, ref, &spp));
    pgi_render_desc pd = {.estimator = "hashgrid",
                          .width = CB_W,
                          .height = CB_H,
                          .bounces = 4,
                          .photons = 2000000,
                          .radius = 0.02f,
                          .direct_samples = direct_samples,
                          .seed = 7};
    TU_CHECK_OK(pgi_render(s, &pd, pm, NULL));
}

static void agreement(const pgi_scene *s, const char *what) {
    pgi_image ref = {0}, pm = {0};
    reference_and_photons(s, 64, &ref, &pm);
    const int nb = (CB_W / CB_BLOCK) * (CB_H / CB_BLOCK);
    double a[16], b[16], worst = 0.0, sa = 0.0, sb = 0.0;
    block_means(&ref, a);
    block_means(&pm, b);
    for (int k = 0; k < nb; k++) {
        double rel = b[k] / a[k] - 1.0;
        if (fabs(rel) > fabs(worst)) worst = rel;
        sa += a[k];
        sb += b[k];
    }
    double all = sb / sa - 1.0;
    fprintf(stderr, "  %s: photon pipeline vs reference: image %+.2f%%, worst block %+.2f%%\n", what, 100 * all,
            100 * worst);
    if (fabs(all) > 0.02) fail_msg("%s: image mean differs by %+.2f%% (bound 2%%)", what, 100 * all);
    if (fabs(worst) > 0.06) fail_msg("%s: a block differs by %+.2f%% (bound 6%%)", what, 100 * worst);
    pgi_image_free(&ref);
    pgi_image_free(&pm);
}

static void test_cornell_agreement(void **state) {
    pgi_scene *s = tu_scene("cornell");
    agreement(s, "Cornell box");
    pgi_scene_destroy(s);
}

/* A box with every material: Lambertian walls, a glossy floor (illum 2, Ks 0.04, Ns 198:
 * the plastic of real interiors), a glossy block (Ks 0.3, Ns 40), a glass block and a mirror
 * on the back wall, lit by a 1x1 area light: exercises MIS with a glossy lobe, eye paths
 * through glass and mirrors, and caustics (light -> glass/mirror -> wall, photons in the
 * pipeline, BSDF-sampled emitter hits in the reference). Rendered twice: with the glossy
 * materials as microfacet plastic (the default; the reference samples visible normals) and
 * as the papers' Blinn-Phong (pgi_scene_set_specular). Same settings and bounds as the
 * Cornell test. */
static const char k_box_mtl[] =
    "newmtl white\nKd 0.7 0.7 0.7\nillum 1\nnewmtl red\nKd 0.6 0.1 0.1\nillum 1\n"
    "newmtl floor\nKd 0.7 0.7 0.7\nKs 0.04 0.04 0.04\nNs 198\nillum 2\n"
    "newmtl green\nKd 0.1 0.5 0.1\nillum 1\nnewmtl light\nKd 0.5 0.5 0.5\nKe 4 4 4\nillum 1\n"
    "newmtl glossy\nKd 0.3 0.3 0.5\nKs 0.3 0.3 0.3\nNs 40\nillum 2\n"
    "newmtl mirror\nKd 0 0 0\nKs 0.9 0.9 0.9\nillum 3\nnewmtl glass\nKd 0 0 0\nKs 1 1 1\nNi 1.5\nillum 7\n";

static void box_quad(char *obj, size_t cap, size_t *len, int *nv, const float q[4][3], const char *m) {
    for (int k = 0; k < 4; k++)
        *len += (size_t)snprintf(obj + *len, cap - *len, "v %g %g %g\n", q[k][0], q[k][1], q[k][2]);
    *len +=
        (size_t)snprintf(obj + *len, cap - *len, "usemtl %s\nf %d %d %d %d\n", m, *nv + 1, *nv + 2, *nv + 3, *nv + 4);
    *nv += 4;
}

static void box_cube(char *obj, size_t cap, size_t *len, int *nv, float x0, float y0, float z0, float x1, float y1,
                     float z1, const char *m) {
    const float f[6][4][3] = {{{x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1}},
                              {{x1, y0, z0}, {x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0}},
                              {{x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0}},
                              {{x1, y0, z1}, {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1}},
                              {{x0, y1, z1}, {x1, y1, z1}, {x1, y1, z0}, {x0, y1, z0}},
                              {{x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1}}};
    for (int k = 0; k < 6; k++) box_quad(obj, cap, len, nv, f[k], m);
}

static void test_materials_agreement(void **state) {
    char dir[512], path[700], json[1600];
    tu_make_tmpdir(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/box.mtl", dir);
    assert_int_equal(tu_write_file(path, k_box_mtl), 0);
    char obj[8192];
    size_t len = (size_t)snprintf(obj, sizeof obj, "mtllib box.mtl\n");
    int nv = 0;
    const float walls[6][4][3] =
        {{{-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}},
         {{-1, 2, -1}, {1, 2, -1}, {1, 2, 1}, {-1, 2, 1}},
         {{-1, 0, -1}, {1, 0, -1}, {1, 2, -1}, {-1, 2, -1}},
         {{-1, 0, -1}, {-1, 2, -1}, {-1, 2, 1}, {-1, 0, 1}},
         {{1, 0, -1}, {1, 0, 1}, {1, 2, 1}, {1, 2, -1}},
         {{-0.5f, 1.99f, -0.5f}, {0.5f, 1.99f, -0.5f}, {0.5f, 1.99f, 0.5f}, {-0.5f, 1.99f, 0.5f}}};
    const char *wm[6] = {"floor", "white", "white", "red", "green", "light"};
    for (int k = 0; k < 6; k++) box_quad(obj, sizeof obj, &len, &nv, walls[k], wm[k]);
    box_cube(obj, sizeof obj, &len, &nv, 0.1f, 0.f, 0.f, 0.6f, 0.6f, 0.5f, "glossy");
    box_cube(obj, sizeof obj, &len, &nv, -0.7f, 0.f, -0.6f, -0.2f, 1.f, -0.1f, "glass");
    const float mirror[4][3] = {{-0.9f, 0.3f, -0.98f}, {0.f, 0.3f, -0.98f}, {0.f, 1.5f, -0.98f}, {-0.9f, 1.5f, -0.98f}};
    box_quad(obj, sizeof obj, &len, &nv, mirror, "mirror");
    snprintf(path, sizeof path, "%s/box.obj", dir);
    assert_int_equal(tu_write_file(path, obj), 0);
    snprintf(json, sizeof json,
             "{\"name\": \"materials-box\", \"mesh\": \"%s\",\n"
             " \"camera\": {\"eye\": [0, 1, 3.9], \"look_at\": [0, 1, 0], \"up\": [0, 1, 0], \"fov_y\": 39}}\n",
             path);
    pgi_scene *s = tu_scene_text(dir, "box.json", json, path, sizeof path);
    pgi_scene_info info;
    pgi_scene_get_info(s, &info);
    assert_int_equal(info.area_triangles, 2);
    assert_int_equal(info.glossy_materials, 2);
    assert_int_equal(info.specular, PGI_SPECULAR_GGX);
    agreement(s, "materials box, plastic");
    TU_CHECK_OK(pgi_scene_set_specular(s, PGI_SPECULAR_PHONG));
    agreement(s, "materials box, Blinn-Phong");
    pgi_scene_destroy(s);
    tu_rm_tmpdir(dir);
}

/* A dark plastic floor (Kd 0.05, Ks 0.04, Ns 198: alpha 0.1) in front of a white wall that a
 * spot light lights (its cone misses the floor): the floor shows only indirect light, mostly
 * the wall's glossy reflection, which the photon pipeline gathers through the plastic's BRDF per
 * photon and the path tracer finds by sampling visible normals. Image and floor (the bottom
 * half) within 3%, 512 spp and 2M photons (r 0.02) as above (measured: image +0.01%, floor
 * +0.02%). Estimators that took the floor for Lambertian (its lobe ignored) fail it (measured:
 * floor -48%); the sampler's density is checked against the evaluation in test_plastic (a
 * visible-normal pdf without its G1 moves this floor by only 1.4%). */
static void test_plastic_floor_agreement(void **state) {
    char dir[512], path[700], json[1600];
    tu_make_tmpdir(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/f.mtl", dir);
    assert_int_equal(tu_write_file(path, "newmtl floor\nKd 0.05 0.05 0.05\nKs 0.04 0.04 0.04\nNs 198\nillum 2\n"
                                         "newmtl wall\nKd 0.8 0.8 0.8\nillum 1\n"),
                     0);
    char obj[4096];
    size_t len = (size_t)snprintf(obj, sizeof obj, "mtllib f.mtl\n");
    int nv = 0;
    const float floor_q[4][3] = {{-2, 0, -1}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -1}};
    const float wall_q[4][3] = {{-2, 0, -1}, {2, 0, -1}, {2, 3, -1}, {-2, 3, -1}};
    box_quad(obj, sizeof obj, &len, &nv, floor_q, "floor");
    box_quad(obj, sizeof obj, &len, &nv, wall_q, "wall");
    snprintf(path, sizeof path, "%s/f.obj", dir);
    assert_int_equal(tu_write_file(path, obj), 0);
    snprintf(json, sizeof json,
             "{\"name\": \"plastic-floor\", \"mesh\": \"%s\",\n"
             " \"camera\": {\"eye\": [0, 0.45, 1.9], \"look_at\": [0, 0.35, -1], \"fov_y\": 45},\n"
             " \"lights\": [{\"type\": \"spot\", \"position\": [0, 1.6, 0.9], \"direction\": [0, -0.6, -1.9],"
             " \"angle\": 20, \"intensity\": [20, 20, 20]}]}\n",
             path);
    pgi_scene *s = tu_scene_text(dir, "f.json", json, path, sizeof path);
    pgi_image ref = {0}, pm = {0};
    reference_and_photons(s, 0, &ref, &pm);
    double ra = 0.0, pa = 0.0, rf = 0.0, pf = 0.0;
    for (int y = 0; y < CB_H; y++)
        for (int x = 0; x < CB_W; x++) {
            const float *a = ref.rgb + 3 * ((size_t)y * CB_W + x), *b = pm.rgb + 3 * ((size_t)y * CB_W + x);
            double la = 0.2126 * a[0] + 0.7152 * a[1] + 0.0722 * a[2],
                   lb = 0.2126 * b[0] + 0.7152 * b[1] + 0.0722 * b[2];
            ra += la, pa += lb;
            if (y >= CB_H / 2) rf += la, pf += lb;
        }
    double all = pa / ra - 1.0, fl = pf / rf - 1.0;
    fprintf(stderr, "  plastic floor: photon pipeline vs reference: image %+.2f%%, floor %+.2f%% (floor mean %.4g)\n",
            100 * all, 100 * fl, rf / (CB_W * CB_H / 2));
    assert_true(rf > 0.0);
    if (fabs(all) > 0.03) fail_msg("plastic floor: image mean differs by %+.2f%% (bound 3%%)", 100 * all);
    if (fabs(fl) > 0.03) fail_msg("plastic floor: floor mean differs by %+.2f%% (bound 3%%)", 100 * fl);
    pgi_image_free(&ref);
    pgi_image_free(&pm);
    pgi_scene_destroy(s);
    tu_rm_tmpdir(dir);
}

/* ------------------------------------------------ determinism, continuation */

static void test_threads_and_continue(void **state) {
    pgi_scene *s = tu_scene("cornell");
    pgi_reference_desc d = {.width = 40, .height = 30, .spp = 8, .seed = 3, .threads = 1};
    pgi_image a = {0}, b = {0}, c = {0};
    uint64_t na = 0, nb = 0, nc = 0;
    TU_CHECK_OK(pgi_reference_render(s, &d, &a, &na));
    d.threads = 2;
    TU_CHECK_OK(pgi_reference_render(s, &d, &b, &nb));
    assert_memory_equal(a.rgb, b.rgb, 3 * 40 * 30 * sizeof(float));
    /* 3 + 5 samples equal 8 samples up to float rounding of the stored mean. */
    d.spp = 3;
    TU_CHECK_OK(pgi_reference_render(s, &d, &c, &nc));
    d.spp = 5;
    TU_CHECK_OK(pgi_reference_render(s, &d, &c, &nc));
    assert_int_equal(nc, 8);
    for (size_t i = 0; i < 3 * 40 * 30; i++) {
        double diff = fabs((double)c.rgb[i] - (double)a.rgb[i]);
        if (diff > 1e-5 * fmax(1.0, fabs((double)a.rgb[i])))
            fail_msg("continued pixel %zu: %g vs %g", i, c.rgb[i], a.rgb[i]);
    }
    /* 4 + 4 samples (a save at a multiple of PGI_REFERENCE_BLOCK, as checkpoints and interrupted
       references are): the same bits as 8 samples in one call (pgi_block_sum_round), whatever the
       threads. */
    pgi_image f = {0};
    uint64_t nf = 0;
    d.spp = 4;
    d.threads = 1;
    TU_CHECK_OK(pgi_reference_render(s, &d, &f, &nf));
    d.threads = 2;
    TU_CHECK_OK(pgi_reference_render(s, &d, &f, &nf));
    assert_int_equal(nf, 8);
    assert_memory_equal(a.rgb, f.rgb, 3 * 40 * 30 * sizeof(float));
    pgi_image_free(&f);
    /* Another seed gives another image. */
    d.seed = 4;
    d.spp = 8;
    uint64_t nd = 0;
    pgi_image e = {0};
    TU_CHECK_OK(pgi_reference_render(s, &d, &e, &nd));
    assert_true(memcmp(a.rgb, e.rgb, 3 * 40 * 30 * sizeof(float)) != 0);
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_image_free(&c);
    pgi_image_free(&e);
    pgi_scene_destroy(s);
}

/* Without jitter a sampler keeps what a pixel's samples share (the primary hit's surface, x0's
 * delta lights) from the first sample it adds: a later sample must come out as a fresh sampler
 * computes it, bit for bit (area lights, mirrors and glass: cornell-mirrors; a point light: giref). */
static void eye_records(const char *scene) {
    pgi_scene *s = tu_scene(scene);
    pgi_reference_desc d = {.width = 40, .height = 30, .seed = 3, .threads = 2, .jitter = PGI_JITTER_OFF};
    pgi_reference_sampler *warm = NULL, *fresh = NULL;
    TU_CHECK_OK(pgi_reference_sampler_create(s, &d, &warm));
    TU_CHECK_OK(pgi_reference_sampler_create(s, &d, &fresh));
    const size_t n = 3 * 40 * 30;
    double *a = calloc(n, sizeof *a), *b = calloc(n, sizeof *b);
    assert_non_null(a);
    assert_non_null(b);
    for (uint64_t k = 0; k < 3; k++) TU_CHECK_OK(pgi_reference_sampler_add(warm, k, a));
    memset(a, 0, n * sizeof *a);
    TU_CHECK_OK(pgi_reference_sampler_add(warm, 3, a));
    TU_CHECK_OK(pgi_reference_sampler_add(fresh, 3, b));
    assert_memory_equal(a, b, n * sizeof *a);
    free(a);
    free(b);
    pgi_reference_sampler_destroy(warm);
    pgi_reference_sampler_destroy(fresh);
    pgi_scene_destroy(s);
}

static void test_eye_records(void **state) {
    eye_records("cornell-mirrors");
    eye_records("giref");
}

static void test_bad_input(void **state) {
    pgi_scene *s = tu_scene("cornell");
    pgi_image img = {0};
    uint64_t spp = 0;
    pgi_reference_desc d = {.width = 16, .height = 16, .spp = 0};
    assert_int_equal(pgi_reference_render(s, &d, &img, &spp), PGI_ERR_INVALID_ARG);
    d.spp = 1;
    d.bounces = 65;
    assert_int_equal(pgi_reference_render(s, &d, &img, &spp), PGI_ERR_INVALID_ARG);
    d.bounces = 0;
    d.camera = 3;
    assert_int_equal(pgi_reference_render(s, &d, &img, &spp), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "camera"));
    d.camera = 0;
    spp = 5; /* continuing an empty image */
    assert_int_equal(pgi_reference_render(s, &d, &img, &spp), PGI_ERR_INVALID_ARG);
    pgi_reference_meta m;
    assert_int_equal(pgi_reference_meta_read("/nonexistent/ref.exr.json", &m), PGI_ERR_IO);
    pgi_scene_destroy(s);
}

int main(void) {
    const struct CMUnitTest furnace[] = {
        cmocka_unit_test(test_furnace_pt_4),
        cmocka_unit_test(test_furnace_pt_1),
    };
    const struct CMUnitTest other[] = {
        cmocka_unit_test(test_cornell_agreement),
        cmocka_unit_test(test_materials_agreement),
        cmocka_unit_test(test_plastic_floor_agreement),
        cmocka_unit_test(test_threads_and_continue),
        cmocka_unit_test(test_eye_records),
        cmocka_unit_test(test_bad_input),
    };
    int fails = cmocka_run_group_tests_name("reference: furnace", furnace, tu_furnace_setup, tu_furnace_teardown);
    fails += cmocka_run_group_tests_name("reference: Cornell box and API", other, NULL, NULL);
    return fails;
}
