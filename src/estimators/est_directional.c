/* directional (Moreau et al., HPG 2016, §4.7): the cluster hierarchy
 * (cluster_build.c), photon traversal stopped at a fixed level: flux goes into
 * 8 view-space octant buckets of that node (the splat in est_cluster.c, which
 * specialises the traversal for this variant); shading weights each bucket o
 * by K(n) max(0, n.d_o), d_o the octant's diagonal; irradiance is blurred
 * (depth- and normal-aware) and multiplied by kd/pi. Approximate. Counters:
 * reads = contributing = bucket deposits.
 *
 * The weights. The paper's 2 max(0, n.d_o) depends on how the normal sits
 * among the octants: for a normal along a view axis, each of the four octants
 * above the surface gets 2/sqrt(3) = 1.155 instead of 1, so walls facing the
 * camera came out 15 % too bright (13 % on the Cornell box), other normals
 * less. K(n) normalises them per view-space normal: light arriving at the
 * surface uniformly over its hemisphere (flux ~ cos) gives exactly the
 * irradiance, sum_o w_o(n) Phi_o = sum_o Phi_o, i.e.
 *   K(n) = 1 / E[max(0, n.d_o(w))] over cosine-distributed w around n.
 * K is tabulated once on a small cube map of view-space normals (the paper's
 * suggestion, §4.7) and interpolated bilinearly: it lies in [1, sqrt(3)]. */
#include <pthread.h>
#include <string.h>

#include "cluster_internal.h"

static const pgi_option k_opt_dir_level =
    {.name = "directional-level",
     .type = PGI_OPTION_INT,
     .offset = offsetof(pgi_estimator_desc, directional.level),
     .min = 0,
     .max = 16,
     .zero = PGI_DIRECTIONAL_LEAVES,
     .def = 1,
     .help = "flux buckets N levels above the leaves (0..16, default 1; 0 = at the leaves)"};
static const pgi_option k_opt_dir_blur = {.name = "directional-blur",
                                          .type = PGI_OPTION_INT,
                                          .offset = offsetof(pgi_estimator_desc, directional.blur),
                                          .min = 0,
                                          .max = 64,
                                          .zero = PGI_DIRECTIONAL_NO_BLUR,
                                          .def = 4,
                                          .help = "irradiance blur radius in pixels (0..64, default 4; 0 = off)"};
static const pgi_option *const k_options[] = {&pgi__opt_cluster_tile, &k_opt_dir_level, &k_opt_dir_blur, NULL};
/* the cluster tile from the image size unless given (pgi__cluster_tile) */
static const pgi_option_default k_defaults[] = {{&pgi__opt_cluster_tile, 0}, {NULL, 0}};


/* Depth- and normal-aware blur along one axis (§4.7) on planes: tent weights
 * in pixels, times a depth weight falling to 0 at a 5% relative depth step
 * and a normal weight max(0, n.n')^8. Invalid samples have depth 1e30 and a
 * zero normal, so they neither give nor receive. Pixels are processed in spans
 * of up to BLUR_SPAN consecutive pixels of one row whose taps are all inside
 * the image: the centre values and the accumulators live in local arrays, and
 * for each tap offset the loop over the span is branch-free and vectorises
 * (restrict pointers, no aliasing checks); border pixels of the horizontal
 * pass take the same expressions with a bounds test. Taps are added in the
 * order -R..R for every pixel, so the result does not depend on the span cut. */
typedef struct {
    const float *z, *nx, *ny, *nz, *e[3];
    float *o[3];
} blur_planes;

#define BLUR_SPAN 256

static inline float blur_w(float tent, float z, float iz, float nx, float ny, float nz, float zj, float nxj, float nyj,
                           float nzj) {
    float wz = 1.f - fabsf(zj - z) * iz;
    wz = 0.5f * (wz + fabsf(wz)); /* max(wz, 0), exact and branch-free */
    float c = nx * nxj + ny * nyj + nz * nzj;
    c = 0.5f * (c + fabsf(c));
    c *= c, c *= c, c *= c;
    return tent * wz * c;
}

