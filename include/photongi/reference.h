/* Path-traced reference with the photon pipeline's light-transport convention
 * (docs/design.md "Reference path tracer"): emission seen along the eye path,
 * direct light at the first non-specular hit (NEE, MIS for area lights) and
 * indirect light of light paths with 1..bounces scattering events before that
 * point. Progressive: each call adds samples to a running mean.
 *
 *   pgi_reference_desc d = {.spp = 64};
 *   pgi_image mean = {0};
 *   uint64_t spp = 0;
 *   pgi_reference_render(scene, &d, &mean, &spp);   // spp == 64 now
 *   d.spp = 64;
 *   pgi_reference_render(scene, &d, &mean, &spp);   // samples 64..127 added, spp == 128
 */
#ifndef PHOTONGI_REFERENCE_H
#define PHOTONGI_REFERENCE_H

#include "photongi/photongi.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Called after every pass (one sample per pixel). done/total are samples per
 * pixel of this call; elapsed_ms since the call started. Return non-zero to
 * stop after this pass (the image stays a valid mean of the samples done). */
typedef int (*pgi_reference_progress_fn)(void *user, uint64_t done, uint64_t total, double elapsed_ms);

/* Zero means "default" for every field. */
typedef struct pgi_reference_desc {
    int width, height;                  /* default scene's or 640x480 */
    int bounces;                        /* scattering events before the visible point; default scene's or 4 */
    uint64_t seed;                      /* default 1 */
    int threads;                        /* OpenMP threads; 0 = all */
    int camera;                         /* index into the scene's cameras */
    uint64_t spp;                       /* samples per pixel to add; required (>= 1) */
    double time_limit_s;                /* > 0: stop after the pass that reaches this wall time */
    pgi_reference_progress_fn progress; /* may be NULL */
    void *progress_user;
    pgi_jitter jitter;          /* AUTO (default) or ON: every sample through its own uniform point of the pixel (one
                          stratified sequence a pixel), so the mean converges to the box-filtered pixel
                          integral (the limit of a progressive render); OFF: through pixel centres (point
                          samples, as one frame of `render`, and the images of references made before) */
    const pgi_camera_def *view; /* non-NULL: render from this camera instead of the scene's `camera` (borrowed
                                   for the call; checked as pgi_render_desc.view) */
} pgi_reference_desc;

/* Adds desc->spp samples (sample indices *spp .. *spp + desc->spp - 1 of the
 * stream of `seed`) to `mean`, which holds the mean of the first *spp samples
 * (*spp = 0: `mean` may be a zeroed image; it is (re)allocated). On return
 * *spp counts the samples in `mean`. The sums are in a fixed order that does not
 * depend on the thread count: the total starts at (double)mean x *spp, the call's
 * samples are summed per pixel in blocks of PGI_REFERENCE_BLOCK consecutive samples
 * (from the call's first), in sample order within a block, and block sums are
 * added in block order (photongi.h, pgi_block_sum_*), so that sample blocks
 * rendered elsewhere (apps/mpi) reduce to the same bits. After every whole block
 * the total is rounded to what the float mean gives back (pgi_block_sum_round), so
 * continuing from a mean saved at a multiple of PGI_REFERENCE_BLOCK samples gives the
 * same bits as one long run; from another count, the same up to float rounding. */
pgi_status pgi_reference_render(const pgi_scene *scene, const pgi_reference_desc *desc, pgi_image *mean, uint64_t *spp);

/* Samples per block of pgi_reference_render's summation order. */
#define PGI_REFERENCE_BLOCK 4

/* The reference's samples one at a time, for callers that deal sample blocks out (apps/mpi):
 * the ray-tracing scene and light tables of `desc` (validated and resolved as
 * pgi_reference_render does; desc->spp, time_limit_s and progress are not used), built once. */
typedef struct pgi_reference_sampler pgi_reference_sampler;
pgi_status pgi_reference_sampler_create(const pgi_scene *scene, const pgi_reference_desc *desc,
                                        pgi_reference_sampler **out);
