/* photongi reference: progressive path-traced reference image
 * (include/photongi/reference.h), EXR + sidecar JSON, optional PNG. */
#define _DEFAULT_SOURCE /* realpath (output.h) */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "cmd.h"
#include "output.h"
#include "parse.h"
#include "photongi/metrics.h"
#include "photongi/reference.h"
#include "camera.h"
#include "progress.h"

static const char *k_reference_help =
    "usage: photongi reference [--scene S] [--spp N | --time SECONDS] [options] -o REF.exr\n"
    "       photongi reference --continue REF.exr [--spp N | --time SECONDS] [-o OUT.exr]\n"
    "       photongi reference --merge A.exr B.exr -o OUT.exr\n"
    "\n"
    "Path-traces a reference with the photon pipeline's light transport: emission seen along\n"
    "the eye path, direct light at the first non-specular hit (next-event estimation, MIS for\n"
    "area lights) and indirect light of light paths with 1..B scattering events, Russian\n"
    "roulette. Each sample looks through its own uniform point of the pixel, so the image\n"
    "converges to the box-filtered pixel integral, as 'render --progressive' does (--jitter off:\n"
    "pixel centres, the point samples of one 'render' frame). Deterministic for a seed whatever\n"
    "the thread count. Writes linear EXR and REF.exr.json (scene, size, bounces, camera, the\n"
    "--eye/--look-at/--up/--fov camera if given, seed, jitter, specular, samples), so that\n"
    "--continue can add samples later.\n"
    "\n"
    "  --scene S          scene, as for 'render' (default cornell)\n"
    "  --spp N            samples per pixel to add, 1..2^40 (default 64; with --time: an upper bound)\n"
    "  --time SECONDS     stop after the pass that reaches this wall time\n"
    "  --bounces B        scattering events before the visible point, as 'render' (default:\n"
    "                     the scene's, else 4)\n"
    "  --size WxH         image size, 1..16384 a side and at most 37748736 pixels (default: the\n"
    "                     scene's, else 640x480)\n"
    "  --seed K           random seed, 0..2^64-1 (default 1; 0 is 1)\n"
    "  --threads T        worker threads, 1..1024 (default: all cores)\n"
    "  --camera NAME|I    the scene's camera, by name or index from 0 (default 0)\n"
    "  --eye X,Y,Z, --look-at X,Y,Z, --up X,Y,Z, --fov DEG   a camera of your own, as 'render';\n"
    "                     the parts not given are the --camera's\n"
    "  --jitter on|off    samples over the whole pixel (on, default) or through its centre\n"
    "  --specular ggx|phong   model of the mesh's glossy materials, as 'render' (default: the\n"
    "                     description's \"specular\", else ggx)\n"
    "  --continue REF.exr add samples to REF.exr (settings from REF.exr.json; -o defaults to it)\n"
    "  --merge A B        average two references of the same scene, size, bounces, camera, jitter\n"
    "                     and specular model rendered with different seeds (e.g. on two machines),\n"
    "                     weighted by their samples; OUT.exr.json counts both, and --continue on\n"
    "                     OUT goes on with A's seed past both counts\n"
    "  --checkpoint SECONDS  save the EXR and its .json at the first multiple of 4 samples after\n"
    "                     every SECONDS of rendering (default 600; 0: only at the end), so that a\n"
    "                     killed run loses at most that much\n"
    "  --png FILE         also write a tone-mapped PNG\n"
    "  --exposure X       exposure for --png (default: the scene's, else 1)\n"
    "  -o, --out FILE     output EXR (required unless --continue); its folder must exist\n"
    "  -q, --quiet        print nothing but errors: no progress bar (shown only on a terminal),\n"
    "                     summary or warnings\n"
    "\n"
    "The outputs (EXR, its .json, --png) are checked before the scene is loaded; two that name the\n"
    "same file are a usage error. Each is written to a temporary file beside it and renamed over it\n"
    "once complete, so a failed write (a full disk) or a killed process leaves the previous file;\n"
    "the .json records the EXR's size and hash, and --continue and --merge refuse a pair that do not\n"
    "belong together, a .json out of range, or an EXR with NaN or infinite pixels. The EXR and its\n"
    ".json are written before --png. SIGINT (Ctrl-C) or SIGTERM: the samples up to the next multiple\n"
    "of 4 are finished (a second signal: only the current one) and saved, then the exit status is\n"
    "130 (SIGINT) or 143 (SIGTERM). Continuing a reference saved at a multiple of 4 samples (every\n"
    "checkpoint and interrupted save is) gives the same bytes as one uninterrupted run.\n"
    "Exit status: 0 success, 2 usage error, 1 failure (see 'photongi --help'), 130/143 interrupted.\n";

