/* The Vulkan compute backend's device layer (issue "The GPU backend"): one device, its queue,
 * storage buffers, compute kernels from SPIR-V embedded at build time, and one command sequence
 * at a time with timestamps. Everything the GPU passes (rays, photons, estimators) need, nothing
 * more. Built when CMake finds Vulkan and glslc (PGI__HAVE_VULKAN); without them every call that
 * could fail returns PGI_ERR_UNSUPPORTED with a message saying the build has no Vulkan backend.
 *
 *   pgi__gpu *g;  pgi__gpu_create(-1, &g);
 *   pgi__gpu_kernel *k;  pgi__gpu_kernel_create(g, pgi__spv_hashgrid_gather, sizeof pgi__spv_hashgrid_gather,
 *                                               "gather", 4, sizeof(push), &k);
 *   pgi__gpu_buffer *b;  pgi__gpu_buffer_reserve(g, &b, bytes, "gpu_photons");
 *   pgi__gpu_upload(g, b, 0, src, bytes);
 *   pgi__gpu_begin(g);
 *   pgi__gpu_timestamp(g, "start");
 *   pgi__gpu_dispatch(g, k, (pgi__gpu_buffer *[]){a, b, c, d}, &push, groups, 1, 1);
 *   pgi__gpu_timestamp(g, "gather");          // the span since the previous label is "gather"
 *   pgi__gpu_submit_wait(g);
 *   pgi__gpu_download(g, d, 0, dst, bytes);
 *
 * Shaders: src/gpu/shaders/<name>.comp (GLSL 4.50, Vulkan 1.3 compute), compiled by glslc at
 * build time into the generated header "gpu/spirv.h" as `static const uint32_t pgi__spv_<name>[]`.
 * Not thread-safe: one thread records and submits (the renderer's). */
#ifndef PGI__GPU_H
#define PGI__GPU_H

#include <stddef.h>
#include <stdint.h>

#include "photongi/photongi.h"

typedef struct pgi__gpu pgi__gpu;
typedef struct pgi__gpu_buffer pgi__gpu_buffer;
typedef struct pgi__gpu_kernel pgi__gpu_kernel;

/* 1 when the library was built with the Vulkan backend. */
int pgi__gpu_available(void);

/* Instance (Vulkan 1.3), physical device `index` in the loader's order (-1: the first discrete
 * GPU, else the first integrated one, else the first CPU device such as lavapipe), a device with
 * one compute queue, a command pool and a timestamp query pool. PGI_ERR_UNSUPPORTED (message:
 * no Vulkan backend in this build / no Vulkan device / device index out of range, listing the
 * devices) when there is none. */
pgi_status pgi__gpu_create(int index, pgi__gpu **out);
void pgi__gpu_destroy(pgi__gpu *g);
/* "llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA H100 80GB HBM3" */
const char *pgi__gpu_device_name(const pgi__gpu *g);
/* Number of Vulkan devices and the name of device i (for `--device vulkan:N` messages and --help). */
int pgi__gpu_device_count(void);
/* (addition) The name of device i of pgi__gpu_device_count() into buf; PGI_ERR_INVALID_ARG out of range. */
pgi_status pgi__gpu_device_name_at(int i, char *buf, size_t size);
/* (addition) Device i's type, driver and Vulkan version: "discrete GPU; driver NVIDIA 580.159.04; Vulkan
 * 1.4.312" (VkPhysicalDeviceDriverProperties); PGI_ERR_INVALID_ARG out of range. */
pgi_status pgi__gpu_device_driver_at(int i, char *buf, size_t size);
/* (addition) 1 when the device's compute queue writes timestamps; 0: pgi__gpu_timings gives one entry,
 * the whole sequence timed on the CPU, under its last label. */
int pgi__gpu_has_timestamps(const pgi__gpu *g);

/* Storage buffers: device-local where the device has such memory (uploads and downloads through a
 * staging buffer), host-visible otherwise. `what` is a static string naming the buffer in the
 * memory stats ("gpu_photons"). reserve: (re)creates *b when it is NULL or smaller than `bytes`
 * (contents are then lost; a buffer is never shrunk). */
