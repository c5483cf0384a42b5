/* Internal scene model: one merged triangle mesh, materials, textures,
 * lights and cameras. Loaders (built-in, Assimp, JSON description) fill it;
 * rt/, photon/ and view/ read it. */
#ifndef PGI__SCENE_INTERNAL_H
#define PGI__SCENE_INTERNAL_H

#include <math.h>

#include "core/core.h"

typedef enum pgi__material_type {
    PGI__MAT_LAMBERT = 0, /* kd / pi */
    PGI__MAT_PHONG = 1,   /* energy-conserving Blinn-Phong, tiled paper eqs. 6-8 */
    PGI__MAT_MIRROR = 2,  /* perfect mirror, reflectance ks */
    PGI__MAT_GLASS = 3,   /* dielectric with Fresnel, index ior, tint ks */
    PGI__MAT_PLASTIC = 4  /* Lambertian base under a GGX lobe with a dielectric's Fresnel (index ior,
                            alpha from shininess, lobe tint min(1, ks / F0(ior))): src/scene/bsdf.h */
} pgi__material_type;

typedef struct pgi__material {
    char name[64];
    pgi__material_type type;
    float kd[3];     /* diffuse albedo (multiplied by the texture if any) */
    float ks[3];     /* Phong: F0; plastic: F0 (tint min(1, ks / F0(ior))); mirror: reflectance; glass:
                        transmission tint */
    float shininess; /* Phong exponent s (MTL Ns); plastic: alpha = sqrt(2 / (s + 2)) */
    float ior;       /* glass, plastic: MTL Ni */
    /* A mesh material with a specular colour (MTL illum 2, Assimp's Phong/Blinn with Ks > 0): its
     * model follows the scene's `specular` setting (pgi_scene_set_specular), plastic by default
     * or the papers' Blinn-Phong; kd_mesh is its diffuse colour as the file gives it (Blinn-Phong
     * lowers kd to 1 - ks). */
    int auto_glossy;
    float kd_mesh[3];
    float ke[3]; /* emitted radiance (MTL Ke); non-zero makes the triangles area lights */
    int tex_kd;  /* index into scene textures, -1 if none */
    /* Cut-out (MTL map_d, glTF alphaMode MASK): where alpha < alpha_cutoff the surface is not
     * there for any ray (an Embree filter, src/rt/rt.c). alpha is the alpha channel of texture
     * tex_alpha (bilinear), or 1 when tex_alpha is -1; a cutoff above 1 removes the whole
     * surface. alpha_cutoff 0 (what a zeroed material holds): no cut-out, tex_alpha unused. */
    float alpha_cutoff;
    int tex_alpha;
} pgi__material;

/* 1 when material m has a cut-out mask. */
static inline int pgi__mat_masked(const pgi__material *m) { return m->alpha_cutoff > 0.f; }

/* 8-bit sRGB texture; lookups return linear RGB. */
#define PGI__MIP_LEVELS 32 /* levels of a texture at most: sides up to 2^31 */
typedef struct pgi__texture {
    int width, height;
    unsigned char *rgba; /* 4 bytes a texel, row 0 is the top of the image */
    /* The same texels in blocks of 4x4 (one 64-byte cache line each, rows of blocks from the
     * top, texels in a block row by row; the last row and column of blocks padded), which the
     * colour lookups read: a bilinear 2x2 footprint then lies in one line 9 times in 16 instead
     * of never. Built by pgi__scene_add_texture from the colour channels, which nothing changes
     * later (the cut-out code rewrites alpha, read from rgba); NULL without memory for it. */
    unsigned char *tiled;
    int channels; /* of the image file: 1-4; 2 and 4 carry alpha (else alpha is 255) */
    /* Mip levels (docs/design.md "Textures"), built by pgi__scene_add_texture: level 0 is rgba,
     * level l (1 .. levels - 1) is mip[l], max(1, w >> l) x max(1, h >> l) texels laid out as
     * rgba, each the mean in linear light of the 2x2 texels of level l - 1 it covers (an odd
     * side's last row or column is left out) stored as the 8-bit sRGB code whose decoding
     * (pgi__srgb8_texture_lut) is nearest that mean; alpha is averaged as it is (linear). Only
     * the view samples read them (pgi__texture_lookup_lod); levels is 1 without memory for them. */
    int levels;
    unsigned char *mip[PGI__MIP_LEVELS];
    float lod_bias; /* 0.5 log2(width height): a triangle's texel-to-world ratio takes it */
    char path[512];
    char canon[512]; /* the file's canonical path (realpath), "" for embedded ones: one decode a file */
} pgi__texture;

