/* Internal scene model: one merged triangle mesh, materials, textures,
 * lights and cameras. Loaders (built-in, Assimp, JSON description) fill it;
 * rt/, photon/ and view/ read it. */
#ifndef PGI_SCENE_INTERNAL_H
#define PGI_SCENE_INTERNAL_H

#include "core/core.h"

typedef enum pgi_material_type {
    PGI_MAT_LAMBERT = 0,   /* kd / pi */
    PGI_MAT_PHONG = 1,     /* energy-conserving Blinn-Phong, tiled paper eqs. 6-8 */
    PGI_MAT_MIRROR = 2,    /* perfect mirror, reflectance ks */
    PGI_MAT_GLASS = 3      /* dielectric with Fresnel, index ior, tint ks */
} pgi_material_type;

typedef struct pgi_material {
    char name[64];
    pgi_material_type type;
    float kd[3];         /* diffuse albedo (multiplied by the texture if any) */
    float ks[3];         /* Phong: F0; mirror: reflectance; glass: transmission tint */
    float shininess;     /* Phong exponent s (MTL Ns) */
    float ior;           /* glass: MTL Ni */
    float ke[3];         /* emitted radiance (MTL Ke); non-zero makes the triangles area lights */
    int tex_kd;          /* index into scene textures, -1 if none */
} pgi_material;

/* 8-bit sRGB texture; lookups return linear RGB. */
typedef struct pgi_texture {
    int width, height;
    unsigned char *rgba;   /* 4 bytes a texel, row 0 is the top of the image */
    char path[512];
} pgi_texture;

typedef enum pgi_light_type {
    PGI_LIGHT_POINT = 0,   /* intensity I (W/sr), power 4 pi I */
    PGI_LIGHT_SPOT = 1,    /* intensity I inside the cone cos(theta) >= cos_cutoff */
    PGI_LIGHT_SUN = 2,     /* irradiance E (W/m^2) on surfaces facing -dir */
    PGI_LIGHT_AREA = 3     /* one emissive triangle, one-sided Lambertian, radiance Le */
} pgi_light_type;

typedef struct pgi_light {
    pgi_light_type type;
    float pos[3];          /* point/spot */
    float dir[3];          /* spot: axis; sun: direction light travels (unit) */
    float color[3];        /* I (point/spot), E (sun), Le (area) */
    float cos_cutoff;      /* spot */
    uint32_t tri;          /* area: triangle index */
    float area;            /* area: triangle area */
    float normal[3];       /* area: unit emitting normal */
    float power[3];        /* computed by pgi__scene_finalize */
} pgi_light;

struct pgi_scene {
    char name[128];
    char source[1024];
    size_t nverts, ntris;
    float *pos;            /* 3 per vertex */
    float *nrm;            /* 3 per vertex, or NULL (flat shading) */
    float *uv;             /* 2 per vertex, or NULL */
    uint32_t *tri;         /* 3 vertex indices per triangle */
    uint32_t *tri_mat;     /* material per triangle */
    pgi_material *mats;
    size_t nmats;
    pgi_texture *texs;
    size_t ntexs;
    pgi_light *lights;
    size_t nlights;
    pgi_camera_def *cams;
    size_t ncams;
    pgi_scene_defaults defaults;
    float bmin[3], bmax[3];
};

/* Allocates an empty scene (all zero, name set). */
pgi_status pgi__scene_new(const char *name, pgi_scene **out);
/* After geometry, materials and explicit lights are in: validates (indices
 * in range, finite numbers), computes bounds, adds one area light per
 * emissive triangle, computes light powers, adds a default camera when none
 * was given. Returns PGI_ERR_PARSE with a message naming `what` on bad data. */
pgi_status pgi__scene_finalize(pgi_scene *s, const char *what);

/* Built-in scenes (builtin.c). NULL-terminated list of names. */
extern const char *const pgi__builtin_names[];
pgi_status pgi__scene_builtin(const char *name, pgi_scene **out);   /* PGI_ERR_INVALID_ARG if unknown */

/* Mesh import through Assimp (load_assimp.c): appends geometry, materials
 * and textures of `path` to `s`. Textures resolve against the mesh folder. */
pgi_status pgi__scene_import_mesh(pgi_scene *s, const char *path);

/* JSON scene description (scene_json.c). */
pgi_status pgi__scene_load_json(const char *path, pgi_scene **out);

/* Texture lookup, bilinear, wrapping; returns linear RGB. */
pgi_v3 pgi__texture_lookup(const pgi_texture *t, float u, float v);

/* Geometry helpers used by rt/ and view/. */
static inline pgi_v3 pgi__scene_vertex(const pgi_scene *s, uint32_t v) { return v3_load(s->pos + 3 * (size_t)v); }

/* Uniform point on triangle `tri` from two uniform numbers. */
static inline pgi_v3 pgi__triangle_sample(const pgi_scene *s, uint32_t tri, float u1, float u2) {
    const uint32_t *t = s->tri + 3 * (size_t)tri;
    float su = sqrtf(u1), b1 = 1.f - su, b2 = u2 * su;
    pgi_v3 a = pgi__scene_vertex(s, t[0]), b = pgi__scene_vertex(s, t[1]), c = pgi__scene_vertex(s, t[2]);
    return v3_add(v3_add(v3_scale(a, 1.f - b1 - b2), v3_scale(b, b1)), v3_scale(c, b2));
}

/* Index i of a normalised CDF (cdf[n-1] = 1) with cdf[i-1] <= u < cdf[i];
 * *p receives that entry's probability. Used to pick lights by power. */
static inline size_t pgi__cdf_pick(const float *cdf, size_t n, float u, float *p) {
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (u < cdf[mid]) hi = mid;
        else lo = mid + 1;
    }
    *p = cdf[lo] - (lo ? cdf[lo - 1] : 0.f);
    return lo;
}

#endif
