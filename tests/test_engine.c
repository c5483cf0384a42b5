/* An engine's scene in memory (docs/api.md "Scenes from memory"): pgi_scene_create from arrays
 * against the same scene read from OBJ/MTL, per-frame vertex updates, light control, the camera
 * from view/projection matrices, AOVs against the view samples, and PGI_OUTPUT_INDIRECT without
 * shadow rays. */
#include "test_util.h"

/* ------------------------------------------------------------ a room as arrays */

#define MAXV 256
#define MAXT 128
typedef struct room {
    float pos[3 * MAXV], nrm[3 * MAXV], uv[2 * MAXV];
    uint32_t idx[3 * MAXT], mat[MAXT];
    size_t nv, nt;
} room;

/* A quad p0 p1 p2 p3 (counter-clockwise seen from its front), normal n, material m: 4 vertices of
 * its own, triangles (0, 1, 2) and (0, 2, 3). */
static void quad(room *r, const float p[4][3], const float n[3], uint32_t m) {
    static const float uvs[4][2] = {{0.f, 0.f}, {1.f, 0.f}, {1.f, 1.f}, {0.f, 1.f}};
    const uint32_t v0 = (uint32_t)r->nv;
    for (int k = 0; k < 4; k++) {
        memcpy(r->pos + 3 * r->nv, p[k], 3 * sizeof(float));
        memcpy(r->nrm + 3 * r->nv, n, 3 * sizeof(float));
        memcpy(r->uv + 2 * r->nv, uvs[k], 2 * sizeof(float));
        r->nv++;
    }
    const uint32_t t[6] = {v0, v0 + 1, v0 + 2, v0, v0 + 2, v0 + 3};
    for (int k = 0; k < 2; k++) {
        memcpy(r->idx + 3 * r->nt, t + 3 * k, 3 * sizeof(uint32_t));
        r->mat[r->nt++] = m;
    }
}

/* An axis-aligned box [lo, hi], faces outwards. */
static void box(room *r, const float lo[3], const float hi[3], uint32_t m) {
    const float x0 = lo[0], y0 = lo[1], z0 = lo[2], x1 = hi[0], y1 = hi[1], z1 = hi[2];
    quad(r, (const float[4][3]){{x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1}}, (const float[3]){0, 0, 1}, m);
    quad(r, (const float[4][3]){{x1, y0, z0}, {x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0}}, (const float[3]){0, 0, -1}, m);
    quad(r, (const float[4][3]){{x1, y0, z1}, {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1}}, (const float[3]){1, 0, 0}, m);
    quad(r, (const float[4][3]){{x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0}}, (const float[3]){-1, 0, 0}, m);
    quad(r, (const float[4][3]){{x0, y1, z1}, {x1, y1, z1}, {x1, y1, z0}, {x0, y1, z0}}, (const float[3]){0, 1, 0}, m);
    quad(r, (const float[4][3]){{x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1}}, (const float[3]){0, -1, 0}, m);
}

/* Materials in the order of the MTL below (numbers exact in binary, as any parser reads them). */
enum { M_WHITE, M_RED, M_FLOOR, M_GLOSSY, M_LIGHT, M_COUNT };
static const char *const k_mat_names[M_COUNT] = {"white", "red", "floor", "glossy", "light"};
static const char *const k_mtl = "newmtl white\nKd 0.75 0.75 0.75\n"
                                 "newmtl red\nKd 0.75 0.125 0.125\n"
                                 "newmtl floor\nKd 1 1 1\nmap_Kd tex.ppm\n"
                                 "newmtl glossy\nKd 0.25 0.25 0.5\nKs 0.5 0.5 0.5\nNs 50\nillum 2\n"
                                 "newmtl light\nKd 0 0 0\nKe 12 12 12\n";

static void materials(pgi_material_desc m[M_COUNT]) {
    memset(m, 0, M_COUNT * sizeof *m);
    m[M_WHITE] = (pgi_material_desc){.name = "white", .diffuse = {0.75f, 0.75f, 0.75f}};
    m[M_RED] = (pgi_material_desc){.name = "red", .diffuse = {0.75f, 0.125f, 0.125f}};
    m[M_FLOOR] = (pgi_material_desc){.name = "floor", .diffuse = {1.f, 1.f, 1.f}, .diffuse_texture = 1};
    m[M_GLOSSY] = (pgi_material_desc){.name = "glossy",
                                      .type = PGI_MATERIAL_GLOSSY,
                                      .diffuse = {0.25f, 0.25f, 0.5f},
                                      .specular = {0.5f, 0.5f, 0.5f},
                                      .shininess = 50.f};
    m[M_LIGHT] = (pgi_material_desc){.name = "light", .emission = {12.f, 12.f, 12.f}};
}

/* A 4x4 RGB checker (8-bit sRGB). */
static unsigned char g_tex[4 * 4 * 3];
static void make_texture(void) {
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++)
            for (int c = 0; c < 3; c++) g_tex[3 * (4 * y + x) + c] = (unsigned char)(((x + y) & 1) ? 230 : 40 + 60 * c);
}

/* The room, its quads grouped by material in material order (as the OBJ importer makes one mesh a
 * material). with_light: the emissive quad under the ceiling. */
static void build_room(room *r, int with_light) {
    memset(r, 0, sizeof *r);
    /* white: ceiling, back wall, right wall */
    quad(r, (const float[4][3]){{-1, 2, 1}, {1, 2, 1}, {1, 2, -1}, {-1, 2, -1}}, (const float[3]){0, -1, 0}, M_WHITE);
    quad(r, (const float[4][3]){{-1, 0, -1}, {1, 0, -1}, {1, 2, -1}, {-1, 2, -1}}, (const float[3]){0, 0, 1}, M_WHITE);
    quad(r, (const float[4][3]){{1, 0, -1}, {1, 0, 1}, {1, 2, 1}, {1, 2, -1}}, (const float[3]){-1, 0, 0}, M_WHITE);
    /* red: left wall */
    quad(r, (const float[4][3]){{-1, 0, 1}, {-1, 0, -1}, {-1, 2, -1}, {-1, 2, 1}}, (const float[3]){1, 0, 0}, M_RED);
    /* textured floor */
    quad(r, (const float[4][3]){{-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}}, (const float[3]){0, 1, 0}, M_FLOOR);
    /* a glossy block */
    box(r, (const float[3]){-0.5f, 0.f, -0.5f}, (const float[3]){0.f, 0.75f, 0.f}, M_GLOSSY);
    if (with_light)
        quad(r,
             (const float[4][3]){{-0.25f, 1.9375f, 0.25f},
                                 {0.25f, 1.9375f, 0.25f},
                                 {0.25f, 1.9375f, -0.25f},
                                 {-0.25f, 1.9375f, -0.25f}},
             (const float[3]){0, -1, 0}, M_LIGHT);
}

