/* Scene loading through the public API: errors name what went wrong and the
 * file; built-in scenes have the expected content. */
#include "test_util.h"

#include "photongi/metrics.h"
#include "photongi/reference.h"
#include "scene/scene_internal.h"

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
    pgi_scene *s = tu_scene(p);
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

/* A texture file that is not there: the scene loads, the material keeps its colour, and the
 * load's warning names the file (once, however many materials name it). A texture that is there
 * but cannot be read still fails. */
static void test_missing_texture(void **state) {
    char p[700], m[700];
    put("tex.mtl",
        "newmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\nmap_Kd textures/not-there.png\n"
        "newmtl lamp2\nKd 0.5 0.5 0.5\nKe 1 1 1\nmap_Kd textures/not-there.png\n",
        m, sizeof m);
    put("tex.obj",
        "mtllib tex.mtl\nusemtl lamp\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"
        "usemtl lamp2\nf 1/1 3/3 2/2\n",
        p, sizeof p);
    pgi_scene *s = tu_scene(p);
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_non_null(strstr(in.warnings, "not found: texture "));
    const char *first = strstr(in.warnings, "not-there.png");
    assert_non_null(first);
    assert_null(strstr(first + 1, "not-there.png"));
    assert_int_equal(s->ntexs, 0);
    for (size_t i = 0; i < s->nmats; i++) assert_int_equal(s->mats[i].tex_kd, -1);
    pgi_scene_destroy(s);
    put("bad.png", "not a png", m, sizeof m);
    put("tex.mtl", "newmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\nmap_Kd bad.png\n", m, sizeof m);
    expect_error(p, PGI_ERR_IO, PGI_ERR_PARSE, "bad.png");
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
    pgi_scene *s = tu_scene(p);
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
        pgi_scene *s = tu_scene(name);
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
    pgi_scene *s = tu_scene("giref");
    pgi_scene_destroy(s);
}

/* ------------------------------------------------- generated normals */

/* Icosphere of radius 1: the icosahedron, each triangle split in four `levels`
 * times, new vertices pushed onto the sphere; every vertex is shared by 5 or 6
 * triangles (counter-clockwise seen from outside). */
#define ICO_MAXV 700
#define ICO_MAXF 1300
typedef struct ico {
    float v[ICO_MAXV][3];
    int f[ICO_MAXF][3];
    int nv, nf;
} ico;

static int ico_push(ico *m, float x, float y, float z) {
    float l = sqrtf(x * x + y * y + z * z);
    assert_true(m->nv < ICO_MAXV);
    m->v[m->nv][0] = x / l, m->v[m->nv][1] = y / l, m->v[m->nv][2] = z / l;
    return m->nv++;
}

static int ico_mid(ico *m, int (*edges)[3], int *ne, int a, int b) {
    int lo = a < b ? a : b, hi = a < b ? b : a;
    for (int i = 0; i < *ne; i++)
        if (edges[i][0] == lo && edges[i][1] == hi) return edges[i][2];
    int k = ico_push(m, 0.5f * (m->v[a][0] + m->v[b][0]), 0.5f * (m->v[a][1] + m->v[b][1]),
                     0.5f * (m->v[a][2] + m->v[b][2]));
    edges[*ne][0] = lo, edges[*ne][1] = hi, edges[*ne][2] = k;
    ++*ne;
    return k;
}