/* The lights' types and their record, pgi__light: light.h (the types only, here; its functions
 * need the scene). */
#define PGI__LIGHT_TYPES_ONLY
#include "scene/light.h"
#undef PGI__LIGHT_TYPES_ONLY

/* Environment light (env.c): radiance from infinitely far away. `w` is the direction the
 * light comes from (pointing away from the scene, the way a ray escapes). */
typedef struct pgi__env {
    float sky[3], ground[3]; /* constant sky (rgb NULL): radiance above / below the horizon */
    float p_sky;             /* constant sky: probability of sampling the upper hemisphere */
    float *rgb;              /* map: w x h radiance (scale applied), row 0 the zenith; NULL: constant */
    int w, h;
    float *cdf_row;            /* map: h entries, rows by luminance x solid angle */
    float *cdf_col;            /* map: w x h, columns of each row by luminance */
    double lum_integral;       /* map: sum of luminance x texel solid angle */
    float rot;                 /* map: rotation about up, radians */
    float fx[3], fy[3], fz[3]; /* frame: fy = up */
    double integral[3];        /* integral of the radiance over the sphere, per channel */
    pgi__light light;          /* type PGI__LIGHT_ENV; power = pi R^2 integral (pgi__env_set_radius) */
    char path[512];            /* map file */
} pgi__env;

pgi_status pgi__env_create_constant(const char *what, const float sky[3], const float ground[3], const float up[3],
                                    pgi__env **out);
/* Reads an equirectangular map (EXR, HDR, or 8-bit images decoded from sRGB); `what` names the
 * scene description in errors. */
pgi_status pgi__env_create_map(const char *what, const char *path, float scale, float rotation_deg, const float up[3],
                               pgi__env **out);
void pgi__env_destroy(pgi__env *e);
/* Power of the photons entering from a disk of radius R: pi R^2 times the integral of L. */
void pgi__env_set_radius(pgi__env *e, float R);
/* Radiance arriving from direction w (unit). */
pgi__v3 pgi__env_eval(const pgi__env *e, pgi__v3 w);
/* A direction w with density proportional to the luminance of the radiance (constant sky:
 * uniform in each hemisphere, the hemisphere by luminance); *pdf is its solid-angle density. */
pgi__v3 pgi__env_sample(const pgi__env *e, float u1, float u2, float *pdf);
float pgi__env_pdf(const pgi__env *e, pgi__v3 w);
/* Direct light at a surface of shading normal ns: a constant sky is sampled by the cosine
 * about ns, a map by an equal mixture of the cosine and the map's own density. */
pgi__v3 pgi__env_sample_direct(const pgi__env *e, pgi__v3 ns, float u1, float u2, float *pdf);
float pgi__env_pdf_direct(const pgi__env *e, pgi__v3 ns, pgi__v3 w);
/* pgi__env_sample_direct for many directions at one point (the direct pass): the tangent frame
 * of ns set up once, and the radiance pgi__env_eval gives for the direction returned in *le. The
 * same numbers as pgi__env_sample_direct and pgi__env_eval, bit for bit (tests/test_env.c). */
typedef struct pgi__env_frame {
    pgi__v3 t, b, n;
} pgi__env_frame;
static inline void pgi__env_frame_init(pgi__env_frame *f, pgi__v3 ns) {
    v3_basis(ns, &f->t, &f->b);
    f->n = ns;
}
/* pgi_to_world(l, f->n) */
static inline pgi__v3 pgi__env_frame_dir(const pgi__env_frame *f, pgi__v3 l) {
    return v3_add(v3_add(v3_scale(f->t, l.x), v3_scale(f->b, l.y)), v3_scale(f->n, l.z));
}
/* The map's case (env.c). */
pgi__v3 pgi__env_sample_direct_map(const pgi__env *e, const pgi__env_frame *f, float u1, float u2, float *pdf,
                                   pgi__v3 *le);
static inline pgi__v3 pgi__env_sample_direct_in(const pgi__env *e, const pgi__env_frame *f, float u1, float u2,
                                                float *pdf, pgi__v3 *le) {
    if (e->rgb) return pgi__env_sample_direct_map(e, f, u1, u2, pdf, le);
    pgi__v3 w = pgi__env_frame_dir(f, pgi_sample_cosine(u1, u2));
    float c = v3_dot(f->n, w);
    /* pgi__env_pdf_direct's fmaxf(0, c) / pi, but for the sign of a zero (a zero pdf is refused) */
    *pdf = (c > 0.f ? c : 0.f) * PGI__INV_PI;
    *le = v3_load(v3_dot(w, v3_load(e->fy)) > 0.f ? e->sky : e->ground);
    return w;
}