static const pgi_camera_def k_cam = {{0.f, 1.f, 3.5f}, {0.f, 1.f, 0.f}, {0.f, 1.f, 0.f}, 45.f};

static pgi_status create_room(const room *r, pgi_scene **s, const pgi_light_desc *lights, size_t nlights, int dynamic) {
    pgi_material_desc m[M_COUNT];
    materials(m);
    const pgi_texture_desc tex = {4, 4, 3, g_tex};
    const pgi_mesh_desc mesh = {.vertex_count = r->nv,
                                .positions = r->pos,
                                .normals = r->nrm,
                                .uvs = r->uv,
                                .triangle_count = r->nt,
                                .indices = r->idx,
                                .materials = r->mat,
                                .dynamic = dynamic};
    const pgi_scene_desc d = {.name = "room",
                              .meshes = &mesh,
                              .mesh_count = 1,
                              .materials = m,
                              .material_count = M_COUNT,
                              .textures = &tex,
                              .texture_count = 1,
                              .lights = lights,
                              .light_count = nlights,
                              .cameras = &k_cam,
                              .camera_count = 1};
    return pgi_scene_create(&d, s);
}

/* The room as OBJ + MTL + a PPM texture in the test folder; returns the OBJ's path. */
static void write_obj(const room *r, char *path, size_t n) {
    char p[700];
    snprintf(p, sizeof p, "%s/room.mtl", tu_dir);
    assert_int_equal(tu_write_file(p, k_mtl), 0);
    snprintf(p, sizeof p, "%s/tex.ppm", tu_dir);
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    fprintf(f, "P6\n4 4\n255\n");
    fwrite(g_tex, 1, sizeof g_tex, f);
    fclose(f);
    snprintf(path, n, "%s/room.obj", tu_dir);
    f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "mtllib room.mtl\no room\n");
    for (size_t v = 0; v < r->nv; v++) {
        fprintf(f, "v %.9g %.9g %.9g\n", (double)r->pos[3 * v], (double)r->pos[3 * v + 1], (double)r->pos[3 * v + 2]);
        fprintf(f, "vt %.9g %.9g\n", (double)r->uv[2 * v], (double)r->uv[2 * v + 1]);
        fprintf(f, "vn %.9g %.9g %.9g\n", (double)r->nrm[3 * v], (double)r->nrm[3 * v + 1], (double)r->nrm[3 * v + 2]);
    }
    uint32_t cur = UINT32_MAX;
    for (size_t t = 0; t < r->nt; t++) {
        if (r->mat[t] != cur) fprintf(f, "usemtl %s\n", k_mat_names[cur = r->mat[t]]);
        const uint32_t *ix = r->idx + 3 * t;
        fprintf(f, "f %u/%u/%u %u/%u/%u %u/%u/%u\n", ix[0] + 1, ix[0] + 1, ix[0] + 1, ix[1] + 1, ix[1] + 1, ix[1] + 1,
                ix[2] + 1, ix[2] + 1, ix[2] + 1);
    }
    fclose(f);
}

static pgi_render_desc small_desc(void) {
    return (pgi_render_desc){.photons = 20000,
                             .radius = 0.1f,
                             .width = 64,
                             .height = 48,
                             .threads = 2,
                             .seed = 7,
                             .view = &k_cam};
}

static void render(const pgi_scene *s, const pgi_render_desc *d, pgi_image *img, pgi_frame_stats *st) {
    pgi_status e = pgi_render(s, d, img, st);
    if (e) fprintf(stderr, "render: %s\n", pgi_last_error());
    assert_int_equal(e, PGI_OK);
}

static int same_image(const pgi_image *a, const pgi_image *b) {
    return a->width == b->width && a->height == b->height &&
           memcmp(a->rgb, b->rgb, 3 * sizeof(float) * (size_t)a->width * (size_t)a->height) == 0;
}

static double image_sum(const pgi_image *a) {
    double s = 0.0;
    for (size_t i = 0; i < 3 * (size_t)a->width * (size_t)a->height; i++) s += a->rgb[i];
    return s;
}

/* ------------------------------------------------------------ arrays = OBJ */

static void test_arrays_equal_obj(void **state) {
    (void)state;
    make_texture();
    room r;
    build_room(&r, 1);
    char obj[700];
    write_obj(&r, obj, sizeof obj);
    pgi_scene *from_file, *from_arrays;
    pgi_status st = pgi_scene_load(obj, &from_file);
    if (st) fprintf(stderr, "%s\n", pgi_last_error());
    assert_int_equal(st, PGI_OK);
    st = create_room(&r, &from_arrays, NULL, 0, 0);
    if (st) fprintf(stderr, "%s\n", pgi_last_error());
    assert_int_equal(st, PGI_OK);
    pgi_scene_info a, b;
    pgi_scene_get_info(from_file, &a);
    pgi_scene_get_info(from_arrays, &b);
    assert_int_equal(a.triangles, b.triangles);
    assert_int_equal(a.vertices, b.vertices);
    assert_int_equal(a.area_triangles, 2);
    assert_int_equal(b.area_triangles, 2);
    assert_int_equal(b.textures, 1);
    assert_int_equal(b.glossy_materials, 1);
    assert_int_equal(pgi_scene_mesh_count(from_arrays), 1);
    assert_int_equal(pgi_scene_mesh_count(from_file), 0);
    pgi_render_desc d = small_desc();
    pgi_image ia = {0}, ib = {0};
    render(from_file, &d, &ia, NULL);
    render(from_arrays, &d, &ib, NULL);
    assert_true(image_sum(&ia) > 0.0);
    assert_true(same_image(&ia, &ib));
    /* both follow pgi_scene_set_specular alike */
    assert_int_equal(pgi_scene_set_specular(from_file, PGI_SPECULAR_PHONG), PGI_OK);
    assert_int_equal(pgi_scene_set_specular(from_arrays, PGI_SPECULAR_PHONG), PGI_OK);
    render(from_file, &d, &ia, NULL);
    render(from_arrays, &d, &ib, NULL);
    assert_true(same_image(&ia, &ib));
    pgi_image_free(&ia);
    pgi_image_free(&ib);
    pgi_scene_destroy(from_file);
    pgi_scene_destroy(from_arrays);
}

