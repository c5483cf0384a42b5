/* photongi command line: render, estimators, info. A thin layer over the
 * public API; only this file decides to exit. */
#include <errno.h>
#include <math.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "photongi/photongi.h"
#include "cmd.h"
#include "options.h"
#include "parse.h"

static const char *k_main_help =
    "photongi " PGI_VERSION_STRING " - global illumination by photon mapping at interactive rates\n"
    "\n"
    "usage: photongi <command> [options]\n"
    "\n"
    "commands:\n"
    "  render       render one frame of a scene to PNG or EXR\n"
    "  estimators   list the registered density estimators\n"
    "  info         print what a scene holds (triangles, materials, lights, bounds, camera)\n"
    "  reference    path-trace a reference image (EXR), resumable with --continue\n"
    "  compare      PSNR and SSIM of an image against a reference, error heat map\n"
    "\n"
    "Run 'photongi <command> --help' for the options of a command.\n";

static const char *k_render_help =
    "usage: photongi render [--scene S] [options] -o OUT.png|OUT.exr\n"
    "\n"
    "Renders one frame: primary rays, photon tracing, density estimation of indirect light,\n"
    "direct light with shadow rays, tone mapping (PNG) or linear radiance (EXR).\n"
    "\n"
    "  --scene S          built-in (cornell [default], giref, sphere-and-plane), a name with a\n"
    "                     description in scenes/S.json (sibenik, crytek-sponza, conference,\n"
    "                     fireplace-room, cornell-box), a .json description, or a mesh file\n"
    "  --estimator E      density estimator (see 'photongi estimators'); default " PGI_DEFAULT_ESTIMATOR "\n"
    "  --photons N        photons to store (flux is normalised by the paths emitted);\n"
    "                     default: the scene's, else 200000\n"
    "  --radius R         photon radius in scene units; default: the scene's, else 2% of its diagonal\n"
    "  --size WxH         image size; default: the scene's, else 640x480\n"
    "  --bounces B        maximum photon bounces (default 4)\n"
    "  --seed K           random seed (default 1); same seed, same image, any thread count\n"
    "  --threads T        worker threads (default: all cores)\n"
    "  --camera I         camera index of the scene (default 0)\n"
    "  --direct-samples K shadow samples per pixel for area lights (default 16)\n"
    "  --exposure X       multiply radiance by X before tone mapping (default: the scene's, else 1)\n"
    "  --output all|direct|indirect|counts   what to put in the image (default all; counts:\n"
    "                     photons that contributed at each pixel, best written as .exr)\n"
    "  --progressive N    average N frames with fresh photons and a shrinking radius\n"
    "                     (Knaus & Zwicker 2011; exact estimators); converges as N grows\n"
    "                     to the pixel integral, as 'photongi reference' (see --jitter)\n"
    "  --jitter auto|on|off   where in its pixel each view sample looks: auto (default) =\n"
    "                     the pixel centre for one frame, and for every frame after the first\n"
    "                     of --progressive a uniform point of the pixel drawn from the seed\n"
    "                     (frame k: point k of a stratified sequence per pixel; a box filter);\n"
    "                     on = such a point for every frame; off = centres always (a\n"
    "                     progressive average then converges to point samples)\n"
    "  --time T           scene time in seconds for animated objects (default 0)\n"
    "  --stats FILE.json  write timings, memory, photon reads/contributing as JSON ('-' = stdout)\n"
    "  -o, --out FILE     output image (.png or .exr); required\n"
    "  -q, --quiet        print nothing but errors\n"
    "  --radius-policy fixed|path|differentials   per-photon footprints (default fixed; others\n"
    "                     need an estimator that honours them: see 'photongi estimators -v')\n"
    "  --r-min R, --r-max R   path: radius range (default r_max = radius, r_min = r_max/8);\n"
    "                     differentials: r_max clamps the footprint radius\n"
    "  --smoothing S      differentials: smoothing factor s (default: automatic)\n"
    "  --filter R         depth/normal-aware bilateral filter of the indirect light, radius R\n"
    "                     pixels (0..16, default 0 = off)\n"
    "\n"
    "Scene files: mesh paths resolve against the .json file, then $PHOTONGI_SCENES\n"
    "(default ../shared/scenes).\n"
    "\n";

