/* Alpha cut-outs (docs/scene-format.md, "Cut-outs"): the built-in scene `cutout` (a lattice
 * mask of open fraction f = 0.375 between a point light + white ceiling and a white floor,
 * src/scene/builtin.c) seen by primary rays, shadow rays, photons and the path tracer; and the
 * masks of MTL map_d and glTF alphaMode MASK as loaded from files. */
#include "test_util.h"

#include "photongi/reference.h"
#include "rt/rt.h"
#include "scene/scene_internal.h"
#include "view/view.h"

#define PI_D 3.14159265358979323846
#define F_OPEN PGI__CUTOUT_OPEN_FRACTION

/* The cutout scene, its lattice made fully open (alpha 0 everywhere: the unoccluded
 * configuration) when `open`. */
static pgi_scene *cutout(int open) {
    pgi_scene *s = tu_scene("cutout");
    assert_int_equal(s->ncams, 3);
    const pgi__material *m = NULL;
    for (size_t i = 0; i < s->nmats; i++)
        if (strcmp(s->mats[i].name, "lattice") == 0) m = &s->mats[i];
    assert_non_null(m);
    assert_true(pgi__mat_masked(m));
    assert_true(m->tex_alpha >= 0);
    pgi__texture *t = &s->texs[m->tex_alpha];
    size_t n = (size_t)t->width * t->height, open_texels = 0;
    for (size_t i = 0; i < n; i++) {
        if (open) t->rgba[4 * i + 3] = 0;
        open_texels += t->rgba[4 * i + 3] < 128;
    }
    assert_true(fabs((double)open_texels / (double)n - (open ? 1.0 : F_OPEN)) < 1e-12);
    return s;
}

/* Mean over the image of channel 0. */
static double image_mean(const pgi_image *img) {
    double sum = 0.0;
    for (size_t i = 0; i < (size_t)img->width * img->height; i++) sum += img->rgb[3 * i];
    return sum / ((double)img->width * img->height);
}

/* ------------------------------------------------ primary rays */

/* Camera 2 looks straight down at the mask's [-0.5, 0.5]^2 from 0.9 above it: at 96 x 96 each
 * pixel centre is over one texel centre. Where the lattice is open, the view sample lies below
 * the mask (the floor or the black walls); where it is closed, on the mask. The packets of the
 * view pass (16-wide) and single rays (the path tracer's) must agree. */
static void test_primary_rays(void **state) {
    (void)state;
    pgi_scene *s = cutout(0);
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    const int W = 96, H = 96;
    pgi_camera cam;
    const pgi_camera_def *cd = &s->cams[2];
    pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, W, H);
    pgi_view_samples vs = {0};
    TU_CHECK_OK(pgi_view_samples_alloc(&vs, W, H));
    float *emit = malloc(3 * sizeof(float) * W * H);
    assert_non_null(emit);
    uint64_t rays = 0;
    const pgi__subpixel sp = {0};
    TU_CHECK_OK(pgi__view_build(s, rt, NULL, &cam, 1, &sp, 0, &vs, emit, NULL, &rays));
    int open = 0, closed = 0, wrong = 0, single_wrong = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * W + x;
            /* The pixel's ray meets the mask plane y = 1 at (mx, mz); its texel. */
            float d[3];
            tu_pixel_dir(&cam, x, y, d);
            float t1 = (1.f - cd->eye[1]) / d[1];
            float mx = cd->eye[0] + t1 * d[0], mz = cd->eye[2] + t1 * d[2];
            int tx = (int)floorf((mx + 1.f) * 0.5f * PGI__CUTOUT_TEXELS);
            int tz = (int)floorf((1.f - (mz + 1.f) * 0.5f) * PGI__CUTOUT_TEXELS); /* row 0 at v = 1 */
            int is_open = pgi__cutout_open(tx, tz);
            open += is_open;
            closed += !is_open;
            assert_true(vs.flags[i] & PGI_VS_VALID);
            float py = vs.pos[3 * i + 1];
            int ok = is_open ? py < 0.99f : fabsf(py - 1.f) < 1e-4f;
            if (!ok && wrong++ < 5)
                fprintf(stderr, "  pixel (%d, %d): texel (%d, %d) %s, view sample at y = %g\n", x, y, tx, tz,
                        is_open ? "open" : "closed", py);
            pgi__hit h;
            int hit = pgi__rt_intersect(rt, v3_load(cd->eye), v3_load(d), 0.f, INFINITY, &h);
            float hy = hit ? cd->eye[1] + h.t * d[1] : 99.f;
            single_wrong += !hit || fabsf(hy - py) > 1e-4f;
            /* A shadow ray from the eye to a point just below the mask: blocked exactly where closed. */
            int occ = pgi__rt_occluded(rt, v3_load(cd->eye), v3_load(d), 0.f, t1 * 1.001f);
            single_wrong += occ != !is_open;
        }
    fprintf(stderr, "  primary rays: %d open and %d closed pixels, %d wrong, %d single-ray mismatches\n", open, closed,
            wrong, single_wrong);
    assert_int_equal(wrong, 0);
    assert_int_equal(single_wrong, 0);
    assert_int_equal(open, W * H * 3 / 8); /* 12 x 12 whole periods */
    free(emit);
    pgi_view_samples_free(&vs);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(s);
}

