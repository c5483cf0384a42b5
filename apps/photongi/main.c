/* photongi command line: estimators, info, help (render, reference and compare
 * in their own files). A thin layer over the public API; only main() exits. */
#define _DEFAULT_SOURCE /* realpath (output.h) */
#include <errno.h>
#include <math.h>
#include <inttypes.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "photongi/photongi.h"
#include "cli.h"
#include "cmd.h"
#include "options.h"
#include "output.h"
#include "parse.h"
#include "progress.h"

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
    "  compare      PSNR, SSIM, FLIP and relMSE of an image against a reference, error maps\n"
    "  study        every estimator at equal photons and equal time against a reference: a table\n"
    "  devices      list the Vulkan devices (render --device vulkan:N) and GPU estimators\n"
    "  help [CMD]   this text, or the options of a command (as 'photongi CMD --help')\n"
    "\n"
    "Run 'photongi <command> --help' for the options of a command. Long renders show a\n"
    "progress line on a terminal (not with -q, nor when standard error is not a terminal).\n"
    "\n"
    "Exit status, every command:\n"
    "  0  success\n"
    "  2  usage error: the command line alone is wrong, whatever the files hold (an unknown\n"
    "     command, option or help topic; a missing, malformed or out-of-range value; options\n"
    "     that do not go together; an output format photongi does not write); found before\n"
    "     any file is read or any work is done\n"
    "  1  failure: the command line is well formed, but what it names or the work is not (a\n"
    "     scene, mesh, image or sidecar missing, unreadable or malformed; a scene name with\n"
    "     no built-in scene and no NAME.json; a camera the scene does not have; an output\n"
    "     folder that does not exist or cannot be written; a failed render)\n"
    "  130, 143  'reference' interrupted by SIGINT or SIGTERM, after saving what it had\n"
    "  Output paths are checked before the scene is loaded (two naming the same file: 2);\n"
    "  nothing is written before the end but 'reference' checkpoints, and each file is written\n"
    "  whole or not at all (a temporary file renamed over it). Output that does not reach\n"
    "  standard output (a full disk, /dev/full) is a failure (1).\n";

static const char *k_info_help = "usage: photongi info [--scene S]\n"
                                 "\n"
                                 "Loads a scene (same forms as 'render --scene') and prints its triangles, vertices,\n"
                                 "materials, textures, lights, bounds, camera and suggested render settings.\n"
                                 "Exit status: 0 success, 2 usage error, 1 failure (see 'photongi --help').\n";

static const char *k_est_help =
    "usage: photongi estimators [-v]\n"
    "\n"
    "Lists the registered density estimators, one name a line (-v: with a summary, whether\n"
    "it is approximate, which of --kernel, --subsample, --radius-policy it supports, and the\n"
    "devices it runs on (--device), with the options it lacks on each).\n"
    "Exit status: 0 success, 2 usage error (see 'photongi --help').\n";

/* Appends ", item" (or "item" to an empty list), truncating at cap. */
static void list_append(char *list, size_t cap, const char *item) {
    size_t n = strlen(list);
    snprintf(list + n, cap - n, "%s%s", n ? ", " : "", item);
}

static int cmd_estimators(int argc, char **argv) {
    int verbose = 0;
    for (int i = 0; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(k_est_help, stdout);
            return 0;
        }
        if (strcmp(argv[i], "-v") == 0) verbose = 1;
        else return cli_usage("estimators", "unknown option '%s'", argv[i]);
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
        /* the devices it runs on, and the options it lacks on each (the library's device table) */
        static const struct {
            pgi_device id;
            const char *name;
        } devices[] = {{PGI_DEVICE_CPU, "cpu"}, {PGI_DEVICE_VULKAN, "vulkan"}};
        char on[256] = "";
        for (size_t d = 0; d < sizeof devices / sizeof devices[0]; d++) {
            if (!pgi_estimator_runs_on(vt, devices[d].id) ||
                (devices[d].id == PGI_DEVICE_VULKAN && !pgi_vulkan_available()))
                continue;
            char without[128] = "";
            for (size_t k = 0; k < pgi_option_count(); k++) {
                const pgi_option *o = pgi_option_at(k);
                if (!pgi_estimator_takes(vt, o) || pgi_estimator_takes_on(vt, o, devices[d].id)) continue;
                char flag[64];
                snprintf(flag, sizeof flag, "--%s", o->name);
                list_append(without, sizeof without, flag);
            }
            char item[192];
            snprintf(item, sizeof item, without[0] ? "%s (without %s)" : "%s", devices[d].name, without);
            list_append(on, sizeof on, item);
        }
        printf("%-*s  devices: %s\n", width, "", on);
    }
    return 0;
}

