/* Dynamic geometry: animated objects of scene descriptions, the ray-tracing
 * update, light groups; and the scene-format errors of the new keys. */
#include "test_util.h"

/* Writes `json` to <tmp>/<name>.json and loads it; returns the status. */
static pgi_status load_json(const char *name, const char *json, pgi_scene **s) {
    char path[700];
    snprintf(path, sizeof path, "%s/%s.json", tu_dir, name);
    assert_int_equal(tu_write_file(path, json), 0);
    return pgi_scene_load(path, s);
}

#define BALL_MOVING                                                                                                    \
    "{\"builtin\": \"cornell\", \"objects\": [{\"name\": \"ball\", \"shape\": \"sphere\","                             \
    " \"center\": [-0.4, 0.3, 0.3], \"radius\": 0.25, \"material\": {\"kd\": [0.9, 0.9, 0.9]},"                        \
    " \"motion\": {\"keyframes\": [{\"t\": 0}, {\"t\": 2, \"translate\": [0.8, 0.5, 0]}]}}]}"
/* The same object held by a one-keyframe motion at the pose of t = 1 ... */
#define BALL_HELD                                                                                                      \
    "{\"builtin\": \"cornell\", \"objects\": [{\"name\": \"ball\", \"shape\": \"sphere\","                             \
    " \"center\": [-0.4, 0.3, 0.3], \"radius\": 0.25, \"material\": {\"kd\": [0.9, 0.9, 0.9]},"                        \
    " \"motion\": {\"keyframes\": [{\"t\": 0, \"translate\": [0.4, 0.25, 0]}]}}]}"
/* ... and a static sphere built at that place. */
#define BALL_STATIC                                                                                                    \
    "{\"builtin\": \"cornell\", \"objects\": [{\"name\": \"ball\", \"shape\": \"sphere\","                             \
    " \"center\": [0.0, 0.55, 0.3], \"radius\": 0.25, \"material\": {\"kd\": [0.9, 0.9, 0.9]}}]}"

static const pgi_render_desc k_desc =
    {.estimator = "hashgrid", .photons = 20000, .width = 48, .height = 48, .direct_samples = 4, .seed = 5};
#define NF (3 * 48 * 48)

/* A frame at time t equals a static render with the object placed at t. */
static void test_frame_at_t_equals_static(void **state) {
    (void)state;
    pgi_scene *mov, *held, *stat;
    TU_CHECK_OK(load_json("moving", BALL_MOVING, &mov));
    TU_CHECK_OK(load_json("held", BALL_HELD, &held));
    TU_CHECK_OK(load_json("static", BALL_STATIC, &stat));
    pgi_scene_info info;
    pgi_scene_get_info(mov, &info);
    assert_int_equal(info.animated_objects, 1);
    assert_float_equal(info.anim_duration, 2.0, 1e-9);

    /* One renderer across the time change: its BVH is refitted, not rebuilt. */
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(mov, &r));
    pgi_image a0 = {0}, a1 = {0}, b = {0}, c = {0};
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_renderer_render(r, &k_desc, &a0, &fs));
    assert_true(fs.rt_update_ms == 0.0);
    TU_CHECK_OK(pgi_scene_set_time(mov, 1.0));
    TU_CHECK_OK(pgi_renderer_render(r, &k_desc, &a1, &fs));
    assert_true(fs.rt_update_ms > 0.0);
    TU_CHECK_OK(pgi_render(held, &k_desc, &b, NULL));
    TU_CHECK_OK(pgi_render(stat, &k_desc, &c, NULL));
    /* Same vertices (same transform), fresh BVH: identical bytes. */
    assert_memory_equal(a1.rgb, b.rgb, NF * sizeof(float));
    /* A sphere tessellated at the new centre differs only by vertex rounding. */
    size_t bad = tu_compare(a1.rgb, c.rgb, NF, 1e-3, "animated vs static");
    assert_true(bad <= NF / 200);
    /* And the object did move: shadows and colour bleeding changed. */
    size_t moved = 0;
    for (size_t i = 0; i < NF; i++) moved += fabsf(a0.rgb[i] - a1.rgb[i]) > 1e-3f * fmaxf(1.f, fabsf(a1.rgb[i]));
    assert_true(moved > NF / 20);
    /* Back to t = 0 reproduces the first frame. */
    TU_CHECK_OK(pgi_scene_set_time(mov, 0.0));
    TU_CHECK_OK(pgi_renderer_render(r, &k_desc, &a1, &fs));
    assert_memory_equal(a0.rgb, a1.rgb, NF * sizeof(float));
    pgi_renderer_destroy(r);
    pgi_image_free(&a0);
    pgi_image_free(&a1);
    pgi_image_free(&b);
    pgi_image_free(&c);
    pgi_scene_destroy(mov);
    pgi_scene_destroy(held);
    pgi_scene_destroy(stat);
}

