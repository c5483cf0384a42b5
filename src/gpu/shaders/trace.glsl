// The photon tracer's scene view, random numbers, emission and BSDF sampling (trace.comp). The
// records are gpu_trace.c's (scalars only, so that std430 and the C structs agree); the functions
// mirror src/photon/trace.c start_path, src/scene/bsdf.c (pgi__scene_surface_untextured,
// pgi__bsdf_sample), src/scene/texture.c (bilinear, wrapping, sRGB table) and src/core/core.h
// (sampling, v3_basis / pgi_to_world). Include after bvh.glsl and gather.glsl (lobes at binding 7).
#ifndef PGI_TRACE_GLSL
#define PGI_TRACE_GLSL

#define MAT_LAMBERT 0u
#define MAT_PHONG 1u
#define MAT_MIRROR 2u
#define MAT_GLASS 3u
#define MAT_PLASTIC 4u

#define LIGHT_POINT 0u
#define LIGHT_SPOT 1u
#define LIGHT_SUN 2u
#define LIGHT_AREA 3u

#define TRACE_HAS_NRM 1u
#define TRACE_HAS_UV 2u

struct TVert { // position, texture u; shading normal (0 when the scene has none), texture v
    float px, py, pz, u, nx, ny, nz, v;
};
struct TTri {
    uint a, b, c, mat;
};
struct TMat {
    uint type;
    int tex_kd; // -1: none
    float kdx, kdy, kdz, ksx, ksy, ksz, ior, pad;
};
struct TLight {
    uint type, tri;
    float px, py, pz, dx, dy, dz, nx, ny, nz, cos_cutoff, pr, pg, pb;
    float cdf; // the light CDF by luminance of power (the CPU tracer's table)
};

layout(std430, set = 0, binding = 4) readonly restrict buffer Verts { TVert verts[]; };
layout(std430, set = 0, binding = 5) readonly restrict buffer Tris { TTri tris[]; };
layout(std430, set = 0, binding = 6) readonly restrict buffer Mats { TMat mats[]; };
layout(std430, set = 0, binding = 8) readonly restrict buffer Lights { TLight lights[]; };
// words 0..255: the sRGB table (float bits); then 4 words a texture: first texel, width, height, 0
layout(std430, set = 0, binding = 9) readonly restrict buffer TexInfo { uint texinfo[]; };
layout(std430, set = 0, binding = 10) readonly restrict buffer Texels { uint texels[]; }; // RGBA8
layout(std430, set = 0, binding = 11) writeonly restrict buffer Slots { Photon slots[]; };
layout(std430, set = 0, binding = 12) writeonly restrict buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 13) restrict buffer Counters { uint counters[]; }; // 0: rays

layout(push_constant) uniform Push {
    uint path0_lo, path0_hi; // global index of the launch's first path
    uint npaths;             // paths of this launch
    uint bounces;            // 1..64: the slots a path
    uint seed_lo, seed_hi;
    uint nlights;
    uint flags; // TRACE_HAS_NRM, TRACE_HAS_UV
    float eps;  // pgi__scene_epsilon
    float radius; // bounding-sphere radius (the sun's disk)
    float cx, cy, cz; // its centre
    uint pad0, pad1, pad2;
} pc;

// ---------------------------------------------------------------- random numbers
// Counter-based: a path's key hashes (seed, path index); draw c of the path is
// hash(hash(key + c * golden) ^ path_lo), hash = lowbias32 (Wellons). A path's numbers depend on
// its index only, whatever the launch and invocation order.
uint tr_mix(uint v) {
    v ^= v >> 16;
    v *= 0x7feb352du;
    v ^= v >> 15;
    v *= 0x846ca68bu;
    v ^= v >> 16;
    return v;
}
struct Rng {
    uint key, lo, ctr;
};
Rng rng_seed(uint lo, uint hi) {
    uint k = tr_mix(pc.seed_lo ^ 0x632be59bu);
    k = tr_mix(k ^ pc.seed_hi);
    k = tr_mix(k ^ hi);
    k = tr_mix(k ^ lo);
    return Rng(k, lo, 0u);
}
float rng_f(inout Rng r) {
    uint x = tr_mix(r.key + r.ctr * 0x9e3779b9u);
    x = tr_mix(x ^ (r.lo * 0x85ebca6bu));
    r.ctr++;
    return float(x >> 8) * (1.0 / 16777216.0);
}

