/* Built-in scenes that need no files: the Cornell box (default), the Cornell
 * box with mirrors and glass, the GIRefScene and sphere_and_plane of the Cal
 * Poly project (papers/004), a cut-out test scene (a lattice mask), a room lit by the sky
 * through a window, and a room lit only through a doorway from a bright second room. */
#include <stdio.h>
#include <string.h>

#include "scene_internal.h"

const char *const pgi__builtin_names[] = {"cornell", "cornell-mirrors", "giref",     "sphere-and-plane",
                                          "cutout",  "window-box",      "two-rooms", NULL};

typedef struct {
    pgi_scene *s;
    size_t vcap, tcap;
    pgi_status st;
} builder;

static int grow(builder *b, size_t nv, size_t nt) {
    if (b->st) return 0;
    pgi_scene *s = b->s;
    if (s->nverts + nv > b->vcap) {
        size_t cap = (s->nverts + nv) * 2;
        float *p = realloc(s->pos, cap * 3 * sizeof *p), *n = p ? realloc(s->nrm, cap * 3 * sizeof *n) : NULL;
        if (p) s->pos = p;
        if (n) s->nrm = n;
        if (!p || !n) {
            b->st = pgi__fail(PGI_ERR_OOM, "out of memory building a scene");
            return 0;
        }
        b->vcap = cap;
    }
    if (s->ntris + nt > b->tcap) {
        size_t cap = (s->ntris + nt) * 2;
        uint32_t *t = realloc(s->tri, cap * 3 * sizeof *t), *m = t ? realloc(s->tri_mat, cap * sizeof *m) : NULL;
        if (t) s->tri = t;
        if (m) s->tri_mat = m;
        if (!t || !m) {
            b->st = pgi__fail(PGI_ERR_OOM, "out of memory building a scene");
            return 0;
        }
        b->tcap = cap;
    }
    return 1;
}

static uint32_t add_vertex(builder *b, pgi__v3 p, pgi__v3 n) {
    pgi_scene *s = b->s;
    v3_store(s->pos + 3 * s->nverts, p);
    v3_store(s->nrm + 3 * s->nverts, n);
    return (uint32_t)s->nverts++;
}

static void add_tri(builder *b, uint32_t a, uint32_t c, uint32_t d, uint32_t mat) {
    pgi_scene *s = b->s;
    s->tri[3 * s->ntris] = a;
    s->tri[3 * s->ntris + 1] = c;
    s->tri[3 * s->ntris + 2] = d;
    s->tri_mat[s->ntris++] = mat;
}

/* Quad a-b-c-d (counter-clockwise seen from the side the normal points to). */
static void add_quad(builder *b, pgi__v3 a, pgi__v3 c1, pgi__v3 c2, pgi__v3 d, uint32_t mat) {
    if (!grow(b, 4, 2)) return;
    pgi__v3 n = v3_norm(v3_cross(v3_sub(c1, a), v3_sub(d, a)));
    uint32_t i0 = add_vertex(b, a, n), i1 = add_vertex(b, c1, n), i2 = add_vertex(b, c2, n), i3 = add_vertex(b, d, n);
    add_tri(b, i0, i1, i2, mat);
    add_tri(b, i0, i2, i3, mat);
}

/* Axis-aligned box of half extents h, rotated by `deg` about y, resting on y = y0. */
static void add_box(builder *b, float cx, float y0, float cz, pgi__v3 h, float deg, uint32_t mat) {
    float a = deg * PGI__PI / 180.f, ca = cosf(a), sa = sinf(a);
    pgi__v3 P[8];
    for (int i = 0; i < 8; i++) {
        float x = (i & 1) ? h.x : -h.x, y = (i & 2) ? 2.f * h.y : 0.f, z = (i & 4) ? h.z : -h.z;
        P[i] = v3(cx + ca * x + sa * z, y0 + y, cz - sa * x + ca * z);
    }
    add_quad(b, P[0], P[4], P[6], P[2], mat); /* -x */
    add_quad(b, P[1], P[3], P[7], P[5], mat); /* +x */
    add_quad(b, P[0], P[1], P[5], P[4], mat); /* -y */
    add_quad(b, P[2], P[6], P[7], P[3], mat); /* +y */
    add_quad(b, P[0], P[2], P[3], P[1], mat); /* -z */
    add_quad(b, P[4], P[5], P[7], P[6], mat); /* +z */
}

