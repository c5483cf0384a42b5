/* bounds3d / bounds25d: photon-major scattering (tiled paper §2.2): every
 * photon's sphere of effect is bounded on the screen and every pixel inside
 * the bound is tested against the sphere (the same per-photon decision as
 * brute, pgi__gather).
 *
 *  - bounds3d: an icosahedron circumscribing the sphere (McGuire & Luebke
 *    2009), its 12 vertices projected; the bound is their convex hull. No
 *    depth test: every covered pixel is tested (what a rasterizer without a
 *    two-sided depth test launches).
 *  - bounds25d: the tightest N-gon around the sphere's projected silhouette
 *    (Mara & McGuire 2013): for N/2 directions theta_k = k pi/(N/2) in the
 *    image plane, the two planes through the eye tangent to the sphere that
 *    contain the image direction perpendicular to theta_k give two exact
 *    supporting lines of the projected ellipse; N = 4 is the axis-aligned
 *    box. Plus the sphere's depth range [z - r, z + r]: a covered pixel whose
 *    view sample lies outside it is rejected before the sphere test.
 *
 * Race-free, deterministic scattering on the CPU: (1) per tile, whether it
 * has valid primary samples; the samples seen through mirrors/glass grouped
 * in view-space cells (spec_cells.h); (2) count, (3) scan, (4) fill: every
 * photon index goes into the bin of every primary tile its bound's rectangle
 * touches and of every cell its sphere may reach (bins 0 .. ntiles - 1 are
 * the tiles, then one per cell; fixed photon chunks, as in "tiled"); (5)
 * scatter: bins in parallel, each applies its photons in photon-index order
 * to its own samples' sums, so every sample sums photons in the same order as
 * brute, whatever the thread count. A tile writes its primary and invalid
 * pixels, a cell its samples: every pixel is written once.
 *
 * Conservative cases. Spheres that reach the eye plane (the icosahedron's
 * vertices or the sphere not strictly in front of the eye) cannot be
 * projected whole: clipped_shape bounds them slice by slice (2.5D keeps the
 * depth range; 3D uses the icosahedron's circumsphere); a sphere holding the
 * eye covers the whole screen.
 * Samples seen through mirrors (no PGI_VS_PRIMARY) are not where the pixel
 * ray says, so projection cannot find them: they are left out of the tiles
 * and grouped by position instead, in hashed cells of edge >= 2r in view
 * space (as in "tiled"); a photon is also binned to every cell whose box of
 * samples its sphere overlaps, and tests all of that cell's samples.
 * The sphere is inflated by a relative 1e-4 (plus float slack) and the
 * polygon by 0.05 pixel, so rounding never drops a pixel the test accepts;
 * the extra pixels only cost tests. A primary sample lies on a ray through
 * its pixel's centre only when the frame is not jittered: in general its
 * projection is within vs->jitter pixels (along x and y) of the centre, so
 * the bound is widened by that much (0.5 for jittered frames: every side
 * moves out by jitter (|a| + |b|) for a unit normal (a, b)) and tested at
 * pixel centres as before.
 *
 * Stats: reads = sphere tests (pixel, photon), contributing = the accepted
 * ones, nodes_visited = covered pixels with a valid primary sample (before
 * the 2.5D depth test). Wasted tests = reads - contributing. */
#ifdef _OPENMP
#include <omp.h>
#endif

#include "estimator_internal.h"
#include "spec_cells.h"

#define MAXE 64          /* half-planes of a bound */
#define PIX_MARGIN 0.05f /* pixels */

typedef struct {
    pgi__est_common c;
    int mode3d, nverts;
    int T, ntx, nty, ntiles, W, H;
    float jitter;     /* the view samples' (pgi_view_samples.jitter) */
    uint8_t *primary; /* per tile: has valid primary samples */
    size_t primary_cap;
    pgi__spec_cells cells; /* samples seen through mirrors/glass: bins ntiles .. nbins - 1 */
    int nbins;             /* ntiles + cells.n */
    float *cview;          /* photon centres in view space, 3 a photon */
    size_t cview_cap;
    uint32_t *counts; /* [chunk][bin] */
    size_t counts_cap;
    uint32_t *tile_start; /* nbins + 1 */
    size_t tile_start_cap;
    uint32_t *bins; /* photon indices, per bin in photon order */
    size_t bins_cap;
    size_t nbinned;
    size_t nphotons;
} bounds_state;
_Static_assert(offsetof(bounds_state, c) == 0, "pgi__est_default_stats reads the state as its pgi__est_common");