/* Loop modes, rotation and scale, observed through the scene bounds: a box
 * far to the +x side of sphere-and-plane sets bounds_max.x. */
static void test_motion_modes(void **state) {
    (void)state;
    static const char *const loops[3] = {"clamp", "repeat", "pingpong"};
    /* translate x: 0 at t=1, 10 at t=3 */
    static const double t[5] = {0.0, 2.0, 3.5, 4.0, 6.0};
    static const double want[3][5] = {{0, 5, 10, 10, 10},
                                      {5, 5, 2.5, 5, 5},
                                      {5, 5, 7.5, 5, 5}}; /* periodic modes also before t0 */
    for (int l = 0; l < 3; l++) {
        char json[1024];
        snprintf(json, sizeof json,
                 "{\"builtin\": \"sphere-and-plane\", \"objects\": [{\"shape\": \"box\", \"center\": [100, 1, 0],"
                 " \"size\": [2, 2, 2], \"motion\": {\"loop\": \"%s\", \"keyframes\": [{\"t\": 1},"
                 " {\"t\": 3, \"translate\": [10, 0, 0]}]}}]}",
                 loops[l]);
        pgi_scene *s;
        TU_CHECK_OK(load_json("modes", json, &s));
        for (int k = 0; k < 5; k++) {
            TU_CHECK_OK(pgi_scene_set_time(s, t[k]));
            pgi_scene_info in;
            pgi_scene_get_info(s, &in);
            double got = in.bounds_max[0] - 101.0;
            if (fabs(got - want[l][k]) > 1e-4)
                fail_msg("%s at t=%g: x offset %g, expected %g", loops[l], t[k], got, want[l][k]);
        }
        pgi_scene_destroy(s);
    }
    /* Rotation by 90 degrees about z and scale 2: a 2x4x2 box becomes 8 wide in x. */
    pgi_scene *s;
    TU_CHECK_OK(
        load_json("rot",
                  "{\"builtin\": \"sphere-and-plane\", \"objects\": [{\"shape\": \"box\", \"center\": [100, 5, 0],"
                  " \"size\": [2, 4, 2], \"motion\": {\"keyframes\": [{\"t\": 0},"
                  " {\"t\": 1, \"rotate\": [0, 0, 90], \"scale\": 2}]}}]}",
                  &s));
    TU_CHECK_OK(pgi_scene_set_time(s, 1.0));
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_float_equal(in.bounds_max[0], 104.f, 1e-3f);
    assert_int_equal(pgi_scene_set_time(s, NAN), PGI_ERR_INVALID_ARG);
    pgi_scene_destroy(s);
}