/* ------------------------------------------------ the light under the mask */

/* Camera 1 sees the floor's [-0.5, 0.5]^2 from inside, 64 x 64 pixels. With one bounce the light
 * there is exactly linear in the mask's open fraction: direct light from the point light through
 * the mask (the light projects the lattice onto the floor 3 times magnified, and the square is 4
 * x 4 whole periods of its shadow, 16 x 16 pixels each, whose edges fall between pixel centres),
 * and light reflected once by the ceiling through the mask (over the square, the rays of any one
 * direction cross 12 x 12 whole periods of the lattice). Mask and walls are black: nothing else
 * reaches the floor. So every estimate over the square, masked, is f = 0.375 times its value
 * with the lattice fully open. */
static pgi_render_desc floor_desc(pgi_output out, uint32_t photons) {
    pgi_render_desc d = {.estimator = "hashgrid",
                         .width = 64,
                         .height = 64,
                         .camera = 1,
                         .bounces = 1,
                         .photons = photons,
                         .radius = 0.05f,
                         .output = out,
                         .seed = 11};
    return d;
}

static double floor_mean(int open, pgi_output out, uint32_t photons) {
    pgi_scene *s = cutout(open);
    pgi_render_desc d = floor_desc(out, photons);
    pgi_image img = {0};
    TU_CHECK_OK(pgi_render(s, &d, &img, NULL));
    double m = image_mean(&img);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
    return m;
}

/* Shadow rays: deterministic (no noise), so compared with the analytic values at the pixel
 * centres p: rho/pi I cos(theta)/d^2 open, and the same where the segment from p to the light
 * crosses an open texel masked (within 0.1%: float rounding). Their ratio is f up to the
 * variation of the weight across a period of the shadow (about 0.2% here): bound 0.5%. */
