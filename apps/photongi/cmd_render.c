/* photongi render: one frame, or the average of --progressive N frames, to PNG or EXR. The
 * frames run in this process, or through pgi_cli_backend_now where a launcher set one
 * (photongi-mpi deals them to MPI ranks, apps/mpi). */
#define _DEFAULT_SOURCE /* realpath (output.h) */
#include <errno.h>
#include <signal.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "camera.h"
#include "cli.h"
#include "cmd.h"
#include "device.h"
#include "options.h"
#include "output.h"
#include "parse.h"
#include "photongi/photongi.h"
#include "progress.h"
#include "render_options.h"

const pgi_cli_backend *pgi_cli_backend_now = NULL;

/* FNV-1a 64 of a file's bytes (0 when it cannot be read: a built-in scene). */
static uint64_t file_hash(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    uint64_t h = 1469598103934665603ull;
    unsigned char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        for (size_t i = 0; i < n; i++) h = (h ^ buf[i]) * 1099511628211ull;
    fclose(f);
    return h;
}

/* SIGINT/SIGTERM during --progressive: the signal (the handler resets itself: a second one ends
 * the process at once). */
static volatile sig_atomic_t g_signal;
static void on_signal(int sig) { g_signal = sig; }

/* After each frame of --progressive: a signal ends the average; every --checkpoint seconds the
 * average so far is written to -o (atomically: a kill while writing keeps the previous file). */
typedef struct render_checkpoint {
    const pgi_image *img; /* the average so far */
    const char *out;
    float exposure;
    int quiet, frames;
    double every_ms, next_ms, t0_ms;
} render_checkpoint;

static int after_frame(void *user) {
    render_checkpoint *c = user;
    c->frames++;
    if (g_signal) return 1;
    if (c->every_ms <= 0.0 || app_now_ms() - c->t0_ms < c->next_ms) return 0;
    c->next_ms = app_now_ms() - c->t0_ms + c->every_ms;
    if (cli_non_finite_pixels(c->img, c->exposure)) {
        fprintf(stderr, "photongi render: checkpoint: the average of %d frames has non-finite pixels: not written\n",
                c->frames);
        return 0;
    }
    if (pgi_image_write(c->img, c->out, c->exposure) != PGI_OK)
        fprintf(stderr, "photongi render: checkpoint: cannot write %s: %s (the render goes on)\n", c->out,
                pgi_last_error());
    else if (!c->quiet)
        fprintf(stderr, "photongi render: checkpoint: %s written with the average of %d frames\n", c->out, c->frames);
    return 0;
}

/* The "view" of a statistics file's "run" (the camera of render --eye ...) as camera flags. */
static int read_view(const cJSON *v, app_camera_args *c) {
    static const char *const keys[3] = {"eye", "look_at", "up"};
    app_camera_args r = {1, 1, 1, 1, {0}, {0}, {0}, 0.f};
    float *dst[3] = {r.eye, r.look_at, r.up};
    for (int k = 0; k < 3; k++) {
        const cJSON *a = cJSON_GetObjectItemCaseSensitive(v, keys[k]);
        if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 3) return 0;
        int i = 0;
        for (const cJSON *it = a->child; it; it = it->next, i++) {
            if (!cJSON_IsNumber(it) || !(fabs(it->valuedouble) <= PGI_MAX_COORD)) return 0;
            dst[k][i] = (float)it->valuedouble;
        }
    }
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(v, "fov_y");
    if (!cJSON_IsNumber(f) || !(f->valuedouble > 0.0 && f->valuedouble <= APP_MAX_FOV)) return 0;
    r.fov = (float)f->valuedouble;
    *c = r;
    return 1;
}

/* What --from-stats read: the scene and the hash of its file then. */
typedef struct from_stats {
    char scene[4096], estimator[128], hash[24];
} from_stats;

/* --from-stats S.json: the settings and the run of a frame's statistics (pgi_stats_write_json) into d
 * and x, as if given on the command line at this point. 1 fine, 0 a failure (message in err). */
