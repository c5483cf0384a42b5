/* photongi-view: interactive viewer. Renders continuously through the public
 * pgi_renderer API (every frame: view samples, photons, estimator build +
 * estimate, direct light), accumulates progressively while nothing changes,
 * and draws an overlay (overlay.h: a built-in bitmap font over a dimmed
 * box). With --frames N it runs headless (no window, no display needed) and
 * can save a screenshot. */
#include <SDL.h>
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "camera.h"
#include "device.h"
#include "held.h"
#include "overlay.h"
#include "photongi/photongi.h"
#include "options.h"
#include "parse.h"
#include "render_options.h"

static const char *k_help =
    "usage: photongi-view [--scene S] [options]\n"
    "\n"
    "Interactive photon-mapping viewer. Every frame traces fresh photons, rebuilds the view\n"
    "samples and the estimator's structures, and shows emission + direct + indirect light.\n"
    "While nothing changes it averages frames progressively (fresh photons, shrinking radius,\n"
    "Knaus & Zwicker 2011), so the picture converges.\n"
    "\n"
    "  --scene S          as 'photongi render --scene' (default cornell; scenes/cornell-moving.json\n"
    "                     has animated objects)\n"
    "  --estimator E      density estimator (default " PGI_DEFAULT_ESTIMATOR ", the fastest exact one at the\n"
    "                     shipped scenes' defaults; Tab switches live)\n"
    "  --photons N        photons to store (default: the scene's, else 200000)\n"
    "  --radius R|auto    photon radius (default: the scene's, else auto: chosen each frame from\n"
    "                     the photon density the camera sees; docs/radius.md)\n"
    "  --size WxH         window / full render size (default: the scene's, else 1280x720)\n"
    "  --scale F          render at F times the window size (0 < F <= 1; default 1)\n"
    "  --seed K           random seed (default 1)\n"
    "  --bounces B        maximum photon bounces (default 4)\n"
    "  --direct-samples K shadow samples per pixel for area lights and the sky (default 16;\n"
    "                     4 in a scene with a sky and portals)\n"
    "  --threads T        worker threads (default: all cores)\n" APP_DEVICE_HELP
    "  --camera NAME|I    scene camera to start from, by name or index (default 0)\n"
    "  --eye X,Y,Z, --look-at X,Y,Z, --up X,Y,Z, --fov DEG   start from this camera instead,\n"
    "                     as 'photongi render' (the parts not given are the --camera's)\n"
    "  --camera-out FILE  where V saves the camera's JSON block (default photongi-camera.json)\n"
    "  --max-frames N     a still view stops rendering after N frames (progressive: N frames\n"
    "                     averaged) and waits for input; 0: never (default 256)\n"
    "  --exposure X       exposure before the sRGB tone map (default: the scene's, else 1)\n"
    "  --output all|direct|indirect|counts   what to show (counts: false-colour photons per pixel)\n"
    "  --emission uniform|guided|auto|portal   photon emission, as 'photongi render --emission'\n"
    "                     (default auto; docs/emission.md)\n"
    "  --store all|view   photons stored, as 'photongi render --store' (view needs --radius)\n"
    "  --time T           scene time in seconds to start at (default 0)\n"
    "  --animate          advance the scene time (real time in a window, 1/30 s a frame headless;\n"
    "                     on by default in a window when the scene has animated objects)\n"
    "  --no-accumulate    never average frames (every frame is a fresh single frame)\n"
    "  --temporal on|off  temporal reuse and the a-trous filter of the indirect light while the\n"
    "                     camera moves (docs/temporal.md; CPU device): on interactively, off with\n"
    "                     --frames\n"
    "  --history N|off    frames the reprojected picture weighs at most (1..256; default 16)\n"
    "  --denoise N|off    a-trous passes on the indirect light (1..5; default 4)\n"
    "  --frames N         render N frames and exit; without --window no window is opened\n"
    "  --window           open a window even with --frames (e.g. SDL_VIDEODRIVER=offscreen)\n"
    "  --screenshot FILE  after the last frame, save the image, no overlay (.png, or .exr: linear)\n"
    "  --stats FILE.json  write the last frame's statistics ('-' = stdout)\n"
    "  --max-memory SIZE|none   memory budget (4G, 512M; default: the machine's memory): a frame\n"
    "                     that would need more is refused and the previous settings kept\n"
    "                     (both paths are checked before the scene loads)\n"
    "  --keys K1,K2,...   press these keys, one before each frame (scripted demos and tests): a\n"
    "                     character, or tab, shift+tab, space, up, down, left, right, pageup,\n"
    "                     pagedown, f12, escape, comma; movement keys take one fixed step (2% of\n"
    "                     the scene's diagonal, times the speed of X / Z); j/k turn. KEY@SECONDS\n"
    "                     is pressed that long into the next frame, abandoning it as input does\n"
    "  -q, --quiet        print nothing but errors\n"
    "\n"
    "Without a display (DISPLAY, WAYLAND_DISPLAY) and without --frames it stops with a message\n"
    "rather than run in SDL's invisible offscreen window (SDL_VIDEODRIVER=offscreen asks for that).\n"
    "\n"
    "keys: mouse drag (left button) look | W A S D move, Q E down/up: a quarter of the scene's\n"
    "      diagonal per second held (wall time, whatever the frame rate; every press counts),\n"
    "      Shift x4, Ctrl x0.2 | mouse wheel or X / Z: speed x1.25 a notch / x2 / x0.5\n"
    "      V print the camera (the JSON block and the 'photongi render' line) and save it\n"
    "      L next light, arrows or Ctrl+drag move it (camera-relative), PgUp/PgDn raise/lower it\n"
    "      Tab / Shift+Tab next/previous estimator, 1-9 pick estimator (not brute, the\n"
    "      O(photons x pixels) oracle, minutes a frame: --estimator brute only)\n"
    "      + / - photons x2 / /2, ] / [ radius x1.25 / /1.25, . / , exposure\n"
    "      O output all/direct/indirect, C photons-per-pixel false colour, P progressive on/off\n"
    "      T temporal reuse on/off, F the indirect light's filter on/off (the overlay says which)\n"
    "      R resolution scale 100/50/25%, Space pause animation, H overlay, F12 screenshot, Esc quit\n"
    "\n";

#define MAX_FRAMES_TIMED 100000

typedef struct viewer {
    pgi_scene *scene;
    pgi_renderer *r;
    pgi_progressive *prog; /* running average while nothing changes */
    pgi_scene_info info;
    pgi_render_desc desc;
    pgi_camera_def cam;
    int cam_moved; /* 0: still exactly the scene's camera */
    float yaw, pitch, diag;
    size_t est_index;
    int out_mode; /* pgi_output */
    int accumulate, animate, overlay, quiet;
    float scale, exposure;
    double time;
    size_t light; /* selected light group */
    int win_w, win_h;
    pgi_image img;
    pgi_frame_stats fs;
    unsigned char *rgb8; /* render resolution, tone-mapped (unused at full scale but for false colour) */
    unsigned char *disp; /* window resolution, with overlay */
    double frame_ms, fps;
    int screenshot_count;
    const char *scene_spec;  /* as given (--scene), for the printed command line */
    const char *camera_out;  /* where V saves the camera's JSON block */
    char est_opts[1024];     /* estimator options as given (" --name value"), for the printed command line */
    float speed_mul;         /* movement speed factor (mouse wheel, X / Z) */
    pgi_cancel *cancel;      /* abandons the frame in progress when input arrives (render_watched) */
    pgi_temporal *temporal;  /* the moving picture's history and filter (NULL: off) */
    pgi_temporal_desc tdesc; /* its settings; T and F toggle them */
    int temporal_on;         /* 1: frames go through `temporal` (CPU, accumulating, not counts) */
} viewer;

static int usage(const char *fmt, const char *arg) {
    fprintf(stderr, "photongi-view: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\nTry 'photongi-view --help'.\n");
    return 2;
}

static int fail(const char *what, pgi_status st) {
    const char *msg = pgi_last_error();
    fprintf(stderr, "photongi-view: %s: %s\n", what, *msg ? msg : pgi_status_string(st));
    return st == PGI_ERR_INVALID_ARG ? 2 : 1;
}

/* ------------------------------------------------------------ camera */

static void v_sub(const float *a, const float *b, float *o) {
    o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}