/* A portal (docs/scene-format.md, "portals"): a parallelogram o + a e1 + b e2 (a, b in [0, 1])
 * through which the sun and the sky reach the inside of the scene (a window, a skylight). Light
 * crosses it along n = unit(e1 x e2), which points into the interior. Photon emission through
 * portals (--emission portal) and the sky's direct light (portal samples, MIS with the cosine
 * ones) use them; without portals neither changes. */
typedef struct pgi__portal {
    float o[3], e1[3], e2[3];
    float n[3]; /* unit, into the interior */
    float area; /* |e1 x e2| */
    float centre[3];
    float d1[3], d2[3]; /* dual vectors: a = (x - o) . d1, b = (x - o) . d2 for x in its plane */
    int rect;           /* e1 and e2 at right angles: direct light samples its solid angle (portal.c) */
} pgi__portal;

struct pgi_scene {
    char name[128];
    char source[1024];
    size_t nverts, ntris;
    float *pos;        /* 3 per vertex */
    float *nrm;        /* 3 per vertex, or NULL (flat shading) */
    float *uv;         /* 2 per vertex, or NULL */
    float *col;        /* 3 per vertex, or NULL: the vertex colour, linear RGB in [0, 1], which
                          multiplies kd before its texture (pgi__scene_kd, bsdf.h); white (1, 1, 1)
                          for the vertices of meshes without colours */
    uint32_t *tri;     /* 3 vertex indices per triangle */
    uint32_t *tri_mat; /* material per triangle */
    pgi__material *mats;
    size_t nmats;
    pgi__texture *texs;
    size_t ntexs;
    pgi__light *lights;
    size_t nlights;
    pgi__env *env;        /* the sky / environment map, or NULL */
    pgi__portal *portals; /* openings the sun and the sky come in through (NULL: none) */
    size_t nportals;
    pgi_camera_def *cams;
    size_t ncams;
    int cams_auto;         /* 1: cams[0] was placed by pgi__scene_finalize (the scene gave none) */
    char (*cam_names)[64]; /* ncams names ("" unnamed), or NULL: none named */
    char warning[2048];    /* what the files hold that the scene does not use or could not find ("" none) */
    pgi_scene_defaults defaults;
    pgi_specular specular; /* the description's "specular" (PGI_SPECULAR_DEFAULT: none given) */
    float bmin[3], bmax[3];
    /* Dynamic geometry (animate.c): objects whose vertices move with the
     * scene time, and counters the renderer compares to know when to update
     * its ray-tracing scene. */
    struct pgi__anim *anims;
    size_t nanims;
    uint8_t *tri_dynamic;     /* per triangle: 1 if an animation moves it; NULL when nothing is animated */
    double time;              /* seconds, set by pgi_scene_set_time */
    uint64_t static_version;  /* bumped when triangles outside tri_dynamic move (a moved area light) */
    uint64_t dynamic_version; /* bumped when animated triangles move */
    /* pgi_scene_create's meshes (scene_create.c): vertices [v0, v0 + nv) and triangles [t0, t0 + nt) each */
    struct pgi__mesh_range *meshes;
    size_t nmeshes;
    float *update_backup; /* pgi_scene_update_positions: the previous positions (a failed update restores them) */
    size_t update_backup_cap;
};

typedef struct pgi__mesh_range {
    size_t v0, nv, t0, nt;
    int dynamic;
} pgi__mesh_range;

/* ----------------------------------------------- building geometry (scene_create.c)
 * The one way vertices and triangles are added to a scene: the mesh loader (load_assimp.c),
 * pgi_scene_create and the objects of a description (animate.c) grow the arrays here and store
 * their normals through pgi__normal_clean and pgi__scene_fix_normals. */
/* Grows the arrays for add_v more vertices and add_t more triangles (the counts are not
 * changed). Normals are kept when want_nrm and the scene has them or no vertices yet; UVs when
 * want_uv or the scene has them (new and, when they are new, earlier ones set to 0, 0); vertex
 * colours when want_col or the scene has them (new and, when they are new, earlier ones set to
 * white, 1, 1, 1). */
pgi_status pgi__scene_grow_geometry(pgi_scene *s, size_t add_v, size_t add_t, int want_nrm, int want_uv, int want_col,
                                    const char *what);
/* A normal as the scene stores it: unit, or 0 for a zero or non-finite one (which
 * pgi__scene_fix_normals replaces). */
