/* photongi: interactive global illumination by photon mapping.
 *
 * One frame: primary rays give view samples (a G-buffer); photons are traced
 * from the lights (Russian roulette, stored from the second hit on); an
 * estimator turns photons into indirect radiance at every view sample; direct
 * light comes from shadow rays; the sum is tone-mapped and written.
 *
 *   pgi_scene *scene;
 *   if (pgi_scene_load("cornell", &scene) != PGI_OK) puts(pgi_last_error());
 *   pgi_render_desc d = {.estimator = "tiled", .photons = 200000};
 *   pgi_image img = {0};
 *   pgi_frame_stats st;
 *   pgi_render(scene, &d, &img, &st);
 *   pgi_image_write(&img, "out.png", 1.0f);
 *   pgi_image_free(&img);
 *   pgi_scene_destroy(scene);
 *
 * Errors: every fallible call returns a pgi_status; the detailed message of
 * the last failure on the calling thread is pgi_last_error(). The library
 * never exits the process. Whoever creates an object destroys it.
 */
#ifndef PHOTONGI_H
#define PHOTONGI_H

#include <stddef.h>
#include <stdint.h>

#include "photongi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define PGI_VERSION_STRING "0.1.0"

const char *pgi_version(void);

/* ------------------------------------------------------------------ scene */

typedef struct pgi_scene pgi_scene;

typedef struct pgi_camera_def {
    float eye[3], look_at[3], up[3];
    float fov_y_deg;                 /* vertical field of view, degrees */
} pgi_camera_def;

/* Defaults a scene description suggests for rendering it (0 = none given). */
typedef struct pgi_scene_defaults {
    uint32_t photons;
    float radius;
    int bounces;
    int width, height;
    float exposure;
} pgi_scene_defaults;

typedef struct pgi_scene_info {
    const char *name;     /* "cornell", or the description/mesh file name */
    const char *source;   /* "built-in" or the file that was loaded */
    size_t triangles, vertices, materials, textures;
    size_t lights;        /* all emitters; emissive triangles count one each */
    size_t point_lights, spot_lights, sun_lights, area_triangles;
    float bounds_min[3], bounds_max[3];
    size_t cameras;
    pgi_camera_def camera; /* camera 0 */
    pgi_scene_defaults defaults;
    size_t animated_objects;  /* objects with a motion (see pgi_scene_set_time) */
    double anim_duration;     /* last keyframe time over all motions, seconds (0 if none) */
} pgi_scene_info;

/* Loads a scene. `spec` is a built-in name ("cornell", "giref",
 * "sphere-and-plane"), a scene description (.json), a scene name with a
 * description in ./scenes/<name>.json, or a mesh file Assimp reads (OBJ/MTL,
 * glTF, PLY). Mesh paths in a description resolve against the description's
 * folder, then against $PHOTONGI_SCENES (default ../shared/scenes). */
pgi_status pgi_scene_load(const char *spec, pgi_scene **out);
void pgi_scene_destroy(pgi_scene *scene);
void pgi_scene_get_info(const pgi_scene *scene, pgi_scene_info *out);
size_t pgi_builtin_scene_count(void);
const char *pgi_builtin_scene_name(size_t i);

/* ----------------------------------------------------------------- render */

typedef enum pgi_output {
    PGI_OUTPUT_ALL = 0,       /* emission + direct + indirect */
    PGI_OUTPUT_INDIRECT = 1,  /* the estimator's indirect radiance only */
    PGI_OUTPUT_DIRECT = 2,    /* emission + direct only */
    PGI_OUTPUT_PHOTON_COUNT = 3 /* photons that contributed at each pixel (all three channels); needs a
                                   second build + estimate pass over unit-flux photons */
} pgi_output;