/* SIGINT/SIGTERM: the signal, and how many came. */
static volatile sig_atomic_t g_signal, g_signals;
static void on_signal(int sig) {
    g_signal = sig;
    g_signals++;
}

/* The progress line (progress.h): samples per pixel done of this command's total, or with --time
 * and no --spp (the total unknown) the samples and the time against the limit. The same callback
 * stops a call at a signal, the time limit or a checkpoint. */
typedef struct ref_progress {
    app_progress bar;
    double time_limit_s;     /* --time, 0 if none */
    int by_time;             /* the bar follows the time, not the samples */
    uint64_t base, total;    /* samples of this command before the current call; the command's total */
    double base_ms, last_ms; /* time of the calls before; of this call so far */
    uint64_t n0;             /* samples in the image when this call began */
    double checkpoint_ms;    /* 0: none */
    int checkpoint;          /* the call stopped for a checkpoint */
} ref_progress;

static int progress_cb(void *user, uint64_t done_call, uint64_t total_call, double elapsed_ms) {
    ref_progress *rp = user;
    rp->last_ms = elapsed_ms;
    const uint64_t done = rp->base + done_call, total = rp->total;
    const double s = (rp->base_ms + elapsed_ms) / 1000.0;
    if (rp->bar.on) {
        if (rp->by_time) {
            double limit = rp->time_limit_s, frac = fmin(1.0, s / limit);
            app_progress_draw(&rp->bar, frac, 1000.0 * s, frac >= 1.0 || done == total,
                              "%" PRIu64 " spp  %.0f s elapsed, %.0f s left", done, s, fmax(0.0, limit - s));
        } else {
            double frac = total ? (double)done / (double)total : 1.0;
            double left_s = done ? s * (double)(total - done) / (double)done : 0.0;
            app_progress_draw(&rp->bar, frac, 1000.0 * s, done == total,
                              "%" PRIu64 "/%" PRIu64 " spp  %.0f s elapsed, %.0f s left", done, total, s, left_s);
        }
    }
    const int aligned = (rp->n0 + done_call) % PGI_REFERENCE_BLOCK == 0;
    if (g_signals >= 2 || (g_signal && aligned)) return 1;
    if (rp->time_limit_s > 0.0 && s >= rp->time_limit_s) return 1;
    if (rp->checkpoint_ms > 0.0 && elapsed_ms >= rp->checkpoint_ms && aligned && done_call < total_call) {
        rp->checkpoint = 1;
        return 1;
    }
    return 0;
}

/* A scene named by a file is recorded by its absolute path: --continue from another folder, or with
 * another file of that name in the current one, loads the same scene. */
static void absolute_scene(pgi_reference_meta *m) {
    struct stat sb;
    if (m->scene[0] == '/' || stat(m->scene, &sb) != 0 || !S_ISREG(sb.st_mode)) return;
    char *real = realpath(m->scene, NULL);
    if (real && strlen(real) < sizeof m->scene) snprintf(m->scene, sizeof m->scene, "%s", real);
    free(real);
}

/* Saves the EXR and its sidecar (pgi_reference_save: both complete on the disk before either replaces
 * the previous one). 0, or prints "photongi reference: [WHAT: ]<problem>" and returns 1. */
static int save_reference(const pgi_image *img, const char *out, const char *meta_path, pgi_reference_meta *meta,
                          const char *what) {
    absolute_scene(meta);
    if (pgi_reference_save(img, out, meta, meta_path) == PGI_OK) return 0;
    fprintf(stderr, "photongi reference: %s%scannot save %" PRIu64 " samples: %s\n", what ? what : "", what ? ": " : "",
            meta->spp, pgi_last_error());
    return 1;
}

static const char *const k_exr[] = {".exr", NULL}, *const k_png[] = {".png", NULL};

/* Reads a reference and its sidecar, and checks that they belong together and that every pixel is
 * finite; 0 or the exit status of the failure. */