static inline pgi__v3 pgi__normal_clean(pgi__v3 n) {
    return !v3_finite(n) || !(v3_len(n) > 0.f) ? v3(0.f, 0.f, 0.f) : v3_norm(n);
}
/* Vertices of triangles [t0, t1) whose normal is zero take the face normal of a triangle using them. */
void pgi__scene_fix_normals(pgi_scene *s, size_t t0, size_t t1);
/* A point, spot or sun light from its public desc (animate.c): checked (`what` names it in the
 * message), the direction normalised, colour x intensity as its radiance; power not yet set. */
pgi_status pgi__light_from_desc(const pgi_light_desc *ld, const char *what, pgi__light *l);
/* A texture whose image has no alpha channel (1 or 3 channels): its grey value becomes its alpha
 * (a cut-out mask given as a grey image). */
void pgi__texture_grey_alpha(pgi__texture *t);

/* ------------------------------------------------------------ animation */

/* One keyframe of a rigid motion about the object's pivot:
 * p' = pivot + translate + Rz Ry Rx (scale * (p - pivot)). */
typedef struct pgi__keyframe {
    float t;
    float translate[3];
    float rotate[3]; /* Euler angles, degrees, applied about x, then y, then z */
    float scale;
} pgi__keyframe;

typedef enum pgi__loop { PGI__LOOP_CLAMP = 0, PGI__LOOP_REPEAT = 1, PGI__LOOP_PINGPONG = 2 } pgi__loop;

typedef struct pgi__anim {
    char name[64];
    uint32_t *verts; /* vertices the motion moves (each once) */
    size_t nverts;
    float *rest_pos; /* 3 per moved vertex, at rest */
    float *rest_nrm; /* 3 per moved vertex, or NULL (flat-shaded scene) */
    float pivot[3];
    pgi__keyframe *keys; /* sorted by t, at least one */
    size_t nkeys;
    pgi__loop loop;
} pgi__anim;

/* Adds an animation moving the vertices of the triangles tris[0..ntris) (the
 * caller keeps tris). Takes ownership of keys (malloc'd). Marks the
 * triangles dynamic. pivot NULL: the centre of their bounding box. */
/* The scene's bounds within PGI_MAX_COORD and each light's power at most PGI_MAX_LIGHT_POWER
 * (after finalize, an animation step or a moved light); `what` names the scene in the message. */
pgi_status pgi__scene_check_numbers(const pgi_scene *s, const char *what);
pgi_status pgi__scene_add_anim(pgi_scene *s, const char *name, const uint32_t *tris, size_t ntris, const float *pivot,
                               pgi__keyframe *keys, size_t nkeys, pgi__loop loop);
/* Appends a UV sphere / an axis-aligned box with material `mat`; the new
 * triangles are [*first, s->ntris). */
pgi_status pgi__scene_add_sphere(pgi_scene *s, const float c[3], float r, uint32_t mat, size_t *first);
pgi_status pgi__scene_add_box(pgi_scene *s, const float c[3], const float size[3], uint32_t mat, size_t *first);
/* Recomputes what depends on vertex positions: bounds, area-light
 * triangles' area and normal, light powers (the sun's disk follows the
 * bounds). */
void pgi__scene_refresh(pgi_scene *s);
void pgi__scene_free_anims(pgi_scene *s);

/* Allocates an empty scene (all zero, name set). */
pgi_status pgi__scene_new(const char *name, pgi_scene **out);
/* After geometry, materials and explicit lights are in: validates (indices
 * in range, finite numbers), computes bounds, adds one area light per
 * emissive triangle, computes light powers, adds a default camera when none
 * was given. Returns PGI_ERR_PARSE with a message naming `what` on bad data. */
pgi_status pgi__scene_finalize(pgi_scene *s, const char *what);
/* Length of the scene's bounding-box diagonal. */
float pgi__scene_diagonal(const pgi_scene *s);
/* Triangles whose material emits (Ke > 0), area lights or not (a zero-area one is none). */
size_t pgi__scene_emissive_triangles(const pgi_scene *s);
/* Ray offset used to leave a surface without hitting it again (from the
 * bounds: 1e-5 of the diagonal, at least 1e-5). */
float pgi__scene_epsilon(const pgi_scene *s);

/* Built-in scenes (builtin.c). NULL-terminated list of names. */
extern const char *const pgi__builtin_names[];
pgi_status pgi__scene_builtin(const char *name, pgi_scene **out); /* PGI_ERR_INVALID_ARG if unknown */