/* Vertex colours (pgi_mesh_desc.colors) multiply the diffuse albedo: the room's white quads (mesh
 * 0: quads 0-2, white 0.75) coloured (1, 0.5, 0.25) beside the rest without colours (mesh 1,
 * white as far as colours go: the textured floor, the red wall, the glossy block keep their
 * colours) render as the room in one mesh whose white is (0.75, 0.375, 0.1875); and the albedo
 * AOV of a coloured quad is that product. */
static void test_arrays_colours(void **state) {
    (void)state;
    make_texture();
    room r;
    build_room(&r, 1);
    assert_int_equal(r.mat[5], M_WHITE);
    assert_int_not_equal(r.mat[6], M_WHITE);
    pgi_material_desc m[M_COUNT];
    materials(m);
    const pgi_texture_desc tex = {4, 4, 3, g_tex};
    float col[3 * 12];
    for (int v = 0; v < 12; v++) col[3 * v] = 1.f, col[3 * v + 1] = 0.5f, col[3 * v + 2] = 0.25f;
    uint32_t idx1[3 * MAXT];
    for (size_t k = 18; k < 3 * r.nt; k++) idx1[k - 18] = r.idx[k] - 12;
    const pgi_mesh_desc two[2] = {{.vertex_count = 12,
                                   .positions = r.pos,
                                   .normals = r.nrm,
                                   .uvs = r.uv,
                                   .triangle_count = 6,
                                   .indices = r.idx,
                                   .materials = r.mat,
                                   .colors = col},
                                  {.vertex_count = r.nv - 12,
                                   .positions = r.pos + 36,
                                   .normals = r.nrm + 36,
                                   .uvs = r.uv + 24,
                                   .triangle_count = r.nt - 6,
                                   .indices = idx1,
                                   .materials = r.mat + 6}};
    pgi_scene_desc d = {.meshes = two,
                        .mesh_count = 2,
                        .materials = m,
                        .material_count = M_COUNT,
                        .textures = &tex,
                        .texture_count = 1,
                        .cameras = &k_cam,
                        .camera_count = 1};
    pgi_scene *coloured = NULL, *plain = NULL;
    TU_CHECK_OK(pgi_scene_create(&d, &coloured));
    m[M_WHITE].diffuse[1] = 0.375f;
    m[M_WHITE].diffuse[2] = 0.1875f;
    const pgi_mesh_desc one = {.vertex_count = r.nv,
                               .positions = r.pos,
                               .normals = r.nrm,
                               .uvs = r.uv,
                               .triangle_count = r.nt,
                               .indices = r.idx,
                               .materials = r.mat};
    d.meshes = &one;
    d.mesh_count = 1;
    TU_CHECK_OK(pgi_scene_create(&d, &plain));
    pgi_render_desc rd = small_desc();
    const size_t n = (size_t)rd.width * (size_t)rd.height;
    float *aa = calloc(3 * n, sizeof(float)), *ab = calloc(3 * n, sizeof(float));
    assert_non_null(aa);
    assert_non_null(ab);
    pgi_aovs a = {.albedo = aa}, b = {.albedo = ab};
    pgi_image ia = {0}, ib = {0};
    rd.aovs = &a;
    render(coloured, &rd, &ia, NULL);
    rd.aovs = &b;
    render(plain, &rd, &ib, NULL);
    const double sa = image_sum(&ia), sb = image_sum(&ib);
    fprintf(stderr, "  coloured arrays %.6g, plain arrays %.6g\n", sa, sb);
    assert_true(sb > 0.0);
    assert_int_equal(tu_compare(ia.rgb, ib.rgb, 3 * n, 1e-4, "coloured vs plain"), 0);
    assert_int_equal(tu_compare(aa, ab, 3 * n, 1e-6, "coloured vs plain albedo"), 0);
    size_t seen = 0; /* pixels of the coloured quads */
    for (size_t i = 0; i < n; i++)
        seen += fabsf(aa[3 * i] - 0.75f) <= 1e-6f && fabsf(aa[3 * i + 1] - 0.375f) <= 1e-6f &&
                fabsf(aa[3 * i + 2] - 0.1875f) <= 1e-6f;
    assert_true(seen > n / 8);
    pgi_image_free(&ia);
    pgi_image_free(&ib);
    free(aa);
    free(ab);
    pgi_scene_destroy(coloured);
    pgi_scene_destroy(plain);
}

/* Bad arrays: refused with a message naming the mesh / material / texture / light. */
static void expect_refused(const pgi_scene_desc *d, pgi_status want, const char *needle) {
    pgi_scene *s = NULL;
    pgi_status st = pgi_scene_create(d, &s);
    assert_int_equal(st, want);
    assert_null(s);
    if (!strstr(pgi_last_error(), needle)) {
        fprintf(stderr, "message '%s' lacks '%s'\n", pgi_last_error(), needle);
        fail();
    }
}