static int read_reference(const char *path, pgi_image *img, pgi_reference_meta *meta, const char *what) {
    char mp[4096];
    if (snprintf(mp, sizeof mp, "%s.json", path) >= (int)sizeof mp)
        return cli_failure("reference", "%s: %s: the name is too long", what, path);
    pgi_status st = pgi_reference_meta_read(mp, meta);
    if (st) return cli_input_fail("reference", what, st);
    uint64_t bytes = 0, hash = 0;
    if ((st = pgi_reference_file_hash(path, &bytes, &hash))) return cli_input_fail("reference", what, st);
    if (meta->exr_bytes && (bytes != meta->exr_bytes || hash != meta->exr_hash))
        return cli_failure("reference",
                           "%s: %s and %s do not belong together (the image has %" PRIu64 " bytes, hash %016" PRIx64
                           "; the .json records %" PRIu64 " bytes, hash %016" PRIx64
                           "): the image was replaced after its .json was written, or a save was cut between the two",
                           what, path, mp, bytes, hash, meta->exr_bytes, meta->exr_hash);
    int hdr = 0;
    st = pgi_image_read(path, img, &hdr);
    if (st) return cli_input_fail("reference", what, st);
    if (!hdr || img->width != meta->width || img->height != meta->height) {
        pgi_image_free(img);
        return cli_failure("reference", "%s: %s is not the %dx%d EXR its .json describes", what, path, meta->width,
                           meta->height);
    }
    const size_t bad = cli_non_finite_pixels(img, 1.f), n = (size_t)img->width * img->height;
    if (bad) {
        pgi_image_free(img);
        return cli_failure("reference", "%s: %s has %zu pixel%s of %zu with NaN or infinite values", what, path, bad,
                           bad == 1 ? "" : "s", n);
    }
    return 0;
}

/* --merge: the sample-weighted mean of two references of the same settings and different seeds. */
static int merge_references(const char *a, const char *b, const char *out, const char *meta_path, int quiet) {
    pgi_image img[2] = {{0}, {0}};
    pgi_reference_meta m[2];
    int rc = read_reference(a, &img[0], &m[0], "cannot merge");
    if (!rc && (rc = read_reference(b, &img[1], &m[1], "cannot merge"))) pgi_image_free(&img[0]);
    if (rc) return rc;
    const char *differs = cli_reference_differs(&m[0], &m[1]);
    if (differs || m[0].seed == m[1].seed) {
        pgi_image_free(&img[0]);
        pgi_image_free(&img[1]);
        if (differs) return cli_failure("reference", "cannot merge %s and %s: their %s differ", a, b, differs);
        return cli_failure("reference", "cannot merge %s and %s: both have seed %" PRIu64 ", so the same samples", a, b,
                           m[0].seed);
    }
    if (m[0].spp == 0 || m[1].spp == 0) {
        pgi_image_free(&img[0]);
        pgi_image_free(&img[1]);
        return cli_failure("reference", "cannot merge %s and %s: %s has no samples", a, b, m[0].spp ? b : a);
    }
    const double wa = (double)m[0].spp / (double)(m[0].spp + m[1].spp);
    const size_t n3 = (size_t)img[0].width * img[0].height * 3;
    for (size_t i = 0; i < n3; i++) img[0].rgb[i] = (float)(wa * img[0].rgb[i] + (1.0 - wa) * img[1].rgb[i]);
    pgi_image_free(&img[1]);
    m[0].spp += m[1].spp;
    rc = m[0].spp > PGI_REFERENCE_MAX_SPP
             ? cli_failure("reference", "cannot merge %s and %s: together over 2^53 samples", a, b)
             : save_reference(&img[0], out, meta_path, &m[0], NULL);
    pgi_image_free(&img[0]);
    if (rc) return rc;
    if (!quiet)
        fprintf(stderr, "%s: %s %dx%d, %" PRIu64 " spp (%s and %s)\n", out, m[0].scene, m[0].width, m[0].height,
                m[0].spp, a, b);
    return 0;
}

/* What the command line of 'reference' gives. */
typedef struct reference_args {
    const char *scene_spec, *out, *png, *cont, *merge[2];
    pgi_reference_desc d;
    long long spp;
    double time_s, checkpoint_s;
    int checkpoint_set;
    float exposure;
    int quiet, size_set, bounces_set, seed_set, camera_set, jitter_set;
    const char *camera_name; /* --camera NAME, found once the scene is loaded */
    pgi_specular specular;
    app_camera_args cam_args;
    pgi_camera_def view;  /* d.view when a camera flag is given */
    char meta_path[4096]; /* the output's sidecar, OUT.exr.json */
} reference_args;

