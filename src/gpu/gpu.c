/* The Vulkan compute backend's device layer (gpu.h): instance, device, one compute queue, storage
 * buffers (device-local with staging, or host-visible and mapped), compute kernels from embedded
 * SPIR-V, one command sequence at a time with timestamps. Without PGI__HAVE_VULKAN (CMake found no
 * Vulkan or no glslc, or PGI_VULKAN=OFF) every call that can fail returns PGI_ERR_UNSUPPORTED. */
#include "gpu/gpu.h"

#include <stdio.h>
#include <string.h>

#include "core/core.h"

#define NO_BACKEND "this build of photongi has no Vulkan backend (built without Vulkan/glslc)"

#ifndef PGI__HAVE_VULKAN

int pgi__gpu_available(void) { return 0; }

pgi_status pgi__gpu_create(int index, pgi__gpu **out) {
    *out = NULL;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
void pgi__gpu_destroy(pgi__gpu *g) { (void)g; }
const char *pgi__gpu_device_name(const pgi__gpu *g) { return "none"; }
int pgi__gpu_device_count(void) { return 0; }
pgi_status pgi__gpu_device_name_at(int i, char *buf, size_t size) {
    if (size) buf[0] = 0;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
pgi_status pgi__gpu_device_driver_at(int i, char *buf, size_t size) {
    if (size) buf[0] = 0;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
pgi_status pgi__gpu_buffer_reserve(pgi__gpu *g, pgi__gpu_buffer **b, size_t bytes, const char *what) {
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
void pgi__gpu_buffer_destroy(pgi__gpu *g, pgi__gpu_buffer *b) {}
size_t pgi__gpu_buffer_size(const pgi__gpu_buffer *b) { return 0; }
pgi_status pgi__gpu_upload(pgi__gpu *g, pgi__gpu_buffer *dst, size_t offset, const void *src, size_t bytes) {
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
pgi_status pgi__gpu_download(pgi__gpu *g, const pgi__gpu_buffer *src, size_t offset, void *dst, size_t bytes) {
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
int pgi__gpu_memory(const pgi__gpu *g, pgi_named_value *out, int max) { return 0; }
pgi_status pgi__gpu_kernel_create(pgi__gpu *g, const uint32_t *spirv, size_t spirv_bytes, const char *name,
                                  int nbuffers, uint32_t push_bytes, pgi__gpu_kernel **out) {
    *out = NULL;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
void pgi__gpu_kernel_destroy(pgi__gpu *g, pgi__gpu_kernel *k) {}
pgi_status pgi__gpu_begin(pgi__gpu *g) { return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND); }
pgi_status pgi__gpu_dispatch(pgi__gpu *g, pgi__gpu_kernel *k, pgi__gpu_buffer *const *buffers, const void *push,
                             uint32_t groups_x, uint32_t groups_y, uint32_t groups_z) {
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
pgi_status pgi__gpu_fill(pgi__gpu *g, pgi__gpu_buffer *b, size_t offset, size_t bytes, uint32_t value) {
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND);
}
void pgi__gpu_timestamp(pgi__gpu *g, const char *label) {}
pgi_status pgi__gpu_submit_wait(pgi__gpu *g) { return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_BACKEND); }
int pgi__gpu_timings(const pgi__gpu *g, pgi_named_value *out, int max) { return 0; }
pgi__gpu_traffic pgi__gpu_traffic_get(const pgi__gpu *g) { return (pgi__gpu_traffic){0}; }
int pgi__gpu_has_timestamps(const pgi__gpu *g) { return 0; }
void pgi__gpu_set_budget(pgi__gpu *g, uint64_t bytes) {}

#else /* PGI__HAVE_VULKAN */

#include <vulkan/vulkan.h>

#define MAX_LABELS 64
/* storage buffers a kernel binds at most: push descriptors' guaranteed minimum (maxPushDescriptors);
 * a device whose stage takes fewer (maxPerStageDescriptorStorageBuffers) lowers it (max_bindings) */
#define MAX_BINDINGS 32
/* descriptor sets of one sequence without push descriptors */
#define MAX_SETS 256
#define STAGING_MAX ((size_t)64 << 20)

struct pgi__gpu_buffer {
    VkBuffer buf;
    VkDeviceMemory mem;
    size_t size;
    const char *what;
    void *mapped;   /* host-visible and coherent: written and read directly */
    uint32_t heap;  /* the memory heap it lives in */
    uint64_t alloc; /* bytes allocated for it there */
    pgi__gpu_buffer *next, *prev;
};

struct pgi__gpu_kernel {
    VkShaderModule module;
    VkDescriptorSetLayout dsl;
    VkPipelineLayout layout;
    VkPipeline pipe;
    int nbuffers;
    uint32_t push_bytes;
    const char *name;
};

struct pgi__gpu {
    VkInstance inst;
    VkPhysicalDevice pd;
    VkDevice dev;
    VkQueue queue;
    uint32_t qfam;
    VkCommandPool pool;
    VkCommandBuffer cb;
    VkFence fence;
    VkQueryPool qp;
    VkDescriptorPool dpool; /* without push descriptors */
    PFN_vkCmdPushDescriptorSetKHR push_desc;
    VkPhysicalDeviceMemoryProperties memp;
    char name[VK_MAX_PHYSICAL_DEVICE_NAME_SIZE + 32];
    double ts_period_ns;
    uint64_t ts_mask;
    int has_ts;
    int max_bindings; /* MAX_BINDINGS, or the device's storage buffers a stage when fewer */
    /* test hooks, from the environment (tests/test_gpu.c): PGI_GPU_STAGING=1: no mapped device buffers
     * (the staging path of a discrete GPU); PGI_GPU_NO_PUSH_DESCRIPTORS=1: descriptor sets from the
     * pool; PGI_GPU_NO_TIMESTAMPS=1: the CPU-timed sequence of a queue without timestamps */
    int force_staging;
    /* Device memory: what each heap holds of ours and may hold (its size; PGI_GPU_HEAP_LIMIT=BYTES, a
     * test hook, makes it smaller). A device whose memory is the host's (a CPU device: lavapipe)
     * also keeps its buffers within the frame's memory budget (pgi__gpu_set_budget). */
    uint64_t heap_used[VK_MAX_MEMORY_HEAPS], heap_limit[VK_MAX_MEMORY_HEAPS];
    int host_memory;
    uint64_t budget;          /* 0: none */
    pgi__gpu_buffer *buffers; /* every live buffer, for the memory stats */
    pgi__gpu_buffer *staging;
    /* the sequence being recorded */
    int recording, commands;
    int nlabels;
    const char *labels[MAX_LABELS];
    double cpu_begin_ms;
    pgi_named_value timings[MAX_LABELS];
    int ntimings;
    pgi__gpu_traffic traffic; /* since creation */
};

static const char *vk_name(VkResult r) {
    switch (r) {
#define C(x)                                                                                                           \
    case x:                                                                                                            \
        return #x;
        C(VK_SUCCESS)
        C(VK_NOT_READY)
        C(VK_TIMEOUT)
        C(VK_INCOMPLETE)
        C(VK_ERROR_OUT_OF_HOST_MEMORY)
        C(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        C(VK_ERROR_INITIALIZATION_FAILED)
        C(VK_ERROR_DEVICE_LOST)
        C(VK_ERROR_MEMORY_MAP_FAILED)
        C(VK_ERROR_LAYER_NOT_PRESENT)
        C(VK_ERROR_EXTENSION_NOT_PRESENT)
        C(VK_ERROR_FEATURE_NOT_PRESENT)
        C(VK_ERROR_INCOMPATIBLE_DRIVER)
        C(VK_ERROR_TOO_MANY_OBJECTS)
        C(VK_ERROR_FORMAT_NOT_SUPPORTED)
        C(VK_ERROR_FRAGMENTED_POOL)
        C(VK_ERROR_OUT_OF_POOL_MEMORY)
        C(VK_ERROR_INVALID_SHADER_NV)
        C(VK_ERROR_UNKNOWN)
#undef C
    default: return "VkResult (unknown)";
    }
}

static pgi_status vk_fail(VkResult r, const char *what) {
    pgi_status s =
        (r == VK_ERROR_OUT_OF_HOST_MEMORY || r == VK_ERROR_OUT_OF_DEVICE_MEMORY) ? PGI_ERR_OOM : PGI_ERR_INTERNAL;
    return pgi__fail(s, "Vulkan: %s failed: %s (%d)", what, vk_name(r), (int)r);
}

int pgi__gpu_available(void) { return 1; }

static const char *type_name(VkPhysicalDeviceType t) {
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
    default: return "other";
    }
}

#define NO_DEVICE                                                                                                      \
    "no Vulkan device: the Vulkan loader found no driver (install mesa-vulkan-drivers for the CPU device lavapipe, "   \
    "or a GPU driver; or render with --device cpu)"

static pgi_status instance_create(VkInstance *inst) {
    VkApplicationInfo app = {.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
                             .pApplicationName = "photongi",
                             .pEngineName = "photongi",
                             .apiVersion = VK_API_VERSION_1_3};
    VkInstanceCreateInfo ci = {.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO, .pApplicationInfo = &app};
    VkResult r = vkCreateInstance(&ci, NULL, inst);
    if (r == VK_ERROR_INCOMPATIBLE_DRIVER) return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_DEVICE);
    if (r != VK_SUCCESS) return vk_fail(r, "vkCreateInstance");
    return PGI_OK;
}

/* The instance's devices (Vulkan 1.3 or later only), at most `max`. */
static int devices_list(VkInstance inst, VkPhysicalDevice *out, int max) {
    uint32_t n = 0;
    if (vkEnumeratePhysicalDevices(inst, &n, NULL) != VK_SUCCESS || n == 0) return 0;
    VkPhysicalDevice all[32];
    if (n > 32) n = 32;
    if (vkEnumeratePhysicalDevices(inst, &n, all) < 0) return 0;
    int k = 0;
    for (uint32_t i = 0; i < n && k < max; i++) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(all[i], &p);
        if (p.apiVersion >= VK_API_VERSION_1_3) out[k++] = all[i];
    }
    return k;
}

static void devices_describe(VkPhysicalDevice *d, int n, char *buf, size_t size) {
    buf[0] = 0;
    for (int i = 0; i < n; i++) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(d[i], &p);
        size_t l = strlen(buf);
        snprintf(buf + l, size - l, "%s%d: %s (%s)", i ? ", " : "", i, p.deviceName, type_name(p.deviceType));
    }
}

int pgi__gpu_device_count(void) {
    VkInstance inst;
    if (instance_create(&inst)) {
        pgi__clear_error();
        return 0;
    }
    VkPhysicalDevice d[32];
    int n = devices_list(inst, d, 32);
    vkDestroyInstance(inst, NULL);
    return n;
}

/* Device i's properties and driver properties (Vulkan 1.3 or later). */
static pgi_status device_props(int i, VkPhysicalDeviceProperties2 *p, VkPhysicalDeviceDriverProperties *drv) {
    VkInstance inst;
    pgi_status st = instance_create(&inst);
    if (st) return st;
    VkPhysicalDevice d[32];
    int n = devices_list(inst, d, 32);
    if (i < 0 || i >= n) {
        vkDestroyInstance(inst, NULL);
        return pgi__fail(PGI_ERR_INVALID_ARG, "Vulkan device %d does not exist (%d found)", i, n);
    }
    *drv = (VkPhysicalDeviceDriverProperties){.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    *p = (VkPhysicalDeviceProperties2){.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = drv};
    vkGetPhysicalDeviceProperties2(d[i], p);
    vkDestroyInstance(inst, NULL);
    return PGI_OK;
}

/* Device i's name (driver 0) or its type, driver and Vulkan version (driver 1) into buf. */
static pgi_status describe(int i, int driver, char *buf, size_t size) {
    if (size) buf[0] = 0;
    VkPhysicalDeviceProperties2 p;
    VkPhysicalDeviceDriverProperties drv;
    pgi_status st = device_props(i, &p, &drv);
    if (st) return st;
    const uint32_t api = p.properties.apiVersion;
    if (!driver) snprintf(buf, size, "%s", p.properties.deviceName);
    else
        snprintf(buf, size, "%s; driver %s %s; Vulkan %u.%u.%u", type_name(p.properties.deviceType), drv.driverName,
                 drv.driverInfo, VK_API_VERSION_MAJOR(api), VK_API_VERSION_MINOR(api), VK_API_VERSION_PATCH(api));
    return PGI_OK;
}

pgi_status pgi__gpu_device_name_at(int i, char *buf, size_t size) { return describe(i, 0, buf, size); }

pgi_status pgi__gpu_device_driver_at(int i, char *buf, size_t size) { return describe(i, 1, buf, size); }

static int has_extension(VkPhysicalDevice pd, const char *name) {
    uint32_t n = 0;
    if (vkEnumerateDeviceExtensionProperties(pd, NULL, &n, NULL) != VK_SUCCESS) return 0;
    VkExtensionProperties *e = malloc(n * sizeof *e + 1);
    if (!e) return 0;
    int found = 0;
    if (vkEnumerateDeviceExtensionProperties(pd, NULL, &n, e) >= 0)
        for (uint32_t i = 0; i < n && !found; i++) found = strcmp(e[i].extensionName, name) == 0;
    free(e);
    return found;
}

static int env_on(const char *name) {
    const char *v = getenv(name);
    return v && strcmp(v, "1") == 0;
}

pgi_status pgi__gpu_create(int index, pgi__gpu **out) {
    *out = NULL;
    pgi__gpu *g = calloc(1, sizeof *g);
    if (!g) return pgi__fail(PGI_ERR_OOM, "out of memory creating the Vulkan device");
    pgi_status st = instance_create(&g->inst);
    if (st) {
        free(g);
        return st;
    }
    VkPhysicalDevice d[32];
    int n = devices_list(g->inst, d, 32);
    char list[1024];
    devices_describe(d, n, list, sizeof list);
    if (n == 0) {
        pgi__gpu_destroy(g);
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", NO_DEVICE " (or none supports Vulkan 1.3)");
    }
    if (index >= n) {
        pgi__gpu_destroy(g);
        return pgi__fail(PGI_ERR_UNSUPPORTED, "Vulkan device %d does not exist; the devices are %s (--device vulkan:N)",
                         index, list);
    }
    if (index < 0) {
        static const VkPhysicalDeviceType pref[] = {VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU,
                                                    VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU,
                                                    VK_PHYSICAL_DEVICE_TYPE_CPU};
        for (int t = 0; t < 3 && index < 0; t++)
            for (int i = 0; i < n && index < 0; i++) {
                VkPhysicalDeviceProperties p;
                vkGetPhysicalDeviceProperties(d[i], &p);
                if (p.deviceType == pref[t]) index = i;
            }
        if (index < 0) index = 0;
    }
    g->pd = d[index];
    g->force_staging = env_on("PGI_GPU_STAGING");
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(g->pd, &props);
    snprintf(g->name, sizeof g->name, "%s", props.deviceName);
    g->max_bindings = props.limits.maxPerStageDescriptorStorageBuffers < MAX_BINDINGS
                          ? (int)props.limits.maxPerStageDescriptorStorageBuffers
                          : MAX_BINDINGS;
    vkGetPhysicalDeviceMemoryProperties(g->pd, &g->memp);
    const char *hl = getenv("PGI_GPU_HEAP_LIMIT");
    const unsigned long long hook = hl ? strtoull(hl, NULL, 10) : 0;
    for (uint32_t i = 0; i < g->memp.memoryHeapCount && i < VK_MAX_MEMORY_HEAPS; i++)
        g->heap_limit[i] = hook && hook < g->memp.memoryHeaps[i].size ? hook : g->memp.memoryHeaps[i].size;
    g->host_memory = props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    /* a compute queue: one without graphics first (a dedicated compute family), else any */
    uint32_t nq = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(g->pd, &nq, NULL);
    VkQueueFamilyProperties qf[16];
    if (nq > 16) nq = 16;
    vkGetPhysicalDeviceQueueFamilyProperties(g->pd, &nq, qf);
    int fam = -1;
    for (uint32_t i = 0; i < nq && fam < 0; i++)
        if ((qf[i].queueFlags & VK_QUEUE_COMPUTE_BIT) && !(qf[i].queueFlags & VK_QUEUE_GRAPHICS_BIT)) fam = (int)i;
    for (uint32_t i = 0; i < nq && fam < 0; i++)
        if (qf[i].queueFlags & VK_QUEUE_COMPUTE_BIT) fam = (int)i;
    if (fam < 0) {
        pgi__gpu_destroy(g);
        return pgi__fail(PGI_ERR_UNSUPPORTED, "Vulkan device %d (%s) has no compute queue", index, props.deviceName);
    }
    g->qfam = (uint32_t)fam;
    uint32_t valid = qf[fam].timestampValidBits;
    g->has_ts = valid > 0 && props.limits.timestampPeriod > 0.f && !env_on("PGI_GPU_NO_TIMESTAMPS");
    g->ts_period_ns = props.limits.timestampPeriod;
    g->ts_mask = valid >= 64 ? UINT64_MAX : ((uint64_t)1 << valid) - 1;
    const int push =
        has_extension(g->pd, VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME) && !env_on("PGI_GPU_NO_PUSH_DESCRIPTORS");
    const char *ext[] = {VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME};
    float prio = 1.f;
    VkDeviceQueueCreateInfo qci = {.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
                                   .queueFamilyIndex = g->qfam,
                                   .queueCount = 1,
                                   .pQueuePriorities = &prio};
    VkDeviceCreateInfo dci = {.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
                              .queueCreateInfoCount = 1,
                              .pQueueCreateInfos = &qci,
                              .enabledExtensionCount = push ? 1 : 0,
                              .ppEnabledExtensionNames = ext};
    VkResult r = vkCreateDevice(g->pd, &dci, NULL, &g->dev);
    if (r != VK_SUCCESS) {
        g->dev = VK_NULL_HANDLE;
        pgi__gpu_destroy(g);
        return vk_fail(r, "vkCreateDevice");
    }
    vkGetDeviceQueue(g->dev, g->qfam, 0, &g->queue);
    if (push) g->push_desc = (PFN_vkCmdPushDescriptorSetKHR)vkGetDeviceProcAddr(g->dev, "vkCmdPushDescriptorSetKHR");
    VkCommandPoolCreateInfo pci = {.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                   .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                                   .queueFamilyIndex = g->qfam};
    if ((r = vkCreateCommandPool(g->dev, &pci, NULL, &g->pool)) != VK_SUCCESS) {
        pgi__gpu_destroy(g);
        return vk_fail(r, "vkCreateCommandPool");
    }
    VkCommandBufferAllocateInfo cai = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                       .commandPool = g->pool,
                                       .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                       .commandBufferCount = 1};
    VkFenceCreateInfo fci = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    if ((r = vkAllocateCommandBuffers(g->dev, &cai, &g->cb)) != VK_SUCCESS ||
        (r = vkCreateFence(g->dev, &fci, NULL, &g->fence)) != VK_SUCCESS) {
        pgi__gpu_destroy(g);
        return vk_fail(r, "creating the command buffer");
    }
    if (g->has_ts) {
        VkQueryPoolCreateInfo qpi = {.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
                                     .queryType = VK_QUERY_TYPE_TIMESTAMP,
                                     .queryCount = MAX_LABELS};
        if ((r = vkCreateQueryPool(g->dev, &qpi, NULL, &g->qp)) != VK_SUCCESS) {
            pgi__gpu_destroy(g);
            return vk_fail(r, "vkCreateQueryPool");
        }
    }
    if (!g->push_desc) {
        VkDescriptorPoolSize ps = {.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                   .descriptorCount = MAX_SETS * MAX_BINDINGS};
        VkDescriptorPoolCreateInfo dpi = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                          .maxSets = MAX_SETS,
                                          .poolSizeCount = 1,
                                          .pPoolSizes = &ps};
        if ((r = vkCreateDescriptorPool(g->dev, &dpi, NULL, &g->dpool)) != VK_SUCCESS) {
            pgi__gpu_destroy(g);
            return vk_fail(r, "vkCreateDescriptorPool");
        }
    }
    *out = g;
    return PGI_OK;
}

int pgi__gpu_has_timestamps(const pgi__gpu *g) { return g && g->has_ts; }

void pgi__gpu_destroy(pgi__gpu *g) {
    if (!g) return;
    if (g->dev) {
        vkDeviceWaitIdle(g->dev);
        while (g->buffers) pgi__gpu_buffer_destroy(g, g->buffers);
        if (g->dpool) vkDestroyDescriptorPool(g->dev, g->dpool, NULL);
        if (g->qp) vkDestroyQueryPool(g->dev, g->qp, NULL);
        if (g->fence) vkDestroyFence(g->dev, g->fence, NULL);
        if (g->pool) vkDestroyCommandPool(g->dev, g->pool, NULL);
        vkDestroyDevice(g->dev, NULL);
    }
    if (g->inst) vkDestroyInstance(g->inst, NULL);
    free(g);
}

const char *pgi__gpu_device_name(const pgi__gpu *g) { return g ? g->name : "none"; }

/* ---------------------------------------------------------------- buffers */

static int memory_type(const pgi__gpu *g, uint32_t bits, VkMemoryPropertyFlags want) {
    for (uint32_t i = 0; i < g->memp.memoryTypeCount; i++)
        if ((bits & (1u << i)) && (g->memp.memoryTypes[i].propertyFlags & want) == want) return (int)i;
    return -1;
}

/* A size as "N.N MiB", or "N KiB" under a MiB (buf: at least 32 bytes). */
static const char *size_text(double bytes, char *buf) {
    if (bytes < 1024.0 * 1024.0) snprintf(buf, 32, "%.0f KiB", bytes / 1024.0);
    else snprintf(buf, 32, "%.1f MiB", bytes / (1024.0 * 1024.0));
    return buf;
}

/* Whether `bytes` more fit in heap `heap` (and, on a device whose memory is the host's, in the
 * budget): an allocation past them is refused with what holds the memory, before the driver
 * fails it or the host runs out. */
static pgi_status heap_fits(const pgi__gpu *g, uint32_t heap, uint64_t bytes, const char *what) {
    uint64_t used = 0;
    for (uint32_t i = 0; i < VK_MAX_MEMORY_HEAPS; i++) used += g->heap_used[i];
    const int over_heap = g->heap_used[heap] + bytes > g->heap_limit[heap];
    const int over_budget = g->host_memory && g->budget && used + bytes > g->budget;
    if (!over_heap && !over_budget) return PGI_OK;
    /* the largest holders, to say where the memory went */
    pgi_named_value top[PGI_MAX_STAT_ENTRIES];
    int n = pgi__gpu_memory(g, top, PGI_MAX_STAT_ENTRIES);
    char list[256] = "";
    for (int k = 0, len = 0; k < 3 && k < n; k++) {
        int best = k;
        for (int i = k + 1; i < n; i++)
            if (top[i].value > top[best].value) best = i;
        pgi_named_value t = top[k];
        top[k] = top[best];
        top[best] = t;
        char sz[32];
        len += snprintf(list + len, sizeof list - (size_t)len, "%s%s %s", k ? ", " : "", top[k].name,
                        size_text(top[k].value, sz));
        if (len >= (int)sizeof list) break;
    }
    char a[32], b[32], c[32];
    if (over_heap)
        return pgi__fail(PGI_ERR_OOM,
                         "Vulkan device %s: %s needs %s of device memory, and %s of its %s are taken by photongi's "
                         "other buffers%s%s%s: use fewer photons or a smaller image",
                         g->name, what, size_text((double)bytes, a), size_text((double)g->heap_used[heap], b),
                         size_text((double)g->heap_limit[heap], c), n ? " (" : "", list, n ? ")" : "");
    return pgi__fail(PGI_ERR_OOM,
                     "Vulkan device %s: %s needs %s, and the device's buffers already hold %s of the %s memory "
                     "budget (--max-memory; this device's memory is the host's)%s%s%s",
                     g->name, what, size_text((double)bytes, a), size_text((double)used, b),
                     size_text((double)g->budget, c), n ? " (" : "", list, n ? ")" : "");
}

void pgi__gpu_set_budget(pgi__gpu *g, uint64_t bytes) {
    if (g) g->budget = bytes == PGI_MEMORY_UNLIMITED ? 0 : bytes;
}

/* A buffer of `bytes`; `host`: host-visible and coherent (staging), else device-local where there is such
 * memory (mapped too when that memory is also host-visible and coherent, as on lavapipe and ReBAR). */
static pgi_status buffer_new(pgi__gpu *g, size_t bytes, const char *what, int host, pgi__gpu_buffer **out) {
    *out = NULL;
    pgi__gpu_buffer *b = calloc(1, sizeof *b);
    if (!b) return pgi__fail(PGI_ERR_OOM, "out of memory");
    if (bytes == 0) bytes = 4;
    bytes = (bytes + 3) & ~(size_t)3;
    VkBufferCreateInfo bci = {.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
                              .size = bytes,
                              .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                                       VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                              .sharingMode = VK_SHARING_MODE_EXCLUSIVE};
    VkResult r = vkCreateBuffer(g->dev, &bci, NULL, &b->buf);
    if (r != VK_SUCCESS) {
        free(b);
        return vk_fail(r, "vkCreateBuffer");
    }
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(g->dev, b->buf, &req);
    const VkMemoryPropertyFlags hv = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    int t = -1;
    if (host) {
        t = memory_type(g, req.memoryTypeBits, hv | VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
        if (t < 0) t = memory_type(g, req.memoryTypeBits, hv);
    } else {
        /* the first device-local type (drivers list the plain device-local one before a host-visible
         * device heap); on lavapipe that one is host-visible too and is mapped */
        t = memory_type(g, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
        if (t < 0) t = memory_type(g, req.memoryTypeBits, hv);
        if (t < 0) t = memory_type(g, req.memoryTypeBits, 0);
    }
    if (t < 0) {
        vkDestroyBuffer(g->dev, b->buf, NULL);
        free(b);
        return pgi__fail(PGI_ERR_UNSUPPORTED, "Vulkan: no memory type for a %s buffer of %zu bytes", what, bytes);
    }
    const uint32_t heap = g->memp.memoryTypes[t].heapIndex;
    pgi_status fits = heap_fits(g, heap, req.size, what);
    if (fits) {
        vkDestroyBuffer(g->dev, b->buf, NULL);
        free(b);
        return fits;
    }
    VkMemoryAllocateInfo mai = {.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
                                .allocationSize = req.size,
                                .memoryTypeIndex = (uint32_t)t};
    if ((r = vkAllocateMemory(g->dev, &mai, NULL, &b->mem)) != VK_SUCCESS) {
        vkDestroyBuffer(g->dev, b->buf, NULL);
        free(b);
        char msg[128];
        snprintf(msg, sizeof msg, "allocating %zu bytes for %s", bytes, what);
        return vk_fail(r, msg);
    }
    if ((r = vkBindBufferMemory(g->dev, b->buf, b->mem, 0)) != VK_SUCCESS) {
        vkFreeMemory(g->dev, b->mem, NULL);
        vkDestroyBuffer(g->dev, b->buf, NULL);
        free(b);
        return vk_fail(r, "vkBindBufferMemory");
    }
    if ((g->memp.memoryTypes[t].propertyFlags & hv) == hv && (host || !g->force_staging) &&
        (r = vkMapMemory(g->dev, b->mem, 0, VK_WHOLE_SIZE, 0, &b->mapped)) != VK_SUCCESS)
        b->mapped = NULL; /* used through staging instead */
    b->size = bytes;
    b->what = what;
    b->heap = heap;
    b->alloc = req.size;
    g->heap_used[heap] += req.size;
    b->next = g->buffers;
    if (g->buffers) g->buffers->prev = b;
    g->buffers = b;
    *out = b;
    return PGI_OK;
}

pgi_status pgi__gpu_buffer_reserve(pgi__gpu *g, pgi__gpu_buffer **b, size_t bytes, const char *what) {
    if (*b && (*b)->size >= bytes) {
        (*b)->what = what;
        return PGI_OK;
    }
    if (g->recording) return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_buffer_reserve inside a command sequence");
    pgi__gpu_buffer_destroy(g, *b);
    *b = NULL;
    return buffer_new(g, bytes, what, 0, b);
}

void pgi__gpu_buffer_destroy(pgi__gpu *g, pgi__gpu_buffer *b) {
    if (!g || !b) return;
    if (b->prev) b->prev->next = b->next;
    else g->buffers = b->next;
    if (b->next) b->next->prev = b->prev;
    if (g->staging == b) g->staging = NULL;
    if (b->mapped) vkUnmapMemory(g->dev, b->mem);
    g->heap_used[b->heap] -= b->alloc;
    vkDestroyBuffer(g->dev, b->buf, NULL);
    vkFreeMemory(g->dev, b->mem, NULL);
    free(b);
}

size_t pgi__gpu_buffer_size(const pgi__gpu_buffer *b) { return b ? b->size : 0; }

int pgi__gpu_memory(const pgi__gpu *g, pgi_named_value *out, int max) {
    int n = 0;
    for (const pgi__gpu_buffer *b = g ? g->buffers : NULL; b; b = b->next) {
        int k = 0;
        while (k < n && strcmp(out[k].name, b->what) != 0) k++;
        if (k == n) {
            if (n == max) continue;
            out[n++] = (pgi_named_value){b->what, 0.0};
        }
        out[k].value += (double)b->size;
    }
    return n;
}

static pgi_status one_shot_begin(pgi__gpu *g) {
    VkResult r = vkResetCommandBuffer(g->cb, 0);
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    if (r == VK_SUCCESS) r = vkBeginCommandBuffer(g->cb, &bi);
    return r == VK_SUCCESS ? PGI_OK : vk_fail(r, "vkBeginCommandBuffer");
}

static pgi_status submit_and_wait(pgi__gpu *g) {
    VkResult r = vkEndCommandBuffer(g->cb);
    if (r != VK_SUCCESS) return vk_fail(r, "vkEndCommandBuffer");
    VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &g->cb};
    if ((r = vkResetFences(g->dev, 1, &g->fence)) != VK_SUCCESS) return vk_fail(r, "vkResetFences");
    if ((r = vkQueueSubmit(g->queue, 1, &si, g->fence)) != VK_SUCCESS) return vk_fail(r, "vkQueueSubmit");
    if ((r = vkWaitForFences(g->dev, 1, &g->fence, VK_TRUE, UINT64_MAX)) != VK_SUCCESS)
        return vk_fail(r, "vkWaitForFences");
    return PGI_OK;
}

static pgi_status staging_get(pgi__gpu *g, size_t bytes) {
    if (g->staging && g->staging->size >= bytes) return PGI_OK;
    pgi__gpu_buffer_destroy(g, g->staging);
    g->staging = NULL;
    return buffer_new(g, bytes, "gpu_staging", 1, &g->staging);
}

static pgi_status check_range(const pgi__gpu_buffer *b, size_t offset, size_t bytes, const char *op) {
    if (!b || offset > b->size || bytes > b->size - offset)
        return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_%s: %zu bytes at %zu outside a buffer of %zu", op, bytes, offset,
                         b ? b->size : 0);
    return PGI_OK;
}

/* Copies through the staging buffer, in chunks of at most STAGING_MAX bytes. */
static pgi_status staged_copy(pgi__gpu *g, pgi__gpu_buffer *dev, size_t offset, void *host, size_t bytes, int up) {
    pgi_status st;
    size_t chunk = bytes < STAGING_MAX ? bytes : STAGING_MAX;
    if ((st = staging_get(g, chunk))) return st;
    for (size_t done = 0; done < bytes; done += chunk) {
        size_t n = bytes - done < chunk ? bytes - done : chunk;
        if (up) memcpy(g->staging->mapped, (const char *)host + done, n);
        if ((st = one_shot_begin(g))) return st;
        VkBufferCopy c = {.srcOffset = up ? 0 : offset + done, .dstOffset = up ? offset + done : 0, .size = n};
        vkCmdCopyBuffer(g->cb, up ? g->staging->buf : dev->buf, up ? dev->buf : g->staging->buf, 1, &c);
        VkMemoryBarrier mb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
                              .srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
                              .dstAccessMask = VK_ACCESS_HOST_READ_BIT | VK_ACCESS_SHADER_READ_BIT};
        vkCmdPipelineBarrier(g->cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &mb, 0, NULL, 0,
                             NULL);
        if ((st = submit_and_wait(g))) return st;
        if (!up) memcpy((char *)host + done, g->staging->mapped, n);
    }
    return PGI_OK;
}