static void add_sphere(builder *b, pgi__v3 c, float r, int slices, int stacks, uint32_t mat) {
    if (!grow(b, (size_t)(slices + 1) * (stacks + 1), (size_t)slices * stacks * 2)) return;
    uint32_t base = (uint32_t)b->s->nverts;
    for (int i = 0; i <= stacks; i++) {
        float th = PGI__PI * (float)i / (float)stacks;
        for (int j = 0; j <= slices; j++) {
            float ph = 2.f * PGI__PI * (float)j / (float)slices;
            pgi__v3 n = v3(sinf(th) * cosf(ph), cosf(th), sinf(th) * sinf(ph));
            add_vertex(b, v3_madd(c, n, r), n);
        }
    }
    for (int i = 0; i < stacks; i++)
        for (int j = 0; j < slices; j++) {
            uint32_t a = base + (uint32_t)(i * (slices + 1) + j), d = a + (uint32_t)(slices + 1);
            if (i > 0) add_tri(b, a, a + 1, d, mat);
            if (i < stacks - 1) add_tri(b, a + 1, d + 1, d, mat);
        }
}

static uint32_t add_mat(builder *b, const char *name, pgi__material_type type, pgi__v3 kd) {
    if (b->st) return 0;
    pgi_scene *s = b->s;
    pgi__material *m = realloc(s->mats, (s->nmats + 1) * sizeof *m);
    if (!m) {
        b->st = pgi__fail(PGI_ERR_OOM, "out of memory building a scene");
        return 0;
    }
    s->mats = m;
    m = &s->mats[s->nmats];
    memset(m, 0, sizeof *m);
    snprintf(m->name, sizeof m->name, "%s", name);
    m->type = type;
    v3_store(m->kd, kd);
    m->ior = 1.5f;
    m->tex_kd = -1;
    m->tex_alpha = -1;
    return (uint32_t)s->nmats++;
}

static void add_light(builder *b, pgi__light_type type, pgi__v3 pos, pgi__v3 color) {
    if (b->st) return;
    pgi_scene *s = b->s;
    pgi__light *l = realloc(s->lights, (s->nlights + 1) * sizeof *l);
    if (!l) {
        b->st = pgi__fail(PGI_ERR_OOM, "out of memory building a scene");
        return;
    }
    s->lights = l;
    l = &s->lights[s->nlights++];
    memset(l, 0, sizeof *l);
    l->type = type;
    v3_store(l->pos, pos);
    v3_store(l->color, color);
}

/* Appends a camera (the first one is the scene's default view). */
static void add_camera(builder *b, pgi__v3 eye, pgi__v3 at, pgi__v3 up, float fov) {
    if (b->st) return;
    pgi_camera_def *c = realloc(b->s->cams, (b->s->ncams + 1) * sizeof *c);
    if (!c) {
        b->st = pgi__fail(PGI_ERR_OOM, "out of memory building a scene");
        return;
    }
    b->s->cams = c;
    c += b->s->ncams++;
    memset(c, 0, sizeof *c);
    v3_store(c->eye, eye);
    v3_store(c->look_at, at);
    v3_store(c->up, up);
    c->fov_y_deg = fov;
}

static void set_camera(builder *b, pgi__v3 eye, pgi__v3 at, float fov) {
    add_camera(b, eye, at, v3(0.f, 1.f, 0.f), fov);
}

/* The classic box (McGuire's CornellBox-Original proportions and colours):
 * x in [-1, 1], y in [0, 2], z in [-1, 1], open towards +z, area light
 * (Ke 17 12 4) just under the ceiling. */