static void ico_make(ico *m, int levels) {
    const float t = 1.618034f; /* golden ratio */
    const float base[12][3] = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                               {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    static const int faces[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                     {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                     {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                     {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    m->nv = m->nf = 0;
    for (int i = 0; i < 12; i++) ico_push(m, base[i][0], base[i][1], base[i][2]);
    for (int i = 0; i < 20; i++) memcpy(m->f[m->nf++], faces[i], sizeof faces[i]);
    static int edges[ICO_MAXF * 2][3];
    for (int l = 0; l < levels; l++) {
        int ne = 0, nf = m->nf;
        assert_true(nf * 4 <= ICO_MAXF);
        for (int i = 0; i < nf; i++) {
            int a = m->f[i][0], b = m->f[i][1], c = m->f[i][2];
            int ab = ico_mid(m, edges, &ne, a, b), bc = ico_mid(m, edges, &ne, b, c), ca = ico_mid(m, edges, &ne, c, a);
            int *f = m->f[i];
            f[0] = a, f[1] = ab, f[2] = ca;
            f = m->f[m->nf++], f[0] = b, f[1] = bc, f[2] = ab;
            f = m->f[m->nf++], f[0] = c, f[1] = ca, f[2] = bc;
            f = m->f[m->nf++], f[0] = ab, f[1] = bc, f[2] = ca;
        }
    }
}

/* Writes the mesh as OBJ (v and f only, no vn; `extra` goes first, e.g. "s off\n") or ASCII PLY
 * (x y z only), every vertex once and shared by its triangles. */
static const char *ico_write(const ico *m, const char *name, const char *extra, char *buf, size_t n) {
    snprintf(buf, n, "%s/%s", g_dir, name);
    FILE *f = fopen(buf, "w");
    if (!f) fail_msg("cannot write %s", buf);
    int ply = strstr(name, ".ply") != NULL;
    if (ply)
        fprintf(f,
                "ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
                "element face %d\nproperty list uchar int vertex_indices\nend_header\n",
                m->nv, m->nf);
    else if (extra) fputs(extra, f);
    for (int i = 0; i < m->nv; i++)
        fprintf(f, "%s%.7f %.7f %.7f\n", ply ? "" : "v ", m->v[i][0], m->v[i][1], m->v[i][2]);
    for (int i = 0; i < m->nf; i++)
        fprintf(f, ply ? "3 %d %d %d\n" : "f %d %d %d\n", m->f[i][0] + !ply, m->f[i][1] + !ply, m->f[i][2] + !ply);
    fclose(f);
    return buf;
}

/* A description around `mesh`: a camera looking at the unit sphere, a point light. */
static const char *sphere_json(const char *name, const char *mesh, char *buf, size_t n) {
    char text[2048];
    snprintf(text, sizeof text,
             "{\"mesh\": \"%s\",\n \"camera\": {\"eye\": [0, 0.4, 3.2], \"look_at\": [0, 0, 0], \"fov_y\": 45},\n"
             " \"lights\": [{\"type\": \"point\", \"position\": [2, 3, 4], \"intensity\": [30, 30, 30]}]}\n",
             mesh);
    return put(name, text, buf, n);
}

static const double k_deg = 57.29577951308232; /* degrees per radian */

/* Largest angle (degrees) between a vertex normal and the sphere's radial direction. */
static double worst_radial_deg(const pgi_scene *s) {
    assert_non_null(s->nrm);
    double worst = 0.0;
    for (size_t i = 0; i < s->nverts; i++) {
        const float *p = s->pos + 3 * i, *nn = s->nrm + 3 * i;
        double c = tu_dot(p, nn) / sqrt((double)tu_dot(p, p) * (double)tu_dot(nn, nn));
        double a = acos(fmin(1.0, c)) * k_deg;
        if (!(a <= worst)) worst = a; /* NaN counts as the worst */
    }
    return worst;
}

/* Largest angle (degrees) between a triangle's corner normals and its face normal. */
static double worst_flat_deg(const pgi_scene *s) {
    assert_non_null(s->nrm);
    double worst = 0.0;
    for (size_t t = 0; t < s->ntris; t++) {
        const uint32_t *ix = s->tri + 3 * t;
        const float *a = s->pos + 3 * ix[0], *b = s->pos + 3 * ix[1], *c = s->pos + 3 * ix[2];
        float e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        float fn[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        tu_normalize(fn);
        for (int k = 0; k < 3; k++) {
            double cs = tu_dot(fn, s->nrm + 3 * ix[k]);
            double ang = acos(fmin(1.0, cs)) * k_deg;
            if (!(ang <= worst)) worst = ang;
        }
    }
    return worst;
}

static pgi_scene *load_ok(const char *path) {
    pgi_scene *s = tu_scene(path);
    return s;
}

static void render_scene(pgi_scene *s, pgi_image *img) {
    pgi_renderer *r = tu_renderer(s);
    pgi_frame_stats st;
    TU_CHECK_OK(
        pgi_renderer_render(r, &(pgi_render_desc){.width = 96, .height = 96, .photons = 20000, .seed = 3, .threads = 2},
                            img, &st));
    pgi_renderer_destroy(r);
}

/* A mesh without normals whose triangles share vertices gets smooth vertex
 * normals, the same from OBJ (no vn) and PLY (no nx ny nz): each vertex of the
 * icosphere faces outwards, and both files render alike. (Assimp 5.2's
 * GenNormals/GenSmoothNormals give each shared PLY vertex the normal of the
 * last triangle written to it: 10.8 degrees off, 20-23 dB against the OBJ.) */
static void test_generated_normals_obj_ply(void **state) {
    static ico m;
    ico_make(&m, 2);
    assert_int_equal(m.nv, 162);
    assert_int_equal(m.nf, 320);
    char obj[700], ply[700], jo[700], jp[700];
    ico_write(&m, "ico.obj", NULL, obj, sizeof obj);
    ico_write(&m, "ico.ply", NULL, ply, sizeof ply);
    pgi_scene *so = load_ok(sphere_json("ico_obj.json", obj, jo, sizeof jo));
    pgi_scene *sp = load_ok(sphere_json("ico_ply.json", ply, jp, sizeof jp));
    double wo = worst_radial_deg(so), wp = worst_radial_deg(sp);
    fprintf(stderr, "  icosphere vertex normals vs radial: OBJ %.2f, PLY %.2f degrees (worst)\n", wo, wp);
    pgi_image io = {0}, ip = {0};
    render_scene(so, &io);
    render_scene(sp, &ip);
    pgi_metrics mt;
    TU_CHECK_OK(pgi_metrics_compute(&ip, &io, 1.f, &mt));
    fprintf(stderr, "  icosphere OBJ vs PLY: PSNR %.2f dB\n", mt.psnr);
    /* The angle-weighted mean of the face normals around a vertex of this sphere is
     * within 1 degree of the radius (the faces around a vertex are nearly symmetric). */
    assert_true(wo < 1.0);
    assert_true(wp < 1.0);
    assert_true(mt.psnr >= 40.0);
    pgi_image_free(&io);
    pgi_image_free(&ip);
    pgi_scene_destroy(so);
    pgi_scene_destroy(sp);
}

/* Where the format asks for flat shading, or the surface has creases, the
 * generated normals are the face normals: a glTF without normals (the glTF
 * spec's rule), an OBJ whose smoothing is off (`s off`), a PLY box (90-degree
 * edges). A mesh's own normals are kept. */
static void test_generated_normals_flat(void **state) {
    static ico m;
    ico_make(&m, 1);
    char mesh[700], json[700];
    /* OBJ with `s off`: flat, each vertex split into one per face around it. */
    ico_write(&m, "ico_off.obj", "s off\n", mesh, sizeof mesh);
    pgi_scene *s = load_ok(sphere_json("ico_off.json", mesh, json, sizeof json));
    double w = worst_flat_deg(s);
    fprintf(stderr, "  OBJ 's off': %zu vertices, corner vs face normal %.3f degrees (worst)\n", s->nverts, w);
    assert_true(w < 0.1); /* float rounding: acos near 1 */
    assert_int_equal(s->nverts, 3 * m.nf);
    pgi_scene_destroy(s);
    /* ... and with `s 1` smooth again. */
    ico_write(&m, "ico_s1.obj", "s 1\n", mesh, sizeof mesh);
    s = load_ok(sphere_json("ico_s1.json", mesh, json, sizeof json));
    assert_int_equal(s->nverts, m.nv);
    assert_true(worst_radial_deg(s) < 2.0);
    pgi_scene_destroy(s);

    /* glTF, positions and indices in an external buffer, no NORMAL attribute. */
    char bin[700];
    snprintf(bin, sizeof bin, "%s/ico.bin", g_dir);
    FILE *f = fopen(bin, "wb");
    assert_non_null(f);
    for (int i = 0; i < m.nv; i++) fwrite(m.v[i], sizeof(float), 3, f);
    for (int i = 0; i < m.nf; i++)
        for (int k = 0; k < 3; k++) {
            uint32_t ix = (uint32_t)m.f[i][k];
            fwrite(&ix, sizeof ix, 1, f);
        }
    fclose(f);
    char gltf[2048];
    size_t vbytes = 12 * (size_t)m.nv, ibytes = 12 * (size_t)m.nf;
    snprintf(gltf, sizeof gltf,
             "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}], \"nodes\": [{\"mesh\": "
             "0}],\n \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1}]}],\n"
             " \"buffers\": [{\"uri\": \"ico.bin\", \"byteLength\": %zu}],\n"
             " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": %zu}, {\"buffer\": 0, "
             "\"byteOffset\": %zu, \"byteLength\": %zu}],\n"
             " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": %d, \"type\": \"VEC3\", "
             "\"min\": [-1, -1, -1], \"max\": [1, 1, 1]},\n"
             "   {\"bufferView\": 1, \"componentType\": 5125, \"count\": %d, \"type\": \"SCALAR\"}]}\n",
             vbytes + ibytes, vbytes, vbytes, ibytes, m.nv, 3 * m.nf);
    put("ico.gltf", gltf, mesh, sizeof mesh);
    s = load_ok(sphere_json("ico_gltf.json", mesh, json, sizeof json));
    w = worst_flat_deg(s);
    fprintf(stderr, "  glTF without normals: %zu triangles, corner vs face normal %.3f degrees (worst)\n", s->ntris, w);
    assert_int_equal(s->ntris, m.nf);
    assert_true(w < 0.1); /* float rounding: acos near 1 */
    pgi_scene_destroy(s);

    /* PLY box, 8 shared corners: the 90-degree edges stay sharp (24 vertices). */
    put("box.ply",
        "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 6\nproperty list uchar int vertex_indices\nend_header\n"
        "-1 -1 -1\n1 -1 -1\n1 1 -1\n-1 1 -1\n-1 -1 1\n1 -1 1\n1 1 1\n-1 1 1\n"
        "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6\n4 1 2 6 5\n4 0 4 7 3\n",
        mesh, sizeof mesh);
    s = load_ok(sphere_json("box.json", mesh, json, sizeof json));
    w = worst_flat_deg(s);
    fprintf(stderr, "  PLY box: %zu vertices, corner vs face normal %.3f degrees (worst)\n", s->nverts, w);
    assert_int_equal(s->ntris, 12);
    assert_int_equal(s->nverts, 24);
    assert_true(w < 0.1); /* float rounding: acos near 1 */
    pgi_scene_destroy(s);

    /* An OBJ with its own normals keeps them, even where they are not the surface's. */
    snprintf(mesh, sizeof mesh, "%s/ico_vn.obj", g_dir);
    f = fopen(mesh, "w");
    assert_non_null(f);
    fputs("vn 0 1 0\n", f);
    for (int i = 0; i < m.nv; i++) fprintf(f, "v %.7f %.7f %.7f\n", m.v[i][0], m.v[i][1], m.v[i][2]);
    for (int i = 0; i < m.nf; i++) fprintf(f, "f %d//1 %d//1 %d//1\n", m.f[i][0] + 1, m.f[i][1] + 1, m.f[i][2] + 1);
    fclose(f);
    s = load_ok(sphere_json("ico_vn.json", mesh, json, sizeof json));
    for (size_t i = 0; i < s->nverts; i++)
        assert_true(s->nrm[3 * i] == 0.f && s->nrm[3 * i + 1] == 1.f && s->nrm[3 * i + 2] == 0.f);
    pgi_scene_destroy(s);
}

/* Numbers a ray or a density estimate cannot take (docs/scene-format.md, Numbers): refused at load or by
 * the setter, never an Embree abort or NaN/Inf pixels. */
static void test_scene_numbers(void **state) {
    char p[700], q[700];
    put("far.obj", "v 0 0 0\nv 1 0 0\nv 0 2e18 0\nf 1 2 3\n", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "vertex 2 at (0, 2e+18, 0) is beyond the coordinate range");
    put("hot.mtl", "newmtl lamp\nKd 0.5 0.5 0.5\nKe 3e38 1 1\n", q, sizeof q);
    put("hot.obj", "mtllib hot.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n", p, sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "material 'lamp' has an emission of 3e+38");
    put("upfar.json",
        "{\"builtin\": \"cornell\", \"camera\": {\"eye\": [0, 1, 3], \"look_at\": [0, 1, 0], \"up\": [0, 1e16, 0]}}", p,
        sizeof p);
    expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "camera.up[1] = 1e+16 is out of range");
    /* A name's control bytes (an escape sequence) become '?'. */
    put("esc.json", "{\"builtin\": \"cornell\", \"name\": \"a\\u001b[2Jb\"}", p, sizeof p);
    pgi_scene *s = tu_scene(p);
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_string_equal(in.name, "a?[2Jb");

    /* Moving a light beyond the range is refused and leaves it where it was. */
    pgi_light_group g0, g1;
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g0));
    assert_int_equal(pgi_scene_set_light_position(s, 0, (const float[3]){0.f, 1e30f, 0.f}), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "-1e+15..1e+15"));
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g1));
    assert_memory_equal(g0.position, g1.position, sizeof g0.position);

    /* A view camera beyond the range, a radius whose pi r^2 underflows: refused by the settings. */
    pgi_renderer *r = tu_renderer(s);
    pgi_image img = {0};
    pgi_camera_def far = {{0.f, 1.f, 2e18f}, {0.f, 1.f, 0.f}, {0.f, 1.f, 0.f}, 40.f};
    pgi_render_desc d = {.width = 16, .height = 16, .photons = 1000, .threads = 1, .view = &far};
    assert_int_equal(pgi_renderer_render(r, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "beyond the coordinate range"));
    d.view = NULL;
    d.radius = 1e-20f;
    assert_int_equal(pgi_renderer_render(r, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "photon radius 1e-20 is out of range (1e-09..1e+15"));
    d.radius = 1e-9f; /* the smallest radius renders finite pixels */
    TU_CHECK_OK(pgi_renderer_render(r, &d, &img, NULL));
    for (size_t i = 0; i < 3 * (size_t)img.width * img.height; i++) assert_true(isfinite(img.rgb[i]));
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

/* A glTF's accessors and what uses them (src/scene/gltf_check.c): a valid quad with an
 * animation loads from a .gltf with an external buffer, a data: URI and a GLB; each broken
 * variant is refused naming the object, where Assimp 5.2 crashed or read out of bounds. */
static char *replace(const char *text, const char *from, const char *to) {
    const char *at = strstr(text, from);
    if (!at) fail_msg("'%s' not in the glTF", from);
    char *out = malloc(strlen(text) + strlen(to) + 1);
    assert_non_null(out);
    sprintf(out, "%.*s%s%s", (int)(at - text), text, to, at + strlen(from));
    return out;
}

static void write_bytes(const char *path, const void *a, size_t n, const void *b, size_t m) {
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_true(fwrite(a, 1, n, f) == n && (!m || fwrite(b, 1, m, f) == m));
    assert_int_equal(fclose(f), 0);
}


/* ------------------------------------------------ cameras and lights from mesh files */

/* A floor (y = 0, x and z in [-2, 2]) and a back wall (z = -2, y in [0, 3]): 8 float3 positions
 * then 12 u16 indices, 120 bytes (the glTF's buffer, written beside it). */
static const float k_room_pos[24] = {-2, 0, -2, 2, 0, -2, 2, 0, 2, -2, 0, 2, -2, 0, -2, 2, 0, -2, 2, 3, -2, -2, 3, -2};
static const uint16_t k_room_idx[12] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7};