static int read_from_stats(const char *path, pgi_render_desc *d, app_render_extra *x, app_camera_args *cam,
                           from_stats *fsr, char *err, size_t size) {
    FILE *f = fopen(path, "rb");
    if (!f) return (snprintf(err, size, "--from-stats %s: cannot read: %s", path, strerror(errno)), 0);
    char *text = malloc(1 << 20);
    size_t n = text ? fread(text, 1, (1 << 20) - 1, f) : 0;
    int big = text && n == (1 << 20) - 1;
    fclose(f);
    if (!text || big) {
        free(text);
        return (snprintf(err, size, "--from-stats %s: not a statistics file (over 1 MB)", path), 0);
    }
    text[n] = 0;
    cJSON *root = cJSON_Parse(text);
    free(text);
    const cJSON *set = cJSON_GetObjectItemCaseSensitive(root, "settings");
    if (!cJSON_IsObject(set)) {
        cJSON_Delete(root);
        return (snprintf(err, size, "--from-stats %s: no \"settings\" object (statistics of photongi 0.1 or later)",
                         path),
                0);
    }
    int ok = 1;
    const cJSON *it;
    cJSON_ArrayForEach(it, set) {
        char flag[80];
        snprintf(flag, sizeof flag, "--%s", it->string ? it->string : "");
        if (!cJSON_IsString(it) || strcmp(flag, "--estimator") == 0) continue;
        int rc = app_render_option(flag, it->valuestring, d, x, NULL, err, size);
        if (rc <= 0) {
            if (rc == 0) snprintf(err, size, "unknown setting '%s'", it->string);
            char msg[400];
            snprintf(msg, sizeof msg, "%.399s", err);
            snprintf(err, size, "--from-stats %.150s: %.200s", path, msg);
            ok = 0;
            break;
        }
    }
    const cJSON *e = cJSON_GetObjectItemCaseSensitive(set, "estimator");
    if (ok && cJSON_IsString(e)) {
        snprintf(fsr->estimator, sizeof fsr->estimator, "%s", e->valuestring);
        d->estimator = fsr->estimator;
    }
    const cJSON *run = cJSON_GetObjectItemCaseSensitive(root, "run");
    if (ok && cJSON_IsObject(run)) {
        const cJSON *sc = cJSON_GetObjectItemCaseSensitive(run, "scene"),
                    *h = cJSON_GetObjectItemCaseSensitive(run, "scene_file_fnv1a64"),
                    *ex = cJSON_GetObjectItemCaseSensitive(run, "exposure"),
                    *t = cJSON_GetObjectItemCaseSensitive(run, "time"),
                    *sp = cJSON_GetObjectItemCaseSensitive(run, "specular"),
                    *view = cJSON_GetObjectItemCaseSensitive(run, "view");
        if (cJSON_IsString(sc)) snprintf(fsr->scene, sizeof fsr->scene, "%s", sc->valuestring);
        if (cJSON_IsString(h)) snprintf(fsr->hash, sizeof fsr->hash, "%s", h->valuestring);
        if (cJSON_IsNumber(ex) && ex->valuedouble > 0.0) x->exposure = (float)ex->valuedouble;
        if (cJSON_IsNumber(t)) x->time = (float)t->valuedouble;
        if (cJSON_IsString(sp) && !parse_specular(sp->valuestring, &x->specular)) x->specular = PGI_SPECULAR_DEFAULT;
        if (view && !read_view(view, cam)) {
            snprintf(err, size, "--from-stats %s: run.view is not a camera (eye, look_at, up: three numbers; fov_y)",
                     path);
            ok = 0;
        }
    }
    cJSON_Delete(root);
    return ok;
}