pgi_status pgi__gpu_upload(pgi__gpu *g, pgi__gpu_buffer *dst, size_t offset, const void *src, size_t bytes) {
    pgi_status st;
    if ((st = check_range(dst, offset, bytes, "upload"))) return st;
    if (g->recording) return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_upload inside a command sequence");
    if (bytes == 0) return PGI_OK;
    g->traffic.uploads++;
    g->traffic.upload_bytes += bytes;
    if (dst->mapped) {
        memcpy((char *)dst->mapped + offset, src, bytes);
        return PGI_OK;
    }
    return staged_copy(g, dst, offset, (void *)src, bytes, 1);
}

pgi_status pgi__gpu_download(pgi__gpu *g, const pgi__gpu_buffer *src, size_t offset, void *dst, size_t bytes) {
    pgi_status st;
    if ((st = check_range(src, offset, bytes, "download"))) return st;
    if (g->recording) return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_download inside a command sequence");
    if (bytes == 0) return PGI_OK;
    g->traffic.downloads++;
    g->traffic.download_bytes += bytes;
    if (src->mapped) {
        memcpy(dst, (const char *)src->mapped + offset, bytes);
        return PGI_OK;
    }
    return staged_copy(g, (pgi__gpu_buffer *)src, offset, dst, bytes, 0);
}

