/* Memory accounting (docs/memory.md): a small ledger of the large allocations a renderer holds
 * (named entries, current and peak bytes), the memory budget they are checked against, and the
 * process's peak resident set. Only large buffers report here (photons, view samples, frame
 * buffers, scratch, estimator structures, the scene and Embree's BVH); nothing tracks small
 * allocations. */
#ifndef PGI__MEM_H
#define PGI__MEM_H

#include "core/core.h"

#define PGI__MEM_MAX 16

typedef struct pgi__mem_entry {
    const char *name; /* static string */
    size_t cur, peak;
} pgi__mem_entry;

typedef struct pgi__mem_ledger {
    pgi__mem_entry e[PGI__MEM_MAX];
    int n;
    size_t cur, peak; /* sum of the entries now, and the largest that sum has been */
    uint64_t budget;  /* bytes; PGI_MEMORY_UNLIMITED: no check */
} pgi__mem_ledger;

/* Records that entry `name` now holds `bytes` (replacing what it held); no budget check (sizes
 * known only once allocated: Embree's BVH, an estimator's structures). */
void pgi__mem_set(pgi__mem_ledger *l, const char *name, size_t bytes);
/* Before an allocation: entry `name` is about to hold `bytes` instead of what it holds. When the
 * other entries plus `bytes` exceed the budget, PGI_ERR_OOM with the message
 * "<name>: <what> need(s) <bytes>, ... over the memory budget of ..." and nothing changes;
 * else the entry is set (as pgi__mem_set). `what` describes the request ("5000000 photons"). */
pgi_status pgi__mem_reserve(pgi__mem_ledger *l, const char *name, size_t bytes, const char *what);
size_t pgi__mem_get(const pgi__mem_ledger *l, const char *name);

/* The default budget (pgi_render_desc.max_memory 0): the machine's physical memory, or the
 * cgroup's memory limit (cgroup v2 memory.max, v1 memory.limit_in_bytes) when lower. */
uint64_t pgi__mem_default_budget(void);
/* "1.5 GiB", "640 MiB", "12 KiB", "100 B" into buf. */
const char *pgi__mem_format(uint64_t bytes, char *buf, size_t size);

/* A frame's expected memory, checked against the budget before anything of the frame is
 * allocated (render.c). Entries are either fixed or proportional to the photon count. */
typedef struct pgi__mem_plan_item {
    const char *name;
    uint64_t bytes;
    int per_photon; /* part of what the photon count costs */
} pgi__mem_plan_item;
/* PGI_ERR_OOM naming what does not fit (the photons: how many would) when the items' sum exceeds
 * `budget`; `photons` is the count the per-photon items were computed for. */
pgi_status pgi__mem_plan_check(const pgi__mem_plan_item *items, int n, uint64_t budget, uint64_t photons);

/* Sets entry `name` of a frame's memory stats (added after "image" when it is not there). */
void pgi__stats_mem_put(pgi_frame_stats *fs, const char *name, size_t bytes);

#endif