static const char *k_render_help =
    "usage: photongi render [--scene S] [options] -o OUT.png|OUT.exr\n"
    "\n"
    "Renders one frame: primary rays, photon tracing, density estimation of indirect light,\n"
    "direct light with shadow rays, tone mapping (PNG) or linear radiance (EXR).\n"
    "\n"
    "  --scene S          built-in (cornell [default], cornell-mirrors, giref, sphere-and-plane,\n"
    "                     cutout: light through a cut-out lattice, window-box: a room lit by the\n"
    "                     sky through a window and a skylight, two-rooms: a room lit through a\n"
    "                     doorway),\n"
    "                     a name with a description S.json (sibenik, crytek-sponza, conference,\n"
    "                     fireplace-room, cornell-box; see 'Scene files' below), a .json\n"
    "                     description, or a mesh\n"
    "  --estimator E      density estimator (see 'photongi estimators'); default " PGI_DEFAULT_ESTIMATOR ",\n"
    "                     the fastest exact one at the shipped scenes' defaults\n"
    "                     (docs/estimators.md); it takes no --kernel or --subsample (the list\n"
    "                     below names those that do)\n"
    "  --photons N        photons to store, 1..100000000 (2e6 is fine too; flux is normalised by\n"
    "                     the paths emitted); default: the scene's, else 200000\n"
    "  --radius R|auto    photon radius in scene units; default: the scene's, else auto: chosen each\n"
    "                     frame from the photon density the camera sees (docs/radius.md; with\n"
    "                     --radius-policy path or differentials: 2% of the scene's diagonal)\n"
    "  --size WxH         image size, 1..16384 a side and at most 37748736 pixels (36 Mi);\n"
    "                     default: the scene's, else 640x480\n"
    "  --bounces B        maximum photon bounces, 1..64 (default 4)\n"
    "  --seed K           random seed, 0..2^64-1 (default 1; 0 is 1); same seed, same image,\n"
    "                     any thread count\n"
    "  --threads T        worker threads, 1..1024 (default: all cores)\n"
    "  --camera NAME|I    the scene's camera: its name (a glTF camera node, a description's camera\n"
    "                     \"name\") or its index from 0 (default 0); 'photongi info' lists them\n"
    "  --eye X,Y,Z        camera position (scene units; default: the --camera's)\n"
    "  --look-at X,Y,Z    the point the camera looks at (default: the --camera's)\n"
    "  --up X,Y,Z         the camera's up direction (default: the --camera's)\n"
    "  --fov DEG          vertical field of view, above 0 and at most 179.9 degrees (default:\n"
    "                     the --camera's). The camera is the one a scene description's \"camera\"\n"
    "                     block with these values gives, to the bit (photongi-view's V key\n"
    "                     prints both forms)\n"
    "  --direct-samples K shadow samples per pixel for area lights and for the sky, 1..4096\n"
    "                     (default 16; 4 in a scene with a sky and portals, where\n"
    "                     3 of every 4 of the sky's go through a portal; --stats settings say\n"
    "                     which)\n"
    "  --exposure X       multiply radiance by X before tone mapping (default: the scene's, else 1)\n"
    "  --output all|direct|indirect|counts   what to put in the image (default all; indirect:\n"
    "                     no direct pass, no shadow ray; counts: photons that contributed\n"
    "                     at each pixel, best written as .exr)\n"
    "  --progressive N    average N frames (1..1000000) with fresh photons and a shrinking radius\n"
    "                     (Knaus & Zwicker 2011; exact estimators); converges as N grows\n"
    "                     to the pixel integral, as 'photongi reference' (see --jitter).\n"
    "                     Ctrl-C (SIGINT) or SIGTERM writes the average of the frames done\n"
    "                     (exit 130/143; a second one stops at once)\n"
    "  --checkpoint SECONDS   with --progressive: write the average so far to -o after the\n"
    "                     first frame that ends SECONDS after the last write (default 600;\n"
    "                     0: none), so that a killed render leaves its last checkpoint\n"
    "  --jitter auto|on|off   where in its pixel each view sample looks: auto (default) =\n"
    "                     the pixel centre for one frame, and for every frame after the first\n"
    "                     of --progressive a uniform point of the pixel drawn from the seed\n"
    "                     (frame k: point k of a stratified sequence per pixel; a box filter);\n"
    "                     on = such a point for every frame; off = centres always (a\n"
    "                     progressive average then converges to point samples)\n"
    "  --texture-filter auto|on|off   the view samples' textures: on = mip-mapped, the level\n"
    "                     of a ray cone a pixel wide (through mirrors and glass), trilinear, as\n"
    "                     the pixel integral would show them; off = the texel at the hit (level\n"
    "                     0; aliases); auto (default) = on where the view samples sit at pixel\n"
    "                     centres (--jitter off or auto, one frame), else off.\n"
    "                     Photons read level 0 either way (docs/design.md \"Textures\")\n"
    "  --emission uniform|guided|auto|portal   how photons leave the lights: uniform\n"
    "                     (the papers'), guided = towards the light paths whose photons\n"
    "                     land where the camera looks (a uniform pilot of 1/8 of the photons,\n"
    "                     then steered and reweighted: unbiased), portal = the sun's and the\n"
    "                     sky's photons start on the scene's portals (its windows, \"portals\" in\n"
    "                     the description; unbiased for the light through them; CPU, fixed\n"
    "                     radius policy), auto = portal where the portals take under half of\n"
    "                     the sun's and sky's uniform paths, else guided where the pilot\n"
    "                     predicts 1.25x the photons in view per unit of frame cost (paths\n"
    "                     traced per photon stored count), else uniform (byte for byte); the\n"
    "                     default (on the GPU: uniform; --stats says which and why: emission_used,\n"
    "                     emission_reason; docs/emission.md)\n"
    "  --store all|view   which photons to store: all (default), or view = only those that\n"
    "                     may lie within the radius of a view sample (the others add nothing;\n"
    "                     --photons then counts photons where the camera looks, and more paths\n"
    "                     are traced to find them); needs a given --radius\n"
    "  --time T           scene time in seconds for animated objects (default 0)\n"
    "  --specular ggx|phong   model of the mesh's glossy materials (MTL illum 2): ggx =\n"
    "                     microfacet plastic, phong = the papers' Blinn-Phong (default: the\n"
    "                     description's \"specular\", else ggx; docs/scene-format.md)\n"
    "  --from-stats S.json   the settings and the scene of a frame's --stats (what it rendered,\n"
    "                     every default resolved): renders that frame again; options after it\n"
    "                     change it (a note when the scene's file has changed since)\n"
    "  --stats FILE.json  write timings, memory (every large allocation and the process's peak\n"
    "                     resident set), photon reads/contributing as JSON ('-' = stdout)\n"
    "  --max-memory SIZE|none   memory budget: a frame whose scene, BVH, photons, buffers and\n"
    "                     estimator would need more is refused before anything is traced, naming\n"
    "                     what does not fit; SIZE in bytes or with K, M, G, T (1024-based), e.g.\n"
    "                     4G; none: no budget (default: the machine's physical memory, or the\n"
    "                     cgroup's limit when lower; docs/memory.md)\n"
    "  -o, --out FILE     output image (.png or .exr); required; its folder must exist\n"
    "  -q, --quiet        print nothing but errors: no progress line (shown only on a terminal),\n"
    "                     summary, notes or warnings\n"
    "  --radius-policy fixed|path|differentials   per-photon footprints (default fixed; others\n"
    "                     need an estimator that honours them: see 'photongi estimators -v')\n"
    "  --r-min R, --r-max R   path: radius range (default r_max = radius, r_min = r_max/8);\n"
    "                     differentials: r_max clamps the footprint radius\n"
    "  --smoothing S      differentials: smoothing factor s (default: automatic)\n"
    "  --filter R         depth/normal-aware bilateral filter of the indirect light, radius R\n"
    "                     pixels (0..16, default 0 = off)\n" APP_DEVICE_HELP "\n"
    "Scene files: a name S is looked up as S.json in ./scenes, then in the scenes/ folder of the\n"
    "source tree photongi was built from (so a build works from any directory), then in the\n"
    "installed share/photongi/scenes. Mesh paths in a description resolve against its folder,\n"
    "then $PHOTONGI_SCENES, or when that is not set the source tree's ../shared/scenes, then\n"
    "../shared/scenes from the working directory.\n"
    "Output files are checked (extension, folder) before the scene is loaded.\n"
    "Exit status: 0 success, 2 usage error, 1 failure (see 'photongi --help').\n"
    "\n";