static void test_create_errors(void **state) {
    (void)state;
    make_texture();
    room r;
    build_room(&r, 1);
    pgi_material_desc m[M_COUNT];
    materials(m);
    const pgi_texture_desc tex = {4, 4, 3, g_tex};
    pgi_mesh_desc mesh = {.vertex_count = r.nv,
                          .positions = r.pos,
                          .normals = r.nrm,
                          .uvs = r.uv,
                          .triangle_count = r.nt,
                          .indices = r.idx,
                          .materials = r.mat};
    pgi_scene_desc d = {.meshes = &mesh,
                        .mesh_count = 1,
                        .materials = m,
                        .material_count = M_COUNT,
                        .textures = &tex,
                        .texture_count = 1};
    pgi_scene *s;
    assert_int_equal(pgi_scene_create(&d, &s), PGI_OK);
    pgi_scene_destroy(s);

    uint32_t idx[3 * MAXT];
    memcpy(idx, r.idx, sizeof idx);
    idx[4] = 9999;
    mesh.indices = idx;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "mesh 0: triangle 1 refers to vertex 9999");
    mesh.indices = r.idx;

    float pos[3 * MAXV];
    memcpy(pos, r.pos, sizeof pos);
    pos[7] = NAN;
    mesh.positions = pos;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "mesh 0: vertex 2");
    pos[7] = 2e15f;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "coordinate range");
    mesh.positions = r.pos;

    uint32_t mat[MAXT];
    memcpy(mat, r.mat, sizeof mat);
    mat[3] = M_COUNT;
    mesh.materials = mat;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "triangle 3 has material 5 of 5");
    mesh.materials = r.mat;

    m[M_FLOOR].diffuse_texture = 2;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "material 2 ('floor')");
    m[M_FLOOR].diffuse_texture = 1;
    m[M_RED].diffuse[0] = 1.5f;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "material 1 ('red'): diffuse");
    m[M_RED].diffuse[0] = 0.75f;
    m[M_LIGHT].emission[1] = INFINITY;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "emission");
    m[M_LIGHT].emission[1] = 0.f;
    m[M_LIGHT].emission[0] = m[M_LIGHT].emission[2] = 0.f;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "no light");
    const pgi_light_desc bad_spot = {.kind = PGI_LIGHT_KIND_SPOT, .direction = {0, -1, 0}, .intensity = 1.f};
    d.lights = &bad_spot;
    d.light_count = 1;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "light 0: spot cone");
    d.lights = NULL;
    d.light_count = 0;
    m[M_LIGHT].emission[0] = m[M_LIGHT].emission[1] = m[M_LIGHT].emission[2] = 12.f;

    const pgi_texture_desc bad_tex = {4, 4, 5, g_tex};
    d.textures = &bad_tex;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "texture 0");
    d.textures = &tex;

    float col[3 * MAXV];
    for (size_t k = 0; k < 3 * r.nv; k++) col[k] = 0.5f;
    col[10] = 1.5f;
    mesh.colors = col;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "mesh 0: the colour of vertex 3 is not in [0, 1]");
    col[10] = NAN;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "mesh 0: the colour of vertex 3");
    mesh.colors = NULL;

    pgi_mesh_desc two[2] = {mesh, mesh};
    two[1].normals = NULL;
    d.meshes = two;
    d.mesh_count = 2;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "mesh 1 has no normals");
    d.meshes = &mesh;
    d.mesh_count = 1;

    d.max_memory = 1000;
    expect_refused(&d, PGI_ERR_OOM, "memory budget");
    d.max_memory = 0;
    d.material_count = 0;
    expect_refused(&d, PGI_ERR_INVALID_ARG, "at least one material");
}

/* ------------------------------------------------------------ vertex updates */

static void test_update_positions(void **state) {
    (void)state;
    make_texture();
    for (int dynamic = 0; dynamic < 2; dynamic++) {
        room r, moved;
        build_room(&r, 1);
        moved = r;
        /* the glossy block (its 24 vertices follow the 5 room quads' 20) half a unit to the right */
        for (size_t v = 20; v < 44; v++) moved.pos[3 * v] += 0.5f;
        pgi_scene *s, *ref;
        assert_int_equal(create_room(&r, &s, NULL, 0, dynamic), PGI_OK);
        assert_int_equal(create_room(&moved, &ref, NULL, 0, dynamic), PGI_OK);
        pgi_renderer *rd;
        assert_int_equal(pgi_renderer_create(s, &rd), PGI_OK);
        pgi_render_desc d = small_desc();
        pgi_image before = {0}, after = {0}, want = {0};
        pgi_frame_stats fs;
        assert_int_equal(pgi_renderer_render(rd, &d, &before, &fs), PGI_OK);
        /* refused: nothing changes */
        assert_int_equal(pgi_scene_update_positions(s, 0, moved.pos, NULL, moved.nv - 1), PGI_ERR_INVALID_ARG);
        assert_non_null(strstr(pgi_last_error(), "vertices given"));
        assert_int_equal(pgi_scene_update_positions(s, 1, moved.pos, NULL, moved.nv), PGI_ERR_INVALID_ARG);
        float bad[3 * MAXV];
        memcpy(bad, moved.pos, sizeof bad);
        bad[5] = NAN;
        assert_int_equal(pgi_scene_update_positions(s, 0, bad, NULL, moved.nv), PGI_ERR_INVALID_ARG);
        assert_non_null(strstr(pgi_last_error(), "vertex 1"));
        assert_int_equal(pgi_renderer_render(rd, &d, &after, &fs), PGI_OK);
        assert_true(same_image(&before, &after));
        /* moved: the next frame sees the new positions */
        assert_int_equal(pgi_scene_update_positions(s, PGI_ALL_MESHES, moved.pos, moved.nrm, moved.nv), PGI_OK);
        assert_int_equal(pgi_renderer_render(rd, &d, &after, &fs), PGI_OK);
        render(ref, &d, &want, NULL);
        assert_false(same_image(&before, &after));
        /* a rebuilt static structure is the fresh one; a refitted one finds the same hits but where a
           ray meets an edge of two triangles (a few pixels) */
        if (!dynamic) assert_true(same_image(&after, &want));
        else {
            size_t differ = 0;
            for (size_t i = 0; i < (size_t)64 * 48; i++)
                differ += memcmp(after.rgb + 3 * i, want.rgb + 3 * i, 3 * sizeof(float)) != 0;
            assert_true(differ <= 64 * 48 / 200); /* 2 pixels of 3072 here */
        }
        pgi_image_free(&before);
        pgi_image_free(&after);
        pgi_image_free(&want);
        pgi_renderer_destroy(rd);
        pgi_scene_destroy(s);
        pgi_scene_destroy(ref);
    }
    pgi_scene *file;
    assert_int_equal(pgi_scene_load("cornell", &file), PGI_OK);
    float p[3] = {0};
    assert_int_equal(pgi_scene_update_positions(file, 0, p, NULL, 1), PGI_ERR_UNSUPPORTED);
    pgi_scene_destroy(file);
}

/* ------------------------------------------------------------ lights */