/* The resolved image size. */
void pgi_reference_sampler_size(const pgi_reference_sampler *s, int *width, int *height);
/* Adds sample `sample` (0-based, of the stream of the desc's seed) of every pixel to `sum`
 * (3 doubles a pixel, row-major): sum[i] += sample. A block's sum is a zeroed buffer and its
 * samples in order. One call at a time on a sampler (without jitter it keeps what a pixel's
 * samples share). */
pgi_status pgi_reference_sampler_add(pgi_reference_sampler *s, uint64_t sample, double *sum);
void pgi_reference_sampler_destroy(pgi_reference_sampler *s);

/* What a reference image needs to be extended later (sidecar "<image>.json"). */
typedef struct pgi_reference_meta {
    char scene[256]; /* scene spec as given on the command line */
    int width, height, bounces, camera;
    uint64_t seed, spp;
    pgi_jitter jitter;            /* PGI_JITTER_ON or PGI_JITTER_OFF (what the samples so far used) */
    pgi_specular specular;        /* the model the samples used (GGX or PHONG; a sidecar without "specular" predates
                              the microfacet plastic and reads as PHONG) */
    uint64_t exr_bytes, exr_hash; /* the EXR's size and FNV-1a 64-bit hash of its bytes when the sidecar
                                     was written ("exr_bytes", "exr_fnv1a64"): a reader checks that the
                                     two files belong together; 0, 0: not recorded (older sidecars) */
    int has_view;                 /* 1: the samples were rendered from `view` (a camera given on the command line,
                                     "view" in the sidecar), not from the scene's camera `camera` */
    pgi_camera_def view;
} pgi_reference_meta;

/* The most samples a sidecar may count (2^53: exact as a double). */
#define PGI_REFERENCE_MAX_SPP (1ULL << 53)

/* Writes/reads the sidecar JSON file `path` (format "photongi-reference-2", with an optional
 * "specular": "ggx" | "phong" and an optional "view": {"eye": [x, y, z], "look_at": [...], "up": [...],
 * "fov_y": f} (has_view; its numbers read back as the same floats);
 * "photongi-reference-1", written before references were jittered, reads as
 * PGI_JITTER_OFF). Reading a missing file is PGI_ERR_IO; a file without the
 * fields, with a value out of range (width and height 1..PGI_MAX_IMAGE_SIDE, bounces 1..64, camera
 * 0..1000000, spp 1..PGI_REFERENCE_MAX_SPP, seed and spp strings of digits) or that is not a regular
 * file (a FIFO) is PGI_ERR_PARSE. A relative "scene" path that names a file beside the sidecar reads
 * as that file's path (the sidecar's folder, not the current one). The write replaces `path`
 * atomically (a temporary file renamed over it). */
pgi_status pgi_reference_meta_write(const pgi_reference_meta *m, const char *path);
pgi_status pgi_reference_meta_read(const char *path, pgi_reference_meta *m);

/* Saves a reference: the EXR `exr` and its sidecar `meta_path` with m->exr_bytes and m->exr_hash set
 * to the EXR's size and hash. Both are written to temporary files beside their targets and flushed
 * to the disk before either is renamed over its target, so that a failure (a full disk) keeps the
 * previous pair and only a kill between the two renames can leave them disagreeing, which the hash
 * tells. An EXR path that is not a regular file (/dev/null) is written directly, without a hash. */
pgi_status pgi_reference_save(const pgi_image *img, const char *exr, pgi_reference_meta *m, const char *meta_path);

/* The size and FNV-1a 64-bit hash of a regular file's bytes (what the sidecar records of its EXR);
 * PGI_ERR_IO for a file that cannot be read or is not a regular file (a FIFO is not waited on). */
pgi_status pgi_reference_file_hash(const char *path, uint64_t *bytes, uint64_t *hash);

#ifdef __cplusplus
}
#endif

#endif