/* The progress line of a render (only on a terminal, see progress.h): the pass, the photons
 * traced, the frame of --progressive. The bar splits a frame between the passes roughly as they
 * take time (tracing the most). */
static void render_progress(void *user, const pgi_progress *p) {
    static const struct {
        const char *pass, *label;
        double from, to;
    } k_passes[] = {{"view", "view samples", 0.0, 0.1},
                    {"trace", "tracing photons", 0.1, 0.6},
                    {"build", "building the estimator", 0.6, 0.7},
                    {"estimate", "estimating indirect light", 0.7, 0.9},
                    {"direct", "direct light", 0.9, 1.0}};
    app_progress *bar = user;
    const char *label = p->pass;
    double within = 0.0;
    for (size_t i = 0; i < sizeof k_passes / sizeof k_passes[0]; i++)
        if (strcmp(p->pass, k_passes[i].pass) == 0) {
            label = k_passes[i].label;
            within = k_passes[i].from;
            if (p->total) within += (k_passes[i].to - k_passes[i].from) * (double)p->done / (double)p->total;
        }
    const int frames = p->frames > 0 ? p->frames : 1;
    const double frac = (p->frame + within) / frames, s = p->elapsed_ms / 1000.0;
    char what[96];
    if (p->total) snprintf(what, sizeof what, "%s %" PRIu64 "/%" PRIu64, label, p->done, p->total);
    else snprintf(what, sizeof what, "%s", label);
    if (frames == 1) app_progress_draw(bar, frac, p->elapsed_ms, 0, "%s  %.1f s", what, s);
    else if (p->frame == 0)
        app_progress_draw(bar, frac, p->elapsed_ms, 0, "frame %d/%d: %s  %.0f s", p->frame + 1, frames, what, s);
    else
        app_progress_draw(bar, frac, p->elapsed_ms, 0, "frame %d/%d: %s  %.0f s elapsed, %.0f s left", p->frame + 1,
                          frames, what, s, s / frac * (1.0 - frac));
}