static void v_cross(const float *a, const float *b, float *o) {
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}
static void v_norm(float *a) {
    float l = sqrtf(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    if (l > 0.f) a[0] /= l, a[1] /= l, a[2] /= l;
}

static void cam_forward(const viewer *v, float f[3]) {
    f[0] = cosf(v->pitch) * sinf(v->yaw);
    f[1] = sinf(v->pitch);
    f[2] = -cosf(v->pitch) * cosf(v->yaw);
}

static void cam_init_angles(viewer *v) {
    float f[3];
    v_sub(v->cam.look_at, v->cam.eye, f);
    v_norm(f);
    v->yaw = atan2f(f[0], -f[2]);
    v->pitch = asinf(fmaxf(-1.f, fminf(1.f, f[1])));
}

/* Look-at from yaw/pitch; the scene's own camera is kept bit-exact until the user moves. */
static void cam_update(viewer *v) {
    float f[3];
    cam_forward(v, f);
    for (int k = 0; k < 3; k++) v->cam.look_at[k] = v->cam.eye[k] + f[k];
    v->cam.up[0] = 0.f, v->cam.up[1] = 1.f, v->cam.up[2] = 0.f;
    v->cam_moved = 1;
}

static void cam_move(viewer *v, float fwd, float side, float upd) {
    float f[3], r[3], up[3] = {0.f, 1.f, 0.f};
    cam_forward(v, f);
    v_cross(f, up, r);
    v_norm(r);
    for (int k = 0; k < 3; k++) v->cam.eye[k] += f[k] * fwd + r[k] * side + up[k] * upd;
    cam_update(v);
}

static void light_move(viewer *v, float fwd, float side, float upd) {
    size_t n = pgi_scene_light_group_count(v->scene);
    if (n == 0) return;
    pgi_light_group g;
    if (pgi_scene_get_light_group(v->scene, v->light % n, &g) != PGI_OK || g.kind == PGI_LIGHT_KIND_SUN) return;
    float f[3], r[3], up[3] = {0.f, 1.f, 0.f};
    cam_forward(v, f);
    f[1] = 0.f; /* arrows move in the horizontal plane */
    v_norm(f);
    v_cross(f, up, r);
    v_norm(r);
    for (int k = 0; k < 3; k++) g.position[k] += f[k] * fwd + r[k] * side + up[k] * upd;
    pgi_status st = pgi_scene_set_light_position(v->scene, v->light % n, g.position);
    if (st && !v->quiet) fprintf(stderr, "photongi-view: cannot move the light: %s\n", pgi_last_error());
}

/* ------------------------------------------------------------ drawing */

/* Photons per pixel as false colour: 0 black, then blue -> green -> yellow -> red on a log scale. */
static void false_colour(const pgi_image *img, unsigned char *out) {
    size_t n = (size_t)img->width * img->height;
    float mx = 1.f;
    for (size_t i = 0; i < n; i++) mx = fmaxf(mx, img->rgb[3 * i]);
    float lm = logf(1.f + mx);
    for (size_t i = 0; i < n; i++) {
        float c = img->rgb[3 * i];
        unsigned char *o = out + 3 * i;
        if (!(c > 0.f)) {
            o[0] = o[1] = o[2] = 0;
            continue;
        }
        float t = logf(1.f + c) / lm, r, g, b;
        if (t < 0.33f) r = 0.f, g = t / 0.33f, b = 1.f - t / 0.33f;
        else if (t < 0.66f) r = (t - 0.33f) / 0.33f, g = 1.f, b = 0.f;
        else r = 1.f, g = 1.f - (t - 0.66f) / 0.34f, b = 0.f;
        o[0] = (unsigned char)(255.f * r + 0.5f);
        o[1] = (unsigned char)(255.f * g + 0.5f);
        o[2] = (unsigned char)(255.f * b + 0.5f);
    }
}

static const char *output_name(int m) {
    static const char *const names[] = {"all", "indirect", "direct", "photons/pixel"};
    return m >= 0 && m <= 3 ? names[m] : "?";
}

/* The image at window size (unless render_frame tone-mapped it there already), then the overlay. */
static void compose(viewer *v, int in_place) {
    const int W = v->win_w, H = v->win_h, w = v->img.width, h = v->img.height;
    if (!in_place && W == w && H == h) memcpy(v->disp, v->rgb8, (size_t)W * H * 3); /* false colour */
    else if (!in_place)
        for (int y = 0; y < H; y++) {
            int sy = (int)((long long)y * h / H);
            for (int x = 0; x < W; x++) {
                int sx = (int)((long long)x * w / W);
                memcpy(v->disp + 3 * ((size_t)y * W + x), v->rgb8 + 3 * ((size_t)sy * w + sx), 3);
            }
        }
    if (!v->overlay) return;
    const pgi_frame_stats *fst = &v->fs;
    char line[6][256];
    size_t ne = pgi_estimator_count();
    snprintf(line[0], sizeof line[0], "%s | %s (%zu/%zu) on %s | %.1f FPS, %.0f ms a frame", v->info.name,
             fst->estimator, v->est_index + 1, ne, fst->device ? fst->device : "cpu", v->fps, v->frame_ms);
    snprintf(line[1], sizeof line[1], "view %.1f  trace %.1f  build %.1f  estimate %.1f  direct %.1f  rt %.1f ms",
             fst->view_ms, fst->trace_ms, fst->build_ms, fst->estimate_ms, fst->direct_ms, fst->rt_update_ms);
    int o = 0;
    o += snprintf(line[2] + o, sizeof line[2] - (size_t)o, "passes:");
    for (int i = 0; i < fst->pass_count && o < (int)sizeof line[2] - 40; i++)
        o += snprintf(line[2] + o, sizeof line[2] - (size_t)o, " %s %.1f", fst->passes_ms[i].name,
                      fst->passes_ms[i].value);
    snprintf(line[3], sizeof line[3], "photons %llu stored / %llu paths, r %.4g, contributing %.1f%% of %llu reads",
             (unsigned long long)fst->photons_stored, (unsigned long long)fst->photons_emitted, (double)fst->radius,
             fst->reads ? 100.0 * (double)fst->contributing / (double)fst->reads : 0.0, (unsigned long long)fst->reads);
    pgi_light_group g = {0};
    size_t nl = pgi_scene_light_group_count(v->scene);
    if (nl) pgi_scene_get_light_group(v->scene, v->light % nl, &g);
    char tline[96];
    if (fst->temporal.on)
        snprintf(tline, sizeof tline, " | T reuse %s (history %.1f), F filter %s (%.0f%%)",
                 v->tdesc.history == PGI_TEMPORAL_OFF ? "off" : "on", fst->temporal.history,
                 v->tdesc.filter == PGI_TEMPORAL_OFF ? "off" : "on", 100.0 * fst->temporal.filter_weight);
    else snprintf(tline, sizeof tline, " | T reuse / F filter off");
    snprintf(line[4], sizeof line[4], "%dx%d (%.0f%%) | %s | frames %d%s%s | t %.2f s%s | light %zu/%zu %s", fst->width,
             fst->height, 100.0 * v->scale, output_name(v->out_mode), fst->frames,
             v->accumulate ? "" : " (no accumulation)", tline, v->time, v->animate ? "" : " (paused)",
             nl ? v->light % nl + 1 : 0, nl, nl ? g.name : "-");
    double mem = 0.0;
    for (int i = 0; i < fst->memory_count; i++) mem += fst->memory_bytes[i].value;
    snprintf(line[5], sizeof line[5],
             "memory %.0f MiB counted, peak RSS %.0f MiB | speed x%.3g | V prints the camera | H hides this; see "
             "--help for keys",
             mem / 1048576.0, (double)fst->memory_peak_rss / 1048576.0, (double)v->speed_mul);
    static const unsigned char yellow[3] = {255, 220, 0};
    /* Marker on the selected light (point lights are invisible otherwise). */
    if (nl && g.kind != PGI_LIGHT_KIND_SUN) {
        float f[3], r[3], u[3], d[3];
        v_sub(v->cam.look_at, v->cam.eye, f);
        v_norm(f);
        v_cross(f, v->cam.up, r);
        v_norm(r);
        v_cross(r, f, u);
        v_sub(g.position, v->cam.eye, d);
        float z = d[0] * f[0] + d[1] * f[1] + d[2] * f[2], th = tanf(0.5f * v->cam.fov_y_deg * 3.14159265f / 180.f);
        if (z > 0.f) {
            float x = (d[0] * r[0] + d[1] * r[1] + d[2] * r[2]) / (z * th * ((float)W / (float)H));
            float y = (d[0] * u[0] + d[1] * u[1] + d[2] * u[2]) / (z * th);
            int px = (int)((x + 1.f) * 0.5f * (float)W), py = (int)((1.f - y) * 0.5f * (float)H);
            for (int k = -8; k <= 8; k++) {
                if (px + k >= 0 && px + k < W && py >= 0 && py < H)
                    memcpy(v->disp + 3 * ((size_t)py * W + px + k), yellow, 3);
                if (py + k >= 0 && py + k < H && px >= 0 && px < W)
                    memcpy(v->disp + 3 * ((size_t)(py + k) * W + px), yellow, 3);
            }
        }
    }
    int sc = W >= 1000 ? 2 : 1;
    const char *const lines[6] = {line[0], line[1], line[2], line[3], line[4], line[5]};
    const unsigned char colours[6][3] = {{255, 255, 255}, {255, 255, 255}, {255, 255, 255},
                                         {255, 255, 255}, {255, 255, 255}, {190, 190, 190}};
    overlay_lines(v->disp, W, H, 6 * sc, 6 * sc, sc, lines, 6, colours, NULL);
}

/* ------------------------------------------------------------ frames */

/* The settings of a frame as render_frame gives them to the library. */
static void frame_desc(const viewer *v, pgi_render_desc *d) {
    *d = v->desc;
    d->estimator = pgi_estimator_at(v->est_index)->name;
    d->width = (int)lroundf((float)v->win_w * v->scale);
    d->height = (int)lroundf((float)v->win_h * v->scale);
    if (d->width < 1) d->width = 1;
    if (d->height < 1) d->height = 1;
    d->view = v->cam_moved ? &v->cam : NULL;
    d->output = (pgi_output)v->out_mode;
}

/* Temporal reuse and the filter run on the CPU device, on an accumulated picture. */
static int temporal_applies(const viewer *v) {
    return v->desc.device == PGI_DEVICE_CPU && v->accumulate && v->out_mode != PGI_OUTPUT_PHOTON_COUNT &&
           (v->tdesc.history != PGI_TEMPORAL_OFF || v->tdesc.filter != PGI_TEMPORAL_OFF);
}

/* (Re)creates the temporal accumulator from v->tdesc (T and F change it); NULL when both are off. */
static pgi_status temporal_renew(viewer *v) {
    pgi_temporal_destroy(v->temporal);
    v->temporal = NULL;
    if (v->tdesc.history == PGI_TEMPORAL_OFF && v->tdesc.filter == PGI_TEMPORAL_OFF) return PGI_OK;
    return pgi_temporal_create(v->r, &v->tdesc, &v->temporal);
}

static pgi_status render_frame(viewer *v) {
    pgi_render_desc d;
    frame_desc(v, &d);
    d.cancel = v->cancel;
    pgi_status st = pgi_scene_set_time(v->scene, v->time);
    if (st) return st;
    if (v->temporal && temporal_applies(v)) st = pgi_temporal_step(v->temporal, &d, &v->img, &v->fs);
    else if (v->accumulate && v->out_mode != PGI_OUTPUT_PHOTON_COUNT)
        st = pgi_progressive_step(v->prog, &d, &v->img, &v->fs);
    else st = pgi_renderer_render(v->r, &d, &v->img, &v->fs);
    if (st) return st;
    /* At full scale the tone map writes straight into the window's image (false colour keeps
     * rgb8: its screenshot is made from it). */
    const int in_place =
        v->img.width == v->win_w && v->img.height == v->win_h && v->out_mode != PGI_OUTPUT_PHOTON_COUNT;
    if (in_place) pgi_tonemap_srgb8(&v->img, v->exposure, v->disp);
    else {
        size_t n = (size_t)v->img.width * v->img.height;
        unsigned char *nb = realloc(v->rgb8, 3 * n);
        if (!nb) return PGI_ERR_OOM;
        v->rgb8 = nb;
        if (v->out_mode == PGI_OUTPUT_PHOTON_COUNT) false_colour(&v->img, v->rgb8);
        else pgi_tonemap_srgb8(&v->img, v->exposure, v->rgb8);
    }
    compose(v, in_place);
    return PGI_OK;
}

/* The rendered image without overlay; false colour is written through the
 * inverse sRGB curve so that the PNG holds the colours shown. */
static pgi_status save_screenshot(viewer *v, const char *path) {
    if (v->out_mode != PGI_OUTPUT_PHOTON_COUNT) return pgi_image_write(&v->img, path, v->exposure);
    size_t n = (size_t)v->img.width * v->img.height;
    pgi_image lin = {v->img.width, v->img.height, malloc(3 * n * sizeof(float))};
    if (!lin.rgb) return PGI_ERR_OOM;
    for (size_t i = 0; i < 3 * n; i++) {
        float c = v->rgb8[i] / 255.f;
        lin.rgb[i] = c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f);
    }
    pgi_status st = pgi_image_write(&lin, path, 1.f);
    pgi_image_free(&lin);
    return st;
}