/* ---------------------------------------------------------------- kernels */

pgi_status pgi__gpu_kernel_create(pgi__gpu *g, const uint32_t *spirv, size_t spirv_bytes, const char *name,
                                  int nbuffers, uint32_t push_bytes, pgi__gpu_kernel **out) {
    *out = NULL;
    if (nbuffers < 1 || nbuffers > MAX_BINDINGS || push_bytes > 128 || push_bytes % 4)
        return pgi__fail(PGI_ERR_INVALID_ARG, "kernel %s: %d buffers (1..%d), %u push bytes (0..128, 4k)", name,
                         nbuffers, MAX_BINDINGS, push_bytes);
    if (nbuffers > g->max_bindings)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "kernel %s: %d storage buffers, the device takes %d a shader stage", name,
                         nbuffers, g->max_bindings);
    pgi__gpu_kernel *k = calloc(1, sizeof *k);
    if (!k) return pgi__fail(PGI_ERR_OOM, "out of memory");
    k->nbuffers = nbuffers;
    k->push_bytes = push_bytes;
    k->name = name;
    char what[160];
    VkShaderModuleCreateInfo smi = {.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
                                    .codeSize = spirv_bytes,
                                    .pCode = spirv};
    VkResult r = vkCreateShaderModule(g->dev, &smi, NULL, &k->module);
    if (r != VK_SUCCESS) {
        snprintf(what, sizeof what, "vkCreateShaderModule (kernel %s)", name);
        goto fail;
    }
    VkDescriptorSetLayoutBinding bind[MAX_BINDINGS];
    for (int i = 0; i < nbuffers; i++)
        bind[i] = (VkDescriptorSetLayoutBinding){.binding = (uint32_t)i,
                                                 .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                                 .descriptorCount = 1,
                                                 .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT};
    VkDescriptorSetLayoutCreateInfo dli = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .flags = g->push_desc
                                                        ? VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR
                                                        : 0,
                                           .bindingCount = (uint32_t)nbuffers,
                                           .pBindings = bind};
    if ((r = vkCreateDescriptorSetLayout(g->dev, &dli, NULL, &k->dsl)) != VK_SUCCESS) {
        snprintf(what, sizeof what, "vkCreateDescriptorSetLayout (kernel %s)", name);
        goto fail;
    }
    VkPushConstantRange pr = {.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT, .offset = 0, .size = push_bytes};
    VkPipelineLayoutCreateInfo pli = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 1,
                                      .pSetLayouts = &k->dsl,
                                      .pushConstantRangeCount = push_bytes ? 1 : 0,
                                      .pPushConstantRanges = &pr};
    if ((r = vkCreatePipelineLayout(g->dev, &pli, NULL, &k->layout)) != VK_SUCCESS) {
        snprintf(what, sizeof what, "vkCreatePipelineLayout (kernel %s)", name);
        goto fail;
    }
    VkComputePipelineCreateInfo cpi = {.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
                                       .stage = {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                                                 .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                                                 .module = k->module,
                                                 .pName = "main"},
                                       .layout = k->layout};
    if ((r = vkCreateComputePipelines(g->dev, VK_NULL_HANDLE, 1, &cpi, NULL, &k->pipe)) != VK_SUCCESS) {
        snprintf(what, sizeof what, "vkCreateComputePipelines (kernel %s)", name);
        goto fail;
    }
    *out = k;
    return PGI_OK;