// ---------------------------------------------------------------- core.h
float maxc(vec3 a) { return max(a.x, max(a.y, a.z)); }
vec3 v3_normalize(vec3 a) {
    float l = v3_len(a);
    return l > 0.0 ? a * (1.0 / l) : vec3(0.0, 0.0, 1.0);
}
void v3_basis(vec3 n, out vec3 t, out vec3 b) {
    float sgn = n.z >= 0.0 ? 1.0 : -1.0; // copysignf(1, n.z) (a -0 z counts as +: rare enough)
    precise float a = -1.0 / (sgn + n.z);
    precise float bb = n.x * n.y * a;
    t = vec3(1.0 + sgn * n.x * n.x * a, sgn * bb, -sgn * n.x);
    b = vec3(bb, sgn + n.y * n.y * a, -n.y);
}
vec3 to_world(vec3 l, vec3 n) {
    vec3 t, b;
    v3_basis(n, t, b);
    precise vec3 r = t * l.x + b * l.y + n * l.z;
    return r;
}
vec3 sample_cosine(float u1, float u2) {
    float r = sqrt(u1), phi = float(2.0 * PGI_PI) * u2;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u1)));
}
vec3 sample_sphere(float u1, float u2) {
    float z = 1.0 - 2.0 * u1, r = sqrt(max(0.0, 1.0 - z * z)), phi = float(2.0 * PGI_PI) * u2;
    return vec3(r * cos(phi), r * sin(phi), z);
}
vec3 sample_cone(float u1, float u2, float cos_max) {
    float z = 1.0 - u1 * (1.0 - cos_max), r = sqrt(max(0.0, 1.0 - z * z)), phi = float(2.0 * PGI_PI) * u2;
    return vec3(r * cos(phi), r * sin(phi), z);
}
vec3 vpos(uint i) { return vec3(verts[i].px, verts[i].py, verts[i].pz); }

// ---------------------------------------------------------------- emission (trace.c start_path)
bool start_path(inout Rng rng, out vec3 o, out vec3 d, out vec3 flux) {
    o = vec3(0.0);
    d = vec3(0.0, 0.0, 1.0);
    flux = vec3(0.0);
    const float ul = rng_f(rng);
    uint lo = 0u, hi = pc.nlights - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (ul < lights[mid].cdf) hi = mid;
        else lo = mid + 1u;
    }
    const float pl = lights[lo].cdf - (lo > 0u ? lights[lo - 1u].cdf : 0.0);
    if (!(pl > 0.0)) return false;
    const TLight L = lights[lo];
    flux = vec3(L.pr, L.pg, L.pb) * (1.0 / pl);
    const float u1 = rng_f(rng), u2 = rng_f(rng);
    float u3 = 0.0, u4 = 0.0;
    if (L.type == LIGHT_AREA) { // the CPU's historical order: the azimuth's number first
        u4 = rng_f(rng);
        u3 = rng_f(rng);
    }
    if (L.type == LIGHT_POINT) {
        o = vec3(L.px, L.py, L.pz);
        d = sample_sphere(u1, u2);
    } else if (L.type == LIGHT_SPOT) {
        o = vec3(L.px, L.py, L.pz);
        d = to_world(sample_cone(u1, u2, L.cos_cutoff), vec3(L.dx, L.dy, L.dz));
    } else if (L.type == LIGHT_SUN) {
        d = vec3(L.dx, L.dy, L.dz);
        float r = pc.radius * sqrt(u1), phi = float(2.0 * PGI_PI) * u2;
        vec3 disk = to_world(vec3(r * cos(phi), r * sin(phi), 0.0), d);
        precise vec3 c = vec3(pc.cx, pc.cy, pc.cz) - d * (1.01 * pc.radius) + disk;
        o = c;
    } else { // area: a uniform point of the triangle, the cosine lobe about its normal
        const vec3 n = vec3(L.nx, L.ny, L.nz);
        const TTri t = tris[L.tri];
        float su = sqrt(u1), b1 = 1.0 - su, b2 = u2 * su;
        precise vec3 q = vpos(t.a) * (1.0 - b1 - b2) + vpos(t.b) * b1 + vpos(t.c) * b2;
        o = q + n * pc.eps;
        d = to_world(sample_cosine(u3, u4), n);
    }
    return true;
}

