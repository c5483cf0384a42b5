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

#include "photongi/estimator.h"
#include "photongi/status.h"
#include "photongi/version.h" /* generated: PGI_VERSION_STRING, _MAJOR, _MINOR, _PATCH */

#ifdef __cplusplus
extern "C" {
#endif

/* The version of the library linked (PGI_VERSION_STRING is that of the headers). */
const char *pgi_version(void);

/* ------------------------------------------------------------------ scene */

typedef struct pgi_scene pgi_scene;

typedef struct pgi_camera_def {
    float eye[3], look_at[3], up[3];
    float fov_y_deg; /* vertical field of view, degrees */
} pgi_camera_def;

/* Defaults a scene description suggests for rendering it (0 = none given). */
typedef struct pgi_scene_defaults {
    uint32_t photons;
    float radius;
    int bounces;
    int width, height;
    float exposure;
} pgi_scene_defaults;

/* The model of mesh materials with a specular colour (MTL `illum 2`, Assimp's Phong/Blinn
 * shading with Ks > 0); docs/scene-format.md "Materials". */
typedef enum pgi_specular {
    PGI_SPECULAR_DEFAULT = 0, /* the scene description's "specular", else GGX */
    PGI_SPECULAR_GGX = 1,     /* microfacet plastic: Lambertian base under a GGX lobe with the Fresnel
                                 of a dielectric (index Ni, default 1.5; alpha = sqrt(2 / (Ns + 2))) */
    PGI_SPECULAR_PHONG = 2    /* the tiled paper's energy-conserving Blinn-Phong (Ks = F0, exponent Ns,
                                 kd lowered to 1 - Ks), to reproduce the papers' images */
} pgi_specular;

typedef struct pgi_scene_info {
    const char *name;   /* "cornell", or the description/mesh file name */
    const char *source; /* "built-in" or the file that was loaded */
    size_t triangles, vertices, materials, textures;
    size_t cutout_materials; /* materials with a cut-out mask (MTL map_d, glTF alphaMode MASK) */
    size_t lights;           /* all emitters; emissive triangles count one each, the sky one */
    size_t point_lights, spot_lights, sun_lights, area_triangles;
    size_t sky_lights; /* 1 when the scene has a sky or environment map (docs/scene-format.md), else 0 */
    float bounds_min[3], bounds_max[3];
    size_t cameras;
    pgi_camera_def camera; /* camera 0 */
    int camera_auto;       /* 1: the scene gives no camera and camera 0 was placed by the loader (outside the
                              bounds on +z, looking at their centre: a closed room is seen from outside) */
    pgi_scene_defaults defaults;
    double surface_area;     /* total triangle area, scene units squared */
    size_t animated_objects; /* objects with a motion (see pgi_scene_set_time) */
    double anim_duration;    /* last keyframe time over all motions, seconds (0 if none) */
    pgi_specular specular;   /* model of the mesh's specular materials now (GGX or PHONG) */
    size_t glossy_materials; /* mesh materials that follow it (pgi_scene_set_specular) */
    /* What the scene's files hold that photongi does not use or could not find, in one line (a
     * material library that is not there, animations, a second vertex colour set, glTF extensions,
     * ...; "" when nothing): for the caller to show as a warning. Valid while the scene lives. */
    const char *warnings;
    size_t portals; /* openings marked for the sun and the sky ("portals", docs/scene-format.md) */
} pgi_scene_info;

/* Loads a scene. `spec` is a built-in name ("cornell", "giref",
 * "sphere-and-plane", "cutout"), a scene description (.json), a scene name with a
 * description <name>.json in ./scenes, in the source tree's scenes/ (a build
 * run from any directory) or in the installed share/photongi/scenes (looked up
 * in that order), or a mesh file Assimp reads (OBJ/MTL, glTF, PLY). A mesh file's
 * own cameras (glTF camera nodes, Assimp's cameras of other formats) and glTF lights
 * (KHR_lights_punctual) come with it (docs/scene-format.md); what it holds that is not
 * used is named in pgi_scene_info.warnings. Mesh paths
 * in a description resolve against the description's folder, then against
 * $PHOTONGI_SCENES, or when that is not set the source tree's ../shared/scenes
 * and then ../shared/scenes from the working directory. An unknown name is
 * PGI_ERR_INVALID_ARG (the message lists the names there are), a missing file
 * PGI_ERR_IO. */
pgi_status pgi_scene_load(const char *spec, pgi_scene **out);
/* pgi_scene_load with a memory budget (bytes; 0: pgi_memory_default_budget(), PGI_MEMORY_UNLIMITED:
 * none) that the files it reads are held to before they are read: a mesh file, the files Assimp
 * opens for it (material libraries, buffers), and the decoded textures (docs/memory.md). */
pgi_status pgi_scene_load_budget(const char *spec, uint64_t max_memory, pgi_scene **out);
void pgi_scene_destroy(pgi_scene *scene);
void pgi_scene_get_info(const pgi_scene *scene, pgi_scene_info *out);
/* Switches the mesh materials with a specular colour (pgi_scene_info.glossy_materials) to
 * `model` (PGI_SPECULAR_DEFAULT: the description's "specular", else GGX). Materials a description
 * declares itself ("objects") keep their "type". Not thread-safe with a render of the scene. */
pgi_status pgi_scene_set_specular(pgi_scene *scene, pgi_specular model);
size_t pgi_builtin_scene_count(void);
const char *pgi_builtin_scene_name(size_t i);

/* ----------------------------------------------------------------- render */

typedef enum pgi_output {
    PGI_OUTPUT_ALL = 0,         /* emission + direct + indirect */
    PGI_OUTPUT_INDIRECT = 1,    /* the estimator's indirect radiance only; no shadow ray (CPU and GPU) */
    PGI_OUTPUT_DIRECT = 2,      /* emission + direct only */
    PGI_OUTPUT_PHOTON_COUNT = 3 /* photons that contributed at each pixel (all three channels); needs a
                                   second build + estimate pass over unit-flux photons */
} pgi_output;

/* Where in its pixel each view sample of a frame looks (pgi_render_desc.jitter). The image of one
 * frame is a point sample per pixel; an average of frames converges to the box-filtered pixel
 * integral (what `pgi_reference_render` computes) only when the points are spread over the pixel. */
typedef enum pgi_jitter {
    PGI_JITTER_AUTO = 0, /* default: a single frame samples pixel centres (the crispest single image);
                            progressive mode jitters every frame after the first */
    PGI_JITTER_OFF,      /* pixel centres, every frame (a progressive average converges to point samples) */
    PGI_JITTER_ON        /* every frame: a uniform point in each pixel, drawn from (seed, pixel index), the
                            same for every pass of the frame and any thread count (a box filter);
                            progressive frame k takes point k of one stratified sequence per pixel */
} pgi_jitter;

/* How the view samples read their textures (pgi_render_desc.texture_filter; docs/design.md
 * "Textures"). Only the albedo at the view samples changes: photons and the reference path tracer
 * read level 0, so every estimator sees the same view samples either way. */
typedef enum pgi_texture_filter {
    PGI_TEXTURE_FILTER_AUTO = 0, /* default: ON where the frame's view samples sit at pixel centres (jitter
                                    resolved OFF), else OFF (a jittered average integrates the pixel itself) */
    PGI_TEXTURE_FILTER_OFF,      /* the texel at the hit (bilinear, level 0) */
    PGI_TEXTURE_FILTER_ON        /* a ray cone of a pixel's width (Ray Tracing Gems ch. 20) through the
                                    eye path's mirrors and glass: its footprint's mip level, trilinear
                                    probes along its long axis (CPU and Vulkan alike) */
} pgi_texture_filter;

/* How photons leave the lights (docs/emission.md). */
typedef enum pgi_emission {
    PGI_EMISSION_UNIFORM = 0, /* default: by the lights' power and emission profiles (the papers' choice) */
    PGI_EMISSION_GUIDED,      /* view importance: a uniform pilot of about an eighth of the photons, then
                                 photons steered towards the light paths whose photons landed where the
                                 camera looks, weighted so that the estimate stays unbiased */
    PGI_EMISSION_AUTO,        /* portal where the scene has portals that carry under half of the sun's and
                                 the sky's uniform paths (pgi_emission_stats.portal_share), else guided where
                                 the pilot predicts at least 1.25x the photons in view per unit
                                 of frame cost (pgi_emission_stats.value: fewer paths per stored photon
                                 count too), uniform elsewhere (PGI_EMISSION_UNIFORM's photons then); on the
                                 GPU uniform. The choice and why: pgi_emission_stats.used, .reason */
    PGI_EMISSION_PORTAL       /* the sun's and the sky's photons start on the scene's portals (windows,
                                 docs/emission.md), weighted so that the flux through them is unbiased;
                                 other lights as uniform. Needs --radius-policy fixed; CPU only */
} pgi_emission;

/* Which photons are stored (docs/emission.md). */
typedef enum pgi_store {
    PGI_STORE_ALL = 0, /* default: every photon from the second bounce on */
    PGI_STORE_VIEW     /* only photons that may lie within the radius of a view sample (the others add nothing
                          to the image; importance-driven storage, Keller & Wald 2000): `photons` then counts
                          photons where the camera looks, and more paths are traced to find them. Needs a
                          given radius (not PGI_RADIUS_AUTO) */
} pgi_store;

/* Limits of a render (pgi_render_desc): photons to store, image size (also the largest image
 * pgi_image_read accepts), frames of pgi_render_progressive. */
#define PGI_MAX_PHOTONS 100000000u
#define PGI_MAX_IMAGE_SIDE 16384
#define PGI_MAX_IMAGE_PIXELS (36u * 1024u * 1024u)
#define PGI_MAX_PROGRESSIVE_FRAMES 1000000

/* Limits of the numbers in a scene and a render (docs/scene-format.md, "Numbers"):
 * - every coordinate (vertex, camera eye and look-at, light position, object centre, motion
 *   translation, and the scene's bounds at every keyframe of its motions), and every direction
 *   and up vector's components: |x| <= PGI_MAX_COORD. Embree's rays are valid up to about
 *   1.8e18 (its FLT_LARGE); 1e15 leaves a factor of 1000 for origins moved along rays and for
 *   the scene's diagonal, whose square (the sun's cross-section, about 1e31) stays a float.
 * - radiances and what multiplies to one (light intensity and irradiance, material emission,
 *   sky colour x intensity, an environment map's pixels x scale): 0..PGI_MAX_RADIANCE; a light's
 *   power (intensity x solid angle, irradiance x the scene's cross-section) at most
 *   PGI_MAX_LIGHT_POWER, so photon fluxes and their sums stay floats.
 * - the photon radius (and r_min, r_max): PGI_MIN_RADIUS..PGI_MAX_RADIUS, so that pi r^2 and
 *   its inverse are normal floats (1e-20 made pi r^2 underflow: every pixel NaN). */
#define PGI_MAX_COORD 1e15
#define PGI_MAX_RADIANCE 1e12
#define PGI_MAX_LIGHT_POWER 1e30
#define PGI_MIN_RADIUS 1e-9
#define PGI_MAX_RADIUS 1e15

/* pgi_render_desc.max_memory: no memory budget. */
#define PGI_MEMORY_UNLIMITED UINT64_MAX

/* Progress of a render, for a progress bar (pgi_render_desc.progress). */
typedef struct pgi_progress {
    const char *pass;     /* the pass now running: "view", "trace", "build", "estimate", "direct" */
    uint64_t done, total; /* "trace": photons stored so far, of `total`; other passes: 0 of 0 */
    int frame, frames;    /* pgi_render_progressive: this frame (0-based) of `frames`; else 0 of 1 */
    double elapsed_ms;    /* since the call started (pgi_render_progressive: since its start) */
    float radius;         /* the frame's photon radius once it is known (a given one from the start, the
                             automatic one from "build" on), else 0 */
} pgi_progress;
/* Called on the thread that called the render, as each pass starts and between batches of
 * photon paths, never from inside a parallel region: it cannot change the image. */
typedef void (*pgi_progress_fn)(void *user, const pgi_progress *progress);

/* pgi_render_desc.radius: choose the radius each frame (docs/radius.md). */
#define PGI_RADIUS_AUTO (-1.0f)

/* Where the frame runs (pgi_render_desc.device; docs/gpu.md). On the GPU the whole frame runs on the
 * device: view samples, photon tracing, the estimator, direct light and the sum; the image is read
 * back. hashgrid works on the device's own photons and view samples; the other GPU estimators read
 * them back and upload them to their own buffers (docs/gpu.md, "What runs where"). */
typedef enum pgi_device {
    PGI_DEVICE_CPU = 0,   /* default */
    PGI_DEVICE_VULKAN = 1 /* the Vulkan compute backend (a build with PGI_VULKAN): estimators with a GPU
                             version only (pgi_device_estimators), and of their options and the frame's
                             settings those the device has; PGI_ERR_UNSUPPORTED naming any other */
} pgi_device;
/* pgi_render_desc.device_index for the loader's Vulkan device i (0-based, as `--device vulkan:i`);
 * 0 = automatic: the first discrete GPU, else integrated, else a CPU device (lavapipe). */
#define PGI_DEVICE_INDEX(i) ((i) + 1)

/* pgi_render_desc.direct_samples when left 0: PGI_DIRECT_SAMPLES_PORTALS where the sky's direct light
 * is sampled through portals (a scene with a sky and "portals", on either device), else
 * PGI_DIRECT_SAMPLES_DEFAULT. The statistics' settings report the resolved count. */
#define PGI_DIRECT_SAMPLES_DEFAULT 16
#define PGI_DIRECT_SAMPLES_PORTALS 4

/* Zero means "default" for every field, nested estimator options included. */
typedef struct pgi_render_desc {
    const char *estimator;  /* registered name; default PGI_DEFAULT_ESTIMATOR */
    pgi_estimator_desc est; /* the estimator's options (include/photongi/estimator.h); options of other
                                estimators are ignored, so one desc serves every estimator */
    uint32_t photons;       /* photons to store (at least 1); default scene's or 200000 */
    float radius;           /* photon radius in scene units (> 0); default the scene's, else chosen each frame
                               from the photon density the camera sees (PGI_RADIUS_AUTO: that even when the
                               scene gives one; only with PGI_RADIUS_FIXED, the other policies default to 2%
                               of the scene's diagonal) */
    int width, height;      /* default scene's or 640x480 */
    int bounces;            /* max photon bounces (1..64); default scene's or 4 */
    uint64_t seed;          /* default 1 */
    int threads;            /* OpenMP threads of the library's parallel regions; 0 = OpenMP's default */
    int camera;             /* index into the scene's cameras (pgi_scene_find_camera finds one by name) */
    int direct_samples;     /* shadow samples per pixel for area lights and for the sky (1..4096); default
                               PGI_DIRECT_SAMPLES_DEFAULT (16), or PGI_DIRECT_SAMPLES_PORTALS (4) in a
                               scene with a sky and portals, whose sky samples are worth more (docs/emission.md,
                               Portals); a value given is used as given */
    pgi_output output;
    const pgi_camera_def *view; /* non-NULL: render from this camera instead of the scene's `camera`
                                   (borrowed for the call; the viewer's free camera) */
    /* Per-photon footprints (radius policies; need an estimator with PGI_EST_CAP_PHOTON_RADIUS). */
    int radius_policy;  /* PGI_RADIUS_FIXED (default), PGI_RADIUS_PATH, PGI_RADIUS_DIFFERENTIALS */
    float r_min, r_max; /* path: radius range (default r_max = radius, r_min = r_max/8);
                                differentials: r_max clamps the footprint radius (default: radius) */
    float smoothing;    /* differentials: smoothing factor s (> 0); 0 = automatic (docs/bvh.md) */
    int filter;         /* bilateral reconstruction filter radius in pixels on the indirect light (0 off) */
    pgi_jitter jitter;  /* sub-pixel position of the view samples; default PGI_JITTER_AUTO (resolved: a single
                           frame reports OFF, a progressive average the caller's value) */
    pgi_texture_filter texture_filter; /* the view samples' textures; default PGI_TEXTURE_FILTER_AUTO (resolved:
                                          the statistics report ON or OFF) */
    pgi_emission emission;             /* photon emission; default PGI_EMISSION_UNIFORM (photongi render, the viewer
                                          and the Python module default to PGI_EMISSION_AUTO) */
    pgi_store store;                   /* which photons are stored; default PGI_STORE_ALL */
    pgi_progress_fn progress;          /* may be NULL; not part of the picture (progressive mode does not restart) */
    void *progress_user;               /* passed to `progress` */
    uint64_t max_memory;      /* memory budget in bytes (docs/memory.md): a frame whose scene, BVH, photons, view
                                 samples, buffers and estimator structures would need more is refused before it
                                 allocates them (PGI_ERR_OOM naming what does not fit; a photon count before any
                                 tracing); 0 = default: pgi_memory_default_budget(); PGI_MEMORY_UNLIMITED: none.
                                 Not part of the picture. */
    pgi_device device;        /* where the estimator runs; default PGI_DEVICE_CPU */
    int device_index;         /* PGI_DEVICE_VULKAN: 0 = automatic, PGI_DEVICE_INDEX(i) = Vulkan device i */
    struct pgi_aovs *aovs;    /* non-NULL: the frame's AOVs are written to these caller-owned buffers (borrowed for
                                 the call; see pgi_aovs); not part of the picture. CPU device only */
    float shift[2];           /* sub-pixel offset of every view sample, pixels (x right, y down), each in
                                 [-0.5, 0.5], added to the pixel centre (or the jittered point): an engine's TAA
                                 jitter (pgi_camera_from_matrices); 0 = none. CPU device only; like `view`, not
                                 in the statistics' settings */
    const pgi_cancel *cancel; /* may be NULL: once requested (pgi_cancel_request, from another thread, the
                                 progress callback or a signal handler) the frame stops within a fraction of
                                 a second (between passes, between batches of photon paths, every few
                                 hundred view samples in the estimators and direct light; between passes on
                                 the GPU) and returns PGI_ERR_CANCELLED; the output image's pixels are then
                                 unspecified and a progressive average is left as it was. Not part of the
                                 picture */
} pgi_render_desc;

typedef enum pgi_radius_policy {
    PGI_RADIUS_FIXED = 0,     /* one radius for every photon */
    PGI_RADIUS_PATH,          /* tiled paper eqs. 4-5: r_min + (r_max - r_min) sqrt(1 - path probability) */
    PGI_RADIUS_DIFFERENTIALS, /* BVH paper §4: skewed ellipsoids from photon differentials */
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

#define PGI_MAX_STAT_ENTRIES 24

typedef struct pgi_named_value {
    const char *name;
    double value;
} pgi_named_value;

/* How the automatic radius was chosen (pgi_frame_stats.auto_radius). For `queries` view samples
 * spread over the image, the distance to the k-th nearest photon each would gather; the radius is
 * the `quantile` of those distances (`knn`), clamped to [lo, hi] and shrunk, when the mean photons
 * a gather would read exceeds `mean_cap`, by the square root of the excess. */
typedef struct pgi_auto_radius_stats {
    int used; /* 0: the radius was given (desc, scene) */
    int k;
    float quantile, knn, lo, hi;
    int queries, starved; /* starved: samples with fewer than k photons near them */
    double mean_reads;    /* mean photons a query gathers at the chosen radius (0: not counted) */
    double mean_cap;
    const char *why; /* one line: the quantile, a clamp, the cost cap, or the fallback (static string) */
} pgi_auto_radius_stats;

/* How photons left the lights (pgi_frame_stats.emission); all zero with uniform emission but `portals`
 * (the scene's portals, on the CPU device). A photon
 * is "in view" when it lands in a cell of the view grid: cells of size `cell` holding a view sample
 * whose surface faces the same way. */
typedef struct pgi_emission_stats {
    int guided;                      /* 1: the guide steered the photons after the pilot (0: it kept uniform emission:
                               auto predicted too little gain, or the pilot saw under 32 photons in view) */
    int bins;                        /* the guide's bins */
    uint64_t pilot_paths;            /* path indices the uniform pilot used (all it traced); their photons were dropped
                               (0 when the guide did not steer: the pilot's photons were kept) */
    double gain;                     /* predicted photons in view per stored photon, steered over uniform */
    double paths_per_stored;         /* predicted paths traced per photon stored, steered (from the pilot) */
    double paths_per_stored_uniform; /* ... and uniform */
    double value;                    /* predicted photons in view per unit of frame cost, steered over uniform: gain x
                               (paths_per_stored_uniform + 1) / (paths_per_stored + 1), a stored photon
                               costing the estimator about what one path costs the tracer; auto steers
                               when it is at least 1.25 */
    double in_view;                  /* fraction of the photons of this frame's paths (the steered ones: not the pilot's
                               when it was dropped) that landed in view; measured over every path traced */
    double in_view_uniform;          /* the same for uniform emission (from the pilot and the bins) */
    size_t cells;                    /* cells the camera sees */
    float cell;                      /* their size, scene units */
    double grid_ms;                  /* building the view grid(s) */
    uint64_t culled;                 /* PGI_STORE_VIEW: photons not stored (no view sample within the radius) */
    int portal;                      /* 1: the sun's and the sky's photons left through the portals */
    size_t portals;                  /* the scene's portals */
    double portal_share;             /* lines through the portals per line of the sun's and the sky's uniform
                                        emission (power-weighted): the fraction of their uniform paths
                                        that can enter (0: no portals, no sun or sky, or emission
                                        uniform or guided, which do not compute it) */
    pgi_emission used;               /* the emission the photons had: PGI_EMISSION_UNIFORM, _GUIDED or _PORTAL (`auto`'s
                           choice; on the GPU always uniform) */
    const char *reason;              /* why, in words (a static string; NULL when no photons were traced) */
} pgi_emission_stats;

/* What the caller did around the frame (pgi_frame_stats.run), for statistics that reproduce a run:
 * the renderer leaves it zeroed; `photongi render` fills it in before it writes --stats, and the JSON
 * has it under "run" when `scene` is set. */
typedef struct pgi_run_info {
    const char *scene;          /* the scene as given to pgi_scene_load */
    const char *scene_file;     /* the file that was loaded (pgi_scene_info.source) */
    uint64_t scene_hash;        /* the caller's hash of that file's bytes (FNV-1a 64; 0: none) */
    float exposure;             /* the exposure of the PNG tone map */
    float time;                 /* pgi_scene_set_time's t */
    pgi_specular specular;      /* pgi_scene_set_specular's model (DEFAULT: not set) */
    const pgi_camera_def *view; /* the camera rendered from instead of the scene's (pgi_render_desc.view:
                                   `render --eye ...`), or NULL; "view" in the JSON, as a scene
                                   description's camera block */
} pgi_run_info;

/* What a temporal step did (pgi_frame_stats.temporal). */
typedef struct pgi_temporal_stats {
    int on;              /* the step was a temporal one */
    int restarted;       /* 1: the history started afresh (not only the camera moved, or the first step) */
    double reused;       /* pixels whose history was kept when the camera moved (fraction; 0 otherwise) */
    double history;      /* the history's mean weight in frames, over all pixels */
    float filter_weight; /* how much of the filtered indirect light the picture holds (1 fresh, 0 converged) */
    int filter_passes;   /* a-trous passes run (0: none) */
    double reproject_ms; /* reprojection and blending */
    double filter_ms;    /* the filter */
} pgi_temporal_stats;

/* What a frame on a Vulkan device exchanged with the host (pgi_frame_stats.traffic): each submit
 * is a host-device sync, each download a read-back. The default GPU frame downloads the image and
 * a few counters (list sizes, the statistics' counts); the automatic radius adds the view samples
 * and photons. */
typedef struct pgi_device_traffic {
    uint64_t submits;                   /* command sequences submitted and waited for */
    uint64_t dispatches;                /* compute dispatches */
    uint64_t uploads, upload_bytes;     /* host-to-device copies */
    uint64_t downloads, download_bytes; /* device-to-host copies */
} pgi_device_traffic;

typedef struct pgi_frame_stats {
    const char *estimator;
    int width, height, threads;
    uint64_t photons_emitted; /* light paths emitted */
    uint64_t photons_stored;
    uint64_t photon_rays;            /* rays cast while tracing photons */
    uint64_t photon_paths_discarded; /* light paths traced beyond the photons asked for (thrown away) */
    uint64_t primary_rays, shadow_rays;
    float radius;
    /* wall-clock milliseconds */
    double view_ms, trace_ms, build_ms, estimate_ms, direct_ms, total_ms;
    /* estimator sub-passes (e.g. tiled: bounds, count, scan, copy, gather) */
    pgi_named_value passes_ms[PGI_MAX_STAT_ENTRIES];
    int pass_count;
    /* Bytes held at the end of the frame by every large allocation (docs/memory.md): "scene" (geometry,
     * materials, lights, sky), "textures", "embree_bvh" (Embree's own count), "photons", "footprints",
     * "trace_scratch", "view_samples", "frame_buffers", "image", "progressive_sum", then the estimator's
     * structures under its names and "estimator_scratch" (its build buffers not listed). */
    pgi_named_value memory_bytes[PGI_MAX_STAT_ENTRIES];
    int memory_count;
    uint64_t memory_counted_peak; /* the largest sum of those entries since the renderer was created (Embree's
                                     build scratch included) */
    uint64_t memory_peak_rss;     /* the process's peak resident set so far, bytes (getrusage), for comparison */
    uint64_t reads;               /* (photon, view sample) pairs the estimator examined */
    uint64_t contributing;        /* of those, the pairs that passed the sphere + hemisphere test (<= reads; the
                                     same count for every exact estimator) */
    uint64_t reads_bulk;          /* of reads: pairs taken as a node's sum without reading each photon (trivial
                                     accept); reads - reads_bulk photon records were read one by one */
    uint64_t nodes_visited;       /* cells / tiles / nodes touched */
    int frames;                   /* frames averaged into the image (progressive); 1 for a single frame */
    int estimators_created;       /* estimators this call created (0 when the renderer reused its estimator) */
    pgi_render_desc settings;     /* what was rendered: every default filled in (estimator options too; `view`,
                                  `progress` and `progress_user` are NULL; `radius` is the first frame's) */
    double rt_update_ms;          /* updating the ray-tracing scene after geometry moved (0 if nothing moved) */
    int radius_policy;            /* pgi_radius_policy used */
    int leaf_size;                /* "bvh": leaf-size threshold used */
    float footprint_bin_width;    /* 0: no per-photon footprints */
    uint64_t footprint_hist[PGI_FOOTPRINT_BINS]; /* see PGI_FOOTPRINT_BINS */
    pgi_auto_radius_stats auto_radius;           /* how `radius` was chosen, when it was */
    double radius_ms;                            /* choosing it (0 when given) */
    pgi_emission_stats emission;                 /* guided or portal photon emission, when asked for */
    const char *device;          /* "cpu", or the Vulkan device's name ("llvmpipe (LLVM 15.0.6, 256 bits)"); valid while
                           the renderer lives. With a GPU: passes_ms has the device's passes ("gpu_count", ...,
                           "gpu_gather": GPU timestamps; "gpu_upload", "gpu_submit", "gpu_download": host wall
                           clock) and memory_bytes the device's buffers ("gpu_photons", "gpu_hash", ...) */
    pgi_run_info run;            /* zeroed by the renderer; see pgi_run_info */
    pgi_temporal_stats temporal; /* pgi_temporal_step's part; zeroed by the renderer */
    pgi_device_traffic traffic;  /* with a GPU: what crossed between host and device; zero on the CPU */
} pgi_frame_stats;

/* Renders one frame into `out` (free with pgi_image_free). Pass a zeroed
 * image the first time; an image of the right size is reused, any other is
 * freed and replaced. `stats` may be NULL. */
pgi_status pgi_render(const pgi_scene *scene, const pgi_render_desc *desc, pgi_image *out, pgi_frame_stats *stats);

typedef struct pgi_renderer pgi_renderer;
/* A renderer keeps the ray-tracing scene and per-frame buffers between frames
 * (the viewer and the benchmark render many frames). The scene is borrowed
 * and must outlive the renderer. */
pgi_status pgi_renderer_create(const pgi_scene *scene, pgi_renderer **out);
/* One frame. The renderer creates its estimator once per estimator name and
 * options and reuses it while they stay the same (radius, seed, threads and
 * the camera are per-frame values). desc->cancel abandons it (PGI_ERR_CANCELLED);
 * the renderer stays usable. */
pgi_status pgi_renderer_render(pgi_renderer *r, const pgi_render_desc *desc, pgi_image *out, pgi_frame_stats *stats);
void pgi_renderer_destroy(pgi_renderer *r);
const pgi_scene *pgi_renderer_scene(const pgi_renderer *r);

/* What density estimation reads in one frame: the view samples and photons
 * of `desc` (traced as pgi_renderer_render traces them, on desc's device), so
 * that a tool can run estimators (its own included) on the renderer's inputs.
 * On PGI_DEVICE_VULKAN they are the device's own, read back into host arrays
 * (the photons' normals, which the device does not keep, are 0). */
typedef struct pgi_frame_inputs {
    const pgi_photons *photons;      /* borrowed: valid until the renderer's next call */
    const pgi_view_samples *samples; /* borrowed: likewise */
    pgi_camera camera;
    float radius;     /* the resolved photon radius */
    float scene_area; /* total triangle area of the scene */
    uint64_t seed;
} pgi_frame_inputs;
/* Casts the view samples and traces the photons of one frame on desc's device
 * (the automatic radius chosen from them); stats (may be NULL) gets the view
 * and trace passes (on the device, "gpu_readback" too). A setting the device
 * does not have for these passes (--emission guided on the GPU) is refused by
 * name: PGI_ERR_UNSUPPORTED. */
pgi_status pgi_renderer_prepare(pgi_renderer *r, const pgi_render_desc *desc, pgi_frame_inputs *out,
                                pgi_frame_stats *stats);

void pgi_image_free(pgi_image *img);
/* Writes PNG (tone-mapped: exposure, then sRGB) or EXR (linear float),
 * chosen by the file extension. Atomically: to a temporary file beside the
 * target, flushed and renamed over it, so a failure (a full disk) or a kill
 * keeps the previous file; a symlink's target is replaced, and a path that is
 * not a regular file (/dev/null) is written directly. pgi_stats_write_json
 * and pgi_reference_meta_write write the same way. */
pgi_status pgi_image_write(const pgi_image *img, const char *path, float exposure);
/* Tone maps to 8-bit sRGB (3 bytes a pixel, caller-owned buffer). */
void pgi_tonemap_srgb8(const pgi_image *img, float exposure, unsigned char *out);
/* The process's peak resident set size so far, bytes (getrusage; 0 if unknown). */
uint64_t pgi_memory_peak_rss(void);
/* The memory budget a render desc with max_memory 0 gets: the machine's physical memory, or the
 * cgroup's memory limit when lower (docs/memory.md). */
uint64_t pgi_memory_default_budget(void);
/* Writes the frame statistics as JSON to `path` ("-" = standard output): the counters, times and
 * memory, "version", "settings" (every setting of the frame as `photongi render` spells it: the
 * option's name without "--" and its value as a string, the estimator's options resolved, so that
 * `photongi render --from-stats` renders the frame again) and "run" (pgi_frame_stats.run). */
pgi_status pgi_stats_write_json(const pgi_frame_stats *stats, const char *path);
/* The same JSON document into buf (size bytes, NUL-terminated, cut short when too small, like
 * snprintf): returns its length without the NUL, so a result >= size asks for a buffer of that
 * plus one; 0 when out of memory. */
size_t pgi_stats_json(const pgi_frame_stats *stats, char *buf, size_t size);

/* ------------------------------------------------------ dynamic scenes */

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
    const char *name;  /* "point 0", or the emissive material's name; valid while the scene lives */
    float position[3]; /* point/spot: position; area: area-weighted centroid; sun: 0 */
    size_t triangles;  /* area: emissive triangles in the group */
} pgi_light_group;

/* Camera i of the scene (the viewer starts from it). */
pgi_status pgi_scene_get_camera(const pgi_scene *scene, size_t i, pgi_camera_def *out);
/* The name of camera i (a glTF camera node's name, a description's camera "name"; "" when it has
 * none or i is out of range). Valid while the scene lives. */
const char *pgi_scene_camera_name(const pgi_scene *scene, size_t i);
/* The camera `name_or_index` stands for, as `--camera` takes it: a whole number is an index, any
 * other text a camera's name (exact match, the first of that name). PGI_ERR_INVALID_ARG when there
 * is none; the message lists the scene's cameras. */
pgi_status pgi_scene_find_camera(const pgi_scene *scene, const char *name_or_index, size_t *index);

size_t pgi_scene_light_group_count(const pgi_scene *scene);
pgi_status pgi_scene_get_light_group(const pgi_scene *scene, size_t i, pgi_light_group *out);
/* Moves light group i so that its position becomes `pos` (area groups: a
 * translation of their triangles). Sun: PGI_ERR_UNSUPPORTED. */
pgi_status pgi_scene_set_light_position(pgi_scene *scene, size_t i, const float pos[3]);

/* ------------------------------------------------- an engine's scene in memory
 * A scene from the caller's arrays instead of a file (pgi_scene_create), its vertices moved each
 * frame (pgi_scene_update_positions), its lights added, removed and changed, a camera from view
 * and projection matrices, and AOVs for a denoiser (pgi_render_desc.aovs). The file loaders
 * build their scenes the same way, so a scene given as arrays renders byte-identical to the same
 * scene read from a file (docs/engine.md). */

/* Material models (the internal ones the file loaders map MTL / glTF materials to). */
typedef enum pgi_material_type {
    PGI_MATERIAL_LAMBERT = 0, /* diffuse: albedo `diffuse` (times the texture) / pi */
    PGI_MATERIAL_GLOSSY,      /* a mesh file's specular material (MTL illum 2): its model follows
                                 pgi_scene_set_specular (GGX plastic by default, or the papers' Blinn-Phong) */
    PGI_MATERIAL_PLASTIC,     /* Lambertian base under a GGX lobe: F0 `specular`, alpha sqrt(2 / (shininess + 2)),
                                 the Fresnel of index `ior` */
    PGI_MATERIAL_PHONG,       /* energy-conserving Blinn-Phong: F0 `specular`, exponent `shininess` */
    PGI_MATERIAL_MIRROR,      /* perfect mirror of reflectance `specular` */
    PGI_MATERIAL_GLASS        /* dielectric of index `ior`, transmission tint `specular` */
} pgi_material_type;

/* A texture as pixels: 8-bit sRGB (the one texture type of the library; lookups return linear
 * RGB), `channels` bytes a texel (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA), rows from the top of
 * the image, no padding. Copied by pgi_scene_create. */
typedef struct pgi_texture_desc {
    int width, height, channels;
    const unsigned char *pixels;
} pgi_texture_desc;

typedef struct pgi_material_desc {
    const char *name; /* NULL: "material <i>" */
    pgi_material_type type;
    float diffuse[3];    /* albedo in [0, 1] (multiplies the texture) */
    float specular[3];   /* see pgi_material_type */
    float shininess;     /* Phong exponent / GGX roughness as above (MTL Ns), 0..10000 */
    float ior;           /* glass, plastic, glossy: index of refraction (> 1); 0: 1.5 */
    float emission[3];   /* emitted radiance (MTL Ke): non-zero makes its triangles area lights */
    int diffuse_texture; /* 0: none; i + 1: textures[i] of the scene desc */
    int alpha_texture;   /* 0: none; i + 1: textures[i], whose alpha (grey if it has none) cuts the surface
                             out where it is below alpha_cutoff */
    float alpha_cutoff;  /* with alpha_texture: 0 = 0.5 */
} pgi_material_desc;

/* One mesh: positions (3 floats a vertex), optional normals (3 floats; NULL: every mesh of the
 * scene must leave them out, and the scene is flat-shaded) and uvs (2 floats; NULL: 0, 0),
 * triangles as 3 vertex indices into this mesh, a material per triangle (NULL: `material` for
 * all), and optional vertex colours (3 floats, linear RGB in [0, 1], interpolated across each
 * triangle and multiplying its material's diffuse albedo before the texture, as a mesh file's
 * vertex colours; NULL: white). The arrays are copied. */
typedef struct pgi_mesh_desc {
    size_t vertex_count;
    const float *positions, *normals, *uvs;
    size_t triangle_count;
    const uint32_t *indices;
    const uint32_t *materials; /* per triangle, indices into the scene desc's materials; NULL: `material` */
    uint32_t material;
    int dynamic;         /* 1: pgi_scene_update_positions will move it every frame: its triangles get a ray-tracing
                    structure of their own that is refitted (as a scene description's "motion"), instead
                    of the rebuild of the static one that moving other meshes costs */
    const float *colors; /* 3 floats a vertex (linear RGB in [0, 1]) or NULL: see above */
} pgi_mesh_desc;

/* A light: point, spot or sun (PGI_LIGHT_KIND_AREA are the emissive materials' triangles; only
 * their colour and intensity can be set, as the emission of their material). */
typedef struct pgi_light_desc {
    pgi_light_kind kind;
    float position[3];  /* point, spot */
    float direction[3]; /* spot: its axis; sun: the way the light travels (need not be unit) */
    float color[3];     /* linear RGB, multiplies intensity; all 0: white (1, 1, 1) */
    float intensity;    /* point, spot: W/sr; sun: irradiance W/m^2; area: radiance (the emission) */
    float cone_deg;     /* spot: half-angle of its cone, degrees in (0, 180) (a hard edge) */
} pgi_light_desc;

typedef struct pgi_scene_desc {
    const char *name; /* NULL: "memory" */
    const pgi_mesh_desc *meshes;
    size_t mesh_count;
    const pgi_material_desc *materials;
    size_t material_count;
    const pgi_texture_desc *textures;
    size_t texture_count;
    const pgi_light_desc *lights;
    size_t light_count;
    const pgi_camera_def *cameras; /* NULL / 0: one looking at the scene from +z (as a mesh file gets) */
    size_t camera_count;
    pgi_specular specular; /* PGI_MATERIAL_GLOSSY materials' model (pgi_scene_set_specular) */
    uint64_t max_memory;   /* as pgi_scene_load_budget: 0 default budget, PGI_MEMORY_UNLIMITED none */
} pgi_scene_desc;

/* Builds a scene from `desc` (nothing of it is kept). The checks of a file load: finite numbers,
 * coordinates within PGI_MAX_COORD, indices in range, radiances and powers within their limits,
 * the arrays within the memory budget; PGI_ERR_INVALID_ARG (PGI_ERR_OOM: the budget) with a
 * message naming the mesh, material, texture or light. A scene needs a light: an emissive
 * material or a light of `lights` (one may be added later only to a scene that has one). */
pgi_status pgi_scene_create(const pgi_scene_desc *desc, pgi_scene **out);

/* Number of meshes of a scene (pgi_scene_create's; a loaded scene has none). */
size_t pgi_scene_mesh_count(const pgi_scene *scene);
#define PGI_ALL_MESHES SIZE_MAX
/* New vertex positions (and normals, NULL: unchanged) of mesh `mesh`, or of every mesh in their
 * order (PGI_ALL_MESHES); vertex_count must be that mesh's (all meshes': their sum). Checked as at
 * creation (nothing changes on an error). A renderer updates its ray-tracing scene on its next
 * frame (refit for dynamic meshes, rebuild otherwise; pgi_frame_stats.rt_update_ms). Not
 * thread-safe with a render of the scene. */
pgi_status pgi_scene_update_positions(pgi_scene *scene, size_t mesh, const float *positions, const float *normals,
                                      size_t vertex_count);

/* Light groups (pgi_scene_get_light_group) as light descs. Adding puts the new light after the
 * other point, spot and sun lights (*group receives its index, may be NULL): the area groups'
 * indices go up by one. Removing (point, spot, sun; not the scene's last light) moves the
 * later groups down by one. Setting keeps the kind (an area group: its material's emission;
 * its position: pgi_scene_set_light_position). Checked as at creation; not thread-safe with a
 * render of the scene. */
pgi_status pgi_scene_get_light(const pgi_scene *scene, size_t group, pgi_light_desc *out);
pgi_status pgi_scene_set_light(pgi_scene *scene, size_t group, const pgi_light_desc *light);
pgi_status pgi_scene_add_light(pgi_scene *scene, const pgi_light_desc *light, size_t *group);
pgi_status pgi_scene_remove_light(pgi_scene *scene, size_t group);

/* A camera from a view matrix (world to camera) and a perspective projection, both 4x4
 * column-major as OpenGL and glm store them (m[4 * column + row]), the camera looking down its -z
 * with y up, for an image of width x height. The projection must be a perspective one (last row
 * 0, 0, -1, 0, no skew) whose aspect P[1][1] / P[0][0] is the image's (within 1e-3); its
 * off-centre terms P[0][2], P[1][2] (an engine's TAA jitter, in NDC) become `shift` (pixels, for
 * pgi_render_desc.shift; may be NULL when they are 0), at most half a pixel. The view matrix must be a rotation and a translation (PGI_ERR_INVALID_ARG naming the
 * problem: singular, scaled or sheared, orthographic, an aspect or offset that does not fit). */
pgi_status pgi_camera_from_matrices(const float view[16], const float projection[16], int width, int height,
                                    pgi_camera_def *out, float shift[2]);

/* AOVs of a frame (pgi_render_desc.aovs), each a caller-owned array of width x height pixels,
 * row-major from the top-left (NULL: not wanted), written after the frame:
 *   albedo   3 floats: the diffuse albedo (texture applied) of the first non-specular hit; 0: none
 *   normal   3 floats: its shading normal (unit, on the side the eye path arrives from); 0: none
 *   depth    1 float: the primary hit's distance along the camera's forward axis; 0: no hit
 *   direct   3 floats: emitted + direct light (pgi_output DIRECT's image; 0 with PGI_OUTPUT_INDIRECT)
 *   indirect 3 floats: the indirect light (PGI_OUTPUT_INDIRECT's image)
 * With PGI_OUTPUT_ALL the image is direct + indirect, pixel by pixel (the same float sum). */
typedef struct pgi_aovs {
    float *albedo, *normal, *depth, *direct, *indirect;
} pgi_aovs;

/* ---------------------------------------------------------- progressive */

/* Progressive photon mapping (Knaus & Zwicker 2011) on top of a renderer:
 * each step renders one more frame into a running average and writes the
 * average to `out`. Frame k (0-based) uses seed stream k and radius r_k with
 * r_0 = desc radius, r_{k+1}^2 = r_k^2 (k+1+alpha)/(k+2), alpha = 2/3. The
 * average restarts by itself when anything that changes the picture differs
 * from the previous step (desc fields, view camera, scene time, geometry or
 * light positions). Needs an exact estimator for k > 0 (an approximate one
 * restarts every step). stats->frames is the count. The renderer is
 * borrowed and must outlive the accumulator. */
typedef struct pgi_progressive pgi_progressive;
pgi_status pgi_progressive_create(pgi_renderer *r, pgi_progressive **out);
/* A step cancelled by desc->cancel (PGI_ERR_CANCELLED) adds nothing: the average stays as it was and
 * the next step goes on from it (out's pixels are then unspecified). Any other error restarts it. */
pgi_status pgi_progressive_step(pgi_progressive *p, const pgi_render_desc *desc, pgi_image *out,
                                pgi_frame_stats *stats);
/* Forgets the running average. */
void pgi_progressive_reset(pgi_progressive *p);
/* With on != 0, guided emission (PGI_EMISSION_GUIDED, or AUTO where it steers) keeps its guide from
 * frame to frame of one average: frame k > 0 runs no pilot and steers by the evidence of frames
 * 0..k-1 (each frame adds its paths' counts), so that later frames trace fewer paths and the guide
 * sharpens (docs/emission.md, "Across frames"). Unbiased, and the same seed gives the same image for
 * any thread count, but frame k then depends on the frames before it in this accumulator: its
 * images are not pgi_progressive_frame's (which photongi-mpi deals to its ranks), and a cancelled
 * step's batches stay in the evidence. Off by default (pgi_render_progressive leaves it off);
 * photongi-view turns it on. Takes effect from the next frame 1. */
void pgi_progressive_keep_guide(pgi_progressive *p, int on);
void pgi_progressive_destroy(pgi_progressive *p);
/* Averages `frames` (1..PGI_MAX_PROGRESSIVE_FRAMES) progressive frames from a fresh start; stats
 * gets the times and counters summed over the frames, the rest from the last. */
pgi_status pgi_render_progressive(pgi_renderer *r, const pgi_render_desc *desc, int frames, pgi_image *out,
                                  pgi_frame_stats *stats);
/* pgi_render_progressive that may end early: after each frame but the last, stop(stop_user) != 0
 * ends the average there (out holds the frames so far, stats->frames their count). A signal
 * handler's flag is what photongi render passes (Ctrl-C saves the average so far). */
pgi_status pgi_render_progressive_until(pgi_renderer *r, const pgi_render_desc *desc, int frames,
                                        int (*stop)(void *stop_user), void *stop_user, pgi_image *out,
                                        pgi_frame_stats *stats);
/* Radius of progressive frame k (0-based) for a first radius r0. */
float pgi_progressive_radius(float r0, int k);

/* Frame k (0-based) of the progressive sequence of `desc`, rendered on its own into `frame` (a
 * zeroed image the first time): the frame pgi_progressive_step adds as its (k+1)-th, whatever
 * was rendered before, so frames can be rendered in any order, on any process. Frame 0 is the
 * ordinary render of `desc` and resolves the first radius: stats->radius is r0, which every
 * later frame needs (`r0` is ignored for k = 0). Frame k > 0 uses seed stream k of desc->seed,
 * radius pgi_progressive_radius(r0, k) and (jitter AUTO) point k of the pixels' sub-pixel
 * sequence. Needs an exact estimator for k > 0. */
pgi_status pgi_progressive_frame(pgi_renderer *r, const pgi_render_desc *desc, float r0, int k, pgi_image *frame,
                                 pgi_frame_stats *stats);
/* Frame k > 0 as pgi_progressive_frame(r, desc, r0, k, ...), byte for byte, for a caller that does not
 * know r0 yet (another process is rendering frame 0, apps/mpi): the frame's view samples and photons,
 * which do not depend on the radius, are made first; then r0_fn(user) is called once, on the calling
 * thread (it may block until r0 is known), and must return frame 0's radius; the frame ends with it.
 * When the photons do depend on the radius (a footprint radius policy, guided emission, --store view)
 * or the frame runs on the GPU device, r0_fn is called first. The time spent in r0_fn is left out of
 * the frame's stats. */
typedef float (*pgi_radius_fn)(void *user);
pgi_status pgi_progressive_frame_await_r0(pgi_renderer *r, const pgi_render_desc *desc, pgi_radius_fn r0_fn, void *user,
                                          int k, pgi_image *frame, pgi_frame_stats *stats);

/* ---------------------------------------------------------- temporal */

/* A picture that stays clean while the camera moves (docs/temporal.md), for a viewer or an
 * engine: each step renders one progressive frame (pgi_progressive_step, which restarts when the
 * picture changes) and then
 *  - temporal reuse: when only the camera moved, the last picture is reprojected into the new view
 *    (each pixel's primary hit found in the previous camera, bilinear over the previous pixels whose
 *    depth, normal and albedo agree, clamped to the new frame's 3x3 neighbourhood so that nothing
 *    moved leaves a ghost) and blended in with the weight of its history, at most `history` frames;
 *    any other change (settings, lights, geometry, time, size) starts the history afresh;
 *  - an edge-aware filter of the indirect light (a-trous, `filter` passes of a 5x5 B-spline at
 *    steps 1, 2, 4, ..., on irradiance with the albedo divided out, stopped at normal, depth and
 *    albedo edges and by each pixel's local variance).
 * Both fade as a still camera's frames accumulate: after `history` frames the history weighs
 * nothing and after `filter_frames` frames the filter is off, so a still view converges to exactly
 * what pgi_progressive_step converges to. CPU device only (it reads the frame's AOVs). Not for
 * comparing estimators: photongi render, the benches and the quality tables never use it. */
typedef struct pgi_temporal_desc {
    int history;       /* 1..256 frames the reprojected picture weighs at most; 0 = 16; PGI_TEMPORAL_OFF: no reuse */
    int filter;        /* a-trous passes 1..5; 0 = 4; PGI_TEMPORAL_OFF: no filter */
    int filter_frames; /* 1..256 frames after which a still view is unfiltered; 0 = 8 */
    int keep_guide;    /* 1: guided emission keeps its guide over the frames of a still picture
                          (pgi_progressive_keep_guide on the accumulator inside); 0 = off */
} pgi_temporal_desc;
#define PGI_TEMPORAL_OFF (-1)

typedef struct pgi_temporal pgi_temporal;
/* The renderer is borrowed and must outlive the accumulator; desc may be NULL (defaults). */
pgi_status pgi_temporal_create(pgi_renderer *r, const pgi_temporal_desc *desc, pgi_temporal **out);
/* One frame into the picture, written to `out`; stats gets the frame's, with `temporal` filled in and
 * "temporal" and "denoise" passes in passes_ms (their time also in total_ms). desc->aovs must be
 * NULL (the step uses them itself). A cancelled step (PGI_ERR_CANCELLED) changes nothing. */
pgi_status pgi_temporal_step(pgi_temporal *t, const pgi_render_desc *desc, pgi_image *out, pgi_frame_stats *stats);
/* Forgets the history and the progressive average. */
void pgi_temporal_reset(pgi_temporal *t);
void pgi_temporal_destroy(pgi_temporal *t);

/* The summation order of a progressive average (and of the reference's samples,
 * include/photongi/reference.h), fixed so that frames rendered anywhere add up to the same
 * bits: frames are summed in BLOCKS of PGI_PROGRESSIVE_BLOCK consecutive frames (block b holds
 * frames bB .. bB+B-1), frames within a block in frame order into a block sum (double), and block
 * sums in block order into the total (double, starting at 0); the image after n frames is
 * (float)((total + the sum of the last, partial block) / n). pgi_progressive_step adds its frames
 * in exactly this order, with these helpers, so a distributed run that renders blocks elsewhere
 * (apps/mpi) and adds their sums in block order gets the same image byte for byte. `values` is
 * 3 x pixels. */
#define PGI_PROGRESSIVE_BLOCK 4
/* block[i] = frame[i] for the first frame of a block (`first` non-zero), else block[i] += frame[i]. */
void pgi_block_sum_add(double *block, const float *frame, size_t values, int first);
/* total[i] += block[i]: a finished block, in block order. */
void pgi_block_sum_merge(double *total, const double *block, size_t values);
/* total[i] = (double)(float)(total[i] * (1 / count)) * count: the total as a saved float mean of count
 * samples gives it back (pgi_reference_render does this after every whole block, so that continuing a
 * reference saved at a multiple of its block reproduces the bytes of one uninterrupted run). */
void pgi_block_sum_round(double *total, size_t values, uint64_t count);
/* out[i] = (float)((total[i] + partial[i]) * (1 / count)); partial may be NULL (no partial block). */
void pgi_block_sum_mean(const double *total, const double *partial, size_t values, uint64_t count, float *out);

/* ---------------------------------------------------------------- devices */

/* 1 when this build has the Vulkan backend (PGI_DEVICE_VULKAN), else 0. */
int pgi_vulkan_available(void);
/* Vulkan devices the loader finds (Vulkan 1.3; 0 without a driver or without the backend). */
int pgi_device_count(void);
/* The name of Vulkan device i (0-based) into buf; PGI_ERR_INVALID_ARG out of range,
 * PGI_ERR_UNSUPPORTED without the backend or a driver. */
pgi_status pgi_device_name(int i, char *buf, size_t size);
/* Device i's type, driver and the Vulkan version it supports into buf, e.g. "CPU; driver llvmpipe Mesa
 * 22.3.6 (LLVM 15.0.6); Vulkan 1.3.230"; errors as pgi_device_name. */
pgi_status pgi_device_driver(int i, char *buf, size_t size);
/* "hashgrid, tiled, cluster, ...": the estimators that run on PGI_DEVICE_VULKAN (hashgrid, tiled,
 * cluster, cluster-cone, cluster-trivial, directional, bvh, bounds3d, bounds25d), in the registry's
 * order (pgi_estimator_at), comma-separated, into buf. */
void pgi_device_estimators(char *buf, size_t size);
/* 1 when estimator vt runs on `device` (the device table pgi_device_estimators lists from), else 0. */
int pgi_estimator_runs_on(const pgi_estimator_vtbl *vt, pgi_device device);
/* 1 when estimator vt takes option o on `device` (pgi_estimator_takes, less what the device's
 * version of the estimator lacks: --subsample on the GPU), else 0. A frame that sets an option its
 * device does not take is refused by name (PGI_ERR_UNSUPPORTED). */
int pgi_estimator_takes_on(const pgi_estimator_vtbl *vt, const pgi_option *o, pgi_device device);

#ifdef __cplusplus
}
#endif

#endif