/* ------------------------------------------------------------ a frame that input abandons */

typedef struct frame_job {
    viewer *v;
    pgi_status st;
    SDL_sem *done; /* posted when the frame returns */
} frame_job;

static int frame_worker(void *user) {
    frame_job *j = user;
    j->st = render_frame(j->v);
    SDL_SemPost(j->done);
    return 0;
}

/* Input that abandons a frame in progress, left queued for the main loop: closing the window, a
 * key pressed or released (not the repeats of a key held down: a held movement key moves by the
 * time held, and frames go on being finished while it moves), a mouse button, the wheel. */
static int input_waiting(void) {
    SDL_PumpEvents();
    if (SDL_PeepEvents(NULL, 0, SDL_PEEKEVENT, SDL_QUIT, SDL_QUIT) > 0 ||
        SDL_PeepEvents(NULL, 0, SDL_PEEKEVENT, SDL_MOUSEBUTTONDOWN, SDL_MOUSEWHEEL) > 0)
        return 1;
    SDL_Event e[64];
    const int n = SDL_PeepEvents(e, 64, SDL_PEEKEVENT, SDL_KEYDOWN, SDL_KEYUP);
    for (int i = 0; i < n; i++)
        if (!e[i].key.repeat) return 1;
    return 0;
}

/* Renders a frame (render_frame) on a worker thread while this thread watches for input (in a
 * window: input_waiting) and for a scripted key due `due_s` seconds after the frame started
 * (--keys KEY@SECONDS; < 0: none). Either asks the frame to stop (pgi_cancel_request): it then
 * returns PGI_ERR_CANCELLED within a fraction of a second, whatever the estimator, and *late_ms
 * gets the time from the request to its return (else -1). */