/* The room as a glTF: a camera node "Cam" at (0, 1.5, 4) turned 15 degrees down about x (yfov 0.8
 * rad, aspect 1.5, which Assimp would fold into its horizontal angle), and the point light "Lamp"
 * of colour (1, 0.5, 0.25) and 20 cd, 1 above its parent node, itself 1 above the floor. `extra`
 * ("": the usual "extensionsUsed") is spliced into the top-level object; `mat` is the material list. */
static const char *put_room_gltf(const char *name, const char *mat, const char *extra, char *buf, size_t n) {
    char bin[700];
    snprintf(bin, sizeof bin, "%s/room.bin", g_dir);
    write_bytes(bin, k_room_pos, sizeof k_room_pos, k_room_idx, sizeof k_room_idx);
    const double a = -15.0 * 3.14159265358979323846 / 180.0;
    char text[4096];
    snprintf(
        text, sizeof text,
        "{\"asset\": {\"version\": \"2.0\"},\n %s\n"
        " \"extensions\": {\"KHR_lights_punctual\": {\"lights\": [\n"
        "   {\"type\": \"point\", \"color\": [1, 0.5, 0.25], \"intensity\": 20}]}},\n"
        " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1, 2]}],\n"
        " \"nodes\": [{\"mesh\": 0},\n"
        "   {\"name\": \"Cam\", \"camera\": 0, \"translation\": [0, 1.5, 4], \"rotation\": [%.17g, 0, 0, %.17g]},\n"
        "   {\"name\": \"LampParent\", \"translation\": [0, 1, 0], \"children\": [3]},\n"
        "   {\"name\": \"Lamp\", \"translation\": [0, 1, 0], \"extensions\": {\"KHR_lights_punctual\": "
        "{\"light\": 0}}}],\n"
        " \"cameras\": [{\"type\": \"perspective\", \"perspective\": {\"yfov\": 0.8, \"aspectRatio\": 1.5, "
        "\"znear\": 0.1}}],\n"
        " \"materials\": [%s],\n"
        " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1, \"material\": 0}]}],\n"
        " \"buffers\": [{\"uri\": \"room.bin\", \"byteLength\": 120}],\n"
        " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": 96}, {\"buffer\": 0, \"byteOffset\": 96, "
        "\"byteLength\": 24}],\n"
        " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 8, \"type\": \"VEC3\", "
        "\"min\": [-2, 0, -2], \"max\": [2, 3, 2]},\n"
        "   {\"bufferView\": 1, \"componentType\": 5123, \"count\": 12, \"type\": \"SCALAR\"}]}\n",
        *extra ? extra : "\"extensionsUsed\": [\"KHR_lights_punctual\"],", sin(a / 2), cos(a / 2), mat);
    return put(name, text, buf, n);
}

static const char *k_grey_gltf_mat = "{\"pbrMetallicRoughness\": {\"baseColorFactor\": [0.8, 0.8, 0.8, 1], "
                                     "\"metallicFactor\": 0}}";

static double image_mean(const pgi_image *img) {
    double m = 0.0;
    const size_t n = 3 * (size_t)img->width * (size_t)img->height;
    for (size_t i = 0; i < n; i++) m += img->rgb[i];
    return m / (double)n;
}

/* The glTF's camera and point light: placed by their nodes' global transforms, the camera's yfov
 * vertical (Assimp stores yfov x aspect), and a glTF with a punctual light and no emissive material
 * renders from that camera: within 2 % of the same room, camera and light in a JSON description. */
static void test_gltf_camera_and_light(void **state) {
    (void)state;
    char p[700];
    pgi_scene *g = load_ok(put_room_gltf("room.gltf", k_grey_gltf_mat, "", p, sizeof p));
    pgi_scene_info in;
    pgi_scene_get_info(g, &in);
    assert_int_equal(in.cameras, 1);
    assert_int_equal(in.point_lights, 1);
    assert_int_equal(in.lights, 1);
    assert_string_equal(in.warnings, "");
    pgi_camera_def c;
    TU_CHECK_OK(pgi_scene_get_camera(g, 0, &c));
    assert_string_equal(pgi_scene_camera_name(g, 0), "Cam");
    const float s15 = sinf(15.f * 3.14159265f / 180.f), c15 = cosf(15.f * 3.14159265f / 180.f);
    const float eye[3] = {0.f, 1.5f, 4.f}, fwd[3] = {0.f, -s15, -c15}, up[3] = {0.f, c15, -s15};
    for (int k = 0; k < 3; k++) {
        assert_true(fabsf(c.eye[k] - eye[k]) < 1e-5f); /* not (0, 3.98, 7.48): the translation once */
        assert_true(fabsf(c.look_at[k] - c.eye[k] - fwd[k]) < 1e-5f);
        assert_true(fabsf(c.up[k] - up[k]) < 1e-5f);
    }
    assert_true(fabsf(c.fov_y_deg - 0.8f * 180.f / 3.14159265f) < 1e-3f); /* 45.84, not 1.2 rad */
    const pgi__light *L = &g->lights[0];
    assert_int_equal(L->type, PGI__LIGHT_POINT);
    assert_true(fabsf(L->pos[0]) < 1e-6f && fabsf(L->pos[1] - 2.f) < 1e-6f && fabsf(L->pos[2]) < 1e-6f);
    assert_true(L->color[0] == 20.f && L->color[1] == 10.f && L->color[2] == 5.f); /* cd -> W/sr, 1:1 */

    /* the same room as an OBJ in a description */
    char m[700], o[700], j[700], text[1024];
    put("room.mtl", "newmtl grey\nKd 0.8 0.8 0.8\n", m, sizeof m);
    size_t k = (size_t)snprintf(text, sizeof text, "mtllib room.mtl\ns off\nusemtl grey\n");
    for (int v = 0; v < 8; v++)
        k += (size_t)snprintf(text + k, sizeof text - k, "v %g %g %g\n", (double)k_room_pos[3 * v],
                              (double)k_room_pos[3 * v + 1], (double)k_room_pos[3 * v + 2]);
    for (int t = 0; t < 4; t++)
        k += (size_t)snprintf(text + k, sizeof text - k, "f %d %d %d\n", k_room_idx[3 * t] + 1,
                              k_room_idx[3 * t + 1] + 1, k_room_idx[3 * t + 2] + 1);
    put("room.obj", text, o, sizeof o);
    snprintf(text, sizeof text,
             "{\"mesh\": \"room.obj\",\n \"camera\": {\"eye\": [0, 1.5, 4], \"look_at\": [0, %.9g, %.9g], \"up\": [0, "
             "%.9g, %.9g], \"fov_y\": %.9g},\n"
             " \"lights\": [{\"type\": \"point\", \"position\": [0, 2, 0], \"intensity\": [20, 10, 5]}]}\n",
             1.5 - (double)s15, 4.0 - (double)c15, (double)c15, -(double)s15, 0.8 * 180.0 / 3.14159265358979323846);
    pgi_scene *js = load_ok(put("room.json", text, j, sizeof j));
    pgi_image a = {0}, b = {0};
    render_scene(g, &a);
    render_scene(js, &b);
    const double ma = image_mean(&a), mb = image_mean(&b);
    fprintf(stderr, "  glTF room mean %.6g, JSON room mean %.6g\n", ma, mb);
    assert_true(mb > 0.01);
    assert_true(fabs(ma - mb) <= 0.02 * mb);
    /* and the light is where the camera looks: the left and right halves are alike, the floor lit */
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_scene_destroy(js);
    pgi_scene_destroy(g);
}