/* A screen bound: pixel rectangle (pixel centres at integers), half-planes
 * a X + b Y <= c with (a, b) unit, and (2.5D) a depth range. */
typedef struct {
    float x0, x1, y0, y1;
    float pad; /* vs->jitter: how far a primary sample projects from its pixel centre */
    int n;
    float a[MAXE], b[MAXE], c[MAXE];
    float zlo, zhi;
    int use_depth;
} shape;

/* Tangent slopes u of the planes x' = u z through the eye that touch the
 * circle (a, z, r), z > r (as in est_tiled.c). */
static inline void silhouette(float a, float z, float r, float *u0, float *u1) {
    float den = (z - r) * (z + r);
    float disc = sqrtf(fmaxf(0.f, a * a + den));
    *u0 = (a * z - r * disc) / den;
    *u1 = (a * z + r * disc) / den;
}

static inline void add_edge(shape *sh, float a, float b, float c) {
    float l = sqrtf(a * a + b * b);
    if (!(l > 0.f) || sh->n >= MAXE) return;
    sh->a[sh->n] = a / l;
    sh->b[sh->n] = b / l;
    sh->c[sh->n] = c / l + PIX_MARGIN + sh->pad * (fabsf(a) + fabsf(b)) / l;
    sh->n++;
}

static inline float px_of(const pgi__view_xf *x, float xi) { return (xi / x->sx + 1.f) * 0.5f * (float)x->W - 0.5f; }
static inline float py_of(const pgi__view_xf *x, float yi) { return (1.f - yi / x->sy) * 0.5f * (float)x->H - 0.5f; }

static const float k_ico[12][3] = {
    {0, 1, 1.6180340f}, {0, -1, 1.6180340f}, {0, 1, -1.6180340f}, {0, -1, -1.6180340f},
    {1, 1.6180340f, 0}, {-1, 1.6180340f, 0}, {1, -1.6180340f, 0}, {-1, -1.6180340f, 0},
    {1.6180340f, 0, 1}, {-1.6180340f, 0, 1}, {1.6180340f, 0, -1}, {-1.6180340f, 0, -1},
};
#define ICO_INRADIUS 1.5115226f /* of the icosahedron above: phi^2 / sqrt(3) */