/* The lattice mask of the built-in scene `cutout`: PGI__CUTOUT_TEXELS^2 texels, periods of 8 x 8
 * texels; columns 3 and 4 and rows 3 and 4 of a period are its narrow bands, and a texel is open
 * (alpha 0) where exactly one of its column and its row is narrow: slots 2 x 6 texels, an open
 * fraction of 2 * 2 * 6 / 64 = 0.375. Every 2 x 2 block of texels is uniform, split in halves
 * or a checker, so bilinear alpha cut at 0.5 opens exactly the open texels' squares. */
#define PGI__CUTOUT_TEXELS 192
#define PGI__CUTOUT_OPEN_FRACTION 0.375
static inline int pgi__cutout_open(int x, int y) {
    int nx = (x & 7) == 3 || (x & 7) == 4, ny = (y & 7) == 3 || (y & 7) == 4;
    return nx != ny;
}

/* Mesh import through Assimp (load_assimp.c): appends geometry, materials
 * and textures of `path` to `s`. Textures resolve against the mesh folder. */
pgi_status pgi__scene_import_mesh(pgi_scene *s, const char *path);

/* JSON scene description (scene_json.c). */
pgi_status pgi__scene_load_json(const char *path, pgi_scene **out);

/* Texture lookup, bilinear, wrapping; returns linear RGB. */
pgi__v3 pgi__texture_lookup(const pgi__texture *t, float u, float v);
/* n (at most PGI__TEXTURE_LOOKUP_N) lookups at once, out[k] = pgi__texture_lookup(t[k], u[k],
 * v[k]) bit for bit: the footprints and their prefetches first, then the texels, so that the
 * lookups' cache misses overlap. */
#define PGI__TEXTURE_LOOKUP_N 16
void pgi__texture_lookup_n(const pgi__texture *const *t, const float *u, const float *v, int n, pgi__v3 *out);
/* 16 lookups on one texture t, out[c][k] = component c of pgi__texture_lookup(t, u[k], v[k]) bit for
 * bit (vectorised where the CPU has AVX2: the two steps below). */
void pgi__texture_lookup16_soa(const pgi__texture *t, const float *u, const float *v, float out[3][16]);
/* pgi__texture_lookup16_soa in two steps, so that the texels' cache misses can pass while other
 * work is done: pgi__texture_quads16 finds the 16 quads (byte offsets into t->tiled and weights)
 * and requests their texels, or returns 0 where the CPU (AVX2) or t cannot (then use
 * pgi__texture_lookup16_soa); pgi__texture_quads16_lookup later blends them, the same bits. */
typedef struct pgi__texel_quads16 {
    int32_t o[4][16]; /* texels (x0, y0), (x1, y0), (x0, y1), (x1, y1) of lookup k: t->tiled + o[c][k] */
    float tx[16], ty[16];
} pgi__texel_quads16;
int pgi__texture_quads16(const pgi__texture *t, const float *u, const float *v, pgi__texel_quads16 *q);
void pgi__texture_quads16_lookup(const pgi__texture *t, const pgi__texel_quads16 *q, float out[3][16]);
/* The view samples' filtered lookup (docs/design.md "Textures"): trilinear between mip levels
 * floor(lod) and floor(lod) + 1 (bilinear in each, weights lod - floor(lod)); lod <= 0 or NaN
 * is pgi__texture_lookup(t, u, v) bit for bit, lod >= levels - 1 the coarsest level alone. One
 * scalar function for every path of the view pass, so that they give the same bits. */
pgi__v3 pgi__texture_lookup_lod(const pgi__texture *t, float u, float v, float lod);
/* Level l (0 .. levels - 1) alone, bilinear. */
pgi__v3 pgi__texture_lookup_level(const pgi__texture *t, float u, float v, int l);
/* Bytes of t's levels 1 and up (the memory ledger's `textures`). */
size_t pgi__texture_mip_bytes(const pgi__texture *t);
/* Frees t's texels and levels (pgi_scene_destroy). */
void pgi__texture_free(pgi__texture *t);
/* The mip level of a ray cone (Akenine-Moller et al. 2019, "Texture Level of Detail Strategies
 * for Real-Time Ray Tracing", Ray Tracing Gems ch. 20, eq. 34): a cone of width `width` at the
 * hit, its direction at cosine `cosine` to the surface's normal, on a triangle whose texture
 * area over world area is 2^(2 tri_lod) (pgi__tri_uv_lod) in uv units:
 * tri_lod + 0.5 log2(w h) + log2(width / |cosine|) + PGI__TEXTURE_LOD_BIAS.
 * The bias matches the filter to the pixel's box: a box of the footprint's width w has variance
 * w^2 / 12 along an axis; a level whose texels are s wide, read bilinearly, averages a box of s
 * (s^2 / 12) under a tent of half-width s (s^2 / 6): s^2 / 4 in all, equal to w^2 / 12 at
 * s = w / sqrt(3), a level log2(sqrt(3)) below log2(w). (Sibenik 320x180 against the pixel
 * integral, isotropic: 26.3 dB without the bias, 27.2 dB with it; docs/design.md "Textures".) */