pgi_status pgi__gpu_buffer_reserve(pgi__gpu *g, pgi__gpu_buffer **b, size_t bytes, const char *what);
void pgi__gpu_buffer_destroy(pgi__gpu *g, pgi__gpu_buffer *b);
size_t pgi__gpu_buffer_size(const pgi__gpu_buffer *b);
/* Blocking copies between host memory and a buffer (outside a begin/submit sequence). */
pgi_status pgi__gpu_upload(pgi__gpu *g, pgi__gpu_buffer *dst, size_t offset, const void *src, size_t bytes);
pgi_status pgi__gpu_download(pgi__gpu *g, const pgi__gpu_buffer *src, size_t offset, void *dst, size_t bytes);
/* Bytes held by the device's buffers, one entry per `what` (summed), for the frame's memory stats. */
int pgi__gpu_memory(const pgi__gpu *g, pgi_named_value *out, int max);
/* The frame's memory budget (--max-memory; PGI_MEMORY_UNLIMITED: none), which a device whose memory
 * is the host's (a CPU device) keeps its buffers within; every device keeps them within its heaps. */
void pgi__gpu_set_budget(pgi__gpu *g, uint64_t bytes);

/* A compute pipeline from SPIR-V: `nbuffers` (1..32, and within the device's storage buffers a
 * shader stage: PGI_ERR_UNSUPPORTED beyond them) storage buffers at set 0, bindings
 * 0..nbuffers-1, and push constants of `push_bytes` (0..128, a multiple of 4). `name` names it in
 * error messages. */
pgi_status pgi__gpu_kernel_create(pgi__gpu *g, const uint32_t *spirv, size_t spirv_bytes, const char *name,
                                  int nbuffers, uint32_t push_bytes, pgi__gpu_kernel **out);
void pgi__gpu_kernel_destroy(pgi__gpu *g, pgi__gpu_kernel *k);
/* A table of kernels made in one go: `static const pgi__gpu_kernel_spec k[K_N] = {[K_X] =
 * PGI__GPU_KERNEL(shader_x, 3, sizeof(x_push)), ...}` (the kernel named after its shader, whose
 * SPIR-V is pgi__spv_<shader> in gpu/spirv.h), then pgi__gpu_kernels_create(g, k, K_N, skip, s->k).
 * Entry i is made unless bit i of `skip` is set (out[i] stays NULL); on a failure the kernels made
 * so far stay in out[] for the caller's destroy. */
typedef struct pgi__gpu_kernel_spec {
    const uint32_t *spirv;
    size_t spirv_bytes;
    const char *name;
    int nbuffers;
    uint32_t push_bytes;
} pgi__gpu_kernel_spec;
#define PGI__GPU_KERNEL(shader, nbuffers, push_bytes)                                                                  \
    { pgi__spv_##shader, sizeof pgi__spv_##shader, #shader, nbuffers, push_bytes }
pgi_status pgi__gpu_kernels_create(pgi__gpu *g, const pgi__gpu_kernel_spec *specs, int n, uint32_t skip,
                                   pgi__gpu_kernel **out);

/* One command sequence: begin, then dispatches, fills and timestamps in order, then submit_wait.
 * Every dispatch and fill waits for the writes of everything recorded before it (a full
 * compute/transfer memory barrier in between), so a sequence runs as written. */
pgi_status pgi__gpu_begin(pgi__gpu *g);
pgi_status pgi__gpu_dispatch(pgi__gpu *g, pgi__gpu_kernel *k, pgi__gpu_buffer *const *buffers, const void *push,
                             uint32_t groups_x, uint32_t groups_y, uint32_t groups_z);
/* A dispatch of `items` invocations in workgroups of `local` (the kernel's local size), as a 2D grid
 * of rows of at most 65535 workgroups (shaders/common.glsl linear_group finds an invocation's index). */
pgi_status pgi__gpu_dispatch_1d(pgi__gpu *g, pgi__gpu_kernel *k, pgi__gpu_buffer *const *buffers, const void *push,
                                size_t items, uint32_t local);
/* Sets `bytes` bytes of b from `offset` to the 32-bit word `value` (vkCmdFillBuffer). */
pgi_status pgi__gpu_fill(pgi__gpu *g, pgi__gpu_buffer *b, size_t offset, size_t bytes, uint32_t value);
/* Records a timestamp named `label` (a static string); after submit_wait, pgi__gpu_timings gives
 * the milliseconds between each label and the one before it, under the later label's name. */
void pgi__gpu_timestamp(pgi__gpu *g, const char *label);
pgi_status pgi__gpu_submit_wait(pgi__gpu *g);
int pgi__gpu_timings(const pgi__gpu *g, pgi_named_value *out, int max);
/* What the device has exchanged with the host since it was created (submits, dispatches, uploads,
 * downloads): a frame's is the difference of two readings. */
typedef pgi_device_traffic pgi__gpu_traffic;
pgi__gpu_traffic pgi__gpu_traffic_get(const pgi__gpu *g);

#endif
