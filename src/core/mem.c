/* Memory ledger, budget and peak resident set (mem.h, docs/memory.md). */
#include "core/mem.h"

#include <stdio.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

/* Where the budget comes from, for messages (the library's field and the CLI's option). */
#define BUDGET_NAME "the memory budget"
#define BUDGET_HOW "(pgi_render_desc.max_memory, --max-memory)"

static pgi__mem_entry *find(pgi__mem_ledger *l, const char *name, int add) {
    for (int i = 0; i < l->n; i++)
        if (strcmp(l->e[i].name, name) == 0) return &l->e[i];
    if (!add || l->n >= PGI__MEM_MAX) return NULL;
    l->e[l->n] = (pgi__mem_entry){name, 0, 0};
    return &l->e[l->n++];
}

void pgi__mem_set(pgi__mem_ledger *l, const char *name, size_t bytes) {
    pgi__mem_entry *e = find(l, name, 1);
    PGI__ASSERT(e != NULL); /* PGI__MEM_MAX covers every name the library uses */
    l->cur = l->cur - e->cur + bytes;
    e->cur = bytes;
    if (bytes > e->peak) e->peak = bytes;
    if (l->cur > l->peak) l->peak = l->cur;
}

size_t pgi__mem_get(const pgi__mem_ledger *l, const char *name) {
    for (int i = 0; i < l->n; i++)
        if (strcmp(l->e[i].name, name) == 0) return l->e[i].cur;
    return 0;
}

const char *pgi__mem_format(uint64_t bytes, char *buf, size_t size) {
    static const char *const units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    double v = (double)bytes;
    int u = 0;
    while (v >= 1024.0 && u < 6) {
        v /= 1024.0;
        u++;
    }
    if (u == 0) snprintf(buf, size, "%llu B", (unsigned long long)bytes);
    else snprintf(buf, size, v < 10.0 ? "%.2f %s" : v < 100.0 ? "%.1f %s" : "%.0f %s", v, units[u]);
    return buf;
}

pgi_status pgi__mem_reserve(pgi__mem_ledger *l, const char *name, size_t bytes, const char *what) {
    pgi__mem_entry *e = find(l, name, 1);
    PGI__ASSERT(e != NULL);
    const size_t others = l->cur - e->cur;
    if (l->budget != PGI_MEMORY_UNLIMITED && (bytes > l->budget || others > l->budget - bytes)) {
        char b[32], o[32], g[32];
        return pgi__fail(PGI_ERR_OOM,
                         "%s: %s need %s; with the %s already held that is over " BUDGET_NAME " of %s " BUDGET_HOW,
                         name, what, pgi__mem_format(bytes, b, sizeof b), pgi__mem_format(others, o, sizeof o),
                         pgi__mem_format(l->budget, g, sizeof g));
    }
    pgi__mem_set(l, name, bytes);
    return PGI_OK;
}

/* A number from a cgroup file ("max" or unreadable: 0). */
static uint64_t read_limit(const char *path) {
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    unsigned long long v = 0;
    int ok = fscanf(f, "%llu", &v) == 1;
    fclose(f);
    return ok ? (uint64_t)v : 0;
}

uint64_t pgi__mem_default_budget(void) {
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    uint64_t phys = pages > 0 && page > 0 ? (uint64_t)pages * (uint64_t)page : PGI_MEMORY_UNLIMITED;
    /* a container's limit is what the kernel enforces (v1 writes a huge number for "none") */
    const char *const cg[] = {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"};
    for (size_t i = 0; i < sizeof cg / sizeof cg[0]; i++) {
        uint64_t v = read_limit(cg[i]);
        if (v > 0 && v < phys) phys = v;
    }
    return phys;
}

uint64_t pgi_memory_default_budget(void) { return pgi__mem_default_budget(); }

uint64_t pgi_memory_peak_rss(void) {
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
#if defined(__APPLE__)
    return (uint64_t)ru.ru_maxrss; /* bytes */
#else
    return (uint64_t)ru.ru_maxrss * 1024u; /* kilobytes */
#endif
}

pgi_status pgi__mem_plan_check(const pgi__mem_plan_item *items, int n, uint64_t budget, uint64_t photons) {
    if (budget == PGI_MEMORY_UNLIMITED) return PGI_OK;
    uint64_t fixed = 0, per = 0;
    for (int i = 0; i < n; i++) *(items[i].per_photon ? &per : &fixed) += items[i].bytes;
    char a[32], b[32], g[32], list[512] = "";
    if (fixed + per <= budget) return PGI_OK;
    /* the parts, largest first */
    int order[32], m = n < 32 ? n : 32;
    for (int i = 0; i < m; i++) order[i] = i;
    for (int i = 1; i < m; i++)
        for (int j = i; j > 0 && items[order[j]].bytes > items[order[j - 1]].bytes; j--) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    if (fixed > budget) {
        /* not even without photons: the fixed parts, the largest named first */
        for (int k = 0; k < m; k++) {
            const pgi__mem_plan_item *it = &items[order[k]];
            if (it->per_photon || !it->bytes) continue;
            size_t len = strlen(list);
            snprintf(list + len, sizeof list - len, "%s%s %s", len ? ", " : "", it->name,
                     pgi__mem_format(it->bytes, a, sizeof a));
        }
        const char *largest = "frame";
        for (int k = 0; k < m; k++)
            if (!items[order[k]].per_photon) {
                largest = items[order[k]].name;
                break;
            }
        return pgi__fail(PGI_ERR_OOM,
                         "%s: the frame needs %s before any photon (%s), over " BUDGET_NAME " of %s " BUDGET_HOW,
                         largest, pgi__mem_format(fixed, b, sizeof b), list, pgi__mem_format(budget, g, sizeof g));
    }
    for (int k = 0; k < m; k++) {
        const pgi__mem_plan_item *it = &items[order[k]];
        if (!it->per_photon || !it->bytes) continue;
        size_t len = strlen(list);
        snprintf(list + len, sizeof list - len, "%s%s %s", len ? ", " : "", it->name,
                 pgi__mem_format(it->bytes, a, sizeof a));
    }
    /* the per-photon parts are proportional (or sub-linear) in the count: this many fit */
    const double each = photons ? (double)per / (double)photons : 0.0;
    const uint64_t fit = each > 0.0 ? (uint64_t)((double)(budget - fixed) / each) : 0;
    return pgi__fail(PGI_ERR_OOM,
                     "photons: %llu photons need %s (%s) besides the frame's %s, over " BUDGET_NAME " of %s " BUDGET_HOW
                     "; about %llu photons fit",
                     (unsigned long long)photons, pgi__mem_format(per, a, sizeof a), list,
                     pgi__mem_format(fixed, b, sizeof b), pgi__mem_format(budget, g, sizeof g),
                     (unsigned long long)fit);
}

void pgi__stats_mem_put(pgi_frame_stats *fs, const char *name, size_t bytes) {
    int at = -1;
    for (int i = 0; i < fs->memory_count; i++) {
        if (strcmp(fs->memory_bytes[i].name, name) == 0) {
            fs->memory_bytes[i].value = (double)bytes;
            return;
        }
        if (strcmp(fs->memory_bytes[i].name, "image") == 0) at = i + 1;
    }
    if (fs->memory_count >= PGI_MAX_STAT_ENTRIES) return;
    if (at < 0) at = fs->memory_count;
    for (int i = fs->memory_count; i > at; i--) fs->memory_bytes[i] = fs->memory_bytes[i - 1];
    fs->memory_bytes[at] = (pgi_named_value){name, (double)bytes};
    fs->memory_count++;
}