#define PGI__TEXTURE_LOD_BIAS (-0.79248125f) /* -0.5 log2(3) */
static inline float pgi__texture_cone_lod(const pgi__texture *t, float tri_lod, float width, float cosine) {
    return tri_lod + t->lod_bias + log2f(width / fabsf(cosine)) + PGI__TEXTURE_LOD_BIAS;
}
/* Alpha channel (0..1, linear), bilinear and wrapping as pgi__texture_lookup; 1 without a texture. */
float pgi__texture_alpha(const pgi__texture *t, float u, float v);
/* 1 when the point at barycentrics (b1, b2) of triangle `tri` is cut out by its material's mask
 * (the ray filters of rt.c call this for hits on masked triangles only). */
int pgi__scene_cut_out(const pgi_scene *s, uint32_t tri, float b1, float b2);
/* Appends a texture that takes ownership of `rgba` (malloc'd, w x h x 4 bytes; freed here on
 * failure); *index receives its index. `channels` as in pgi__texture. */
pgi_status pgi__scene_add_texture(pgi_scene *s, int w, int h, int channels, unsigned char *rgba, const char *path,
                                  int *index);
/* The 2x2 texels of a bilinear lookup, found once: pgi__texture_quad computes them for (u, v)
 * and prefetches them (0 when the texture has no texels: the lookup is then white, and q is
 * not set); pgi__texture_quad_lookup later gives exactly pgi__texture_lookup(t, u, v). The
 * photon tracer finds a hit's quad one pipeline stage before it shades the hit. */
typedef struct pgi__texel_quad {
    const unsigned char *p[4]; /* texels (x0, y0), (x1, y0), (x0, y1), (x1, y1) */
    float tx, ty;              /* weights of x1 and y1 */
} pgi__texel_quad;
/* Defined here, inline: the photon tracer and the path tracer call them for every textured hit
 * (a call each cost the tracer about 1 %; texture.c builds its lookups from the same pieces). */
/* Wraps a texel index of [-1, n] into [0, n) (coordinates are reduced to [0, 1] first, so
 * nothing farther out occurs; no division on this hot path). */
static inline int pgi__tex_wrap_index(long i, int n) { return i < 0 ? (int)(i + n) : i >= n ? (int)(i - n) : (int)i; }

static inline pgi__v3 pgi__tex_decode(const unsigned char *p) {
    return v3(pgi__srgb8_texture_lut[p[0]], pgi__srgb8_texture_lut[p[1]], pgi__srgb8_texture_lut[p[2]]);
}

/* The 2x2 texels of a bilinear lookup at (u, v): columns x0, x1, rows y0, y1, and the weights
 * (tx, ty) of x1 and y1. NaN / Inf coordinates (degenerate UVs) read texel (0, 0)'s
 * neighbourhood instead of crashing. */
typedef struct pgi__tex_footprint2x2 {
    int x0, x1, y0, y1;
    float tx, ty;
} pgi__tex_footprint2x2;

static inline pgi__tex_footprint2x2 pgi__tex_bilinear_footprint_wh(int width, int height, float u, float v) {
    if (!isfinite(u)) u = 0.f;
    if (!isfinite(v)) v = 0.f;
    /* Reduce to [0, 1) first so that huge tiling factors keep their precision in the fraction. */
    float fu = u - floorf(u);
    float fv = v - floorf(v);
    float x = fu * (float)width - 0.5f;
    float y = (1.f - fv) * (float)height - 0.5f; /* v = 0 is the bottom row */
    float x0f = floorf(x), y0f = floorf(y);
    pgi__tex_footprint2x2 f;
    f.tx = x - x0f;
    f.ty = y - y0f;
    f.x0 = pgi__tex_wrap_index((long)x0f, width);
    f.x1 = pgi__tex_wrap_index((long)x0f + 1, width);
    f.y0 = pgi__tex_wrap_index((long)y0f, height);
    f.y1 = pgi__tex_wrap_index((long)y0f + 1, height);
    return f;
}

static inline pgi__tex_footprint2x2 pgi__tex_bilinear_footprint(const pgi__texture *t, float u, float v) {
    return pgi__tex_bilinear_footprint_wh(t->width, t->height, u, v);
}

