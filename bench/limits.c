/* photongi-bench --limits: each ray pass of a frame next to the time Embree
 * alone takes for the same rays (docs/performance.md).
 *
 * Per scene: a warm-up frame, then one frame with ray capture on
 * (src/rt/ray_log.h): every ray each pass casts, with its call style, packet
 * and answer; the frames use one seed, so all cast these rays. The view
 * camera's primary rays are also cast in ideal layouts (4x2 tiles for 8-wide
 * packets, 8x2 and 4x4 tiles for 16-wide, 16x16 blocks for streams). Then a
 * warm-up round and N rounds, each one frame (the view, trace and direct pass
 * times) and one replay of every (pass, call) group in every style (as
 * captured, single rays, 8/16-wide packets with a coherent or incoherent
 * context, 1M streams of 256) and of every layout, with raw Embree calls over
 * the render's thread count, every answer checked against the captured one.
 * Medians over the rounds. Tables: per pass the pass time, the fastest raw
 * style (per group, summed over the pass's groups), their ratio and
 * throughputs; every style per group; the layouts. CSV: one row per pass, per
 * (group, style) and per layout. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "photongi/photongi.h"
#include "pipeline/pipeline.h"
#include "rt/ray_log.h"
#include "view/view.h"

#include "bench_common.h"
#include "limits.h"

#define MAXF 64

static const char *const k_pass_names[PGI__PASS_COUNT] = {"other", "view", "trace", "direct"};

typedef struct {
    pgi__pass pass;
    pgi__ray_kind kind;
    uint64_t rays;
    double ms[PGI__REPLAY_METHOD_COUNT]; /* median; < 0: not run */
    double min[PGI__REPLAY_METHOD_COUNT];
    uint64_t mism[PGI__REPLAY_METHOD_COUNT];
    int best;
} group_result;

/* A method's short name; "cast" becomes the captured call's width ("1", "8", "16", "1M"). */
static const char *style(pgi__ray_kind kind, int m) {
    if (m != PGI__REPLAY_CAST) return pgi__replay_method_name((pgi__replay_method)m);
    switch (kind) {
    case PGI__RAY_INTERSECT8:
    case PGI__RAY_OCCLUDED8: return "8";
    case PGI__RAY_INTERSECT16:
    case PGI__RAY_OCCLUDED16: return "16";
    case PGI__RAY_INTERSECT1M:
    case PGI__RAY_OCCLUDED1M: return "1M";
    default: return "1";
    }
}

/* Methods worth timing for a group: all that run here, less the one equal to "cast" (single rays). */
static int method_applies(const pgi__rt *rt, pgi__ray_kind kind, pgi__replay_method m) {
    if (!pgi__rt_replay_supported(rt, m)) return 0;
    if (m == PGI__REPLAY_1 && (kind == PGI__RAY_INTERSECT1 || kind == PGI__RAY_OCCLUDED1)) return 0;
    return 1;
}

/* The view camera's primary rays cast in an ideal layout, captured into `log`
 * (pass tag VIEW): tiles of tw x th pixels as 8-wide packets (lanes row-major
 * in the tile; 4x2 or 8x1), tiles ordered so that consecutive packets form
 * bigger tiles: two packets stack into 8x2 (8x1) or 4x4 (4x2), and 4x4 tiles
 * go row-major through 16x16 blocks. */
static void cast_layout(pgi__rt *rt, pgi__ray_log *log, const pgi_camera *cam, int tw, int rows) {
    const int W = cam->width, H = cam->height, th = 8 / tw;
    const pgi__v3 eye = v3_load(cam->eye);
    pgi__rt_capture_set(rt, log);
    pgi__ray_log_set_pass(log, PGI__PASS_VIEW);
    /* block (16x16, or one row pair of 8-wide tiles for 8x1) -> pair of packets stacked vertically */
    /* rows: plain 8x1 rows, left to right, top to bottom (one "block" a row) */
    const int bw = rows ? W : tw == 4 ? 16 : 8, bh = rows ? 1 : tw == 4 ? 16 : 2;
    for (int by = 0; by < H; by += bh)
        for (int bx = 0; bx < W; bx += bw)
            for (int ty = by; ty < by + bh; ty += rows ? 1 : 2 * th)
                for (int tx = bx; tx < bx + bw; tx += tw)
                    for (int half = 0; half < (rows ? 1 : 2); half++) {
                        int valid[8];
                        pgi__v3 dirs[8];
                        pgi__hit hits[8];
                        for (int k = 0; k < 8; k++) {
                            int x = tx + k % tw, y = ty + half * th + k / tw;
                            valid[k] = x < W && y < H;
                            dirs[k] = pgi__camera_dir(cam, valid[k] ? x : 0, valid[k] ? y : 0);
                        }
                        pgi__rt_intersect8(rt, valid, eye, dirs, INFINITY, hits);
                    }
    pgi__rt_capture_set(rt, NULL);
}