static void test_direct_light(void **state) {
    (void)state;
    double masked = floor_mean(0, PGI_OUTPUT_DIRECT, 1000), open = floor_mean(1, PGI_OUTPUT_DIRECT, 1000);
    pgi_scene *s = cutout(0);
    pgi_camera cam;
    const pgi_camera_def *cd = &s->cams[1];
    pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, 64, 64);
    double an_open = 0.0, an_masked = 0.0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            float d[3];
            tu_pixel_dir(&cam, x, y, d);
            double t = -cd->eye[1] / d[1], px = cd->eye[0] + t * d[0], pz = cd->eye[2] + t * d[2];
            double d2 = px * px + 1.5 * 1.5 + pz * pz, cosv = 1.5 / sqrt(d2);
            double L = 0.8 / PI_D * 4.5 * cosv / d2;
            /* The segment to the light at (0, 1.5, 0) crosses the mask (y = 1) at p / 3. */
            int tx = (int)floor((px / 3.0 + 1.0) * 0.5 * PGI__CUTOUT_TEXELS);
            int tz = (int)floor((1.0 - (pz / 3.0 + 1.0) * 0.5) * PGI__CUTOUT_TEXELS);
            an_open += L;
            an_masked += pgi__cutout_open(tx, tz) ? L : 0.0;
        }
    an_open /= 64.0 * 64.0;
    an_masked /= 64.0 * 64.0;
    pgi_scene_destroy(s);
    double ratio = masked / open;
    fprintf(stderr, "  direct: masked %.6f (analytic %.6f), open %.6f (analytic %.6f), ratio %.5f (f = %.3f)\n", masked,
            an_masked, open, an_open, ratio, F_OPEN);
    assert_true(fabs(open / an_open - 1.0) < 1e-3);
    assert_true(fabs(masked / an_masked - 1.0) < 1e-3);
    assert_true(fabs(ratio / F_OPEN - 1.0) < 5e-3);
}

/* Photons: the indirect light (stored photons: the ceiling's light through the mask) masked is f
 * times the open value. Noise: about 50k photons a frame land on the square when open, 20k
 * masked; the mean's relative sd is under 1%: bound 3% (an unmasked lattice gives 1/f = 2.7 times
 * the value, a mask that photons ignore but shadow rays honour fails the same way). */
static void test_photons(void **state) {
    (void)state;
    double masked = floor_mean(0, PGI_OUTPUT_INDIRECT, 400000), open = floor_mean(1, PGI_OUTPUT_INDIRECT, 400000);
    double ratio = masked / open;
    fprintf(stderr, "  photons: masked %.6f, open %.6f, ratio %.4f (f = %.3f, %+.2f%%)\n", masked, open, ratio, F_OPEN,
            100 * (ratio / F_OPEN - 1.0));
    assert_true(open > 0.0);
    assert_true(fabs(ratio / F_OPEN - 1.0) < 0.03);
}

/* The path tracer (direct + one bounce through the mask, single rays): masked is f times open,
 * and the photon pipeline agrees with it on the masked scene. Noise: 64 x 64 pixels x 64
 * samples; the mean's relative sd is well under 1%: bounds 2% and 3%. */
static double pt_mean(int open) {
    pgi_scene *s = cutout(open);
    pgi_reference_desc d =
        {.width = 64, .height = 64, .camera = 1, .bounces = 1, .spp = 64, .seed = 5, .jitter = PGI_JITTER_OFF};
    pgi_image img = {0};
    uint64_t spp = 0;
    TU_CHECK_OK(pgi_reference_render(s, &d, &img, &spp));
    double m = image_mean(&img);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
    return m;
}

static void test_path_tracer(void **state) {
    (void)state;
    double masked = pt_mean(0), open = pt_mean(1), ratio = masked / open;
    double pm = floor_mean(0, PGI_OUTPUT_ALL, 400000);
    fprintf(stderr, "  path tracer: masked %.6f, open %.6f, ratio %.4f (%+.2f%%); photon pipeline %.6f (%+.2f%%)\n",
            masked, open, ratio, 100 * (ratio / F_OPEN - 1.0), pm, 100 * (pm / masked - 1.0));
    assert_true(fabs(ratio / F_OPEN - 1.0) < 0.02);
    assert_true(fabs(pm / masked - 1.0) < 0.03);
}

/* The same picture whatever the thread count (the filters keep no state). */
static void test_threads(void **state) {
    (void)state;
    pgi_scene *s = cutout(0);
    pgi_render_desc d = floor_desc(PGI_OUTPUT_ALL, 50000);
    d.camera = 0;
    pgi_image a = {0}, b = {0};
    d.threads = 1;
    TU_CHECK_OK(pgi_render(s, &d, &a, NULL));
    d.threads = 3;
    TU_CHECK_OK(pgi_render(s, &d, &b, NULL));
    assert_memory_equal(a.rgb, b.rgb, 3 * sizeof(float) * (size_t)a.width * a.height);
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_scene_destroy(s);
}