static void build_cornell(builder *b) {
    pgi__v3 white = v3(0.725f, 0.71f, 0.68f);
    uint32_t mw = add_mat(b, "white", PGI__MAT_LAMBERT, white);
    uint32_t mr = add_mat(b, "red", PGI__MAT_LAMBERT, v3(0.63f, 0.065f, 0.05f));
    uint32_t mg = add_mat(b, "green", PGI__MAT_LAMBERT, v3(0.14f, 0.45f, 0.091f));
    uint32_t ml = add_mat(b, "light", PGI__MAT_LAMBERT, v3(0.78f, 0.78f, 0.78f));
    if (!b->st) v3_store(b->s->mats[ml].ke, v3(17.f, 12.f, 4.f));
    add_quad(b, v3(-1, 0, -1), v3(-1, 0, 1), v3(1, 0, 1), v3(1, 0, -1), mw);   /* floor */
    add_quad(b, v3(-1, 2, -1), v3(1, 2, -1), v3(1, 2, 1), v3(-1, 2, 1), mw);   /* ceiling */
    add_quad(b, v3(-1, 0, -1), v3(1, 0, -1), v3(1, 2, -1), v3(-1, 2, -1), mw); /* back */
    add_quad(b, v3(-1, 0, -1), v3(-1, 2, -1), v3(-1, 2, 1), v3(-1, 0, 1), mr); /* left */
    add_quad(b, v3(1, 0, -1), v3(1, 0, 1), v3(1, 2, 1), v3(1, 2, -1), mg);     /* right */
    add_quad(b, v3(-0.24f, 1.98f, -0.22f), v3(0.23f, 1.98f, -0.22f), v3(0.23f, 1.98f, 0.16f), v3(-0.24f, 1.98f, 0.16f),
             ml);                                                    /* light, facing down */
    add_box(b, 0.33f, 0.f, 0.37f, v3(0.3f, 0.3f, 0.3f), -17.f, mw);  /* short block */
    add_box(b, -0.34f, 0.f, -0.28f, v3(0.3f, 0.6f, 0.3f), 17.f, mw); /* tall block */
    set_camera(b, v3(0.f, 1.f, 3.9f), v3(0.f, 1.f, 0.f), 39.f);
    b->s->defaults = (pgi_scene_defaults){200000, 0.05f, 4, 512, 512, 1.f};
}

/* The Cornell box with specular surfaces in view: a mirror over most of the
 * left wall, a mirror sphere in place of the tall block and a glass sphere on
 * the short block. About a third of the view samples are seen through them,
 * and the two spheres show the whole box in a few pixels: the case that
 * defeats screen-space bounds (estimator exactness tests, bench --scenes). */
static void build_cornell_mirrors(builder *b) {
    build_cornell(b);
    if (b->st) return;
    /* drop the tall block (the last box: 12 triangles) */
    b->s->ntris -= 12;
    b->s->nverts -= 24;
    uint32_t mm = add_mat(b, "mirror", PGI__MAT_MIRROR, v3(0.f, 0.f, 0.f));
    uint32_t mglass = add_mat(b, "glass", PGI__MAT_GLASS, v3(0.f, 0.f, 0.f));
    if (b->st) return;
    v3_store(b->s->mats[mm].ks, v3(0.9f, 0.9f, 0.9f));
    v3_store(b->s->mats[mglass].ks, v3(1.f, 1.f, 1.f));
    add_quad(b, v3(-0.99f, 0.1f, -0.95f), v3(-0.99f, 1.9f, -0.95f), v3(-0.99f, 1.9f, 0.95f), v3(-0.99f, 0.1f, 0.95f),
             mm);                                                  /* mirror over the left wall */
    add_sphere(b, v3(-0.3f, 0.45f, -0.35f), 0.45f, 64, 32, mm);    /* mirror sphere */
    add_sphere(b, v3(0.33f, 0.88f, 0.37f), 0.28f, 64, 32, mglass); /* glass sphere on the short block */
}

/* GIRefScene: a closed box of six planes, grey except the coloured left and
 * right walls, two spheres, a point light under the ceiling. */
