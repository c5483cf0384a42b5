/* Mip-mapped textures at the view samples (docs/design.md "Textures"): the levels built at load
 * (a constant texture's are that constant, a checkerboard's coarse levels grey), the ray cone's
 * level at a plane seen at a known distance and angle (the analytic lambda of Ray Tracing Gems
 * ch. 20, eq. 34) directly and through a flat mirror, and the same bits from the narrow and the
 * wide builds of the view pass. */
#include "test_util.h"

#include "core/core.h"
#include "photon/photon.h"
#include "rt/rt.h"
#include "scene/scene_internal.h"
#include "view/view.h"

#define PI_D 3.14159265358979323846

/* A scene from memory: quad 0 (material 0, textured with `tex`) of side L centred at (0, 0, zq)
 * facing +z (or -z: `down`), and optionally a mirror quad (material 1) of side 8 at z = 0 facing
 * +z; a point light; camera `cam`. */
static pgi_scene *plane_scene(const pgi_texture_desc *tex, float L, float zq, int down, int mirror,
                              const pgi_camera_def *cam) {
    const float h = 0.5f * L;
    float pos[24] = {-h, -h, zq, h, -h, zq, h, h, zq, -h, h, zq, -4, -4, 0, 4, -4, 0, 4, 4, 0, -4, 4, 0};
    float uv[16] = {0, 0, 1, 0, 1, 1, 0, 1, 0, 0, 1, 0, 1, 1, 0, 1};
    uint32_t idx[12] = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
    if (down) idx[1] = 2, idx[2] = 1, idx[4] = 3, idx[5] = 2;
    uint32_t mat[4] = {0, 0, 1, 1};
    pgi_material_desc m[2] = {{.type = PGI_MATERIAL_LAMBERT, .diffuse = {1, 1, 1}, .diffuse_texture = 1},
                              {.type = PGI_MATERIAL_MIRROR, .specular = {1, 1, 1}}};
    const pgi_mesh_desc mesh = {.vertex_count = mirror ? 8 : 4,
                                .positions = pos,
                                .uvs = uv,
                                .triangle_count = mirror ? 4 : 2,
                                .indices = idx,
                                .materials = mat};
    const pgi_light_desc light = {.kind = PGI_LIGHT_KIND_POINT, .position = {0.3f, 0.2f, 1.f}, .intensity = 1.f};
    const pgi_scene_desc d = {.meshes = &mesh,
                              .mesh_count = 1,
                              .materials = m,
                              .material_count = 2,
                              .textures = tex,
                              .texture_count = 1,
                              .lights = &light,
                              .light_count = 1,
                              .cameras = cam,
                              .camera_count = 1};
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_create(&d, &s));
    return s;
}

/* n x n texels, RGB, filled by f(x, y, rgb). */
static unsigned char *texels(int n, void (*f)(int, int, unsigned char *)) {
    unsigned char *p = malloc((size_t)n * n * 3);
    assert_non_null(p);
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) f(x, y, p + 3 * ((size_t)y * n + x));
    return p;
}

static void constant_rgb(int x, int y, unsigned char *c) { (void)x, (void)y, c[0] = 200, c[1] = 97, c[2] = 13; }
static int g_cell; /* checker cell side, texels */
static void checker_rgb(int x, int y, unsigned char *c) {
    c[0] = c[1] = c[2] = ((x / g_cell + y / g_cell) & 1) ? 255 : 0;
}
static void noise_rgb(int x, int y, unsigned char *c) {
    uint64_t h = 0x9e3779b97f4a7c15ULL * (uint64_t)(y * 1031 + x + 1);
    h ^= h >> 29;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 32;
    c[0] = (unsigned char)h, c[1] = (unsigned char)(h >> 8), c[2] = (unsigned char)(h >> 16);
}

static const pgi_camera_def k_cam = {{0, 0, 4}, {0, 0, 0}, {0, 1, 0}, 60.f};

/* Width of level l of t. */
static int level_w(const pgi__texture *t, int l) { return t->width >> l > 0 ? t->width >> l : 1; }