/* ------------------------------------------------ masks from files */

/* An uncompressed 32-bit TGA (stb_image reads it; alpha kept): 8 x 8 texels, the left half
 * (x < 4) opaque, the right half alpha 0. */
static void write_tga(const char *path, int channels) {
    unsigned char hdr[18] = {0};
    hdr[2] = channels == 1 ? 3 : 2; /* grey or true colour, uncompressed */
    hdr[12] = 8;
    hdr[14] = 8;
    hdr[16] = (unsigned char)(8 * channels);
    hdr[17] = channels == 4 ? 8 | 0x20 : 0x20; /* alpha bits, top-left origin */
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fwrite(hdr, 1, sizeof hdr, f);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 8; x++) {
            unsigned char a = x < 4 ? 255 : 0;
            unsigned char px[4] = {200, 100, 50, a};
            if (channels == 1) px[0] = a; /* a grey mask: its value is the alpha */
            fwrite(px, 1, (size_t)channels, f);
        }
    assert_int_equal(fclose(f), 0);
}

/* A quad at z = 0 over x, y in [0, 1] with u = x, v = y, material `m` of `mtl`. */
static void write_obj(const char *name, const char *mtl) {
    char path[700], text[1024];
    snprintf(path, sizeof path, "%s/%s.mtl", tu_dir, name);
    assert_int_equal(tu_write_file(path, mtl), 0);
    snprintf(text, sizeof text,
             "mtllib %s.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl m\n"
             "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n",
             name);
    snprintf(path, sizeof path, "%s/%s.obj", tu_dir, name);
    assert_int_equal(tu_write_file(path, text), 0);
}

/* Rays straight down (-z) onto the quad at x = 0.05, 0.15, .. 0.85: which of them hit (the
 * texture's opaque half covers x < 0.5). */
static void probe(const pgi_scene *s, int hits[9]) {
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    for (int i = 0; i < 9; i++) {
        pgi__hit h;
        hits[i] = pgi__rt_intersect(rt, v3(0.05f + 0.1f * (float)i, 0.5f, 1.f), v3(0.f, 0.f, -1.f), 0.f, 10.f, &h);
    }
    pgi__rt_destroy(rt);
}

/* Imports tu_dir/name.ext; its quad's material must be of `type`, masked or not, and the probe
 * rays must hit as `expect` says. */
static void check_file(const char *name, const char *ext, int type, int masked, const int expect[9]) {
    char path[700];
    snprintf(path, sizeof path, "%s/%s.%s", tu_dir, name, ext);
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi__scene_new("t", &s));
    TU_CHECK_OK(pgi__scene_import_mesh(s, path));
    TU_CHECK_OK(pgi__scene_finalize(s, path));
    const pgi__material *m = &s->mats[s->tri_mat[0]];
    assert_int_equal(m->type, type);
    assert_int_equal(pgi__mat_masked(m), masked);
    int hits[9];
    probe(s, hits);
    for (int i = 0; i < 9; i++)
        if (hits[i] != expect[i])
            fail_msg("%s.%s: the ray at x = %.2f %s", name, ext, 0.05 + 0.1 * i, hits[i] ? "hit" : "passed");
    pgi_scene_destroy(s);
}

/* map_d with d = 1 is a cut-out, not glass: the alpha of an RGBA image or the value of a grey
 * one, cut at 0.5. d scales the alpha (d = 0.6: the opaque half's 0.6 stays; d = 0.4 cuts the
 * whole quad). d < 1 without map_d stays glass, and map_Kd alone is no mask. */
