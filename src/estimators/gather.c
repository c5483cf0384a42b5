/* The batched glossy gather's lobe (gather.h, pgi__gather_flush): pgi__lobe_eval_o for a batch of
 * photons of one view sample. The GGX and Blinn-Phong lobes run 8 photons a step in an AVX2
 * build, picked at run time (pgi__cpu_avx2); CPUs without AVX2 call pgi__lobe_eval_o photon by
 * photon. The AVX2 lanes compute pgi__lobe_eval_o's expressions in its order with correctly
 * rounded operations only (add, sub, mul, div, sqrt, min/max, truncation; no FMA, the build has
 * -ffp-contract=off), so both builds give the same bits (tests/test_estimators.c checks it). */
#include "gather.h"

#if PGI__AVX2_TARGET && (defined(__x86_64__) || defined(__i386__))
#define GATHER_AVX2 1
#include <immintrin.h>
#endif

#ifdef GATHER_AVX2
/* f * flux of the GGX lobe of v (pgi__lobe_eval_o with one_m_eo) for the photons [0, n8) of b
 * (n8 a multiple of 8; lanes past b->n are zero and ignored), into pr, pg, pb. Per lane:
 *   base = (1 - E(ci)) (1 - E(co)) / (1 - E_avg) - 1,   r = kd (base / pi)
 *   r += ks spec(ci, co, h)   where ci > 0 and co > 0 and |h| > 0
 * with spec = F(h.wi) D(h.n) / (2 (co root(ci) + ci root(co))) as pgi__ggx_spec. */