/* The colour bytes of footprint f's texels (x0, y0), (x1, y0), (x0, y1), (x1, y1), in the block
 * layout when there is one (pgi__texture.tiled): each address is a row part plus a column part,
 * two of each computed once. */
static inline void pgi__tex_quad_at(const pgi__texture *t, const pgi__tex_footprint2x2 *f, pgi__texel_quad *q) {
    size_t r0, r1, c0, c1;
    const unsigned char *base = t->tiled;
    if (base) {
        const size_t bw = (size_t)((t->width + 3) >> 2);
        r0 = 64 * ((size_t)(f->y0 >> 2) * bw) + 16 * (size_t)(f->y0 & 3);
        r1 = 64 * ((size_t)(f->y1 >> 2) * bw) + 16 * (size_t)(f->y1 & 3);
        c0 = 64 * (size_t)(f->x0 >> 2) + 4 * (size_t)(f->x0 & 3);
        c1 = 64 * (size_t)(f->x1 >> 2) + 4 * (size_t)(f->x1 & 3);
    } else {
        base = t->rgba;
        r0 = 4 * (size_t)f->y0 * (size_t)t->width;
        r1 = 4 * (size_t)f->y1 * (size_t)t->width;
        c0 = 4 * (size_t)f->x0;
        c1 = 4 * (size_t)f->x1;
    }
    q->p[0] = base + r0 + c0;
    q->p[1] = base + r0 + c1;
    q->p[2] = base + r1 + c0;
    q->p[3] = base + r1 + c1;
    q->tx = f->tx;
    q->ty = f->ty;
}

static inline int pgi__texture_quad(const pgi__texture *t, float u, float v, pgi__texel_quad *q) {
    if (!t || !t->rgba || t->width <= 0 || t->height <= 0) return 0;
    pgi__tex_footprint2x2 f = pgi__tex_bilinear_footprint(t, u, v);
    pgi__tex_quad_at(t, &f, q);
    /* all four requested (mostly one or two lines): with p[0] and p[3] alone, the photon tracer's
       shading still waited on the others (the four: about 1 % off its pass) */
    __builtin_prefetch(q->p[0]);
    __builtin_prefetch(q->p[1]);
    __builtin_prefetch(q->p[2]);
    __builtin_prefetch(q->p[3]);
    return 1;
}

/* The bilinear pgi__tex_blend of every colour lookup (the order of the operations is part of the result). */
static inline pgi__v3 pgi__tex_blend(pgi__v3 a, pgi__v3 b, pgi__v3 c, pgi__v3 d, float tx, float ty) {
    pgi__v3 top = v3_add(v3_scale(a, 1.f - tx), v3_scale(b, tx));
    pgi__v3 bot = v3_add(v3_scale(c, 1.f - tx), v3_scale(d, tx));
    return v3_add(v3_scale(top, 1.f - ty), v3_scale(bot, ty));
}

/* The quad's colours, bilinearly weighted. */
static inline pgi__v3 pgi__texture_quad_lookup(const pgi__texel_quad *q) {
    return pgi__tex_blend(pgi__tex_decode(q->p[0]), pgi__tex_decode(q->p[1]), pgi__tex_decode(q->p[2]),
                          pgi__tex_decode(q->p[3]), q->tx, q->ty);
}

/* Geometry helpers used by rt/ and view/. */
static inline pgi__v3 pgi__scene_vertex(const pgi_scene *s, uint32_t v) { return v3_load(s->pos + 3 * (size_t)v); }
struct cJSON;
/* A camera a mesh file names (glTF camera nodes, Assimp's aiCamera). */
typedef struct pgi__file_camera {
    char name[64]; /* "" when the file gives none */
    pgi_camera_def def;
} pgi__file_camera;

/* What a glTF's JSON holds beyond what Assimp 5.2 reports correctly (gltf_scene.c): its camera
 * nodes (Assimp adds the node's translation twice and renames them), its KHR_lights_punctual
 * lights placed by their nodes, KHR_materials_emissive_strength per material, and what the file
 * holds that photongi does not use. */
typedef struct pgi__gltf_extras {
    pgi__file_camera *cams;
    size_t ncams;
    pgi__light *lights;
    size_t nlights;
    float *emissive_strength; /* per glTF material (1 when absent) */
    size_t nmats;
    char unused[1024]; /* "2 animations, KHR_materials_clearcoat, ...": comma-separated, "" if nothing */
} pgi__gltf_extras;

/* What the mesh check learns on the way that Assimp does not report: OBJ
 * smoothing-group statements (Assimp 5.2 skips `s` lines), material libraries that are not
 * there (Assimp goes on without a word), a glTF's extras. Free with pgi__mesh_hints_free. */