static pgi_status render_watched(viewer *v, int in_window, double due_s, double *late_ms) {
    *late_ms = -1.0;
    pgi_cancel_reset(v->cancel);
    frame_job j = {.v = v, .st = PGI_OK, .done = SDL_CreateSemaphore(0)};
    SDL_Thread *th = j.done ? SDL_CreateThread(frame_worker, "photongi-frame", &j) : NULL;
    if (!th) { /* no thread to spare: a frame that runs to its end */
        if (j.done) SDL_DestroySemaphore(j.done);
        return render_frame(v);
    }
    const double f = (double)SDL_GetPerformanceFrequency(), t0 = (double)SDL_GetPerformanceCounter() / f;
    double asked = -1.0;
    while (SDL_SemWaitTimeout(j.done, asked < 0.0 ? 4 : 1) != 0) { /* returns as soon as the frame does */
        const double now = (double)SDL_GetPerformanceCounter() / f;
        if (asked < 0.0 && ((due_s >= 0.0 && now - t0 >= due_s) || (in_window && input_waiting()))) {
            asked = now;
            pgi_cancel_request(v->cancel);
        }
    }
    SDL_WaitThread(th, NULL);
    SDL_DestroySemaphore(j.done);
    if (asked >= 0.0) *late_ms = 1000.0 * ((double)SDL_GetPerformanceCounter() / f - asked);
    return j.st;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Tab and the number keys reach every estimator but the oracle (brute: O(photons x pixels), a
 * frame of minutes that cannot be interrupted); --estimator brute still selects it. */
static int key_selectable(size_t i) { return !pgi_estimator_at(i)->oracle; }

static void cycle_estimator(viewer *v, int step) {
    size_t n = pgi_estimator_count(), i = v->est_index;
    for (size_t tries = 0; tries < n; tries++) {
        i = (i + n + (size_t)(step % (int)n + (int)n)) % n;
        if (key_selectable(i)) {
            v->est_index = i;
            return;
        }
    }
}

/* Number key k (0-based): the k-th estimator Tab reaches, in registry order; 0 when there is none. */
static int pick_estimator(viewer *v, size_t k) {
    for (size_t i = 0; i < pgi_estimator_count(); i++)
        if (key_selectable(i) && k-- == 0) {
            v->est_index = i;
            return 1;
        }
    return 0;
}

static void change_radius(viewer *v, float f) { v->desc.radius = v->fs.radius * f; }

static void change_photons(viewer *v, double f) {
    double p = (double)v->fs.settings.photons * f; /* what the last frame used, defaults resolved */
    if (p < 1000) p = 1000;
    if (p > 50e6) p = 50e6;
    v->desc.photons = (uint32_t)p;
}

/* s for a shell: as is when it holds only safe characters, else in single quotes. */
static void shell_word(const char *s, char *out, size_t size) {
    int safe = *s != 0;
    for (const char *p = s; *p; p++) safe &= strchr("+-./:=@_,", *p) != NULL || isalnum((unsigned char)*p);
    if (safe) {
        snprintf(out, size, "%s", s);
        return;
    }
    size_t o = 0;
    if (o + 1 < size) out[o++] = '\'';
    for (const char *p = s; *p && o + 5 < size; p++) {
        if (*p == '\'') memcpy(out + o, "'\\''", 4), o += 4;
        else out[o++] = *p;
    }
    if (o + 1 < size) out[o++] = '\'';
    out[o] = 0;
}

/* The camera now (the scene's, or the one moved to). */
static pgi_camera_def current_camera(const viewer *v) {
    pgi_camera_def c = v->cam;
    if (!v->cam_moved) pgi_scene_get_camera(v->scene, (size_t)v->desc.camera, &c);
    return c;
}

/* The `photongi render` command line of the frame shown: the camera's flags and the settings
 * given (defaults are the same in both programs), --progressive for the frames averaged. */
static void command_line(const viewer *v, char *buf, size_t size) {
    pgi_render_desc d;
    frame_desc(v, &d);
    const pgi_camera_def c = current_camera(v);
    char w[4200], cam[400];
    shell_word(v->scene_spec, w, sizeof w);
    app_camera_flags(&c, cam, sizeof cam);
    int o = snprintf(buf, size, "photongi render --scene %s --size %dx%d --estimator %s", w, d.width, d.height,
                     d.estimator);
#define ADD_(...)                                                                                                      \
    do {                                                                                                               \
        if (o > 0 && (size_t)o < size) o += snprintf(buf + o, size - (size_t)o, __VA_ARGS__);                          \
    } while (0)
    if (v->est_opts[0]) ADD_("%s", v->est_opts);
    if (d.photons) ADD_(" --photons %u", d.photons);
    if (d.radius == PGI_RADIUS_AUTO) ADD_(" --radius auto");
    else if (d.radius > 0.f) ADD_(" --radius %.9g", (double)d.radius);
    if (d.seed) ADD_(" --seed %llu", (unsigned long long)d.seed);
    if (d.bounces) ADD_(" --bounces %d", d.bounces);
    if (d.direct_samples) ADD_(" --direct-samples %d", d.direct_samples);
    if (d.emission != PGI_EMISSION_AUTO)
        ADD_(" --emission %s", d.emission == PGI_EMISSION_GUIDED    ? "guided"
                               : d.emission == PGI_EMISSION_UNIFORM ? "uniform"
                                                                    : "portal");
    if (d.store == PGI_STORE_VIEW) ADD_(" --store view");
    if (d.device == PGI_DEVICE_VULKAN) ADD_(" --device vulkan");
    if (d.output != PGI_OUTPUT_ALL)
        ADD_(" --output %s", d.output == PGI_OUTPUT_DIRECT     ? "direct"
                             : d.output == PGI_OUTPUT_INDIRECT ? "indirect"
                                                               : "counts");
    if (v->time != 0.0) ADD_(" --time %.9g", v->time);
    ADD_(" --exposure %.9g", (double)v->exposure);
    if (v->accumulate && d.output != PGI_OUTPUT_PHOTON_COUNT && v->fs.frames > 1)
        ADD_(" --progressive %d", v->fs.frames);
    if (v->desc.camera) ADD_(" --camera %d", v->desc.camera);
    ADD_(" %s -o view.png", cam);
#undef ADD_
}

/* V: the camera as the JSON camera block of a scene description and as the command line that
 * renders the frame shown, on stdout; the block is saved to v->camera_out. */
static void print_camera(const viewer *v) {
    const pgi_camera_def c = current_camera(v);
    char block[512], cmd[8192];
    app_camera_json(&c, block, sizeof block);
    command_line(v, cmd, sizeof cmd);
    printf("camera: %s\nrender: %s\n", block, cmd);
    fflush(stdout);
    FILE *f = fopen(v->camera_out, "w");
    int bad = !f || fprintf(f, "%s\n", block) < 0;
    if (f && fclose(f) != 0) bad = 1;
    if (bad) fprintf(stderr, "photongi-view: cannot write the camera to %s: %s\n", v->camera_out, strerror(errno));
    else if (!v->quiet) fprintf(stderr, "photongi-view: camera saved to %s\n", v->camera_out);
}

/* Handles one key press; returns 0 to quit, 2 for a key that leaves the picture as it is (V, F12,
 * the speed keys: a still view stays idle), else 1. `step` > 0 (scripted keys): the
 * movement keys move the camera or the light by that distance once (held
 * keys in a window move continuously instead, see the main loop). */
static int press_key(viewer *v, SDL_Keycode k, int shift, float step) {
    if (k == SDLK_ESCAPE) return 0;
    if (k == SDLK_TAB) cycle_estimator(v, shift ? -1 : 1);
    else if (k >= SDLK_1 && k <= SDLK_9) pick_estimator(v, (size_t)(k - SDLK_1));
    else if (k == SDLK_EQUALS || k == SDLK_PLUS || k == SDLK_KP_PLUS) change_photons(v, 2.0);
    else if (k == SDLK_MINUS || k == SDLK_KP_MINUS) change_photons(v, 0.5);
    else if (k == SDLK_RIGHTBRACKET) change_radius(v, 1.25f);
    else if (k == SDLK_LEFTBRACKET) change_radius(v, 1.f / 1.25f);
    else if (k == SDLK_PERIOD) v->exposure *= 1.25f;
    else if (k == SDLK_COMMA) v->exposure /= 1.25f;
    else if (k == SDLK_o)
        v->out_mode = v->out_mode == PGI_OUTPUT_ALL      ? PGI_OUTPUT_DIRECT
                      : v->out_mode == PGI_OUTPUT_DIRECT ? PGI_OUTPUT_INDIRECT
                                                         : PGI_OUTPUT_ALL;
    else if (k == SDLK_c)
        v->out_mode = v->out_mode == PGI_OUTPUT_PHOTON_COUNT ? PGI_OUTPUT_ALL : PGI_OUTPUT_PHOTON_COUNT;
    else if (k == SDLK_p) v->accumulate = !v->accumulate;
    else if (k == SDLK_t || k == SDLK_f) {
        int *field = k == SDLK_t ? &v->tdesc.history : &v->tdesc.filter;
        *field = *field == PGI_TEMPORAL_OFF ? 0 : PGI_TEMPORAL_OFF;
        pgi_status st = temporal_renew(v);
        if (st) fprintf(stderr, "photongi-view: %s\n", pgi_last_error());
    } else if (k == SDLK_r) v->scale = v->scale > 0.75f ? 0.5f : v->scale > 0.375f ? 0.25f : 1.f;
    else if (k == SDLK_SPACE) v->animate = !v->animate;
    else if (k == SDLK_h) v->overlay = !v->overlay;
    else if (k == SDLK_l) v->light++;
    else if (k == SDLK_v) {
        print_camera(v);
        return 2;
    } else if (k == SDLK_x || k == SDLK_z) {
        v->speed_mul = fminf(1e3f, fmaxf(1e-3f, v->speed_mul * (k == SDLK_x ? 2.f : 0.5f)));
        if (!v->quiet) fprintf(stderr, "photongi-view: movement speed x%.3g\n", (double)v->speed_mul);
        return 2;
    } else if (k == SDLK_F12) {
        char name[64];
        snprintf(name, sizeof name, "photongi-view-%03d.png", v->screenshot_count++);
        if (save_screenshot(v, name)) fprintf(stderr, "photongi-view: %s\n", pgi_last_error());
        else if (!v->quiet) fprintf(stderr, "photongi-view: wrote %s\n", name);
        return 2;
    } else if (step > 0.f) {
        if (k == SDLK_w) cam_move(v, step, 0.f, 0.f);
        else if (k == SDLK_s) cam_move(v, -step, 0.f, 0.f);
        else if (k == SDLK_d) cam_move(v, 0.f, step, 0.f);
        else if (k == SDLK_a) cam_move(v, 0.f, -step, 0.f);
        else if (k == SDLK_e) cam_move(v, 0.f, 0.f, step);
        else if (k == SDLK_q) cam_move(v, 0.f, 0.f, -step);
        else if (k == SDLK_UP) light_move(v, step, 0.f, 0.f);
        else if (k == SDLK_DOWN) light_move(v, -step, 0.f, 0.f);
        else if (k == SDLK_RIGHT) light_move(v, 0.f, step, 0.f);
        else if (k == SDLK_LEFT) light_move(v, 0.f, -step, 0.f);
        else if (k == SDLK_PAGEUP) light_move(v, 0.f, 0.f, step);
        else if (k == SDLK_PAGEDOWN) light_move(v, 0.f, 0.f, -step);
        else if (k == SDLK_j || k == SDLK_k) { /* scripted mouse look: yaw left / right */
            v->yaw += k == SDLK_k ? 0.1f : -0.1f;
            cam_update(v);
        }
    }
    return 1;
}

/* Key names for --keys: a printable character, or tab, space, up, down,
 * left, right, pageup, pagedown, f12, escape. */
static SDL_Keycode key_from_name(const char *n) {
    static const struct {
        const char *name;
        SDL_Keycode key;
    } words[] = {
        {"tab", SDLK_TAB},   {"space", SDLK_SPACE},   {"up", SDLK_UP},         {"down", SDLK_DOWN},
        {"left", SDLK_LEFT}, {"right", SDLK_RIGHT},   {"pageup", SDLK_PAGEUP}, {"pagedown", SDLK_PAGEDOWN},
        {"f12", SDLK_F12},   {"escape", SDLK_ESCAPE}, {"comma", SDLK_COMMA},
    };
    for (size_t i = 0; i < sizeof words / sizeof words[0]; i++)
        if (strcmp(n, words[i].name) == 0) return words[i].key;
    if (n[0] > ' ' && n[0] < 127 && n[1] == 0) return (SDL_Keycode)(n[0] >= 'A' && n[0] <= 'Z' ? n[0] + 32 : n[0]);
    return SDLK_UNKNOWN;
}

/* The key at the head of a --keys script: "NAME", "shift+NAME" or either with "@SECONDS". */
typedef struct script_key {
    char name[32];
    SDL_Keycode key;
    int shift;
    double secs; /* KEY@SECONDS: the seconds; else -1 */
    size_t len;  /* characters to skip past it and its comma */
} script_key;

/* Reads the head of `script` into *k; 0 for an unknown key or bad seconds (k->name says which). */
static int script_head(const char *script, script_key *k) {
    const size_t len = strcspn(script, ",");
    snprintf(k->name, sizeof k->name, "%.*s", (int)(len < 31 ? len : 31), script);
    k->len = len + (script[len] == ',');
    k->secs = -1.0;
    char name[32];
    snprintf(name, sizeof name, "%s", k->name);
    char *at = strchr(name, '@');
    if (at) {
        float secs;
        if (!parse_finite_float(at + 1, &secs) || !(secs >= 0.f && secs <= 3600.f)) return 0;
        k->secs = secs;
        *at = 0;
    }
    k->shift = strncmp(name, "shift+", 6) == 0;
    k->key = key_from_name(k->shift ? name + 6 : name);
    return k->key != SDLK_UNKNOWN;
}

/* ------------------------------------------------------------ startup checks */

/* An output file (`what`: screenshot or stats) must be writable before any
 * frame is rendered: it names a file, not a folder, in a folder that exists
 * and is writable, and (`image`) its extension is one pgi_image_write knows.
 * Prints the message; returns 0 (ok), 1 (cannot write there) or 2 (name). */
static int check_output(const char *what, const char *path, int image) {
    size_t n = strlen(path);
    if (image && !(n > 4 && (strcasecmp(path + n - 4, ".png") == 0 || strcasecmp(path + n - 4, ".exr") == 0)))
        return usage("--screenshot needs a .png or .exr file name, got '%s'", path);
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (slash == path) snprintf(dir, sizeof dir, "/");
    else snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    struct stat st;
    char why[4200];
    why[0] = 0;
    if (n == 0 || path[n - 1] == '/' || (stat(path, &st) == 0 && S_ISDIR(st.st_mode)))
        snprintf(why, sizeof why, "that is a folder, not a file name");
    else if (stat(dir, &st) != 0) snprintf(why, sizeof why, "folder '%s': %s", dir, strerror(errno));
    else if (!S_ISDIR(st.st_mode)) snprintf(why, sizeof why, "'%s' is not a folder", dir);
    else if (access(dir, W_OK) != 0) snprintf(why, sizeof why, "folder '%s': %s", dir, strerror(errno));
    if (!why[0]) return 0;
    fprintf(stderr, "photongi-view: cannot write the %s '%s': %s\n", what, path, why);
    return 1;
}

/* Starts SDL's video. With no display SDL 2 falls back to its offscreen (or
 * dummy) driver: the window then exists but nobody sees it, and an
 * interactive session would run until killed. Those drivers are taken only
 * when asked for (SDL_VIDEODRIVER) or when the run ends by itself (--frames).
 * Returns 1 when video is up (SDL_Quit to undo), 0 after a message. */
static int start_video(int interactive) {
    if (SDL_Init(SDL_INIT_VIDEO) != 0) {
        fprintf(stderr, "photongi-view: cannot open a window: %s (run headless with --frames N)\n", SDL_GetError());
        return 0;
    }
    const char *drv = SDL_GetCurrentVideoDriver(), *asked = getenv("SDL_VIDEODRIVER");
    if (interactive && drv && (strcmp(drv, "offscreen") == 0 || strcmp(drv, "dummy") == 0) && !(asked && *asked)) {
        fprintf(stderr,
                "photongi-view: no display available (SDL video driver '%s'); set DISPLAY or WAYLAND_DISPLAY, "
                "or render headless with --frames N [--screenshot FILE.png]\n",
                drv);
        SDL_Quit();
        return 0;
    }
    return 1;
}

/* ------------------------------------------------------------ the command line */

/* What the command line asks for besides the viewer's own state. */
typedef struct view_args {
    const char *scene_spec, *shot, *stats_path, *script;
    long long frames, max_frames;
    int want_window, size_set, camera_out_set;
    app_camera_args cam; /* --eye, --look-at, --up, --fov */
    app_render_extra x;  /* --camera NAME, --exposure, --time, --specular */
    int temporal;        /* --temporal: 1 on, 0 off, -1 not given (on in a window, off headless) */
} view_args;

/* The render settings the viewer takes, parsed as 'photongi render' parses them (render_options.h):
 * all of them but --progressive (the viewer averages by itself while the view is still). */
static int viewer_render_setting(const char *a) {
    static const char *const k[] = {"--estimator",      "--photons", "--radius",         "--size",       "--seed",
                                    "--threads",        "--camera",  "--exposure",       "--time",       "--output",
                                    "--direct-samples", "--bounces", "--emission",       "--max-memory", "--store",
                                    "--device",         "--filter",  "--radius-policy",  "--r-min",      "--r-max",
                                    "--smoothing",      "--jitter",  "--texture-filter", "--specular",   NULL};
    for (int i = 0; k[i]; i++)
        if (strcmp(a, k[i]) == 0) return 1;
    return 0;
}

/* Whether option `a` takes a value: the render settings, the viewer's own, the camera's, the
 * estimators'. */
static int takes_value(const char *a) {
    static const char *const own[] = {"--scene",      "--keys",       "--screenshot", "--stats",
                                      "--camera-out", "--max-frames", "--frames",     "--scale",
                                      "--eye",        "--look-at",    "--up",         "--fov",
                                      "--temporal",   "--history",    "--denoise",    NULL};
    for (int i = 0; own[i]; i++)
        if (strcmp(a, own[i]) == 0) return 1;
    return viewer_render_setting(a) || (strncmp(a, "--", 2) == 0 && pgi_option_find(a + 2) != NULL);
}

/* One "--name value" of the viewer's own; -1 not one of them, else 0 or the exit status. */
static int viewer_option(const char *a, const char *val, viewer *v, view_args *g) {
    if (strcmp(a, "--scene") == 0) g->scene_spec = val;
    else if (strcmp(a, "--keys") == 0) g->script = val;
    else if (strcmp(a, "--screenshot") == 0) g->shot = val;
    else if (strcmp(a, "--stats") == 0) g->stats_path = val;
    else if (strcmp(a, "--camera-out") == 0) v->camera_out = val, g->camera_out_set = 1;
    else if (strcmp(a, "--max-frames") == 0) {
        if (!parse_whole(val, 0, MAX_FRAMES_TIMED * 10LL, &g->max_frames))
            return usage("--max-frames needs a frame count, a whole number in 0..1000000 (0: never stop), got '%s'",
                         val);
    } else if (strcmp(a, "--frames") == 0) {
        if (!parse_whole(val, 1, MAX_FRAMES_TIMED, &g->frames))
            return usage("--frames needs a number in 1..100000, got '%s'", val);
    } else if (strcmp(a, "--scale") == 0) {
        if (!parse_finite_float(val, &v->scale) || !(v->scale > 0.f && v->scale <= 1.f))
            return usage("--scale needs a number in (0, 1], got '%s'", val);
    } else if (strcmp(a, "--temporal") == 0) {
        if (strcmp(val, "on") == 0) g->temporal = 1;
        else if (strcmp(val, "off") == 0) g->temporal = 0;
        else return usage("--temporal must be on or off, got '%s'", val);
    } else if (strcmp(a, "--history") == 0 || strcmp(a, "--denoise") == 0) {
        const int hist = a[2] == 'h';
        long long n;
        int *field = hist ? &v->tdesc.history : &v->tdesc.filter;
        if (strcmp(val, "off") == 0) *field = PGI_TEMPORAL_OFF;
        else if (parse_whole(val, 1, hist ? 256 : 5, &n)) *field = (int)n;
        else
            return usage(hist ? "--history needs frames, a whole number in 1..256, or off, got '%s'"
                              : "--denoise needs a-trous passes, a whole number in 1..5, or off, got '%s'",
                         val);
    } else return -1;
    return 0;
}

/* Parses argv into v and g; -1 to go on, else the exit status (0 after --help). */
static int parse_args(int argc, char **argv, viewer *v, view_args *g) {
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            fputs(k_help, stdout);
            app_print_estimator_options(stdout);
            return 0;
        }
        if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) v->quiet = 1;
        else if (strcmp(a, "--animate") == 0) v->animate = 1;
        else if (strcmp(a, "--no-accumulate") == 0) v->accumulate = 0;
        else if (strcmp(a, "--window") == 0) g->want_window = 1;
        else if (a[0] != '-') return usage("unexpected argument '%s'", a);
        else {
            char err[600];
            if (!takes_value(a)) return usage("unknown option '%s'", a);
            if (i + 1 >= argc) return usage("%s needs a value", a);
            const char *val = argv[++i];
            int co = app_camera_option(a, val, &g->cam, err, sizeof err);
            if (co < 0) return usage("%s", err);
            if (co > 0) continue;
            const int own = viewer_option(a, val, v, g);
            if (own >= 0) {
                if (own > 0) return own;
                continue;
            }
            const int estimator_option = strncmp(a, "--", 2) == 0 && pgi_option_find(a + 2) != NULL;
            if (!estimator_option && !viewer_render_setting(a)) return usage("unknown option '%s'", a);
            if (app_render_option(a, val, &v->desc, &g->x, NULL, err, sizeof err) < 0) return usage("%s", err);
            if (estimator_option) { /* for the printed command line */
                size_t used = strlen(v->est_opts);
                char word[600];
                shell_word(val, word, sizeof word);
                snprintf(v->est_opts + used, sizeof v->est_opts - used, " %s %s", a, word);
            }
            if (strcmp(a, "--size") == 0) g->size_set = 1;
        }
    }
    return -1;
}

