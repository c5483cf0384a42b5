/* photongi estimators: the one interface every density-estimation method
 * implements (docs/estimators.md), and the data they read.
 *
 * An estimator turns a photon map (pgi_photons) into indirect radiance at every
 * view sample (pgi_view_samples). Lifecycle:
 *
 *   pgi_estimator *e;
 *   pgi_estimator_create("hashgrid", &(pgi_estimator_desc){0}, &e);  // once
 *   pgi_estimate_args a = {.photons = &ph, .samples = &vs, .camera = &cam, .out_rgb = buf,
 *                          .radius = 0.05f};
 *   pgi_estimator_build(e, &a);      // per frame: acceleration structures
 *   pgi_estimator_estimate(e, &a);   // writes 3 floats per view sample
 *   pgi_estimator_stats st; pgi_estimator_get_stats(e, &st);
 *   pgi_estimator_destroy(e);
 *
 * The arrays in pgi_photons / pgi_view_samples are borrowed for the duration
 * of build + estimate. All exact estimators agree with "brute" up to float
 * summation order (constant kernel, fixed radius).
 */
#ifndef PHOTONGI_ESTIMATOR_H
#define PHOTONGI_ESTIMATOR_H

#include <stddef.h>
#include <stdint.h>

#include "photongi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Photon map, structure of arrays. Direction (dx,dy,dz) is the unit vector
 * pointing back the way the photon came (ω_p, away from the surface). */
typedef struct pgi_photons {
    size_t count, capacity;
    float *px, *py, *pz; /* position */
    float *dx, *dy, *dz; /* incoming direction, pointing away from the surface */
    float *fr, *fg, *fb; /* flux (W), already divided by the paths emitted */
    float *nx, *ny, *nz; /* geometric normal where it was stored */
    float *radius;       /* optional per-photon footprint radius (radius policies); NULL: the
                                estimator's fixed radius. Only estimators with PGI_EST_CAP_PHOTON_RADIUS
                                accept it. Not allocated by pgi_photons_alloc. */
    uint64_t emitted;    /* light paths emitted to produce them */
    /* Optional skewed-ellipsoid footprints (photon differentials, BVH paper §3.2/§4); NULL: spheres.
       Photon i's ellipsoid is {p + u*a + v*b + w*radius[i]*n : u^2 + v^2 + w^2 < 1} with the semi-axes
       a = (sax,say,saz)[i], b = (sbx,sby,sbz)[i] in its tangent plane and n = (nx,ny,nz)[i]; radius[i]
       must then hold the equivalent radius sqrt(|a x b|) (its footprint area is pi |a x b|). Not
       allocated by pgi_photons_alloc. */
    float *sax, *say, *saz, *sbx, *sby, *sbz;
} pgi_photons;

/* Pinhole camera, world space. */
typedef struct pgi_camera {
    float eye[3];
    float forward[3], right[3], up[3]; /* orthonormal, right-handed view basis */
    float tan_half_fov_y;              /* tan(fov_y/2) */
    float aspect;                      /* width / height */
    int width, height;
} pgi_camera;

enum {
    PGI_VS_VALID = 1,   /* hit a non-specular surface (else: sky or lost) */
    PGI_VS_PRIMARY = 2, /* reached directly by the primary ray (no mirror/glass on the way) */
    PGI_VS_LAMBERT = 4, /* material is purely Lambertian (ks = 0) */
    PGI_VS_GGX = 8      /* microfacet plastic (ks = lobe tint, shininess = GGX alpha, ior); else Blinn-Phong */
};

/* View samples (G-buffer): one per pixel, index y*width + x, one plane per
 * attribute (3 floats a sample for the vector ones). */
typedef struct pgi_view_samples {
    int width, height;
    size_t count;     /* width * height */
    float *pos;       /* world position of the first non-specular eye hit */
    float *nrm;       /* shading normal, on the side the eye path arrives from */
    float *ngeo;      /* geometric normal, same side */
    float *wo;        /* unit direction towards where the eye path came from */
    float *kd;        /* diffuse albedo (texture applied), linear RGB */
    float *ks;        /* Blinn-Phong F0; PGI_VS_GGX: the lobe's tint; 0 for Lambertian */
    float *shininess; /* Blinn-Phong exponent s; PGI_VS_GGX: GGX alpha */
    float *ior;       /* PGI_VS_GGX: index of refraction of the plastic's dielectric (its Fresnel) */
    float *weight;    /* throughput of the specular chain from the eye (1 if primary) */
    float *depth;     /* view-space depth (along camera forward) of the primary hit */
    uint8_t *flags;   /* PGI_VS_* */
    float jitter;     /* how far (in pixels, along x and along y) a PGI_VS_PRIMARY sample's primary ray may
                         pass from its pixel's centre: 0 = through the centre (pgi_view_samples_alloc's
                         value), 0.5 = anywhere in the pixel (the renderer's jittered frames). Estimators
                         that find samples by projecting onto the screen (bounds3d, bounds25d) widen their
                         bounds by it, so that they stay exact. */
} pgi_view_samples;

