/* The scene on the GPU (issue "The GPU backend", the frame's passes): everything shading needs
 * on the device, uploaded once from the scene's internals (scene_internal.h) and refreshed when
 * its geometry or lights change (static_version / dynamic_version as the renderer's BVH, a hash of
 * the lights as progressive.c's picture_of), plus
 * the ray-tracing BVH (gpu_rays.h), so that one object gives a pass every buffer it binds.
 *
 *   pgi__gpu_scene *gs;  pgi__gpu_scene_create(gpu, scene, &gs);     // PGI_ERR_UNSUPPORTED: a feature
 *   if (pgi__gpu_scene_needs_update(gs, scene)) pgi__gpu_scene_update(gs, scene);   // after animation
 *   pgi__gpu_buffer *b[PGI__GPU_SCENE_NBUF];  pgi__gpu_scene_buffers(gs, b);        // bindings 0..10
 *   pgi__gpu_scene_push sp;  pgi__gpu_scene_info(gs, &sp);           // first 32 bytes of a kernel's push
 *
 * A kernel that shades includes src/gpu/shaders/scene.glsl, which declares the buffers at set 0,
 * bindings 0..PGI__GPU_SCENE_NBUF-1 in the order below (its own buffers follow), and the push
 * constants' first member `SceneInfo scene` (pgi__gpu_scene_push).
 *
 * Layouts (std430, little-endian 32-bit words; scene.glsl declares the same structs):
 *   0..3  the BVH: nodes, triangles, cut-out masks, alpha words (rt/tri_bvh.h; "gpu_bvh_*")
 *   4  verts[nverts]   pgi__gpu_vert, 48 bytes: pos.xyz, u | nrm.xyz, v | col.xyz, 0. nrm is 0
 *                      when the scene has no vertex normals, u, v 0 without texture coordinates,
 *                      col (the vertex colour, linear) 1 without vertex colours (SceneInfo.flags
 *                      says which).                                                 ("gpu_scene")
 *   5  tris[ntris]     uvec4: the three vertex indices, the material.               ("gpu_scene")
 *   6  mats[nmats]     pgi__gpu_mat, 48 bytes: kd.xyz, type | ks.xyz, ior | ke.xyz, tex_kd (-1 none)
 *                                                                                   ("gpu_scene")
 *   7  lobes[nmats]    the material's lobe as pgi__lobe_of_material sets it up (gather.glsl Lobe,
 *                      160 bytes: model, ks, s, eta, a2, 1/(1-E_avg), E[32]); a view sample's lobe
 *                      index is its material, and the GPU estimator reads this table.  ("gpu_scene")
 *   8  lights[nlights] pgi__gpu_light, 64 bytes: pos.xyz, type | dir.xyz, cos_cutoff |
 *                      color.xyz, area | normal.xyz, tri                          ("gpu_scene")
 *   9  area[narea]     pgi__gpu_area, 8 bytes: the CDF over the area lights by the luminance of
 *                      their power (as pgi__direct builds it: cumulative, divided by the total, the
 *                      last entry 1; uniform when the total is 0), and the light's index.
 *                                                                                   ("gpu_scene")
 *   10 textures        words: [0, 256) pgi__srgb8_texture_lut (floats), then one uvec4 a texture
 *                      (first texel word, width, height, 0), then the texels, one RGBA8 word each
 *                      (R the least significant byte), rows from the top as pgi__texture.
 *                                                                                ("gpu_textures")
 * Empty arrays still get one zero entry (a buffer must exist).
 *
 * Not supported (PGI_ERR_UNSUPPORTED naming it): an environment map (a constant sky is uploaded:
 * SceneInfo sky / ground / up; the sky's radiance and its cosine sampling are in scene.glsl). */
#ifndef PGI__GPU_SCENE_H
#define PGI__GPU_SCENE_H

#include "gpu/gpu.h"
#include "gpu/gpu_rays.h"

#define PGI__GPU_SCENE_NBUF 11

/* SceneInfo flags */
#define PGI__GPU_SCENE_NORMALS 1u /* vertex normals */
#define PGI__GPU_SCENE_UVS 2u     /* texture coordinates */
#define PGI__GPU_SCENE_SKY 4u     /* a constant sky (sky, ground, up) */
#define PGI__GPU_SCENE_COLORS 8u  /* vertex colours (they multiply kd: pgi__scene_kd) */

typedef struct pgi__gpu_vert {
    float pos[3], u;
    float nrm[3], v;
    float col[3], pad;
} pgi__gpu_vert;
_Static_assert(sizeof(pgi__gpu_vert) == 48 && offsetof(pgi__gpu_vert, nrm) == 16 && offsetof(pgi__gpu_vert, col) == 32,
               "scene.glsl Vert");

typedef struct pgi__gpu_mat {
    float kd[3];
    uint32_t type; /* pgi__material_type */
    float ks[3];
    float ior;
    float ke[3];
    int32_t tex_kd;
} pgi__gpu_mat;
_Static_assert(sizeof(pgi__gpu_mat) == 48 && offsetof(pgi__gpu_mat, ks) == 16 && offsetof(pgi__gpu_mat, tex_kd) == 44,
               "scene.glsl Mat");