/* KHR_materials_emissive_strength scales the emission: strength 20 emits 20 times strength 1 (the
 * material, and the image of its direct light and emission), and the ratio needs no light besides. */
static void test_gltf_emissive_strength(void **state) {
    (void)state;
    char p[700];
    double mean[2];
    for (int i = 0; i < 2; i++) {
        char mat[256];
        snprintf(mat, sizeof mat,
                 "{\"emissiveFactor\": [1, 0.5, 0.25], \"extensions\": {\"KHR_materials_emissive_strength\": "
                 "{\"emissiveStrength\": %d}}}",
                 i ? 20 : 1);
        pgi_scene *s = load_ok(put_room_gltf("glow.gltf", mat, "", p, sizeof p));
        assert_true(s->mats[0].ke[0] == (i ? 20.f : 1.f) && s->mats[0].ke[2] == (i ? 5.f : 0.25f));
        s->lights[0].color[0] = s->lights[0].color[1] = s->lights[0].color[2] = 0.f; /* the emitter alone */
        pgi__scene_refresh(s);
        pgi_renderer *r = tu_renderer(s);
        pgi_image img = {0};
        TU_CHECK_OK(pgi_renderer_render(r,
                                        &(pgi_render_desc){.width = 48,
                                                           .height = 32,
                                                           .photons = 5000,
                                                           .seed = 3,
                                                           .threads = 2,
                                                           .output = PGI_OUTPUT_DIRECT},
                                        &img, NULL));
        mean[i] = image_mean(&img);
        pgi_image_free(&img);
        pgi_renderer_destroy(r);
        pgi_scene_destroy(s);
    }
    fprintf(stderr, "  emissive strength 1: mean %.6g, 20: %.6g\n", mean[0], mean[1]);
    assert_true(mean[0] > 0.0);
    assert_true(fabs(mean[1] / mean[0] - 20.0) < 20.0 * 1e-4);
}

/* Spot and directional lights: units 1:1, directions down their nodes' -z, the spot's smooth
 * falloff as the hard cone of the same power and on-axis intensity. */
static void test_gltf_spot_and_sun(void **state) {
    (void)state;
    char p[700];
    const char *lights = "\"extensions\": {\"KHR_lights_punctual\": {\"lights\": [\n"
                         "   {\"type\": \"point\", \"color\": [1, 0.5, 0.25], \"intensity\": 20},\n"
                         "   {\"type\": \"spot\", \"intensity\": 3, \"spot\": {\"innerConeAngle\": 0.2, "
                         "\"outerConeAngle\": 0.5}},\n"
                         "   {\"type\": \"directional\", \"color\": [0.5, 1, 1], \"intensity\": 4, \"range\": 9}]}},";
    pgi_scene *s;
    {
        char base[700];
        put_room_gltf("lights.gltf", k_grey_gltf_mat, "", base, sizeof base);
        char *text = NULL;
        FILE *f = fopen(base, "rb");
        assert_non_null(f);
        fseek(f, 0, SEEK_END);
        long n = ftell(f);
        rewind(f);
        text = calloc((size_t)n + 1, 1);
        assert_true(fread(text, 1, (size_t)n, f) == (size_t)n);
        fclose(f);
        char *t1 = replace(text,
                           "\"extensions\": {\"KHR_lights_punctual\": {\"lights\": [\n"
                           "   {\"type\": \"point\", \"color\": [1, 0.5, 0.25], \"intensity\": 20}]}},",
                           lights);
        /* the lamp node becomes the spot; a sun node turned 90 degrees about x (-z -> -y) */
        char *t2 = replace(t1, "{\"light\": 0}}}]",
                           "{\"light\": 1}}}, {\"rotation\": [-0.70710678, 0, 0, 0.70710678], "
                           "\"extensions\": {\"KHR_lights_punctual\": {\"light\": 2}}}]");
        char *t3 = replace(t2, "\"nodes\": [0, 1, 2]", "\"nodes\": [0, 1, 2, 4]");
        s = load_ok(put("lights.gltf", t3, p, sizeof p));
        free(text);
        free(t1);
        free(t2);
        free(t3);
    }
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_int_equal(in.spot_lights, 1);
    assert_int_equal(in.sun_lights, 1);
    assert_int_equal(in.point_lights, 0);
    const pgi__light *spot = NULL, *sun = NULL;
    for (size_t i = 0; i < s->nlights; i++) {
        if (s->lights[i].type == PGI__LIGHT_SPOT) spot = &s->lights[i];
        if (s->lights[i].type == PGI__LIGHT_SUN) sun = &s->lights[i];
    }
    assert_non_null(spot);
    assert_non_null(sun);
    assert_true(spot->color[0] == 3.f && spot->color[1] == 3.f && spot->color[2] == 3.f);
    assert_true(fabsf(spot->pos[1] - 2.f) < 1e-6f && fabsf(spot->dir[2] + 1.f) < 1e-6f);
    const double want = (2.0 * cos(0.2) + cos(0.5)) / 3.0;
    assert_true(fabs((double)spot->cos_cutoff - want) < 1e-6);
    /* the power of glTF's falloff, 2 pi [(1 - cos_i) + (cos_i - cos_o) / 3], and of the cone */
    const double glTF_power = 2.0 * 3.14159265358979323846 * 3.0 * ((1.0 - cos(0.2)) + (cos(0.2) - cos(0.5)) / 3.0);
    assert_true(fabs((double)spot->power[0] - glTF_power) < 1e-4 * glTF_power);
    assert_true(sun->color[0] == 2.f && sun->color[1] == 4.f && sun->color[2] == 4.f); /* lux -> W/m^2, 1:1 */
    assert_true(fabsf(sun->dir[1] + 1.f) < 1e-5f && fabsf(sun->dir[0]) < 1e-5f && fabsf(sun->dir[2]) < 1e-5f);
    assert_non_null(strstr(in.warnings, "lights.gltf: not used: 1 light range"));
    pgi_scene_destroy(s);
}

/* Cameras of other formats come through Assimp: a Collada camera node, placed by its node and named
 * by it. Assimp stores Collada's xfov, the whole horizontal angle (its header says half), and the
 * aspect ratio: fov_y = 2 atan(tan(xfov / 2) / aspect). */
static void test_collada_camera(void **state) {
    (void)state;
    char p[700], j[700];
    put("cam.dae",
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
        "<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">\n"
        " <asset><unit name=\"meter\" meter=\"1\"/><up_axis>Y_UP</up_axis></asset>\n"
        " <library_cameras><camera id=\"c\" name=\"C\"><optics><technique_common><perspective><xfov>60</xfov>"
        "<aspect_ratio>1.5</aspect_ratio><znear>0.1</znear><zfar>100</zfar></perspective></technique_common>"
        "</optics></camera></library_cameras>\n"
        " <library_geometries><geometry id=\"tri\" name=\"tri\"><mesh>\n"
        "  <source id=\"p\"><float_array id=\"pa\" count=\"9\">0 0 0 1 0 0 0 1 0</float_array><technique_common>"
        "<accessor source=\"#pa\" count=\"3\" stride=\"3\"><param name=\"X\" type=\"float\"/><param name=\"Y\" "
        "type=\"float\"/><param name=\"Z\" type=\"float\"/></accessor></technique_common></source>\n"
        "  <vertices id=\"v\"><input semantic=\"POSITION\" source=\"#p\"/></vertices>\n"
        "  <triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>0 1 2</p></triangles>\n"
        " </mesh></geometry></library_geometries>\n"
        " <library_visual_scenes><visual_scene id=\"S\" name=\"S\">\n"
        "  <node id=\"tri-node\" name=\"tri\"><instance_geometry url=\"#tri\"/></node>\n"
        "  <node id=\"CamNode\" name=\"CamNode\"><translate>0 1.5 4</translate><rotate>1 0 0 -15</rotate>"
        "<instance_camera url=\"#c\"/></node>\n"
        " </visual_scene></library_visual_scenes>\n"
        " <scene><instance_visual_scene url=\"#S\"/></scene>\n"
        "</COLLADA>\n",
        p, sizeof p);
    put("cam.json",
        "{\"mesh\": \"cam.dae\", \"lights\": [{\"type\": \"point\", \"position\": [0, 1, 1], "
        "\"intensity\": [1, 1, 1]}]}",
        j, sizeof j);
    pgi_scene *s = load_ok(j);
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_int_equal(in.cameras, 1);
    assert_string_equal(pgi_scene_camera_name(s, 0), "CamNode");
    pgi_camera_def c;
    TU_CHECK_OK(pgi_scene_get_camera(s, 0, &c));
    const float s15 = sinf(15.f * 3.14159265f / 180.f), c15 = cosf(15.f * 3.14159265f / 180.f);
    const float eye[3] = {0.f, 1.5f, 4.f}, fwd[3] = {0.f, -s15, -c15};
    for (int k = 0; k < 3; k++) {
        assert_true(fabsf(c.eye[k] - eye[k]) < 1e-5f);
        assert_true(fabsf(c.look_at[k] - c.eye[k] - fwd[k]) < 1e-5f);
    }
    const double want = 2.0 * atan(tan(30.0 * 3.14159265358979323846 / 180.0) / 1.5) * 180.0 / 3.14159265358979323846;
    fprintf(stderr, "  Collada camera: fov_y %.6g (want %.6g)\n", (double)c.fov_y_deg, want);
    assert_true(fabs((double)c.fov_y_deg - want) < 1e-3);
    pgi_scene_destroy(s);
}

