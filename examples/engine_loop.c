/* An engine's frame loop on photongi's public API: the scene handed over as arrays (no file), a
 * mesh moved every frame, a light changed, the camera given as view and projection matrices with
 * a TAA sub-pixel jitter, and the AOVs (albedo, normal, depth, direct, indirect) read back for a
 * denoiser.
 *
 *   engine_loop [OUT.png [WIDTHxHEIGHT [FRAMES]]]
 *
 * Writes the last frame to OUT.png (default engine_loop.png, 320x240, 4 frames) and prints a
 * line a frame. Build it against an installed photongi:
 *   cc engine_loop.c $(pkg-config --cflags --libs photongi) -lm -o engine_loop */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <photongi/photongi.h>

static int fail(const char *what, pgi_status s) {
    fprintf(stderr, "engine_loop: %s: %s: %s\n", what, pgi_status_string(s), pgi_last_error());
    return 1;
}

/* ------------------------------------------------------------ the engine's side */

typedef struct mesh {
    float pos[3 * 64], nrm[3 * 64];
    uint32_t idx[3 * 32], mat[32];
    uint32_t nv, nt;
} mesh;

/* A quad (counter-clockwise seen from its front) with its own 4 vertices. */
static void quad(mesh *m, const float p[4][3], uint32_t mat) {
    float e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++) e1[k] = p[1][k] - p[0][k], e2[k] = p[2][k] - p[0][k];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const uint32_t v = m->nv;
    for (int k = 0; k < 4; k++, m->nv++) {
        memcpy(m->pos + 3 * m->nv, p[k], sizeof p[k]);
        memcpy(m->nrm + 3 * m->nv, n, sizeof n); /* photongi normalises them */
    }
    const uint32_t t[6] = {v, v + 1, v + 2, v, v + 2, v + 3};
    memcpy(m->idx + 3 * m->nt, t, sizeof t);
    m->mat[m->nt++] = mat;
    m->mat[m->nt++] = mat;
}

/* A cube of half-size h at c, turned by `angle` about y (the animated mesh). */
static void cube(mesh *m, const float c[3], float h, float angle, uint32_t mat) {
    static const int f[6][4][3] = {{{-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1}},
                                   {{1, -1, -1}, {-1, -1, -1}, {-1, 1, -1}, {1, 1, -1}},
                                   {{1, -1, 1}, {1, -1, -1}, {1, 1, -1}, {1, 1, 1}},
                                   {{-1, -1, -1}, {-1, -1, 1}, {-1, 1, 1}, {-1, 1, -1}},
                                   {{-1, 1, 1}, {1, 1, 1}, {1, 1, -1}, {-1, 1, -1}},
                                   {{-1, -1, -1}, {1, -1, -1}, {1, -1, 1}, {-1, -1, 1}}};
    const float cs = cosf(angle), sn = sinf(angle);
    m->nv = m->nt = 0;
    for (int i = 0; i < 6; i++) {
        float p[4][3];
        for (int k = 0; k < 4; k++) {
            const float x = h * (float)f[i][k][0], y = h * (float)f[i][k][1], z = h * (float)f[i][k][2];
            p[k][0] = c[0] + cs * x + sn * z;
            p[k][1] = c[1] + y;
            p[k][2] = c[2] - sn * x + cs * z;
        }
        quad(m, (const float(*)[3])p, mat);
    }
}

/* The camera as an engine keeps it: a view matrix (world to camera, looking down -z) and an
 * OpenGL perspective projection, column-major. */
