/* photongi._photongi: the CPython extension under the `photongi` package (python/photongi/__init__.py
 * holds the documented API). Written against the library's public headers, so that the compiler
 * checks every struct it reads; the render settings are parsed by the same code as `photongi render`
 * (apps/common/render_options.h). Images come back as NumPy float32 arrays (H, W, 3) that own the
 * library's buffer (no copy); the GIL is released while the library renders, traces references and
 * compares images. Scenes and renderers are capsules that the Python classes wrap. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <stdlib.h>
#include <string.h>

#include "photongi/metrics.h"
#include "photongi/photongi.h"
#include "photongi/reference.h"
#include "render_options.h"

static PyObject *g_error; /* photongi.Error */

/* Raises photongi.Error(message, status name) for a failed library call. */
static PyObject *fail(pgi_status st, const char *what) {
    const char *msg = pgi_last_error();
    PyObject *args = Py_BuildValue("(ss)", msg && *msg ? msg : what, pgi_status_string(st));
    if (args) {
        PyErr_SetObject(g_error, args);
        Py_DECREF(args);
    }
    return NULL;
}

/* ------------------------------------------------------------ capsules */

#define SCENE_CAP "photongi.scene"
#define RENDERER_CAP "photongi.renderer"

static void scene_free(PyObject *cap) {
    pgi_scene *s = PyCapsule_GetPointer(cap, SCENE_CAP);
    if (s) pgi_scene_destroy(s);
}
static void renderer_free(PyObject *cap) {
    pgi_renderer *r = PyCapsule_GetPointer(cap, RENDERER_CAP);
    if (r) pgi_renderer_destroy(r);
}
static pgi_scene *scene_of(PyObject *cap) { return PyCapsule_GetPointer(cap, SCENE_CAP); }

/* An image's buffer handed to NumPy: the array owns it through this capsule. */
static void image_free(PyObject *cap) { free(PyCapsule_GetPointer(cap, "photongi.image")); }

/* The (H, W, 3) float32 array over img's buffer (taken: img is zeroed). */
static PyObject *array_take(pgi_image *img) {
    npy_intp dims[3] = {img->height, img->width, 3};
    PyObject *arr = PyArray_SimpleNewFromData(3, dims, NPY_FLOAT32, img->rgb);
    if (!arr) return NULL;
    PyObject *owner = PyCapsule_New(img->rgb, "photongi.image", image_free);
    if (!owner || PyArray_SetBaseObject((PyArrayObject *)arr, owner) < 0) {
        Py_XDECREF(owner);
        Py_DECREF(arr);
        return NULL;
    }
    memset(img, 0, sizeof *img);
    return arr;
}

/* A borrowed pgi_image over an (H, W, 3) array of any real type, converted to float32 C-contiguous (*keep holds the array
 * to release after use). */