// ---------------------------------------------------------------- surfaces (bsdf.c, texture.c)
struct Surface {
    vec3 ng, ns; // unit geometric normal (winding order), shading normal on its side
    float u, v;
    uint mat;
    vec3 kd;
};

Surface surface(uint prim, float bu, float bv) {
    const TTri t = tris[prim];
    Surface s;
    const vec3 a = vpos(t.a), b = vpos(t.b), c = vpos(t.c);
    precise float bw = 1.0 - bu - bv;
    s.ng = v3_normalize(cross(b - a, c - a));
    s.ns = s.ng;
    if ((pc.flags & TRACE_HAS_NRM) != 0u) {
        precise vec3 n = vec3(verts[t.a].nx, verts[t.a].ny, verts[t.a].nz) * bw +
                         vec3(verts[t.b].nx, verts[t.b].ny, verts[t.b].nz) * bu +
                         vec3(verts[t.c].nx, verts[t.c].ny, verts[t.c].nz) * bv;
        float l = v3_len(n);
        if (l > 0.0 && !isinf(l)) {
            n = n * (1.0 / l);
            s.ns = v3_dot(n, s.ng) < 0.0 ? -n : n;
        }
    }
    s.u = 0.0;
    s.v = 0.0;
    if ((pc.flags & TRACE_HAS_UV) != 0u) {
        precise float u = bw * verts[t.a].u + bu * verts[t.b].u + bv * verts[t.c].u;
        precise float v = bw * verts[t.a].v + bu * verts[t.b].v + bv * verts[t.c].v;
        s.u = u;
        s.v = v;
    }
    s.mat = t.mat;
    s.kd = vec3(mats[t.mat].kdx, mats[t.mat].kdy, mats[t.mat].kdz);
    return s;
}

vec3 texel_rgb(uint first, int w, int x, int y) {
    const uint p = texels[first + uint(y) * uint(w) + uint(x)];
    return vec3(uintBitsToFloat(texinfo[p & 0xFFu]), uintBitsToFloat(texinfo[(p >> 8) & 0xFFu]),
                uintBitsToFloat(texinfo[(p >> 16) & 0xFFu]));
}

// pgi__texture_lookup: bilinear, wrapping, v = 0 the bottom row, sRGB decoded by the table.
vec3 texture_lookup(int ti, float u, float v) {
    const uint h0 = 256u + 4u * uint(ti);
    const uint first = texinfo[h0];
    const int w = int(texinfo[h0 + 1u]), h = int(texinfo[h0 + 2u]);
    if (w <= 0 || h <= 0) return vec3(1.0);
    if (isnan(u) || isinf(u)) u = 0.0;
    if (isnan(v) || isinf(v)) v = 0.0;
    precise float fu = u - floor(u);
    precise float fv = v - floor(v);
    precise float x = fu * float(w) - 0.5;
    precise float y = (1.0 - fv) * float(h) - 0.5;
    const float x0f = floor(x), y0f = floor(y);
    precise float tx = x - x0f;
    precise float ty = y - y0f;
    const int x0 = bvh_wrap(int(x0f), w), x1 = bvh_wrap(int(x0f) + 1, w);
    const int y0 = bvh_wrap(int(y0f), h), y1 = bvh_wrap(int(y0f) + 1, h);
    const vec3 A = texel_rgb(first, w, x0, y0), B = texel_rgb(first, w, x1, y0);
    const vec3 C = texel_rgb(first, w, x0, y1), D = texel_rgb(first, w, x1, y1);
    precise vec3 top = A * (1.0 - tx) + B * tx;
    precise vec3 bot = C * (1.0 - tx) + D * tx;
    precise vec3 r = top * (1.0 - ty) + bot * ty;
    return r;
}