/* A constant texture's levels (sides halved down to 1 x 1, one more for an odd side kept) are that
 * constant, byte for byte, and every lookup at any level of detail decodes it exactly. */
static void test_constant_levels(void **state) {
    (void)state;
    unsigned char *p = texels(96, constant_rgb);
    const pgi_texture_desc tex = {96, 96, 3, p};
    pgi_scene *s = plane_scene(&tex, 2.f, 0.f, 0, 0, &k_cam);
    free(p);
    const pgi__texture *t = &s->texs[0];
    assert_int_equal(t->levels, 7); /* 96, 48, 24, 12, 6, 3, 1 */
    assert_int_equal(level_w(t, 6), 1);
    for (int l = 1; l < t->levels; l++) {
        assert_non_null(t->mip[l]);
        for (int i = 0; i < level_w(t, l) * level_w(t, l); i++) {
            assert_int_equal(t->mip[l][4 * i], 200);
            assert_int_equal(t->mip[l][4 * i + 1], 97);
            assert_int_equal(t->mip[l][4 * i + 2], 13);
            assert_int_equal(t->mip[l][4 * i + 3], 255);
        }
    }
    const float lods[] = {-3.f, 0.f, 0.3f, 1.f, 2.75f, 5.5f, 6.f, 40.f, INFINITY, NAN};
    for (size_t k = 0; k < sizeof lods / sizeof *lods; k++) {
        const pgi__v3 c = pgi__texture_lookup_lod(t, 0.37f, 0.81f, lods[k]);
        assert_true(c.x == pgi__srgb8_texture_lut[200] && c.y == pgi__srgb8_texture_lut[97] &&
                    c.z == pgi__srgb8_texture_lut[13]);
    }
    size_t scene_b, tex_b;
    pgi__scene_memory(s, &scene_b, &tex_b);
    size_t mips = 0;
    for (int l = 1; l < t->levels; l++) mips += 4 * (size_t)level_w(t, l) * level_w(t, l);
    assert_int_equal(pgi__texture_mip_bytes(t), mips);
    assert_true(tex_b >= 96 * 96 * 4 + mips); /* the ledger counts the levels */
    pgi_scene_destroy(s);
}

/* A checkerboard of 4-texel cells: levels 1 and 2 average equal texels (still black and white),
 * level 3 and up average a cell of each: grey, 0.5 in linear light (to the 8-bit code nearest it),
 * not sRGB's mid-grey 0.214. */
static void test_checker_grey(void **state) {
    (void)state;
    g_cell = 4;
    unsigned char *p = texels(64, checker_rgb);
    const pgi_texture_desc tex = {64, 64, 3, p};
    pgi_scene *s = plane_scene(&tex, 2.f, 0.f, 0, 0, &k_cam);
    free(p);
    const pgi__texture *t = &s->texs[0];
    assert_int_equal(t->levels, 7);
    for (int l = 1; l < t->levels; l++) {
        const int w = level_w(t, l);
        double sum = 0.0;
        for (int y = 0; y < w; y++)
            for (int x = 0; x < w; x++) {
                const unsigned char *q = t->mip[l] + 4 * ((size_t)y * w + x);
                assert_true(q[0] == q[1] && q[1] == q[2]);
                const float lin = pgi__srgb8_texture_lut[q[0]];
                if (l <= 2) assert_int_equal(q[0], (((x << l) / 4 + (y << l) / 4) & 1) ? 255 : 0);
                else assert_true(fabsf(lin - 0.5f) < 0.003f);
                sum += lin;
            }
        assert_true(fabs(sum / (w * w) - 0.5) < 0.003); /* every level keeps the mean */
    }
    /* trilinear between level 2 (black or white) and level 3 (grey) */
    const pgi__v3 a = pgi__texture_lookup_level(t, 0.5f / 16.f, 1.f - 0.5f / 16.f, 2);
    const pgi__v3 b = pgi__texture_lookup_level(t, 0.5f / 16.f, 1.f - 0.5f / 16.f, 3);
    const pgi__v3 c = pgi__texture_lookup_lod(t, 0.5f / 16.f, 1.f - 0.5f / 16.f, 2.25f);
    assert_true(a.x == 0.f);
    assert_true(fabsf(c.x - (0.75f * a.x + 0.25f * b.x)) < 1e-6f);
    pgi_scene_destroy(s);
}

