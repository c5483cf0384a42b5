/* Scenes written to a temporary folder, shared by several tests (header only;
 * include after test_util.h).
 *
 * The furnace (docs/design.md, "Reference path tracer"): a 128x64 UV sphere of radius 1 around the
 * origin (flat faces), Lambertian albedo FURNACE_RHO, a point light of
 * intensity FURNACE_I at the centre, the camera at the centre looking along
 * +x. Use tu_furnace_setup / tu_furnace_teardown as a cmocka group's
 * setup/teardown; the scene description is then tu_furnace_json. */
#ifndef PGI__TEST_SCENES_H
#define PGI__TEST_SCENES_H

#include "test_util.h"

#define FURNACE_RHO 0.5
#define FURNACE_I 2.0 /* W/sr; R = 1, so E0 = I / R^2 = 2 W/m^2 */

static char tu_furnace_dir[512];
static char tu_furnace_json[600];

static inline int tu_furnace_setup(void **state) {
    (void)state;
    const double pi = 3.14159265358979323846;
    tu_make_tmpdir(tu_furnace_dir, sizeof tu_furnace_dir);
    char path[700];
    snprintf(path, sizeof path, "%s/sphere.mtl", tu_furnace_dir);
    if (tu_write_file(path, "newmtl white\nKa 0 0 0\nKd 0.5 0.5 0.5\nKs 0 0 0\nNs 0\nillum 1\n")) return -1;
    const int nu = 128, nv = 64;
    size_t cap = 64u * (size_t)(nu * (nv + 1) + 2 * nu * nv) + 256;
    char *obj = malloc(cap);
    size_t len = (size_t)snprintf(obj, cap, "mtllib sphere.mtl\no sphere\nusemtl white\n");
    for (int j = 0; j <= nv; j++) {
        double th = pi * j / nv;
        for (int i = 0; i < nu; i++) {
            double ph = 2.0 * pi * i / nu;
            len += (size_t)snprintf(obj + len, cap - len, "v %.9f %.9f %.9f\n", sin(th) * cos(ph), sin(th) * sin(ph),
                                    cos(th));
        }
    }
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            int a = j * nu + i + 1, b = j * nu + (i + 1) % nu + 1, c = a + nu, d = b + nu;
            if (j > 0) len += (size_t)snprintf(obj + len, cap - len, "f %d %d %d\n", a, b, d);
            if (j < nv - 1) len += (size_t)snprintf(obj + len, cap - len, "f %d %d %d\n", a, d, c);
        }
    snprintf(path, sizeof path, "%s/sphere.obj", tu_furnace_dir);
    int rc = tu_write_file(path, obj);
    free(obj);
    if (rc) return -1;
    char json[2048];
    snprintf(json, sizeof json,
             "{\n  \"name\": \"furnace\",\n  \"mesh\": \"%s\",\n"
             "  \"camera\": {\"eye\": [0, 0, 0], \"look_at\": [1, 0, 0], \"up\": [0, 0, 1], \"fov_y\": 60},\n"
             "  \"lights\": [{\"type\": \"point\", \"position\": [0, 0, 0], \"intensity\": [%g, %g, %g]}]\n}\n",
             path, FURNACE_I, FURNACE_I, FURNACE_I);
    snprintf(tu_furnace_json, sizeof tu_furnace_json, "%s/furnace.json", tu_furnace_dir);
    return tu_write_file(tu_furnace_json, json);
}

static inline int tu_furnace_teardown(void **state) {
    (void)state;
    tu_rm_tmpdir(tu_furnace_dir);
    return 0;
}

#endif