/* The reference being made: the scene, the image, its samples and the sidecar that describes it. */
typedef struct reference_run {
    pgi_scene *scene;
    char scene_name[128];
    pgi_image img;
    uint64_t have, before; /* samples in the image; of those, before this command */
    pgi_reference_meta meta;
    ref_progress rp;
} reference_run;

/* One "--name value" of reference's (not --merge, not a camera flag): 0, else the exit status. */
static int reference_option(const char *a, const char *v, reference_args *ra) {
    pgi_reference_desc *d = &ra->d;
    long long n;
    if (strcmp(a, "--scene") == 0) {
        if (!*v) return cli_usage("reference", "%s", "--scene needs a scene");
        ra->scene_spec = v;
    } else if (strcmp(a, "-o") == 0 || strcmp(a, "--out") == 0) ra->out = v;
    else if (strcmp(a, "--png") == 0) ra->png = v;
    else if (strcmp(a, "--continue") == 0) ra->cont = v;
    else if (strcmp(a, "--spp") == 0) {
        if (!parse_whole(v, 1, 1LL << 40, &ra->spp))
            return cli_usage("reference", "--spp needs a whole number in 1..%lld (2^40), got '%s'", 1LL << 40, v);
    } else if (strcmp(a, "--checkpoint") == 0) {
        if (!parse_checkpoint(v, &ra->checkpoint_s))
            return cli_usage("reference", "--checkpoint needs seconds, a number in 0..1e9 (0: none), got '%s'", v);
        ra->checkpoint_set = 1;
    } else if (strcmp(a, "--time") == 0) {
        if (!parse_pos_double(v, &ra->time_s))
            return cli_usage("reference", "--time needs a positive number of seconds, got '%s'", v);
    } else if (strcmp(a, "--bounces") == 0) {
        if (!parse_whole(v, 1, 64, &n))
            return cli_usage("reference", "--bounces needs a whole number in 1..64, got '%s'", v);
        d->bounces = (int)n;
        ra->bounces_set = 1;
    } else if (strcmp(a, "--seed") == 0) {
        if (!parse_u64(v, &d->seed))
            return cli_usage("reference", "--seed needs a whole number in 0..%" PRIu64 ", got '%s'", UINT64_MAX, v);
        ra->seed_set = 1;
    } else if (strcmp(a, "--threads") == 0) {
        if (!parse_whole(v, 1, 1024, &n))
            return cli_usage("reference", "--threads needs a whole number in 1..1024, got '%s'", v);
        d->threads = (int)n;
    } else if (strcmp(a, "--camera") == 0) {
        if (!*v || ((*v >= '0' && *v <= '9') && !parse_whole(v, 0, 1000000, &n)))
            return cli_usage("reference", "--camera needs a camera name or index (a whole number from 0), got '%s'", v);
        if (*v >= '0' && *v <= '9') d->camera = (int)n, ra->camera_name = NULL;
        else ra->camera_name = v;
        ra->camera_set = 1;
    } else if (strcmp(a, "--jitter") == 0) {
        if (strcmp(v, "on") == 0) d->jitter = PGI_JITTER_ON;
        else if (strcmp(v, "off") == 0) d->jitter = PGI_JITTER_OFF;
        else return cli_usage("reference", "--jitter must be on or off, got '%s'", v);
        ra->jitter_set = 1;
    } else if (strcmp(a, "--specular") == 0) {
        if (!parse_specular(v, &ra->specular))
            return cli_usage("reference", "--specular must be ggx or phong, got '%s'", v);
    } else if (strcmp(a, "--size") == 0) {
        if (!parse_size(v, PGI_MAX_IMAGE_SIDE, PGI_MAX_IMAGE_PIXELS, &d->width, &d->height))
            return cli_usage("reference",
                             "--size needs WIDTHxHEIGHT, e.g. 640x480, each side in 1..%d and at most %u pixels, "
                             "got '%s'",
                             PGI_MAX_IMAGE_SIDE, PGI_MAX_IMAGE_PIXELS, v);
        ra->size_set = 1;
    } else if (strcmp(a, "--exposure") == 0) {
        double x;
        if (!parse_pos_double(v, &x)) return cli_usage("reference", "--exposure needs a positive number, got '%s'", v);
        ra->exposure = (float)x;
    } else return cli_usage("reference", "unknown option '%s'", a);
    return 0;
}