static void build_giref(builder *b) {
    uint32_t mg = add_mat(b, "grey", PGI__MAT_LAMBERT, v3(0.7f, 0.7f, 0.7f));
    uint32_t mr = add_mat(b, "red", PGI__MAT_LAMBERT, v3(0.75f, 0.15f, 0.15f));
    uint32_t mb = add_mat(b, "blue", PGI__MAT_LAMBERT, v3(0.15f, 0.2f, 0.75f));
    uint32_t ms = add_mat(b, "sphere", PGI__MAT_LAMBERT, v3(0.8f, 0.8f, 0.8f));
    add_quad(b, v3(-5, 0, -5), v3(-5, 0, 5), v3(5, 0, 5), v3(5, 0, -5), mg);
    add_quad(b, v3(-5, 10, -5), v3(5, 10, -5), v3(5, 10, 5), v3(-5, 10, 5), mg);
    add_quad(b, v3(-5, 0, -5), v3(5, 0, -5), v3(5, 10, -5), v3(-5, 10, -5), mg);
    add_quad(b, v3(-5, 0, 5), v3(-5, 10, 5), v3(5, 10, 5), v3(5, 0, 5), mg);
    add_quad(b, v3(-5, 0, -5), v3(-5, 10, -5), v3(-5, 10, 5), v3(-5, 0, 5), mr);
    add_quad(b, v3(5, 0, -5), v3(5, 0, 5), v3(5, 10, 5), v3(5, 10, -5), mb);
    add_sphere(b, v3(-2.f, 2.f, -1.5f), 2.f, 64, 32, ms);
    add_sphere(b, v3(2.5f, 1.5f, 1.f), 1.5f, 64, 32, ms);
    add_light(b, PGI__LIGHT_POINT, v3(0.f, 9.5f, 0.f), v3(60.f, 60.f, 60.f));
    set_camera(b, v3(0.f, 5.f, 4.9f), v3(0.f, 4.f, 0.f), 65.f);
    b->s->defaults = (pgi_scene_defaults){200000, 0.25f, 4, 640, 480, 1.f};
}

/* sphere_and_plane: a point light, a sphere, a ground plane; half the view is
 * empty sky. The light sits low and close to the sphere: most light leaves an
 * open scene, and a photon is stored from its second hit on, so a light 4
 * above the plane stored one photon per 87 paths, past the tracer's limit of
 * 64 paths per requested photon (its defaults warned that photons were
 * missing); here about one per 28. */
static void build_sphere_and_plane(builder *b) {
    uint32_t mp = add_mat(b, "plane", PGI__MAT_LAMBERT, v3(0.7f, 0.7f, 0.7f));
    uint32_t ms = add_mat(b, "sphere", PGI__MAT_LAMBERT, v3(0.8f, 0.3f, 0.2f));
    add_quad(b, v3(-20, 0, -20), v3(-20, 0, 20), v3(20, 0, 20), v3(20, 0, -20), mp);
    add_sphere(b, v3(0.f, 1.f, 0.f), 1.f, 64, 32, ms);
    add_light(b, PGI__LIGHT_POINT, v3(1.5f, 2.f, 1.5f), v3(12.f, 12.f, 12.f));
    set_camera(b, v3(0.f, 2.5f, 7.f), v3(0.f, 0.8f, 0.f), 50.f);
    b->s->defaults = (pgi_scene_defaults){200000, 0.1f, 4, 640, 480, 1.f};
}

/* cutout: a lattice mask (PGI__CUTOUT_* in scene_internal.h) at y = 1 over a white floor at
 * y = 0, x, z in [-1, 1]; black walls close the space between them, so that light reaches
 * the floor only through the mask; a point light at y = 1.5 and a white ceiling at y = 2
 * above it (light reflected by the ceiling reaches the floor through the mask too: stored
 * photons). The mask and the walls are black, so with one bounce the light on the floor is
 * exactly linear in the open fraction of the mask. Cameras: 0 a view from the front; 1 inside,
 * at y = 0.9 straight down onto the floor's [-0.5, 0.5]^2 (the point light projects the
 * mask onto the floor magnified 3 times: that square is the shadow of 4 x 4 lattice periods,
 * 16 pixels each at 64 x 64); 2 above the mask at y = 1.9 straight down onto its
 * [-0.5, 0.5]^2 (12 x 12 periods: 96 x 96 pixels put one pixel centre on each texel centre). */
