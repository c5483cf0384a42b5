/* Rays on the GPU (issue "The GPU backend", item 2): the scene's BVH (rt/tri_bvh.h, built on the CPU)
 * uploaded once per geometry change, and the kernel src/gpu/shaders/rays.comp that intersects a
 * buffer of rays with it (closest hit, or any hit for shadow rays). Works on every Vulkan device,
 * lavapipe included; no hardware ray tracing.
 *
 *   pgi__gpu_rays *gr;  pgi__gpu_rays_create(gpu, scene, &gr);
 *   if (pgi__gpu_rays_needs_update(gr, scene)) pgi__gpu_rays_update(gr, scene);   // after animation
 *   pgi__gpu_rays_intersect(gr, rays, n, 0, hits);     // host arrays: upload, run, download
 *   // or, inside a pass's own sequence with rays already on the device:
 *   pgi__gpu_begin(gpu); pgi__gpu_rays_dispatch(gr, ray_buf, hit_buf, 0, n, 1); pgi__gpu_submit_wait(gpu);
 *
 * Rays are pgi__tri_bvh_ray (32 bytes), hits pgi__hit (16 bytes, prim UINT32_MAX for none), as the
 * CPU's pgi__rt_intersect returns them (Embree's conventions: t in (tnear, tfar], both faces, u, v
 * the barycentrics of vertices 1 and 2; cut-out materials refuse hits where their mask is open, as
 * the renderer's Embree filter). */
#ifndef PGI__GPU_RAYS_H
#define PGI__GPU_RAYS_H

#include "gpu/gpu.h"
#include "rt/tri_bvh.h"

typedef struct pgi__gpu_rays pgi__gpu_rays;

/* Builds the BVH of s (the default pgi__tri_bvh_config), uploads it to g (buffers "gpu_bvh_nodes",
 * "gpu_bvh_tris", "gpu_bvh_masks", "gpu_bvh_alpha") and creates the kernel. The scene and the
 * device are borrowed. */
pgi_status pgi__gpu_rays_create(pgi__gpu *g, const pgi_scene *s, pgi__gpu_rays **out);
void pgi__gpu_rays_destroy(pgi__gpu_rays *r);
/* 1 when the scene's geometry moved since the BVH was built. */
int pgi__gpu_rays_needs_update(const pgi__gpu_rays *r, const pgi_scene *s);
/* Rebuilds the BVH from the scene's current positions and uploads it (buffers grow as needed).
 * On failure the device may hold part of the new BVH: update again (or destroy) before tracing. */
pgi_status pgi__gpu_rays_update(pgi__gpu_rays *r, const pgi_scene *s);
/* (addition, gpu-frame) The BVH's four buffers in bvh.glsl's binding order: nodes, triangles,
 * masks, alpha (for passes that bind them beside their own, gpu_scene.h). */
void pgi__gpu_rays_buffers(const pgi__gpu_rays *r, pgi__gpu_buffer **out);
/* The BVH on the device (its statistics, and the CPU traversal of the same layout). */
const pgi__bvh *pgi__gpu_rays_bvh(const pgi__gpu_rays *r);

/* Records the intersection of rays[first .. first + n) of buffer `rays` (pgi__tri_bvh_ray) into the
 * same entries of `hits` (pgi__hit) in the sequence being recorded (between pgi__gpu_begin and
 * pgi__gpu_submit_wait); any_hit: occlusion queries. Splits into dispatches of at most 65535
 * groups of 64. */
pgi_status pgi__gpu_rays_dispatch(pgi__gpu_rays *r, pgi__gpu_buffer *rays, pgi__gpu_buffer *hits, size_t first,
                                  size_t n, int any_hit);
/* Benchmarks: rebuilds and uploads the BVH of s with build settings cfg (NULL: the default), kept
 * for later updates; on failure the previous settings stay (the device state as after a failed
 * update). */
pgi_status pgi__gpu_rays_set_config(pgi__gpu_rays *r, const pgi_scene *s, const pgi__tri_bvh_config *cfg);
/* Tests: dispatches of at most `groups` groups (1..65535) from now on, to exercise the split. */
void pgi__gpu_rays_set_max_groups(pgi__gpu_rays *r, uint32_t groups);
/* Host arrays: uploads n rays, runs one sequence (timestamp label "rays"), downloads n hits.
 * Blocking; the ray and hit buffers ("gpu_rays", "gpu_hits") are kept and grown for the next call. */
pgi_status pgi__gpu_rays_intersect(pgi__gpu_rays *r, const pgi__tri_bvh_ray *rays, size_t n, int any_hit,
                                   pgi__hit *hits);

#endif