fail:
    pgi__gpu_kernel_destroy(g, k);
    return vk_fail(r, what);
}

void pgi__gpu_kernel_destroy(pgi__gpu *g, pgi__gpu_kernel *k) {
    if (!g || !k) return;
    if (k->pipe) vkDestroyPipeline(g->dev, k->pipe, NULL);
    if (k->layout) vkDestroyPipelineLayout(g->dev, k->layout, NULL);
    if (k->dsl) vkDestroyDescriptorSetLayout(g->dev, k->dsl, NULL);
    if (k->module) vkDestroyShaderModule(g->dev, k->module, NULL);
    free(k);
}

/* ---------------------------------------------------------------- sequences */

pgi_status pgi__gpu_begin(pgi__gpu *g) {
    if (g->recording) return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_begin: a sequence is already being recorded");
    pgi_status st = one_shot_begin(g);
    if (st) return st;
    if (g->dpool) vkResetDescriptorPool(g->dev, g->dpool, 0);
    if (g->has_ts) vkCmdResetQueryPool(g->cb, g->qp, 0, MAX_LABELS);
    g->recording = 1;
    g->commands = 0;
    g->nlabels = 0;
    g->ntimings = 0;
    g->cpu_begin_ms = pgi__now_ms();
    return PGI_OK;
}