/* Pixels [c, c + n) with the taps at offsets off[0..nt) (weights tent[]). */
PGI__HOT_LOOP
static void blur_span(const float *restrict Z, const float *restrict NX, const float *restrict NY,
                      const float *restrict NZ, const float *restrict E0, const float *restrict E1,
                      const float *restrict E2, float *restrict O0, float *restrict O1, float *restrict O2, size_t c,
                      int n, const ptrdiff_t *off, const float *tent, int nt) {
    float cz[BLUR_SPAN], ciz[BLUR_SPAN], cnx[BLUR_SPAN], cny[BLUR_SPAN], cnz[BLUR_SPAN];
    float a0[BLUR_SPAN], a1[BLUR_SPAN], a2[BLUR_SPAN], ws[BLUR_SPAN];
    for (int t = 0; t < n; t++) {
        cz[t] = Z[c + t];
        ciz[t] = 1.f / (0.05f * fabsf(cz[t]) + 1e-12f);
        cnx[t] = NX[c + t], cny[t] = NY[c + t], cnz[t] = NZ[c + t];
        a0[t] = E0[c + t], a1[t] = E1[c + t], a2[t] = E2[c + t];
        ws[t] = 1.f;
    }
    for (int k = 0; k < nt; k++) {
        const size_t j = (size_t)((ptrdiff_t)c + off[k]);
        const float tk = tent[k];
        const float *restrict zj = Z + j, *restrict xj = NX + j, *restrict yj = NY + j, *restrict wj = NZ + j;
        const float *restrict e0 = E0 + j, *restrict e1 = E1 + j, *restrict e2 = E2 + j;
        for (int t = 0; t < n; t++) {
            float w = blur_w(tk, cz[t], ciz[t], cnx[t], cny[t], cnz[t], zj[t], xj[t], yj[t], wj[t]);
            a0[t] += w * e0[t], a1[t] += w * e1[t], a2[t] += w * e2[t];
            ws[t] += w;
        }
    }
    for (int t = 0; t < n; t++) {
        float inv = 1.f / ws[t];
        O0[c + t] = a0[t] * inv, O1[c + t] = a1[t] * inv, O2[c + t] = a2[t] * inv;
    }
}

static void blur_pass(const blur_planes *P, int W, int H, int R, int vertical, int threads) {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < H; y++) {
        const size_t row = (size_t)y * W;
        ptrdiff_t off[2 * 64];
        float tent[2 * 64];
        int nt = 0;
        for (int k = -R; k <= R; k++) {
            if (!k) continue;
            if (vertical && (y + k < 0 || y + k >= H)) continue;
            off[nt] = vertical ? (ptrdiff_t)k * W : k;
            tent[nt++] = 1.f - (float)abs(k) / (float)(R + 1);
        }
        int x0 = vertical ? 0 : (R < W ? R : W), x1 = vertical ? W : (W - R > x0 ? W - R : x0);
        for (int x = x0; x < x1; x += BLUR_SPAN) {
            int n = x1 - x < BLUR_SPAN ? x1 - x : BLUR_SPAN;
            blur_span(P->z, P->nx, P->ny, P->nz, P->e[0], P->e[1], P->e[2], P->o[0], P->o[1], P->o[2], row + (size_t)x,
                      n, off, tent, nt);
        }
        if (vertical) continue;
        for (int x = 0; x < W; x++) { /* horizontal borders: taps inside the row only */
            if (x >= x0 && x < x1) continue;
            const size_t i = row + (size_t)x;
            const float z = P->z[i], iz = 1.f / (0.05f * fabsf(z) + 1e-12f);
            float a[3] = {P->e[0][i], P->e[1][i], P->e[2][i]}, ws = 1.f;
            for (int k = 0; k < nt; k++) {
                if (x + off[k] < 0 || x + off[k] >= W) continue;
                const size_t j = (size_t)((ptrdiff_t)i + off[k]);
                float w = blur_w(tent[k], z, iz, P->nx[i], P->ny[i], P->nz[i], P->z[j], P->nx[j], P->ny[j], P->nz[j]);
                for (int d = 0; d < 3; d++) a[d] += w * P->e[d][j];
                ws += w;
            }
            for (int d = 0; d < 3; d++) P->o[d][i] = a[d] * (1.f / ws);
        }
    }
}

/* ------------------------------------------------- octant weight normalisation */

#define KRES 16    /* cube-map texels a side */
#define KSTRATA 64 /* cosine-hemisphere strata a side for each texel's integral */
static float g_knorm[6][KRES][KRES];
static pthread_once_t g_knorm_once = PTHREAD_ONCE_INIT;

