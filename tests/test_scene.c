/* Scene loading through the public API: errors name what went wrong and the
 * file; built-in scenes have the expected content. */
#include "test_util.h"

static char g_dir[512];

static int setup(void **state) {
    tu_make_tmpdir(g_dir, sizeof g_dir);
    return 0;
}

static int teardown(void **state) {
    tu_rm_tmpdir(g_dir);
    return 0;
}

/* Writes `text` to g_dir/name and returns the full path (static buffer per call site). */
static const char *put(const char *name, const char *text, char *buf, size_t n) {
    snprintf(buf, n, "%s/%s", g_dir, name);
    if (tu_write_file(buf, text)) fail_msg("cannot write %s", buf);
    return buf;
}

/* Loads `path`, expects failure with one of the two codes, and the message to contain `needle`. */
static void expect_error(const char *path, pgi_status code1, pgi_status code2, const char *needle) {
    pgi_scene *s = (pgi_scene *)&g_dir; /* must be reset to NULL */
    pgi_status st = pgi_scene_load(path, &s);
    if (st == PGI_OK) {
        pgi_scene_destroy(s);
        fail_msg("%s: loaded, expected an error", path);
    }
    assert_null(s);
    const char *msg = pgi_last_error();
    fprintf(stderr, "  %s -> %s: %s\n", path, pgi_status_string(st), msg);
    if (st != code1 && st != code2) fail_msg("%s: status %s (%d)", path, pgi_status_string(st), (int)st);
    if (!strstr(msg, needle)) fail_msg("%s: message '%s' does not name '%s'", path, msg, needle);
}

static const char *k_tri_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
static const char *k_mtl_light = "newmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n";

static void test_missing_file(void **state) {
    expect_error("/nonexistent/dir/model.obj", PGI_ERR_IO, PGI_ERR_IO, "/nonexistent/dir/model.obj");
    expect_error("/nonexistent/dir/scene.json", PGI_ERR_IO, PGI_ERR_IO, "/nonexistent/dir/scene.json");
}

static void test_unknown_name(void **state) {
    expect_error("no-such-scene", PGI_ERR_INVALID_ARG, PGI_ERR_IO, "no-such-scene");
    pgi_scene *s = (pgi_scene *)&g_dir;
    assert_int_equal(pgi_scene_load("", &s), PGI_ERR_INVALID_ARG);
    assert_null(s);
    assert_int_equal(pgi_scene_load(NULL, &s), PGI_ERR_INVALID_ARG);
}