static void build_cutout(builder *b) {
    uint32_t mf = add_mat(b, "floor", PGI__MAT_LAMBERT, v3(0.8f, 0.8f, 0.8f));
    uint32_t mc = add_mat(b, "ceiling", PGI__MAT_LAMBERT, v3(0.8f, 0.8f, 0.8f));
    uint32_t mb = add_mat(b, "black", PGI__MAT_LAMBERT, v3(0.f, 0.f, 0.f));
    uint32_t mm = add_mat(b, "lattice", PGI__MAT_LAMBERT, v3(0.f, 0.f, 0.f));
    add_quad(b, v3(-1, 0, -1), v3(-1, 0, 1), v3(1, 0, 1), v3(1, 0, -1), mf);   /* floor, facing up */
    add_quad(b, v3(-1, 2, -1), v3(1, 2, -1), v3(1, 2, 1), v3(-1, 2, 1), mc);   /* ceiling, facing down */
    add_quad(b, v3(-1, 0, -1), v3(1, 0, -1), v3(1, 1, -1), v3(-1, 1, -1), mb); /* walls under the mask */
    add_quad(b, v3(-1, 0, 1), v3(-1, 1, 1), v3(1, 1, 1), v3(1, 0, 1), mb);
    add_quad(b, v3(-1, 0, -1), v3(-1, 1, -1), v3(-1, 1, 1), v3(-1, 0, 1), mb);
    add_quad(b, v3(1, 0, -1), v3(1, 0, 1), v3(1, 1, 1), v3(1, 1, -1), mb);
    const size_t v0 = b->s->nverts;
    add_quad(b, v3(-1, 1, -1), v3(-1, 1, 1), v3(1, 1, 1), v3(1, 1, -1), mm); /* the mask, facing up */
    if (b->st) return;
    pgi_scene *s = b->s;
    /* u = (x + 1) / 2, v = (z + 1) / 2 on the mask; 0 elsewhere. */
    s->uv = calloc(2 * s->nverts, sizeof *s->uv);
    const int n = PGI__CUTOUT_TEXELS;
    unsigned char *rgba = malloc(4 * (size_t)n * n);
    if (!s->uv || !rgba) {
        free(rgba);
        b->st = pgi__fail(PGI_ERR_OOM, "out of memory building a scene");
        return;
    }
    for (size_t v = v0; v < v0 + 4; v++) {
        s->uv[2 * v] = 0.5f * (s->pos[3 * v] + 1.f);
        s->uv[2 * v + 1] = 0.5f * (s->pos[3 * v + 2] + 1.f);
    }
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            unsigned char *p = rgba + 4 * ((size_t)y * n + x);
            p[0] = p[1] = p[2] = 255;
            p[3] = pgi__cutout_open(x, y) ? 0 : 255;
        }
    int tex;
    if ((b->st = pgi__scene_add_texture(s, n, n, 4, rgba, "cutout:lattice", &tex))) return;
    s->mats[mm].tex_alpha = tex;
    s->mats[mm].alpha_cutoff = 0.5f;
    add_light(b, PGI__LIGHT_POINT, v3(0.f, 1.5f, 0.f), v3(4.5f, 4.5f, 4.5f));
    const float fov = 2.f * atanf(0.5f / 0.9f) * 180.f / PGI__PI; /* [-0.5, 0.5]^2 at distance 0.9 */
    add_camera(b, v3(0.f, 1.95f, 1.5f), v3(0.f, 0.f, -0.4f), v3(0.f, 1.f, 0.f), 60.f);
    add_camera(b, v3(0.f, 0.9f, 0.f), v3(0.f, 0.f, 0.f), v3(0.f, 0.f, -1.f), fov);
    add_camera(b, v3(0.f, 1.9f, 0.f), v3(0.f, 0.f, 0.f), v3(0.f, 0.f, -1.f), fov);
    s->defaults = (pgi_scene_defaults){200000, 0.02f, 4, 640, 480, 1.f};
}

/* Quads of the rectangle [a0, a1] x [b0, b1] (coordinates along the axes ea, eb of a plane
 * through `o`) around the hole [h0, h1] (a0 <= h0 < h1 <= a1 along each): four quads, wound
 * so that their normal is ea x eb. */
static void add_wall_with_hole(builder *b, pgi__v3 o, pgi__v3 ea, pgi__v3 eb, const float a[2], const float bb[2],
                               const float ha[2], const float hb[2], uint32_t mat) {
    const float r[4][4] = {{a[0], a[1], bb[0], hb[0]},   /* below the hole */
                           {a[0], a[1], hb[1], bb[1]},   /* above */
                           {a[0], ha[0], hb[0], hb[1]},  /* left of it */
                           {ha[1], a[1], hb[0], hb[1]}}; /* right of it */
    for (int k = 0; k < 4; k++) {
        if (!(r[k][1] > r[k][0] && r[k][3] > r[k][2])) continue;
        pgi__v3 p00 = v3_add(o, v3_add(v3_scale(ea, r[k][0]), v3_scale(eb, r[k][2])));
        pgi__v3 p10 = v3_add(o, v3_add(v3_scale(ea, r[k][1]), v3_scale(eb, r[k][2])));
        pgi__v3 p11 = v3_add(o, v3_add(v3_scale(ea, r[k][1]), v3_scale(eb, r[k][3])));
        pgi__v3 p01 = v3_add(o, v3_add(v3_scale(ea, r[k][0]), v3_scale(eb, r[k][3])));
        add_quad(b, p00, p10, p11, p01, mat);
    }
}