/* The unit direction of face f (major axis f / 2, sign - when f is odd) at
 * face coordinates (a, b) in [-1, 1]. */
static void face_dir(int f, double a, double b, double d[3]) {
    const int ax = f / 2;
    d[ax] = (f & 1) ? -1.0 : 1.0;
    d[(ax + 1) % 3] = a;
    d[(ax + 2) % 3] = b;
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++) d[k] /= l;
}

/* 1 / E[max(0, n.d_o(w))] for w cosine-distributed about n (stratified). */
static float knorm_of(const double n[3]) {
    double t[3], b[3];
    if (fabs(n[0]) > 0.5) t[0] = n[1], t[1] = -n[0], t[2] = 0.0;
    else t[0] = 0.0, t[1] = n[2], t[2] = -n[1];
    double l = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    for (int k = 0; k < 3; k++) t[k] /= l;
    b[0] = n[1] * t[2] - n[2] * t[1], b[1] = n[2] * t[0] - n[0] * t[2], b[2] = n[0] * t[1] - n[1] * t[0];
    const double c3 = 0.57735026918962576;
    double sum = 0.0;
    for (int i = 0; i < KSTRATA; i++)
        for (int j = 0; j < KSTRATA; j++) {
            double u1 = (i + 0.5) / KSTRATA, u2 = (j + 0.5) / KSTRATA;
            double r = sqrt(u1), ph = 2.0 * 3.14159265358979323846 * u2, z = sqrt(1.0 - u1);
            double w[3], c = 0.0;
            for (int k = 0; k < 3; k++) w[k] = t[k] * r * cos(ph) + b[k] * r * sin(ph) + n[k] * z;
            for (int k = 0; k < 3; k++) c += n[k] * (w[k] < 0.0 ? -c3 : c3);
            sum += c > 0.0 ? c : 0.0;
        }
    return (float)((double)(KSTRATA * KSTRATA) / sum);
}

static void knorm_init(void) {
    for (int f = 0; f < 6; f++)
        for (int i = 0; i < KRES; i++)
            for (int j = 0; j < KRES; j++) {
                double n[3];
                face_dir(f, 2.0 * (i + 0.5) / KRES - 1.0, 2.0 * (j + 0.5) / KRES - 1.0, n);
                g_knorm[f][i][j] = knorm_of(n);
            }
}

/* K for view-space normal (x, y, z) (any length > 0): bilinear between the
 * texel centres of its cube face, clamped at the face's edges. */
static inline float knorm(float x, float y, float z) {
    const float v[3] = {x, y, z}, a[3] = {fabsf(x), fabsf(y), fabsf(z)};
    const int ax = a[0] >= a[1] ? (a[0] >= a[2] ? 0 : 2) : (a[1] >= a[2] ? 1 : 2);
    if (!(a[ax] > 0.f)) return 1.f;
    const int f = 2 * ax + (v[ax] < 0.f);
    float fu = (v[(ax + 1) % 3] / a[ax] + 1.f) * 0.5f * KRES - 0.5f;
    float fv = (v[(ax + 2) % 3] / a[ax] + 1.f) * 0.5f * KRES - 0.5f;
    fu = fu < 0.f ? 0.f : (fu > KRES - 1 ? (float)(KRES - 1) : fu);
    fv = fv < 0.f ? 0.f : (fv > KRES - 1 ? (float)(KRES - 1) : fv);
    int i0 = (int)fu, j0 = (int)fv;
    int i1 = i0 + 1 < KRES ? i0 + 1 : i0, j1 = j0 + 1 < KRES ? j0 + 1 : j0;
    float du = fu - (float)i0, dv = fv - (float)j0;
    const float(*k)[KRES] = g_knorm[f];
    return (1.f - du) * ((1.f - dv) * k[i0][j0] + dv * k[i0][j1]) + du * ((1.f - dv) * k[i1][j0] + dv * k[i1][j1]);
}

/* The K table (6 faces x KRES x KRES, texel [f][i][j] at (f KRES + i) KRES + j), for the GPU
 * directional (gpu_cluster.c), which interpolates it as knorm does. */
const float *pgi__directional_knorm_table(int *res) {
    pthread_once(&g_knorm_once, knorm_init);
    *res = KRES;
    return &g_knorm[0][0][0];
}