/* Density-estimation kernels (tiled paper §2.2); each is normalised to
 * integrate to 1 over its disk of radius r. */
typedef enum pgi_kernel {
    PGI_KERNEL_CONSTANT = 0, /* 1/(pi r^2) */
    PGI_KERNEL_CONE,         /* 3/(pi r^2) (1 - d/r) */
    PGI_KERNEL_EPANECHNIKOV, /* 2/(pi r^2) (1 - d^2/r^2) */
    PGI_KERNEL_COUNT_
} pgi_kernel;

/* BVH photon map builders (BVH paper §5). */
typedef enum pgi_bvh_build { PGI_BVH_LINEAR = 0, PGI_BVH_VVH = 1 } pgi_bvh_build;

/* Named values of the directional options where the option's own zero would
 * mean "default" (zero means default in every desc). */
enum {
    PGI_DIRECTIONAL_LEAVES = -1, /* directional.level: flux buckets at the leaves */
    PGI_DIRECTIONAL_NO_BLUR = -1 /* directional.blur: no irradiance blur */
};

/* Creation options of an estimator. Zero means default for every field;
 * pgi_estimator_create fills in the defaults and checks every range (the
 * option tables below hold both). Each method reads only its own
 * sub-struct, so one desc can create every estimator. Per-frame values
 * (radius, seed, threads) are arguments of build/estimate instead: an
 * estimator is created once per configuration and reused across frames. */
typedef struct pgi_estimator_desc {
    pgi_kernel kernel; /* default constant; others need PGI_EST_CAP_KERNELS */
    int subsample;     /* stochastic subsampling factor k (0 or 1: off, up to 64); needs PGI_EST_CAP_SUBSAMPLE */
    struct {
        int tile_size; /* "tiled", "bounds3d", "bounds25d": tile edge in pixels (1..4096); default 16 for tiled, 32 for the bounds methods */
    } tiled;
    struct {
        float cell_size; /* "hashgrid": cell edge (at least radius/64); 0 = 2 x the frame's radius */
    } hashgrid;
    struct {
        int tile; /* "cluster*", "directional": cluster edge in pixels (1..256); default 8 (directional: a 64th of the
                     image's shorter side, 1..8) */
    } cluster;
    struct {
        int level; /* flux buckets this many levels above the leaves (1..16); default 1;
                            PGI_DIRECTIONAL_LEAVES: at the leaves */
        int blur;  /* irradiance blur radius in pixels (1..64); default 4; PGI_DIRECTIONAL_NO_BLUR: off */
    } directional;
    struct {
        pgi_bvh_build build; /* default PGI_BVH_LINEAR */
        int leaf_size;       /* leaf-size threshold (1..65536); 0 = T_auto */
    } bvh;
    struct {
        int knn; /* k nearest photons within the radius (1..4096); 0 = fixed-radius range mode */
    } kdtree;
    struct {
        int polygon; /* "bounds25d": vertices of the screen polygon around a projected sphere
                            (even, 4..64); default 8 */
    } bounds;
} pgi_estimator_desc;

/* A request to stop work early (a lock-free atomic flag): the caller creates one, hands it to the
 * work (pgi_render_desc.cancel, pgi_estimate_args.cancel) and requests from any thread, or from a
 * signal handler, while the work runs; the work returns PGI_ERR_CANCELLED at its next check. The
 * request stands until pgi_cancel_reset: a call given a requested token stops at its first check. */
typedef struct pgi_cancel pgi_cancel;
pgi_status pgi_cancel_create(pgi_cancel **out);
void pgi_cancel_destroy(pgi_cancel *c);
void pgi_cancel_request(pgi_cancel *c);
void pgi_cancel_reset(pgi_cancel *c);
/* 1 once requested (until reset); 0 for NULL. */
int pgi_cancel_requested(const pgi_cancel *c);