/* The checks before any file is read: output paths writable, the estimator known and on the
 * device. 0 to go on, else the exit status. */
static int check_args(viewer *v, const view_args *g) {
    if (g->shot && !g->frames) return usage("%s", "--screenshot needs --frames N (the frame after which to save)");
    int bad = g->shot ? check_output("screenshot", g->shot, 1) : 0;
    if (!bad && g->stats_path && strcmp(g->stats_path, "-") != 0) bad = check_output("stats", g->stats_path, 0);
    if (!bad && g->camera_out_set) bad = check_output("camera file", v->camera_out, 0);
    if (bad) return bad;
    const char *est = v->desc.estimator ? v->desc.estimator : PGI_DEFAULT_ESTIMATOR;
    const pgi_estimator_vtbl *vt = pgi_estimator_find(est);
    if (!vt) {
        fprintf(stderr, "photongi-view: unknown estimator '%s'; registered:", est);
        for (size_t i = 0; i < pgi_estimator_count(); i++) fprintf(stderr, " %s", pgi_estimator_at(i)->name);
        fprintf(stderr, "\n");
        return 2;
    }
    for (size_t i = 0; i < pgi_estimator_count(); i++)
        if (pgi_estimator_at(i) == vt) v->est_index = i;
    char err[400];
    if (!app_check_device(&v->desc, vt->name, err, sizeof err)) {
        fprintf(stderr, "photongi-view: %s\n", err);
        return 1;
    }
    return 0;
}

