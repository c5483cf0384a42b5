/* photongi-bench-cluster: estimator-only benchmark for the cluster family
 * (Moreau et al. 2016): per-pass milliseconds and bytes per structure (the
 * paper's Table 1), photon reads vs contributing (its Fig. 7), and the
 * speed ratios tiled / cluster-trivial and cluster-trivial / directional,
 * all from one run.
 *
 * View samples and photons are made once per (scene, case) with the library's
 * own view pass and photon tracer; then every estimator runs build + estimate
 * on the same inputs: one warm-up, then the median of N frames per pass.
 *
 *   photongi-bench-cluster [--scenes sibenik,crytek-sponza] [--size 1920x1080]
 *       [--cases 10000:3,50000:1.7,200000:1,1000000:0.6] [--frames 3] [--threads T]
 *       [--estimators tiled,cluster,cluster-cone,cluster-trivial,directional] [--csv FILE]
 *
 * A case is PHOTONS:SCALE; the radius is SCALE x the scene's default radius (a scene without
 * one, sibenik now: 0.2, the radius it shipped with when these cases were chosen), or
 * PHOTONS:=R for an absolute radius. */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "photongi/photongi.h"

#include "bench_common.h"

#define MAXF 32
#define MAXE 16

typedef struct {
    const char *name;
    double total; /* median build + estimate, ms */
} result;