static void test_mtl_map_d(void **state) {
    (void)state;
    char path[700];
    snprintf(path, sizeof path, "%s/rgba.tga", tu_dir);
    write_tga(path, 4);
    snprintf(path, sizeof path, "%s/grey.tga", tu_dir);
    write_tga(path, 1);
    static const struct {
        const char *name, *mtl;
        int type, masked;
        int expect[9];
    } cases[] = {
        {"rgba",
         "newmtl m\nKd 0.5 0.5 0.5\nd 1\nillum 2\nmap_Kd rgba.tga\nmap_d rgba.tga\n",
         PGI__MAT_LAMBERT,
         1,
         {1, 1, 1, 1, 1, 0, 0, 0, 0}},
        {"grey", "newmtl m\nKd 0.5 0.5 0.5\nd 1\nmap_d grey.tga\n", PGI__MAT_LAMBERT, 1, {1, 1, 1, 1, 1, 0, 0, 0, 0}},
        {"d06", "newmtl m\nKd 0.5 0.5 0.5\nd 0.6\nmap_d grey.tga\n", PGI__MAT_LAMBERT, 1, {1, 1, 1, 1, 1, 0, 0, 0, 0}},
        {"d04", "newmtl m\nKd 0.5 0.5 0.5\nd 0.4\nmap_d grey.tga\n", PGI__MAT_LAMBERT, 1, {0, 0, 0, 0, 0, 0, 0, 0, 0}},
        {"glass", "newmtl m\nKd 0.5 0.5 0.5\nd 0.5\nNi 1.5\n", PGI__MAT_GLASS, 0, {1, 1, 1, 1, 1, 1, 1, 1, 1}},
        {"plain", "newmtl m\nKd 0.5 0.5 0.5\nmap_Kd rgba.tga\n", PGI__MAT_LAMBERT, 0, {1, 1, 1, 1, 1, 1, 1, 1, 1}},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        write_obj(cases[c].name, cases[c].mtl);
        check_file(cases[c].name, "obj", cases[c].type, cases[c].masked, cases[c].expect);
    }
}

/* glTF alphaMode MASK: the base colour texture's alpha, cut at alphaCutoff (default 0.5); BLEND and
 * OPAQUE are not cut-outs. */
static void test_gltf_mask(void **state) {
    (void)state;
    static const struct {
        const char *name, *mode;
        int masked;
        int expect[9];
    } cases[] = {
        {"mask", "\"alphaMode\": \"MASK\"", 1, {1, 1, 1, 1, 1, 0, 0, 0, 0}},
        {"cut0", "\"alphaMode\": \"MASK\", \"alphaCutoff\": 0.0", 0, {1, 1, 1, 1, 1, 1, 1, 1, 1}},
        {"opaque", "\"alphaMode\": \"OPAQUE\"", 0, {1, 1, 1, 1, 1, 1, 1, 1, 1}},
    };
    /* Two triangles over [0, 1]^2 at z = 0 (positions, then uvs with glTF's v down, then indices). */
    const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, uv[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    unsigned char buf[92];
    memcpy(buf, pos, 48);
    memcpy(buf + 48, uv, 32);
    memcpy(buf + 80, idx, 12);
    char path[700];
    snprintf(path, sizeof path, "%s/quad.bin", tu_dir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fwrite(buf, 1, sizeof buf, f);
    assert_int_equal(fclose(f), 0);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char json[3000];
        snprintf(json, sizeof json,
                 "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
                 "\"nodes\": [{\"mesh\": 0}],"
                 "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1}, \"indices\": 2,"
                 " \"material\": 0}]}],"
                 "\"materials\": [{\"name\": \"m\", %s, \"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": "
                 "0},"
                 " \"metallicFactor\": 0}}],"
                 "\"textures\": [{\"source\": 0}], \"images\": [{\"uri\": \"rgba.tga\"}],"
                 "\"buffers\": [{\"uri\": \"quad.bin\", \"byteLength\": %zu}],"
                 "\"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},"
                 " {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 32},"
                 " {\"buffer\": 0, \"byteOffset\": 80, \"byteLength\": 12}],"
                 "\"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\","
                 " \"min\": [0, 0, 0], \"max\": [1, 1, 0]},"
                 " {\"bufferView\": 1, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC2\"},"
                 " {\"bufferView\": 2, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"}]}",
                 cases[c].mode, sizeof buf);
        snprintf(path, sizeof path, "%s/%s.gltf", tu_dir, cases[c].name);
        assert_int_equal(tu_write_file(path, json), 0);
        check_file(cases[c].name, "gltf", PGI__MAT_LAMBERT, cases[c].masked, cases[c].expect);
    }
}