typedef struct pgi__gpu_light {
    float pos[3];
    uint32_t type; /* pgi__light_type */
    float dir[3];
    float cos_cutoff;
    float color[3];
    float area;
    float normal[3];
    uint32_t tri;
} pgi__gpu_light;
_Static_assert(sizeof(pgi__gpu_light) == 64 && offsetof(pgi__gpu_light, color) == 32 &&
                   offsetof(pgi__gpu_light, tri) == 60,
               "scene.glsl Light");

typedef struct pgi__gpu_area {
    float cdf;
    uint32_t light;
} pgi__gpu_area;
_Static_assert(sizeof(pgi__gpu_area) == 8, "scene.glsl AreaPick");

/* The scene's counts and constants, the first 64 bytes of a shading kernel's push constants
 * (scene.glsl SceneInfo). */
typedef struct pgi__gpu_scene_push {
    uint32_t nlights, narea, flags, ntris;
    float eps;             /* pgi__scene_epsilon */
    float up[3];           /* constant sky: its up direction (the env frame's fy) */
    float sky[3], pad1;    /* constant sky: radiance above the horizon */
    float ground[3], pad2; /* below */
} pgi__gpu_scene_push;
_Static_assert(sizeof(pgi__gpu_scene_push) == 64 && offsetof(pgi__gpu_scene_push, sky) == 32 &&
                   offsetof(pgi__gpu_scene_push, ground) == 48,
               "scene.glsl SceneInfo");

typedef struct pgi__gpu_scene pgi__gpu_scene;

/* Uploads s to g (and builds + uploads its BVH). The scene and the device are borrowed.
 * PGI_ERR_UNSUPPORTED for an environment map. */
pgi_status pgi__gpu_scene_create(pgi__gpu *g, const pgi_scene *s, pgi__gpu_scene **out);
void pgi__gpu_scene_destroy(pgi__gpu_scene *gs);
/* 1 when the scene's geometry or lights moved since the upload (static/dynamic versions, and a
 * hash of the lights: point and spot lights move without a version). */
int pgi__gpu_scene_needs_update(const pgi__gpu_scene *gs, const pgi_scene *s);
/* Uploads again what depends on positions: vertices, lights, the area CDF, and the BVH. */
pgi_status pgi__gpu_scene_update(pgi__gpu_scene *gs, const pgi_scene *s);
/* The buffers in binding order 0..PGI__GPU_SCENE_NBUF-1. */
void pgi__gpu_scene_buffers(const pgi__gpu_scene *gs, pgi__gpu_buffer **out);
void pgi__gpu_scene_info(const pgi__gpu_scene *gs, pgi__gpu_scene_push *out);
/* The material lobe table (binding 7), for the estimator. */
pgi__gpu_buffer *pgi__gpu_scene_lobes(const pgi__gpu_scene *gs);
pgi__gpu_rays *pgi__gpu_scene_rays(const pgi__gpu_scene *gs);

/* (addition, gpu-trace) Photon emission (src/gpu/gpu_trace.h), a buffer outside the bindings
 * above ("gpu_scene"): nemit records pgi__gpu_emit, one a light and the sky last when the scene
 * has one, with the light CDF by the luminance of the power as src/photon/trace.c builds it
 * (cumulative in double, divided by the total, the last entry 1); then three records: the
 * bounding sphere (centre, radius; the sun's and the sky's disks), the sky's frame x axis and its
 * probability of the upper hemisphere (p_sky), its z axis (and 0). nemit is 0 when no light has
 * power (no photons). Updated with the lights. */
typedef struct pgi__gpu_emit {
    float power[3];
    float cdf;
} pgi__gpu_emit;
_Static_assert(sizeof(pgi__gpu_emit) == 16, "trace.glsl Emit");
pgi__gpu_buffer *pgi__gpu_scene_emit(const pgi__gpu_scene *gs, uint32_t *nemit);

/* The scene's portals (scene_internal.h pgi__portal; docs/scene-format.md),
 * a buffer outside the bindings above ("gpu_scene"): nportals records pgi__gpu_portal (up to
 * PGI__MAX_PORTALS), for the sky's direct light through them (shaders/portal.glsl, direct.comp);
 * one zero record and nportals 0 without portals. */
typedef struct pgi__gpu_portal {
    float o[3], area;
    float e1[3];
    uint32_t rect; /* e1 and e2 at right angles: sampled by solid angle */
    float e2[3], pad0;
    float n[3], pad1;
    float centre[3], pad2;
    float d1[3], pad3;
    float d2[3], pad4;
} pgi__gpu_portal;
_Static_assert(sizeof(pgi__gpu_portal) == 112 && offsetof(pgi__gpu_portal, n) == 48 &&
                   offsetof(pgi__gpu_portal, d2) == 96,
               "portal.glsl Portal");
pgi__gpu_buffer *pgi__gpu_scene_portals(const pgi__gpu_scene *gs, uint32_t *nportals);

#endif