__attribute__((target("avx2"))) static void ggx8(const pgi__vs *v, const pgi__gather_batch *b, uint32_t n8, float *pr,
                                                 float *pg, float *pb) {
    const pgi__lobe *l = &v->lobe;
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f);
    const __m256 nx = _mm256_set1_ps(v->nx), ny = _mm256_set1_ps(v->ny), nz = _mm256_set1_ps(v->nz);
    const __m256 wox = _mm256_set1_ps(v->wo.x), woy = _mm256_set1_ps(v->wo.y), woz = _mm256_set1_ps(v->wo.z);
    const float co_s = v->nx * v->wo.x + v->ny * v->wo.y + v->nz * v->wo.z;
    const int spec_on = co_s > 0.f; /* the same for every photon: pgi__lobe_eval_o's co > 0 */
    const __m256 co = _mm256_set1_ps(co_s);
    const __m256 a2 = _mm256_set1_ps(l->a2), one_m_a2 = _mm256_set1_ps(1.f - l->a2),
                 a2_m_1 = _mm256_set1_ps(l->a2 - 1.f);
    /* root(co) = sqrtf(co^2 (1 - a2) + a2), as pgi__ggx_root */
    const __m256 root_o = _mm256_set1_ps(pgi__ggx_root(l->a2, co_s));
    const __m256 eta = _mm256_set1_ps(l->eta), inv_eta = _mm256_set1_ps(1.f / l->eta);
    const __m256 one_m_eo = _mm256_set1_ps(v->one_m_eo), inv_1mEavg = _mm256_set1_ps(l->inv_1mEavg);
    const __m256 inv_pi = _mm256_set1_ps(PGI__INV_PI), pi = _mm256_set1_ps(PGI__PI), half = _mm256_set1_ps(0.5f);
    const __m256 kdx = _mm256_set1_ps(v->kd.x), kdy = _mm256_set1_ps(v->kd.y), kdz = _mm256_set1_ps(v->kd.z);
    const __m256 ksx = _mm256_set1_ps(l->ks.x), ksy = _mm256_set1_ps(l->ks.y), ksz = _mm256_set1_ps(l->ks.z);
    const __m256 nmu = _mm256_set1_ps((float)(PGI__GGX_NMU - 1));
    const __m256i imax = _mm256_set1_epi32(PGI__GGX_NMU - 2);
    for (uint32_t k = 0; k < n8; k += 8) {
        const __m256 wx = _mm256_loadu_ps(b->dx + k), wy = _mm256_loadu_ps(b->dy + k), wz = _mm256_loadu_ps(b->dz + k);
        const __m256 ci =
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, wx), _mm256_mul_ps(ny, wy)), _mm256_mul_ps(nz, wz));
        /* pgi__lobe_E(ci): x = sqrt(clamp(ci, 0, 1)) (NMU - 1), linear between nodes i and i + 1
         * (fmaxf(ci, 0) is max_ps(ci, 0): 0 for NaN as well) */
        const __m256 x = _mm256_mul_ps(_mm256_sqrt_ps(_mm256_min_ps(_mm256_max_ps(ci, zero), one)), nmu);
        const __m256i i = _mm256_min_epi32(_mm256_cvttps_epi32(x), imax);
        const __m256 t = _mm256_sub_ps(x, _mm256_cvtepi32_ps(i));
        const __m256 e0 = _mm256_i32gather_ps(l->E, i, 4), e1 = _mm256_i32gather_ps(l->E + 1, i, 4);
        const __m256 E = _mm256_add_ps(e0, _mm256_mul_ps(_mm256_sub_ps(e1, e0), t));
        const __m256 base =
            _mm256_sub_ps(_mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(one, E), one_m_eo), inv_1mEavg), one);
        const __m256 bp = _mm256_mul_ps(base, inv_pi);
        __m256 rx = _mm256_mul_ps(kdx, bp), ry = _mm256_mul_ps(kdy, bp), rz = _mm256_mul_ps(kdz, bp);
        if (spec_on) {
            /* pgi__ggx_spec */
            const __m256 hx = _mm256_add_ps(wx, wox), hy = _mm256_add_ps(wy, woy), hz = _mm256_add_ps(wz, woz);
            const __m256 hl = _mm256_sqrt_ps(
                _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(hx, hx), _mm256_mul_ps(hy, hy)), _mm256_mul_ps(hz, hz)));
            const __m256 hn = _mm256_div_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(hx, nx), _mm256_mul_ps(hy, ny)),
                                                          _mm256_mul_ps(hz, nz)),
                                            hl);
            const __m256 hi =
                _mm256_min_ps(_mm256_max_ps(_mm256_div_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(hx, wx),
                                                                                      _mm256_mul_ps(hy, wy)),
                                                                        _mm256_mul_ps(hz, wz)),
                                                          hl),
                                            zero),
                              one);
            /* pgi__fresnel_dielectric(hi, 1, eta) (1 * x is x) */
            const __m256 sin_t =
                _mm256_mul_ps(inv_eta, _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(one, _mm256_mul_ps(hi, hi)), zero)));
            const __m256 cos_t = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(one, _mm256_mul_ps(sin_t, sin_t)), zero));
            const __m256 ec = _mm256_mul_ps(eta, cos_t), eh = _mm256_mul_ps(eta, hi);
            const __m256 rs = _mm256_div_ps(_mm256_sub_ps(hi, ec), _mm256_add_ps(hi, ec));
            const __m256 rp = _mm256_div_ps(_mm256_sub_ps(eh, cos_t), _mm256_add_ps(eh, cos_t));
            __m256 F = _mm256_mul_ps(half, _mm256_add_ps(_mm256_mul_ps(rs, rs), _mm256_mul_ps(rp, rp)));
            F = _mm256_blendv_ps(F, one, _mm256_cmp_ps(sin_t, one, _CMP_GE_OQ)); /* total internal reflection */
            /* G2 / (4 ci co) = 1 / (2 (co root(ci) + ci root(co))) */
            const __m256 root_i = _mm256_sqrt_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(ci, ci), one_m_a2), a2));
            const __m256 vis = _mm256_div_ps(half, _mm256_add_ps(_mm256_mul_ps(co, root_i), _mm256_mul_ps(ci, root_o)));
            /* pgi__ggx_D(a2, hn) = a2 / (pi d d), d = hn^2 (a2 - 1) + 1 */
            const __m256 d = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(hn, hn), a2_m_1), one);
            const __m256 D = _mm256_div_ps(a2, _mm256_mul_ps(_mm256_mul_ps(pi, d), d));
            const __m256 spec = _mm256_mul_ps(_mm256_mul_ps(F, D), vis);
            /* where ci > 0 and |h| > 0; elsewhere r keeps base alone (spec 0 would add +0) */
            const __m256 on = _mm256_and_ps(_mm256_cmp_ps(ci, zero, _CMP_GT_OQ), _mm256_cmp_ps(hl, zero, _CMP_GT_OQ));
            rx = _mm256_blendv_ps(rx, _mm256_add_ps(rx, _mm256_mul_ps(ksx, spec)), on);
            ry = _mm256_blendv_ps(ry, _mm256_add_ps(ry, _mm256_mul_ps(ksy, spec)), on);
            rz = _mm256_blendv_ps(rz, _mm256_add_ps(rz, _mm256_mul_ps(ksz, spec)), on);
        }
        _mm256_storeu_ps(pr + k, _mm256_mul_ps(rx, _mm256_loadu_ps(b->fr + k)));
        _mm256_storeu_ps(pg + k, _mm256_mul_ps(ry, _mm256_loadu_ps(b->fg + k)));
        _mm256_storeu_ps(pb + k, _mm256_mul_ps(rz, _mm256_loadu_ps(b->fb + k)));
    }
}