static const char *k_info_help = "usage: photongi info [--scene S]\n"
                                 "\n"
                                 "Loads a scene (same forms as 'render --scene') and prints its triangles, vertices,\n"
                                 "materials, textures, lights, bounds, camera and suggested render settings.\n";

static const char *k_est_help =
    "usage: photongi estimators [-v]\n"
    "\n"
    "Lists the registered density estimators, one name a line (-v: with a summary, whether\n"
    "it is approximate, and which of --kernel, --subsample, --radius-policy it supports).\n";

static int fail(const char *what, pgi_status st) {
    const char *msg = pgi_last_error();
    fprintf(stderr, "photongi: %s: %s\n", what, *msg ? msg : pgi_status_string(st));
    return st == PGI_ERR_INVALID_ARG ? 2 : 1;
}

static int usage_error(const char *cmd, const char *fmt, const char *arg) {
    fprintf(stderr, "photongi %s: ", cmd);
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\nTry 'photongi %s --help'.\n", cmd);
    return 2;
}

static int is_help(const char *a) { return strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0; }

/* Appends ", item" (or "item" to an empty list), truncating at cap. */
static void list_append(char *list, size_t cap, const char *item) {
    size_t n = strlen(list);
    snprintf(list + n, cap - n, "%s%s", n ? ", " : "", item);
}

static int cmd_estimators(int argc, char **argv) {
    int verbose = 0;
    for (int i = 0; i < argc; i++) {
        if (is_help(argv[i])) {
            fputs(k_est_help, stdout);
            return 0;
        }
        if (strcmp(argv[i], "-v") == 0) verbose = 1;
        else return usage_error("estimators", "unknown option '%s'", argv[i]);
    }
    int width = 0;
    for (size_t i = 0; i < pgi_estimator_count(); i++) {
        int n = (int)strlen(pgi_estimator_at(i)->name);
        if (n > width) width = n;
    }
    for (size_t i = 0; i < pgi_estimator_count(); i++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(i);
        if (!verbose) {
            printf("%s\n", vt->name);
            continue;
        }
        printf("%-*s  %s%s\n", width, vt->name, vt->summary, vt->exact ? "" : " [approximate]");
        char also[256] = "";
        for (size_t k = 0; k < pgi_option_count(); k++) {
            const pgi_option *o = pgi_option_at(k);
            if (!pgi_estimator_takes(vt, o)) continue;
            char flag[64];
            snprintf(flag, sizeof flag, "--%s", o->name);
            list_append(also, sizeof also, flag);
        }
        if (vt->caps & PGI_EST_CAP_PHOTON_RADIUS) list_append(also, sizeof also, "--radius-policy path|differentials");
        if (also[0]) printf("%-*s  also: %s\n", width, "", also);
    }
    return 0;
}

static int cmd_info(int argc, char **argv) {
    const char *scene_spec = "cornell";
    for (int i = 0; i < argc; i++) {
        if (is_help(argv[i])) {
            fputs(k_info_help, stdout);
            return 0;
        } else if (strcmp(argv[i], "--scene") == 0) {
            if (i + 1 >= argc) return usage_error("info", "%s needs a value", argv[i]);
            scene_spec = argv[++i];
        } else return usage_error("info", "unknown option '%s'", argv[i]);
    }
    pgi_scene *scene;
    pgi_status st = pgi_scene_load(scene_spec, &scene);
    if (st) return fail("cannot load scene", st);
    pgi_scene_info in;
    pgi_scene_get_info(scene, &in);
    printf("scene:      %s\n", in.name);
    printf("source:     %s\n", in.source);
    printf("triangles:  %zu\n", in.triangles);
    printf("vertices:   %zu\n", in.vertices);
    printf("materials:  %zu\n", in.materials);
    printf("textures:   %zu\n", in.textures);
    printf("lights:     %zu (point %zu, spot %zu, sun %zu, emissive triangles %zu)\n", in.lights, in.point_lights,
           in.spot_lights, in.sun_lights, in.area_triangles);
    printf("bounds:     (%g, %g, %g) - (%g, %g, %g)\n", in.bounds_min[0], in.bounds_min[1], in.bounds_min[2],
           in.bounds_max[0], in.bounds_max[1], in.bounds_max[2]);
    printf("cameras:    %zu\n", in.cameras);
    printf("camera 0:   eye (%g, %g, %g) look-at (%g, %g, %g) up (%g, %g, %g) fov_y %g deg\n", in.camera.eye[0],
           in.camera.eye[1], in.camera.eye[2], in.camera.look_at[0], in.camera.look_at[1], in.camera.look_at[2],
           in.camera.up[0], in.camera.up[1], in.camera.up[2], in.camera.fov_y_deg);
    const pgi_scene_defaults *d = &in.defaults;
    printf("defaults:   photons %u, radius %g, bounces %d, size %dx%d, exposure %g\n", d->photons, d->radius,
           d->bounces, d->width, d->height, d->exposure);
    printf("animated:   %zu objects, keyframes up to %g s\n", in.animated_objects, in.anim_duration);
    pgi_scene_destroy(scene);
    return 0;
}