/* window-box: a closed room x in [-1, 1], y in [0, 2], z in [-1, 1] (zero-thickness
 * Lambertian walls) with two openings, a window in the left wall (x = -1, y in [0.7, 1.5],
 * z in [-0.7, 0.1]) and a skylight in the ceiling (x, z in [-0.1, 0.5] x [-0.5, 0.1]), a
 * block on the floor, under a uniform sky of radiance (0.6, 0.75, 1.0) and no other light:
 * daylight through openings (direct light to infinity, photons from the sky) and the sky
 * seen through the window. Needs no files (tests of the sky light). */
static void build_window_box(builder *b) {
    uint32_t mw = add_mat(b, "white", PGI__MAT_LAMBERT, v3(0.7f, 0.7f, 0.7f));
    uint32_t mf = add_mat(b, "floor", PGI__MAT_LAMBERT, v3(0.6f, 0.5f, 0.4f));
    uint32_t mr = add_mat(b, "red", PGI__MAT_LAMBERT, v3(0.63f, 0.065f, 0.05f));
    uint32_t mb = add_mat(b, "block", PGI__MAT_LAMBERT, v3(0.5f, 0.6f, 0.7f));
    add_quad(b, v3(-1, 0, -1), v3(-1, 0, 1), v3(1, 0, 1), v3(1, 0, -1), mf);   /* floor */
    add_quad(b, v3(-1, 0, -1), v3(1, 0, -1), v3(1, 2, -1), v3(-1, 2, -1), mw); /* back */
    add_quad(b, v3(-1, 0, 1), v3(-1, 2, 1), v3(1, 2, 1), v3(1, 0, 1), mw);     /* front, behind the camera */
    add_quad(b, v3(1, 0, -1), v3(1, 0, 1), v3(1, 2, 1), v3(1, 2, -1), mr);     /* right */
    /* left wall (ea = +z, eb = +y) with the window */
    add_wall_with_hole(b, v3(-1, 0, 0), v3(0, 0, 1), v3(0, 1, 0), (const float[2]){-1.f, 1.f},
                       (const float[2]){0.f, 2.f}, (const float[2]){-0.7f, 0.1f}, (const float[2]){0.7f, 1.5f}, mw);
    /* ceiling (ea = +z, eb = +x) with the skylight */
    add_wall_with_hole(b, v3(0, 2, 0), v3(0, 0, 1), v3(1, 0, 0), (const float[2]){-1.f, 1.f},
                       (const float[2]){-1.f, 1.f}, (const float[2]){-0.5f, 0.1f}, (const float[2]){-0.1f, 0.5f}, mw);
    add_box(b, 0.35f, 0.f, -0.3f, v3(0.25f, 0.35f, 0.25f), 20.f, mb);
    set_camera(b, v3(0.3f, 1.f, 0.95f), v3(-0.2f, 0.9f, -1.f), 70.f);
    if (b->st) return;
    const float sky[3] = {0.6f, 0.75f, 1.f}, up[3] = {0.f, 1.f, 0.f};
    b->st = pgi__env_create_constant("window-box", sky, sky, up, &b->s->env);
    b->s->defaults = (pgi_scene_defaults){200000, 0.03f, 4, 512, 384, 2.f};
}

/* two-rooms: two closed rooms side by side, y in [0, 2.5], z in [-2, 2]: a bright one, x in
 * [-4, 0], with an area light under its ceiling (x in [-2.6, -1.4], z in [-0.5, 0.5]), and a
 * dark one, x in [0, 4], lit only through a doorway in the shared wall (z in [-0.45, 0.45], y
 * below 1.9). The camera stands in the dark room by the doorway's wall and looks into it, away
 * from the light: what it sees is lit by the few photons that find the doorway (the test scene
 * of view-importance emission, docs/emission.md). Zero-thickness Lambertian walls. */