static const char *const k_image_exts[] = {".png", ".exr", NULL};

/* What the command line of 'render' gives: the frame's settings, the scene, the outputs. */
typedef struct render_args {
    pgi_render_desc d;
    app_given_options given;
    app_render_extra x;
    const char *scene_spec, *out, *stats_path;
    int quiet;
    from_stats fsr; /* --from-stats: its strings live through the call */
    double checkpoint_s;
    int checkpoint_set;
    app_camera_args cam_args;
    pgi_camera_def view; /* d.view when a camera flag is given */
} render_args;

/* The frame: its scene, the image and statistics it made, the progress line. */
typedef struct render_state {
    pgi_scene *scene;
    pgi_scene_info info;
    char scene_name[128], scene_file[4096];
    uint64_t scene_hash;
    float exposure;
    app_progress bar;
    pgi_image img;
    pgi_frame_stats fs;
    char device_name[256]; /* the stats' device name lives with the renderer */
} render_state;

/* Parses argv into ra; -1 to go on, else the exit status (0 after --help). */
static int parse_args(int argc, char **argv, render_args *ra) {
    char err[1400];
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (cli_is_help(a)) {
            fputs(k_render_help, stdout);
            app_print_estimator_options(stdout);
            return 0;
        }
        if (cli_is_quiet(a)) {
            ra->quiet = 1;
            continue;
        }
        if (a[0] != '-') return cli_usage("render", "unexpected argument '%s'", a);
        if (i + 1 >= argc) return cli_usage("render", "%s needs a value", a);
        const char *v = argv[++i];
        int ro = app_render_option(a, v, &ra->d, &ra->x, &ra->given, err, sizeof err);
        if (ro < 0) return cli_usage("render", "%s", err);
        if (ro > 0) continue;
        if ((ro = app_camera_option(a, v, &ra->cam_args, err, sizeof err)) < 0) return cli_usage("render", "%s", err);
        if (ro > 0) continue;
        if (strcmp(a, "--scene") == 0) {
            if (!*v) return cli_usage("render", "%s", "--scene needs a scene");
            ra->scene_spec = v;
        } else if (strcmp(a, "--from-stats") == 0) {
            if (!read_from_stats(v, &ra->d, &ra->x, &ra->cam_args, &ra->fsr, err, sizeof err))
                return cli_failure("render", "%s", err);
            if (ra->fsr.scene[0]) ra->scene_spec = ra->fsr.scene;
        } else if (strcmp(a, "-o") == 0 || strcmp(a, "--out") == 0) ra->out = v;
        else if (strcmp(a, "--stats") == 0) ra->stats_path = v;
        else if (strcmp(a, "--checkpoint") == 0) {
            if (!parse_checkpoint(v, &ra->checkpoint_s))
                return cli_usage("render", "--checkpoint needs seconds, a number in 0..1e9 (0: none), got '%s'", v);
            ra->checkpoint_set = 1;
        } else return cli_usage("render", "unknown option '%s'", a);
    }
    return -1;
}

/* Everything the command line alone decides, before any file is read: the outputs, the settings
 * together. 0 to go on, else the exit status. */