typedef struct {
    const char *layout, *label;
    int log; /* 0: 8x1 rows, 1: 4x2 tiles, 2: 8x1 in 8x2 pairs */
    pgi__replay_method m;
} ideal_case;

static int run_scene(const char *sc, const pgi_render_desc *d, int frames, FILE *csv) {
    pgi_scene *scene;
    pgi_renderer *r;
    if (!open_scene(sc, &scene, &r)) return 0;
    pgi__rt *rt = pgi__renderer_rt(r);
    pgi__ray_log *log = NULL, *tiles = NULL, *pairs = NULL, *rowlog = NULL;
    pgi_image img = {0};
    pgi_frame_stats fs;
    int ok = 0;
    double pt[PGI__PASS_COUNT][MAXF], pass_ms[PGI__PASS_COUNT] = {0};
    uint64_t pass_rays[PGI__PASS_COUNT] = {0};

    /* Capture one frame after a warm-up (the same seed, so the same rays as the timed frames). */
    if (pgi_renderer_render(r, d, &img, &fs) != PGI_OK) goto fail;
    if (pgi__ray_log_create(&log) || pgi__ray_log_create(&tiles) || pgi__ray_log_create(&pairs) ||
        pgi__ray_log_create(&rowlog))
        goto fail;
    pgi__rt_capture_set(rt, log);
    pgi_status st = pgi_renderer_render(r, d, &img, &fs);
    pgi__rt_capture_set(rt, NULL);
    if (st || pgi__ray_log_merge(log)) goto fail;
    if (pgi__ray_log_dropped(log))
        fprintf(stderr, "photongi-bench: %s: %llu rays dropped while capturing\n", sc,
                (unsigned long long)pgi__ray_log_dropped(log));
    const uint64_t counted[PGI__PASS_COUNT] = {0, fs.primary_rays, fs.photon_rays, fs.shadow_rays};
    const int threads = fs.threads;

    /* Ideal primary-ray layouts over the view camera. */
    pgi_frame_inputs in;
    if (pgi_renderer_prepare(r, d, &in, NULL)) goto fail;
    cast_layout(rt, tiles, &in.camera, 4, 0);
    cast_layout(rt, pairs, &in.camera, 8, 0);
    cast_layout(rt, rowlog, &in.camera, 8, 1);
    if (pgi__ray_log_merge(tiles) || pgi__ray_log_merge(pairs) || pgi__ray_log_merge(rowlog)) goto fail;
    const ideal_case ideal[] = {
        {"8x1 rows", "rtcIntersect8 coherent", 0, PGI__REPLAY_CAST},
        {"4x2 tiles", "rtcIntersect8 coherent", 1, PGI__REPLAY_CAST},
        {"16x1 rows", "rtcIntersect16 coherent", 0, PGI__REPLAY_16},
        {"8x2 tiles", "rtcIntersect16 coherent", 2, PGI__REPLAY_16},
        {"4x4 tiles", "rtcIntersect16 coherent", 1, PGI__REPLAY_16},
        {"singles in rows", "rtcIntersect1", 0, PGI__REPLAY_1},
        {"singles in 4x4 tiles", "rtcIntersect1", 1, PGI__REPLAY_1},
        {"256x1 rows", "rtcIntersect1M coherent", 0, PGI__REPLAY_1MC},
        {"16x16 blocks", "rtcIntersect1M coherent", 1, PGI__REPLAY_1MC},
        {"16x16 blocks", "rtcIntersect1M incoherent", 1, PGI__REPLAY_1M},
    };
    enum { NIDEAL = sizeof ideal / sizeof ideal[0] };
    const pgi__ray_log *ideal_log[3] = {rowlog, tiles, pairs};
    const uint64_t ideal_rays = pgi__ray_log_rays(tiles, PGI__PASS_VIEW, PGI__RAY_INTERSECT8);

    /* Replay items: every (group, method), then the ideal layouts. */
    group_result gr[PGI__PASS_COUNT * PGI__RAY_KIND_COUNT];
    int ng = 0;
    for (int p = PGI__PASS_VIEW; p < PGI__PASS_COUNT; p++)
        for (int k = 0; k < PGI__RAY_KIND_COUNT; k++) {
            uint64_t n = pgi__ray_log_rays(log, (pgi__pass)p, (pgi__ray_kind)k);
            if (!n) continue;
            pass_rays[p] += n;
            gr[ng++] = (group_result){.pass = (pgi__pass)p, .kind = (pgi__ray_kind)k, .rays = n, .best = -1};
        }
    for (int p = PGI__PASS_VIEW; p < PGI__PASS_COUNT; p++)
        if (pass_rays[p] != counted[p])
            fprintf(stderr, "photongi-bench: %s: %s pass counted %llu rays, captured %llu\n", sc, k_pass_names[p],
                    (unsigned long long)counted[p], (unsigned long long)pass_rays[p]);
    static double gt[PGI__PASS_COUNT * PGI__RAY_KIND_COUNT][PGI__REPLAY_METHOD_COUNT][MAXF];
    double it[NIDEAL][MAXF], ideal_ms[NIDEAL];
    uint64_t ideal_mism[NIDEAL] = {0};

    /* Rounds: one frame (pass times), then one replay of every item; round -1 warms up. Interleaving
     * spreads any load from elsewhere on the machine over both sides. */
    for (int f = -1; f < frames; f++) {
        if (pgi_renderer_render(r, d, &img, &fs) != PGI_OK) goto fail;
        if (f >= 0) {
            pt[PGI__PASS_VIEW][f] = fs.view_ms;
            pt[PGI__PASS_TRACE][f] = fs.trace_ms;
            pt[PGI__PASS_DIRECT][f] = fs.direct_ms;
        }
        pgi__replay_result rr;
        for (int i = 0; i < ng; i++)
            for (int m = 0; m < PGI__REPLAY_METHOD_COUNT; m++) {
                if (!method_applies(rt, gr[i].kind, (pgi__replay_method)m)) continue;
                if (pgi__rt_replay(rt, log, gr[i].pass, gr[i].kind, (pgi__replay_method)m, threads, &rr)) goto fail;
                if (rr.mismatches > gr[i].mism[m]) gr[i].mism[m] = rr.mismatches;
                if (f >= 0) gt[i][m][f] = rr.ms;
            }
        for (int i = 0; i < NIDEAL; i++) {
            if (!pgi__rt_replay_supported(rt, ideal[i].m)) continue;
            if (pgi__rt_replay(rt, ideal_log[ideal[i].log], PGI__PASS_VIEW, PGI__RAY_INTERSECT8, ideal[i].m, threads,
                               &rr))
                goto fail;
            if (rr.mismatches > ideal_mism[i]) ideal_mism[i] = rr.mismatches;
            if (f >= 0) it[i][f] = rr.ms;
        }
    }
    /* median() sorts: [0] is then the fastest, which the CSV also gets (robust to load from elsewhere). */
    double pass_min[PGI__PASS_COUNT] = {0}, ideal_min[NIDEAL];
    for (int p = PGI__PASS_VIEW; p < PGI__PASS_COUNT; p++) pass_ms[p] = median(pt[p], frames), pass_min[p] = pt[p][0];
    for (int i = 0; i < ng; i++)
        for (int m = 0; m < PGI__REPLAY_METHOD_COUNT; m++) {
            gr[i].ms[m] = method_applies(rt, gr[i].kind, (pgi__replay_method)m) ? median(gt[i][m], frames) : -1.0;
            gr[i].min[m] = gt[i][m][0];
            if (gr[i].ms[m] >= 0.0 && (gr[i].best < 0 || gr[i].ms[m] < gr[i].ms[gr[i].best])) gr[i].best = m;
        }
    for (int i = 0; i < NIDEAL; i++)
        ideal_ms[i] = pgi__rt_replay_supported(rt, ideal[i].m) ? median(it[i], frames) : -1.0, ideal_min[i] = it[i][0];

    /* Tables. */
    printf("\n%s %dx%d, %llu photons stored, %s, %d threads: medians of %d frames / replays after a warm-up\n", sc,
           fs.width, fs.height, (unsigned long long)fs.photons_stored, fs.estimator, threads, frames);
    printf("%-7s %9s %9s %9s %-12s %6s %13s %12s\n", "pass", "rays", "pass ms", "raw ms", "raw method", "ratio",
           "pass Mrays/s", "raw Mrays/s");
    for (int p = PGI__PASS_VIEW; p < PGI__PASS_COUNT; p++) {
        double raw = 0.0, raw_min = 0.0;
        char methods[64] = "";
        for (int i = 0; i < ng; i++) {
            if (gr[i].pass != (pgi__pass)p) continue;
            raw += gr[i].ms[gr[i].best];
            raw_min += gr[i].min[gr[i].best];
            const char *name = style(gr[i].kind, gr[i].best);
            size_t len = strlen(methods);
            snprintf(methods + len, sizeof methods - len, "%s%s", len ? "+" : "", name);
        }
        double ratio = raw > 0.0 ? pass_ms[p] / raw : 0.0;
        double pm = pass_ms[p] > 0.0 ? (double)pass_rays[p] / (pass_ms[p] * 1e3) : 0.0;
        double rm = raw > 0.0 ? (double)pass_rays[p] / (raw * 1e3) : 0.0;
        printf("%-7s %9llu %9.1f %9.1f %-12s %6.2f %13.2f %12.2f\n", k_pass_names[p], (unsigned long long)pass_rays[p],
               pass_ms[p], raw, methods, ratio, pm, rm);
        fprintf(csv, "%s,%d,%d,%d,%llu,%s,%d,pass,%s,all,%s,,%llu,%.3f,%.3f,%.4f,%.3f,%.3f,1,,%.3f,%.3f\n", sc,
                fs.width, fs.height, threads, (unsigned long long)fs.photons_stored, fs.estimator, frames,
                k_pass_names[p], methods, (unsigned long long)pass_rays[p], pass_ms[p], raw, ratio, pm, rm, pass_min[p],
                raw_min);
    }

    printf("\nraw Embree per ray group, ms (* fastest; cast = the calls the pass made)\n%-17s %9s", "group", "rays");
    for (int m = 0; m < PGI__REPLAY_METHOD_COUNT; m++) printf(" %7s", pgi__replay_method_name((pgi__replay_method)m));
    printf("  %s\n", "mismatch cast/other");
    for (int i = 0; i < ng; i++) {
        const group_result *g = &gr[i];
        char name[48];
        snprintf(name, sizeof name, "%s/%s", k_pass_names[g->pass], pgi__ray_kind_name(g->kind));
        printf("%-17s %9llu", name, (unsigned long long)g->rays);
        uint64_t worst = 0;
        for (int m = 0; m < PGI__REPLAY_METHOD_COUNT; m++) {
            if (g->ms[m] < 0.0) {
                printf(" %7s", "-");
                continue;
            }
            printf(" %6.1f%c", g->ms[m], m == g->best ? '*' : ' ');
            if (m != PGI__REPLAY_CAST && g->mism[m] > worst) worst = g->mism[m];
            int occl = pgi__ray_kind_occluded(g->kind);
            const char *call = m == PGI__REPLAY_CAST ? pgi__ray_kind_name(g->kind)
                                                     : pgi__replay_method_call((pgi__replay_method)m, occl);
            double pm = pass_ms[g->pass] > 0.0 ? (double)pass_rays[g->pass] / (pass_ms[g->pass] * 1e3) : 0.0;
            fprintf(csv, "%s,%d,%d,%d,%llu,%s,%d,method,%s,%s,%s,%s,%llu,%.3f,%.3f,%.4f,%.3f,%.3f,%d,%llu,%.3f,%.3f\n",
                    sc, fs.width, fs.height, threads, (unsigned long long)fs.photons_stored, fs.estimator, frames,
                    k_pass_names[g->pass], pgi__ray_kind_name(g->kind), pgi__replay_method_name((pgi__replay_method)m),
                    call, (unsigned long long)g->rays, pass_ms[g->pass], g->ms[m],
                    g->ms[m] > 0.0 ? pass_ms[g->pass] / g->ms[m] : 0.0, pm,
                    g->ms[m] > 0.0 ? (double)g->rays / (g->ms[m] * 1e3) : 0.0, m == g->best,
                    (unsigned long long)g->mism[m], pass_min[g->pass], g->min[m]);
        }
        printf("  %llu/%llu\n", (unsigned long long)g->mism[PGI__REPLAY_CAST], (unsigned long long)worst);
    }

    printf("\nprimary rays of the view camera in ideal layouts (%llu rays)\n%-20s %-26s %8s %9s %9s\n",
           (unsigned long long)ideal_rays, "layout", "call", "ms", "Mrays/s", "mismatch");
    for (int i = 0; i < NIDEAL; i++) {
        if (ideal_ms[i] < 0.0) {
            printf("%-20s %-26s %8s\n", ideal[i].layout, ideal[i].label, "n/a");
            continue;
        }
        double mr = (double)ideal_rays / (ideal_ms[i] * 1e3);
        printf("%-20s %-26s %8.1f %9.2f %9llu\n", ideal[i].layout, ideal[i].label, ideal_ms[i], mr,
               (unsigned long long)ideal_mism[i]);
        fprintf(csv, "%s,%d,%d,%d,%llu,%s,%d,ideal,view,%s,%s,%s,%llu,,%.3f,,,%.3f,,%llu,,%.3f\n", sc, fs.width,
                fs.height, threads, (unsigned long long)fs.photons_stored, fs.estimator, frames, ideal[i].layout,
                pgi__replay_method_name(ideal[i].m), ideal[i].label, (unsigned long long)ideal_rays, ideal_ms[i], mr,
                (unsigned long long)ideal_mism[i], ideal_min[i]);
    }
    fflush(stdout);
    ok = 1;
fail:
    if (!ok) fprintf(stderr, "photongi-bench: %s: %s\n", sc, pgi_last_error());
    pgi__rt_capture_set(rt, NULL);
    pgi__ray_log_destroy(log);
    pgi__ray_log_destroy(tiles);
    pgi__ray_log_destroy(pairs);
    pgi__ray_log_destroy(rowlog);
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
    return ok;
}