static int cmd_info(int argc, char **argv) {
    const char *scene_spec = "cornell";
    for (int i = 0; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(k_info_help, stdout);
            return 0;
        } else if (strcmp(argv[i], "--scene") == 0) {
            if (i + 1 >= argc || !*argv[i + 1]) return cli_usage("info", "%s needs a scene", argv[i]);
            scene_spec = argv[++i];
        } else return cli_usage("info", "unknown option '%s'", argv[i]);
    }
    pgi_scene *scene;
    pgi_status st = pgi_scene_load(scene_spec, &scene);
    if (st) return cli_input_fail("info", "cannot load scene", st);
    pgi_scene_info in;
    pgi_scene_get_info(scene, &in);
    if (*in.warnings) cli_warn(0, "info", "%s", in.warnings);
    printf("scene:      %s\n", in.name);
    printf("source:     %s\n", in.source);
    printf("triangles:  %zu\n", in.triangles);
    printf("vertices:   %zu\n", in.vertices);
    if (in.cutout_materials) printf("materials:  %zu (%zu with cut-out masks)\n", in.materials, in.cutout_materials);
    else printf("materials:  %zu\n", in.materials);
    printf("glossy:     %zu mesh materials as %s\n", in.glossy_materials,
           in.specular == PGI_SPECULAR_PHONG ? "Blinn-Phong (phong)" : "microfacet plastic (ggx)");
    printf("textures:   %zu\n", in.textures);
    printf("lights:     %zu (point %zu, spot %zu, sun %zu, emissive triangles %zu, sky %zu)\n", in.lights,
           in.point_lights, in.spot_lights, in.sun_lights, in.area_triangles, in.sky_lights);
    if (in.portals) printf("portals:    %zu (openings for the sun and the sky, docs/scene-format.md)\n", in.portals);
    printf("bounds:     (%g, %g, %g) - (%g, %g, %g)\n", in.bounds_min[0], in.bounds_min[1], in.bounds_min[2],
           in.bounds_max[0], in.bounds_max[1], in.bounds_max[2]);
    printf("cameras:    %zu\n", in.cameras);
    for (size_t c = 0; c < in.cameras; c++) {
        pgi_camera_def cd;
        pgi_scene_get_camera(scene, c, &cd);
        const char *cn = pgi_scene_camera_name(scene, c);
        char label[96];
        snprintf(label, sizeof label, *cn ? "'%.64s' " : "%s", cn);
        printf("camera %zu:   %seye (%g, %g, %g) look-at (%g, %g, %g) up (%g, %g, %g) fov_y %g deg\n", c, label,
               cd.eye[0], cd.eye[1], cd.eye[2], cd.look_at[0], cd.look_at[1], cd.look_at[2], cd.up[0], cd.up[1],
               cd.up[2], cd.fov_y_deg);
    }
    const pgi_scene_defaults *d = &in.defaults;
    char radius[32];
    if (d->radius > 0.f) snprintf(radius, sizeof radius, "%g", d->radius);
    else snprintf(radius, sizeof radius, "auto");
    printf("defaults:   photons %u, radius %s, bounces %d, size %dx%d, exposure %g\n", d->photons, radius, d->bounces,
           d->width, d->height, d->exposure);
    printf("animated:   %zu objects, keyframes up to %g s\n", in.animated_objects, in.anim_duration);
    pgi_scene_destroy(scene);
    return 0;
}

static const char *k_devices_help =
    "usage: photongi devices\n"
    "\n"
    "Lists the Vulkan devices the loader finds, numbered as 'render --device vulkan:N' takes them,\n"
    "each with its type, driver and Vulkan version on the line below, and the estimators that run\n"
    "on them (docs/gpu.md). A build without the Vulkan backend, or a machine without a Vulkan\n"
    "driver, lists none (exit status 0: the CPU device is always there).\n"
    "Exit status: 0 success, 2 usage error (see 'photongi --help').\n";

