/* A camera on the command line (--eye, --look-at, --up, --fov) and a camera one can carry: the
 * JSON camera block of a scene description (docs/scene-format.md) and the `photongi render`
 * command line that render a pgi_camera_def. Floats are written with %.9g, which reads back
 * (strtof, or the JSON loader's double rounded to a float) as the same float, so a camera
 * printed and pasted back is the same camera bit for bit. Header only (static inline), shared by
 * photongi and photongi-view; the callers report the errors themselves. */
#ifndef PGI__APPS_CAMERA_H
#define PGI__APPS_CAMERA_H

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "parse.h"
#include "photongi/estimator.h"
#include "photongi/photongi.h"

/* The widest field of view a camera may have, degrees (as the scene description's "fov_y"). */
#define APP_MAX_FOV 179.9

/* The camera flags given on a command line: each part given or not. */
typedef struct app_camera_args {
    int has_eye, has_look_at, has_up, has_fov;
    float eye[3], look_at[3], up[3];
    float fov;
} app_camera_args;

/* 1 when any of the camera flags was given. */
static inline int app_camera_given(const app_camera_args *c) {
    return c->has_eye || c->has_look_at || c->has_up || c->has_fov;
}

/* "X,Y,Z": three finite floats with |x| <= PGI_MAX_COORD. */
static inline int app_parse_vec3(const char *s, float out[3]) {
    char part[3][64];
    const char *p = s;
    for (int k = 0; k < 3; k++) {
        size_t n = strcspn(p, ",");
        if (n == 0 || n >= sizeof part[k] || (k < 2 && p[n] != ',') || (k == 2 && p[n] != 0)) return 0;
        memcpy(part[k], p, n);
        part[k][n] = 0;
        p += n + (k < 2);
    }
    float v[3];
    for (int k = 0; k < 3; k++)
        if (!parse_finite_float(part[k], &v[k]) || !(fabsf(v[k]) <= (float)PGI_MAX_COORD)) return 0;
    memcpy(out, v, sizeof v);
    return 1;
}

/* Parses flag `a` ("--eye") with value `v` into c: 1 handled, 0 not a camera flag, -1 a bad
 * value (message in err). */
static inline int app_camera_option(const char *a, const char *v, app_camera_args *c, char *err, size_t size) {
    float *dst = strcmp(a, "--eye") == 0       ? c->eye
                 : strcmp(a, "--look-at") == 0 ? c->look_at
                 : strcmp(a, "--up") == 0      ? c->up
                                               : NULL;
    if (dst) {
        if (!app_parse_vec3(v, dst))
            return (snprintf(err, size, "%s needs X,Y,Z: three finite numbers within +-%g (scene units), got '%s'", a,
                             PGI_MAX_COORD, v),
                    -1);
        if (dst == c->eye) c->has_eye = 1;
        else if (dst == c->look_at) c->has_look_at = 1;
        else c->has_up = 1;
        return 1;
    }
    if (strcmp(a, "--fov") == 0) {
        float f;
        if (!parse_finite_float(v, &f) || !(f > 0.f && f <= (float)APP_MAX_FOV))
            return (snprintf(err, size,
                             "--fov needs a vertical field of view in degrees, above 0 and at most %g, got "
                             "'%s'",
                             APP_MAX_FOV, v),
                    -1);
        c->fov = f;
        c->has_fov = 1;
        return 1;
    }
    return 0;
}

/* The camera of the flags given, the parts not given taken from `base` (the scene's chosen
 * camera). 1 fine; 0 a camera that cannot render (eye = look-at, up zero or parallel to the
 * view), with the message in err. */
static inline int app_camera_resolve(const app_camera_args *c, const pgi_camera_def *base, pgi_camera_def *out,
                                     char *err, size_t size) {
    pgi_camera_def r = *base;
    if (c->has_eye) memcpy(r.eye, c->eye, sizeof r.eye);
    if (c->has_look_at) memcpy(r.look_at, c->look_at, sizeof r.look_at);
    if (c->has_up) memcpy(r.up, c->up, sizeof r.up);
    if (c->has_fov) r.fov_y_deg = c->fov;
    const float d[3] = {r.look_at[0] - r.eye[0], r.look_at[1] - r.eye[1], r.look_at[2] - r.eye[2]};
    const float x[3] = {d[1] * r.up[2] - d[2] * r.up[1], d[2] * r.up[0] - d[0] * r.up[2],
                        d[0] * r.up[1] - d[1] * r.up[0]};
    if (!(d[0] != 0.f || d[1] != 0.f || d[2] != 0.f))
        return (snprintf(err, size, "the camera's eye (%g,%g,%g) and look-at are the same point%s", (double)r.eye[0],
                         (double)r.eye[1], (double)r.eye[2],
                         c->has_eye && c->has_look_at ? "" : " (a part not given is the scene camera's)"),
                0);
    if (!(sqrtf(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) > 0.f))
        return (snprintf(err, size, "the camera's up (%g,%g,%g) is zero or parallel to the view direction%s",
                         (double)r.up[0], (double)r.up[1], (double)r.up[2],
                         c->has_up ? "; give another --up" : " (the scene camera's up; give --up X,Y,Z)"),
                0);
    *out = r;
    return 1;
}