static int check_args(const render_args *ra) {
    if (!ra->out) return cli_usage("render", "%s", "no output file: give -o OUT.png or -o OUT.exr");
    int rc = app_check_output("photongi render", "-o", ra->out, k_image_exts);
    if (rc) return rc;
    if (ra->stats_path && strcmp(ra->stats_path, "-") != 0 &&
        (rc = app_check_output("photongi render", "--stats", ra->stats_path, NULL)))
        return rc;
    {
        const char *names[] = {"-o", "--stats"}, *paths[] = {ra->out, ra->stats_path};
        if ((rc = app_check_distinct("photongi render", 2, names, paths))) return rc;
    }
    char err[1400];
    int ck = app_render_check(&ra->d, &ra->x, err, sizeof err);
    if (ck == 0 && !pgi_estimator_find(ra->d.estimator ? ra->d.estimator : PGI_DEFAULT_ESTIMATOR)) {
        fprintf(stderr, "photongi render: %s\nTry 'photongi estimators -v'.\n", err);
        return CLI_EXIT_USAGE;
    }
    if (ck == 0) return cli_usage("render", "%s", err);
    if (ra->checkpoint_set && ra->x.progressive < 2)
        return cli_usage("render", "%s",
                         "--checkpoint needs --progressive N with N > 1 (one frame has nothing to save)");
    if (ra->checkpoint_set && pgi_cli_backend_now && ra->checkpoint_s > 0.0)
        return cli_usage("render", "%s", "--checkpoint: photongi-mpi render writes only at its end");
    if (!ra->quiet) app_note_ignored_options("photongi render", ra->d.estimator, &ra->given);
    if (ck < 0) return cli_failure("render", "%s", err);
    return 0;
}

/* Loads the scene at its time with its glossy model, then the camera (--camera, or the flags of a
 * camera of one's own) and the exposure. 0 to go on, else the exit status (the scene freed). */
static int open_scene(render_args *ra, render_state *rs) {
    int rc = cli_load_scene("render", ra->scene_spec, ra->d.max_memory, ra->x.specular, &rs->scene);
    if (rc) return rc;
    pgi_status st;
    if ((st = pgi_scene_set_time(rs->scene, ra->x.time))) {
        pgi_scene_destroy(rs->scene);
        return cli_fail("render", "cannot set the scene time", st);
    }
    pgi_scene_info *info = &rs->info;
    pgi_scene_get_info(rs->scene, info);
    snprintf(rs->scene_name, sizeof rs->scene_name, "%s", info->name);
    snprintf(rs->scene_file, sizeof rs->scene_file, "%s", info->source);
    rs->scene_hash = file_hash(rs->scene_file);
    if (ra->fsr.hash[0]) {
        char now[24];
        snprintf(now, sizeof now, "%016llx", (unsigned long long)rs->scene_hash);
        if (strcmp(now, ra->fsr.hash) != 0)
            cli_warn(ra->quiet, "render",
                     "%s has changed since the statistics of --from-stats were written: the image "
                     "may differ",
                     rs->scene_file);
    }
    if (*info->warnings) cli_warn(ra->quiet, "render", "%s", info->warnings);
    char err[1400];
    if (!app_render_camera(rs->scene, &ra->d, &ra->x, err, sizeof err)) {
        pgi_scene_destroy(rs->scene);
        return cli_failure("render", "%s", err);
    }
    if (app_camera_given(&ra->cam_args)) {
        if ((rc = cli_resolve_view("render", rs->scene, ra->d.camera, rs->scene_name, &ra->cam_args, &ra->view))) {
            pgi_scene_destroy(rs->scene);
            return rc;
        }
        ra->d.view = &ra->view;
    }
    rs->exposure = cli_exposure(ra->x.exposure, info);
    return 0;
}

/* --progressive N in this process: SIGINT/SIGTERM end the average after the frame in progress (a
 * second one, at once), and every --checkpoint seconds the average so far is written. */
static pgi_status render_progressive(const render_args *ra, render_state *rs, pgi_renderer *r) {
    struct sigaction sa, old_int, old_term;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sa.sa_flags = (int)SA_RESETHAND;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old_int);
    sigaction(SIGTERM, &sa, &old_term);
    render_checkpoint cp = {&rs->img,
                            ra->out,
                            rs->exposure,
                            ra->quiet || rs->bar.on,
                            0,
                            1000.0 * ra->checkpoint_s,
                            1000.0 * ra->checkpoint_s,
                            app_now_ms()};
    pgi_status st =
        pgi_render_progressive_until(r, &ra->d, (int)ra->x.progressive, after_frame, &cp, &rs->img, &rs->fs);
    sigaction(SIGINT, &old_int, NULL);
    sigaction(SIGTERM, &old_term, NULL);
    return st;
}