static int cmd_render(int argc, char **argv) {
    pgi_render_desc d = {0};
    app_given_options given = {0};
    long long progressive = 1;
    const char *scene_spec = "cornell", *out = NULL, *stats_path = NULL;
    float exposure = 0.f, scene_time = 0.f;
    int quiet = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (is_help(a)) {
            fputs(k_render_help, stdout);
            app_print_estimator_options(stdout);
            return 0;
        }
        if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            quiet = 1;
            continue;
        }
        if (a[0] != '-') return usage_error("render", "unexpected argument '%s'", a);
        if (i + 1 >= argc) return usage_error("render", "%s needs a value", a);
        const char *v = argv[++i];
        long long n;
        int eo = app_estimator_option("photongi render", a, v, &d.est, &given);
        if (eo < 0) {
            fprintf(stderr, "Try 'photongi render --help'.\n");
            return 2;
        }
        if (eo > 0) continue;
        if (strcmp(a, "--scene") == 0) scene_spec = v;
        else if (strcmp(a, "--estimator") == 0) d.estimator = v;
        else if (strcmp(a, "-o") == 0 || strcmp(a, "--out") == 0) out = v;
        else if (strcmp(a, "--stats") == 0) stats_path = v;
        else if (strcmp(a, "--photons") == 0) {
            if (!parse_long(v, 1, 4000000000LL, &n))
                return usage_error("render", "--photons needs a positive whole number of photons, got '%s'", v);
            d.photons = (uint32_t)n;
        } else if (strcmp(a, "--radius") == 0) {
            if (!parse_pos_float(v, &d.radius))
                return usage_error("render", "--radius needs a positive number (scene units), got '%s'", v);
        } else if (strcmp(a, "--size") == 0) {
            int w, h;
            char extra;
            if (sscanf(v, "%dx%d%c", &w, &h, &extra) != 2)
                return usage_error("render", "--size needs WIDTHxHEIGHT, e.g. 1280x720, got '%s'", v);
            if (w <= 0 || h <= 0) return usage_error("render", "--size must be positive, got '%s'", v);
            d.width = w;
            d.height = h;
        } else if (strcmp(a, "--bounces") == 0) {
            if (!parse_long(v, 1, 64, &n))
                return usage_error("render", "--bounces needs a number in 1..64, got '%s'", v);
            d.bounces = (int)n;
        } else if (strcmp(a, "--seed") == 0) {
            if (!parse_u64(v, &d.seed))
                return usage_error("render", "--seed needs a non-negative integer, got '%s'", v);
        } else if (strcmp(a, "--threads") == 0) {
            if (!parse_long(v, 1, 1024, &n))
                return usage_error("render", "--threads needs a number in 1..1024, got '%s'", v);
            d.threads = (int)n;
        } else if (strcmp(a, "--camera") == 0) {
            if (!parse_long(v, 0, 1000000, &n)) return usage_error("render", "--camera needs an index, got '%s'", v);
            d.camera = (int)n;
        } else if (strcmp(a, "--direct-samples") == 0) {
            if (!parse_long(v, 1, 4096, &n))
                return usage_error("render", "--direct-samples needs a number in 1..4096, got '%s'", v);
            d.direct_samples = (int)n;
        } else if (strcmp(a, "--exposure") == 0) {
            if (!parse_float(v, &exposure) || !(exposure > 0.f))
                return usage_error("render", "--exposure needs a positive number, got '%s'", v);
        } else if (strcmp(a, "--output") == 0) {
            if (strcmp(v, "all") == 0) d.output = PGI_OUTPUT_ALL;
            else if (strcmp(v, "direct") == 0) d.output = PGI_OUTPUT_DIRECT;
            else if (strcmp(v, "indirect") == 0) d.output = PGI_OUTPUT_INDIRECT;
            else if (strcmp(v, "counts") == 0) d.output = PGI_OUTPUT_PHOTON_COUNT;
            else return usage_error("render", "--output must be all, direct, indirect or counts, got '%s'", v);
        } else if (strcmp(a, "--progressive") == 0) {
            if (!parse_long(v, 1, 1000000, &n))
                return usage_error("render", "--progressive needs a frame count in 1..1000000, got '%s'", v);
            progressive = n;
        } else if (strcmp(a, "--time") == 0) {
            if (!parse_float(v, &scene_time) || !isfinite(scene_time))
                return usage_error("render", "--time needs a number of seconds, got '%s'", v);
        } else if (strcmp(a, "--radius-policy") == 0) {
            if (strcmp(v, "fixed") == 0) d.radius_policy = PGI_RADIUS_FIXED;
            else if (strcmp(v, "path") == 0) d.radius_policy = PGI_RADIUS_PATH;
            else if (strcmp(v, "differentials") == 0) d.radius_policy = PGI_RADIUS_DIFFERENTIALS;
            else return usage_error("render", "--radius-policy must be fixed, path or differentials, got '%s'", v);
        } else if (strcmp(a, "--r-min") == 0 || strcmp(a, "--r-max") == 0 || strcmp(a, "--smoothing") == 0) {
            float f;
            if (!parse_float(v, &f) || !(f > 0.f) || !isfinite(f)) {
                fprintf(stderr,
                        "photongi render: %s needs a positive number, got '%s'\nTry 'photongi render --help'.\n", a, v);
                return 2;
            }
            if (a[2] == 's') d.smoothing = f;
            else if (strcmp(a, "--r-min") == 0) d.r_min = f;
            else d.r_max = f;
        } else if (strcmp(a, "--jitter") == 0) {
            if (strcmp(v, "auto") == 0) d.jitter = PGI_JITTER_AUTO;
            else if (strcmp(v, "on") == 0) d.jitter = PGI_JITTER_ON;
            else if (strcmp(v, "off") == 0) d.jitter = PGI_JITTER_OFF;
            else return usage_error("render", "--jitter must be auto, on or off, got '%s'", v);
        } else if (strcmp(a, "--filter") == 0) {
            if (!parse_long(v, 0, 16, &n))
                return usage_error("render", "--filter needs a radius in 0..16 pixels, got '%s'", v);
            d.filter = (int)n;
        } else return usage_error("render", "unknown option '%s'", a);
    }
    if (!out) return usage_error("render", "%s", "no output file: give -o OUT.png or -o OUT.exr");
    if (d.estimator && !pgi_estimator_find(d.estimator)) {
        fprintf(stderr, "photongi render: unknown estimator '%s'; registered:", d.estimator);
        for (size_t i = 0; i < pgi_estimator_count(); i++) fprintf(stderr, " %s", pgi_estimator_at(i)->name);
        fprintf(stderr, "\n");
        return 2;
    }
    if (!quiet) app_note_ignored_options("photongi render", d.estimator, &given);
    pgi_scene *scene;
    pgi_status st = pgi_scene_load(scene_spec, &scene);
    if (st) return fail("cannot load scene", st);
    if ((st = pgi_scene_set_time(scene, scene_time))) {
        pgi_scene_destroy(scene);
        return fail("cannot set the scene time", st);
    }
    pgi_scene_info info;
    pgi_scene_get_info(scene, &info);
    char scene_name[128];
    snprintf(scene_name, sizeof scene_name, "%s", info.name);
    if (exposure == 0.f) exposure = info.defaults.exposure > 0.f ? info.defaults.exposure : 1.f;
    pgi_image img = {0};
    pgi_frame_stats fs;
    pgi_renderer *r;
    if ((st = pgi_renderer_create(scene, &r))) {
        pgi_scene_destroy(scene);
        return fail("cannot create a renderer", st);
    }
    st = progressive > 1 ? pgi_render_progressive(r, &d, (int)progressive, &img, &fs)
                         : pgi_renderer_render(r, &d, &img, &fs);
    pgi_renderer_destroy(r);
    if (st) {
        pgi_image_free(&img);
        pgi_scene_destroy(scene);
        return fail("render failed", st);
    }
    st = pgi_image_write(&img, out, exposure);
    pgi_image_free(&img);
    pgi_scene_destroy(scene);
    if (st) return fail("cannot write image", st);
    if (stats_path) {
        st = pgi_stats_write_json(&fs, stats_path);
        if (st) return fail("cannot write stats", st);
    }
    if (fs.photons_stored < (uint64_t)fs.settings.photons * (uint64_t)fs.frames)
        fprintf(stderr,
                "photongi: warning: only %" PRIu64 " photons were stored from %" PRIu64
                " paths: most light leaves the scene (the tracer stops after 64 paths per requested photon)\n",
                fs.photons_stored, fs.photons_emitted);
    if (!quiet) {
        fprintf(stderr,
                "%s: %s %dx%d, %s, %" PRIu64 " photons stored from %" PRIu64 " paths, r=%g\n"
                "  view %.1f ms | trace %.1f ms | build %.1f ms | estimate %.1f ms | direct %.1f ms | total %.1f ms\n"
                "  photon reads %" PRIu64 ", contributing %" PRIu64 " (%.1f%%)\n",
                out, scene_name, fs.width, fs.height, fs.estimator, fs.photons_stored, fs.photons_emitted,
                (double)fs.radius, fs.view_ms, fs.trace_ms, fs.build_ms, fs.estimate_ms, fs.direct_ms, fs.total_ms,
                fs.reads, fs.contributing, fs.reads ? 100.0 * (double)fs.contributing / (double)fs.reads : 0.0);
        if (fs.frames > 1)
            fprintf(stderr, "  progressive: %d frames averaged (times and counts summed), last radius %g\n", fs.frames,
                    (double)fs.radius);
        if (fs.leaf_size > 0) fprintf(stderr, "  bvh leaf-size threshold %d\n", fs.leaf_size);
        if (fs.footprint_bin_width > 0.f) {
            fprintf(stderr, "  footprint radii (before the r_max clamp):\n");
            for (int k = 0; k < PGI_FOOTPRINT_BINS; k++) {
                double lo = k * (double)fs.footprint_bin_width;
                if (k < PGI_FOOTPRINT_BINS - 1)
                    fprintf(stderr, "    %8.4g - %-8.4g %10" PRIu64 "\n", lo, lo + fs.footprint_bin_width,
                            fs.footprint_hist[k]);
                else fprintf(stderr, "    > %-17.4g %10" PRIu64 "\n", lo, fs.footprint_hist[k]);
            }
        }
    }
    return 0;
}

int main(int argc, char **argv) {
    if (argc < 2 || is_help(argv[1])) {
        fputs(k_main_help, argc < 2 ? stderr : stdout);
        return argc < 2 ? 2 : 0;
    }
    if (strcmp(argv[1], "--version") == 0) {
        printf("photongi %s\n", pgi_version());
        return 0;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "render") == 0) return cmd_render(argc - 2, argv + 2);
    if (strcmp(cmd, "estimators") == 0) return cmd_estimators(argc - 2, argv + 2);
    if (strcmp(cmd, "info") == 0) return cmd_info(argc - 2, argv + 2);
    if (strcmp(cmd, "reference") == 0) return pgi_cmd_reference(argc - 2, argv + 2);
    if (strcmp(cmd, "compare") == 0) return pgi_cmd_compare(argc - 2, argv + 2);
    fprintf(stderr, "photongi: unknown command '%s'\n\n%s", cmd, k_main_help);
    return 2;
}