void surface_texture(inout Surface s) {
    const int ti = mats[s.mat].tex_kd;
    if (ti >= 0) s.kd = s.kd * texture_lookup(ti, s.u, s.v);
}

bool mat_specular(uint type) { return type == MAT_MIRROR || type == MAT_GLASS; }

vec3 reflect_about(vec3 w, vec3 n) {
    precise vec3 r = n * (2.0 * v3_dot(w, n)) - w;
    return r;
}

// ---------------------------------------------------------------- BSDF sampling (bsdf.c)
// The lobe of material m is lobes[m] (model 0 for Lambert, mirror and glass).
float glossy_pick(uint m, vec3 kd, vec3 ns, vec3 wi) {
    float wd = 0.2126 * kd.x + 0.7152 * kd.y + 0.0722 * kd.z;
    float wsp = 0.2126 * lobes[m].ksx + 0.7152 * lobes[m].ksy + 0.0722 * lobes[m].ksz;
    if (lobes[m].model == LOBE_GGX) {
        float ci = v3_dot(wi, ns);
        if (!(ci > 0.0)) return 0.0;
        float e = lobe_E(m, ci);
        wsp *= e;
        wd *= 1.0 - e;
    }
    return wd + wsp > 0.0 ? wsp / (wd + wsp) : 0.0;
}

float ggx_pdf(uint m, vec3 n, vec3 wi, vec3 wo) {
    float ci = v3_dot(n, wi);
    if (!(ci > 0.0)) return 0.0;
    vec3 h = wi + wo;
    float hl = v3_len(h);
    if (!(hl > 0.0)) return 0.0;
    float hn = v3_dot(h, n) / hl;
    if (!(hn > 0.0)) return 0.0;
    const float a2 = lobes[m].a2;
    return ggx_D(a2, hn) / (2.0 * (ci + ggx_root(a2, ci)));
}

float glossy_pdf(uint m, vec3 ns, vec3 wi, vec3 wo) {
    if (lobes[m].model == LOBE_GGX) return ggx_pdf(m, ns, wi, wo);
    const float s = lobes[m].s;
    vec3 h = v3_normalize(wi + wo);
    float hn = max(0.0, v3_dot(h, ns)), hw = abs(v3_dot(h, wo));
    return hw > 0.0 ? (s + 1.0) / float(2.0 * PGI_PI) * pow(hn, s) / (4.0 * hw) : 0.0;
}

// bsdf.h pgi__ggx_sample_vndf (Heitz 2018)
vec3 ggx_sample_vndf(vec3 V, float alpha, float u1, float u2) {
    vec3 Vh = v3_normalize(vec3(alpha * V.x, alpha * V.y, V.z));
    float lensq = Vh.x * Vh.x + Vh.y * Vh.y;
    vec3 T1 = lensq > 0.0 ? vec3(-Vh.y, Vh.x, 0.0) * (1.0 / sqrt(lensq)) : vec3(1.0, 0.0, 0.0);
    vec3 T2 = cross(Vh, T1);
    float r = sqrt(u1), phi = float(2.0 * PGI_PI) * u2;
    float t1 = r * cos(phi), t2 = r * sin(phi), sv = 0.5 * (1.0 + Vh.z);
    t2 = (1.0 - sv) * sqrt(max(0.0, 1.0 - t1 * t1)) + sv * t2;
    vec3 Nh = T1 * t1 + T2 * t2 + Vh * sqrt(max(0.0, 1.0 - t1 * t1 - t2 * t2));
    return v3_normalize(vec3(alpha * Nh.x, alpha * Nh.y, max(0.0, Nh.z)));
}