int main(int argc, char **argv) {
    const char *scenes = "sibenik,crytek-sponza", *ests = "tiled,cluster,cluster-cone,cluster-trivial,directional";
    const char *cases = "10000:3,50000:1.7,200000:1,1000000:0.6", *csv_path = NULL;
    int width = 1920, height = 1080, frames = 3, threads = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            printf("usage: photongi-bench-cluster [--scenes a,b] [--size WxH] [--cases N:SCALE,N:=R,...]\n"
                   "                              [--frames N] [--threads T] [--estimators a,b] [--csv FILE]\n"
                   "Estimator passes only (view samples and photons made once per case): median ms per pass,\n"
                   "bytes per structure, reads vs contributing, and the ratios tiled/cluster-trivial and\n"
                   "cluster-trivial/directional (build + estimate) from the same run.\n");
            return 0;
        }
        if (!v) {
            fprintf(stderr, "photongi-bench-cluster: %s needs a value\n", a);
            return 2;
        }
        i++;
        if (strcmp(a, "--scenes") == 0) scenes = v;
        else if (strcmp(a, "--estimators") == 0) ests = v;
        else if (strcmp(a, "--cases") == 0) cases = v;
        else if (strcmp(a, "--frames") == 0) frames = atoi(v);
        else if (strcmp(a, "--threads") == 0) threads = atoi(v);
        else if (strcmp(a, "--csv") == 0) csv_path = v;
        else if (strcmp(a, "--size") == 0) {
            if (sscanf(v, "%dx%d", &width, &height) != 2 || width < 1 || height < 1) {
                fprintf(stderr, "photongi-bench-cluster: --size needs WxH\n");
                return 2;
            }
        } else {
            fprintf(stderr, "photongi-bench-cluster: unknown option %s\n", a);
            return 2;
        }
    }
    if (frames < 1 || frames > MAXF) {
        fprintf(stderr, "photongi-bench-cluster: --frames must be 1..%d\n", MAXF);
        return 2;
    }
    FILE *csv = csv_path ? fopen(csv_path, "w") : NULL;
    if (csv_path && !csv) {
        fprintf(stderr, "photongi-bench-cluster: cannot write %s\n", csv_path);
        return 1;
    }
    if (csv)
        fprintf(csv, "scene,width,height,threads,photons,radius,estimator,build_ms,estimate_ms,total_ms,reads,"
                     "contributing,nodes_visited,passes,memory\n");
    printf("threads %d, %dx%d, medians of %d frames after a warm-up (ms)\n",
           threads > 0 ? threads : omp_get_max_threads(), width, height, frames);
    float *out = malloc(3 * (size_t)width * (size_t)height * sizeof *out);
    if (!out) {
        fprintf(stderr, "photongi-bench-cluster: out of memory\n");
        return 1;
    }
    char sbuf[1024];
    snprintf(sbuf, sizeof sbuf, "%s", scenes);
    char *ssave = NULL;
    for (char *sc = strtok_r(sbuf, ",", &ssave); sc; sc = strtok_r(NULL, ",", &ssave)) {
        pgi_scene *scene;
        if (pgi_scene_load(sc, &scene) != PGI_OK) {
            fprintf(stderr, "photongi-bench-cluster: skipping %s: %s\n", sc, pgi_last_error());
            continue;
        }
        pgi_renderer *r = NULL;
        if (pgi_renderer_create(scene, &r) != PGI_OK) {
            fprintf(stderr, "photongi-bench-cluster: %s: %s\n", sc, pgi_last_error());
            pgi_scene_destroy(scene);
            continue;
        }
        pgi_scene_info info;
        pgi_scene_get_info(scene, &info);
        /* no radius in the description (the automatic one): the cases keep their old base */
        float r0 = info.defaults.radius > 0.f ? info.defaults.radius : 0.2f;
        char cbuf[1024];
        snprintf(cbuf, sizeof cbuf, "%s", cases);
        char *csave = NULL;
        for (char *cs = strtok_r(cbuf, ",", &csave); cs; cs = strtok_r(NULL, ",", &csave)) {
            unsigned long np = strtoul(cs, NULL, 10);
            const char *colon = strchr(cs, ':');
            float radius = r0;
            if (colon) radius = colon[1] == '=' ? strtof(colon + 2, NULL) : r0 * strtof(colon + 1, NULL);
            if (np < 1 || !(radius > 0.f)) {
                fprintf(stderr, "photongi-bench-cluster: bad case '%s'\n", cs);
                return 2;
            }
            /* View samples and photons once per case, as a frame makes them. */
            pgi_frame_inputs in;
            pgi_render_desc rd = {.photons = (uint32_t)np,
                                  .radius = radius,
                                  .width = width,
                                  .height = height,
                                  .bounces = 4,
                                  .seed = 1,
                                  .threads = threads};
            if (pgi_renderer_prepare(r, &rd, &in, NULL) != PGI_OK) {
                fprintf(stderr, "photongi-bench-cluster: %s: view samples / photons failed: %s\n", sc,
                        pgi_last_error());
                return 1;
            }
            const pgi_photons ph = *in.photons;
            printf("\n== %s  %zu photons  r = %g\n", sc, ph.count, (double)radius);
            printf("%-16s %9s %9s %9s | %12s %12s %7s | passes (ms) | memory (MiB)\n", "estimator", "build", "estimate",
                   "total", "reads", "contrib", "reject");
            result res[MAXE];
            int nres = 0;
            char ebuf[512];
            snprintf(ebuf, sizeof ebuf, "%s", ests);
            char *esave = NULL;
            for (char *en = strtok_r(ebuf, ",", &esave); en && nres < MAXE; en = strtok_r(NULL, ",", &esave)) {
                pgi_estimator *e = NULL;
                if (pgi_estimator_create(en, &(pgi_estimator_desc){0}, &e) != PGI_OK) {
                    fprintf(stderr, "photongi-bench-cluster: %s: %s\n", en, pgi_last_error());
                    continue;
                }
                pgi_estimate_args a = {.photons = in.photons,
                                       .samples = in.samples,
                                       .camera = &in.camera,
                                       .out_rgb = out,
                                       .radius = radius,
                                       .seed = 1,
                                       .threads = threads,
                                       .scene_area = in.scene_area};
                double tb[MAXF], te[MAXF], tp[PGI_EST_MAX_ENTRIES][MAXF];
                pgi_estimator_stats st = {0};
                int ok = 1;
                for (int f = -1; f < frames && ok; f++) {
                    if (pgi_estimator_build(e, &a) != PGI_OK || pgi_estimator_estimate(e, &a) != PGI_OK) {
                        fprintf(stderr, "photongi-bench-cluster: %s: %s\n", en, pgi_last_error());
                        ok = 0;
                        break;
                    }
                    pgi_estimator_get_stats(e, &st);
                    if (f < 0) continue;
                    tb[f] = st.build_ms;
                    te[f] = st.estimate_ms;
                    for (int k = 0; k < st.pass_count; k++) tp[k][f] = st.pass_ms[k];
                }
                if (ok) {
                    double mb = median(tb, frames), me = median(te, frames);
                    double rej = st.reads ? 100.0 * (1.0 - (double)st.contributing / (double)st.reads) : 0.0;
                    char passes[512] = "", mem[512] = "";
                    size_t pl = 0, ml = 0;
                    for (int k = 0; k < st.pass_count; k++)
                        pl += (size_t)snprintf(passes + pl, sizeof passes - pl, "%s%s=%.1f", k ? " " : "",
                                               st.pass_names[k], median(tp[k], frames));
                    for (int k = 0; k < st.memory_count; k++)
                        ml += (size_t)snprintf(mem + ml, sizeof mem - ml, "%s%s=%.2f", k ? " " : "", st.memory_names[k],
                                               (double)st.memory_bytes[k] / 1048576.0);
                    printf("%-16s %9.1f %9.1f %9.1f | %12llu %12llu %6.1f%% | %s | %s\n", en, mb, me, mb + me,
                           (unsigned long long)st.reads, (unsigned long long)st.contributing, rej, passes, mem);
                    if (csv)
                        fprintf(csv, "%s,%d,%d,%d,%zu,%g,%s,%.3f,%.3f,%.3f,%llu,%llu,%llu,%s,%s\n", sc, width, height,
                                threads > 0 ? threads : omp_get_max_threads(), ph.count, (double)radius, en, mb, me,
                                mb + me, (unsigned long long)st.reads, (unsigned long long)st.contributing,
                                (unsigned long long)st.nodes_visited, passes, mem);
                    res[nres].name = pgi_estimator_name(e);
                    res[nres++].total = mb + me;
                }
                pgi_estimator_destroy(e);
                fflush(stdout);
            }
            double t_tiled = 0, t_triv = 0, t_dir = 0;
            for (int k = 0; k < nres; k++) {
                if (strcmp(res[k].name, "tiled") == 0) t_tiled = res[k].total;
                if (strcmp(res[k].name, "cluster-trivial") == 0) t_triv = res[k].total;
                if (strcmp(res[k].name, "directional") == 0) t_dir = res[k].total;
            }
            if (t_tiled > 0 && t_triv > 0) printf("ratio tiled / cluster-trivial       = %.2f\n", t_tiled / t_triv);
            if (t_triv > 0 && t_dir > 0) printf("ratio cluster-trivial / directional = %.2f\n", t_triv / t_dir);
        }
        pgi_renderer_destroy(r);
        pgi_scene_destroy(scene);
    }
    free(out);
    if (csv) fclose(csv);
    return 0;
}