/* Parses argv into ra; -1 to go on, else the exit status (0 after --help). */
static int parse_args(int argc, char **argv, reference_args *ra) {
    char err[400];
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (cli_is_help(a)) {
            fputs(k_reference_help, stdout);
            return 0;
        }
        if (cli_is_quiet(a)) {
            ra->quiet = 1;
            continue;
        }
        if (a[0] != '-') return cli_usage("reference", "unexpected argument '%s'", a);
        if (strcmp(a, "--merge") == 0) {
            if (i + 2 >= argc) return cli_usage("reference", "%s", "--merge needs two references: --merge A.exr B.exr");
            ra->merge[0] = argv[++i];
            ra->merge[1] = argv[++i];
            if (ra->merge[0][0] == '-' || ra->merge[1][0] == '-')
                return cli_usage("reference", "%s", "--merge needs two references: --merge A.exr B.exr");
            continue;
        }
        if (i + 1 >= argc) return cli_usage("reference", "%s needs a value", a);
        const char *v = argv[++i];
        int co = app_camera_option(a, v, &ra->cam_args, err, sizeof err);
        if (co < 0) return cli_usage("reference", "%s", err);
        if (co > 0) continue;
        int rc = reference_option(a, v, ra);
        if (rc) return rc;
    }
    return -1;
}

/* Everything the command line alone decides, then the outputs, before any file is read: 0 to go
 * on, else the exit status. */
static int check_args(reference_args *ra) {
    const int view_set = app_camera_given(&ra->cam_args);
    if (ra->cont && (ra->scene_spec || ra->size_set || ra->bounces_set || ra->seed_set || ra->camera_set || view_set ||
                     ra->jitter_set || ra->specular != PGI_SPECULAR_DEFAULT))
        return cli_usage("reference", "%s",
                         "--continue takes the scene, size, bounces, seed, camera (--eye, --look-at, --up, --fov "
                         "too), jitter and specular from the reference's .json file; do not give them");
    if (ra->merge[0] &&
        (ra->cont || ra->scene_spec || ra->size_set || ra->bounces_set || ra->seed_set || ra->camera_set || view_set ||
         ra->jitter_set || ra->spp || ra->time_s > 0.0 || ra->png || ra->specular != PGI_SPECULAR_DEFAULT ||
         ra->d.threads || ra->exposure > 0.f || ra->checkpoint_set))
        return cli_usage("reference", "%s", "--merge takes only the two references and -o OUT.exr");
    if (!ra->out) ra->out = ra->cont;
    if (!ra->out) return cli_usage("reference", "%s", "no output file: give -o REF.exr");
    const char *out = ra->out, *png = ra->png, *meta_path = ra->meta_path;
    if (snprintf(ra->meta_path, sizeof ra->meta_path, "%s.json", out) >= (int)sizeof ra->meta_path)
        return cli_failure("reference", "-o %.64s...: the name is too long", out);
    int rc = app_check_output("photongi reference", "-o", out, k_exr);
    if (!rc) rc = app_check_output("photongi reference", "-o (its sidecar)", meta_path, NULL);
    if (!rc && png) rc = app_check_output("photongi reference", "--png", png, k_png);
    if (rc) return rc;
    const char *names[] = {"-o", "-o's sidecar", "--png"}, *paths[] = {out, meta_path, png};
    return app_check_distinct("photongi reference", 3, names, paths);
}

/* Frees what rn holds after a failure (its message printed) and returns rc. */
static int give_up(reference_run *rn, int rc) {
    pgi_image_free(&rn->img);
    pgi_scene_destroy(rn->scene);
    rn->scene = NULL;
    return rc;
}

/* What the sidecar says, for checkpoints and the end (the samples aside). */
static void describe(const reference_args *ra, reference_run *rn, pgi_specular specular) {
    const pgi_reference_desc *d = &ra->d;
    pgi_reference_meta *meta = &rn->meta;
    if (ra->scene_spec != meta->scene) /* --continue: already there (copying it onto itself is undefined) */
        snprintf(meta->scene, sizeof meta->scene, "%s", ra->scene_spec);
    meta->width = d->width;
    meta->height = d->height;
    meta->bounces = d->bounces;
    meta->camera = d->camera;
    if (d->view && d->view != &meta->view) meta->view = *d->view;
    meta->has_view = d->view != NULL;
    meta->seed = d->seed;
    meta->jitter = d->jitter;
    meta->specular = specular; /* the model in use, whether given or the scene's */
}