/* Light groups: get/set positions; a moved area light equals a fresh build. */
static void test_light_groups(void **state) {
    (void)state;
    pgi_scene *s, *s2;
    TU_CHECK_OK(pgi_scene_load("cornell", &s));
    assert_int_equal(pgi_scene_light_group_count(s), 1);
    pgi_light_group g;
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g));
    assert_int_equal(g.kind, PGI_LIGHT_KIND_AREA);
    assert_int_equal(g.triangles, 2);
    assert_float_equal(g.position[1], 1.98f, 1e-4f);
    assert_int_equal(pgi_scene_get_light_group(s, 1, &g), PGI_ERR_INVALID_ARG);

    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_image a = {0}, b = {0};
    TU_CHECK_OK(pgi_renderer_render(r, &k_desc, &a, NULL));
    float p[3] = {0.4f, 1.9f, 0.2f};
    TU_CHECK_OK(pgi_scene_set_light_position(s, 0, p));
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g));
    for (int k = 0; k < 3; k++) assert_float_equal(g.position[k], p[k], 1e-5f);
    TU_CHECK_OK(pgi_renderer_render(r, &k_desc, &a, NULL)); /* BVH updated inside */
    TU_CHECK_OK(pgi_scene_load("cornell", &s2));
    TU_CHECK_OK(pgi_scene_set_light_position(s2, 0, p));
    TU_CHECK_OK(pgi_render(s2, &k_desc, &b, NULL)); /* fresh BVH */
    assert_memory_equal(a.rgb, b.rgb, NF * sizeof(float));
    float bad[3] = {NAN, 0.f, 0.f};
    assert_int_equal(pgi_scene_set_light_position(s, 0, bad), PGI_ERR_INVALID_ARG);
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s2);
    pgi_scene_destroy(s);

    /* Point and sun lights. */
    TU_CHECK_OK(load_json("sun",
                          "{\"builtin\": \"sphere-and-plane\", \"lights\": [{\"type\": \"sun\","
                          " \"direction\": [0, -1, 0], \"irradiance\": [1, 1, 1]}]}",
                          &s));
    assert_int_equal(pgi_scene_light_group_count(s), 2);
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g));
    assert_int_equal(g.kind, PGI_LIGHT_KIND_POINT);
    assert_float_equal(g.position[1], 2.f, 1e-6f); /* the built-in light is at (1.5, 2, 1.5) */
    TU_CHECK_OK(pgi_scene_set_light_position(s, 0, p));
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g));
    assert_float_equal(g.position[0], p[0], 0.f);
    TU_CHECK_OK(pgi_scene_get_light_group(s, 1, &g));
    assert_int_equal(g.kind, PGI_LIGHT_KIND_SUN);
    assert_int_equal(pgi_scene_set_light_position(s, 1, p), PGI_ERR_UNSUPPORTED);
    pgi_scene_destroy(s);
}

/* Photon counts: the count view agrees with the estimator's contributing total. */
static void test_photon_counts(void **state) {
    (void)state;
    pgi_scene *s;
    TU_CHECK_OK(pgi_scene_load("cornell", &s));
    pgi_render_desc d = k_desc;
    for (size_t i = 0; i < pgi_estimator_count(); i++) {
        if (!pgi_estimator_at(i)->exact) continue;
        d.estimator = pgi_estimator_at(i)->name;
        d.output = PGI_OUTPUT_PHOTON_COUNT;
        pgi_image img = {0};
        pgi_frame_stats fs;
        TU_CHECK_OK(pgi_render(s, &d, &img, &fs));
        double total = 0.0;
        for (size_t p = 0; p < NF / 3; p++) {
            assert_true(img.rgb[3 * p] == floorf(img.rgb[3 * p]) && img.rgb[3 * p] == img.rgb[3 * p + 2]);
            total += img.rgb[3 * p];
        }
        if (fabs(total - (double)fs.contributing) > 0.5)
            fail_msg("%s: counts sum to %.0f, the estimator reports %llu contributing", d.estimator, total,
                     (unsigned long long)fs.contributing);
        assert_true(total > 0.0);
        pgi_image_free(&img);
    }
    pgi_scene_destroy(s);
}

static void expect_parse_error(const char *json, const char *needle) {
    pgi_scene *s = NULL;
    pgi_status st = load_json("bad", json, &s);
    if (st != PGI_ERR_PARSE || !strstr(pgi_last_error(), needle))
        fail_msg("expected a parse error mentioning '%s', got status %d: %s", needle, (int)st, pgi_last_error());
    assert_null(s);
}