/* f * flux of the Blinn-Phong lobe of v (pgi__phong_lobe and pgi__lobe_eval_o's PHONG case) for
 * the photons [0, n8) of b, into pr, pg, pb; powf is glibc's, lane by lane (a vector pow would
 * round differently), the rest 8 lanes a step:
 *   h = (wi + wo) / |wi + wo|,  k = (8 + s) / (8 pi) max(0, h.n)^s,  fr = (1 - max(0, h.wi))^5
 *   f = k (ks + (1 - ks) fr), 0 where |wi + wo| = 0 */
__attribute__((target("avx2"))) static void phong8(const pgi__vs *v, const pgi__gather_batch *b, uint32_t n8, float *pr,
                                                   float *pg, float *pb) {
    const pgi__lobe *l = &v->lobe;
    const float s = l->s;
    float hn_[PGI__GATHER_BATCH], fr_[PGI__GATHER_BATCH], on_[PGI__GATHER_BATCH];
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f);
    const __m256 nx = _mm256_set1_ps(v->nx), ny = _mm256_set1_ps(v->ny), nz = _mm256_set1_ps(v->nz);
    const __m256 wox = _mm256_set1_ps(v->wo.x), woy = _mm256_set1_ps(v->wo.y), woz = _mm256_set1_ps(v->wo.z);
    for (uint32_t k = 0; k < n8; k += 8) {
        const __m256 wx = _mm256_loadu_ps(b->dx + k), wy = _mm256_loadu_ps(b->dy + k), wz = _mm256_loadu_ps(b->dz + k);
        __m256 hx = _mm256_add_ps(wx, wox), hy = _mm256_add_ps(wy, woy), hz = _mm256_add_ps(wz, woz);
        const __m256 hl = _mm256_sqrt_ps(
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(hx, hx), _mm256_mul_ps(hy, hy)), _mm256_mul_ps(hz, hz)));
        const __m256 ih = _mm256_div_ps(one, hl);
        hx = _mm256_mul_ps(hx, ih), hy = _mm256_mul_ps(hy, ih), hz = _mm256_mul_ps(hz, ih);
        const __m256 hn = _mm256_max_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(hx, nx), _mm256_mul_ps(hy, ny)),
                                                      _mm256_mul_ps(hz, nz)),
                                        zero);
        const __m256 hi = _mm256_max_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(hx, wx), _mm256_mul_ps(hy, wy)),
                                                      _mm256_mul_ps(hz, wz)),
                                        zero);
        const __m256 m = _mm256_sub_ps(one, hi), m2 = _mm256_mul_ps(m, m);
        _mm256_storeu_ps(hn_ + k, hn);
        _mm256_storeu_ps(fr_ + k, _mm256_mul_ps(_mm256_mul_ps(m2, m2), m));
        _mm256_storeu_ps(on_ + k, _mm256_cmp_ps(hl, zero, _CMP_GT_OQ));
    }
    for (uint32_t k = 0; k < n8; k++) hn_[k] = powf(hn_[k], s);
    const __m256 kc = _mm256_set1_ps((8.f + s) * (1.f / (8.f * PGI__PI)));
    const __m256 ksx = _mm256_set1_ps(l->ks.x), ksy = _mm256_set1_ps(l->ks.y), ksz = _mm256_set1_ps(l->ks.z);
    const __m256 ksx1 = _mm256_set1_ps(1.f - l->ks.x), ksy1 = _mm256_set1_ps(1.f - l->ks.y),
                 ksz1 = _mm256_set1_ps(1.f - l->ks.z);
    for (uint32_t k = 0; k < n8; k += 8) {
        const __m256 on = _mm256_loadu_ps(on_ + k);
        const __m256 kk = _mm256_and_ps(_mm256_mul_ps(kc, _mm256_loadu_ps(hn_ + k)), on);
        const __m256 fr = _mm256_and_ps(_mm256_loadu_ps(fr_ + k), on);
        const __m256 fx = _mm256_mul_ps(kk, _mm256_add_ps(ksx, _mm256_mul_ps(ksx1, fr)));
        const __m256 fy = _mm256_mul_ps(kk, _mm256_add_ps(ksy, _mm256_mul_ps(ksy1, fr)));
        const __m256 fz = _mm256_mul_ps(kk, _mm256_add_ps(ksz, _mm256_mul_ps(ksz1, fr)));
        _mm256_storeu_ps(pr + k, _mm256_mul_ps(fx, _mm256_loadu_ps(b->fr + k)));
        _mm256_storeu_ps(pg + k, _mm256_mul_ps(fy, _mm256_loadu_ps(b->fg + k)));
        _mm256_storeu_ps(pb + k, _mm256_mul_ps(fz, _mm256_loadu_ps(b->fb + k)));
    }
}
#endif