/* The settings of --continue's reference (its image into rn), the scene with its glossy model, the
 * camera, the exposure and the defaults resolved, the samples to add: 0 to go on, else the exit
 * status (what was read freed). */
static int open_scene(reference_args *ra, reference_run *rn) {
    pgi_reference_desc *d = &ra->d;
    if (ra->cont) {
        int rc2 = read_reference(ra->cont, &rn->img, &rn->meta, "cannot continue");
        if (rc2) return rc2;
        const pgi_reference_meta *meta = &rn->meta;
        ra->scene_spec = meta->scene;
        d->width = meta->width;
        d->height = meta->height;
        d->bounces = meta->bounces;
        d->camera = meta->camera;
        if (meta->has_view) d->view = &meta->view; /* the samples so far were rendered from it */
        d->seed = meta->seed;
        d->jitter = meta->jitter;
        ra->specular = meta->specular;
        rn->have = meta->spp;
    }
    if (!ra->scene_spec) ra->scene_spec = "cornell";
    d->spp = ra->spp ? (uint64_t)ra->spp : ra->time_s > 0.0 ? (uint64_t)1 << 40 : 64;
    d->time_limit_s = ra->time_s;
    int rc = cli_load_scene("reference", ra->scene_spec, 0, ra->specular, &rn->scene);
    if (rc) return give_up(rn, rc);
    pgi_scene_info info;
    pgi_scene_get_info(rn->scene, &info);
    snprintf(rn->scene_name, sizeof rn->scene_name, "%s", info.name);
    if (*info.warnings) cli_warn(ra->quiet, "reference", "%s", info.warnings);
    {
        char idx[24];
        snprintf(idx, sizeof idx, "%d", d->camera);
        const char *cam = ra->camera_name ? ra->camera_name : idx;
        size_t ci;
        if (pgi_scene_find_camera(rn->scene, cam, &ci) != PGI_OK)
            return give_up(rn, cli_failure("reference", "--camera %s: %s", cam, pgi_last_error()));
        d->camera = (int)ci;
    }
    if (app_camera_given(&ra->cam_args)) {
        if ((rc = cli_resolve_view("reference", rn->scene, d->camera, rn->scene_name, &ra->cam_args, &ra->view)))
            return give_up(rn, rc);
        d->view = &ra->view;
    }
    ra->exposure = cli_exposure(ra->exposure, &info);
    /* Resolve defaults here too, for the metadata. */
    if (d->width == 0 && d->height == 0) {
        d->width = info.defaults.width > 0 ? info.defaults.width : 640;
        d->height = info.defaults.height > 0 ? info.defaults.height : 480;
    }
    if (d->bounces == 0) d->bounces = info.defaults.bounces > 0 ? info.defaults.bounces : 4;
    if (d->seed == 0) d->seed = 1;
    if (d->jitter == PGI_JITTER_AUTO) d->jitter = PGI_JITTER_ON;
    if (rn->have + d->spp > PGI_REFERENCE_MAX_SPP && ra->spp)
        return give_up(rn, cli_failure("reference", "%s has %" PRIu64 " samples: %lld more would pass 2^53", ra->cont,
                                       rn->have, ra->spp));
    if (rn->have + d->spp > PGI_REFERENCE_MAX_SPP) d->spp = PGI_REFERENCE_MAX_SPP - rn->have;
    describe(ra, rn, info.specular);
    return 0;
}

/* Calls of the library (or of photongi-mpi's backend, across its ranks) that stop at a
   checkpoint or a signal (on a multiple of 4 samples: the next call goes on with the same bits)
   or at the time limit; a checkpoint saves the EXR and its sidecar. Frees the scene. */