static inline float cross2(const float *o, const float *a, const float *b) {
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

/* Bound of a sphere (view-space centre c, radius ri) that reaches the eye
 * plane, by slices (the clipped case of Mara & McGuire 2013): for each image
 * direction theta_k the sphere, seen along the perpendicular image direction,
 * is a circle (a, z, ri) in the plane through the eye. When the eye lies
 * outside that circle, its points in front of the eye (z > 0) project to
 * x' = tan(psi) with psi within the circle's wedge of directions
 * [psi_c - alpha, psi_c + alpha] (alpha = asin(ri/d)) intersected with
 * (-pi/2, pi/2): a bound on one or both sides. A wedge entirely behind the eye
 * means the sphere has no point in front: 0 is returned. Directions where the
 * eye is inside the circle give no bound. Double precision plus an angular
 * margin of 1e-6 keep it conservative. */
static int clipped_shape(const pgi__view_xf *x, pgi__v3 c, float ri, int m, shape *sh) {
    const double HALF = 0.5 * 3.14159265358979323846, TWO_PI = 2.0 * 3.14159265358979323846;
    const float ax = 2.f * x->sx / (float)x->W, bx = x->sx * (1.f / (float)x->W - 1.f);
    const float ay = -2.f * x->sy / (float)x->H, by = x->sy * (1.f - 1.f / (float)x->H);
    sh->n = 0;
    sh->x0 = -1.f;
    sh->y0 = -1.f;
    sh->x1 = (float)x->W;
    sh->y1 = (float)x->H;
    for (int k = 0; k < m; k++) {
        double th = 3.14159265358979323846 * (double)k / (double)m, cs = cos(th), sn = sin(th);
        double a = (double)c.x * cs + (double)c.y * sn, z = c.z, r = ri;
        double d2 = a * a + z * z;
        if (!(d2 > r * r * (1.0 + 1e-6))) continue; /* eye inside the circle: no bound */
        double alpha = asin(r / sqrt(d2)) + 1e-6, pc = atan2(a, z);
        double lo = pc - alpha, hi = pc + alpha;
        /* the representation of the wedge that meets (-pi/2, pi/2), if any */
        if (hi <= -HALF) lo += TWO_PI, hi += TWO_PI;
        else if (lo >= HALF) lo -= TWO_PI, hi -= TWO_PI;
        if (hi <= -HALF || lo >= HALF) return 0; /* nothing in front of the eye */
        int has_lo = lo > -HALF + 1e-6, has_hi = hi < HALF - 1e-6;
        float tlo = has_lo ? (float)tan(lo) : 0.f, thi = has_hi ? (float)tan(hi) : 0.f;
        float C0 = (float)cs * bx + (float)sn * by;
        if (k == 0) {
            if (has_lo) sh->x0 = fmaxf(sh->x0, px_of(x, tlo));
            if (has_hi) sh->x1 = fminf(sh->x1, px_of(x, thi));
        } else if (2 * k == m) {
            if (has_hi) sh->y0 = fmaxf(sh->y0, py_of(x, thi));
            if (has_lo) sh->y1 = fminf(sh->y1, py_of(x, tlo));
        } else {
            float A = (float)cs * ax, B = (float)sn * ay;
            if (has_hi) add_edge(sh, A, B, thi - C0);
            if (has_lo) add_edge(sh, -A, -B, C0 - tlo);
        }
    }
    return 1;
}

/* Bound of a photon sphere (view-space centre c, radius r). Returns 0 when
 * no primary sample can be inside the sphere (it lies behind the eye, or its
 * bound misses the screen). */
static int make_shape(const bounds_state *s, const pgi__view_xf *x, pgi__v3 c, float r, shape *sh) {
    float ri = pgi__pad_radius(c, r);
    sh->n = 0;
    sh->pad = s->jitter;
    sh->zlo = c.z - ri;
    sh->zhi = c.z + ri;
    sh->use_depth = !s->mode3d;
    if (!(sh->zhi > 0.f)) return 0; /* primary samples have positive depth */
    int fallback = 0;
    if (s->mode3d) {
        float scale = ri / ICO_INRADIUS * 1.00001f;
        float p[12][2];
        int idx[12];
        for (int k = 0; k < 12; k++) {
            float vx = c.x + scale * k_ico[k][0], vy = c.y + scale * k_ico[k][1], vz = c.z + scale * k_ico[k][2];
            if (!(vz > 1e-3f * ri)) {
                fallback = 1;
                break;
            }
            p[k][0] = px_of(x, vx / vz);
            p[k][1] = py_of(x, vy / vz);
            idx[k] = k;
        }
        if (!fallback) {
            /* Andrew's monotone chain on 12 points (insertion sort by x, y). */
            for (int i = 1; i < 12; i++) {
                int t = idx[i], j = i - 1;
                while (j >= 0 && (p[idx[j]][0] > p[t][0] || (p[idx[j]][0] == p[t][0] && p[idx[j]][1] > p[t][1]))) {
                    idx[j + 1] = idx[j];
                    j--;
                }
                idx[j + 1] = t;
            }
            int hull[25], h = 0;
            for (int i = 0; i < 12; i++) {
                while (h >= 2 && cross2(p[hull[h - 2]], p[hull[h - 1]], p[idx[i]]) <= 0.f) h--;
                hull[h++] = idx[i];
            }
            for (int i = 10, lo = h + 1; i >= 0; i--) {
                while (h >= lo && cross2(p[hull[h - 2]], p[hull[h - 1]], p[idx[i]]) <= 0.f) h--;
                hull[h++] = idx[i];
            }
            h--; /* last point repeats the first */
            /* counter-clockwise in (X, Y): the interior is on the left of each edge */
            sh->x0 = sh->y0 = INFINITY;
            sh->x1 = sh->y1 = -INFINITY;
            for (int i = 0; i < h; i++) {
                const float *a = p[hull[i]], *b = p[hull[(i + 1) % h]];
                float dx = b[0] - a[0], dy = b[1] - a[1];
                add_edge(sh, dy, -dx, dy * a[0] - dx * a[1]);
                sh->x0 = fminf(sh->x0, a[0]);
                sh->x1 = fmaxf(sh->x1, a[0]);
                sh->y0 = fminf(sh->y0, a[1]);
                sh->y1 = fmaxf(sh->y1, a[1]);
            }
        }
    } else if (c.z - ri > 1e-3f * ri) {
        float u0, u1, w0, w1;
        silhouette(c.x, c.z, ri, &u0, &u1);
        silhouette(c.y, c.z, ri, &w0, &w1);
        sh->x0 = px_of(x, u0);
        sh->x1 = px_of(x, u1);
        sh->y0 = py_of(x, w1);
        sh->y1 = py_of(x, w0);
        /* image-plane coordinates from pixel coordinates: xi = ax X + bx, yi = ay Y + by */
        const float ax = 2.f * x->sx / (float)x->W, bx = x->sx * (1.f / (float)x->W - 1.f);
        const float ay = -2.f * x->sy / (float)x->H, by = x->sy * (1.f - 1.f / (float)x->H);
        const int m = s->nverts / 2;
        for (int k = 0; k < m; k++) {
            /* axis directions (k = 0 and, for even m, k = m/2) are the rectangle */
            if (k == 0 || 2 * k == m) continue;
            float th = PGI__PI * (float)k / (float)m, cs = cosf(th), sn = sinf(th);
            float t0, t1;
            silhouette(c.x * cs + c.y * sn, c.z, ri, &t0, &t1);
            float A = cs * ax, B = sn * ay, C0 = cs * bx + sn * by;
            add_edge(sh, A, B, t1 - C0);
            add_edge(sh, -A, -B, C0 - t0);
        }
    } else fallback = 1;
    if (fallback) {
        /* 3D: the icosahedron's circumsphere, by the two axis slices; 2.5D: the sphere, N/2 slices */
        if (s->mode3d) {
            if (!clipped_shape(x, c, ri * (1.9021130f / ICO_INRADIUS) * 1.00001f, 2, sh)) return 0;
        } else if (!clipped_shape(x, c, ri, s->nverts / 2, sh)) return 0;
    }
    sh->x0 -= PIX_MARGIN + sh->pad;
    sh->y0 -= PIX_MARGIN + sh->pad;
    sh->x1 += PIX_MARGIN + sh->pad;
    sh->y1 += PIX_MARGIN + sh->pad;
    if (!(sh->x1 >= 0.f && sh->x0 <= (float)(x->W - 1) && sh->y1 >= 0.f && sh->y0 <= (float)(x->H - 1))) return 0;
    return 1;
}

/* Pixel rows/columns of the rectangle, clipped to [lo, hi]. */
static inline int clip_lo(float v, int lo) { return v <= (float)lo ? lo : (int)ceilf(v); }
static inline int clip_hi(float v, int hi) { return v >= (float)hi ? hi : (int)floorf(v); }

/* Columns [*xa, *xb] of row Y inside the shape (empty: *xa > *xb). */
static inline void row_span(const shape *sh, float Y, int W, int *xa, int *xb) {
    float xl = sh->x0, xr = sh->x1;
    for (int e = 0; e < sh->n; e++) {
        float t = sh->c[e] - sh->b[e] * Y, a = sh->a[e];
        if (a > 1e-6f) xr = fminf(xr, t / a);
        else if (a < -1e-6f) xl = fmaxf(xl, t / a);
        else if (t < 0.f) {
            *xa = 1, *xb = 0;
            return;
        }
    }
    if (!(xl <= xr) || xl > (float)(W - 1) || xr < 0.f) {
        *xa = 1, *xb = 0;
        return;
    }
    *xa = clip_lo(xl, 0);
    *xb = clip_hi(xr, W - 1);
}

/* Calls BODY with t for every bin photon j goes to: the primary tiles of its
 * bound's rectangle in increasing order, then the cells of mirror-seen samples
 * its sphere (padded by pgi__pad_radius, as the bounds) may reach (t = ntiles + cell). */
#define FOR_EACH_BIN(S_, XF_, J_, BODY)                                                                                \
    do {                                                                                                               \
        pgi__v3 c_ = v3((S_)->cview[3 * (J_)], (S_)->cview[3 * (J_) + 1], (S_)->cview[3 * (J_) + 2]);                  \
        shape sh_;                                                                                                     \
        if (make_shape((S_), (XF_), c_, r, &sh_)) {                                                                    \
            const int tx0 = clip_lo(sh_.x0, 0) / (S_)->T, tx1 = clip_hi(sh_.x1, (S_)->W - 1) / (S_)->T;                \
            const int ty0 = clip_lo(sh_.y0, 0) / (S_)->T, ty1 = clip_hi(sh_.y1, (S_)->H - 1) / (S_)->T;                \
            for (int ty_ = ty0; ty_ <= ty1; ty_++)                                                                     \
                for (int tx_ = tx0; tx_ <= tx1; tx_++) {                                                               \
                    int t = ty_ * (S_)->ntx + tx_;                                                                     \
                    if ((S_)->primary[t]) { BODY; }                                                                    \
                }                                                                                                      \
        }                                                                                                              \
        const float rr_ = pgi__pad_radius(c_, r);                                                                      \
        PGI__FOR_EACH_SPEC_CELL(&(S_)->cells, c_, rr_, int t = (S_)->ntiles + (int)k_; BODY);                          \
    } while (0)

static const pgi_option k_opt_polygon = {.name = "polygon",
                                         .type = PGI_OPTION_INT,
                                         .offset = offsetof(pgi_estimator_desc, bounds.polygon),
                                         .min = 4,
                                         .max = 64,
                                         .step = 2,
                                         .def = 8,
                                         .help = "bounds25d: vertices of the screen polygon (even, 4..64, default 8)"};
static const pgi_option *const k_options3d[] = {&pgi__opt_tile, NULL};
static const pgi_option *const k_options25d[] = {&pgi__opt_tile, &k_opt_polygon, NULL};

static pgi_status b_create_common(const pgi_estimator_desc *d, void **state, int mode3d) {
    bounds_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->c.desc = *d;
    s->mode3d = mode3d;
    s->nverts = d->bounds.polygon;
    s->T = d->tiled.tile_size;
    *state = s;
    return PGI_OK;
}
static pgi_status b3_create(const pgi_estimator_desc *d, void **state) { return b_create_common(d, state, 1); }
static pgi_status b25_create(const pgi_estimator_desc *d, void **state) { return b_create_common(d, state, 0); }

static pgi_status b_build(void *state, const pgi_estimate_args *a) {
    bounds_state *s = state;
    pgi__est_frame(&s->c, a);
    memset(&s->c.st, 0, sizeof s->c.st);
    const pgi_view_samples *vs = a->samples;
    const pgi_photons *ph = a->photons;
    const float r = s->c.radius;
    const int W = vs->width, H = vs->height, T = s->T;
    s->W = W;
    s->H = H;
    s->jitter = vs->jitter;
    s->ntx = (W + T - 1) / T;
    s->nty = (H + T - 1) / T;
    s->ntiles = s->ntx * s->nty;
    const size_t n = ph->count;
    size_t chunk = n / 64 + 1;
    if (chunk < 8192) chunk = 8192;
    const size_t nchunks = (n + chunk - 1) / chunk;
    pgi_status st;
    if ((st = pgi__ensure((void **)&s->primary, &s->primary_cap, (size_t)s->ntiles, 1)) ||
        (st = pgi__ensure((void **)&s->cview, &s->cview_cap, 3 * n + 3, sizeof(float))))
        return st;
    const pgi__view_xf x = pgi__view_xf_make(a->camera, W, H);
    double t0 = pgi__now_ms();
    if ((st = pgi__spec_cells_build(&s->cells, vs, &x, r, pgi__spec_cells_cap(s->ntiles), s->c.threads))) return st;
    s->nbins = s->ntiles + (int)s->cells.n;
    if ((st = pgi__ensure((void **)&s->tile_start, &s->tile_start_cap, (size_t)s->nbins + 1, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->counts, &s->counts_cap, (nchunks + 1) * (size_t)s->nbins, sizeof(uint32_t))))
        return st;
#pragma omp parallel for schedule(dynamic, 4) num_threads(s->c.threads)
    for (int t = 0; t < s->ntiles; t++) {
        uint8_t prim = 0;
        int tx = t % s->ntx, ty = t / s->ntx;
        for (int py = ty * T; py < (ty + 1) * T && py < H && !prim; py++)
            for (int px = tx * T; px < (tx + 1) * T && px < W; px++) {
                size_t i = (size_t)py * W + (size_t)px;
                if ((vs->flags[i] & (PGI_VS_VALID | PGI_VS_PRIMARY)) == (PGI_VS_VALID | PGI_VS_PRIMARY)) {
                    prim = 1;
                    break;
                }
            }
        s->primary[t] = prim;
    }
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
    for (long long j = 0; j < (long long)n; j++) {
        pgi__v3 c = pgi__to_view(&x, ph->px[j], ph->py[j], ph->pz[j]);
        s->cview[3 * j] = c.x, s->cview[3 * j + 1] = c.y, s->cview[3 * j + 2] = c.z;
    }
    double t1 = pgi__now_ms();
    const int nbins = s->nbins; /* tiles, then cells */
#pragma omp parallel for schedule(dynamic, 1) num_threads(s->c.threads)
    for (long long cidx = 0; cidx < (long long)nchunks; cidx++) {
        uint32_t *cnt = s->counts + (size_t)cidx * nbins;
        memset(cnt, 0, (size_t)nbins * sizeof *cnt);
        size_t j1 = ((size_t)cidx + 1) * chunk < n ? ((size_t)cidx + 1) * chunk : n;
        for (size_t j = (size_t)cidx * chunk; j < j1; j++) FOR_EACH_BIN(s, &x, j, cnt[t]++);
    }
    double t2 = pgi__now_ms();
    uint64_t sum = 0;
    for (int t = 0; t < nbins; t++) {
        s->tile_start[t] = (uint32_t)sum;
        for (size_t cidx = 0; cidx < nchunks; cidx++) {
            uint32_t *cnt = s->counts + cidx * nbins + t;
            uint32_t c = *cnt;
            *cnt = (uint32_t)sum;
            sum += c;
        }
    }
    s->tile_start[nbins] = (uint32_t)sum;
    if (sum > UINT32_MAX)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: %llu binned photons exceed the 32-bit index; use a smaller radius",
                         s->mode3d ? "bounds3d" : "bounds25d", (unsigned long long)sum);
    if ((st = pgi__ensure((void **)&s->bins, &s->bins_cap, (size_t)sum + 1, sizeof(uint32_t)))) return st;
    s->nbinned = (size_t)sum;
    double t3 = pgi__now_ms();
#pragma omp parallel for schedule(dynamic, 1) num_threads(s->c.threads)
    for (long long cidx = 0; cidx < (long long)nchunks; cidx++) {
        uint32_t *off = s->counts + (size_t)cidx * nbins;
        size_t j1 = ((size_t)cidx + 1) * chunk < n ? ((size_t)cidx + 1) * chunk : n;
        for (size_t j = (size_t)cidx * chunk; j < j1; j++) FOR_EACH_BIN(s, &x, j, s->bins[off[t]++] = (uint32_t)j);
    }
    double t4 = pgi__now_ms();
    s->nphotons = n;
    pgi__stats_pass(&s->c.st, "tiles+project", t1 - t0);
    pgi__stats_pass(&s->c.st, "count", t2 - t1);
    pgi__stats_pass(&s->c.st, "scan", t3 - t2);
    pgi__stats_pass(&s->c.st, "bin", t4 - t3);
    s->c.st.build_ms = t4 - t0;
    return PGI_OK;
}

