// The per-photon contribution and the BRDF at the view sample, in GLSL. Mirrors, operation for
// operation (`precise` where the C does not contract: the photongi build uses -ffp-contract=off):
//   src/estimators/gather.h  pgi__gather, pgi__gather_k, pgi__acc_add, pgi__acc_finish(_k),
//                            pgi__kernel_weight
//   src/scene/bsdf.h         pgi__phong_lobe, pgi__fresnel_dielectric, pgi__lobe_E, pgi__ggx_D,
//                            pgi__ggx_root, pgi__ggx_spec, pgi__lobe_eval_o
// A change there must be made here too (tests/test_gpu.c compares against the CPU's brute force).
// The including shader declares the lobe table `lobes[]` (struct Lobe, below) before including this
// file with GATHER_LOBES defined: lobes are read from it by index (a Lobe passed by value, with its
// 32-float table, was copied for every photon).
#ifndef PGIS_GATHER_GLSL
#define PGIS_GATHER_GLSL

#define PGIS_PI 3.14159265358979323846
#define PGIS_INV_PI 0.31830988618379067154
#define GGX_NMU 32

#define VS_VALID 1u
#define VS_LAMBERT 4u

#define LOBE_PHONG 1u
#define LOBE_GGX 2u

// One view sample as gpu_hashgrid.c uploads it (64 bytes): pgi__vs less the lobe, which is in
// the lobe table at `lobe` when the sample is not Lambertian.
struct ViewSample {
    float px, py, pz, nx, ny, nz;
    float wox, woy, woz, kdx, kdy, kdz;
    float one_m_eo; // GGX: 1 - E(n.wo)
    uint flags;     // PGI_VS_*
    uint lobe;      // index into the lobe table
    uint pad;
};

// pgi__lobe (src/scene/bsdf.h), 40 floats.
struct Lobe {
    uint model;
    float ksx, ksy, ksz, s, eta, a2, inv_1mEavg;
    float E[GGX_NMU];
};

#ifdef GATHER_LOBES_DECLARE
GATHER_LOBES_DECLARE
#endif

struct Acc {
    float fr, fg, fb; // sum of flux
    float sr, sg, sb; // sum of specular f * flux
    uint contributing;
};

float v3_len(vec3 v) {
    precise float d = v.x * v.x + v.y * v.y + v.z * v.z;
    return sqrt(d);
}
float v3_dot(vec3 a, vec3 b) {
    precise float d = a.x * b.x + a.y * b.y + a.z * b.z;
    return d;
}

// bsdf.h pgi__phong_lobe
void phong_lobe(vec3 n, vec3 wi, vec3 wo, float s, out float k, out float fr) {
    precise vec3 h = wi + wo;
    float hl = v3_len(h);
    if (!(hl > 0.0)) {
        k = 0.0;
        fr = 0.0;
        return;
    }
    h = h * (1.0 / hl);
    float hn = max(0.0, v3_dot(h, n));
    float hi = max(0.0, v3_dot(h, wi));
    precise float m = 1.0 - hi, m2 = m * m;
    fr = m2 * m2 * m;
    k = (8.0 + s) * float(1.0 / (8.0 * PGIS_PI)) * pow(hn, s);
}

// bsdf.h pgi__fresnel_dielectric
float fresnel_dielectric(float cos_i, float eta_i, float eta_t) {
    precise float sin_t = eta_i / eta_t * sqrt(max(0.0, 1.0 - cos_i * cos_i));
    if (sin_t >= 1.0) return 1.0;
    precise float cos_t = sqrt(max(0.0, 1.0 - sin_t * sin_t));
    precise float rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    precise float rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    precise float f = 0.5 * (rs * rs + rp * rp);
    return f;
}

// bsdf.h pgi__lobe_E
float lobe_E(uint li, float mu) {
    precise float x = sqrt(min(max(mu, 0.0), 1.0)) * float(GGX_NMU - 1);
    int i = int(x);
    if (i > GGX_NMU - 2) i = GGX_NMU - 2;
    precise float t = x - float(i);
    float e0 = lobes[li].E[i], e1 = lobes[li].E[i + 1];
    precise float e = e0 + (e1 - e0) * t;
    return e;
}

float ggx_D(float a2, float c) {
    precise float d = c * c * (a2 - 1.0) + 1.0;
    precise float D = a2 / (float(PGIS_PI) * d * d);
    return D;
}
float ggx_root(float a2, float c) {
    precise float q = c * c * (1.0 - a2) + a2;
    return sqrt(q);
}