/* Per-frame arguments: build and the estimate that follows it take the same. */
typedef struct pgi_estimate_args {
    const pgi_photons *photons;
    const pgi_view_samples *samples;
    const pgi_camera *camera;
    float *out_rgb;           /* estimate: 3 floats a view sample, indirect radiance (weight not applied) */
    float radius;             /* this frame's photon radius (> 0, finite); per-photon radii take its place */
    uint64_t seed;            /* stochastic subsampling: per-pixel random streams from (seed, pixel index) */
    int threads;              /* OpenMP threads of this call's parallel regions; 0 = OpenMP's default */
    float scene_area;         /* scene surface area ("bvh" T_auto); 0 = the surface of the photons' bounding box */
    const pgi_cancel *cancel; /* may be NULL; once requested, build and estimate stop early (within a few
                                 hundred view samples or photons a thread) and return PGI_ERR_CANCELLED,
                                 out_rgb then partly written; an estimator of the caller's own may ignore
                                 it (the call still returns PGI_ERR_CANCELLED) */
} pgi_estimate_args;

/* ---- Options: one table row per setting holds its name, range, default
 * and help. The CLI and the viewer parse and document estimator options
 * from these tables; pgi_estimator_create checks a desc against them. */
typedef enum pgi_option_type {
    PGI_OPTION_INT = 1,   /* int field */
    PGI_OPTION_FLOAT = 2, /* float field */
    PGI_OPTION_CHOICE = 3 /* enum field: one of `choices` ("a|b|c"), stored as its index */
} pgi_option_type;

typedef struct pgi_option {
    const char *name; /* "cluster-tile": the CLI flag without "--", and the key of pgi_estimator_desc_set */
    pgi_option_type type;
    size_t offset;       /* of the field in pgi_estimator_desc */
    double min, max;     /* INT: range a user may write; FLOAT: (min, max], min exclusive */
    int step;            /* INT: the value must be a multiple of step (0: any) */
    int zero;            /* INT with min 0: the field value a user's 0 stands for (PGI_DIRECTIONAL_LEAVES) */
    int def;             /* INT: the value a zero field resolves to (0: zero is itself the default mode) */
    const char *choices; /* CHOICE: "constant|cone|epanechnikov" */
    unsigned caps;       /* shared options: the PGI_EST_CAP_* an estimator needs to take it; 0 otherwise */
    unsigned flags;      /* PGI_OPTION_STRICT */
    const char *help;    /* one line, with the range and the default */
} pgi_option;

/* Setting a strict option for an estimator that does not take it is an error
 * (it changes what is computed); other options of other estimators are
 * ignored, so one desc can serve every estimator. Shared options (caps) are
 * always strict. */
#define PGI_OPTION_STRICT 1u

#define PGI_EST_MAX_ENTRIES 12

typedef struct pgi_estimator_stats {
    double build_ms, estimate_ms;
    const char *pass_names[PGI_EST_MAX_ENTRIES];
    double pass_ms[PGI_EST_MAX_ENTRIES];
    int pass_count;
    const char *memory_names[PGI_EST_MAX_ENTRIES];
    size_t memory_bytes[PGI_EST_MAX_ENTRIES];
    int memory_count;
    uint64_t reads, contributing, nodes_visited;
    uint64_t reads_bulk; /* of reads: (photon, sample) pairs accepted as a node's sum without reading each photon
                            ("cluster-trivial"'s trivial accept); reads - reads_bulk were read one by one */
    int leaf_size;       /* "bvh": the leaf-size threshold used (T_auto or given) */
} pgi_estimator_stats;

/* One method: a const table of function pointers, dispatched once per pass. */
typedef struct pgi_estimator_vtbl {
    const char *name;
    const char *summary;
    int exact;  /* equals brute for a constant kernel and fixed radius */
    int oracle; /* the O(photons x pixels) reference every exact method is tested against */
    pgi_status (*create)(const pgi_estimator_desc *desc, void **state);
    pgi_status (*build)(void *state, const pgi_estimate_args *args);
    pgi_status (*estimate)(void *state, const pgi_estimate_args *args);
    void (*stats)(const void *state, pgi_estimator_stats *out);
    void (*destroy)(void *state);
    unsigned caps; /* PGI_EST_CAP_* this method supports beyond the constant-kernel fixed-radius case */
    const pgi_option *const *options; /* its own options (NULL-terminated; NULL: none) */
    /* Its own defaults for options it shares with others (NULL-terminated by .option; NULL:
     * the rows' defaults), e.g. tiled's 16-pixel tiles on the --tile row that bounds3d/25d
     * default to 32. */
    const struct pgi_option_default *defaults;
    /* About the bytes its structures and build scratch hold per photon and per view sample (a
     * little above what it reports in its stats): the memory budget's up-front check of a frame
     * (pgi_render_desc.max_memory) uses them before anything is traced. Both 0: 64 each. */
    size_t bytes_per_photon, bytes_per_sample;
} pgi_estimator_vtbl;