static int image_view(PyObject *obj, const char *name, pgi_image *img, PyObject **keep) {
    PyObject *a = PyArray_FROMANY(obj, NPY_FLOAT32, 0, 0, NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
    if (!a) return 0;
    if (PyArray_NDIM((PyArrayObject *)a) != 3 || PyArray_DIM((PyArrayObject *)a, 2) != 3) {
        Py_DECREF(a);
        PyErr_Format(PyExc_ValueError, "%s: an image is an array of shape (height, width, 3)", name);
        return 0;
    }
    img->height = (int)PyArray_DIM((PyArrayObject *)a, 0);
    img->width = (int)PyArray_DIM((PyArrayObject *)a, 1);
    img->rgb = PyArray_DATA((PyArrayObject *)a);
    *keep = a;
    return 1;
}

static PyObject *vec3(const float *v) { return Py_BuildValue("(ddd)", v[0], v[1], v[2]); }

static PyObject *camera_dict(const pgi_camera_def *c) {
    return Py_BuildValue("{s:N,s:N,s:N,s:d}", "eye", vec3(c->eye), "look_at", vec3(c->look_at), "up", vec3(c->up),
                         "fov", (double)c->fov_y_deg);
}

/* -------------------------------------------------------------- scenes */

static PyObject *py_scene_load(PyObject *self, PyObject *args) {
    const char *spec;
    if (!PyArg_ParseTuple(args, "s", &spec)) return NULL;
    pgi_scene *s = NULL;
    pgi_status st;
    PyThreadState *ts = PyEval_SaveThread(); /* the GIL released */
    st = pgi_scene_load(spec, &s);
    PyEval_RestoreThread(ts);
    if (st) return fail(st, "cannot load the scene");
    PyObject *cap = PyCapsule_New(s, SCENE_CAP, scene_free);
    if (!cap) pgi_scene_destroy(s);
    return cap;
}

static PyObject *py_scene_info(PyObject *self, PyObject *args) {
    PyObject *cap;
    if (!PyArg_ParseTuple(args, "O", &cap)) return NULL;
    pgi_scene *s = scene_of(cap);
    if (!s) return NULL;
    pgi_scene_info i;
    pgi_scene_get_info(s, &i);
    const pgi_scene_defaults *d = &i.defaults;
    return Py_BuildValue(
        "{s:s,s:s,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:(NN),s:n,s:N,s:{s:I,s:d,s:i,s:i,s:i,s:d},"
        "s:d,s:n,s:d,s:s,s:n,s:n}",
        "name", i.name, "source", i.source, "triangles", (Py_ssize_t)i.triangles, "vertices", (Py_ssize_t)i.vertices,
        "materials", (Py_ssize_t)i.materials, "textures", (Py_ssize_t)i.textures, "cutout_materials",
        (Py_ssize_t)i.cutout_materials, "lights", (Py_ssize_t)i.lights, "point_lights", (Py_ssize_t)i.point_lights,
        "spot_lights", (Py_ssize_t)i.spot_lights, "sun_lights", (Py_ssize_t)i.sun_lights, "area_triangles",
        (Py_ssize_t)i.area_triangles, "sky_lights", (Py_ssize_t)i.sky_lights, "bounds", vec3(i.bounds_min),
        vec3(i.bounds_max), "cameras", (Py_ssize_t)i.cameras, "camera", camera_dict(&i.camera), "defaults", "photons",
        d->photons, "radius", (double)d->radius, "bounces", d->bounces, "width", d->width, "height", d->height,
        "exposure", (double)d->exposure, "surface_area", i.surface_area, "animated_objects",
        (Py_ssize_t)i.animated_objects, "anim_duration", i.anim_duration, "specular",
        i.specular == PGI_SPECULAR_PHONG ? "phong" : "ggx", "glossy_materials", (Py_ssize_t)i.glossy_materials,
        "portals", (Py_ssize_t)i.portals);
}

static PyObject *py_scene_camera(PyObject *self, PyObject *args) {
    PyObject *cap;
    Py_ssize_t k;
    if (!PyArg_ParseTuple(args, "On", &cap, &k)) return NULL;
    pgi_scene *s = scene_of(cap);
    if (!s) return NULL;
    pgi_camera_def c;
    pgi_status st = pgi_scene_get_camera(s, k < 0 ? (size_t)-1 : (size_t)k, &c);
    if (st) return fail(st, "no such camera");
    return camera_dict(&c);
}

static PyObject *py_scene_lights(PyObject *self, PyObject *args) {
    PyObject *cap;
    if (!PyArg_ParseTuple(args, "O", &cap)) return NULL;
    pgi_scene *s = scene_of(cap);
    if (!s) return NULL;
    static const char *const kinds[] = {"point", "spot", "sun", "area"};
    size_t n = pgi_scene_light_group_count(s);
    PyObject *list = PyList_New((Py_ssize_t)n);
    for (size_t i = 0; list && i < n; i++) {
        pgi_light_group g;
        pgi_status st = pgi_scene_get_light_group(s, i, &g);
        if (st) {
            Py_DECREF(list);
            return fail(st, "cannot read a light");
        }
        PyObject *d = Py_BuildValue("{s:s,s:s,s:N,s:n}", "kind", kinds[g.kind & 3], "name", g.name, "position",
                                    vec3(g.position), "triangles", (Py_ssize_t)g.triangles);
        if (!d) {
            Py_DECREF(list);
            return NULL;
        }
        PyList_SET_ITEM(list, (Py_ssize_t)i, d);
    }
    return list;
}

static PyObject *py_scene_set_light_position(PyObject *self, PyObject *args) {
    PyObject *cap;
    Py_ssize_t i;
    float p[3];
    if (!PyArg_ParseTuple(args, "On(fff)", &cap, &i, &p[0], &p[1], &p[2])) return NULL;
    pgi_scene *s = scene_of(cap);
    if (!s) return NULL;
    pgi_status st = pgi_scene_set_light_position(s, i < 0 ? (size_t)-1 : (size_t)i, p);
    if (st) return fail(st, "cannot move the light");
    Py_RETURN_NONE;
}

static PyObject *py_scene_set_time(PyObject *self, PyObject *args) {
    PyObject *cap;
    double t;
    if (!PyArg_ParseTuple(args, "Od", &cap, &t)) return NULL;
    pgi_scene *s = scene_of(cap);
    if (!s) return NULL;
    pgi_status st = pgi_scene_set_time(s, t);
    if (st) return fail(st, "cannot set the scene time");
    Py_RETURN_NONE;
}

static PyObject *py_scene_set_specular(PyObject *self, PyObject *args) {
    PyObject *cap;
    const char *m;
    if (!PyArg_ParseTuple(args, "Os", &cap, &m)) return NULL;
    pgi_scene *s = scene_of(cap);
    if (!s) return NULL;
    pgi_specular model = PGI_SPECULAR_DEFAULT;
    if (strcmp(m, "default") != 0 && !parse_specular(m, &model))
        return PyErr_Format(PyExc_ValueError, "specular must be 'ggx', 'phong' or 'default', got '%s'", m);
    pgi_status st = pgi_scene_set_specular(s, model);
    if (st) return fail(st, "cannot set the specular model");
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------- render */

static PyObject *py_renderer_create(PyObject *self, PyObject *args) {
    PyObject *cap;
    if (!PyArg_ParseTuple(args, "O", &cap)) return NULL;
    pgi_scene *s = scene_of(cap);
    if (!s) return NULL;
    pgi_renderer *r = NULL;
    pgi_status st;
    PyThreadState *ts = PyEval_SaveThread(); /* the GIL released */
    st = pgi_renderer_create(s, &r);
    PyEval_RestoreThread(ts);
    if (st) return fail(st, "cannot create a renderer");
    PyObject *out = PyCapsule_New(r, RENDERER_CAP, renderer_free);
    if (!out) pgi_renderer_destroy(r);
    return out;
}

/* Parses the (flag, value) pairs (the CLI's spelling: ("--photons", "200000")) into d and x. */
static int parse_settings(PyObject *pairs, pgi_render_desc *d, app_render_extra *x) {
    Py_ssize_t n = PyList_Size(pairs);
    if (n < 0) return 0;
    char err[400];
    for (Py_ssize_t i = 0; i < n; i++) {
        const char *flag, *value;
        if (!PyArg_ParseTuple(PyList_GET_ITEM(pairs, i), "ss", &flag, &value)) return 0;
        int rc = app_render_option(flag, value, d, x, NULL, err, sizeof err);
        if (rc < 0) {
            PyErr_SetString(PyExc_ValueError, err);
            return 0;
        }
        if (rc == 0) {
            char name[64];
            snprintf(name, sizeof name, "%s", flag + (strncmp(flag, "--", 2) == 0 ? 2 : 0));
            for (char *c = name; *c; c++)
                if (*c == '-') *c = '_';
            PyErr_Format(PyExc_TypeError,
                         "unknown render setting '%s' (photongi.estimators() lists the "
                         "estimators' options; 'photongi render --help' the others)",
                         name);
            return 0;
        }
    }
    int ck = app_render_check(d, x, err, sizeof err);
    if (ck == 0) PyErr_SetString(PyExc_ValueError, err);
    else if (ck < 0) PyErr_SetObject(g_error, Py_BuildValue("(ss)", err, "unsupported"));
    return ck > 0;
}

/* render(renderer, [(flag, value)...], view or None) -> (image, stats JSON). The pairs' strings
 * stay alive with the list, which the caller holds through the call. */
static PyObject *py_render(PyObject *self, PyObject *args) {
    PyObject *cap, *pairs, *view;
    if (!PyArg_ParseTuple(args, "OO!O", &cap, &PyList_Type, &pairs, &view)) return NULL;
    pgi_renderer *r = PyCapsule_GetPointer(cap, RENDERER_CAP);
    if (!r) return NULL;
    pgi_render_desc d = {.emission = PGI_EMISSION_AUTO}; /* as photongi render */
    app_render_extra x = APP_RENDER_EXTRA_INIT;
    if (!parse_settings(pairs, &d, &x)) return NULL;
    char cerr[1400];
    if (x.camera && !app_render_camera(pgi_renderer_scene(r), &d, &x, cerr, sizeof cerr)) {
        PyErr_SetString(PyExc_ValueError, cerr);
        return NULL;
    }
    pgi_camera_def cam;
    if (view != Py_None) {
        if (!PyArg_ParseTuple(view, "(fff)(fff)(fff)f", &cam.eye[0], &cam.eye[1], &cam.eye[2], &cam.look_at[0],
                              &cam.look_at[1], &cam.look_at[2], &cam.up[0], &cam.up[1], &cam.up[2], &cam.fov_y_deg))
            return NULL;
        d.view = &cam;
    }
    pgi_image img = {0};
    pgi_frame_stats fs;
    pgi_status st;
    PyThreadState *ts = PyEval_SaveThread(); /* the GIL released */
    if (x.progressive > 1) st = pgi_render_progressive(r, &d, (int)x.progressive, &img, &fs);
    else st = pgi_renderer_render(r, &d, &img, &fs);
    PyEval_RestoreThread(ts);
    if (st) {
        pgi_image_free(&img);
        return fail(st, "render failed");
    }
    char small[1];
    size_t n = pgi_stats_json(&fs, small, sizeof small);
    char *json = n ? malloc(n + 1) : NULL;
    if (!json) {
        pgi_image_free(&img);
        return PyErr_NoMemory();
    }
    pgi_stats_json(&fs, json, n + 1);
    PyObject *arr = array_take(&img);
    PyObject *out = arr ? Py_BuildValue("(Ns)", arr, json) : NULL;
    free(json);
    pgi_image_free(&img);
    return out;
}

/* reference(scene, width, height, bounces, seed, threads, camera, spp, time_limit_s, jitter, mean or
 * None, samples in mean) -> (mean, samples) */
static PyObject *py_reference(PyObject *self, PyObject *args) {
    PyObject *cap, *prev;
    pgi_reference_desc d = {0};
    unsigned long long seed, spp, have;
    int jitter;
    if (!PyArg_ParseTuple(args, "OiiiKiiKdiOK", &cap, &d.width, &d.height, &d.bounces, &seed, &d.threads, &d.camera,
                          &spp, &d.time_limit_s, &jitter, &prev, &have))
        return NULL;
    pgi_scene *s = scene_of(cap);
    if (!s) return NULL;
    d.seed = seed;
    d.spp = spp;
    d.jitter = (pgi_jitter)jitter;
    pgi_image mean = {0};
    uint64_t count = 0;
    if (prev != Py_None) {
        pgi_image v;
        PyObject *keep;
        if (!image_view(prev, "resume", &v, &keep)) return NULL;
        size_t bytes = (size_t)v.width * (size_t)v.height * 3 * sizeof(float);
        mean = (pgi_image){v.width, v.height, malloc(bytes ? bytes : 1)};
        if (!mean.rgb) {
            Py_DECREF(keep);
            return PyErr_NoMemory();
        }
        memcpy(mean.rgb, v.rgb, bytes);
        Py_DECREF(keep);
        count = have;
    }
    pgi_status st;
    PyThreadState *ts = PyEval_SaveThread(); /* the GIL released */
    st = pgi_reference_render(s, &d, &mean, &count);
    PyEval_RestoreThread(ts);
    if (st) {
        pgi_image_free(&mean);
        return fail(st, "reference failed");
    }
    PyObject *arr = array_take(&mean);
    return arr ? Py_BuildValue("(NK)", arr, (unsigned long long)count) : NULL;
}

/* ----------------------------------------------------- images, metrics */

static PyObject *py_compare(PyObject *self, PyObject *args) {
    PyObject *oa, *ob, *ka, *kb;
    float exposure;
    if (!PyArg_ParseTuple(args, "OOf", &oa, &ob, &exposure)) return NULL;
    pgi_image a, b;
    if (!image_view(oa, "a", &a, &ka)) return NULL;
    if (!image_view(ob, "b", &b, &kb)) {
        Py_DECREF(ka);
        return NULL;
    }
    npy_intp dims[2] = {a.height, a.width};
    PyObject *map = PyArray_SimpleNew(2, dims, NPY_FLOAT32);
    pgi_metrics m;
    pgi_status st = PGI_OK;
    if (map) {
        float *mp = PyArray_DATA((PyArrayObject *)map);
        PyThreadState *ts = PyEval_SaveThread(); /* the GIL released */
        st = pgi_metrics_compute_flip(&a, &b, exposure, PGI_FLIP_DEFAULT_PPD, mp, &m);
        PyEval_RestoreThread(ts);
    }
    Py_DECREF(ka);
    Py_DECREF(kb);
    if (!map) return NULL;
    if (st) {
        Py_DECREF(map);
        return fail(st, "cannot compare the images");
    }
    return Py_BuildValue("({s:i,s:i,s:d,s:d,s:d,s:d,s:(ddd),s:d,s:d,s:{s:d,s:d,s:d,s:d,s:d,s:d,s:d}}N)", "width",
                         m.width, "height", m.height, "mse", m.mse, "psnr", m.psnr, "ssim", m.ssim, "ssim_rgb",
                         m.ssim_rgb, "ssim_channel", m.ssim_channel[0], m.ssim_channel[1], m.ssim_channel[2], "max_abs",
                         m.max_abs, "relmse", m.relmse, "flip", "mean", m.flip.mean, "median", m.flip.weighted_median,
                         "q1", m.flip.weighted_q1, "q3", m.flip.weighted_q3, "min", m.flip.min, "max", m.flip.max,
                         "ppd", (double)m.flip.ppd, map);
}

static PyObject *py_read_image(PyObject *self, PyObject *args) {
    const char *path;
    if (!PyArg_ParseTuple(args, "s", &path)) return NULL;
    pgi_image img = {0};
    int hdr = 0;
    pgi_status st;
    PyThreadState *ts = PyEval_SaveThread(); /* the GIL released */
    st = pgi_image_read(path, &img, &hdr);
    PyEval_RestoreThread(ts);
    if (st) return fail(st, "cannot read the image");
    return array_take(&img);
}

static PyObject *py_write_image(PyObject *self, PyObject *args) {
    PyObject *obj, *keep;
    const char *path;
    float exposure;
    if (!PyArg_ParseTuple(args, "Osf", &obj, &path, &exposure)) return NULL;
    pgi_image img;
    if (!image_view(obj, "image", &img, &keep)) return NULL;
    pgi_status st;
    PyThreadState *ts = PyEval_SaveThread(); /* the GIL released */
    st = pgi_image_write(&img, path, exposure);
    PyEval_RestoreThread(ts);
    Py_DECREF(keep);
    if (st) return fail(st, "cannot write the image");
    Py_RETURN_NONE;
}

/* ------------------------------------------------ what the library has */

static PyObject *py_estimators(PyObject *self, PyObject *noargs) {
    static const char *const types[] = {"", "int", "float", "choice"};
    char gpu[256];
    pgi_device_estimators(gpu, sizeof gpu);
    PyObject *list = PyList_New(0);
    for (size_t e = 0; list && e < pgi_estimator_count(); e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        pgi_estimator_desc def;
        pgi_estimator_desc zero = {0};
        if (pgi_estimator_desc_resolve(vt, &zero, &def) != PGI_OK) memset(&def, 0, sizeof def);
        PyObject *opts = PyList_New(0);
        for (size_t i = 0; opts && i < pgi_option_count(); i++) {
            const pgi_option *o = pgi_option_at(i);
            if (!pgi_estimator_takes(vt, o)) continue;
            char dv[64];
            pgi_option_format(o, &def, dv, sizeof dv);
            PyObject *od = Py_BuildValue("{s:s,s:s,s:d,s:d,s:s,s:s,s:s}", "name", o->name, "type", types[o->type & 3],
                                         "min", o->min, "max", o->max, "choices", o->choices ? o->choices : "",
                                         "default", dv, "help", o->help);
            if (!od || PyList_Append(opts, od) < 0) Py_CLEAR(opts);
            Py_XDECREF(od);
        }
        size_t n = strlen(vt->name);
        int on_gpu = 0;
        for (const char *p = gpu; (p = strstr(p, vt->name)) != NULL; p += n)
            if ((p == gpu || p[-1] == ' ') && (p[n] == 0 || p[n] == ',')) on_gpu = 1;
        PyObject *d =
            opts ? Py_BuildValue("{s:s,s:s,s:O,s:O,s:O,s:N}", "name", vt->name, "summary", vt->summary, "exact",
                                 vt->exact ? Py_True : Py_False, "oracle", vt->oracle ? Py_True : Py_False, "gpu",
                                 on_gpu ? Py_True : Py_False, "options", opts)
                 : NULL;
        if (!d || PyList_Append(list, d) < 0) Py_CLEAR(list);
        Py_XDECREF(d);
    }
    return list;
}

static PyObject *py_builtin_scenes(PyObject *self, PyObject *noargs) {
    PyObject *list = PyList_New(0);
    for (size_t i = 0; list && i < pgi_builtin_scene_count(); i++) {
        PyObject *s = PyUnicode_FromString(pgi_builtin_scene_name(i));
        if (!s || PyList_Append(list, s) < 0) Py_CLEAR(list);
        Py_XDECREF(s);
    }
    return list;
}

static PyObject *py_devices(PyObject *self, PyObject *noargs) {
    PyObject *list = PyList_New(0);
    int n = pgi_device_count();
    for (int i = 0; list && i < n; i++) {
        char name[256], drv[512];
        if (pgi_device_name(i, name, sizeof name) != PGI_OK) continue;
        if (pgi_device_driver(i, drv, sizeof drv) != PGI_OK) drv[0] = 0;
        PyObject *d = Py_BuildValue("{s:s,s:s,s:s}", "device", "", "name", name, "driver", drv);
        PyObject *spec = PyUnicode_FromFormat("vulkan:%d", i);
        if (!d || !spec || PyDict_SetItemString(d, "device", spec) < 0 || PyList_Append(list, d) < 0) Py_CLEAR(list);
        Py_XDECREF(spec);
        Py_XDECREF(d);
    }
    return list;
}

static PyObject *py_version(PyObject *self, PyObject *noargs) { return PyUnicode_FromString(pgi_version()); }

static PyObject *py_peak_rss(PyObject *self, PyObject *noargs) {
    return PyLong_FromUnsignedLongLong(pgi_memory_peak_rss());
}

static PyMethodDef k_methods[] = {{"version", py_version, METH_NOARGS, "The library's version."},
                                  {"scene_load", py_scene_load, METH_VARARGS, NULL},
                                  {"scene_info", py_scene_info, METH_VARARGS, NULL},
                                  {"scene_camera", py_scene_camera, METH_VARARGS, NULL},
                                  {"scene_lights", py_scene_lights, METH_VARARGS, NULL},
                                  {"scene_set_light_position", py_scene_set_light_position, METH_VARARGS, NULL},
                                  {"scene_set_time", py_scene_set_time, METH_VARARGS, NULL},
                                  {"scene_set_specular", py_scene_set_specular, METH_VARARGS, NULL},
                                  {"renderer_create", py_renderer_create, METH_VARARGS, NULL},
                                  {"render", py_render, METH_VARARGS, NULL},
                                  {"reference", py_reference, METH_VARARGS, NULL},
                                  {"compare", py_compare, METH_VARARGS, NULL},
                                  {"read_image", py_read_image, METH_VARARGS, NULL},
                                  {"write_image", py_write_image, METH_VARARGS, NULL},
                                  {"estimators", py_estimators, METH_NOARGS, NULL},
                                  {"builtin_scenes", py_builtin_scenes, METH_NOARGS, NULL},
                                  {"devices", py_devices, METH_NOARGS, NULL},
                                  {"peak_rss", py_peak_rss, METH_NOARGS, NULL},
                                  {NULL, NULL, 0, NULL}};

static struct PyModuleDef k_module = {PyModuleDef_HEAD_INIT,
                                      "_photongi",
                                      "The C half of the photongi package (use `import photongi`).",
                                      -1,
                                      k_methods,
                                      NULL,
                                      NULL,
                                      NULL,
                                      NULL};

PyMODINIT_FUNC PyInit__photongi(void) {
    import_array();
    PyObject *m = PyModule_Create(&k_module);
    if (!m) return NULL;
    g_error = PyErr_NewExceptionWithDoc("photongi.Error",
                                        "A failure of the photongi library: args are (message, status), the status "
                                        "one of 'invalid argument', 'i/o error', 'parse error', 'out of memory', "
                                        "'unsupported', 'internal error'.",
                                        PyExc_RuntimeError, NULL);
    if (!g_error || PyModule_AddObject(m, "Error", g_error) < 0) {
        Py_XDECREF(g_error);
        Py_DECREF(m);
        return NULL;
    }
    Py_INCREF(g_error);
    return m;
}