/* The camera as the JSON camera block of a scene description (one line, no newline):
 * {"eye": [x, y, z], "look_at": [...], "up": [...], "fov_y": f}. Returns what snprintf does. */
static inline int app_camera_json(const pgi_camera_def *c, char *buf, size_t size) {
    return snprintf(buf, size,
                    "{\"eye\": [%.9g, %.9g, %.9g], \"look_at\": [%.9g, %.9g, %.9g], \"up\": [%.9g, %.9g, %.9g], "
                    "\"fov_y\": %.9g}",
                    (double)c->eye[0], (double)c->eye[1], (double)c->eye[2], (double)c->look_at[0],
                    (double)c->look_at[1], (double)c->look_at[2], (double)c->up[0], (double)c->up[1], (double)c->up[2],
                    (double)c->fov_y_deg);
}

/* The camera flags of `photongi render` (and reference, photongi-view) that give camera c:
 * "--eye x,y,z --look-at x,y,z --up x,y,z --fov f". Returns what snprintf does. */
static inline int app_camera_flags(const pgi_camera_def *c, char *buf, size_t size) {
    return snprintf(buf, size, "--eye %.9g,%.9g,%.9g --look-at %.9g,%.9g,%.9g --up %.9g,%.9g,%.9g --fov %.9g",
                    (double)c->eye[0], (double)c->eye[1], (double)c->eye[2], (double)c->look_at[0],
                    (double)c->look_at[1], (double)c->look_at[2], (double)c->up[0], (double)c->up[1], (double)c->up[2],
                    (double)c->fov_y_deg);
}

/* 1 when no pixel of the image has any light (every value 0, or not a positive number). */
static inline int app_image_unlit(const pgi_image *img) {
    const size_t n = 3 * (size_t)img->width * (size_t)img->height;
    for (size_t i = 0; i < n; i++)
        if (img->rgb[i] > 0.f) return 0;
    return 1;
}

/* Whether the view of desc d sees anything lit by a light or a light itself: emission and direct
 * light only (PGI_OUTPUT_DIRECT), at most 64 pixels wide, 1000 photons and a fixed radius, on the
 * CPU, so it takes milliseconds. Light that reaches the camera only through photons (a wall seen
 * from behind, its inside lit) does not count: a closed room seen from outside is unlit here.
 * 1 lit, 0 unlit, -1 the probe failed (no answer). The image of d is not touched. */
static inline int app_view_sees_light(pgi_renderer *r, const pgi_render_desc *d, const pgi_scene_info *info) {
    pgi_render_desc p = *d;
    const int w = d->width > 0 ? d->width : 640, h = d->height > 0 ? d->height : 480;
    p.width = w < 64 ? w : 64;
    p.height = (int)((long long)h * p.width / w);
    if (p.height < 1) p.height = 1;
    p.output = PGI_OUTPUT_DIRECT;
    p.photons = 1000;
    p.progress = NULL;
    p.device = PGI_DEVICE_CPU;
    p.device_index = 0;
    p.direct_samples = 4;
    p.radius_policy = PGI_RADIUS_FIXED;
    p.store = PGI_STORE_ALL;
    p.emission = PGI_EMISSION_UNIFORM;
    p.filter = 0;
    const float e[3] = {info->bounds_max[0] - info->bounds_min[0], info->bounds_max[1] - info->bounds_min[1],
                        info->bounds_max[2] - info->bounds_min[2]};
    p.radius = 0.01f * sqrtf(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    if (!(p.radius >= (float)PGI_MIN_RADIUS && p.radius <= (float)PGI_MAX_RADIUS)) p.radius = 1.f;
    pgi_image img = {0};
    pgi_frame_stats fs;
    if (pgi_renderer_render(r, &p, &img, &fs) != PGI_OK) return -1;
    const int lit = !app_image_unlit(&img);
    pgi_image_free(&img);
    return lit;
}

/* The warning for a first frame that sees nothing lit (a black image, app_image_unlit, or an
 * automatic camera that app_view_sees_light finds unlit), naming where the camera came from: the
 * scene's automatic one (camera_auto), one given on the command line (given), or the scene's
 * camera `index`. */
static inline void app_unlit_warning(const pgi_scene_info *info, int index, int given, char *buf, size_t size) {
    if (given)
        snprintf(buf, size,
                 "the image is black: the camera given (--eye, --look-at, --up, --fov) sees nothing lit; "
                 "is it inside a wall, or looking away from the lights?");
    else if (info->camera_auto)
        snprintf(buf, size,
                 "the camera sees no light and nothing a light shines on (the image is dark or black): "
                 "scene %s gives no camera, so one was placed "
                 "outside its bounds on +z looking at their centre (a closed room is then seen from outside); "
                 "give one with --eye X,Y,Z --look-at X,Y,Z (bounds %g,%g,%g .. %g,%g,%g), or a \"camera\" in a "
                 "scene description (docs/scene-format.md)",
                 info->name, (double)info->bounds_min[0], (double)info->bounds_min[1], (double)info->bounds_min[2],
                 (double)info->bounds_max[0], (double)info->bounds_max[1], (double)info->bounds_max[2]);
    else
        snprintf(buf, size,
                 "the image is black: camera %d of scene %s sees nothing lit; another one can be given with "
                 "--eye X,Y,Z --look-at X,Y,Z",
                 index, info->name);
}

#endif