/* Every command waits for the writes of everything recorded before it. */
static void barrier(pgi__gpu *g) {
    if (g->commands++ == 0) return;
    VkMemoryBarrier mb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
                          .srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
                          .dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                                           VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT};
    const VkPipelineStageFlags stages = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
    vkCmdPipelineBarrier(g->cb, stages, stages, 0, 1, &mb, 0, NULL, 0, NULL);
}

pgi_status pgi__gpu_dispatch(pgi__gpu *g, pgi__gpu_kernel *k, pgi__gpu_buffer *const *buffers, const void *push,
                             uint32_t groups_x, uint32_t groups_y, uint32_t groups_z) {
    if (!g->recording) return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_dispatch outside begin/submit_wait");
    if (groups_x == 0 || groups_y == 0 || groups_z == 0) return PGI_OK;
    g->traffic.dispatches++;
    VkDescriptorBufferInfo info[MAX_BINDINGS];
    VkWriteDescriptorSet w[MAX_BINDINGS];
    for (int i = 0; i < k->nbuffers; i++) {
        if (!buffers[i]) return pgi__fail(PGI_ERR_INTERNAL, "kernel %s: buffer %d is NULL", k->name, i);
        info[i] = (VkDescriptorBufferInfo){.buffer = buffers[i]->buf, .offset = 0, .range = VK_WHOLE_SIZE};
        w[i] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                      .dstBinding = (uint32_t)i,
                                      .descriptorCount = 1,
                                      .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                      .pBufferInfo = &info[i]};
    }
    barrier(g);
    vkCmdBindPipeline(g->cb, VK_PIPELINE_BIND_POINT_COMPUTE, k->pipe);
    if (g->push_desc) {
        g->push_desc(g->cb, VK_PIPELINE_BIND_POINT_COMPUTE, k->layout, 0, (uint32_t)k->nbuffers, w);
    } else {
        VkDescriptorSetAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                          .descriptorPool = g->dpool,
                                          .descriptorSetCount = 1,
                                          .pSetLayouts = &k->dsl};
        VkDescriptorSet set;
        VkResult r = vkAllocateDescriptorSets(g->dev, &ai, &set);
        if (r != VK_SUCCESS) {
            char what[128];
            snprintf(what, sizeof what, "vkAllocateDescriptorSets (kernel %s; at most %d dispatches a sequence)",
                     k->name, MAX_SETS);
            return vk_fail(r, what);
        }
        for (int i = 0; i < k->nbuffers; i++) w[i].dstSet = set;
        vkUpdateDescriptorSets(g->dev, (uint32_t)k->nbuffers, w, 0, NULL);
        vkCmdBindDescriptorSets(g->cb, VK_PIPELINE_BIND_POINT_COMPUTE, k->layout, 0, 1, &set, 0, NULL);
    }
    if (k->push_bytes) vkCmdPushConstants(g->cb, k->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, k->push_bytes, push);
    vkCmdDispatch(g->cb, groups_x, groups_y, groups_z);
    return PGI_OK;
}