/* The view samples of a scene (filter on or off). */
static void view(const pgi_scene *s, int W, int H, int filter, pgi_view_samples *vs) {
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    pgi_camera cam;
    const pgi_camera_def *cd = &s->cams[0];
    pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, W, H);
    TU_CHECK_OK(pgi_view_samples_alloc(vs, W, H));
    float *emit = malloc(3 * sizeof(float) * (size_t)W * H);
    assert_non_null(emit);
    const pgi__subpixel sp = {.tex_filter = filter};
    uint64_t rays = 0;
    TU_CHECK_OK(pgi__view_build(s, rt, NULL, &cam, 1, &sp, 2, vs, emit, NULL, &rays));
    free(emit);
    pgi__rt_destroy(rt);
}

/* A noise texture of N x N on a plane of side L seen from distance D at angle theta to its normal
 * (fov 60 degrees, H x H pixels, H odd: the centre pixel's ray hits the plane's centre, uv (0.5,
 * 0.5)). The cone's width there is spread D, spread = 2 tan(30 deg) / H (a pixel's angle); on the
 * plane its footprint is that across and spread D / cos theta along v (the camera looks along +y).
 * In texels: minor = N spread D / L, major = minor / cos theta; n = ceil(major / minor) probes at
 * v offsets ((i + 0.5) / n - 0.5) spread D / (L cos theta), each trilinear at lambda =
 * log2(major / n) - log2(sqrt(3)) (PGI__TEXTURE_LOD_BIAS). Head-on that is the isotropic
 * lambda = log2(N / L) + log2(spread D) - log2(sqrt 3), which pgi__texture_cone_lod gives from the
 * triangle's record (log2(1 / L)). The centre sample's albedo must be the analytic one (the noise's
 * levels all differ, so a quarter of a level off shows); with the filter off it is level 0's.
 * Through a flat mirror the distance is the path's length. */