static pgi_status dir_create(const pgi_estimator_desc *d, void **st) {
    pthread_once(&g_knorm_once, knorm_init);
    return cl_create_variant(d, st, V_DIR);
}

/* Octant-bucket shading of nb sorted samples (world normals n*), vectorised
 * over the samples: for each bucket o (direction: the octant's diagonal d_o)
 * the weight is K(n) max(0, n.d_o), a select instead of a branch; buckets are
 * added in octant order. */
PGI__HOT_LOOP
static void dir_block(const float *restrict snx, const float *restrict sny, const float *restrict snz, int nb,
                      const pgi__view_xf *x, const float *restrict b, float *restrict e0, float *restrict e1,
                      float *restrict e2) {
    const float c3 = 0.57735026919f;
    const float rx = x->right.x, ry = x->right.y, rz = x->right.z, ux = x->up.x, uy = x->up.y, uz = x->up.z,
                fx = x->fwd.x, fy = x->fwd.y, fz = x->fwd.z;
    float vx[64], vy[64], vz[64], kn[64];
    for (int t = 0; t < nb; t++) {
        vx[t] = snx[t] * rx + sny[t] * ry + snz[t] * rz;
        vy[t] = snx[t] * ux + sny[t] * uy + snz[t] * uz;
        vz[t] = snx[t] * fx + sny[t] * fy + snz[t] * fz;
        e0[t] = e1[t] = e2[t] = 0.f;
    }
    for (int t = 0; t < nb; t++) kn[t] = c3 * knorm(vx[t], vy[t], vz[t]);
    for (int o = 0; o < 8; o++) {
        const float sx = (o & 1) ? -1.f : 1.f, sy = (o & 2) ? -1.f : 1.f, sz = (o & 4) ? -1.f : 1.f;
        const float b0 = b[3 * o], b1 = b[3 * o + 1], b2 = b[3 * o + 2];
        for (int t = 0; t < nb; t++) {
            float w = kn[t] * (sx * vx[t] + sy * vy[t] + sz * vz[t]);
            w = 0.5f * (w + fabsf(w)); /* max(w, 0) */
            e0[t] += w * b0, e1[t] += w * b1, e2[t] += w * b2;
        }
    }
}