/* Zero means "default" for every field. */
typedef struct pgi_render_desc {
    const char *estimator;   /* registered name; default "tiled" */
    uint32_t photons;        /* photons to store; default scene's or 200000 */
    float radius;            /* photon radius in scene units; default scene's or 2% of the diagonal */
    int width, height;       /* default scene's or 640x480 */
    int bounces;             /* max photon bounces; default 4 */
    uint64_t seed;           /* default 1 */
    int threads;             /* OpenMP threads; 0 = all */
    int camera;              /* index into the scene's cameras */
    int tile_size;           /* tiled estimator tile edge in pixels; default 32 */
    int direct_samples;      /* shadow samples per pixel for area lights; default 16 */
    pgi_output output;
    int radius_set;          /* non-zero: `radius` was given explicitly (0 or less is then an error) */
    int photons_set;         /* non-zero: `photons` was given explicitly (0 is then an error) */
    const pgi_camera_def *view; /* non-NULL: render from this camera instead of the scene's `camera`
                                   (borrowed for the call; the viewer's free camera) */
    int progressive;         /* > 1: pgi_renderer_render averages this many frames with fresh photons
                                and a shrinking radius (Knaus & Zwicker 2011); 0 or 1: one frame */
    int cluster_tile;        /* cluster estimators: cluster edge in pixels; default 8 */
    int directional_level;   /* directional: buckets this many levels above the leaves; 0 = 1, -1 = leaves */
    int directional_blur;    /* directional: irradiance blur radius in pixels; 0 = 4, -1 = off */
    /* Per-photon footprints (radius policies; need an estimator with PGI_EST_CAP_PHOTON_RADIUS). */
    int radius_policy;       /* PGI_RADIUS_FIXED (default), PGI_RADIUS_PATH, PGI_RADIUS_DIFFERENTIALS */
    float r_min, r_max;      /* path: radius range (default r_max = radius, r_min = r_max/8);
                                differentials: r_max clamps the footprint radius (default: radius) */
    float smoothing;         /* differentials: smoothing factor s (> 0); 0 = automatic (docs/bvh.md) */
    int bvh_build;           /* "bvh": PGI_BVH_LINEAR (default) or PGI_BVH_VVH */
    int leaf_size;           /* "bvh": leaf-size threshold; 0 = T_auto */
    int kernel;              /* pgi_kernel: 0 constant (default), 1 cone, 2 Epanechnikov */
    int subsample;           /* stochastic subsampling factor k (0/1 off; hashgrid, tiled, kdtree range) */
    int filter;              /* bilateral reconstruction filter radius in pixels on the indirect light (0 off) */
    int knn;                 /* kdtree: k nearest photons within the radius (0 = fixed-radius range mode) */
    int polygon_vertices;    /* bounds25d: vertices of the screen polygon (even, 4..64); default 8 */
} pgi_render_desc;

typedef enum pgi_radius_policy {
    PGI_RADIUS_FIXED = 0,         /* one radius for every photon */
    PGI_RADIUS_PATH,              /* tiled paper eqs. 4-5: r_min + (r_max - r_min) sqrt(1 - path probability) */
    PGI_RADIUS_DIFFERENTIALS,     /* BVH paper §4: skewed ellipsoids from photon differentials */
    PGI_RADIUS_POLICY_COUNT_
} pgi_radius_policy;

/* Footprint radius histogram (BVH paper Table 3): bin k counts radii in
 * [k, k+1) * r_max/14 before the clamp, the last bin everything above. */
#define PGI_FOOTPRINT_BINS 21

/* Linear RGB radiance, row-major from the top-left, 3 floats a pixel. */
typedef struct pgi_image {
    int width, height;
    float *rgb;
} pgi_image;

#define PGI_MAX_STAT_ENTRIES 8

typedef struct pgi_named_value {
    const char *name;
    double value;
} pgi_named_value;

typedef struct pgi_frame_stats {
    const char *estimator;
    int width, height, threads;
    uint64_t photons_emitted;        /* light paths emitted */
    uint64_t photons_stored;
    uint64_t photon_rays;            /* rays cast while tracing photons */
    uint64_t primary_rays, shadow_rays;
    float radius;
    /* wall-clock milliseconds */
    double view_ms, trace_ms, build_ms, estimate_ms, direct_ms, total_ms;
    /* estimator sub-passes (e.g. tiled: bounds, count, scan, copy, gather) */
    pgi_named_value passes_ms[PGI_MAX_STAT_ENTRIES];
    int pass_count;
    /* bytes per structure (photons, view samples, estimator structures) */
    pgi_named_value memory_bytes[PGI_MAX_STAT_ENTRIES];
    int memory_count;
    uint64_t reads;          /* photon reads by the estimator */
    uint64_t contributing;   /* reads that passed the sphere + hemisphere test */
    uint64_t nodes_visited;  /* cells / tiles / nodes touched */
    int frames;              /* frames averaged into the image (progressive); 1 for a single frame */
    double rt_update_ms;     /* updating the ray-tracing scene after geometry moved (0 if nothing moved) */
    int radius_policy;       /* pgi_radius_policy used */
    int leaf_size;           /* "bvh": leaf-size threshold used */
    float footprint_bin_width;                     /* 0: no per-photon footprints */
    uint64_t footprint_hist[PGI_FOOTPRINT_BINS];   /* see PGI_FOOTPRINT_BINS */
} pgi_frame_stats;