static void build_two_rooms(builder *b) {
    uint32_t mw = add_mat(b, "white", PGI__MAT_LAMBERT, v3(0.75f, 0.75f, 0.75f));
    uint32_t mf = add_mat(b, "floor", PGI__MAT_LAMBERT, v3(0.6f, 0.5f, 0.4f));
    uint32_t mr = add_mat(b, "red", PGI__MAT_LAMBERT, v3(0.63f, 0.065f, 0.05f));
    uint32_t mg = add_mat(b, "green", PGI__MAT_LAMBERT, v3(0.14f, 0.45f, 0.091f));
    uint32_t mb = add_mat(b, "block", PGI__MAT_LAMBERT, v3(0.5f, 0.6f, 0.7f));
    uint32_t ml = add_mat(b, "light", PGI__MAT_LAMBERT, v3(0.78f, 0.78f, 0.78f));
    if (!b->st) v3_store(b->s->mats[ml].ke, v3(40.f, 36.f, 30.f));
    add_quad(b, v3(-4, 0, -2), v3(-4, 0, 2), v3(4, 0, 2), v3(4, 0, -2), mf);             /* floor */
    add_quad(b, v3(-4, 2.5f, -2), v3(4, 2.5f, -2), v3(4, 2.5f, 2), v3(-4, 2.5f, 2), mw); /* ceiling */
    add_quad(b, v3(-4, 0, -2), v3(4, 0, -2), v3(4, 2.5f, -2), v3(-4, 2.5f, -2), mw);     /* back (-z) */
    add_quad(b, v3(-4, 0, 2), v3(-4, 2.5f, 2), v3(4, 2.5f, 2), v3(4, 0, 2), mw);         /* front (+z) */
    add_quad(b, v3(-4, 0, -2), v3(-4, 2.5f, -2), v3(-4, 2.5f, 2), v3(-4, 0, 2), mr);     /* bright room's end */
    add_quad(b, v3(4, 0, -2), v3(4, 0, 2), v3(4, 2.5f, 2), v3(4, 2.5f, -2), mg);         /* dark room's end */
    /* the shared wall x = 0 (ea = +z, eb = +y) with the doorway */
    add_wall_with_hole(b, v3(0, 0, 0), v3(0, 0, 1), v3(0, 1, 0), (const float[2]){-2.f, 2.f},
                       (const float[2]){0.f, 2.5f}, (const float[2]){-0.45f, 0.45f}, (const float[2]){0.f, 1.9f}, mw);
    add_quad(b, v3(-2.6f, 2.49f, -0.5f), v3(-1.4f, 2.49f, -0.5f), v3(-1.4f, 2.49f, 0.5f), v3(-2.6f, 2.49f, 0.5f),
             ml);                                                 /* light, facing down */
    add_box(b, 2.4f, 0.f, -0.8f, v3(0.4f, 0.5f, 0.4f), 25.f, mb); /* a block in the dark room */
    add_box(b, -2.f, 0.f, 1.f, v3(0.4f, 0.4f, 0.4f), -15.f, mw);  /* and one in the bright room */
    set_camera(b, v3(1.f, 1.3f, 1.8f), v3(3.2f, 0.7f, -1.2f), 60.f);
    b->s->defaults = (pgi_scene_defaults){200000, 0.f, 4, 640, 360, 1.f};
}

pgi_status pgi__scene_builtin(const char *name, pgi_scene **out) {
    *out = NULL;
    void (*fn)(builder *) = NULL;
    if (strcmp(name, "cornell") == 0) fn = build_cornell;
    else if (strcmp(name, "cornell-mirrors") == 0) fn = build_cornell_mirrors;
    else if (strcmp(name, "giref") == 0) fn = build_giref;
    else if (strcmp(name, "sphere-and-plane") == 0) fn = build_sphere_and_plane;
    else if (strcmp(name, "cutout") == 0) fn = build_cutout;
    else if (strcmp(name, "window-box") == 0) fn = build_window_box;
    else if (strcmp(name, "two-rooms") == 0) fn = build_two_rooms;
    if (!fn) return pgi__fail(PGI_ERR_INVALID_ARG, "no built-in scene named '%s'", name);
    builder b = {0};
    pgi_status st = pgi__scene_new(name, &b.s);
    if (st) return st;
    fn(&b);
    st = b.st ? b.st : pgi__scene_finalize(b.s, name);
    if (st) {
        pgi_scene_destroy(b.s);
        return st;
    }
    *out = b.s;
    return PGI_OK;
}