/* --camera NAME: a glTF camera node's name, a description's camera "name", an index; an unknown
 * name lists the cameras there are. */
static void test_camera_names(void **state) {
    (void)state;
    char p[700], j[700];
    put_room_gltf("room.gltf", k_grey_gltf_mat, "", p, sizeof p);
    put("named.json",
        "{\"mesh\": \"room.gltf\", \"cameras\": [{\"eye\": [0, 1, 5], \"look_at\": [0, 1, 0], \"name\": \"front\"},\n"
        "  {\"eye\": [3, 1, 3], \"look_at\": [0, 1, 0]}]}\n",
        j, sizeof j);
    pgi_scene *s = load_ok(j);
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_int_equal(in.cameras, 3); /* the description's two, then the file's */
    assert_int_equal(in.point_lights, 1);
    size_t i = 99;
    TU_CHECK_OK(pgi_scene_find_camera(s, "front", &i));
    assert_int_equal(i, 0);
    TU_CHECK_OK(pgi_scene_find_camera(s, "Cam", &i));
    assert_int_equal(i, 2);
    TU_CHECK_OK(pgi_scene_find_camera(s, "1", &i));
    assert_int_equal(i, 1);
    assert_string_equal(pgi_scene_camera_name(s, 1), "");
    assert_int_equal(pgi_scene_find_camera(s, "3", &i), PGI_ERR_INVALID_ARG);
    assert_int_equal(pgi_scene_find_camera(s, "back", &i), PGI_ERR_INVALID_ARG);
    const char *msg = pgi_last_error();
    fprintf(stderr, "  %s\n", msg);
    assert_non_null(strstr(msg, "'back'"));
    assert_non_null(strstr(msg, "0 'front', 1 (unnamed), 2 'Cam'"));
    pgi_scene_destroy(s);
    /* a name that looks like an index is refused (--camera 2 is camera 2) */
    put("badname.json",
        "{\"mesh\": \"room.gltf\", \"camera\": {\"eye\": [0, 1, 5], \"look_at\": [0, 1, 0], \"name\": \"2nd\"}}", j,
        sizeof j);
    expect_error(j, PGI_ERR_PARSE, PGI_ERR_PARSE, "camera.name");
}

/* One warning line names what a file holds that is not used, or not found: a missing material
 * library, glTF animations, extensions; nothing for a file that uses it all (a PLY's vertex
 * colours are used: test_vertex_colours_*). */
static void test_load_warnings(void **state) {
    (void)state;
    char p[700], m[700];
    put("lamp.mtl", k_mtl_light, m, sizeof m);
    put("nomtl.obj", "mtllib lamp.mtl\nmtllib gone.mtl\nusemtl lamp\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", p,
        sizeof p);
    pgi_scene *s = load_ok(p);
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    fprintf(stderr, "  %s\n", in.warnings);
    assert_non_null(strstr(in.warnings, "nomtl.obj: not found: material library gone.mtl"));
    assert_null(strchr(in.warnings, '\n'));
    pgi_scene_destroy(s);
    put("withmtl.obj", "mtllib lamp.mtl\nusemtl lamp\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", p, sizeof p);
    s = load_ok(p);
    pgi_scene_get_info(s, &in);
    assert_string_equal(in.warnings, "");
    pgi_scene_destroy(s);
    /* a PLY's vertex colours are used: nothing to name */
    put("col.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n",
        p, sizeof p);
    char j[700];
    put("col.json",
        "{\"mesh\": \"col.ply\", \"lights\": [{\"type\": \"point\", \"position\": [0, 0, 1], "
        "\"intensity\": [1, 1, 1]}]}",
        j, sizeof j);
    s = load_ok(j);
    pgi_scene_get_info(s, &in);
    fprintf(stderr, "  %s\n", in.warnings);
    assert_string_equal(in.warnings, "");
    assert_non_null(s->col);
    pgi_scene_destroy(s);
    /* glTF: an extension, a metallic material */
    put_room_gltf("ext.gltf",
                  "{\"pbrMetallicRoughness\": {\"metallicFactor\": 1}, \"extensions\": {\"KHR_materials_clearcoat\": "
                  "{}}}",
                  "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_clearcoat\"], \"animations\": [],", p,
                  sizeof p);
    s = load_ok(p);
    pgi_scene_get_info(s, &in);
    fprintf(stderr, "  %s\n", in.warnings);
    assert_non_null(
        strstr(in.warnings, "ext.gltf: not used: 1 metallic material (drawn as diffuse), KHR_materials_clearcoat"));
    pgi_scene_destroy(s);
}

