/* photongi reference: progressive path-traced reference image
 * (include/photongi/reference.h), EXR + sidecar JSON, optional PNG. */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "cmd.h"
#include "parse.h"
#include "photongi/metrics.h"
#include "photongi/reference.h"

static const char *k_reference_help =
    "usage: photongi reference [--scene S] [--spp N | --time SECONDS] [options] -o REF.exr\n"
    "       photongi reference --continue REF.exr [--spp N | --time SECONDS] [-o OUT.exr]\n"
    "\n"
    "Path-traces a reference with the photon pipeline's light transport: emission seen along\n"
    "the eye path, direct light at the first non-specular hit (next-event estimation, MIS for\n"
    "area lights) and indirect light of light paths with 1..B scattering events, Russian\n"
    "roulette. Each sample looks through its own uniform point of the pixel, so the image\n"
    "converges to the box-filtered pixel integral, as 'render --progressive' does (--jitter off:\n"
    "pixel centres, the point samples of one 'render' frame). Deterministic for a seed whatever\n"
    "the thread count. Writes linear EXR and REF.exr.json (scene, size, bounces, camera, seed,\n"
    "jitter, samples), so that --continue can add samples later.\n"
    "\n"
    "  --scene S          scene, as for 'render' (default cornell)\n"
    "  --spp N            samples per pixel to add (default 64; with --time: an upper bound)\n"
    "  --time SECONDS     stop after the pass that reaches this wall time\n"
    "  --bounces B        scattering events before the visible point, as 'render' (default:\n"
    "                     the scene's, else 4)\n"
    "  --size WxH         image size (default: the scene's, else 640x480)\n"
    "  --seed K           random seed (default 1)\n"
    "  --threads T        worker threads (default: all cores)\n"
    "  --camera I         camera index (default 0)\n"
    "  --jitter on|off    samples over the whole pixel (on, default) or through its centre\n"
    "  --continue REF.exr add samples to REF.exr (settings from REF.exr.json; -o defaults to it)\n"
    "  --png FILE         also write a tone-mapped PNG\n"
    "  --exposure X       exposure for --png (default: the scene's, else 1)\n"
    "  -o, --out FILE     output EXR (required unless --continue)\n"
    "  -q, --quiet        no progress bar or summary (the bar is shown only on a terminal)\n";

static int ref_usage(const char *fmt, const char *arg) {
    fprintf(stderr, "photongi reference: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\nTry 'photongi reference --help'.\n");
    return 2;
}

static int ref_fail(const char *what, pgi_status st) {
    const char *msg = pgi_last_error();
    fprintf(stderr, "photongi reference: %s: %s\n", what, *msg ? msg : pgi_status_string(st));
    return st == PGI_ERR_INVALID_ARG ? 2 : 1;
}

typedef struct {
    double time_limit_s; /* --time, 0 if none */
    double last_ms;      /* last redraw: at most 10 a second */
} progress_state;

static int progress_bar(void *user, uint64_t done, uint64_t total, double elapsed_ms) {
    progress_state *ps = user;
    if (done != total && elapsed_ms - ps->last_ms < 100.0) return 0;
    ps->last_ms = elapsed_ms;
    const int width = 30;
    double frac = total ? (double)done / (double)total : 1.0;
    int fill = (int)(frac * width);
    double left_s = done ? elapsed_ms / 1000.0 * (double)(total - done) / (double)done : 0.0;
    char bar[64];
    for (int i = 0; i < width; i++) bar[i] = i < fill ? '#' : '.';
    bar[width] = 0;
    fprintf(stderr, "\r[%s] %" PRIu64 "/%" PRIu64 " spp  %.0f s elapsed, %.0f s left   ", bar, done, total,
            elapsed_ms / 1000.0, left_s);
    if (done == total) fputc('\n', stderr);
    fflush(stderr);
    return 0;
}

