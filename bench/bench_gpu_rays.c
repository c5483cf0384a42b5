/* photongi-bench-gpu-rays: the GPU backend's BVH (src/rt/tri_bvh.h) and ray kernel
 * (src/gpu/gpu_rays.h) on one scene.
 *
 *   photongi-bench-gpu-rays [--scene sibenik] [--rays 200000] [--size 640x360] [--threads 2] [--configs]
 *                           [--config QUALITY,WIDTH,MAX_LEAF] [--device N]
 *
 * Prints markdown tables: the default build (time, bytes, nodes, leaves, SAH cost) and, with
 * --configs, the other builds (binned SAH or spatial splits, 2- or 4-wide, leaf sizes; --config:
 * another build first, e.g. 2,4,8 for spatial splits, 4-wide, leaves of 8), with the
 * work a ray costs the traversal (nodes, leaves, triangles) and the rate of the layout's CPU
 * traversal (--threads threads) for primary rays (every camera of the scene at --size) and random
 * rays (origins in the scene's box, uniform directions); then the rates of Embree (single-ray
 * queries, --threads threads) and of the GPU kernel (Vulkan device N, default the first GPU, else
 * lavapipe) for those and for shadow rays (any hit, from random rays' hits to random points):
 * the kernel alone (timestamps) and with the rays' upload and the hits' download. */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rt/tri_bvh.h"
#include "gpu/gpu_rays.h"
#include "rt/rt.h"
#include "scene/scene_internal.h"
#include "view/view.h"

typedef struct ray_set {
    const char *name;
    pgi__tri_bvh_ray *r;
    size_t n;
    int any; /* occlusion queries */
} ray_set;

static uint64_t splitmix(uint64_t *s) {
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static float unif(uint64_t *s) { return (float)(splitmix(s) >> 40) * (1.0f / 16777216.0f); }

static ray_set primary_rays(const pgi_scene *s, int w, int h) {
    ray_set rs = {"primary", malloc((size_t)w * h * (s->ncams ? s->ncams : 1) * sizeof(pgi__tri_bvh_ray)), 0, 0};
    for (size_t c = 0; c < s->ncams; c++) {
        pgi_camera cam;
        const pgi_camera_def *cd = &s->cams[c];
        pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, w, h);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                pgi__v3 d = pgi__camera_dir(&cam, x, y);
                rs.r[rs.n++] = (pgi__tri_bvh_ray){{cam.eye[0], cam.eye[1], cam.eye[2]}, 0.f, {d.x, d.y, d.z}, INFINITY};
            }
    }
    return rs;
}

static ray_set random_rays(const pgi_scene *s, size_t n) {
    ray_set rs = {"random", malloc(n * sizeof(pgi__tri_bvh_ray)), n, 0};
    uint64_t g = 12345;
    for (size_t i = 0; i < n; i++) {
        float o[3];
        for (int k = 0; k < 3; k++) o[k] = s->bmin[k] + (0.01f + 0.98f * unif(&g)) * (s->bmax[k] - s->bmin[k]);
        float z = 2.f * unif(&g) - 1.f, phi = 6.2831853f * unif(&g), r = sqrtf(fmaxf(0.f, 1.f - z * z));
        rs.r[i] = (pgi__tri_bvh_ray){{o[0], o[1], o[2]}, 0.f, {r * cosf(phi), r * sinf(phi), z}, INFINITY};
    }
    return rs;
}

/* Shadow rays: from the closest hits of the random rays (their origins where they miss) to
 * uniform points in the scene's box, over (epsilon, 0.9999 length). */
static ray_set shadow_rays(const pgi_scene *s, const pgi__rt *rt, const ray_set *from) {
    ray_set rs = {"shadow", malloc(from->n * sizeof(pgi__tri_bvh_ray)), from->n, 1};
    uint64_t g = 777;
    const float eps = pgi__scene_epsilon(s);
    for (size_t i = 0; i < from->n; i++) {
        const pgi__tri_bvh_ray *r = &from->r[i];
        pgi__hit h;
        float p[3] = {r->org[0], r->org[1], r->org[2]}, d[3];
        if (pgi__rt_intersect(rt, v3(p[0], p[1], p[2]), v3(r->dir[0], r->dir[1], r->dir[2]), 0.f, INFINITY, &h))
            for (int k = 0; k < 3; k++) p[k] += h.t * r->dir[k];
        for (int k = 0; k < 3; k++) d[k] = s->bmin[k] + (0.01f + 0.98f * unif(&g)) * (s->bmax[k] - s->bmin[k]) - p[k];
        float len = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        rs.r[i] = (pgi__tri_bvh_ray){{p[0], p[1], p[2]}, eps, {d[0] / len, d[1] / len, d[2] / len}, 0.9999f * len};
    }
    return rs;
}