static void test_gltf_structure(void **state) {
    (void)state;
    /* 4 positions, 6 u16 indices, 2 key times, 2 VEC3 key values: 132 bytes */
    unsigned char bin[132] = {0};
    const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, times[2] = {0, 1};
    const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    memcpy(bin, pos, 48);
    memcpy(bin + 48, idx, 12);
    memcpy(bin + 60, times, 8);
    char p[700], json[4096];
    snprintf(p, sizeof p, "%s/q.bin", g_dir);
    write_bytes(p, bin, sizeof bin, NULL, 0);
    const char *base =
        "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}], \"nodes\": [{\"mesh\": "
        "0}],\n"
        " \"materials\": [{\"emissiveFactor\": [1, 1, 1]}],\n"
        " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1, \"material\": 0}]}],\n"
        " \"animations\": [{\"samplers\": [{\"input\": 2, \"output\": 3, \"interpolation\": \"LINEAR\"}],\n"
        "   \"channels\": [{\"sampler\": 0, \"target\": {\"node\": 0, \"path\": \"translation\"}}]}],\n"
        " \"buffers\": [{\"uri\": \"q.bin\", \"byteLength\": 132}],\n"
        " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": 48}, {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": "
        "12},\n"
        "   {\"buffer\": 0, \"byteOffset\": 60, \"byteLength\": 72}],\n"
        " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\",\n"
        "   \"min\": [0, 0, 0], \"max\": [1, 1, 0]},\n"
        "   {\"bufferView\": 1, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"},\n"
        "   {\"bufferView\": 2, \"componentType\": 5126, \"count\": 2, \"type\": \"SCALAR\", \"min\": [0], \"max\": "
        "[1]},\n"
        "   {\"bufferView\": 2, \"byteOffset\": 8, \"componentType\": 5126, \"count\": 2, \"type\": \"VEC3\"}]}\n";
    pgi_scene *s = load_ok(put("q.gltf", base, p, sizeof p));
    assert_int_equal(s->ntris, 2);
    pgi_scene_destroy(s);

    static const struct {
        const char *from, *to, *needle;
    } k[] = {
        {"\"type\": \"VEC3\",\n", "\"type\": \"VEC3\", \"sparse\": {\"count\": 1, \"values\": {\"bufferView\": 0}},\n",
         "accessor 0: sparse has no \"indices\" object"},
        {"\"count\": 4", "\"count\": 5",
         "accessor 0: 5 elements of 12 bytes from byte 0 need 60 bytes, buffer view 0 has 48"},
        {"\"count\": 4", "\"count\": 3", "mesh 0 primitive 0: index 3 of accessor 1 is past its 3 vertices"},
        {"\"indices\": 1,", "\"indices\": 1, \"mode\": 5,", NULL},
        {"{\"bufferView\": 1, ", "{", "accessor 1 has neither a bufferView nor a sparse part"},
        {"\"scene\": 0,", "\"scene\": 0, \"skins\": [{\"joints\": [0]}],", "skin 0 has no \"inverseBindMatrices\""},
        {"\"LINEAR\"", "\"CUBICSPLINE\"", "animation 0 sampler 0: 2 outputs for 2 inputs (CUBICSPLINE: three each)"},
        {"\"sampler\": 0,", "\"sampler\": 1,", "animation 0 channel 0: \"sampler\" is not one of its 1 samplers"},
        {"{\"POSITION\": 0}", "{\"POSITION\": 0, \"NORMAL\": 3}", "attribute NORMAL: 2 elements, POSITION has 4"},
        {"{\"POSITION\": 0}", "{\"POSITION\": 0, \"TEXCOORD_0\": 1}",
         "attribute TEXCOORD_0: accessor 1 (SCALAR of 5123)"},
    };
    for (size_t i = 0; i < sizeof k / sizeof k[0]; i++) {
        char *text = replace(base, k[i].from, k[i].to);
        if (!k[i].needle) { /* a strip of 2: the indices' count */
            char *t2 = replace(text, "\"count\": 6", "\"count\": 2");
            free(text);
            text = t2;
        }
        put("bad.gltf", text, p, sizeof p);
        expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE,
                     k[i].needle ? k[i].needle : "2 vertices, mode 5 needs at least 3");
        free(text);
    }

    /* Not glTF 2.0: refused, never handed to whichever Assimp importer claims the bytes. */
    expect_error(put("junk.gltf", "A{\001headrindexarray", p, sizeof p), PGI_ERR_PARSE, PGI_ERR_PARSE,
                 "junk.gltf: not glTF: its JSON does not parse");
    expect_error(put("v1.gltf", "{\"asset\": {\"version\": \"1.0\"}}", p, sizeof p), PGI_ERR_UNSUPPORTED,
                 PGI_ERR_UNSUPPORTED, "v1.gltf: not a glTF 2.0 file");
    expect_error(put("more.gltf", "{\"asset\": {\"version\": \"2.0\"}} {}", p, sizeof p), PGI_ERR_PARSE, PGI_ERR_PARSE,
                 "more.gltf: not glTF: more follows its JSON (byte 30)");

    /* The same buffer as a base64 data: URI, then as a GLB's BIN chunk: the index past the
     * vertices is found there too. */
    static const char b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char uri[256] = "data:application/octet-stream;base64,";
    size_t n = strlen(uri);
    for (size_t i = 0; i < sizeof bin; i += 3) {
        const uint32_t q = (uint32_t)bin[i] << 16 | (uint32_t)bin[i + 1] << 8 | bin[i + 2];
        for (int j = 3; j >= 0; j--) uri[n++] = b64[q >> (6 * j) & 63];
    }
    uri[n] = 0;
    char *data = replace(base, "q.bin", uri);
    TU_CHECK_OK(pgi_scene_load(put("data.gltf", data, p, sizeof p), &s));
    pgi_scene_destroy(s);
    char *bad = replace(data, "\"count\": 4", "\"count\": 3");
    expect_error(put("data-bad.gltf", bad, p, sizeof p), PGI_ERR_PARSE, PGI_ERR_PARSE, "index 3 of accessor 1");
    free(bad);
    free(data);
    for (int broken = 0; broken < 2; broken++) {
        char *glb = replace(base, "\"uri\": \"q.bin\", ", "");
        if (broken) {
            char *t = replace(glb, "\"count\": 4", "\"count\": 3");
            free(glb);
            glb = t;
        }
        snprintf(json, sizeof json, "%s", glb);
        free(glb);
        while (strlen(json) % 4) strcat(json, " ");
        const uint32_t jn = (uint32_t)strlen(json);
        unsigned char head[4096];
        const uint32_t total = 12 + 8 + jn + 8 + (uint32_t)sizeof bin;
        const uint32_t words[5] = {0x46546C67u, 2, total, jn, 0x4E4F534Au}; /* "glTF", 2, total, n, "JSON" */
        memcpy(head, words, 20);
        memcpy(head + 20, json, jn);
        const uint32_t bh[2] = {(uint32_t)sizeof bin, 0x004E4942u}; /* n, "BIN\0" */
        memcpy(head + 20 + jn, bh, 8);
        snprintf(p, sizeof p, "%s/q%d.glb", g_dir, broken);
        write_bytes(p, head, 28 + jn, bin, sizeof bin);
        if (!broken) {
            TU_CHECK_OK(pgi_scene_load(p, &s));
            assert_int_equal(s->ntris, 2);
            pgi_scene_destroy(s);
        } else {
            expect_error(p, PGI_ERR_PARSE, PGI_ERR_PARSE, "index 3 of accessor 1 is past its 3 vertices");
        }
    }
}

/* ------------------------------------------------ vertex colours */

/* The room of k_room_pos / k_room_idx (floor: vertices 0-3, back wall: 4-7) with vertex normals, as
 * an ASCII PLY whose vertices carry 8-bit colours (the floor's `fl`, the wall's `wa`). */
static const char *put_room_ply(const char *name, const int fl[3], const int wa[3], char *buf, size_t n) {
    char text[2048];
    size_t k = (size_t)snprintf(text, sizeof text,
                                "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                                "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                                "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 4\n"
                                "property list uchar int vertex_indices\nend_header\n");
    for (int v = 0; v < 8; v++) {
        const int *c = v < 4 ? fl : wa;
        k += (size_t)snprintf(text + k, sizeof text - k, "%g %g %g %d %d %d %d %d %d\n", (double)k_room_pos[3 * v],
                              (double)k_room_pos[3 * v + 1], (double)k_room_pos[3 * v + 2], 0, v < 4, v >= 4, c[0],
                              c[1], c[2]);
    }
    for (int t = 0; t < 4; t++)
        k += (size_t)snprintf(text + k, sizeof text - k, "3 %d %d %d\n", k_room_idx[3 * t], k_room_idx[3 * t + 1],
                              k_room_idx[3 * t + 2]);
    return put(name, text, buf, n);
}

/* The same room as an OBJ with the same normals and materials of colour `fl` (floor) and `wa` (wall). */
static const char *put_room_obj(const char *name, const char *fl, const char *wa, char *buf, size_t n) {
    char mtl[700], text[2048];
    snprintf(text, sizeof text, "newmtl floor\nKd %s\nnewmtl wall\nKd %s\n", fl, wa);
    put("room_rw.mtl", text, mtl, sizeof mtl);
    size_t k = (size_t)snprintf(text, sizeof text, "mtllib room_rw.mtl\n");
    for (int v = 0; v < 8; v++)
        k += (size_t)snprintf(text + k, sizeof text - k, "v %g %g %g\n", (double)k_room_pos[3 * v],
                              (double)k_room_pos[3 * v + 1], (double)k_room_pos[3 * v + 2]);
    k += (size_t)snprintf(text + k, sizeof text - k, "vn 0 1 0\nvn 0 0 1\n");
    for (int t = 0; t < 4; t++) {
        if (t == 0 || t == 2) k += (size_t)snprintf(text + k, sizeof text - k, "usemtl %s\n", t ? "wall" : "floor");
        k += (size_t)snprintf(text + k, sizeof text - k, "f %d//%d %d//%d %d//%d\n", k_room_idx[3 * t] + 1, 1 + t / 2,
                              k_room_idx[3 * t + 1] + 1, 1 + t / 2, k_room_idx[3 * t + 2] + 1, 1 + t / 2);
    }
    return put(name, text, buf, n);
}

/* A description around a room mesh: a camera seeing the floor and the wall, a point light. */
static const char *room_desc(const char *name, const char *mesh, char *buf, size_t n) {
    char text[1024];
    snprintf(text, sizeof text,
             "{\"mesh\": \"%s\", \"camera\": {\"eye\": [0, 1.5, 4], \"look_at\": [0, 0.6, -1], \"fov_y\": 55},\n"
             " \"lights\": [{\"type\": \"point\", \"position\": [0.5, 2, 0.5], \"intensity\": [20, 20, 20]}]}\n",
             mesh);
    return put(name, text, buf, n);
}

#define VC_W 64
#define VC_H 48

/* A frame of s (VC_W x VC_H, 20000 photons) and its albedo AOV (3 floats a pixel, caller's). */
static void render_vc(pgi_scene *s, pgi_image *img, float *albedo) {
    pgi_renderer *r = tu_renderer(s);
    pgi_aovs a = {.albedo = albedo};
    pgi_frame_stats st;
    TU_CHECK_OK(pgi_renderer_render(r,
                                    &(pgi_render_desc){.width = VC_W,
                                                       .height = VC_H,
                                                       .photons = 20000,
                                                       .seed = 3,
                                                       .threads = 2,
                                                       .aovs = &a},
                                    img, &st));
    pgi_renderer_destroy(r);
}