pgi_status pgi__gpu_fill(pgi__gpu *g, pgi__gpu_buffer *b, size_t offset, size_t bytes, uint32_t value) {
    if (!g->recording) return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_fill outside begin/submit_wait");
    pgi_status st = check_range(b, offset, bytes, "fill");
    if (st) return st;
    if (offset % 4 || bytes % 4)
        return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_fill: offset %zu and size %zu must be multiples of 4", offset,
                         bytes);
    if (bytes == 0) return PGI_OK;
    barrier(g);
    vkCmdFillBuffer(g->cb, b->buf, offset, bytes, value);
    return PGI_OK;
}

void pgi__gpu_timestamp(pgi__gpu *g, const char *label) {
    if (!g->recording || g->nlabels >= MAX_LABELS) return;
    if (g->has_ts) {
        /* after everything recorded so far has finished */
        vkCmdWriteTimestamp(g->cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, g->qp, (uint32_t)g->nlabels);
    }
    g->labels[g->nlabels++] = label;
}

pgi_status pgi__gpu_submit_wait(pgi__gpu *g) {
    if (!g->recording) return pgi__fail(PGI_ERR_INTERNAL, "pgi__gpu_submit_wait without pgi__gpu_begin");
    g->recording = 0;
    g->traffic.submits++;
    /* the results become visible to the host (mapped buffers) */
    VkMemoryBarrier mb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
                          .srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
                          .dstAccessMask = VK_ACCESS_HOST_READ_BIT};
    vkCmdPipelineBarrier(g->cb, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &mb, 0, NULL, 0, NULL);
    double t0 = pgi__now_ms();
    pgi_status st = submit_and_wait(g);
    double t1 = pgi__now_ms();
    if (st) return st;
    g->ntimings = 0;
    if (g->nlabels < 2) return PGI_OK;
    if (!g->has_ts) {
        /* no timestamps on this queue: the whole sequence, timed on the CPU, under the last label */
        g->timings[g->ntimings++] = (pgi_named_value){g->labels[g->nlabels - 1], t1 - t0};
        return PGI_OK;
    }
    uint64_t ts[MAX_LABELS];
    VkResult r = vkGetQueryPoolResults(g->dev, g->qp, 0, (uint32_t)g->nlabels, sizeof ts, ts, sizeof ts[0],
                                       VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    if (r != VK_SUCCESS) return vk_fail(r, "vkGetQueryPoolResults");
    for (int i = 1; i < g->nlabels; i++) {
        uint64_t d = ((ts[i] & g->ts_mask) - (ts[i - 1] & g->ts_mask)) & g->ts_mask;
        g->timings[g->ntimings++] = (pgi_named_value){g->labels[i], (double)d * g->ts_period_ns * 1e-6};
    }
    return PGI_OK;
}