/* Every float of b is k times a's, within rel (of the larger of both and floor). */
static void expect_scaled(const float *a, const float *b, size_t n, double k, double rel, const char *what) {
    double peak = tu_max_abs(b, n), worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        const double e = fabs((double)b[i] - k * (double)a[i]) / fmax(fabs((double)b[i]), 1e-4 * peak);
        if (e > worst) worst = e;
    }
    if (worst > rel) fprintf(stderr, "%s: worst relative error %g\n", what, worst);
    assert_true(peak > 0.0);
    assert_true(worst <= rel);
}

/* One frame's direct and indirect AOVs, by a renderer kept across frames (r) or a fresh one. */
static void render_aovs(const pgi_scene *s, pgi_renderer *r, float *direct, float *indirect) {
    pgi_aovs a = {.direct = direct, .indirect = indirect};
    pgi_render_desc d = small_desc();
    d.aovs = &a;
    pgi_image img = {0};
    if (r) assert_int_equal(pgi_renderer_render(r, &d, &img, NULL), PGI_OK);
    else render(s, &d, &img, NULL);
    pgi_image_free(&img);
}

static void test_light_intensity_doubles(void **state) {
    (void)state;
    make_texture();
    const size_t n = 3 * 64 * 48;
    float *d1 = malloc(n * sizeof(float)), *i1 = malloc(n * sizeof(float)), *d2 = malloc(n * sizeof(float)),
          *i2 = malloc(n * sizeof(float));
    assert_non_null(d1 && i1 && d2 && i2);
    /* an area light (the emissive quad) and, in a room without it, a point light */
    room r;
    for (int point = 0; point < 2; point++) {
        build_room(&r, !point);
        const pgi_light_desc pl = {.kind = PGI_LIGHT_KIND_POINT,
                                   .position = {0.f, 1.75f, 0.25f},
                                   .color = {1.f, 0.75f, 0.5f},
                                   .intensity = 3.f};
        pgi_scene *s;
        assert_int_equal(create_room(&r, &s, point ? &pl : NULL, point, 0), PGI_OK);
        assert_int_equal(pgi_scene_light_group_count(s), 1);
        pgi_renderer *rd; /* kept across the change, as an engine keeps it */
        assert_int_equal(pgi_renderer_create(s, &rd), PGI_OK);
        render_aovs(s, rd, d1, i1);
        pgi_light_desc l;
        assert_int_equal(pgi_scene_get_light(s, 0, &l), PGI_OK);
        assert_int_equal(l.kind, point ? PGI_LIGHT_KIND_POINT : PGI_LIGHT_KIND_AREA);
        assert_float_equal(l.intensity, point ? 3.f : 12.f, 1e-6);
        l.intensity *= 2.f;
        assert_int_equal(pgi_scene_set_light(s, 0, &l), PGI_OK);
        render_aovs(s, rd, d2, i2);
        expect_scaled(d1, d2, n, 2.0, 1e-5, point ? "point direct" : "area direct");
        expect_scaled(i1, i2, n, 2.0, 1e-5, point ? "point indirect" : "area indirect");
        /* the kind cannot change; bad values are refused and change nothing */
        l.kind = PGI_LIGHT_KIND_SUN;
        assert_int_equal(pgi_scene_set_light(s, 0, &l), PGI_ERR_INVALID_ARG);
        l.kind = point ? PGI_LIGHT_KIND_POINT : PGI_LIGHT_KIND_AREA;
        l.intensity = -1.f;
        assert_int_equal(pgi_scene_set_light(s, 0, &l), PGI_ERR_INVALID_ARG);
        assert_non_null(strstr(pgi_last_error(), "light group 0"));
        render_aovs(s, NULL, d1, i1); /* a fresh renderer agrees */
        assert_memory_equal(d1, d2, n * sizeof(float));
        assert_memory_equal(i1, i2, n * sizeof(float));
        /* switched off: black, not NaN (no light has power) */
        l.intensity = 0.f;
        assert_int_equal(pgi_scene_set_light(s, 0, &l), PGI_OK);
        render_aovs(s, rd, d1, i1);
        for (size_t i = 0; i < n; i++) assert_true(d1[i] == 0.f && i1[i] == 0.f); /* NaN fails */
        pgi_renderer_destroy(rd);
        pgi_scene_destroy(s);
    }
    free(d1);
    free(i1);
    free(d2);
    free(i2);
}