static int cmd_devices(int argc, char **argv) {
    if (argc == 1 && cli_is_help(argv[0])) {
        fputs(k_devices_help, stdout);
        return 0;
    }
    if (argc > 0) return cli_usage("devices", "unexpected argument '%s'", argv[0]);
    printf("cpu: the CPU (default, every estimator)\n");
    if (!pgi_vulkan_available()) {
        printf("vulkan: none (this build of photongi has no Vulkan backend: built without Vulkan/glslc)\n");
        return 0;
    }
    int n = pgi_device_count();
    if (n == 0) printf("vulkan: no device (no Vulkan driver: install mesa-vulkan-drivers or a GPU driver)\n");
    for (int i = 0; i < n; i++) {
        char name[256], driver[512];
        if (pgi_device_name(i, name, sizeof name) == PGI_OK) printf("vulkan:%d: %s\n", i, name);
        if (pgi_device_driver(i, driver, sizeof driver) == PGI_OK) printf("          %s\n", driver);
    }
    char names[256];
    pgi_device_estimators(names, sizeof names);
    printf("GPU estimators: %s\n", names);
    return 0;
}

typedef struct command {
    const char *name;
    int (*run)(int argc, char **argv);
} command;

static const command k_commands[] = {{"render", pgi_cmd_render},   {"estimators", cmd_estimators},
                                     {"info", cmd_info},           {"reference", pgi_cmd_reference},
                                     {"compare", pgi_cmd_compare}, {"devices", cmd_devices},
                                     {"study", pgi_cmd_study}};

static const command *find_command(const char *name) {
    for (size_t i = 0; i < sizeof k_commands / sizeof k_commands[0]; i++)
        if (strcmp(name, k_commands[i].name) == 0) return &k_commands[i];
    return NULL;
}

/* photongi help [COMMAND]: the main help, or the command's own --help. */
static int cmd_help(int argc, char **argv) {
    if (argc == 0) {
        fputs(k_main_help, stdout);
        return 0;
    }
    const command *c = find_command(argv[0]);
    if (argc > 1 || !c) {
        char names[128] = "";
        for (size_t i = 0; i < sizeof k_commands / sizeof k_commands[0]; i++)
            list_append(names, sizeof names, k_commands[i].name);
        if (argc > 1) fprintf(stderr, "photongi help: takes one command at most (%s)\n", names);
        else
            fprintf(stderr, "photongi help: unknown help topic '%s'; the topics are the commands: %s\n", argv[0],
                    names);
        fprintf(stderr, "Try 'photongi --help'.\n");
        return CLI_EXIT_USAGE;
    }
    char help[] = "--help";
    char *args[] = {help, NULL};
    return c->run(1, args);
}

static int run(int argc, char **argv) {
    if (argc < 2 || cli_is_help(argv[1])) {
        fputs(k_main_help, argc < 2 ? stderr : stdout);
        return argc < 2 ? CLI_EXIT_USAGE : 0;
    }
    if (strcmp(argv[1], "--version") == 0) {
        printf("photongi %s\n", pgi_version());
        return 0;
    }
    if (strcmp(argv[1], "help") == 0) return cmd_help(argc - 2, argv + 2);
    const command *c = find_command(argv[1]);
    if (c) return c->run(argc - 2, argv + 2);
    fprintf(stderr, "photongi: unknown command '%s'\n\n%s", argv[1], k_main_help);
    return CLI_EXIT_USAGE;
}

int main(int argc, char **argv) {
    /* A file size limit (ulimit -f) makes a write fail, reported as a full disk is, rather than
       killing the process half way through a file. */
    signal(SIGXFSZ, SIG_IGN);
    int rc = run(argc, argv);
    /* Whatever a command printed must have reached standard output (not a full disk, /dev/full, a
       closed pipe): a result that was not delivered is a failure. */
    errno = 0;
    int e = fflush(stdout) != 0 ? errno : 0;
    if (e || ferror(stdout)) {
        fprintf(stderr, "photongi%s%s: cannot write to standard output: %s\n", argc > 1 ? " " : "",
                argc > 1 ? argv[1] : "", e ? strerror(e) : "write error");
        return rc ? rc : CLI_EXIT_FAILURE;
    }
    return rc;
}