/* Fraction of the machine's CPU time that was not idle over 300 ms (Linux /proc/stat; 0 elsewhere). */
static double cpu_busy(void) {
    unsigned long long a[2][8] = {{0}};
    for (int k = 0; k < 2; k++) {
        FILE *f = fopen("/proc/stat", "r");
        if (!f) return 0.0;
        int n = fscanf(f, "cpu %llu %llu %llu %llu %llu %llu %llu %llu", &a[k][0], &a[k][1], &a[k][2], &a[k][3],
                       &a[k][4], &a[k][5], &a[k][6], &a[k][7]);
        fclose(f);
        if (n != 8) return 0.0;
        if (k == 0) nanosleep(&(struct timespec){0, 300000000}, NULL);
    }
    unsigned long long total = 0, idle = (a[1][3] - a[0][3]) + (a[1][4] - a[0][4]);
    for (int i = 0; i < 8; i++) total += a[1][i] - a[0][i];
    return total ? 1.0 - (double)idle / (double)total : 0.0;
}

int pgi_bench_limits(const char *scenes, const char *estimator, int frames, unsigned photons, int width, int height,
                     float radius, int threads, const char *csv_path) {
    if (frames > MAXF) frames = MAXF;
    FILE *csv = open_csv(csv_path);
    if (!csv) return 1;
    fprintf(csv, "scene,width,height,threads,photons,estimator,frames,section,pass,group,method,call,rays,pass_ms,"
                 "raw_ms,ratio,pass_mrays_s,raw_mrays_s,best,mismatches,pass_min_ms,raw_min_ms\n");
    pgi_render_desc d = {.estimator = estimator,
                         .photons = photons,
                         .width = width,
                         .height = height,
                         .threads = threads,
                         .seed = 1,
                         .radius = radius};
    /* Other processes on the cores make every parallel region wait for a time slice (times in multiples
     * of a few ms): say so. */
    double busy = cpu_busy();
    if (busy > 0.2)
        fprintf(stderr,
                "photongi-bench: the CPUs were %.0f%% busy before starting: other processes will distort the "
                "times\n",
                100.0 * busy);
    char buf[4096];
    snprintf(buf, sizeof buf, "%s", scenes);
    int failed = 0;
    for (char *sc = strtok(buf, ","); sc; sc = strtok(NULL, ",")) failed |= !run_scene(sc, &d, frames, csv);
    fclose(csv);
    printf("\n(pass ms: the renderer's pass; raw ms: the same rays with raw Embree calls, fastest style per group, "
           "summed; ratio = pass / raw; mismatch: answers that differ from the pass's (other styles: other kernels "
           "may split ties on shared edges); CSV: %s)\n",
           csv_path);
    return failed;
}
