/* A camera one can carry (apps/common/camera.h, issue 40): a camera printed as the JSON camera
 * block and as the --eye/--look-at/--up/--fov flags (what photongi-view's V key prints), pasted
 * back into a scene description (the JSON loader) or parsed as flags, is the same pgi_camera_def
 * bit for bit and renders the same image; the flags' checks refuse what cannot render; a part
 * not given is the base camera's. */
#include "test_util.h"

#include <stdint.h>

#include "camera.h"

/* Cameras with awkward floats: values whose shortest decimal needs 9 digits, negative zero,
 * tiny and huge coordinates, a tilted up. */
static pgi_camera_def awkward_camera(int i) {
    pgi_camera_def c;
    uint32_t s = 0x9e3779b9u * (uint32_t)(i + 1);
    for (int k = 0; k < 3; k++) {
        s = s * 1664525u + 1013904223u;
        c.eye[k] = 0.3f + (float)(s >> 8) * (1.f / 16777216.f) * 0.7f;
        s = s * 1664525u + 1013904223u;
        c.look_at[k] = -0.2f + (float)(s >> 8) * (1.f / 16777216.f) * 0.4f;
    }
    c.up[0] = i == 1 ? -0.f : 0.01f * (float)i / 3.f;
    c.up[1] = 1.f;
    c.up[2] = i == 2 ? 1e-7f : 0.f;
    s = s * 1664525u + 1013904223u;
    c.fov_y_deg = 20.f + (float)(s >> 8) * (1.f / 16777216.f) * 70.f;
    if (i == 3) c.eye[2] = 123456.789f, c.look_at[2] = -9.87654e-6f;
    return c;
}

/* Splits "--eye a,b,c --look-at ..." into flags and parses them. */
static void parse_flags(const char *line, app_camera_args *args) {
    char buf[512], err[400];
    snprintf(buf, sizeof buf, "%s", line);
    memset(args, 0, sizeof *args);
    char *save = NULL, *flag = strtok_r(buf, " ", &save);
    int n = 0;
    while (flag) {
        char *value = strtok_r(NULL, " ", &save);
        assert_non_null(value);
        int rc = app_camera_option(flag, value, args, err, sizeof err);
        if (rc != 1) fail_msg("'%s %s' was not taken: %s", flag, value, rc < 0 ? err : "not a camera flag");
        n++;
        flag = strtok_r(NULL, " ", &save);
    }
    assert_int_equal(n, 4);
}

/* The JSON block, pasted into a description over the built-in giref scene, loaded. */
static pgi_scene *scene_with_camera(const char *block) {
    const char *path = "test_camera_carry.json";
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "{\"builtin\": \"giref\", \"camera\": %s}\n", block);
    fclose(f);
    pgi_scene *s = NULL;
    pgi_status st = pgi_scene_load(path, &s);
    if (st) fail_msg("%s: %s", block, pgi_last_error());
    remove(path);
    return s;
}

static void test_json_and_flags_round_trip(void **state) {
    (void)state;
    for (int i = 0; i < 40; i++) {
        const pgi_camera_def c = awkward_camera(i);
        char block[512], flags[512], err[400];
        assert_true(app_camera_json(&c, block, sizeof block) < (int)sizeof block);
        assert_true(app_camera_flags(&c, flags, sizeof flags) < (int)sizeof flags);
        /* the flags */
        app_camera_args args;
        parse_flags(flags, &args);
        pgi_camera_def back, base = {{9, 9, 9}, {8, 8, 8}, {0, 0, 1}, 10.f};
        assert_true(app_camera_resolve(&args, &base, &back, err, sizeof err));
        if (memcmp(&back, &c, sizeof c) != 0) fail_msg("camera %d: the flags '%s' read back differently", i, flags);
        /* the JSON block */
        pgi_scene *s = scene_with_camera(block);
        pgi_camera_def loaded;
        assert_int_equal(pgi_scene_get_camera(s, 0, &loaded), PGI_OK);
        if (memcmp(&loaded, &c, sizeof c) != 0) fail_msg("camera %d: the block %s loads differently", i, block);
        pgi_scene_info info;
        pgi_scene_get_info(s, &info);
        assert_int_equal(info.camera_auto, 0);
        pgi_scene_destroy(s);
    }
}