static void test_light_add_remove(void **state) {
    (void)state;
    make_texture();
    room r;
    build_room(&r, 1);
    pgi_scene *s;
    assert_int_equal(create_room(&r, &s, NULL, 0, 0), PGI_OK);
    pgi_render_desc d = small_desc();
    pgi_image base = {0}, img = {0}, wide = {0};
    render(s, &d, &base, NULL);
    assert_int_equal(pgi_scene_remove_light(s, 0), PGI_ERR_UNSUPPORTED); /* an emissive material */
    /* a spot light down onto the floor: the second group, the area group moves up */
    pgi_light_desc spot = {.kind = PGI_LIGHT_KIND_SPOT,
                           .position = {0.5f, 1.5f, 0.5f},
                           .direction = {0.f, -1.f, 0.f},
                           .intensity = 4.f,
                           .cone_deg = 20.f};
    size_t g = 99;
    assert_int_equal(pgi_scene_add_light(s, &spot, &g), PGI_OK);
    assert_int_equal(g, 0);
    assert_int_equal(pgi_scene_light_group_count(s), 2);
    pgi_light_group lg;
    assert_int_equal(pgi_scene_get_light_group(s, 1, &lg), PGI_OK);
    assert_int_equal(lg.kind, PGI_LIGHT_KIND_AREA);
    pgi_light_desc got;
    assert_int_equal(pgi_scene_get_light(s, 0, &got), PGI_OK);
    assert_float_equal(got.cone_deg, 20.f, 1e-3);
    assert_float_equal(got.direction[1], -1.f, 1e-6);
    render(s, &d, &img, NULL);
    assert_true(image_sum(&img) > image_sum(&base));
    /* a wider cone lights more */
    spot.cone_deg = 40.f;
    assert_int_equal(pgi_scene_set_light(s, 0, &spot), PGI_OK);
    render(s, &d, &wide, NULL);
    assert_true(image_sum(&wide) > image_sum(&img));
    /* colour: a red spot adds red direct light and no green or blue (the photons' split between the
       lights changes the indirect light's noise) */
    const size_t n = 3 * 64 * 48;
    float *dir0 = malloc(n * sizeof(float)), *dir1 = malloc(n * sizeof(float));
    assert_non_null(dir0 && dir1);
    assert_int_equal(pgi_scene_remove_light(s, 0), PGI_OK);
    render_aovs(s, NULL, dir0, NULL);
    spot.color[0] = 1.f;
    spot.color[1] = spot.color[2] = 0.f;
    spot.direction[0] = 0.25f; /* not unit: normalised */
    assert_int_equal(pgi_scene_add_light(s, &spot, NULL), PGI_OK);
    assert_int_equal(pgi_scene_get_light(s, 0, &got), PGI_OK);
    assert_float_equal(got.color[1], 0.f, 0.f);
    assert_float_equal(got.direction[0] * got.direction[0] + got.direction[1] * got.direction[1], 1.f, 1e-5);
    render_aovs(s, NULL, dir1, NULL);
    double dr = 0.0;
    for (size_t i = 0; i < n; i += 3) {
        dr += dir1[i] - dir0[i];
        assert_true(dir1[i + 1] == dir0[i + 1] && dir1[i + 2] == dir0[i + 2]);
    }
    assert_true(dr > 0.0);
    free(dir0);
    free(dir1);
    /* removed: the image is the one without it again */
    assert_int_equal(pgi_scene_remove_light(s, 0), PGI_OK);
    assert_int_equal(pgi_scene_light_group_count(s), 1);
    render(s, &d, &img, NULL);
    assert_true(same_image(&img, &base));
    /* a sun; bad lights refused */
    const pgi_light_desc sun = {.kind = PGI_LIGHT_KIND_SUN, .direction = {0.f, -1.f, 0.f}, .intensity = 1.f};
    assert_int_equal(pgi_scene_add_light(s, &sun, NULL), PGI_OK);
    assert_int_equal(pgi_scene_remove_light(s, 0), PGI_OK);
    const pgi_light_desc area = {.kind = PGI_LIGHT_KIND_AREA, .intensity = 1.f};
    assert_int_equal(pgi_scene_add_light(s, &area, NULL), PGI_ERR_INVALID_ARG);
    const pgi_light_desc nodir = {.kind = PGI_LIGHT_KIND_SUN, .intensity = 1.f};
    assert_int_equal(pgi_scene_add_light(s, &nodir, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "direction"));
    const pgi_light_desc far = {.kind = PGI_LIGHT_KIND_POINT, .position = {2e15f, 0, 0}, .intensity = 1.f};
    assert_int_equal(pgi_scene_add_light(s, &far, NULL), PGI_ERR_INVALID_ARG);
    assert_int_equal(pgi_scene_light_group_count(s), 1);
    assert_int_equal(pgi_scene_remove_light(s, 5), PGI_ERR_INVALID_ARG);
    pgi_image_free(&base);
    pgi_image_free(&img);
    pgi_image_free(&wide);
    pgi_scene_destroy(s);

    /* the only light of a scene stays */
    build_room(&r, 0);
    const pgi_light_desc pl = {.kind = PGI_LIGHT_KIND_POINT, .position = {0.f, 1.5f, 0.f}, .intensity = 1.f};
    assert_int_equal(create_room(&r, &s, &pl, 1, 0), PGI_OK);
    assert_int_equal(pgi_scene_remove_light(s, 0), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "only light"));
    pgi_scene_destroy(s);
}

/* ------------------------------------------------------------ camera matrices */

/* glm::lookAt and glm::perspective (OpenGL conventions, column-major), in double. */
static void look_at_matrix(const pgi_camera_def *c, float m[16]) {
    double f[3], s[3], u[3], up[3] = {c->up[0], c->up[1], c->up[2]};
    for (int k = 0; k < 3; k++) f[k] = (double)c->look_at[k] - (double)c->eye[k];
    double l = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    for (int k = 0; k < 3; k++) f[k] /= l;
    s[0] = f[1] * up[2] - f[2] * up[1];
    s[1] = f[2] * up[0] - f[0] * up[2];
    s[2] = f[0] * up[1] - f[1] * up[0];
    l = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    for (int k = 0; k < 3; k++) s[k] /= l;
    u[0] = s[1] * f[2] - s[2] * f[1];
    u[1] = s[2] * f[0] - s[0] * f[2];
    u[2] = s[0] * f[1] - s[1] * f[0];
    memset(m, 0, 16 * sizeof(float));
    for (int k = 0; k < 3; k++) {
        m[4 * k + 0] = (float)s[k];
        m[4 * k + 1] = (float)u[k];
        m[4 * k + 2] = (float)-f[k];
    }
    double e[3] = {c->eye[0], c->eye[1], c->eye[2]};
    m[12] = (float)-(s[0] * e[0] + s[1] * e[1] + s[2] * e[2]);
    m[13] = (float)-(u[0] * e[0] + u[1] * e[1] + u[2] * e[2]);
    m[14] = (float)(f[0] * e[0] + f[1] * e[1] + f[2] * e[2]);
    m[15] = 1.f;
}

static void perspective_matrix(double fov_deg, double aspect, float m[16]) {
    const double t = tan(fov_deg * 3.14159265358979323846 / 360.0), zn = 0.1, zf = 100.0;
    memset(m, 0, 16 * sizeof(float));
    m[0] = (float)(1.0 / (aspect * t));
    m[5] = (float)(1.0 / t);
    m[10] = (float)(-(zf + zn) / (zf - zn));
    m[11] = -1.f;
    m[14] = (float)(-2.0 * zf * zn / (zf - zn));
}

