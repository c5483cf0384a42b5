/* The frame's view samples, direct light and sum on the GPU (issue "The GPU backend"; the
 * renderer's --device vulkan path, docs/gpu.md): shaders/view.comp writes the G-buffer straight
 * into device buffers (no round trip), shaders/direct.comp adds direct light and composes the
 * image from it, the emitted light and the estimator's radiance.
 *
 *   pgi__gpu_view *v;  pgi__gpu_view_create(gpu, &v);
 *   pgi__gpu_view_prepare(v, &cam, seed, &subpixel);       // outside a sequence: buffers, parameters
 *   pgi__gpu_begin(gpu);
 *   pgi__gpu_view_record(v, gs);                           // timestamp "gpu_view"
 *   ... the estimator reads pgi__gpu_view_samples(v) and the scene's lobes, writes `indirect` ...
 *   pgi__gpu_direct_record(v, gs, indirect, samples, seed, output);   // timestamp "gpu_direct"
 *   pgi__gpu_submit_wait(gpu);
 *   pgi__gpu_download(gpu, pgi__gpu_view_image(v), 0, rgb, 12 * w * h);
 *
 * Device buffers of a w x h frame (std430; shaders/frame.glsl):
 *   "gpu_view_samples" (four buffers): w h ViewSample (gather.glsl, 64 bytes: position, shading
 *      normal, wo, kd, 1 - E(n.wo), PGI_VS_* flags, the lobe = the material's entry of the scene's
 *      lobe table); w h PixelExtra (48 bytes: geometric normal + view depth, the specular chain's
 *      weight, the emitted radiance seen); the frame parameters (pgi__gpu_frame_params); two
 *      64-bit counters (primary + specular rays, shadow rays);
 *   "gpu_image": w h x 3 floats, the frame (what pgi_image holds).
 *
 * Random numbers: scene.glsl's counter-based hash (pcg4d of pixel, seed, purpose, draw count), one
 * stream a pixel and purpose: deterministic, not the CPU's numbers (the glass choice of an eye path
 * and the direct-light samples differ from the CPU's, their expectations do not). The sub-pixel
 * point is the CPU's bit for bit (view.h pgi__pixel_jitter, 64-bit arithmetic in 32-bit words). */
#ifndef PGI__GPU_VIEW_H
#define PGI__GPU_VIEW_H

#include "gpu/gpu.h"
#include "gpu/gpu_scene.h"
#include "view/view.h"

typedef struct pgi__gpu_frame_params {
    float eye[3], tan_half_fov;
    float forward[3], aspect;
    float right[3], pad0;
    float up[3], pad1;
    uint32_t width, height, jitter, index;
    uint32_t seed_lo, seed_hi, key_lo, key_hi;
    uint32_t direct_samples, output, tex_filter; /* tex_filter: pgi__subpixel.tex_filter */
    float spread;                                /* view.c tex_cone.spread */
} pgi__gpu_frame_params;
_Static_assert(sizeof(pgi__gpu_frame_params) == 112 && offsetof(pgi__gpu_frame_params, width) == 64 &&
                   offsetof(pgi__gpu_frame_params, direct_samples) == 96,
               "frame.glsl FrameParams");

/* frame.glsl PixelExtra */
typedef struct pgi__gpu_pixel_extra {
    float ngeo[3], depth;
    float weight[3], pad0;
    float emit[3], pad1;
} pgi__gpu_pixel_extra;
_Static_assert(sizeof(pgi__gpu_pixel_extra) == 48 && offsetof(pgi__gpu_pixel_extra, emit) == 32,
               "frame.glsl PixelExtra");

/* gather.glsl ViewSample */
typedef struct pgi__gpu_view_sample {
    float pos[3], nrm[3], wo[3], kd[3], one_m_eo;
    uint32_t flags, lobe, pad;
} pgi__gpu_view_sample;
_Static_assert(sizeof(pgi__gpu_view_sample) == 64 && offsetof(pgi__gpu_view_sample, flags) == 52,
               "gather.glsl ViewSample");

typedef struct pgi__gpu_view pgi__gpu_view;

pgi_status pgi__gpu_view_create(pgi__gpu *g, pgi__gpu_view **out);
void pgi__gpu_view_destroy(pgi__gpu_view *v);
/* Outside a sequence: the frame's buffers for cam's size, and its parameters (the camera, the
 * seed of the random numbers, the sub-pixel point as pgi__view_build's). */
pgi_status pgi__gpu_view_prepare(pgi__gpu_view *v, const pgi_camera *cam, uint64_t seed, const pgi__subpixel *sp);
/* Records the view pass (zeroes the counters first; timestamp "gpu_view"). */
pgi_status pgi__gpu_view_record(pgi__gpu_view *v, const pgi__gpu_scene *gs);
/* Records direct light and the sum (timestamp "gpu_direct"): indirect is the estimator's radiance
 * (3 floats a pixel) or NULL (none: zero); output PGI_OUTPUT_ALL / INDIRECT / DIRECT. */
pgi_status pgi__gpu_direct_record(pgi__gpu_view *v, const pgi__gpu_scene *gs, pgi__gpu_buffer *indirect,
                                  int direct_samples, uint64_t seed, pgi_output output);
pgi__gpu_buffer *pgi__gpu_view_samples(const pgi__gpu_view *v); /* the ViewSample array (offset 0) */
pgi__gpu_buffer *pgi__gpu_view_image(const pgi__gpu_view *v);
pgi__gpu_buffer *pgi__gpu_view_extra(const pgi__gpu_view *v); /* the PixelExtra array */
/* After the sequence: primary rays (eye rays, the specular bounces included) and shadow rays. */
pgi_status pgi__gpu_view_counters(pgi__gpu_view *v, uint64_t *primary, uint64_t *shadow);
/* Downloads the G-buffer into host view samples (tests; the automatic radius): every field the
 * CPU's view pass writes (ks, shininess, ior from the material's lobe parameters). vs must be
 * allocated for the frame's size. */
pgi_status pgi__gpu_view_download(pgi__gpu_view *v, const pgi_scene *s, pgi_view_samples *vs, float *emit);

#endif