static void check_lod(float theta_deg, int mirror) {
    const int N = 256, H = 65;
    const float L = 2.f, D = 4.f, th = (float)(theta_deg * PI_D / 180.0);
    pgi_camera_def cam = {{0.f, -D * sinf(th), D * cosf(th)}, {0, 0, 0}, {0, 0, 1}, 60.f};
    if (theta_deg == 0.f) cam.up[1] = 1.f, cam.up[2] = 0.f;
    float zq = 0.f, path = D;
    if (mirror) { /* the camera looks down at the mirror from 2; the texture faces down at 3 */
        const pgi_camera_def mc = {{0, 0, 2}, {0, 0, 0}, {0, 1, 0}, 60.f};
        cam = mc;
        zq = 3.f;
        path = 2.f + 3.f;
    }
    unsigned char *p = texels(N, noise_rgb);
    const pgi_texture_desc tex = {N, N, 3, p};
    pgi_scene *s = plane_scene(&tex, L, zq, mirror, mirror, &cam);
    free(p);
    const pgi__texture *t = &s->texs[0];
    assert_int_equal(t->levels, 9);

    pgi__tri_cache sc = {0};
    TU_CHECK_OK(pgi__tri_cache_update(&sc, s, 1));
    const float tri_lod = sc.tri_uv[6];
    assert_true(fabsf(tri_lod - -log2f(L)) < 1e-6f);
    assert_true(fabsf(sc.tri_uv[PGI__TRI_UV + 6] - -log2f(L)) < 1e-6f);
    pgi__tri_cache_free(&sc);

    const double spread = 2.0 * tan(30.0 * PI_D / 180.0) / H;
    const double cosine = mirror ? 1.0 : cos(theta_deg * PI_D / 180.0);
    const double minor = N * spread * path / L, major = minor / cosine;
    const int n = major / minor > 1.001 ? (int)ceil(major / minor - 0.001) : 1;
    const double lambda = log2(major / n) - 0.5 * log2(3.0);
    if (theta_deg == 0.f) {
        const float got = pgi__texture_cone_lod(t, tri_lod, (float)(spread * path), (float)cosine);
        assert_true(fabs(got - lambda) < 1e-4);
    }
    /* the expected albedo at lambda + dl */
    pgi__v3 want, lo, hi;
    pgi__v3 *const outs[3] = {&lo, &want, &hi};
    for (int j = 0; j < 3; j++) {
        const float dl = 0.25f * (float)(j - 1);
        pgi__v3 sum = v3(0.f, 0.f, 0.f);
        for (int i = 0; i < n; i++) {
            const double o = (i + 0.5) / n - 0.5;
            sum = v3_add(sum, pgi__texture_lookup_lod(t, 0.5f, (float)(0.5 + o * spread * path / (L * cosine)),
                                                      (float)lambda + dl));
        }
        *outs[j] = v3_scale(sum, 1.f / (float)n);
    }
    const float u = 0.5f, v = 0.5f;

    pgi_view_samples on = {0}, off = {0};
    view(s, H, H, 1, &on);
    view(s, H, H, 0, &off);
    const size_t c = (size_t)(H / 2) * H + H / 2;
    assert_true(on.flags[c] & PGI_VS_VALID);
    const float *kd = on.kd + 3 * c;
    const float err = fabsf(kd[0] - want.x) + fabsf(kd[1] - want.y) + fabsf(kd[2] - want.z);
    const float dlo = fabsf(lo.x - want.x) + fabsf(lo.y - want.y) + fabsf(lo.z - want.z);
    const float dhi = fabsf(hi.x - want.x) + fabsf(hi.y - want.y) + fabsf(hi.z - want.z);
    if (!(err < 0.1f * dlo && err < 0.1f * dhi))
        fail_msg("theta %g mirror %d: lambda %.4f: kd (%g %g %g), want (%g %g %g); a quarter level off: %g, %g",
                 (double)theta_deg, mirror, lambda, (double)kd[0], (double)kd[1], (double)kd[2], (double)want.x,
                 (double)want.y, (double)want.z, (double)dlo, (double)dhi);
    const pgi__v3 l0 = pgi__texture_lookup(t, u, v);
    const float *kd0 = off.kd + 3 * c;
    assert_true(fabsf(kd0[0] - l0.x) + fabsf(kd0[1] - l0.y) + fabsf(kd0[2] - l0.z) < 1e-3f);
    assert_true(fabsf(kd0[0] - want.x) + fabsf(kd0[1] - want.y) + fabsf(kd0[2] - want.z) > 10.f * err);

    /* the narrow builds (lane by lane) give the wide builds' bits (uniform tiles, AVX2 / AVX-512) */
    pgi_view_samples nar = {0};
    pgi__cpu_narrow = 1;
    view(s, H, H, 1, &nar);
    pgi__cpu_narrow = 0;
    assert_memory_equal(nar.kd, on.kd, 3 * sizeof(float) * (size_t)H * H);
    pgi_view_samples_free(&nar);
    pgi_view_samples_free(&on);
    pgi_view_samples_free(&off);
    pgi_scene_destroy(s);
}

static void test_lod_head_on(void **state) {
    (void)state;
    check_lod(0.f, 0); /* lambda = 7 + log2(0.0178 * 4) - 0.79 = 2.39 */
}

static void test_lod_oblique(void **state) {
    (void)state;
    check_lod(60.f, 0); /* 2 probes, lambda = 7 + log2(0.0178 * 4) - 0.79 = 2.39 */
}

static void test_lod_grazing(void **state) {
    (void)state;
    check_lod(80.f, 0); /* 6 probes, lambda = 7 + log2(0.0178 * 23.0 / 6) - 0.79 = 2.33 */
}

static void test_lod_mirror(void **state) {
    (void)state;
    check_lod(0.f, 1); /* lambda = 7 + log2(0.0178 * 5) - 0.79 = 2.71 */
}

TU_MAIN("mip", NULL, NULL, cmocka_unit_test(test_constant_levels), cmocka_unit_test(test_checker_grey),
        cmocka_unit_test(test_lod_head_on), cmocka_unit_test(test_lod_oblique), cmocka_unit_test(test_lod_grazing),
        cmocka_unit_test(test_lod_mirror))