bool bsdf_sample(Surface sf, vec3 wi, float u1, float u2, float u3, out vec3 wo, out vec3 weight) {
    const uint m = sf.mat;
    const uint type = mats[m].type;
    const float side = v3_dot(wi, sf.ng) >= 0.0 ? 1.0 : -1.0;
    const vec3 ng = sf.ng * side, ns = sf.ns * side;
    const vec3 ks = vec3(mats[m].ksx, mats[m].ksy, mats[m].ksz);
    wo = vec3(0.0, 0.0, 1.0);
    weight = vec3(0.0);
    if (type == MAT_MIRROR) {
        wo = reflect_about(wi, ns);
        weight = ks;
        return v3_dot(wo, ng) > 0.0;
    }
    if (type == MAT_GLASS) {
        const float ior = mats[m].ior;
        float eta_i = side > 0.0 ? 1.0 : ior, eta_t = side > 0.0 ? ior : 1.0;
        float ci = min(1.0, max(0.0, v3_dot(wi, ns)));
        float F = fresnel_dielectric(ci, eta_i, eta_t);
        if (u1 < F) {
            wo = reflect_about(wi, ns);
            weight = vec3(1.0);
            return v3_dot(wo, ng) > 0.0;
        }
        float eta = eta_i / eta_t;
        float st2 = eta * eta * (1.0 - ci * ci);
        float ct = sqrt(max(0.0, 1.0 - st2));
        wo = v3_normalize(-wi * eta - ns * (ct - eta * ci));
        weight = ks;
        return v3_dot(wo, ng) < 0.0;
    }
    if (type == MAT_PHONG || type == MAT_PLASTIC) {
        const float ps = glossy_pick(m, sf.kd, ns, wi);
        if (u3 < ps) {
            if (lobes[m].model == LOBE_GGX) {
                vec3 t, b;
                v3_basis(ns, t, b);
                vec3 V = vec3(v3_dot(wi, t), v3_dot(wi, b), v3_dot(wi, ns));
                wo = reflect_about(wi, to_world(ggx_sample_vndf(V, lobes[m].s, u1, u2), ns));
            } else {
                const float s = lobes[m].s;
                float ct = pow(u1, 1.0 / (s + 1.0)), st = sqrt(max(0.0, 1.0 - ct * ct)),
                      phi = float(2.0 * PGI_PI) * u2;
                vec3 h = to_world(vec3(st * cos(phi), st * sin(phi), ct), ns);
                wo = reflect_about(wi, h);
            }
        } else {
            wo = to_world(sample_cosine(u1, u2), ns);
        }
        float cg = v3_dot(wo, ng), cs = v3_dot(wo, ns);
        if (!(cg > 0.0) || !(cs > 0.0)) return false;
        float pdf = ps * glossy_pdf(m, ns, wi, wo) + (1.0 - ps) * cs * float(PGI_INV_PI);
        if (!(pdf > 0.0)) return false;
        const float one_m_eo = lobes[m].model == LOBE_GGX ? 1.0 - lobe_E(m, v3_dot(ns, wo)) : 0.0;
        vec3 f = sf.kd * float(PGI_INV_PI) + lobe_eval(m, sf.kd, ns, wi, wo, one_m_eo);
        weight = f * (cs / pdf);
        return true;
    }
    wo = to_world(sample_cosine(u1, u2), ns);
    weight = sf.kd;
    return v3_dot(wo, ng) > 0.0;
}

#endif