static void look_at(const float e[3], const float t[3], float V[16]) {
    float f[3] = {t[0] - e[0], t[1] - e[1], t[2] - e[2]}, up[3] = {0.f, 1.f, 0.f}, s[3], u[3];
    float l = sqrtf(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    for (int k = 0; k < 3; k++) f[k] /= l;
    s[0] = f[1] * up[2] - f[2] * up[1], s[1] = f[2] * up[0] - f[0] * up[2], s[2] = f[0] * up[1] - f[1] * up[0];
    l = sqrtf(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    for (int k = 0; k < 3; k++) s[k] /= l;
    u[0] = s[1] * f[2] - s[2] * f[1], u[1] = s[2] * f[0] - s[0] * f[2], u[2] = s[0] * f[1] - s[1] * f[0];
    memset(V, 0, 16 * sizeof *V);
    for (int k = 0; k < 3; k++) V[4 * k] = s[k], V[4 * k + 1] = u[k], V[4 * k + 2] = -f[k];
    V[12] = -(s[0] * e[0] + s[1] * e[1] + s[2] * e[2]);
    V[13] = -(u[0] * e[0] + u[1] * e[1] + u[2] * e[2]);
    V[14] = f[0] * e[0] + f[1] * e[1] + f[2] * e[2];
    V[15] = 1.f;
}

static void perspective(float fov_y_deg, int w, int h, float P[16]) {
    const float t = tanf(fov_y_deg * 3.14159265f / 360.f), zn = 0.05f, zf = 50.f;
    memset(P, 0, 16 * sizeof *P);
    P[0] = 1.f / (t * (float)w / (float)h);
    P[5] = 1.f / t;
    P[10] = -(zf + zn) / (zf - zn);
    P[11] = -1.f;
    P[14] = -2.f * zf * zn / (zf - zn);
}

/* Halton (2, 3) point k in (-0.5, 0.5): a TAA jitter sequence. */
static float halton(int k, int b) {
    float f = 1.f, r = 0.f;
    for (int i = k + 1; i > 0; i /= b) f /= (float)b, r += f * (float)(i % b);
    return r - 0.5f;
}

int main(int argc, char **argv) {
    const char *out = argc > 1 ? argv[1] : "engine_loop.png";
    int width = 320, height = 240, frames = 4;
    if ((argc > 2 && (sscanf(argv[2], "%dx%d", &width, &height) != 2 || width < 1 || height < 1)) ||
        (argc > 3 && (sscanf(argv[3], "%d", &frames) != 1 || frames < 1)) || argc > 4) {
        fprintf(stderr, "usage: engine_loop [OUT.png [WIDTHxHEIGHT [FRAMES]]]\n");
        return 2;
    }

    /* The room (static) and a cube (dynamic: moved every frame). */
    enum { WHITE, RED, GREEN, CUBE, PANEL };
    const pgi_material_desc mats[] = {
        {.name = "white", .diffuse = {0.75f, 0.75f, 0.75f}},
        {.name = "red", .diffuse = {0.7f, 0.1f, 0.1f}},
        {.name = "green", .diffuse = {0.1f, 0.6f, 0.1f}},
        {.name = "cube",
         .type = PGI_MATERIAL_PLASTIC,
         .diffuse = {0.2f, 0.3f, 0.7f},
         .specular = {0.04f, 0.04f, 0.04f},
         .shininess = 200.f},
        {.name = "panel", .emission = {6.f, 6.f, 6.f}},
    };
    static mesh room, box;
    quad(&room, (const float[4][3]){{-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}}, WHITE);   /* floor */
    quad(&room, (const float[4][3]){{-1, 2, -1}, {1, 2, -1}, {1, 2, 1}, {-1, 2, 1}}, WHITE);   /* ceiling */
    quad(&room, (const float[4][3]){{-1, 0, -1}, {1, 0, -1}, {1, 2, -1}, {-1, 2, -1}}, WHITE); /* back */
    quad(&room, (const float[4][3]){{-1, 0, 1}, {-1, 0, -1}, {-1, 2, -1}, {-1, 2, 1}}, RED);   /* left */
    quad(&room, (const float[4][3]){{1, 0, -1}, {1, 0, 1}, {1, 2, 1}, {1, 2, -1}}, GREEN);     /* right */
    quad(&room,
         (const float[4][3]){{-0.3f, 1.99f, -0.3f}, {0.3f, 1.99f, -0.3f}, {0.3f, 1.99f, 0.3f}, {-0.3f, 1.99f, 0.3f}},
         PANEL);
    const float centre[3] = {0.2f, 0.35f, -0.1f};
    cube(&box, centre, 0.3f, 0.f, CUBE);
    const pgi_mesh_desc meshes[] = {
        {.vertex_count = room.nv,
         .positions = room.pos,
         .normals = room.nrm,
         .triangle_count = room.nt,
         .indices = room.idx,
         .materials = room.mat},
        {.vertex_count = box.nv,
         .positions = box.pos,
         .normals = box.nrm,
         .triangle_count = box.nt,
         .indices = box.idx,
         .material = CUBE,
         .dynamic = 1},
    };
    const pgi_light_desc lamp = {.kind = PGI_LIGHT_KIND_POINT, .position = {-0.5f, 1.5f, 0.5f}, .intensity = 0.5f};
    const pgi_scene_desc sd = {.name = "engine room",
                               .meshes = meshes,
                               .mesh_count = 2,
                               .materials = mats,
                               .material_count = sizeof mats / sizeof mats[0],
                               .lights = &lamp,
                               .light_count = 1};
    pgi_scene *scene;
    pgi_status s = pgi_scene_create(&sd, &scene);
    if (s != PGI_OK) return fail("creating the scene", s);
    pgi_renderer *r;
    if ((s = pgi_renderer_create(scene, &r)) != PGI_OK) {
        pgi_scene_destroy(scene);
        return fail("creating the renderer", s);
    }

    const size_t n = (size_t)width * (size_t)height;
    float *buf = malloc(13 * n * sizeof(float));
    if (!buf) {
        fprintf(stderr, "engine_loop: out of memory\n");
        return 1;
    }
    pgi_aovs aovs = {.albedo = buf,
                     .normal = buf + 3 * n,
                     .depth = buf + 6 * n,
                     .direct = buf + 7 * n,
                     .indirect = buf + 10 * n};
    pgi_image img = {0};
    pgi_camera_def cam;
    pgi_render_desc desc =
        {.photons = 50000, .radius = 0.05f, .width = width, .height = height, .view = &cam, .aovs = &aovs};
    for (int f = 0; f < frames && s == PGI_OK; f++) {
        /* the engine's updates: the cube turns, the lamp warms up and dims */
        cube(&box, centre, 0.3f, 0.3f * (float)f, CUBE);
        s = pgi_scene_update_positions(scene, 1, box.pos, box.nrm, box.nv);
        pgi_light_desc l;
        if (s == PGI_OK) s = pgi_scene_get_light(scene, 0, &l);
        if (s == PGI_OK) {
            l.color[0] = 1.f, l.color[1] = 0.9f - 0.1f * (float)f, l.color[2] = 0.8f - 0.15f * (float)f;
            l.intensity = 0.5f / (float)(f + 1);
            s = pgi_scene_set_light(scene, 0, &l);
        }
        /* the camera from its matrices, jittered for TAA */
        float V[16], P[16];
        look_at((const float[3]){0.3f * sinf(0.2f * (float)f), 1.f, 3.4f}, (const float[3]){0.f, 0.9f, 0.f}, V);
        perspective(45.f, width, height, P);
        P[8] = 2.f * halton(f, 2) / (float)width; /* NDC offsets of the jitter */
        P[9] = 2.f * halton(f, 3) / (float)height;
        if (s == PGI_OK) s = pgi_camera_from_matrices(V, P, width, height, &cam, desc.shift);
        pgi_frame_stats st;
        if (s == PGI_OK) s = pgi_renderer_render(r, &desc, &img, &st);
        if (s != PGI_OK) break;
        /* what a denoiser would read: here, a few numbers */
        double depth = 0.0, direct = 0.0, indirect = 0.0;
        size_t hits = 0;
        for (size_t i = 0; i < n; i++) {
            if (aovs.depth[i] > 0.f) hits++, depth += aovs.depth[i];
            direct += aovs.direct[3 * i + 1];
            indirect += aovs.indirect[3 * i + 1];
        }
        printf("frame %d: %.1f ms (BVH update %.2f ms), %zu of %zu pixels hit, mean depth %.3f, green direct %.4f "
               "indirect %.4f\n",
               f, st.total_ms, st.rt_update_ms, hits, n, hits ? depth / (double)hits : 0.0, direct / (double)n,
               indirect / (double)n);
    }
    if (s == PGI_OK) s = pgi_image_write(&img, out, 1.0f);
    if (s == PGI_OK) printf("engine_loop: photongi %s, %d frames -> %s\n", pgi_version(), frames, out);
    free(buf);
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
    return s == PGI_OK ? 0 : fail("the frame loop", s);
}
