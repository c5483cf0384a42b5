/* directional (Moreau et al., HPG 2016, §4.7): the cluster hierarchy
 * (cluster_build.c), photon traversal stopped at a fixed level: flux goes into
 * 8 view-space octant buckets of that node (the splat in est_cluster.c, which
 * specialises the traversal for this variant), each bucket also summing its
 * photons' directions weighted by their flux; a sample takes a bucket whole
 * when the bucket's mean direction lies above its surface (n.m > 0), else not
 * at all; irradiance is blurred (depth- and normal-aware) and multiplied by
 * kd/pi. Approximate. Counters: reads = contributing = bucket deposits.
 *
 * The weights. The exact estimators take a photon in the sphere when it
 * arrives from above the surface (pgi__gather: n.w > 0), at full flux: the
 * photon density already carries the cosine. Every photon on an open surface
 * arrives from above it, so the right weight of every bucket there is 1. The
 * paper's 2 max(0, n.d_o) (d_o: the octant's diagonal) gives each of the
 * four octants above a surface facing the camera 2/sqrt(3) = 1.155 and less to
 * octants at grazing angles, so its error depends on where the light comes from
 * and how the surface faces the view: +13 % on the Cornell box; normalised for
 * light arriving uniformly over the hemisphere it was still 3.6-4.5 % dark on
 * Sibenik (7-8 % in the vaults at the top of the view). The mean direction's test
 * is exact wherever a node's photons arrive at one side of one surface; it
 * errs only where a bucket mixes photons from surfaces facing different ways
 * (corners, thin objects), and only by the share that the sample would reject. */
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

static pgi_status dir_create(const pgi_estimator_desc *d, void **st) { return cl_create_variant(d, st, V_DIR); }

/* Octant-bucket shading of nb sorted samples (world normals n*), vectorised
 * over the samples: bucket o (flux b[6o..6o+2], direction sum m = b[6o+3..6o+5],
 * world space) counts when n.m > 0, a select instead of a branch; buckets are
 * added in octant order. */
PGI__HOT_LOOP
static void dir_block(const float *restrict snx, const float *restrict sny, const float *restrict snz, int nb,
                      const float *restrict b, float *restrict e0, float *restrict e1, float *restrict e2) {
    for (int t = 0; t < nb; t++) e0[t] = e1[t] = e2[t] = 0.f;
    for (int o = 0; o < 8; o++) {
        const float *bo = b + PGI__DIR_BUCKET * o;
        const float b0 = bo[0], b1 = bo[1], b2 = bo[2], mx = bo[3], my = bo[4], mz = bo[5];
        for (int t = 0; t < nb; t++) {
            const float w = snx[t] * mx + sny[t] * my + snz[t] * mz > 0.f ? 1.f : 0.f;
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
    const float inv_area = 1.f / (PGI__PI * s->r * s->r);
    if (s->splatted) {
        const uint32_t leaf0 = s->lvl_off[s->L], leaf1 = s->lvl_off[s->L + 1];
#pragma omp parallel for schedule(dynamic, 16) num_threads(s->c.threads)
        for (long long li = leaf0; li < (long long)leaf1; li++) {
            if (pgi__est_stop(&s->c)) continue;
            /* the leaf's buckets plus those of its ancestors down from level D */
            float b[8 * PGI__DIR_BUCKET];
            memset(b, 0, sizeof b);
            uint32_t path[MAX_LEVELS + 2];
            int np = 0;
            uint32_t u = (uint32_t)li;
            for (int l = s->L; l >= s->D; l--, u = s->nodes[u].parent) path[np++] = u;
            for (int p = np - 1; p >= 0; p--) {
                const float *bb = s->buckets + (size_t)(path[p] - s->lvl_off[s->D]) * 8 * PGI__DIR_BUCKET;
                for (int c = 0; c < 8 * PGI__DIR_BUCKET; c++) b[c] += bb[c];
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
                dir_block(snx + k0, sny + k0, snz + k0, nb, b, e0, e1, e2);
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
        for (int d = 0; d < 3; d++) out[d] = kd[d] * PGI__INV_PI * E[d][ii];
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

const pgi_estimator_vtbl pgi__est_directional =
    PGI__EST_TABLE("directional",
                   "cluster hierarchy, flux in 8 octant buckets per node from a fixed level down, "
                   "blurred irradiance (§4.7)",
                   dir_create, cl_build, dir_estimate, cl_destroy, .options = k_options, .defaults = k_defaults,
                   .bytes_per_photon = 80, .bytes_per_sample = 120);