/* ------------------------------------------------------------ start and end */

/* Frees what the viewer holds (any part may be missing). */
static void viewer_free(viewer *v) {
    pgi_image_free(&v->img);
    free(v->rgb8);
    free(v->disp);
    pgi_cancel_destroy(v->cancel);
    pgi_temporal_destroy(v->temporal);
    pgi_progressive_destroy(v->prog);
    pgi_renderer_destroy(v->r);
    pgi_scene_destroy(v->scene);
}

/* Loads the scene and sets up the camera, the window size, the renderer. 0, else the exit status
 * (the message printed; viewer_free frees what was made). */
static int open_scene(viewer *v, const view_args *g) {
    pgi_status st = pgi_scene_load_budget(g->scene_spec, v->desc.max_memory, &v->scene);
    if (st) return fail("cannot load scene", st);
    pgi_scene_get_info(v->scene, &v->info);
    if (*v->info.warnings) fprintf(stderr, "photongi-view: warning: %s\n", v->info.warnings);
    char err[600];
    if (!app_render_camera(v->scene, &v->desc, &g->x, err, sizeof err)) {
        fprintf(stderr, "photongi-view: %s\n", err);
        return 2;
    }
    v->scene_spec = g->scene_spec;
    pgi_scene_get_camera(v->scene, (size_t)v->desc.camera, &v->cam);
    if (app_camera_given(&g->cam)) {
        pgi_camera_def base = v->cam;
        if (!app_camera_resolve(&g->cam, &base, &v->cam, err, sizeof err)) {
            fprintf(stderr, "photongi-view: scene %s: %s\n", v->info.name, err);
            return 1;
        }
        v->cam_moved = 1; /* rendered as a view, as 'photongi render --eye ...' */
    }
    cam_init_angles(v);
    float ext[3];
    v_sub(v->info.bounds_max, v->info.bounds_min, ext);
    v->diag = sqrtf(ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]);
    if (!g->size_set) {
        v->win_w = v->info.defaults.width > 0 ? v->info.defaults.width : 1280;
        v->win_h = v->info.defaults.height > 0 ? v->info.defaults.height : 720;
    }
    v->exposure = g->x.exposure > 0.f               ? g->x.exposure
                  : v->info.defaults.exposure > 0.f ? v->info.defaults.exposure
                                                    : 1.f;
    v->time = g->x.time;
    v->disp = malloc((size_t)v->win_w * v->win_h * 3);
    if (!v->disp) {
        fprintf(stderr, "photongi-view: out of memory\n");
        return 1;
    }
    if (g->x.specular != PGI_SPECULAR_DEFAULT && (st = pgi_scene_set_specular(v->scene, g->x.specular)))
        return fail("cannot set the specular model", st);
    if ((st = pgi_renderer_create(v->scene, &v->r)) || (st = pgi_progressive_create(v->r, &v->prog)) ||
        (st = pgi_cancel_create(&v->cancel)) || (st = temporal_renew(v)))
        return fail("cannot create the renderer", st);
    /* interactive: guided emission learns over the frames of a still view (scripted --frames N
       runs average as 'photongi render --progressive N', frame by frame) */
    if (!g->frames) pgi_progressive_keep_guide(v->prog, 1);
    if (!g->frames && v->info.animated_objects > 0) v->animate = 1; /* interactive: play animations */
    if (pgi_estimator_at(v->est_index)->oracle && !v->quiet)
        fprintf(stderr,
                "photongi-view: note: %s is the O(photons x pixels) oracle: each frame reads every photon at every "
                "pixel (%d x %d pixels here), minutes at large sizes; any key abandons the frame, Tab and the "
                "number keys leave it\n",
                pgi_estimator_at(v->est_index)->name, (int)lroundf((float)v->win_w * v->scale),
                (int)lroundf((float)v->win_h * v->scale));
    return 0;
}

typedef struct window {
    SDL_Window *win;
    SDL_Renderer *ren;
    SDL_Texture *tex;
} window;

static void close_window(window *w) {
    if (w->tex) SDL_DestroyTexture(w->tex);
    if (w->ren) SDL_DestroyRenderer(w->ren);
    if (w->win) SDL_DestroyWindow(w->win);
    *w = (window){0};
}

/* 1 with the window open, 0 after a message. */
static int open_window(const viewer *v, window *w) {
    w->win = SDL_CreateWindow("photongi-view", SDL_WINDOWPOS_CENTERED, SDL_WINDOWPOS_CENTERED, v->win_w, v->win_h, 0);
    w->ren = w->win ? SDL_CreateRenderer(w->win, -1, 0) : NULL;
    if (!w->ren && w->win) w->ren = SDL_CreateRenderer(w->win, -1, SDL_RENDERER_SOFTWARE);
    w->tex = w->ren ? SDL_CreateTexture(w->ren, SDL_PIXELFORMAT_RGB24, SDL_TEXTUREACCESS_STREAMING, v->win_w, v->win_h)
                    : NULL;
    if (w->tex) return 1;
    fprintf(stderr, "photongi-view: cannot create the window: %s\n", SDL_GetError());
    close_window(w);
    return 0;
}