/* Mrays/s of Embree's single-ray queries over the set, best of 3. */
static double embree_rate(const pgi__rt *rt, const ray_set *rs, int threads, size_t *hits) {
    double best = 0.0;
    for (int rep = 0; rep < 3; rep++) {
        size_t nh = 0;
        double t0 = pgi__now_ms();
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1024) reduction(+ : nh)
        for (size_t i = 0; i < rs->n; i++) {
            const pgi__tri_bvh_ray *r = &rs->r[i];
            pgi__hit h;
            nh += (size_t)pgi__rt_intersect(rt, v3(r->org[0], r->org[1], r->org[2]),
                                            v3(r->dir[0], r->dir[1], r->dir[2]), r->tnear, r->tfar, &h);
        }
        double ms = pgi__now_ms() - t0;
        best = fmax(best, (double)rs->n / (ms * 1e3));
        *hits = nh;
    }
    return best;
}

/* Mrays/s of the layout's CPU traversal, best of 3; the work counters of one pass. */
static double bvh_rate(const pgi__bvh *b, const ray_set *rs, int threads, pgi__tri_bvh_counters *work) {
    double best = 0.0;
    for (int rep = 0; rep < 3; rep++) {
        uint64_t nn = 0, nl = 0, nt = 0;
        double t0 = pgi__now_ms();
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1024) reduction(+ : nn, nl, nt)
        for (size_t i = 0; i < rs->n; i++) {
            const pgi__tri_bvh_ray *r = &rs->r[i];
            pgi__hit h;
            pgi__tri_bvh_counters c = {0};
            if (rs->any) pgi__tri_bvh_occluded(b, r->org, r->dir, r->tnear, r->tfar, NULL, NULL, &c);
            else pgi__tri_bvh_intersect(b, r->org, r->dir, r->tnear, r->tfar, &h, NULL, NULL, &c);
            nn += c.nodes;
            nl += c.leaves;
            nt += c.tris;
        }
        double ms = pgi__now_ms() - t0;
        best = fmax(best, (double)rs->n / (ms * 1e3));
        *work = (pgi__tri_bvh_counters){nn, nl, nt};
    }
    return best;
}

/* Mrays/s of the GPU kernel over the set, best of 3: the kernel alone (the sequence's "rays"
 * timestamp) in *kernel, with the upload and download as the return value; *hits its hits. */
static double gpu_rate(pgi__gpu *g, pgi__gpu_rays *gr, const ray_set *rs, double *kernel, size_t *hits) {
    pgi__hit *h = malloc(rs->n * sizeof *h);
    double best = 0.0, best_k = 0.0;
    for (int rep = 0; h && rep < 4; rep++) {
        double t0 = pgi__now_ms();
        if (pgi__gpu_rays_intersect(gr, rs->r, rs->n, rs->any, h) != PGI_OK) {
            fprintf(stderr, "%s\n", pgi_last_error());
            break;
        }
        double ms = pgi__now_ms() - t0;
        pgi_named_value tv[8];
        int nt = pgi__gpu_timings(g, tv, 8);
        double kms = 0.0;
        for (int i = 0; i < nt; i++)
            if (!strcmp(tv[i].name, "rays")) kms = tv[i].value;
        if (rep == 0) continue; /* warm-up (buffers allocated, pipeline compiled) */
        best = fmax(best, (double)rs->n / (ms * 1e3));
        if (kms > 0) best_k = fmax(best_k, (double)rs->n / (kms * 1e3));
        size_t nh = 0;
        for (size_t i = 0; i < rs->n; i++) nh += h[i].prim != UINT32_MAX;
        *hits = nh;
    }
    free(h);
    *kernel = best_k;
    return best;
}