static pgi_status b_estimate(void *state, const pgi_estimate_args *a) {
    bounds_state *s = state;
    pgi__est_frame(&s->c, a);
    double t0 = pgi__now_ms();
    const pgi_view_samples *vs = a->samples;
    const pgi_photons *ph = a->photons;
    const int W = vs->width, H = vs->height, T = s->T;
    if (W != s->W || H != s->H || ph->count != s->nphotons || vs->jitter != s->jitter)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: estimate called with other inputs than build's",
                         s->mode3d ? "bounds3d" : "bounds25d");
    const float r = s->c.radius, r2 = r * r;
    const pgi_kernel kern = s->c.desc.kernel;
    const pgi__view_xf x = pgi__view_xf_make(a->camera, W, H);
    const size_t TT = (size_t)T * (size_t)T;
    int nthreads = 1;
#ifdef _OPENMP
    nthreads = s->c.threads;
#endif
    /* per thread: samples, sums, view depth, kind (0 invalid, 1 primary, 2 seen through a mirror: its cell writes it) */
    const size_t per = (TT * (sizeof(pgi__vs) + sizeof(pgi__acc) + sizeof(float) + 1) + 127) & ~(size_t)63;
    char *scratch = malloc((size_t)nthreads * per);
    if (!scratch) return pgi__fail(PGI_ERR_OOM, "out of memory for %d tile buffers", nthreads);
    uint64_t reads = 0, contrib = 0, covered = 0;