/* Pixels whose albedo is within 1e-6 of `want` (each channel); (0, 0, 0): those that see no surface. */
static size_t albedo_pixels(const float *albedo, const float want[3]) {
    size_t n = 0;
    for (size_t i = 0; i < (size_t)VC_W * VC_H; i++)
        n += fabsf(albedo[3 * i] - want[0]) <= 1e-6f && fabsf(albedo[3 * i + 1] - want[1]) <= 1e-6f &&
             fabsf(albedo[3 * i + 2] - want[2]) <= 1e-6f;
    return n;
}

/* Two renders of what should be one picture: the frames (every float within 1e-4 relative) and
 * path-traced references (within 1e-4) agree, and the albedos do to 1e-6. */
static void expect_same_room(pgi_scene *a, pgi_scene *b, const char *what) {
    const size_t n = (size_t)VC_W * VC_H;
    float *aa = calloc(3 * n, sizeof(float)), *ab = calloc(3 * n, sizeof(float));
    assert_non_null(aa);
    assert_non_null(ab);
    pgi_image ia = {0}, ib = {0};
    render_vc(a, &ia, aa);
    render_vc(b, &ib, ab);
    pgi_metrics mt;
    TU_CHECK_OK(pgi_metrics_compute(&ia, &ib, 1.f, &mt));
    const double mean = image_mean(&ib);
    fprintf(stderr, "  %s: frame mean %.6g vs %.6g, PSNR %.2f dB\n", what, image_mean(&ia), mean, mt.psnr);
    assert_true(mean > 0.01);
    assert_int_equal(tu_compare(ia.rgb, ib.rgb, 3 * n, 1e-4, what), 0);
    assert_int_equal(tu_compare(aa, ab, 3 * n, 1e-6, what), 0);
    pgi_image_free(&ia);
    pgi_image_free(&ib);
    const pgi_reference_desc d = {.width = VC_W, .height = VC_H, .spp = 4, .seed = 3, .threads = 2};
    uint64_t spp = 0;
    TU_CHECK_OK(pgi_reference_render(a, &d, &ia, &spp));
    spp = 0;
    TU_CHECK_OK(pgi_reference_render(b, &d, &ib, &spp));
    TU_CHECK_OK(pgi_metrics_compute(&ia, &ib, 1.f, &mt));
    fprintf(stderr, "  %s: reference mean %.6g vs %.6g, PSNR %.2f dB\n", what, image_mean(&ia), image_mean(&ib),
            mt.psnr);
    assert_int_equal(tu_compare(ia.rgb, ib.rgb, 3 * n, 1e-4, what), 0);
    pgi_image_free(&ia);
    pgi_image_free(&ib);
    free(aa);
    free(ab);
}

/* A PLY's 8-bit vertex colours are its base colour: a room whose floor's vertices are all red
 * (255, 0, 0) and wall's white renders as the same room with a red and a white material (an OBJ):
 * the frame (the view samples, the photons' colour bleeding onto the wall) and the path-traced
 * reference; nothing is named as unused. */
static void test_vertex_colours_ply(void **state) {
    (void)state;
    char p[700], o[700], jp[700], jo[700];
    const int red[3] = {255, 0, 0}, white[3] = {255, 255, 255};
    pgi_scene *sp = load_ok(room_desc("vc_ply.json", put_room_ply("vc.ply", red, white, p, sizeof p), jp, sizeof jp));
    pgi_scene *so =
        load_ok(room_desc("vc_obj.json", put_room_obj("vc.obj", "1 0 0", "1 1 1", o, sizeof o), jo, sizeof jo));
    pgi_scene_info in;
    pgi_scene_get_info(sp, &in);
    assert_string_equal(in.warnings, "");
    assert_non_null(sp->col);
    assert_null(so->col);
    for (size_t v = 0; v < sp->nverts; v++) {
        const float *c = sp->col + 3 * v;
        assert_true((c[0] == 1.f && c[1] == 0.f && c[2] == 0.f) || (c[0] == 1.f && c[1] == 1.f && c[2] == 1.f));
    }
    /* PLY has no materials: the one Assimp makes up is white here (grey 0.6 without colours) */
    assert_int_equal(sp->nmats, 1);
    assert_true(sp->mats[0].kd[0] == 1.f && sp->mats[0].kd[1] == 1.f && sp->mats[0].kd[2] == 1.f);
    expect_same_room(sp, so, "PLY red vertices vs OBJ red material");
    /* and the albedo is the colour: red on the floor, white on the wall */
    const size_t n = (size_t)VC_W * VC_H;
    float *al = calloc(3 * n, sizeof(float));
    assert_non_null(al);
    pgi_image im = {0};
    render_vc(sp, &im, al);
    const float r1[3] = {1.f, 0.f, 0.f}, w1[3] = {1.f, 1.f, 1.f}, none[3] = {0.f, 0.f, 0.f};
    const size_t nr = albedo_pixels(al, r1), nw = albedo_pixels(al, w1), n0 = albedo_pixels(al, none);
    fprintf(stderr, "  PLY room: %zu red, %zu white and %zu empty pixels of %zu\n", nr, nw, n0, n);
    assert_true(nr > n / 8 && nw > n / 8 && nr + nw + n0 == n);
    pgi_image_free(&im);
    free(al);
    pgi_scene_destroy(sp);
    pgi_scene_destroy(so);
}

/* The colours' space: a PLY's 8-bit colours and an OBJ's `v x y z r g b` are sRGB-encoded (decoded
 * as an 8-bit texture's texels are), and the albedo of a vertex-coloured surface is that linear
 * colour times its material's; without colours the made-up material stays grey 0.6. */
static void test_vertex_colours_srgb(void **state) {
    (void)state;
    char p[700], j[700];
    const int c8[3] = {200, 100, 50}, white[3] = {255, 255, 255};
    pgi_scene *s = load_ok(room_desc("vcs.json", put_room_ply("vcs.ply", c8, white, p, sizeof p), j, sizeof j));
    const size_t n = (size_t)VC_W * VC_H;
    float *al = calloc(3 * n, sizeof(float));
    assert_non_null(al);
    pgi_image im = {0};
    render_vc(s, &im, al);
    const float lin[3] = {pgi__srgb8_texture_lut[200], pgi__srgb8_texture_lut[100], pgi__srgb8_texture_lut[50]};
    size_t nf = albedo_pixels(al, lin);
    fprintf(stderr, "  PLY (200, 100, 50): albedo %.6g %.6g %.6g at %zu pixels\n", (double)lin[0], (double)lin[1],
            (double)lin[2], nf);
    assert_true(nf > n / 8);
    assert_true(fabsf(lin[0] - 0.5775804f) < 1e-6f); /* not 200 / 255 = 0.784 */
    pgi_image_free(&im);
    pgi_scene_destroy(s);

    /* an OBJ's vertex colours (Assimp reads `v x y z r g b`), on faces without a material */
    char text[1024];
    size_t k = 0;
    for (int v = 0; v < 8; v++)
        k += (size_t)snprintf(text + k, sizeof text - k, "v %g %g %g %s\n", (double)k_room_pos[3 * v],
                              (double)k_room_pos[3 * v + 1], (double)k_room_pos[3 * v + 2],
                              v < 4 ? "0.5 0.25 1" : "1 1 1");
    for (int t = 0; t < 4; t++)
        k += (size_t)snprintf(text + k, sizeof text - k, "f %d %d %d\n", k_room_idx[3 * t] + 1,
                              k_room_idx[3 * t + 1] + 1, k_room_idx[3 * t + 2] + 1);
    put("vcs.obj", text, p, sizeof p);
    s = load_ok(room_desc("vcs_obj.json", p, j, sizeof j));
    pgi_scene_info in;
    pgi_scene_get_info(s, &in);
    assert_string_equal(in.warnings, "");
    render_vc(s, &im, al);
    const float want[3] = {(float)pgi__srgb_to_linear(0.5), (float)pgi__srgb_to_linear(0.25), 1.f};
    nf = albedo_pixels(al, want);
    fprintf(stderr, "  OBJ (0.5, 0.25, 1): albedo %.6g %.6g %.6g at %zu pixels\n", (double)want[0], (double)want[1],
            (double)want[2], nf);
    assert_true(nf > n / 8);
    pgi_image_free(&im);
    pgi_scene_destroy(s);

    /* the same PLY without colours: grey 0.6 everywhere (as before) */
    k = (size_t)snprintf(text, sizeof text,
                         "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n");
    for (int v = 0; v < 8; v++)
        k += (size_t)snprintf(text + k, sizeof text - k, "%g %g %g\n", (double)k_room_pos[3 * v],
                              (double)k_room_pos[3 * v + 1], (double)k_room_pos[3 * v + 2]);
    for (int t = 0; t < 4; t++)
        k += (size_t)snprintf(text + k, sizeof text - k, "3 %d %d %d\n", k_room_idx[3 * t], k_room_idx[3 * t + 1],
                              k_room_idx[3 * t + 2]);
    put("vcn.ply", text, p, sizeof p);
    s = load_ok(room_desc("vcn.json", p, j, sizeof j));
    assert_null(s->col);
    render_vc(s, &im, al);
    const float grey[3] = {0.6f, 0.6f, 0.6f}, none[3] = {0.f, 0.f, 0.f};
    const size_t ng = albedo_pixels(al, grey);
    assert_true(ng > n / 4);
    assert_int_equal(ng + albedo_pixels(al, none), n);
    pgi_image_free(&im);
    pgi_scene_destroy(s);
    free(al);
}