static void test_camera_matrices(void **state) {
    (void)state;
    pgi_scene *s;
    assert_int_equal(pgi_scene_load("cornell", &s), PGI_OK);
    pgi_camera_def cam, got;
    assert_int_equal(pgi_scene_get_camera(s, 0, &cam), PGI_OK);
    /* the scene's view with its look-at one unit ahead, so that look-at - eye normalises exactly (as
       the matrices give it; (0, 0, -3.9) normalises to (0, 0, -0.99999994)) */
    for (int k = 0; k < 3; k++) cam.look_at[k] = cam.eye[k] + (k == 2 ? -1.f : 0.f);
    assert_true(cam.look_at[2] - cam.eye[2] == -1.f);
    const int W = 64, H = 48;
    float V[16], P[16], shift[2] = {9.f, 9.f};
    look_at_matrix(&cam, V);
    perspective_matrix(cam.fov_y_deg, (double)W / H, P);
    assert_int_equal(pgi_camera_from_matrices(V, P, W, H, &got, shift), PGI_OK);
    assert_float_equal(shift[0], 0.f, 0.f);
    assert_float_equal(shift[1], 0.f, 0.f);
    pgi_render_desc d = {.photons = 20000, .radius = 0.05f, .width = W, .height = H, .threads = 2, .view = &cam};
    pgi_image a = {0}, b = {0};
    render(s, &d, &a, NULL);
    d.view = &got;
    render(s, &d, &b, NULL);
    assert_true(same_image(&a, &b));

    /* a turned camera: the same view within float rounding of the basis */
    pgi_camera_def turned = {{0.75f, 1.25f, 3.f}, {-0.25f, 0.75f, 0.f}, {0.125f, 1.f, 0.f}, 37.f};
    look_at_matrix(&turned, V);
    perspective_matrix(turned.fov_y_deg, (double)W / H, P);
    assert_int_equal(pgi_camera_from_matrices(V, P, W, H, &got, NULL), PGI_OK);
    pgi_camera ca, cb;
    pgi_camera_look_at(&ca, turned.eye, turned.look_at, turned.up, turned.fov_y_deg, W, H);
    pgi_camera_look_at(&cb, got.eye, got.look_at, got.up, got.fov_y_deg, W, H);
    for (int k = 0; k < 3; k++) {
        assert_float_equal(ca.eye[k], cb.eye[k], 1e-6);
        assert_float_equal(ca.forward[k], cb.forward[k], 1e-6);
        assert_float_equal(ca.up[k], cb.up[k], 1e-6);
        assert_float_equal(ca.right[k], cb.right[k], 1e-6);
    }
    assert_float_equal(ca.tan_half_fov_y, cb.tan_half_fov_y, 1e-7);

    /* TAA jitter: P[0][2], P[1][2] in NDC become a shift in pixels (x right, y down) */
    look_at_matrix(&cam, V);
    perspective_matrix(cam.fov_y_deg, (double)W / H, P);
    P[8] = 2.f * 0.25f / W;
    P[9] = 2.f * 0.375f / H;
    assert_int_equal(pgi_camera_from_matrices(V, P, W, H, &got, shift), PGI_OK);
    assert_float_equal(shift[0], 0.25f, 1e-6);
    assert_float_equal(shift[1], -0.375f, 1e-6);
    assert_int_equal(pgi_camera_from_matrices(V, P, W, H, &got, NULL), PGI_ERR_INVALID_ARG);
    /* the shifted view samples: the world point each sees lands on its pixel's centre through P V */
    pgi_renderer *r;
    assert_int_equal(pgi_renderer_create(s, &r), PGI_OK);
    d.view = &got;
    d.shift[0] = shift[0];
    d.shift[1] = shift[1];
    pgi_frame_inputs in;
    assert_int_equal(pgi_renderer_prepare(r, &d, &in, NULL), PGI_OK);
    int checked = 0;
    for (int y = 0; y < H; y += 7)
        for (int x = 0; x < W; x += 5) {
            const size_t i = (size_t)y * W + (size_t)x;
            if (!(in.samples->flags[i] & 2 /* PGI_VS_PRIMARY */)) continue;
            const float *p = in.samples->pos + 3 * i;
            double cv[4], cl[4];
            for (int row = 0; row < 4; row++)
                cv[row] = V[row] * p[0] + V[4 + row] * p[1] + V[8 + row] * p[2] + V[12 + row];
            for (int row = 0; row < 4; row++)
                cl[row] = P[row] * cv[0] + P[4 + row] * cv[1] + P[8 + row] * cv[2] + P[12 + row] * cv[3];
            const double px = (cl[0] / cl[3] + 1.0) * 0.5 * W, py = (1.0 - cl[1] / cl[3]) * 0.5 * H;
            assert_float_equal(px, x + 0.5, 2e-3);
            assert_float_equal(py, y + 0.5, 2e-3);
            checked++;
        }
    assert_true(checked > 20);
    render(s, &d, &b, NULL);
    assert_false(same_image(&a, &b));
    d.shift[0] = 0.75f;
    assert_int_equal(pgi_render(s, &d, &b, NULL), PGI_ERR_INVALID_ARG);
    pgi_renderer_destroy(r);

    /* refused, each with its reason */
    look_at_matrix(&cam, V);
    perspective_matrix(cam.fov_y_deg, (double)W / H, P);
    float O[16] = {0};
    O[0] = 1.f, O[5] = 4.f / 3.f, O[10] = -0.02f, O[14] = -1.f, O[15] = 1.f;
    assert_int_equal(pgi_camera_from_matrices(V, O, W, H, &got, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "orthographic"));
    float Z[16] = {0};
    Z[15] = 1.f;
    assert_int_equal(pgi_camera_from_matrices(Z, P, W, H, &got, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "singular"));
    float S[16];
    memcpy(S, V, sizeof S);
    for (int k = 0; k < 12; k++) S[k] *= 2.f;
    assert_int_equal(pgi_camera_from_matrices(S, P, W, H, &got, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "scaled or sheared"));
    assert_int_equal(pgi_camera_from_matrices(V, P, 48, 48, &got, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "aspect"));
    float J[16];
    memcpy(J, P, sizeof J);
    J[8] = 2.f * 3.f / W;
    assert_int_equal(pgi_camera_from_matrices(V, J, W, H, &got, shift), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "off-centre"));
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_scene_destroy(s);
}

/* ------------------------------------------------------------ AOVs */