// bsdf.h pgi__ggx_spec
float ggx_spec(uint li, vec3 n, vec3 wi, vec3 wo, float ci, float co) {
    const float eta = lobes[li].eta, a2 = lobes[li].a2;
    precise vec3 h = wi + wo;
    float hl = v3_len(h);
    if (!(hl > 0.0)) return 0.0;
    precise float hn = v3_dot(h, n) / hl, hi = min(1.0, max(0.0, v3_dot(h, wi) / hl));
    float F = fresnel_dielectric(hi, 1.0, eta);
    precise float v = 0.5 / (co * ggx_root(a2, ci) + ci * ggx_root(a2, co));
    precise float r = F * ggx_D(a2, hn) * v;
    return r;
}

// bsdf.h pgi__lobe_eval_o
vec3 lobe_eval(uint li, vec3 kd, vec3 n, vec3 wi, vec3 wo, float one_m_eo) {
    const uint model = lobes[li].model;
    const vec3 ks = vec3(lobes[li].ksx, lobes[li].ksy, lobes[li].ksz);
    if (model == LOBE_PHONG) {
        float k, fr;
        phong_lobe(n, wi, wo, lobes[li].s, k, fr);
        precise vec3 r = vec3(k * (ks.x + (1.0 - ks.x) * fr), k * (ks.y + (1.0 - ks.y) * fr),
                              k * (ks.z + (1.0 - ks.z) * fr));
        return r;
    }
    if (model != LOBE_GGX) return vec3(0.0);
    float ci = v3_dot(n, wi), co = v3_dot(n, wo);
    precise float base = (1.0 - lobe_E(li, ci)) * one_m_eo * lobes[li].inv_1mEavg - 1.0;
    precise vec3 r = kd * (base * float(PGIS_INV_PI));
    if (ci > 0.0 && co > 0.0) r = r + ks * ggx_spec(li, n, wi, wo, ci, co);
    return r;
}

// gather.h pgi__kernel_weight (constant 0, cone 1, Epanechnikov 2)
float kernel_weight(uint k, float d2, float r2) {
    precise float w = 1.0;
    if (k == 1u) w = 1.0 - sqrt(d2 / r2);
    if (k == 2u) w = 1.0 - d2 / r2;
    return w;
}

// gather.h pgi__gather / pgi__gather_k (+ pgi__acc_add): the same decision (d^2 < r^2 strictly,
// dot(n, w_p) > 0) and sums. `lambert`: no lobe; `l` is read only otherwise.
void gather(ViewSample v, bool lambert, float r2, uint kern, Photon q, inout Acc a) {
    precise float ex = q.px - v.px, ey = q.py - v.py, ez = q.pz - v.pz;
    precise float d2 = ex * ex + ey * ey + ez * ez;
    if (!(d2 < r2)) return;
    precise float c = v.nx * q.dx + v.ny * q.dy + v.nz * q.dz;
    if (!(c > 0.0)) return;
    a.contributing++;
    if (kern == 0u) {
        a.fr += q.fr;
        a.fg += q.fg;
        a.fb += q.fb;
        if (!lambert) {
            vec3 f = lobe_eval(v.lobe, vec3(v.kdx, v.kdy, v.kdz), vec3(v.nx, v.ny, v.nz), vec3(q.dx, q.dy, q.dz),
                               vec3(v.wox, v.woy, v.woz), v.one_m_eo);
            precise float tr = f.x * q.fr, tg = f.y * q.fg, tb = f.z * q.fb;
            a.sr += tr;
            a.sg += tg;
            a.sb += tb;
        }
    } else {
        float w = kernel_weight(kern, d2, r2);
        precise float wr = w * q.fr, wg = w * q.fg, wb = w * q.fb;
        a.fr += wr;
        a.fg += wg;
        a.fb += wb;
        if (!lambert) {
            vec3 f = lobe_eval(v.lobe, vec3(v.kdx, v.kdy, v.kdz), vec3(v.nx, v.ny, v.nz), vec3(q.dx, q.dy, q.dz),
                               vec3(v.wox, v.woy, v.woz), v.one_m_eo);
            precise float tr = f.x * wr, tg = f.y * wg, tb = f.z * wb;
            a.sr += tr;
            a.sg += tg;
            a.sb += tb;
        }
    }
}

// footprint.h pgi__acc_finish_w: (kd/pi * flux + spec) * w.
vec3 acc_finish_w(ViewSample v, Acc a, float w) {
    precise vec3 o = vec3((v.kdx * float(PGIS_INV_PI) * a.fr + a.sr) * w, (v.kdy * float(PGIS_INV_PI) * a.fg + a.sg) * w,
                          (v.kdz * float(PGIS_INV_PI) * a.fb + a.sb) * w);
    return o;
}

// gather.h pgi__acc_finish_k: (kd/pi * flux + spec) / (pi r^2), times the kernel's normalisation.
vec3 acc_finish(ViewSample v, Acc a, float r2, float m) {
    precise float w = 1.0 / (float(PGIS_PI) * r2);
    precise vec3 o = acc_finish_w(v, a, w);
    if (m != 1.0) o = o * m;
    return o;
}

#endif