/* The same image from the scene description's camera and from the flags' camera as a view. */
static void test_same_image(void **state) {
    (void)state;
    pgi_camera_def c = awkward_camera(5);
    char block[512], flags[512], err[400];
    app_camera_json(&c, block, sizeof block);
    app_camera_flags(&c, flags, sizeof flags);
    pgi_scene *s = scene_with_camera(block);
    app_camera_args args;
    parse_flags(flags, &args);
    pgi_camera_def base, view;
    assert_int_equal(pgi_scene_get_camera(s, 0, &base), PGI_OK);
    assert_true(app_camera_resolve(&args, &base, &view, err, sizeof err));
    pgi_renderer *r;
    assert_int_equal(pgi_renderer_create(s, &r), PGI_OK);
    pgi_render_desc d = {.width = 48, .height = 32, .photons = 4000, .seed = 3, .threads = 2};
    pgi_image a = {0}, b = {0}, other = {0};
    assert_int_equal(pgi_renderer_render(r, &d, &a, NULL), PGI_OK);
    d.view = &view;
    assert_int_equal(pgi_renderer_render(r, &d, &b, NULL), PGI_OK);
    assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * 48 * 32);
    /* guard: another camera renders another image */
    view.eye[0] += 0.05f;
    assert_int_equal(pgi_renderer_render(r, &d, &other, NULL), PGI_OK);
    assert_true(memcmp(a.rgb, other.rgb, sizeof(float) * 3 * 48 * 32) != 0);
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_image_free(&other);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

/* Parts not given are the base camera's; values and degenerate cameras are refused. */
static void test_partial_and_refused(void **state) {
    (void)state;
    char err[400];
    const pgi_camera_def base = {{1, 2, 3}, {0, 2, 0}, {0, 1, 0}, 45.f};
    app_camera_args a = {0};
    pgi_camera_def out;
    assert_int_equal(app_camera_option("--fov", "30", &a, err, sizeof err), 1);
    assert_true(app_camera_resolve(&a, &base, &out, err, sizeof err));
    assert_true(out.fov_y_deg == 30.f && memcmp(out.eye, base.eye, sizeof out.eye) == 0 &&
                memcmp(out.look_at, base.look_at, sizeof out.look_at) == 0 &&
                memcmp(out.up, base.up, sizeof out.up) == 0);
    assert_int_equal(app_camera_option("--scene", "x", &a, err, sizeof err), 0);
    static const char *const bad[][2] = {
        {"--eye", "1,2"},     {"--eye", "1,2,3,"},       {"--eye", "1,,3"}, {"--eye", "nan,0,0"},
        {"--eye", "0,inf,0"}, {"--look-at", "2e15,0,0"}, {"--up", "a,b,c"}, {"--fov", "0"},
        {"--fov", "180"},     {"--fov", "-5"},           {"--fov", "45x"},  {"--eye", ""},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        app_camera_args b = {0};
        if (app_camera_option(bad[i][0], bad[i][1], &b, err, sizeof err) != -1)
            fail_msg("%s '%s' was accepted", bad[i][0], bad[i][1]);
        assert_non_null(strstr(err, bad[i][0]));
        assert_false(app_camera_given(&b));
    }
    app_camera_args same = {0};
    assert_int_equal(app_camera_option("--eye", "0,2,0", &same, err, sizeof err), 1); /* base's look-at */
    assert_false(app_camera_resolve(&same, &base, &out, err, sizeof err));
    assert_non_null(strstr(err, "same point"));
    app_camera_args par = {0};
    assert_int_equal(app_camera_option("--eye", "0,5,0", &par, err, sizeof err), 1); /* straight down, up 0,1,0 */
    assert_false(app_camera_resolve(&par, &base, &out, err, sizeof err));
    assert_non_null(strstr(err, "parallel"));
    assert_int_equal(app_camera_option("--up", "1,0,0", &par, err, sizeof err), 1);
    assert_true(app_camera_resolve(&par, &base, &out, err, sizeof err));
}

/* A mesh without a camera gets the automatic one, and says so; a built-in scene has its own. */
static void test_automatic_camera_flag(void **state) {
    (void)state;
    FILE *m = fopen("test_camera_carry.mtl", "w"), *f = fopen("test_camera_carry.obj", "w");
    assert_non_null(m);
    assert_non_null(f);
    fputs("newmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n", m);
    fputs("mtllib test_camera_carry.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n", f);
    fclose(m);
    fclose(f);
    pgi_scene *s = NULL;
    pgi_status st = pgi_scene_load("test_camera_carry.obj", &s);
    remove("test_camera_carry.obj");
    remove("test_camera_carry.mtl");
    if (st) fail_msg("%s", pgi_last_error());
    pgi_scene_info info;
    pgi_scene_get_info(s, &info);
    assert_int_equal(info.cameras, 1);
    assert_int_equal(info.camera_auto, 1);
    pgi_scene_destroy(s);
    assert_int_equal(pgi_scene_load("cornell", &s), PGI_OK);
    pgi_scene_get_info(s, &info);
    assert_int_equal(info.camera_auto, 0);
    pgi_scene_destroy(s);
}

TU_MAIN("camera carry", NULL, NULL, cmocka_unit_test(test_json_and_flags_round_trip), cmocka_unit_test(test_same_image),
        cmocka_unit_test(test_partial_and_refused), cmocka_unit_test(test_automatic_camera_flag))