static void test_aovs(void **state) {
    (void)state;
    /* a plane of albedo (0.25, 0.5, 0.75) at z = -4 facing the camera at the origin, a point light
       between them, and behind the camera a panel facing them (the indirect light) */
    const float pos[] = {-8, -8, -4, 8, -8, -4, 8, 8, -4, -8, 8, -4, -8, -8, 1, -8, 8, 1, 8, 8, 1, 8, -8, 1};
    const float nrm[] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, -1, 0, 0, -1, 0, 0, -1, 0, 0, -1};
    const uint32_t idx[] = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
    const pgi_material_desc mat = {.diffuse = {0.25f, 0.5f, 0.75f}};
    const pgi_mesh_desc mesh = {.vertex_count = 8,
                                .positions = pos,
                                .normals = nrm,
                                .triangle_count = 4,
                                .indices = idx};
    const pgi_light_desc light = {.kind = PGI_LIGHT_KIND_POINT, .position = {0.f, 0.f, -1.f}, .intensity = 5.f};
    const pgi_camera_def cam = {{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60.f};
    const pgi_scene_desc sd = {.meshes = &mesh,
                               .mesh_count = 1,
                               .materials = &mat,
                               .material_count = 1,
                               .lights = &light,
                               .light_count = 1,
                               .cameras = &cam,
                               .camera_count = 1};
    pgi_scene *s;
    assert_int_equal(pgi_scene_create(&sd, &s), PGI_OK);
    const int W = 40, H = 30;
    const size_t n = (size_t)W * H;
    float *albedo = malloc(3 * n * sizeof(float)), *normal = malloc(3 * n * sizeof(float)),
          *depth = malloc(n * sizeof(float)), *direct = malloc(3 * n * sizeof(float)),
          *indirect = malloc(3 * n * sizeof(float));
    assert_non_null(albedo && normal && depth && direct && indirect);
    pgi_aovs a = {albedo, normal, depth, direct, indirect};
    pgi_render_desc d = {.photons = 20000, .radius = 0.25f, .width = W, .height = H, .threads = 2, .aovs = &a};
    pgi_renderer *r;
    assert_int_equal(pgi_renderer_create(s, &r), PGI_OK);
    pgi_image img = {0};
    assert_int_equal(pgi_renderer_render(r, &d, &img, NULL), PGI_OK);
    /* the centre pixel: the plane 4 units ahead */
    const size_t c = (size_t)(H / 2) * W + W / 2;
    assert_float_equal(depth[c], 4.f, 1e-4);
    assert_float_equal(normal[3 * c + 2], 1.f, 1e-6);
    assert_float_equal(albedo[3 * c], 0.25f, 1e-6);
    assert_float_equal(albedo[3 * c + 1], 0.5f, 1e-6);
    assert_float_equal(albedo[3 * c + 2], 0.75f, 1e-6);
    /* every pixel: the view samples' values, and the image direct + indirect */
    pgi_frame_inputs in;
    assert_int_equal(pgi_renderer_prepare(r, &d, &in, NULL), PGI_OK);
    for (size_t i = 0; i < n; i++) {
        assert_true(in.samples->flags[i] & 1);
        assert_memory_equal(albedo + 3 * i, in.samples->kd + 3 * i, 3 * sizeof(float));
        assert_memory_equal(normal + 3 * i, in.samples->nrm + 3 * i, 3 * sizeof(float));
        assert_memory_equal(depth + i, in.samples->depth + i, sizeof(float));
        for (int k = 0; k < 3; k++) assert_true(img.rgb[3 * i + k] == direct[3 * i + k] + indirect[3 * i + k]);
    }
    assert_true(tu_max_abs(direct, 3 * n) > 0.0);
    assert_true(tu_max_abs(indirect, 3 * n) > 0.0);
    /* without a hit: zeros */
    d.view = &(const pgi_camera_def){{0, 0, 2}, {0, 0, 3}, {0, 1, 0}, 60.f}; /* away from everything */
    assert_int_equal(pgi_renderer_render(r, &d, &img, NULL), PGI_OK);
    assert_true(tu_max_abs(albedo, 3 * n) == 0.0 && tu_max_abs(normal, 3 * n) == 0.0 && tu_max_abs(depth, n) == 0.0);
    pgi_scene_destroy(s);
    pgi_renderer_destroy(r);
    pgi_image_free(&img);
    free(albedo);
    free(normal);
    free(depth);
    free(direct);
    free(indirect);
}

/* --output indirect: no shadow ray, the image the composite made; the AOVs of a full frame are the
 * DIRECT and INDIRECT images. */
static void test_indirect_no_shadow_rays(void **state) {
    (void)state;
    pgi_scene *s;
    assert_int_equal(pgi_scene_load("cornell", &s), PGI_OK);
    const int W = 48, H = 36;
    const size_t n = 3 * (size_t)W * H;
    float *direct = malloc(n * sizeof(float)), *indirect = malloc(n * sizeof(float));
    assert_non_null(direct && indirect);
    pgi_aovs a = {.direct = direct, .indirect = indirect};
    pgi_render_desc d = {.photons = 20000, .radius = 0.05f, .width = W, .height = H, .threads = 2, .aovs = &a};
    pgi_image all = {0}, ind = {0}, dir = {0};
    pgi_frame_stats fs;
    render(s, &d, &all, &fs);
    assert_true(fs.shadow_rays > 0);
    d.aovs = NULL;
    render(s, &d, &dir, &fs); /* AOVs are not part of the picture */
    assert_true(same_image(&all, &dir));
    d.output = PGI_OUTPUT_INDIRECT;
    render(s, &d, &ind, &fs);
    assert_int_equal(fs.shadow_rays, 0);
    assert_memory_equal(ind.rgb, indirect, n * sizeof(float));
    assert_true(tu_max_abs(ind.rgb, n) > 0.0);
    d.output = PGI_OUTPUT_DIRECT;
    render(s, &d, &dir, &fs);
    assert_true(fs.shadow_rays > 0);
    assert_memory_equal(dir.rgb, direct, n * sizeof(float));
    /* the AOVs of an indirect-only frame: no direct light */
    d.output = PGI_OUTPUT_INDIRECT;
    d.aovs = &a;
    render(s, &d, &ind, &fs);
    assert_true(tu_max_abs(direct, n) == 0.0);
    assert_memory_equal(ind.rgb, indirect, n * sizeof(float));
    pgi_image_free(&all);
    pgi_image_free(&ind);
    pgi_image_free(&dir);
    free(direct);
    free(indirect);
    pgi_scene_destroy(s);
}

TU_MAIN("engine", tu_dir_setup, tu_dir_teardown, cmocka_unit_test(test_arrays_equal_obj),
        cmocka_unit_test(test_arrays_colours), cmocka_unit_test(test_create_errors),
        cmocka_unit_test(test_update_positions), cmocka_unit_test(test_light_intensity_doubles),
        cmocka_unit_test(test_light_add_remove), cmocka_unit_test(test_camera_matrices), cmocka_unit_test(test_aovs),
        cmocka_unit_test(test_indirect_no_shadow_rays))