/* Renders the frame, or the average of --progressive N, into rs->img and rs->fs (through the
 * launcher's backend where there is one), with the progress line; warns of a view that sees
 * nothing lit. 0 to go on, else the exit status (the image and the scene freed). */
static int render(render_args *ra, render_state *rs) {
    pgi_renderer *r;
    pgi_status st;
    if ((st = pgi_renderer_create(rs->scene, &r))) {
        pgi_scene_destroy(rs->scene);
        return cli_fail("render", "cannot create a renderer", st);
    }
    pgi_render_desc *d = &ra->d;
    app_progress_init(&rs->bar, ra->quiet);
    if (rs->bar.on) {
        d->progress = render_progress;
        d->progress_user = &rs->bar;
    }
    const pgi_cli_backend *be = pgi_cli_backend_now;
    if (be) st = be->progressive(r, d, (int)ra->x.progressive, &rs->img, &rs->fs);
    else if (ra->x.progressive > 1) st = render_progressive(ra, rs, r);
    else st = pgi_renderer_render(r, d, &rs->img, &rs->fs);
    app_progress_end(&rs->bar, 0);
    /* A camera that sees nothing lit: an automatic one (the scene gives none) is probed for direct
     * light, any other one warned about when its image is black. */
    const pgi_scene_info *info = &rs->info;
    if (st == PGI_OK && !ra->quiet && !be && d->output == PGI_OUTPUT_ALL &&
        (app_image_unlit(&rs->img) || (info->camera_auto && !d->view && app_view_sees_light(r, d, info) == 0))) {
        char why[700];
        app_unlit_warning(info, d->camera, d->view != NULL, why, sizeof why);
        cli_warn(ra->quiet, "render", "%s", why);
    }
    if (st == PGI_OK) {
        snprintf(rs->device_name, sizeof rs->device_name, "%s", rs->fs.device ? rs->fs.device : "cpu");
        rs->fs.device = rs->device_name;
    }
    pgi_renderer_destroy(r);
    if (st) {
        pgi_image_free(&rs->img);
        pgi_scene_destroy(rs->scene);
        return cli_fail("render", "render failed", st);
    }
    return 0;
}

/* Writes the image, then, unless a signal ended the average, the statistics. Frees the image and
 * the scene. 0 to go on, else the exit status. */
static int write_outputs(const render_args *ra, render_state *rs) {
    const char *out = ra->out;
    /* A frame that is not numbers is a failed render, not an image (the scene's limits keep its
     * values floats, docs/scene-format.md "Numbers"; this catches what they let through). */
    const size_t bad = cli_non_finite_pixels(&rs->img, rs->exposure),
                 npx = (size_t)rs->img.width * (size_t)rs->img.height;
    if (bad) {
        pgi_image_free(&rs->img);
        pgi_scene_destroy(rs->scene);
        return cli_failure("render",
                           "%s: the render has %zu non-finite pixel%s (NaN or Inf) of %zu, with exposure %g: not "
                           "written (scene %s; see docs/scene-format.md, Numbers)",
                           out, bad, bad == 1 ? "" : "s", npx, (double)rs->exposure, rs->scene_file);
    }
    pgi_status st = pgi_image_write(&rs->img, out, rs->exposure);
    pgi_image_free(&rs->img);
    pgi_scene_destroy(rs->scene);
    if (st) return cli_fail("render", "cannot write image", st);
    pgi_frame_stats *fs = &rs->fs;
    if (g_signal) { /* the average so far is written; the stats are not */
        fprintf(stderr, "photongi render: interrupted (%s): %s written with the average of %d of %lld frames\n",
                cli_signal_name(g_signal), out, fs->frames, ra->x.progressive);
        return 128 + g_signal;
    }
    fs->memory_peak_rss = pgi_memory_peak_rss(); /* writing the image included */
    fs->run = (pgi_run_info){ra->scene_spec, rs->scene_file, rs->scene_hash, rs->exposure,
                             ra->x.time,     ra->x.specular, ra->d.view};
    if (ra->stats_path) {
        const pgi_cli_backend *be = pgi_cli_backend_now;
        st = be && be->write_stats ? be->write_stats(fs, ra->stats_path) : pgi_stats_write_json(fs, ra->stats_path);
        if (st) return cli_fail("render", "cannot write stats", st);
    }
    return 0;
}