/* Renders one frame into `out` (free with pgi_image_free). Pass a zeroed
 * image the first time; an image of the right size is reused, any other is
 * freed and replaced. `stats` may be NULL. */
pgi_status pgi_render(const pgi_scene *scene, const pgi_render_desc *desc,
                      pgi_image *out, pgi_frame_stats *stats);

typedef struct pgi_renderer pgi_renderer;
/* A renderer keeps the ray-tracing scene and per-frame buffers between frames
 * (the viewer and the benchmark render many frames). The scene is borrowed
 * and must outlive the renderer. */
pgi_status pgi_renderer_create(const pgi_scene *scene, pgi_renderer **out);
pgi_status pgi_renderer_render(pgi_renderer *r, const pgi_render_desc *desc,
                               pgi_image *out, pgi_frame_stats *stats);
void pgi_renderer_destroy(pgi_renderer *r);

void pgi_image_free(pgi_image *img);
/* Writes PNG (tone-mapped: exposure, then sRGB) or EXR (linear float),
 * chosen by the file extension. */
pgi_status pgi_image_write(const pgi_image *img, const char *path, float exposure);
/* Tone maps to 8-bit sRGB (3 bytes a pixel, caller-owned buffer). */
void pgi_tonemap_srgb8(const pgi_image *img, float exposure, unsigned char *out);
/* Writes the frame statistics as JSON to `path` ("-" = standard output). */
pgi_status pgi_stats_write_json(const pgi_frame_stats *stats, const char *path);

/* ------------------------------------------------ dynamic scenes (issue 6) */

/* Moves every animated object of a scene description ("motion" keyframes,
 * docs/scene-format.md) to time t (seconds). A renderer using the scene
 * updates its ray-tracing scene on its next frame. Not thread-safe with a
 * render in progress on the same scene. */
pgi_status pgi_scene_set_time(pgi_scene *scene, double t);

/* Lights a user can move. Group i < (point, spot and sun lights) is that
 * light; after them comes one group per emissive material (all its
 * triangles, moved together). */
typedef enum pgi_light_kind {
    PGI_LIGHT_KIND_POINT = 0,
    PGI_LIGHT_KIND_SPOT = 1,
    PGI_LIGHT_KIND_SUN = 2,
    PGI_LIGHT_KIND_AREA = 3
} pgi_light_kind;

typedef struct pgi_light_group {
    pgi_light_kind kind;
    const char *name;      /* "point 0", or the emissive material's name; valid while the scene lives */
    float position[3];     /* point/spot: position; area: area-weighted centroid; sun: 0 */
    size_t triangles;      /* area: emissive triangles in the group */
} pgi_light_group;

/* Camera i of the scene (the viewer starts from it). */
pgi_status pgi_scene_get_camera(const pgi_scene *scene, size_t i, pgi_camera_def *out);

size_t pgi_scene_light_group_count(const pgi_scene *scene);
pgi_status pgi_scene_get_light_group(const pgi_scene *scene, size_t i, pgi_light_group *out);
/* Moves light group i so that its position becomes `pos` (area groups: a
 * translation of their triangles). Sun: PGI_ERR_UNSUPPORTED. */
pgi_status pgi_scene_set_light_position(pgi_scene *scene, size_t i, const float pos[3]);

/* Progressive accumulation for interactive use: renders one more frame
 * into the renderer's running average and writes the average to `out`.
 * The average restarts by itself when anything that changes the picture
 * differs from the previous call (desc fields, view camera, scene time,
 * geometry or light positions); frame k (0-based) uses seed stream k and
 * radius r_k with r_0 = desc radius, r_{k+1}^2 = r_k^2 (k+1+alpha)/(k+2),
 * alpha = 2/3 (Knaus & Zwicker 2011). Needs an exact estimator for k > 0
 * (an approximate one restarts every frame). stats->frames is the count. */
pgi_status pgi_renderer_accumulate(pgi_renderer *r, const pgi_render_desc *desc, pgi_image *out,
                                   pgi_frame_stats *stats);
/* Forgets the running average. */
void pgi_renderer_reset_accumulation(pgi_renderer *r);
/* Radius of progressive frame k (0-based) for a first radius r0. */
float pgi_progressive_radius(float r0, int k);

#ifdef __cplusplus
}
#endif

#include "photongi/estimator.h"

#endif