static pgi_status dir_radiance(cl_state *s, const pgi_estimate_args *a, double *t_blur) {
    const pgi_view_samples *vs = a->samples;
    const size_t npix = vs->count;
    pgi_status st;
    /* planes: 3 irradiance + 3 blurred, depth, normal (40 bytes a pixel) */
    if ((st = ENSURE(irr, 10 * npix, float))) return st;
    blur_planes P;
    float *pl = s->irr;
    float *ep[3] = {pl, pl + npix, pl + 2 * npix}, *op[3] = {pl + 3 * npix, pl + 4 * npix, pl + 5 * npix};
    float *pz = pl + 6 * npix, *pnx = pl + 7 * npix, *pny = pl + 8 * npix, *pnz = pl + 9 * npix;
    for (int d = 0; d < 3; d++) P.e[d] = ep[d], P.o[d] = op[d];
    P.z = pz, P.nx = pnx, P.ny = pny, P.nz = pnz;
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
    for (long long i = 0; i < (long long)npix; i++) {
        int ok = (vs->flags[i] & PGI_VS_VALID) != 0;
        pz[i] = ok ? vs->depth[i] : 1e30f;
        pnx[i] = ok ? vs->nrm[3 * i] : 0.f;
        pny[i] = ok ? vs->nrm[3 * i + 1] : 0.f;
        pnz[i] = ok ? vs->nrm[3 * i + 2] : 0.f;
        if (!ok || !s->splatted) ep[0][i] = ep[1][i] = ep[2][i] = 0.f; /* valid samples are shaded below */
    }
    const float inv_area = 1.f / (PGI_PI * s->r * s->r);
    if (s->splatted) {
        const uint32_t leaf0 = s->lvl_off[s->L], leaf1 = s->lvl_off[s->L + 1];
#pragma omp parallel for schedule(dynamic, 16) num_threads(s->c.threads)
        for (long long li = leaf0; li < (long long)leaf1; li++) {
            /* the leaf's buckets plus those of its ancestors down from level D */
            float b[24];
            memset(b, 0, sizeof b);
            uint32_t path[MAX_LEVELS + 2];
            int np = 0;
            uint32_t u = (uint32_t)li;
            for (int l = s->L; l >= s->D; l--, u = s->nodes[u].parent) path[np++] = u;
            for (int p = np - 1; p >= 0; p--) {
                const float *bb = s->buckets + (size_t)(path[p] - s->lvl_off[s->D]) * 24;
                for (int c = 0; c < 24; c++) b[c] += bb[c];
            }
            const size_t nv = s->nvalid;
            const float *snx = s->sam + 3 * nv, *sny = snx + nv, *snz = sny + nv; /* sorted normals */
            if (li + 1 < (long long)leaf1) /* the next leaf's irradiance rows (written) */
                for (uint32_t k = s->sbeg[li + 1]; k < s->send[li + 1]; k += 8)
                    for (int d = 0; d < 3; d++) __builtin_prefetch(ep[d] + s->order[k], 1);
            enum { B = 64 };
            float e0[B], e1[B], e2[B];
            for (uint32_t k0 = s->sbeg[li]; k0 < s->send[li]; k0 += B) {
                const int nb = (int)(s->send[li] - k0 < B ? s->send[li] - k0 : B);
                dir_block(snx + k0, sny + k0, snz + k0, nb, &s->x, b, e0, e1, e2);
                for (int t = 0; t < nb; t++) {
                    const size_t i = s->order[k0 + t];
                    ep[0][i] = e0[t] * inv_area, ep[1][i] = e1[t] * inv_area, ep[2][i] = e2[t] * inv_area;
                }
            }
        }
    }
    *t_blur = pgi__now_ms();
    const float *E[3] = {P.e[0], P.e[1], P.e[2]};
    if (s->blur > 0 && s->splatted) {
        blur_pass(&P, vs->width, vs->height, s->blur, 0, s->c.threads); /* e -> o */
        blur_planes Q = P;
        for (int d = 0; d < 3; d++) Q.e[d] = op[d], Q.o[d] = ep[d];
        blur_pass(&Q, vs->width, vs->height, s->blur, 1, s->c.threads); /* o -> e */
    }
#pragma omp parallel for schedule(static) num_threads(s->c.threads)
    for (long long ii = 0; ii < (long long)npix; ii++) {
        float *out = a->out_rgb + 3 * ii;
        if (!(vs->flags[ii] & PGI_VS_VALID)) {
            out[0] = out[1] = out[2] = 0.f;
            continue;
        }
        const float *kd = vs->kd + 3 * ii;
        for (int d = 0; d < 3; d++) out[d] = kd[d] * PGI_INV_PI * E[d][ii];
    }
    return PGI_OK;
}

static pgi_status dir_estimate(void *state, const pgi_estimate_args *a) {
    cl_state *s = state;
    pgi__est_frame(&s->c, a);
    double t0 = pgi__now_ms();
    const pgi_view_samples *vs = a->samples;
    if (vs->width != s->W || vs->height != s->H)
        return pgi__fail(PGI_ERR_INVALID_ARG, "directional: estimate called with a frame size other than build's");
    pgi_status st;
    double tb = t0;
    if ((st = dir_radiance(s, a, &tb))) return st;
    double t1 = pgi__now_ms();
    s->c.st.estimate_ms = t1 - t0;
    pgi__stats_pass(&s->c.st, "radiance", tb - t0);
    pgi__stats_pass(&s->c.st, "blur", t1 - tb);
    s->c.st.reads = s->c.st.contributing = s->deposits;
    cl_stats_memory(s, vs->count);
    return PGI_OK;
}

const pgi_estimator_vtbl pgi__est_directional = {
    .name = "directional",
    .summary = "cluster hierarchy, flux in 8 octant buckets per node from a fixed level down, "
               "blurred irradiance (§4.7)",
    .exact = 0,
    .create = dir_create,
    .build = cl_build,
    .estimate = dir_estimate,
    .stats = pgi__est_default_stats,
    .destroy = cl_destroy,
    .options = k_options,
    .defaults = k_defaults,
    .caps = 0,
    /* memory budget: measured bytes of its stats per photon and per view sample, rounded up */
    .bytes_per_photon = 80,
    .bytes_per_sample = 120,
};