/* Shows the texture (`update`: after copying the frame into it, with the title). */
static void present(const viewer *v, window *w, int update) {
    if (!w->tex) return;
    if (update) SDL_UpdateTexture(w->tex, NULL, v->disp, v->win_w * 3);
    SDL_RenderClear(w->ren);
    SDL_RenderCopy(w->ren, w->tex, NULL, NULL);
    SDL_RenderPresent(w->ren);
    if (!update) return;
    char title[256];
    snprintf(title, sizeof title, "photongi-view - %s - %s - %.1f FPS - %d frames", v->info.name, v->fs.estimator,
             v->fps, v->fs.frames);
    SDL_SetWindowTitle(w->win, title);
}

/* ------------------------------------------------------------ the loop */

/* The main loop's state between turns. */
typedef struct loop_state {
    long long done, rendered, idled, still, abandoned; /* turns, frames rendered, turns idle, ..., abandoned */
    double due_s;                                      /* a scripted KEY@SECONDS: pressed that long into the frame */
    int due_now;                                       /* ... whose time has come: pressed before the next frame */
    int running, dragging, warned_unlit;
    int good_valid, good_out; /* the last settings that rendered */
    size_t good_est;
    pgi_render_desc good_desc;
    float good_scale;
    double last;    /* seconds, the previous turn */
    double *times;  /* --frames: each frame's time, then the viewer's overhead */
    held_keys held; /* movement keys: wall time held */
} loop_state;

/* Movement keys: the camera's W S D A E Q, the light's arrows and PgUp/PgDn. A key moves by the
 * wall time it is held (from its press to its release, or to now while it is down), not by the
 * frame time, so a tap during a slow frame moves a tap's distance and every press counts. */
static const SDL_Scancode k_move[HELD_KEYS] = {SDL_SCANCODE_W,    SDL_SCANCODE_S,      SDL_SCANCODE_D,
                                               SDL_SCANCODE_A,    SDL_SCANCODE_E,      SDL_SCANCODE_Q,
                                               SDL_SCANCODE_UP,   SDL_SCANCODE_DOWN,   SDL_SCANCODE_RIGHT,
                                               SDL_SCANCODE_LEFT, SDL_SCANCODE_PAGEUP, SDL_SCANCODE_PAGEDOWN};

/* One event; returns 1 when it changes the picture. Quitting clears ls->running. */
static int take_event(viewer *v, window *w, loop_state *ls, const SDL_Event *e) {
    if (e->type == SDL_QUIT) ls->running = 0;
    else if (e->type == SDL_WINDOWEVENT && ls->good_valid) present(v, w, 0); /* uncovered: draw it again */
    else if (e->type == SDL_MOUSEBUTTONDOWN && e->button.button == SDL_BUTTON_LEFT) ls->dragging = 1;
    else if (e->type == SDL_MOUSEBUTTONUP && e->button.button == SDL_BUTTON_LEFT) ls->dragging = 0;
    else if (e->type == SDL_MOUSEWHEEL && e->wheel.y != 0) {
        v->speed_mul = fminf(1e3f, fmaxf(1e-3f, v->speed_mul * powf(1.25f, (float)e->wheel.y)));
        return 1; /* the overlay shows the speed */
    } else if (e->type == SDL_MOUSEMOTION && ls->dragging && (SDL_GetModState() & KMOD_CTRL)) {
        /* Ctrl + drag: move the selected light in the horizontal plane. */
        float k = 0.002f * v->diag;
        light_move(v, -k * (float)e->motion.yrel, k * (float)e->motion.xrel, 0.f);
        return 1;
    } else if (e->type == SDL_MOUSEMOTION && ls->dragging) {
        v->yaw += 0.005f * (float)e->motion.xrel;
        v->pitch -= 0.005f * (float)e->motion.yrel;
        v->pitch = fmaxf(-1.55f, fminf(1.55f, v->pitch));
        cam_update(v);
        return 1;
    } else if (e->type == SDL_KEYDOWN || e->type == SDL_KEYUP) {
        const double t = e->key.timestamp ? e->key.timestamp / 1000.0 : SDL_GetTicks64() / 1000.0;
        int mk = -1;
        for (int k = 0; k < HELD_KEYS; k++)
            if (e->key.keysym.scancode == k_move[k]) mk = k;
        if (mk >= 0 && e->type == SDL_KEYDOWN) held_press(&ls->held, mk, t);
        else if (mk >= 0) held_release(&ls->held, mk, t);
        else if (e->type == SDL_KEYDOWN) {
            int pk = press_key(v, e->key.keysym.sym, (e->key.keysym.mod & KMOD_SHIFT) != 0, 0.f);
            if (!pk) ls->running = 0;
            return pk == 1;
        }
    }
    return 0;
}

/* A window's input since the last turn: every queued event, each press on its own, then the
 * movement of the keys held (by wall time) and the animation clock. Returns 1 when the picture
 * changes. */
static int take_input(viewer *v, window *w, loop_state *ls, double dt) {
    int changed = 0;
    SDL_Event e;
    while (SDL_PollEvent(&e)) changed |= take_event(v, w, ls, &e);
    double held[HELD_KEYS];
    changed |= held_take(&ls->held, SDL_GetTicks64() / 1000.0, held);
    const SDL_Keymod mod = SDL_GetModState();
    const double speed = 0.25 * v->diag; /* scene diagonals per second / 4 */
    const double sp = speed * v->speed_mul * ((mod & KMOD_SHIFT) ? 4.0 : 1.0) * ((mod & KMOD_CTRL) ? 0.2 : 1.0);
    float fw = (float)(sp * (held[0] - held[1])), sd = (float)(sp * (held[2] - held[3])),
          ud = (float)(sp * (held[4] - held[5]));
    if (fw != 0.f || sd != 0.f || ud != 0.f) cam_move(v, fw, sd, ud);
    float lf = (float)(0.5 * sp * (held[6] - held[7])), lsd = (float)(0.5 * sp * (held[8] - held[9])),
          lu = (float)(0.5 * sp * (held[10] - held[11]));
    if (lf != 0.f || lsd != 0.f || lu != 0.f) light_move(v, lf, lsd, lu);
    if (v->animate) v->time += dt;
    return changed;
}

/* --keys: one scripted key a turn (movement keys take a fixed step); KEY@SECONDS is pressed that
 * long into the frame after the key before it, abandoning that frame if it is still running,
 * then (due_now) pressed before the next frame like any key. Returns 1 when the picture changes,
 * -1 after a usage error (rc set). */
static int take_script_key(viewer *v, loop_state *ls, const char **script, int *rc) {
    ls->due_s = -1.0;
    if (!*script || !**script) return 0;
    int changed = 0;
    script_key sk;
    if (!script_head(*script, &sk)) {
        *rc = usage("--keys: unknown key or bad KEY@SECONDS (seconds in 0..3600) '%s'", sk.name);
        return -1;
    }
    if (sk.secs < 0.0 || ls->due_now) {
        *script += sk.len;
        int pk = press_key(v, sk.key, sk.shift, (float)(0.02 * v->diag) * v->speed_mul);
        if (!pk) ls->running = 0;
        changed = pk == 1;
    }
    ls->due_now = 0;
    if (**script && script_head(*script, &sk) && sk.secs >= 0.0) ls->due_s = sk.secs; /* during this frame */
    return changed;
}

/* After the first frame of the starting view: a camera that sees nothing lit is told about. */
static void warn_unlit(viewer *v, const view_args *g) {
    pgi_render_desc d;
    frame_desc(v, &d);
    if (app_image_unlit(&v->img) ||
        (v->info.camera_auto && !v->cam_moved && app_view_sees_light(v->r, &d, &v->info) == 0)) {
        char why[700];
        app_unlit_warning(&v->info, v->desc.camera, app_camera_given(&g->cam), why, sizeof why);
        fprintf(stderr, "photongi-view: warning: %s\n", why);
    }
}

/* Renders one frame and shows it. Returns 0 (rendered, abandoned for input, or a rejected setting
 * undone), else the exit status. */