int main(int argc, char **argv) {
    const char *scene = "sibenik";
    size_t nrays = 200000;
    int w = 640, h = 360, threads = 2, configs = 0, device = -1;
    pgi__tri_bvh_config first = pgi__tri_bvh_default_config();
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--scene") && i + 1 < argc) scene = argv[++i];
        else if (!strcmp(argv[i], "--rays") && i + 1 < argc) nrays = (size_t)strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--size") && i + 1 < argc && sscanf(argv[++i], "%dx%d", &w, &h) == 2) {
        } else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--configs")) configs = 1;
        else if (!strcmp(argv[i], "--device") && i + 1 < argc) device = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--config") && i + 1 < argc &&
                 sscanf(argv[++i], "%d,%d,%d", &first.quality, &first.width, &first.max_leaf) == 3) {
        } else {
            fprintf(stderr,
                    "usage: %s [--scene NAME] [--rays N] [--size WxH] [--threads N] [--configs] [--config Q,W,L] "
                    "[--device N]\n"
                    "  the GPU BVH and ray kernel on one scene: build statistics, work a ray, rates against Embree\n",
                    argv[0]);
            return 2;
        }
    }
    if (w < 1 || h < 1 || threads < 1 || nrays < 1) {
        fprintf(stderr, "bad --size, --threads or --rays\n");
        return 2;
    }
    pgi_scene *s = NULL;
    if (pgi_scene_load(scene, &s) != PGI_OK) {
        fprintf(stderr, "%s\n", pgi_last_error());
        return 1;
    }
    pgi__rt *rt = NULL;
    double t0 = pgi__now_ms();
    if (pgi__rt_create(s, &rt) != PGI_OK) {
        fprintf(stderr, "%s\n", pgi_last_error());
        pgi_scene_destroy(s);
        return 1;
    }
    double embree_ms = pgi__now_ms() - t0;
    size_t embree_peak = 0, embree_bytes = pgi__rt_memory(rt, &embree_peak);
    ray_set sets[3] = {primary_rays(s, w, h), random_rays(s, nrays), {0}};
    sets[2] = shadow_rays(s, rt, &sets[1]);
    printf("scene %s: %zu triangles; Embree scene build %.1f ms, %zu bytes (peak %zu); %zu primary rays (%dx%d x %zu "
           "cameras), %zu random rays, %d threads\n\n",
           scene, s->ntris, embree_ms, embree_bytes, embree_peak, sets[0].n, w, h, s->ncams, sets[1].n, threads);
    pgi__gpu *g = NULL;
    pgi__gpu_rays *gr = NULL;
    char gname[160] = "no Vulkan device";
    if (pgi__gpu_create(device, &g) == PGI_OK) {
        snprintf(gname, sizeof gname, "%s", pgi__gpu_device_name(g));
        if (pgi__gpu_rays_create(g, s, &gr) != PGI_OK) snprintf(gname, sizeof gname, "%s", pgi_last_error());
    } else snprintf(gname, sizeof gname, "%s", pgi_last_error());
    pgi__tri_bvh_config list[16];
    int ncfg = 0;
    list[ncfg++] = first;
    if (configs) {
        const int q[] = {1, 2}, wd[] = {4, 2}, leaf[] = {1, 2, 4, 8, 16};
        for (int a = 0; a < 2; a++)
            for (int b = 0; b < 2; b++)
                for (int c = 0; c < 5; c++) {
                    if (wd[b] == 2 && leaf[c] != 4) continue;
                    pgi__tri_bvh_config cf = {q[a], wd[b], leaf[c], 1.f, 1.f};
                    if (!memcmp(&cf, &list[0], sizeof cf)) continue;
                    if (ncfg < 16) list[ncfg++] = cf;
                }
    }
    printf(
        "| quality | width | max leaf | build ms | bytes | inner | leaves | tri refs | depth | stack | SAH | "
        "primary: nodes / leaves / tris a ray | Mrays/s | random: nodes / leaves / tris a ray | Mrays/s | GPU kernel "
        "primary / random Mrays/s |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (int k = 0; k < ncfg; k++) {
        pgi__bvh *b = NULL;
        if (pgi__tri_bvh_build(s, &list[k], &b) != PGI_OK) {
            fprintf(stderr, "%s\n", pgi_last_error());
            continue;
        }
        const pgi__tri_bvh_stats *S = &b->stats;
        printf("| %s | %d | %d | %.1f | %zu | %zu | %zu | %zu | %d | %d | %.1f |",
               list[k].quality == 2 ? "SAH+splits" : "binned SAH", list[k].width, list[k].max_leaf, S->build_ms,
               S->bytes, S->inner, S->leaves, S->tri_refs, S->max_depth, S->stack_need, S->sah_cost);
        for (int r = 0; r < 2; r++) {
            pgi__tri_bvh_counters c;
            double rate = bvh_rate(b, &sets[r], threads, &c);
            double n = (double)sets[r].n;
            printf(" %.1f / %.1f / %.1f | %.2f |", (double)c.nodes / n, (double)c.leaves / n, (double)c.tris / n, rate);
        }
        if (gr && pgi__gpu_rays_set_config(gr, s, &list[k]) == PGI_OK) {
            double kp = 0.0, kr = 0.0;
            size_t nh;
            gpu_rate(g, gr, &sets[0], &kp, &nh);
            gpu_rate(g, gr, &sets[1], &kr, &nh);
            printf(" %.2f / %.2f |", kp, kr);
        } else printf(" - |");
        printf("\n");
        fflush(stdout);
        pgi__tri_bvh_destroy(b);
    }
    if (gr && pgi__gpu_rays_set_config(gr, s, NULL) != PGI_OK) { /* the default build for the rates */
        fprintf(stderr, "%s\n", pgi_last_error());
        pgi__gpu_rays_destroy(gr);
        gr = NULL;
    }
    printf("\n| rays | n | Embree (%d threads) Mrays/s | GPU kernel Mrays/s | GPU with transfers Mrays/s | "
           "Embree hits | GPU hits |\n|---|---|---|---|---|---|---|\n",
           threads);
    for (int r = 0; r < 3; r++) {
        size_t hits = 0, ghits = 0;
        double rate = embree_rate(rt, &sets[r], threads, &hits), kern = 0.0;
        double grate = gr ? gpu_rate(g, gr, &sets[r], &kern, &ghits) : 0.0;
        printf("| %s | %zu | %.2f | %.2f | %.2f | %zu | %zu |\n", sets[r].name, sets[r].n, rate, kern, grate, hits,
               ghits);
    }
    printf("\nGPU: %s\n", gname);
    pgi__gpu_rays_destroy(gr);
    pgi__gpu_destroy(g);
    for (int r = 0; r < 3; r++) free(sets[r].r);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(s);
    return 0;
}