/* A masked object that moves (its own refitted geometry, src/rt/rt.c): the lattice of `cutout`
 * animated by 0.5 in x over 1 s, rendered by one renderer that updates its BVH. At t = 0 the
 * floor's direct light is the static scene's; at t = 0.5 the lattice has moved 3 whole periods
 * (the same light on the floor); at t = 1/12 half a period (another pattern, and the same open
 * fraction: a mean within 1%). */
static void test_animated_mask(void **state) {
    (void)state;
    char path[700];
    snprintf(path, sizeof path, "%s/moving.json", tu_dir);
    assert_int_equal(tu_write_file(path, "{\"builtin\": \"cutout\", \"animate\": [{\"material\": \"lattice\", "
                                         "\"motion\": {\"keyframes\": [{\"t\": 0}, {\"t\": 1, \"translate\": "
                                         "[0.5, 0, 0]}]}}]}"),
                     0);
    pgi_scene *s = tu_scene(path);
    pgi_renderer *r = tu_renderer(s);
    const pgi_render_desc d = floor_desc(PGI_OUTPUT_DIRECT, 1000);
    pgi_image a = {0}, b = {0}, c = {0};
    TU_CHECK_OK(pgi_renderer_render(r, &d, &a, NULL));
    TU_CHECK_OK(pgi_scene_set_time(s, 0.5));
    TU_CHECK_OK(pgi_renderer_render(r, &d, &b, NULL));
    TU_CHECK_OK(pgi_scene_set_time(s, 1.0 / 12.0));
    TU_CHECK_OK(pgi_renderer_render(r, &d, &c, NULL));
    double still = floor_mean(0, PGI_OUTPUT_DIRECT, 1000), ma = image_mean(&a), mc = image_mean(&c);
    size_t n = 3 * (size_t)a.width * a.height, changed = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        worst = fmax(worst, fabs(b.rgb[i] - a.rgb[i]));
        changed += fabsf(c.rgb[i] - a.rgb[i]) > 1e-3f;
    }
    fprintf(stderr,
            "  moving lattice: t = 0 %.6f (static %.6f), 3 periods on: worst pixel %g, half a period on: %zu of %zu "
            "values changed, mean %.6f\n",
            ma, still, worst, changed, n, mc);
    assert_true(fabs(ma / still - 1.0) < 1e-5);
    assert_true(worst < 1e-5);
    assert_true(changed > n / 4);
    assert_true(fabs(mc / ma - 1.0) < 0.01);
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_image_free(&c);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

int main(void) {
    const struct CMUnitTest scene[] = {
        cmocka_unit_test(test_primary_rays), cmocka_unit_test(test_direct_light), cmocka_unit_test(test_photons),
        cmocka_unit_test(test_path_tracer),  cmocka_unit_test(test_threads),
    };
    const struct CMUnitTest files[] = {
        cmocka_unit_test(test_mtl_map_d),
        cmocka_unit_test(test_gltf_mask),
        cmocka_unit_test(test_animated_mask),
    };
    int fails = cmocka_run_group_tests_name("cutout scene", scene, NULL, NULL);
    fails += cmocka_run_group_tests_name("masks from files", files, tu_dir_setup, tu_dir_teardown);
    return fails;
}