static int frame_turn(viewer *v, window *w, loop_state *ls, const view_args *g, int headless) {
    const double freq = (double)SDL_GetPerformanceFrequency(), f0 = SDL_GetPerformanceCounter() / freq;
    double late_ms;
    pgi_status st = render_watched(v, !headless, ls->due_s, &late_ms);
    if (ls->due_s >= 0.0) ls->due_now = 1; /* the timed key: pressed now, whether or not the frame ended first */
    if (st == PGI_ERR_CANCELLED) {
        /* Abandoned for input: the input is handled at the top of the loop and a new frame
         * starts; a progressive average keeps what it had. */
        ls->abandoned++;
        if (ls->due_s >= 0.0 && !v->quiet)
            fprintf(stderr,
                    "photongi-view: frame abandoned %.0f ms into it for a scripted key; it stopped %.1f ms "
                    "after the request\n",
                    1000.0 * (SDL_GetPerformanceCounter() / freq - f0) - late_ms, late_ms);
        return 0;
    }
    if (st) {
        /* Interactive: a setting the estimator rejects (say, a radius too small for its grid, or
         * photons over the memory budget) is reported and undone, as often as it comes; headless,
         * or when the last good settings themselves fail, it ends the program. */
        const int were_good = ls->good_valid && v->est_index == ls->good_est && v->scale == ls->good_scale &&
                              v->out_mode == ls->good_out && memcmp(&v->desc, &ls->good_desc, sizeof v->desc) == 0;
        if (headless || !ls->good_valid || were_good) return fail("render failed", st);
        fprintf(stderr, "photongi-view: %s; going back to the previous settings\n", pgi_last_error());
        v->est_index = ls->good_est;
        v->desc = ls->good_desc;
        v->scale = ls->good_scale;
        v->out_mode = ls->good_out;
        return 0;
    }
    ls->good_valid = 1;
    ls->good_est = v->est_index;
    ls->good_desc = v->desc;
    ls->good_scale = v->scale;
    ls->good_out = v->out_mode;
    ls->still++;
    if (!ls->warned_unlit && !v->quiet && v->out_mode == PGI_OUTPUT_ALL) {
        ls->warned_unlit = 1;
        warn_unlit(v, g);
    }
    present(v, w, 1);
    v->frame_ms = 1000.0 * (SDL_GetPerformanceCounter() / freq - f0);
    v->fps = v->frame_ms > 0.0 ? 1000.0 / v->frame_ms : 0.0;
    if (ls->times)
        ls->times[ls->rendered] = v->frame_ms, ls->times[g->frames + ls->rendered] = v->frame_ms - v->fs.total_ms;
    ls->rendered++;
    ls->done++;
    if (g->frames && ls->done >= g->frames) ls->running = 0;
    return 0;
}

/* The loop: input, scripted keys, then a frame, or an idle turn once a still view has its frames.
 * Returns the exit status. */
static int run(viewer *v, window *w, loop_state *ls, const view_args *g, int headless) {
    const char *script = g->script;
    int rc = 0;
    while (ls->running) {
        const double now = SDL_GetTicks64() / 1000.0, dt = now - ls->last;
        ls->last = now;
        int changed = 0; /* input or animation: a still view renders again */
        if (!headless) changed = take_input(v, w, ls, dt);
        else if (v->animate && ls->done > 0) v->time += 1.0 / 30.0;
        changed |= v->animate;
        const int sk = take_script_key(v, ls, &script, &rc);
        if (sk < 0) break;
        changed |= sk;
        if (!ls->running) break;
        /* A still view that has its frames (averaged, or --no-accumulate's fresh ones) waits for
         * input instead of rendering on: in a window it sleeps until an event comes. */
        if (changed) ls->still = 0;
        const int averaging = v->accumulate && v->out_mode != PGI_OUTPUT_PHOTON_COUNT;
        if (g->max_frames > 0 && ls->good_valid && !changed &&
            (averaging ? v->fs.frames : ls->still) >= g->max_frames) {
            if (ls->due_s >= 0.0) ls->due_now = 1; /* no frame to press a timed key into: pressed next turn */
            ls->idled++;
            ls->done++;
            if (g->frames && ls->done >= g->frames) ls->running = 0;
            else if (!headless) SDL_WaitEventTimeout(NULL, 500);
            continue;
        }
        if ((rc = frame_turn(v, w, ls, g, headless))) break;
    }
    return rc;
}

/* After the loop: the screenshot, the stats, the summary lines. Returns the exit status. */
static int finish(viewer *v, const window *w, loop_state *ls, const view_args *g) {
    pgi_status st;
    if (g->shot && ls->done == g->frames && (st = save_screenshot(v, g->shot)))
        return fail("cannot write the screenshot", st);
    if (g->stats_path && ls->done > 0 && (st = pgi_stats_write_json(&v->fs, g->stats_path)))
        return fail("cannot write stats", st);
    if (v->quiet) return 0;
    const long long n = ls->rendered;
    if (g->frames && n > 0) {
        double *t = ls->times, first = t[0];
        qsort(t, (size_t)n, sizeof *t, cmp_double);
        qsort(t + g->frames, (size_t)n, sizeof *t, cmp_double);
        double med = t[n / 2], over = t[g->frames + n / 2];
        fprintf(stderr,
                "photongi-view: %s %dx%d, %s, %lld frames: median %.1f ms a frame (%.2f FPS), first %.1f ms, "
                "viewer overhead (tone map, overlay%s) %.1f ms; "
                "last frame: view %.1f trace %.1f build %.1f estimate %.1f direct %.1f rt %.1f ms, %d averaged\n",
                v->info.name, v->fs.width, v->fs.height, v->fs.estimator, n, med, med > 0 ? 1000.0 / med : 0.0, first,
                w->tex ? ", display" : "", over, v->fs.view_ms, v->fs.trace_ms, v->fs.build_ms, v->fs.estimate_ms,
                v->fs.direct_ms, v->fs.rt_update_ms, v->fs.frames);
    }
    if (ls->abandoned > 0)
        fprintf(stderr, "photongi-view: %lld frame%s abandoned for input\n", ls->abandoned,
                ls->abandoned == 1 ? "" : "s");
    if (g->frames && ls->idled > 0)
        fprintf(stderr, "photongi-view: %lld frames rendered, then %lld turns idle (--max-frames %lld reached)\n", n,
                ls->idled, g->max_frames);
    return 0;
}

/* ------------------------------------------------------------ main */

int main(int argc, char **argv) {
    viewer v;
    memset(&v, 0, sizeof v);
    v.desc.emission = PGI_EMISSION_AUTO; /* as photongi render */
    v.camera_out = "photongi-camera.json";
    v.speed_mul = 1.f;
    v.accumulate = 1;
    v.overlay = 1;
    v.scale = 1.f;
    view_args g = {.scene_spec = "cornell", .max_frames = 256, .x = APP_RENDER_EXTRA_INIT, .temporal = -1};
    int rc = parse_args(argc, argv, &v, &g);
    if (rc >= 0) return rc;
    if ((rc = check_args(&v, &g))) return rc;
    if (g.size_set) v.win_w = v.desc.width, v.win_h = v.desc.height; /* --size: the window's */
    /* Temporal reuse and the filter: on in an interactive session, off with --frames (scripted runs and
     * benches stay raw, and --frames N averages as 'photongi render --progressive N'), unless
     * --temporal says. */
    v.tdesc.keep_guide = g.frames == 0; /* interactive: as the progressive accumulator's (open_scene) */
    if (g.temporal < 0 ? g.frames > 0 : g.temporal == 0) v.tdesc.history = v.tdesc.filter = PGI_TEMPORAL_OFF;
    else if (g.temporal == 1 && v.desc.device != PGI_DEVICE_CPU)
        return usage("%s", "--temporal on: temporal reuse and the filter run on the CPU device only");
    v.out_mode = (int)v.desc.output; /* --output; the frame's desc takes it from out_mode */
    v.desc.output = PGI_OUTPUT_ALL;
    v.desc.estimator = NULL; /* est_index names it */
    v.desc.width = v.desc.height = 0;

    /* The display next: without one, loading the scene would be wasted. */
    const int headless = g.frames > 0 && !g.want_window;
    if (!headless && !start_video(g.frames == 0)) return 1;
    window w = {0};
    if ((rc = open_scene(&v, &g)) || (!headless && !open_window(&v, &w))) {
        viewer_free(&v);
        if (!headless) SDL_Quit();
        return rc ? rc : 1;
    }
    loop_state ls = {.due_s = -1.0,
                     .running = 1,
                     .good_est = v.est_index,
                     .good_desc = v.desc,
                     .good_scale = v.scale,
                     .last = SDL_GetTicks64() / 1000.0};
    ls.times = g.frames ? malloc(2 * (size_t)g.frames * sizeof *ls.times) : NULL;
    if (g.frames && !ls.times) rc = fail("out of memory", PGI_ERR_OOM);
    if (!rc) rc = run(&v, &w, &ls, &g, headless);
    if (!rc) rc = finish(&v, &w, &ls, &g);
    free(ls.times);
    close_window(&w);
    if (!headless) SDL_Quit();
    viewer_free(&v);
    return rc;
}