/* The summary on stderr (-q: none): the frame, its passes' times, photon reads, memory; and the
 * warning of photons that did not stay in the scene. */
static void print_summary(const render_args *ra, const render_state *rs) {
    const pgi_frame_stats *fs = &rs->fs;
    if (fs->photons_stored < (uint64_t)fs->settings.photons * (uint64_t)fs->frames)
        cli_warn(ra->quiet, "render",
                 "only %" PRIu64 " photons were stored from %" PRIu64
                 " paths: most light leaves the scene (the tracer stops after 64 paths per requested photon)",
                 fs->photons_stored, fs->photons_emitted);
    if (ra->quiet) return;
    fprintf(stderr,
            "%s: %s %dx%d, %s, %" PRIu64 " photons stored from %" PRIu64 " paths, r=%g\n"
            "  view %.1f ms | trace %.1f ms | build %.1f ms | estimate %.1f ms | direct %.1f ms | total %.1f ms\n"
            "  photon reads %" PRIu64 ", contributing %" PRIu64 " (%.1f%%)\n",
            ra->out, rs->scene_name, fs->width, fs->height, fs->estimator, fs->photons_stored, fs->photons_emitted,
            (double)fs->radius, fs->view_ms, fs->trace_ms, fs->build_ms, fs->estimate_ms, fs->direct_ms, fs->total_ms,
            fs->reads, fs->contributing, fs->reads ? 100.0 * (double)fs->contributing / (double)fs->reads : 0.0);
    if (strcmp(fs->device, "cpu") != 0) {
        fprintf(stderr, "  device %s:", fs->device);
        for (int k = 0; k < fs->pass_count; k++)
            fprintf(stderr, "%s %s %.2f ms", k ? " |" : "", fs->passes_ms[k].name, fs->passes_ms[k].value);
        fprintf(stderr, "\n");
    }
    if (fs->frames > 1)
        fprintf(stderr, "  progressive: %d frames averaged (times and counts summed), last radius %g\n", fs->frames,
                (double)fs->radius);
    double counted = 0.0;
    int big = 0;
    for (int k = 0; k < fs->memory_count; k++) {
        counted += fs->memory_bytes[k].value;
        if (fs->memory_bytes[k].value > fs->memory_bytes[big].value) big = k;
    }
    if (fs->memory_count > 0)
        fprintf(stderr, "  memory %.1f MiB counted (largest: %s %.1f MiB), peak resident set %.1f MiB\n",
                counted / 1048576.0, fs->memory_bytes[big].name, fs->memory_bytes[big].value / 1048576.0,
                (double)fs->memory_peak_rss / 1048576.0);
    if (fs->leaf_size > 0) fprintf(stderr, "  bvh leaf-size threshold %d\n", fs->leaf_size);
    if (fs->footprint_bin_width > 0.f) {
        fprintf(stderr, "  footprint radii (before the r_max clamp):\n");
        for (int k = 0; k < PGI_FOOTPRINT_BINS; k++) {
            double lo = k * (double)fs->footprint_bin_width;
            if (k < PGI_FOOTPRINT_BINS - 1)
                fprintf(stderr, "    %8.4g - %-8.4g %10" PRIu64 "\n", lo, lo + fs->footprint_bin_width,
                        fs->footprint_hist[k]);
            else fprintf(stderr, "    > %-17.4g %10" PRIu64 "\n", lo, fs->footprint_hist[k]);
        }
    }
}

int pgi_cmd_render(int argc, char **argv) {
    render_args ra = {.d = {.emission = PGI_EMISSION_AUTO},
                      .x = APP_RENDER_EXTRA_INIT,
                      .scene_spec = "cornell",
                      .checkpoint_s = 600.0};
    int rc = parse_args(argc, argv, &ra);
    if (rc >= 0) return rc;
    if ((rc = check_args(&ra))) return rc;
    render_state rs;
    memset(&rs, 0, sizeof rs); /* fs: a launcher's rank that does not write leaves it untouched */
    if ((rc = open_scene(&ra, &rs)) || (rc = render(&ra, &rs))) return rc;
    if (pgi_cli_backend_now && !pgi_cli_backend_now->writer) { /* another process writes */
        pgi_image_free(&rs.img);
        pgi_scene_destroy(rs.scene);
        return 0;
    }
    if ((rc = write_outputs(&ra, &rs))) return rc;
    print_summary(&ra, &rs);
    return 0;
}