static void test_malformed_obj(void **state) {
    char p[700];
    put("garbage.obj", "this is not\x01\x02 an OBJ file\nf x y z\nv 1 2\n\xff\xfe\n", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_IO, "garbage.obj");
    /* An empty file and a file with only vertices: no triangles. */
    put("empty.obj", "", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_IO, "empty.obj");
    put("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_IO, "points.obj");
    /* A face that refers to vertices that do not exist. */
    put("badindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_IO, "badindex.obj");
}

/* A bare mesh without emissive materials has no light: a clear error. */
static void test_obj_without_lights(void **state) {
    char p[700];
    put("nolight.obj", k_tri_obj, p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "nolight.obj");
}

/* An emissive OBJ loads; one area light per emissive triangle. */
static void test_emissive_obj_loads(void **state) {
    char p[700], m[700];
    put("lamp.mtl", k_mtl_light, m, sizeof m);
    put("lamp.obj", "mtllib lamp.mtl\nusemtl lamp\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", p, sizeof p);
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load(p, &s));
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_int_equal(in.triangles, 2);
    assert_int_equal(in.area_triangles, 2);
    assert_int_equal(in.lights, 2);
    assert_true(in.bounds_max[0] > 0.99f && in.bounds_max[0] < 1.01f);
    pgi_scene_destroy(s);
}

/* Non-finite vertices: 1e999 overflows to inf and must be rejected; NaN must
 * not crash (and is rejected too, whatever Assimp makes of it). */
static void test_nonfinite_vertex(void **state) {
    char p[700], m[700];
    put("lamp.mtl", k_mtl_light, m, sizeof m);
    put("inf.obj", "mtllib lamp.mtl\nusemtl lamp\nv 1e999 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_IO, "inf.obj");
    put("nan.obj", "mtllib lamp.mtl\nusemtl lamp\nv nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", p, sizeof p);
    pgi_scene *s = NULL;
    pgi_status st = pgi_scene_load(p, &s);
    fprintf(stderr, "  nan.obj -> %s: %s\n", pgi_status_string(st), pgi_last_error());
    if (st == PGI_OK) {
        /* If it loads, every number must be finite (NaN read as something else). */
        pgi_scene_info in;
        pgi_scene_get_info(s, &in);
        for (int k = 0; k < 3; k++) assert_true(isfinite(in.bounds_min[k]) && isfinite(in.bounds_max[k]));
        pgi_scene_destroy(s);
    } else {
        assert_null(s);
        assert_non_null(strstr(pgi_last_error(), "nan.obj"));
    }
}

static void test_missing_texture(void **state) {
    char p[700], m[700];
    put("tex.mtl", "newmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\nmap_Kd textures/not-there.png\n", m, sizeof m);
    put("tex.obj", "mtllib tex.mtl\nusemtl lamp\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n", p,
        sizeof p);
    expect_error(p, PGI_ERR_IO, PGI_ERR_PARSE, "not-there.png");
}

/* JSON descriptions. */
static void json_scene(const char *name, const char *mesh_line, const char *lights, char *buf, size_t n) {
    char text[2048];
    snprintf(text, sizeof text,
             "{\n  %s\n  \"camera\": {\"eye\": [0.3, 0.3, 3], \"look_at\": [0.3, 0.3, 0]},\n  \"lights\": %s\n}\n",
             mesh_line, lights);
    put(name, text, buf, n);
}

static void test_json_errors(void **state) {
    char tri[700], p[700], mesh_line[800];
    put("tri.obj", k_tri_obj, tri, sizeof tri);
    snprintf(mesh_line, sizeof mesh_line, "\"mesh\": \"%s\",", tri);
    const char *ok_light = "[{\"type\": \"point\", \"position\": [0, 0, 1], \"intensity\": [1, 1, 1]}]";

    /* The valid description loads: the test below changes one thing at a time. */
    json_scene("good.json", mesh_line, ok_light, p, sizeof p);
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load(p, &s));
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_int_equal(in.point_lights, 1);
    assert_int_equal(in.triangles, 1);
    pgi_scene_destroy(s);

    json_scene("neg.json", mesh_line, "[{\"type\": \"point\", \"position\": [0, 0, 1], \"intensity\": [1, -1, 1]}]", p,
               sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "intensity");
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "neg.json");

    put("syntax.json", "{\n  \"mesh\": \"x.obj\",\n  \"lights\": [ {\"type\": \"point\" ,, ]\n", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "syntax.json");

    json_scene("nomesh.json", "\"mesh\": \"does-not-exist/missing.obj\",", ok_light, p, sizeof p);
    expect_error(p, PGI_ERR_IO, PGI_ERR_PARSE, "missing.obj");

    json_scene("nomeshkey.json", "", ok_light, p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "mesh");

    json_scene("typo.json", mesh_line, "[{\"type\": \"point\", \"positon\": [0, 0, 1], \"intensity\": [1, 1, 1]}]", p,
               sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "positon");

    json_scene("ltype.json", mesh_line, "[{\"type\": \"laser\", \"position\": [0, 0, 1], \"intensity\": [1, 1, 1]}]", p,
               sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "laser");

    json_scene("nolights.json", mesh_line, "[]", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "nolights.json");

    put("nul.json", "", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_IO, "nul.json");
}

static void test_builtins(void **state) {
    assert_true(pgi_builtin_scene_count() >= 3);
    assert_null(pgi_builtin_scene_name(pgi_builtin_scene_count()));
    for (size_t i = 0; i < pgi_builtin_scene_count(); i++) {
        const char *name = pgi_builtin_scene_name(i);
        pgi_scene *s = NULL;
        TU_CHECK_OK(pgi_scene_load(name, &s));
        pgi_scene_info in;
        pgi_scene_get_info(s, &in);
        assert_string_equal(in.name, name);
        assert_true(in.triangles > 0);
        assert_true(in.lights > 0);
        assert_true(in.cameras >= 1);
        for (int k = 0; k < 3; k++) assert_true(in.bounds_min[k] <= in.bounds_max[k]);
        if (strcmp(name, "cornell") == 0) {
            assert_true(in.area_triangles > 0);
            assert_int_equal(in.point_lights, 0);
            assert_int_equal(in.lights, in.area_triangles);
            assert_true(in.bounds_min[1] > -0.01f && in.bounds_max[1] < 2.01f);
        }
        if (strcmp(name, "giref") == 0) {
            assert_int_equal(in.point_lights, 1);
            assert_int_equal(in.lights, 1);
            assert_int_equal(in.area_triangles, 0);
        }
        pgi_scene_destroy(s);
    }
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("giref", &s));
    pgi_scene_destroy(s);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_missing_file),       cmocka_unit_test(test_unknown_name),
        cmocka_unit_test(test_malformed_obj),      cmocka_unit_test(test_obj_without_lights),
        cmocka_unit_test(test_emissive_obj_loads), cmocka_unit_test(test_nonfinite_vertex),
        cmocka_unit_test(test_missing_texture),    cmocka_unit_test(test_json_errors),
        cmocka_unit_test(test_builtins),
    };
    return cmocka_run_group_tests_name("scene", tests, setup, teardown);
}