typedef struct pgi__mesh_hints {
    size_t smooth_on;      /* OBJ `s N` with N > 0 */
    size_t smooth_off;     /* OBJ `s off` or `s 0` */
    char missing_mtl[512]; /* OBJ mtllib names not found, comma-separated ("" if none) */
    char missing_tex[512]; /* texture files not found (the materials keep their colour), comma-separated */
    int gltf;              /* a glTF (.gltf / .glb): `extras` is filled */
    pgi__gltf_extras extras;
} pgi__mesh_hints;
void pgi__mesh_hints_free(pgi__mesh_hints *h);
/* Fills *x from a glTF's parsed JSON (`root`, a cJSON *; checked by pgi__gltf_check). */
pgi_status pgi__gltf_read_extras(const char *path, const struct cJSON *root, pgi__gltf_extras *x);
/* Appends a camera (name may be NULL or "": unnamed) to the scene. */
pgi_status pgi__scene_add_camera(pgi_scene *s, const pgi_camera_def *def, const char *name);
/* Appends `text` to the scene's warning line (pgi_scene_info.warnings), "; "-separated. */
void pgi__scene_warn(pgi_scene *s, const char *text);
/* Limits of what a mesh file may declare (docs/scene-format.md, "Mesh files"), checked before Assimp reads it:
 * nesting (JSON, XML, braces of .x/.bvh/.ogex, AC3D kids, a glTF's node tree) deeper than
 * PGI__MAX_MESH_DEPTH levels (Assimp recurses once a level: a deep file overflows its stack);
 * more than PGI__MAX_MESH_MATERIALS materials (Assimp 5.2's OBJ import is quadratic in them);
 * more than PGI__MAX_MESH_FILES material libraries named by one OBJ, or files opened by Assimp for
 * one import; a file Assimp opens more than PGI__MAX_FILE_OPENS times in one import. */
#define PGI__MAX_MESH_DEPTH 1000
#define PGI__MAX_MESH_MATERIALS 10000
#define PGI__MAX_MESH_FILES 256
#define PGI__MAX_FILE_OPENS 64
/* Refuses mesh files that make Assimp crash, hang or allocate far more than the file holds
 * (mesh_check.c): counts a header declares that the file is too small to hold, nesting past
 * PGI__MAX_MESH_DEPTH, material libraries that are not regular files. `budget`: the memory
 * budget of the load (a file it reads whole may be no larger). Fills *hints (may be NULL). */
pgi_status pgi__mesh_precheck(const char *path, uint64_t budget, pgi__mesh_hints *hints);
/* A glTF's accessors, buffer views, primitives, skins and animations, as Assimp 5.2 reads them
 * (gltf_check.c); root: its parsed JSON (a cJSON *), glb: the GLB file whose BIN chunk holds
 * glb_bin_len bytes from offset glb_bin (NULL for a .gltf). */
struct cJSON;
pgi_status pgi__gltf_check(const char *path, const struct cJSON *root, FILE *glb, uint64_t glb_bin,
                           uint64_t glb_bin_len);
/* The memory budget of the scene being loaded on this thread (pgi_scene_load_budget; the
 * default budget, pgi__mem_default_budget, otherwise). */
uint64_t pgi__scene_load_budget(void);
/* Bytes the scene holds (scene.c, for the memory stats): geometry, materials, lights, cameras,
 * sky map and motions in *scene_bytes, decoded textures in *texture_bytes. */
void pgi__scene_memory(const pgi_scene *s, size_t *scene_bytes, size_t *texture_bytes);
/* Total triangle area (scene.c). */
double pgi__scene_area(const pgi_scene *s);

/* Uniform point on the triangle a, b, c from two uniform numbers. */
static inline pgi__v3 pgi__tri_point(pgi__v3 a, pgi__v3 b, pgi__v3 c, float u1, float u2) {
    float su = sqrtf(u1), b1 = 1.f - su, b2 = u2 * su;
    return v3_add(v3_add(v3_scale(a, 1.f - b1 - b2), v3_scale(b, b1)), v3_scale(c, b2));
}

/* Uniform point on triangle `tri` from two uniform numbers. */
static inline pgi__v3 pgi__triangle_sample(const pgi_scene *s, uint32_t tri, float u1, float u2) {
    const uint32_t *t = s->tri + 3 * (size_t)tri;
    pgi__v3 a = pgi__scene_vertex(s, t[0]), b = pgi__scene_vertex(s, t[1]), c = pgi__scene_vertex(s, t[2]);
    return pgi__tri_point(a, b, c, u1, u2);
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