/* An estimator's default for a shared option row. */
typedef struct pgi_option_default {
    const pgi_option *option;
    int value;
} pgi_option_default;

enum {
    PGI_EST_CAP_KERNELS = 1,      /* honours desc.kernel */
    PGI_EST_CAP_SUBSAMPLE = 2,    /* honours desc.subsample */
    PGI_EST_CAP_PHOTON_RADIUS = 4 /* honours pgi_photons.radius (per-photon footprints) */
};

size_t pgi_estimator_count(void);
const pgi_estimator_vtbl *pgi_estimator_at(size_t i);
/* NULL if no estimator has that name. */
const pgi_estimator_vtbl *pgi_estimator_find(const char *name);
/* The estimator a desc without one gets: the fastest exact one on the shipped scenes at their
 * defaults (automatic radius included), with a GPU version (docs/estimators.md, "Choosing an
 * estimator"). It takes neither kernels nor subsampling: those options name the estimators that do. */
#define PGI_DEFAULT_ESTIMATOR "cluster-trivial"

/* Every estimator option, each once: the shared ones ("kernel", "subsample":
 * every estimator with the matching capability takes them), then each
 * estimator's own in registry order. */
size_t pgi_option_count(void);
const pgi_option *pgi_option_at(size_t i); /* NULL past the end */
/* "tiled, bounds3d, bounds25d": the estimators that take option o, into buf. */
void pgi_option_takers(const pgi_option *o, char *buf, size_t size);
/* 1 if estimator `vt` takes option `o` (its own, or a shared one it has the capability for). */
int pgi_estimator_takes(const pgi_estimator_vtbl *vt, const pgi_option *o);
/* The option called `name` (without "--") among every estimator's and the shared ones; NULL if none. */
const pgi_option *pgi_option_find(const char *name);
/* Parses `value` as a user writes it (the CLI's spelling: 0 = leaves, "vvh", ...) into its field of
 * `desc`. Unknown name or bad value: PGI_ERR_INVALID_ARG, with a message naming "--name". */
pgi_status pgi_estimator_desc_set(pgi_estimator_desc *desc, const char *name, const char *value);
/* Writes the option's value in `desc` as a user would write it ("8", "vvh", "0" for the leaves). */
void pgi_option_format(const pgi_option *o, const pgi_estimator_desc *desc, char *buf, size_t size);
/* The desc estimator `vt` would be created with: defaults filled in, every range checked (one
 * message per setting, from the option tables), options of other estimators cleared. */
pgi_status pgi_estimator_desc_resolve(const pgi_estimator_vtbl *vt, const pgi_estimator_desc *in,
                                      pgi_estimator_desc *out);

typedef struct pgi_estimator pgi_estimator;
/* Unknown name or an option out of range: PGI_ERR_INVALID_ARG. */
pgi_status pgi_estimator_create(const char *name, const pgi_estimator_desc *desc, pgi_estimator **out);
/* Per frame: build, then estimate with the same args (radius <= 0 or not finite: PGI_ERR_INVALID_ARG). */
pgi_status pgi_estimator_build(pgi_estimator *e, const pgi_estimate_args *args);
pgi_status pgi_estimator_estimate(pgi_estimator *e, const pgi_estimate_args *args);
void pgi_estimator_get_stats(const pgi_estimator *e, pgi_estimator_stats *out);
const char *pgi_estimator_name(const pgi_estimator *e);
/* The resolved desc the estimator was created with. */
void pgi_estimator_get_desc(const pgi_estimator *e, pgi_estimator_desc *out);
void pgi_estimator_destroy(pgi_estimator *e);

/* Photon and view-sample buffers owned by the caller of these helpers. */
pgi_status pgi_photons_alloc(pgi_photons *ph, size_t capacity);
void pgi_photons_free(pgi_photons *ph);
pgi_status pgi_view_samples_alloc(pgi_view_samples *vs, int width, int height);
void pgi_view_samples_free(pgi_view_samples *vs);
/* Builds a pinhole camera from a look-at description. */
void pgi_camera_look_at(pgi_camera *cam, const float eye[3], const float look_at[3], const float up[3], float fov_y_deg,
                        int width, int height);

#ifdef __cplusplus
}
#endif

#endif