void pgi__gather_flush(const pgi__vs *v, pgi__gather_batch *b, pgi__acc *a) {
    const uint32_t n = b->n;
    b->n = 0;
    if (!n) return;
#ifdef GATHER_AVX2
    if ((v->lobe.model == PGI__LOBE_GGX || v->lobe.model == PGI__LOBE_PHONG) && pgi__cpu_avx2()) {
        const uint32_t n8 = (n + 7) & ~7u;
        for (uint32_t k = n; k < n8; k++) b->dx[k] = b->dy[k] = b->dz[k] = b->fr[k] = b->fg[k] = b->fb[k] = 0.f;
        float pr[PGI__GATHER_BATCH], pg[PGI__GATHER_BATCH], pb[PGI__GATHER_BATCH];
        if (v->lobe.model == PGI__LOBE_GGX) ggx8(v, b, n8, pr, pg, pb);
        else phong8(v, b, n8, pr, pg, pb);
        /* in push order: the order of pgi__gather's sums */
        float fr = a->fr, fg = a->fg, fb = a->fb, sr = a->sr, sg = a->sg, sb = a->sb;
        for (uint32_t k = 0; k < n; k++) {
            fr += b->fr[k], fg += b->fg[k], fb += b->fb[k];
            sr += pr[k], sg += pg[k], sb += pb[k];
        }
        a->fr = fr, a->fg = fg, a->fb = fb, a->sr = sr, a->sg = sg, a->sb = sb;
        return;
    }
#endif
    const pgi__v3 nrm = v3(v->nx, v->ny, v->nz);
    for (uint32_t k = 0; k < n; k++) {
        pgi__v3 f = pgi__lobe_eval_o(&v->lobe, v->kd, nrm, v3(b->dx[k], b->dy[k], b->dz[k]), v->wo, v->one_m_eo);
        a->fr += b->fr[k];
        a->fg += b->fg[k];
        a->fb += b->fb[k];
        a->sr += f.x * b->fr[k];
        a->sg += f.y * b->fg[k];
        a->sb += f.z * b->fb[k];
    }
}