int pgi__gpu_timings(const pgi__gpu *g, pgi_named_value *out, int max) {
    int n = 0;
    for (int i = 0; g && i < g->ntimings && n < max; i++) out[n++] = g->timings[i];
    return n;
}

pgi__gpu_traffic pgi__gpu_traffic_get(const pgi__gpu *g) { return g->traffic; }

#endif /* PGI__HAVE_VULKAN */

/* Both builds: only pgi__gpu_dispatch differs. */
pgi_status pgi__gpu_dispatch_1d(pgi__gpu *g, pgi__gpu_kernel *k, pgi__gpu_buffer *const *buffers, const void *push,
                                size_t items, uint32_t local) {
    size_t groups = (items + local - 1) / local;
    if (groups == 0) groups = 1;
    const uint32_t gx = groups < 65535 ? (uint32_t)groups : 65535u;
    const uint32_t gy = (uint32_t)((groups + gx - 1) / gx);
    return pgi__gpu_dispatch(g, k, buffers, push, gx, gy, 1);
}

pgi_status pgi__gpu_kernels_create(pgi__gpu *g, const pgi__gpu_kernel_spec *specs, int n, uint32_t skip,
                                   pgi__gpu_kernel **out) {
    for (int i = 0; i < n; i++) {
        if (skip >> i & 1u) continue;
        pgi_status st = pgi__gpu_kernel_create(g, specs[i].spirv, specs[i].spirv_bytes, specs[i].name,
                                               specs[i].nbuffers, specs[i].push_bytes, &out[i]);
        if (st) return st;
    }
    return PGI_OK;
}