#pragma omp parallel reduction(+ : reads, contrib, covered) num_threads(s->c.threads)
    {
        int tid = 0;
#ifdef _OPENMP
        tid = omp_get_thread_num();
#endif
        char *base = scratch + (size_t)tid * per;
        pgi__vs *lv = (pgi__vs *)base;
        pgi__acc *acc = (pgi__acc *)(lv + TT);
        float *lz = (float *)(acc + TT);
        uint8_t *kind = (uint8_t *)(lz + TT);
#pragma omp for schedule(dynamic, 1)
        for (int t = 0; t < s->nbins; t++) {
            if (pgi__est_stop(&s->c)) continue;
            const uint32_t b0 = s->tile_start[t], b1 = s->tile_start[t + 1];
            if (t >= s->ntiles) {
                /* A cell of mirror-seen samples: every binned photon against every sample, TT samples at a time. */
                const pgi__spec_cells *cl = &s->cells;
                const uint32_t k = (uint32_t)(t - s->ntiles), m1 = cl->start[k + 1];
                for (uint32_t m0 = cl->start[k]; m0 < m1; m0 += (uint32_t)TT) {
                    const uint32_t nb = m1 - m0 < TT ? m1 - m0 : (uint32_t)TT;
                    for (uint32_t q = 0; q < nb; q++) {
                        pgi__vs_load(vs, cl->sample[m0 + q], &lv[q]);
                        memset(&acc[q], 0, sizeof acc[q]);
                    }
                    for (uint32_t kb = b0; kb < b1; kb++) {
                        const uint32_t j = s->bins[kb];
                        const float ppx = ph->px[j], ppy = ph->py[j], ppz = ph->pz[j];
                        const float pdx = ph->dx[j], pdy = ph->dy[j], pdz = ph->dz[j];
                        const float pfr = ph->fr[j], pfg = ph->fg[j], pfb = ph->fb[j];
                        for (uint32_t q = 0; q < nb; q++)
                            pgi__gather_k(&lv[q], r2, kern, ppx, ppy, ppz, pdx, pdy, pdz, pfr, pfg, pfb, &acc[q]);
                    }
                    reads += (uint64_t)nb * (b1 - b0);
                    for (uint32_t q = 0; q < nb; q++) {
                        pgi__acc_finish_k(&lv[q], &acc[q], r2, kern, 1.f, a->out_rgb + 3 * (size_t)cl->sample[m0 + q]);
                        contrib += acc[q].contributing;
                    }
                }
                continue;
            }
            const int tx = t % s->ntx, ty = t / s->ntx;
            const int X0 = tx * T, Y0 = ty * T;
            const int X1 = X0 + T < W ? X0 + T : W, Y1 = Y0 + T < H ? Y0 + T : H; /* exclusive */
            const int tw = X1 - X0;
            for (int py = Y0; py < Y1; py++)
                for (int px = X0; px < X1; px++) {
                    size_t i = (size_t)py * W + (size_t)px, l = (size_t)(py - Y0) * tw + (size_t)(px - X0);
                    const uint8_t f = vs->flags[i];
                    if ((f & (PGI_VS_VALID | PGI_VS_PRIMARY)) != (PGI_VS_VALID | PGI_VS_PRIMARY)) {
                        kind[l] = (f & PGI_VS_VALID) ? 2 : 0;
                        continue;
                    }
                    kind[l] = 1;
                    pgi__vs_load(vs, i, &lv[l]);
                    memset(&acc[l], 0, sizeof acc[l]);
                    lz[l] = pgi__to_view(&x, lv[l].px, lv[l].py, lv[l].pz).z;
                }
            for (uint32_t kb = b0; kb < b1; kb++) {
                const uint32_t j = s->bins[kb];
                pgi__v3 c = v3(s->cview[3 * j], s->cview[3 * j + 1], s->cview[3 * j + 2]);
                shape sh;
                if (!make_shape(s, &x, c, r, &sh)) continue;
                const float ppx = ph->px[j], ppy = ph->py[j], ppz = ph->pz[j];
                const float pdx = ph->dx[j], pdy = ph->dy[j], pdz = ph->dz[j];
                const float pfr = ph->fr[j], pfg = ph->fg[j], pfb = ph->fb[j];
                int ya = clip_lo(sh.y0, Y0), yb = clip_hi(sh.y1, Y1 - 1);
                for (int py = ya; py <= yb; py++) {
                    int xa, xb;
                    row_span(&sh, (float)py, W, &xa, &xb);
                    if (xa < X0) xa = X0;
                    if (xb > X1 - 1) xb = X1 - 1;
                    for (int px = xa; px <= xb; px++) {
                        size_t l = (size_t)(py - Y0) * tw + (size_t)(px - X0);
                        if (kind[l] != 1) continue;
                        covered++;
                        if (sh.use_depth && !(lz[l] >= sh.zlo && lz[l] <= sh.zhi)) continue;
                        reads++;
                        pgi__gather_k(&lv[l], r2, kern, ppx, ppy, ppz, pdx, pdy, pdz, pfr, pfg, pfb, &acc[l]);
                    }
                }
            }
            for (int py = Y0; py < Y1; py++)
                for (int px = X0; px < X1; px++) {
                    size_t i = (size_t)py * W + (size_t)px, l = (size_t)(py - Y0) * tw + (size_t)(px - X0);
                    float *out = a->out_rgb + 3 * i;
                    if (kind[l] == 2) continue; /* its cell writes it */
                    if (!kind[l]) {
                        out[0] = out[1] = out[2] = 0.f;
                        continue;
                    }
                    pgi__acc_finish_k(&lv[l], &acc[l], r2, kern, 1.f, out);
                    contrib += acc[l].contributing;
                }
        }
    }
    free(scratch);
    pgi__stats_estimated(&s->c.st, t0, reads, contrib);
    s->c.st.nodes_visited = covered;
    s->c.st.memory_count = 0;
    pgi__stats_mem(&s->c.st, "tile_bins", s->nbinned * sizeof(uint32_t));
    pgi__stats_mem(&s->c.st, "photon_view_pos", s->nphotons * 3 * sizeof(float));
    pgi__stats_mem(&s->c.st, "tile_offsets", s->counts_cap * sizeof(uint32_t) + ((size_t)s->nbins + 1) * 4);
    pgi__stats_mem(&s->c.st, "specular_cells", pgi__spec_cells_bytes(&s->cells));
    return PGI_OK;
}

static void b_destroy(void *state) {
    bounds_state *s = state;
    if (!s) return;
    pgi__afree(s->primary);
    pgi__spec_cells_free(&s->cells);
    pgi__afree(s->cview);
    pgi__afree(s->counts);
    pgi__afree(s->tile_start);
    pgi__afree(s->bins);
    free(s);
}

const pgi_estimator_vtbl pgi__est_bounds3d =
    PGI__EST_TABLE("bounds3d",
                   "photon-major scatter, icosahedron bounds projected to the screen (Mara et al. 2013 §2.2)",
                   b3_create, b_build, b_estimate, b_destroy, .exact = 1, .caps = PGI_EST_CAP_KERNELS,
                   .options = k_options3d, .bytes_per_photon = 24, .bytes_per_sample = 8);

const pgi_estimator_vtbl pgi__est_bounds25d =
    PGI__EST_TABLE("bounds25d",
                   "photon-major scatter, tight screen polygon + depth range per sphere (Mara & McGuire 2013)",
                   b25_create, b_build, b_estimate, b_destroy, .exact = 1, .caps = PGI_EST_CAP_KERNELS,
                   .options = k_options25d, .bytes_per_photon = 24, .bytes_per_sample = 8);