static void test_format_errors(void **state) {
    (void)state;
    expect_parse_error("{\"builtin\": \"nope\"}", "builtin must name a built-in scene");
    expect_parse_error("{\"builtin\": \"cornell\", \"mesh\": \"x.obj\"}", "either mesh or builtin");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": {}}", "objects must be an array");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"cone\", \"center\": [0,0,0]}]}",
                       "objects[0].shape");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"sphere\", \"center\": [0,0,0],"
                       " \"radius\": -1}]}",
                       "objects[0].radius");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"sphere\", \"center\": [0,0,0],"
                       " \"size\": [1,1,1], \"radius\": 1}]}",
                       "not a size");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"box\", \"center\": [0,0,0],"
                       " \"size\": [1,0,1]}]}",
                       "size must be 3 positive");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"box\", \"center\": [0,0,0],"
                       " \"size\": [1,1,1], \"material\": {\"type\": \"velvet\"}}]}",
                       "material.type");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"box\", \"center\": [0,0,0],"
                       " \"size\": [1,1,1], \"material\": {\"kd\": [2,0,0]}}]}",
                       "at most 1");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"box\", \"center\": [0,0,0],"
                       " \"size\": [1,1,1], \"motion\": {\"keyframes\": []}}]}",
                       "keyframes must be a non-empty array");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"box\", \"center\": [0,0,0],"
                       " \"size\": [1,1,1], \"motion\": {\"keyframes\": [{\"t\": 1}, {\"t\": 1}]}}]}",
                       "greater than the previous");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"box\", \"center\": [0,0,0],"
                       " \"size\": [1,1,1], \"motion\": {\"keyframes\": [{\"t\": 0, \"translat\": [1,0,0]}]}}]}",
                       "unknown key 'objects[0].motion.keyframes[0].translat'");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"box\", \"center\": [0,0,0],"
                       " \"size\": [1,1,1], \"motion\": {\"loop\": \"forever\", \"keyframes\": [{\"t\": 0}]}}]}",
                       "loop must be");
    expect_parse_error("{\"builtin\": \"cornell\", \"objects\": [{\"shape\": \"box\", \"center\": [0,0,0],"
                       " \"size\": [1,1,1], \"motion\": {\"keyframes\": [{\"t\": 0, \"scale\": 0}]}}]}",
                       "scale");
    expect_parse_error("{\"builtin\": \"cornell\", \"animate\": [{\"material\": \"nope\", \"motion\":"
                       " {\"keyframes\": [{\"t\": 0}]}}]}",
                       "not a material of the mesh");
    expect_parse_error("{\"builtin\": \"cornell\", \"animate\": [{\"material\": \"white\"}]}", "motion is missing");
    /* A mesh material can be animated (the built-in's "light" quad here). */
    pgi_scene *s;
    TU_CHECK_OK(load_json("anim-mat",
                          "{\"builtin\": \"cornell\", \"animate\": [{\"material\": \"light\", \"motion\":"
                          " {\"keyframes\": [{\"t\": 0}, {\"t\": 1, \"translate\": [0.3, 0, 0]}]}}]}",
                          &s));
    pgi_light_group g0, g1;
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g0));
    TU_CHECK_OK(pgi_scene_set_time(s, 1.0));
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g1));
    assert_float_equal(g1.position[0] - g0.position[0], 0.3f, 1e-5f);
    float p[3] = {0, 1.9f, 0};
    assert_int_equal(pgi_scene_set_light_position(s, 0, p), PGI_ERR_UNSUPPORTED);
    pgi_scene_destroy(s);
}

/* The example scene shipped in scenes/ loads and needs no files. */
static void test_example_scene(void **state) {
    (void)state;
    pgi_scene *s;
    TU_CHECK_OK(pgi_scene_load("scenes/cornell-moving.json", &s));
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_true(in.animated_objects >= 1);
    pgi_render_desc d = {.photons = 2000, .width = 16, .height = 16, .direct_samples = 1};
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_image img = {0};
    for (int k = 0; k < 4; k++) {
        TU_CHECK_OK(pgi_scene_set_time(s, 0.37 * k));
        TU_CHECK_OK(pgi_renderer_render(r, &d, &img, NULL));
    }
    pgi_renderer_destroy(r);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
}

TU_MAIN("dynamic", tu_dir_setup, tu_dir_teardown, cmocka_unit_test(test_frame_at_t_equals_static),
        cmocka_unit_test(test_motion_modes), cmocka_unit_test(test_light_groups), cmocka_unit_test(test_photon_counts),
        cmocka_unit_test(test_format_errors), cmocka_unit_test(test_example_scene))