/* With --time and no --spp the total is unknown: show samples and time only. */
static int progress_time(void *user, uint64_t done, uint64_t total, double elapsed_ms) {
    progress_state *ps = user;
    double limit = ps->time_limit_s;
    if (done != total && elapsed_ms < 1000.0 * limit && elapsed_ms - ps->last_ms < 100.0) return 0;
    ps->last_ms = elapsed_ms;
    double frac = fmin(1.0, elapsed_ms / 1000.0 / limit);
    const int width = 30;
    int fill = (int)(frac * width);
    char bar[64];
    for (int i = 0; i < width; i++) bar[i] = i < fill ? '#' : '.';
    bar[width] = 0;
    fprintf(stderr, "\r[%s] %" PRIu64 " spp  %.0f s elapsed, %.0f s left   ", bar, done, elapsed_ms / 1000.0,
            fmax(0.0, limit - elapsed_ms / 1000.0));
    if (frac >= 1.0 || done == total) fputc('\n', stderr);
    fflush(stderr);
    return 0;
}

int pgi_cmd_reference(int argc, char **argv) {
    const char *scene_spec = NULL, *out = NULL, *png = NULL, *cont = NULL;
    pgi_reference_desc d = {0};
    long long spp = 0;
    double time_s = 0.0;
    float exposure = 0.f;
    int quiet = 0, size_set = 0, bounces_set = 0, seed_set = 0, camera_set = 0, jitter_set = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            fputs(k_reference_help, stdout);
            return 0;
        }
        if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            quiet = 1;
            continue;
        }
        if (a[0] != '-') return ref_usage("unexpected argument '%s'", a);
        if (i + 1 >= argc) return ref_usage("%s needs a value", a);
        const char *v = argv[++i];
        long long n;
        if (strcmp(a, "--scene") == 0) scene_spec = v;
        else if (strcmp(a, "-o") == 0 || strcmp(a, "--out") == 0) out = v;
        else if (strcmp(a, "--png") == 0) png = v;
        else if (strcmp(a, "--continue") == 0) cont = v;
        else if (strcmp(a, "--spp") == 0) {
            if (!parse_long(v, 1, 1LL << 40, &spp))
                return ref_usage("--spp needs a positive whole number, got '%s'", v);
        } else if (strcmp(a, "--time") == 0) {
            if (!parse_pos_double(v, &time_s))
                return ref_usage("--time needs a positive number of seconds, got '%s'", v);
        } else if (strcmp(a, "--bounces") == 0) {
            if (!parse_long(v, 1, 64, &n)) return ref_usage("--bounces needs a number in 1..64, got '%s'", v);
            d.bounces = (int)n;
            bounces_set = 1;
        } else if (strcmp(a, "--seed") == 0) {
            if (!parse_long(v, 0, INT64_MAX, &n)) return ref_usage("--seed needs a non-negative integer, got '%s'", v);
            d.seed = (uint64_t)n;
            seed_set = 1;
        } else if (strcmp(a, "--threads") == 0) {
            if (!parse_long(v, 1, 1024, &n)) return ref_usage("--threads needs a number in 1..1024, got '%s'", v);
            d.threads = (int)n;
        } else if (strcmp(a, "--camera") == 0) {
            if (!parse_long(v, 0, 1000000, &n)) return ref_usage("--camera needs an index, got '%s'", v);
            d.camera = (int)n;
            camera_set = 1;
        } else if (strcmp(a, "--jitter") == 0) {
            if (strcmp(v, "on") == 0) d.jitter = PGI_JITTER_ON;
            else if (strcmp(v, "off") == 0) d.jitter = PGI_JITTER_OFF;
            else return ref_usage("--jitter must be on or off, got '%s'", v);
            jitter_set = 1;
        } else if (strcmp(a, "--size") == 0) {
            int w, h;
            char c;
            if (sscanf(v, "%dx%d%c", &w, &h, &c) != 2 || w <= 0 || h <= 0)
                return ref_usage("--size needs WIDTHxHEIGHT with positive numbers, e.g. 640x480, got '%s'", v);
            d.width = w;
            d.height = h;
            size_set = 1;
        } else if (strcmp(a, "--exposure") == 0) {
            double x;
            if (!parse_pos_double(v, &x)) return ref_usage("--exposure needs a positive number, got '%s'", v);
            exposure = (float)x;
        } else return ref_usage("unknown option '%s'", a);
    }
    pgi_image img = {0};
    uint64_t have = 0;
    pgi_reference_meta meta;
    memset(&meta, 0, sizeof meta);
    char meta_path[4096];
    if (cont) {
        if (scene_spec || size_set || bounces_set || seed_set || camera_set || jitter_set)
            return ref_usage("%s", "--continue takes the scene, size, bounces, seed, camera and jitter from the "
                                   "reference's .json file; do not give them");
        snprintf(meta_path, sizeof meta_path, "%s.json", cont);
        pgi_status st = pgi_reference_meta_read(meta_path, &meta);
        if (st) return ref_fail("cannot continue", st);
        int hdr = 0;
        st = pgi_image_read(cont, &img, &hdr);
        if (st) return ref_fail("cannot continue", st);
        if (!hdr || img.width != meta.width || img.height != meta.height) {
            pgi_image_free(&img);
            fprintf(stderr, "photongi reference: cannot continue: %s is not the %dx%d EXR its .json describes\n", cont,
                    meta.width, meta.height);
            return 1;
        }
        scene_spec = meta.scene;
        d.width = meta.width;
        d.height = meta.height;
        d.bounces = meta.bounces;
        d.camera = meta.camera;
        d.seed = meta.seed;
        d.jitter = meta.jitter;
        have = meta.spp;
        if (!out) out = cont;
    }
    if (!out) return ref_usage("%s", "no output file: give -o REF.exr");
    size_t ol = strlen(out);
    if (ol < 4 || strcasecmp(out + ol - 4, ".exr") != 0)
        return ref_usage("the output must be an .exr file (linear radiance), got '%s'", out);
    if (!scene_spec) scene_spec = "cornell";
    d.spp = spp ? (uint64_t)spp : time_s > 0.0 ? (uint64_t)1 << 40 : 64;
    d.time_limit_s = time_s;
    pgi_scene *scene;
    pgi_status st = pgi_scene_load(scene_spec, &scene);
    if (st) {
        pgi_image_free(&img);
        return ref_fail("cannot load scene", st);
    }
    pgi_scene_info info;
    pgi_scene_get_info(scene, &info);
    if (exposure == 0.f) exposure = info.defaults.exposure > 0.f ? info.defaults.exposure : 1.f;
    /* Resolve defaults here too, for the metadata. */
    if (d.width == 0 && d.height == 0) {
        d.width = info.defaults.width > 0 ? info.defaults.width : 640;
        d.height = info.defaults.height > 0 ? info.defaults.height : 480;
    }
    if (d.bounces == 0) d.bounces = info.defaults.bounces > 0 ? info.defaults.bounces : 4;
    if (d.seed == 0) d.seed = 1;
    if (d.jitter == PGI_JITTER_AUTO) d.jitter = PGI_JITTER_ON;
    progress_state ps = {time_s, -1e9};
    if (!quiet && isatty(2)) {
        d.progress = spp || time_s <= 0.0 ? progress_bar : progress_time;
        d.progress_user = &ps;
    }
    char scene_name[128];
    snprintf(scene_name, sizeof scene_name, "%s", info.name);
    uint64_t before = have;
    st = pgi_reference_render(scene, &d, &img, &have);
    pgi_scene_destroy(scene);
    if (st) {
        pgi_image_free(&img);
        return ref_fail("render failed", st);
    }
    st = pgi_image_write(&img, out, 1.f);
    if (!st && png) st = pgi_image_write(&img, png, exposure);
    pgi_image_free(&img);
    if (st) return ref_fail("cannot write image", st);
    if (scene_spec != meta.scene) /* --continue: already there (copying it onto itself is undefined) */
        snprintf(meta.scene, sizeof meta.scene, "%s", scene_spec);
    meta.width = d.width;
    meta.height = d.height;
    meta.bounces = d.bounces;
    meta.camera = d.camera;
    meta.seed = d.seed;
    meta.spp = have;
    meta.jitter = d.jitter;
    snprintf(meta_path, sizeof meta_path, "%s.json", out);
    st = pgi_reference_meta_write(&meta, meta_path);
    if (st) return ref_fail("cannot write metadata", st);
    if (!quiet)
        fprintf(stderr, "%s: %s %dx%d, %" PRIu64 " spp (%" PRIu64 " added), bounces %d, seed %" PRIu64 "\n", out,
                scene_name, d.width, d.height, have, have - before, d.bounces, d.seed);
    return 0;
}