/* The room as a glTF (no normals: flat) in `prims` primitives over one buffer: positions, COLOR_0
 * as float RGB (floor red, wall white), COLOR_0 as normalised RGBA bytes (floor (128, 64, 255),
 * wall white), the indices; accessors 0 positions, 1 float colours, 2 byte colours, 3 all
 * indices, 4 the floor's, 5 the wall's. `prims` and `mats` are the JSON of the primitives and
 * materials. */
static const char *put_room_gltf_vc(const char *name, const char *prims, const char *mats, char *buf, size_t n) {
    unsigned char bin[248];
    memcpy(bin, k_room_pos, 96);
    for (int v = 0; v < 8; v++) {
        const float c[3] = {1.f, v < 4 ? 0.f : 1.f, v < 4 ? 0.f : 1.f};
        memcpy(bin + 96 + 12 * v, c, 12);
        const unsigned char b[4] = {v < 4 ? 128 : 255, v < 4 ? 64 : 255, 255, 255};
        memcpy(bin + 192 + 4 * v, b, 4);
    }
    memcpy(bin + 224, k_room_idx, 24);
    char path[700];
    snprintf(path, sizeof path, "%s/vc_room.bin", g_dir);
    write_bytes(path, bin, sizeof bin, NULL, 0);
    char text[4096];
    snprintf(text, sizeof text,
             "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],\n"
             " \"nodes\": [{\"mesh\": 0}], \"materials\": [%s],\n"
             " \"meshes\": [{\"primitives\": [%s]}],\n"
             " \"buffers\": [{\"uri\": \"vc_room.bin\", \"byteLength\": 248}],\n"
             " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": 96}, {\"buffer\": 0, \"byteOffset\": 96, "
             "\"byteLength\": 96},\n"
             "   {\"buffer\": 0, \"byteOffset\": 192, \"byteLength\": 32}, {\"buffer\": 0, \"byteOffset\": 224, "
             "\"byteLength\": 24}],\n"
             " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 8, \"type\": \"VEC3\", "
             "\"min\": [-2, 0, -2], \"max\": [2, 3, 2]},\n"
             "   {\"bufferView\": 1, \"componentType\": 5126, \"count\": 8, \"type\": \"VEC3\"},\n"
             "   {\"bufferView\": 2, \"componentType\": 5121, \"normalized\": true, \"count\": 8, \"type\": "
             "\"VEC4\"},\n"
             "   {\"bufferView\": 3, \"componentType\": 5123, \"count\": 12, \"type\": \"SCALAR\"},\n"
             "   {\"bufferView\": 3, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"},\n"
             "   {\"bufferView\": 3, \"byteOffset\": 12, \"componentType\": 5123, \"count\": 6, \"type\": "
             "\"SCALAR\"}]}\n",
             mats, prims);
    return put(name, text, buf, n);
}

/* A glTF's COLOR_0 multiplies the base colour and is linear (the glTF spec): float colours (floor
 * red, wall white) on a white material render as red and white materials (the floor's back
 * corners lie where the wall's bottom ones do, without normals: Assimp 5.2's JoinIdenticalVertices
 * would join them and paint the wall's bottom red, load_assimp.c); normalised bytes are not
 * decoded from sRGB (128 -> 128 / 255); a primitive without COLOR_0 beside one with it keeps its
 * material's colour; COLOR_1 is named as unused. */
static void test_vertex_colours_gltf(void **state) {
    (void)state;
    char g[700], j1[700], j2[700];
    const char *mat = "{\"pbrMetallicRoughness\": {\"baseColorFactor\": [%s, 1], \"metallicFactor\": 0}}";
    char white[160], red[160], grey[160], mats[400];
    snprintf(white, sizeof white, mat, "1, 1, 1");
    snprintf(red, sizeof red, mat, "1, 0, 0");
    snprintf(grey, sizeof grey, mat, "0.8, 0.8, 0.8");
    put_room_gltf_vc("vc_col.gltf",
                     "{\"attributes\": {\"POSITION\": 0, \"COLOR_0\": 1}, \"indices\": 3, \"material\": 0}", white, g,
                     sizeof g);
    pgi_scene *sc = load_ok(room_desc("vc_gcol.json", g, j1, sizeof j1));
    snprintf(mats, sizeof mats, "%s, %s", red, white);
    put_room_gltf_vc("vc_mat.gltf",
                     "{\"attributes\": {\"POSITION\": 0}, \"indices\": 4, \"material\": 0}, "
                     "{\"attributes\": {\"POSITION\": 0}, \"indices\": 5, \"material\": 1}",
                     mats, g, sizeof g);
    pgi_scene *sm = load_ok(room_desc("vc_gmat.json", g, j2, sizeof j2));
    pgi_scene_info in;
    pgi_scene_get_info(sc, &in);
    assert_string_equal(in.warnings, "");
    assert_non_null(sc->col);
    assert_null(sm->col);
    expect_same_room(sc, sm, "glTF COLOR_0 vs glTF materials");
    pgi_scene_destroy(sc);
    pgi_scene_destroy(sm);

    /* bytes, linear; the wall without colours keeps its grey */
    snprintf(mats, sizeof mats, "%s, %s", white, grey);
    put_room_gltf_vc("vc_mix.gltf",
                     "{\"attributes\": {\"POSITION\": 0, \"COLOR_0\": 2}, \"indices\": 4, \"material\": 0}, "
                     "{\"attributes\": {\"POSITION\": 0}, \"indices\": 5, \"material\": 1}",
                     mats, g, sizeof g);
    pgi_scene *s = load_ok(room_desc("vc_gmix.json", g, j1, sizeof j1));
    const size_t n = (size_t)VC_W * VC_H;
    float *al = calloc(3 * n, sizeof(float));
    assert_non_null(al);
    pgi_image im = {0};
    render_vc(s, &im, al);
    const float fl[3] = {128.f / 255.f, 64.f / 255.f, 1.f}, wa[3] = {0.8f, 0.8f, 0.8f}, none[3] = {0.f, 0.f, 0.f};
    const size_t nf = albedo_pixels(al, fl), nw = albedo_pixels(al, wa), n0 = albedo_pixels(al, none);
    fprintf(stderr, "  glTF bytes (128, 64, 255): %zu floor pixels, %zu grey wall pixels of %zu\n", nf, nw, n);
    assert_true(nf > n / 8 && nw > n / 8 && nf + nw + n0 == n);
    pgi_image_free(&im);
    free(al);
    pgi_scene_destroy(s);

    /* a second colour set is named */
    put_room_gltf_vc("vc_two.gltf",
                     "{\"attributes\": {\"POSITION\": 0, \"COLOR_0\": 1, \"COLOR_1\": 2}, \"indices\": 3, "
                     "\"material\": 0}",
                     white, g, sizeof g);
    s = load_ok(room_desc("vc_gtwo.json", g, j1, sizeof j1));
    pgi_scene_get_info(s, &in);
    fprintf(stderr, "  %s\n", in.warnings);
    assert_non_null(strstr(in.warnings, "not used: 1 primitive with a second vertex colour set (COLOR_1"));
    pgi_scene_destroy(s);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_missing_file),
        cmocka_unit_test(test_unknown_name),
        cmocka_unit_test(test_malformed_obj),
        cmocka_unit_test(test_obj_without_lights),
        cmocka_unit_test(test_emissive_obj_loads),
        cmocka_unit_test(test_nonfinite_vertex),
        cmocka_unit_test(test_missing_texture),
        cmocka_unit_test(test_json_errors),
        cmocka_unit_test(test_scene_numbers),
        cmocka_unit_test(test_gltf_structure),
        cmocka_unit_test(test_gltf_camera_and_light),
        cmocka_unit_test(test_gltf_emissive_strength),
        cmocka_unit_test(test_gltf_spot_and_sun),
        cmocka_unit_test(test_collada_camera),
        cmocka_unit_test(test_camera_names),
        cmocka_unit_test(test_load_warnings),
        cmocka_unit_test(test_vertex_colours_ply),
        cmocka_unit_test(test_vertex_colours_srgb),
        cmocka_unit_test(test_vertex_colours_gltf),
        cmocka_unit_test(test_builtins),
        cmocka_unit_test(test_generated_normals_obj_ply),
        cmocka_unit_test(test_generated_normals_flat),
    };
    return cmocka_run_group_tests_name("scene", tests, setup, teardown);
}