static pgi_status render_samples(reference_args *ra, reference_run *rn) {
    pgi_reference_desc *d = &ra->d;
    ref_progress *rp = &rn->rp;
    *rp = (ref_progress){.time_limit_s = ra->time_s, .by_time = !ra->spp && ra->time_s > 0.0, .total = d->spp};
    app_progress_init(&rp->bar, ra->quiet);
    rn->before = rn->have;
    const pgi_cli_backend *be = pgi_cli_backend_now;
    /* kept to the end: a signal while saving is noted, not fatal */
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    d->progress = progress_cb;
    d->progress_user = rp;
    d->time_limit_s = 0.0;
    rp->checkpoint_ms = 1000.0 * ra->checkpoint_s;
    const int writer = !be || be->writer;
    uint64_t left = d->spp;
    pgi_status st;
    for (;;) {
        d->spp = left;
        rp->n0 = rn->have;
        rp->checkpoint = 0;
        rp->last_ms = 0.0;
        const uint64_t h0 = rn->have;
        st = be ? be->reference(rn->scene, d, &rn->img, &rn->have)
                : pgi_reference_render(rn->scene, d, &rn->img, &rn->have);
        if (st) break;
        rp->base += rn->have - h0;
        rp->base_ms += rp->last_ms;
        left -= rn->have - h0;
        int more = rp->checkpoint && left > 0 && !g_signal;
        if (be) more = be->agree(more); /* the writer's progress decides for every process */
        if (!more) break;
        rn->meta.spp = rn->have;
        if (writer && save_reference(&rn->img, ra->out, ra->meta_path, &rn->meta, "checkpoint") == 0 && !ra->quiet &&
            !rp->bar.on)
            fprintf(stderr, "photongi reference: checkpoint: %s saved at %" PRIu64 " spp\n", ra->out, rn->have);
    }
    app_progress_end(&rp->bar, 1);
    pgi_scene_destroy(rn->scene);
    rn->scene = NULL;
    return st;
}

/* Saves the reference, then --png; the note of an interrupted run, or the summary. Frees the image.
 * Returns the exit status. */
static int finish(const reference_args *ra, reference_run *rn) {
    const char *out = ra->out;
    const uint64_t have = rn->have;
    rn->meta.spp = have;
    int rc = save_reference(&rn->img, out, ra->meta_path, &rn->meta, NULL);
    if (!rc && ra->png && pgi_image_write(&rn->img, ra->png, ra->exposure)) {
        fprintf(stderr, "photongi reference: cannot write --png: %s (%s and %s are saved at %" PRIu64 " spp)\n",
                pgi_last_error(), out, ra->meta_path, have);
        rc = 1;
    }
    pgi_image_free(&rn->img);
    if (g_signal) {
        const int sig = g_signal;
        if (rc == 0)
            fprintf(stderr,
                    "photongi reference: interrupted (%s): %s saved with %" PRIu64 " samples per pixel (%" PRIu64
                    " added); 'photongi reference --continue %s' adds more\n",
                    cli_signal_name(sig), out, have, have - rn->before, out);
        else fprintf(stderr, "photongi reference: interrupted (%s)\n", cli_signal_name(sig));
        return 128 + sig;
    }
    if (rc) return rc;
    if (!ra->quiet)
        fprintf(stderr, "%s: %s %dx%d, %" PRIu64 " spp (%" PRIu64 " added), bounces %d, seed %" PRIu64 "\n", out,
                rn->scene_name, ra->d.width, ra->d.height, have, have - rn->before, ra->d.bounces, ra->d.seed);
    return 0;
}

int pgi_cmd_reference(int argc, char **argv) {
    reference_args ra = {.checkpoint_s = 600.0, .specular = PGI_SPECULAR_DEFAULT};
    int rc = parse_args(argc, argv, &ra);
    if (rc >= 0) return rc;
    if ((rc = check_args(&ra))) return rc;
    if (ra.merge[0]) /* no samples to deal: one process merges */
        return pgi_cli_backend_now && !pgi_cli_backend_now->writer
                   ? 0
                   : merge_references(ra.merge[0], ra.merge[1], ra.out, ra.meta_path, ra.quiet);

    reference_run rn;
    memset(&rn, 0, sizeof rn);
    if ((rc = open_scene(&ra, &rn))) return rc;
    pgi_status st = render_samples(&ra, &rn);
    if (st) {
        pgi_image_free(&rn.img);
        return cli_fail("reference", "render failed", st);
    }
    if (pgi_cli_backend_now && !pgi_cli_backend_now->writer) { /* another process writes */
        pgi_image_free(&rn.img);
        return 0;
    }
    return finish(&ra, &rn);
}
